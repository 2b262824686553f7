//! Cube maps in files: the layouts people store the six faces in, the face stack spheremap
//! holds them in, and the file-name patterns that name six face files.  The faces themselves
//! (order, orientation, presets) are [`crate::mappings::cube`].
//!
//! ## The internal representation: a face stack
//!
//! spheremap holds a cube map as one image F wide and 6F tall: the six GL face images in GL
//! order, top to bottom — byte for byte the numpy array `(6, F, F, C)` the Python API takes.
//! The canvas coordinates of the stack are (u, v) = (col/F, row/6F), v down.
//!
//! ## Layouts (files)
//!
//! ```text
//!  stack / vstrip (F × 6F)      hstrip (6F × F)            hcross = dice (4F × 3F)
//!  +X                           +X −X +Y −Y +Z −Z               +Y
//!  −X                           (GL face images,           −X  −Z  +X  +Z
//!  +Y                            as stored in KTX/DDS)          −Y
//!  −Y
//!  +Z                           horizon (6F × F)           vcross (3F × 4F)
//!  −Z                           −Z +X +Z −X +Y −Y               +Y
//!  (GL face images)                                        −X  −Z  +X
//!                                                               −Y
//!                                                               +Z (rotated 180°)
//! ```
//!
//! `hstrip`, `vstrip` and six files hold the GL face images unchanged.  The crosses and
//! `horizon` hold **views from the inside** (not mirrored: each face as a camera at the centre
//! sees it, side faces with +Y up, +Y with +Z at its top, −Y with −Z at its top), arranged so the
//! cross is one continuous picture around the forward face −Z.  These are py360convert's `dice`
//! and `horizon` layouts (faces F R B L U D), with py360convert's forward +Z being our −Z: its
//! world is ours with z negated, checked numerically in `tests/test_convert.py`.

use crate::base::error::{Error, Result};
use crate::images::Image;
use crate::mappings::cube::FACE_NAMES;

crate::base::named::named_enum! {
    /// How the six faces sit in a file.  See the module diagram.
    pub enum Layout: "cube layout" as "layout" {
        /// F × 6F, GL faces top to bottom (the internal stack).
        VStrip = "vstrip" | "stack",
        /// 6F × F, GL faces left to right.
        HStrip = "hstrip",
        /// 4F × 3F cross of inside views around −Z (= py360convert `dice`).
        HCross = "hcross" | "cross" | "dice",
        /// 3F × 4F cross of inside views, +Z at the bottom rotated 180°.
        VCross = "vcross",
        /// 6F × F, inside views −Z +X +Z −X +Y −Y (py360convert `horizon`).
        Horizon = "horizon",
    }
    hint = ", or six files (named, or a {face} pattern)"
}

/// A face image's orientation in a layout slot, relative to the GL face image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Orient {
    Same,
    FlipH,
    FlipV,
}

impl Layout {
    /// The layout an image of `w`×`h` must be, judged by shape alone, when it is unambiguous:
    /// 1:6 vstrip, 4:3 hcross, 3:4 vcross.  6:1 is hstrip or horizon: the caller must say.
    pub fn from_shape(w: usize, h: usize) -> Result<Layout> {
        if w > 0 && h == 6 * w {
            Ok(Layout::VStrip)
        } else if h > 0 && 3 * w == 4 * h && w % 4 == 0 {
            Ok(Layout::HCross)
        } else if w > 0 && 4 * w == 3 * h && w % 3 == 0 {
            Ok(Layout::VCross)
        } else if h > 0 && w == 6 * h {
            Err(Error::param(
                "layout",
                format!(
                    "a {w}x{h} image could be 'hstrip' (GL faces) or 'horizon' (py360convert); \
                     say which"
                ),
            ))
        } else {
            Err(Error::param(
                "layout",
                format!(
                    "a {w}x{h} image is no cube layout (vstrip 1:6, hstrip/horizon 6:1, \
                     hcross 4:3, vcross 3:4 with square faces)"
                ),
            ))
        }
    }

    /// (width, height) of the layout for faces of F.
    pub fn dims(self, f: usize) -> (usize, usize) {
        match self {
            Layout::VStrip => (f, 6 * f),
            Layout::HStrip | Layout::Horizon => (6 * f, f),
            Layout::HCross => (4 * f, 3 * f),
            Layout::VCross => (3 * f, 4 * f),
        }
    }

    /// Face size for a layout image of `w`×`h`, checking the shape.
    pub fn face_size(self, w: usize, h: usize) -> Result<usize> {
        let f = match self {
            Layout::VStrip => w,
            Layout::HStrip | Layout::Horizon => h,
            Layout::HCross => w / 4,
            Layout::VCross => w / 3,
        };
        if f == 0 || self.dims(f) != (w, h) {
            let (ew, eh) = self.dims(f.max(1));
            return Err(Error::param(
                "layout",
                format!(
                    "a {w}x{h} image is not a '{}' cube layout (that is {}:{} with square \
                     faces, e.g. {ew}x{eh})",
                    self.name(),
                    ew / f.max(1),
                    eh / f.max(1)
                ),
            ));
        }
        Ok(f)
    }

    /// For each GL face: its slot (column, row in face units) and orientation.
    fn slots(self) -> [(usize, usize, Orient); 6] {
        use Orient::*;
        match self {
            Layout::VStrip => [
                (0, 0, Same),
                (0, 1, Same),
                (0, 2, Same),
                (0, 3, Same),
                (0, 4, Same),
                (0, 5, Same),
            ],
            Layout::HStrip => [
                (0, 0, Same),
                (1, 0, Same),
                (2, 0, Same),
                (3, 0, Same),
                (4, 0, Same),
                (5, 0, Same),
            ],
            // Inside views: side faces mirrored left-right, ±Y top-bottom (module docs).
            Layout::HCross => [
                (2, 1, FlipH),
                (0, 1, FlipH),
                (1, 0, FlipV),
                (1, 2, FlipV),
                (3, 1, FlipH),
                (1, 1, FlipH),
            ],
            // +Z below −Y: the inside view turned 180° = FlipH ∘ rot180 = FlipV.
            Layout::VCross => [
                (2, 1, FlipH),
                (0, 1, FlipH),
                (1, 0, FlipV),
                (1, 2, FlipV),
                (1, 3, FlipV),
                (1, 1, FlipH),
            ],
            // F R B L U D = −Z +X +Z −X +Y −Y.
            Layout::Horizon => [
                (1, 0, FlipH),
                (3, 0, FlipH),
                (4, 0, FlipV),
                (5, 0, FlipV),
                (2, 0, FlipH),
                (0, 0, FlipH),
            ],
        }
    }

    /// Layout image → face stack (F × 6F).  Unused cells of a cross are ignored.
    pub fn to_stack(self, img: &Image) -> Result<Image> {
        let f = self.face_size(img.width, img.height)?;
        let c = img.channels;
        let mut out = Image::new(f, 6 * f, c);
        self.for_each_texel(f, |stack_i, (x, y)| {
            let (src, dst) = ((y * img.width + x) * c, stack_i * c);
            out.data[dst..dst + c].copy_from_slice(&img.data[src..src + c]);
        });
        Ok(out)
    }

    /// Calls `f(i, (x, y))` for every texel of the face stack: `i` its index in the stack,
    /// (x, y) its place in this layout's image.
    fn for_each_texel(self, f: usize, mut each: impl FnMut(usize, (usize, usize))) {
        for (face, &(sx, sy, o)) in self.slots().iter().enumerate() {
            for row in 0..f {
                for col in 0..f {
                    let (scol, srow) = o.apply(col, row, f);
                    each((face * f + row) * f + col, (sx * f + scol, sy * f + srow));
                }
            }
        }
    }

    /// Face stack → layout image; unused cells of a cross are 0 (alpha 0 when there is alpha).
    pub fn from_stack(self, stack: &Image) -> Result<Image> {
        let f = stack.width;
        if stack.height != 6 * f {
            return Err(Error::param(
                "image",
                format!(
                    "a cube face stack is F x 6F, got {}x{}",
                    stack.width, stack.height
                ),
            ));
        }
        let c = stack.channels;
        let (w, h) = self.dims(f);
        let mut out = Image::new(w, h, c);
        self.for_each_texel(f, |stack_i, (x, y)| {
            let (src, dst) = (stack_i * c, (y * w + x) * c);
            out.data[dst..dst + c].copy_from_slice(&stack.data[src..src + c]);
        });
        Ok(out)
    }
}

impl Orient {
    /// Where GL face texel (col, row) sits inside the slot.  Each is its own inverse.
    #[inline]
    fn apply(self, col: usize, row: usize, f: usize) -> (usize, usize) {
        match self {
            Orient::Same => (col, row),
            Orient::FlipH => (f - 1 - col, row),
            Orient::FlipV => (col, f - 1 - row),
        }
    }
}

/// The naming schemes of six face files, as pattern tokens, each with its six names in GL order
/// (+X, −X, +Y, −Y, +Z, −Z):
///
/// * `{face}`: px nx py ny pz nz (three.js, Babylon.js);
/// * `{posx}`: posx negx posy negy posz negz (Humus's cube-map packs);
/// * `{side}`: right left top bottom front back, in the order LearnOpenGL loads them onto
///   `GL_TEXTURE_CUBE_MAP_POSITIVE_X + i` — so front is +Z and back −Z (skybox packs that call
///   −Z the front need `{face}` or six named files);
/// * `{index}`: 0 1 2 3 4 5 (the face's number, as in a KTX file or D3D's face order).
pub const FACE_TOKENS: [(&str, [&str; 6]); 4] = [
    ("{face}", FACE_NAMES),
    ("{posx}", ["posx", "negx", "posy", "negy", "posz", "negz"]),
    (
        "{side}",
        ["right", "left", "top", "bottom", "front", "back"],
    ),
    ("{index}", ["0", "1", "2", "3", "4", "5"]),
];

/// An environment map handed over as an array (Python's): its `shape` and row-major `data`,
/// as the canvas the core reads.  A map of another mapping is (H, W) or (H, W, C); a cube map
/// (`cube`) is one image in `layout` (a layout's name, read as `{name} layout`), six faces
/// (6, F, F) or (6, F, F, C) in GL order, their (6F, F, C) stack, or one image in the layout its
/// shape implies, and becomes the stack.  C is 1 to 4.  Errors name `name`.
pub fn env_array(
    shape: &[usize],
    data: Vec<f32>,
    cube: bool,
    layout: Option<&str>,
    name: &str,
) -> Result<Image> {
    if data.len() != shape.iter().product::<usize>() {
        return Err(Error::param(
            name,
            format!("{} values for shape {shape:?}", data.len()),
        ));
    }
    let channels_ok = |c: usize| (1..=4).contains(&c);
    let image = |h: usize, w: usize, c: usize, data: Vec<f32>| Image {
        width: w,
        height: h,
        channels: c,
        data,
    };
    let plain = |data: Vec<f32>| match *shape {
        [h, w] => Ok(image(h, w, 1, data)),
        [h, w, c] if channels_ok(c) => Ok(image(h, w, c, data)),
        _ => Err(Error::param(
            name,
            format!("expected (H, W) or (H, W, C) with C in 1..4, got shape {shape:?}"),
        )),
    };
    if !cube {
        return plain(data);
    }
    if let Some(l) = layout {
        let l = Layout::parse(l).map_err(|e| e.named(&format!("{name} layout")))?;
        if !matches!(shape.len(), 2 | 3) {
            return Err(Error::param(
                name,
                format!("a cube map in a layout is (H, W) or (H, W, C), got shape {shape:?}"),
            ));
        }
        return l
            .to_stack(&plain(data)?)
            .map_err(|e| e.renamed("layout", name));
    }
    match *shape {
        [6, f, g, c] if f == g && channels_ok(c) => Ok(image(6 * f, f, c, data)),
        [_, _, _, _] => Err(Error::param(
            name,
            format!("a cube map is (6, F, F, C), got shape {shape:?}"),
        )),
        [6, f, g] if f == g => Ok(image(6 * f, f, 1, data)),
        [h, w, c] if h == 6 * w && channels_ok(c) => Ok(image(h, w, c, data)),
        [h, w] | [h, w, _] => {
            let img = plain(data)?;
            match Layout::from_shape(w, h) {
                Ok(l) => l.to_stack(&img),
                Err(Error::InvalidParameter { reason, .. }) if reason.contains("could be") => {
                    Err(Error::param(name, reason))
                }
                Err(e) => Err(Error::param(
                    name,
                    format!(
                        "a cube map is (6, F, F, C) faces or one image in a layout, and {}",
                        match e {
                            Error::InvalidParameter { reason, .. } => reason,
                            e => e.to_string(),
                        }
                    ),
                )),
            }
        }
        _ => plain(data),
    }
}

/// Six face files: expands a pattern holding a face token ([`FACE_TOKENS`]: `{face}`,
/// `{posx}`, `{side}` or `{index}`) into the six paths, GL order.  Every token in the pattern
/// is replaced, each by its own scheme's name for the face.
pub fn face_paths(pattern: &str) -> Option<[String; 6]> {
    if !FACE_TOKENS.iter().any(|(t, _)| pattern.contains(t)) {
        return None;
    }
    Some(std::array::from_fn(|i| {
        FACE_TOKENS
            .iter()
            .fold(pattern.to_string(), |p, (t, names)| p.replace(t, names[i]))
    }))
}

/// Six face images (GL order, equal square sizes and channel counts) → stack.
pub fn stack_faces(faces: &[Image], names: &[String]) -> Result<Image> {
    let f = faces[0].width;
    let c = faces[0].channels;
    for (img, name) in faces.iter().zip(names) {
        if img.width != img.height || img.width != f || img.channels != c {
            return Err(Error::data(
                name,
                format!(
                    "cube face is {}x{} with {} channels; expected {f}x{f} with {c} like {}",
                    img.width, img.height, img.channels, names[0]
                ),
            ));
        }
    }
    let mut out = Image::new(f, 6 * f, c);
    for (i, img) in faces.iter().enumerate() {
        out.data[i * f * f * c..(i + 1) * f * f * c].copy_from_slice(&img.data);
    }
    Ok(out)
}

/// Stack → six face images (GL order).
pub fn split_stack(stack: &Image) -> Vec<Image> {
    let f = stack.width;
    let c = stack.channels;
    (0..6)
        .map(|i| Image {
            width: f,
            height: f,
            channels: c,
            data: stack.data[i * f * f * c..(i + 1) * f * f * c].to_vec(),
        })
        .collect()
}

#[cfg(test)]
mod tests {

    #[test]
    fn an_environment_array_becomes_the_canvas_by_its_shape() {
        let f = 4;
        let data = |n: usize| (0..n).map(|v| v as f32).collect::<Vec<f32>>();
        // Faces (6, F, F, C) are their stack as they lie; so are six one-channel faces.
        let st = env_array(&[6, f, f, 3], data(6 * f * f * 3), true, None, "env").unwrap();
        assert_eq!((st.width, st.height, st.channels), (f, 6 * f, 3));
        assert_eq!(st.data, data(6 * f * f * 3));
        let st = env_array(&[6, f, f], data(6 * f * f), true, None, "env").unwrap();
        assert_eq!((st.width, st.height, st.channels), (f, 6 * f, 1));
        // A stack stays one; a cross is read by its layout, as Layout::to_stack reads it.
        let st = env_array(&[6 * f, f, 2], data(12 * f * f), true, None, "env").unwrap();
        assert_eq!(st.data, data(12 * f * f));
        let cross = Layout::HCross.from_stack(&st).unwrap();
        let shape = [cross.height, cross.width, 2];
        let back = env_array(&shape, cross.data.clone(), true, None, "env").unwrap();
        assert_eq!(back.data, st.data);
        let named = env_array(&shape, cross.data, true, Some("hcross"), "env").unwrap();
        assert_eq!(named.data, st.data);
        // Other mappings: (H, W) or (H, W, C).
        let ll = env_array(&[2, 4], data(8), false, None, "env").unwrap();
        assert_eq!((ll.width, ll.height, ll.channels), (4, 2, 1));
        for (shape, cube, layout, start) in [
            (
                vec![2, 4, 7],
                false,
                None,
                "env: expected (H, W) or (H, W, C)",
            ),
            (
                vec![5, 4, 4, 3],
                true,
                None,
                "env: a cube map is (6, F, F, C)",
            ),
            (
                vec![16, 96, 3],
                true,
                None,
                "env: a 96x16 image could be 'hstrip'",
            ),
            (
                vec![4, 8, 3],
                true,
                None,
                "env: a cube map is (6, F, F, C) faces or one image",
            ),
            (vec![16, 96, 3], true, Some("dice9"), "env layout: "),
            (
                vec![6, 4, 4, 3],
                true,
                Some("hcross"),
                "env: a cube map in a layout",
            ),
        ] {
            let n = shape.iter().product();
            let e = env_array(&shape, data(n), cube, layout, "env")
                .unwrap_err()
                .to_string();
            assert!(e.starts_with(start), "{shape:?}: {e}");
        }
    }

    use super::*;
    use crate::mappings::cube::face_st_to_dir;

    #[test]
    fn layouts_round_trip() {
        let f = 3;
        let mut stack = Image::new(f, 6 * f, 1);
        for (i, v) in stack.data.iter_mut().enumerate() {
            *v = i as f32;
        }
        for l in [
            Layout::VStrip,
            Layout::HStrip,
            Layout::HCross,
            Layout::VCross,
            Layout::Horizon,
        ] {
            let img = l.from_stack(&stack).unwrap();
            assert_eq!((img.width, img.height), l.dims(f));
            assert_eq!(l.to_stack(&img).unwrap().data, stack.data, "{l:?}");
        }
    }

    /// The cross is one continuous picture: across every shared edge of the horizontal cross,
    /// neighbouring texels look in nearly the same direction.
    #[test]
    fn cross_is_continuous() {
        let f = 16;
        let mut stack = Image::new(f, 6 * f, 3);
        for face in 0..6 {
            for row in 0..f {
                for col in 0..f {
                    let d = face_st_to_dir(
                        face,
                        (col as f64 + 0.5) / f as f64,
                        (row as f64 + 0.5) / f as f64,
                    );
                    let i = ((face * f + row) * f + col) * 3;
                    for k in 0..3 {
                        stack.data[i + k] = d[k] as f32;
                    }
                }
            }
        }
        for layout in [Layout::HCross, Layout::VCross] {
            let img = layout.from_stack(&stack).unwrap();
            let at = |x: usize, y: usize| {
                let i = (y * img.width + x) * 3;
                [img.data[i], img.data[i + 1], img.data[i + 2]]
            };
            let filled = |p: [f32; 3]| p.iter().any(|v| *v != 0.0);
            let mut edges = 0;
            for y in 0..img.height {
                for x in 0..img.width {
                    for (dx, dy) in [(1, 0), (0, 1)] {
                        let (x2, y2) = (x + dx, y + dy);
                        if x2 >= img.width || y2 >= img.height {
                            continue;
                        }
                        let (a, b) = (at(x, y), at(x2, y2));
                        if !(filled(a) && filled(b)) {
                            continue;
                        }
                        let dot: f32 = (0..3).map(|k| a[k] * b[k]).sum();
                        // One texel is at most 2/F ≈ 0.125 rad wide.
                        assert!(dot > 0.99, "{layout:?} ({x},{y})-({x2},{y2}): {dot}");
                        edges += 1;
                    }
                }
            }
            assert!(edges > 0);
        }
    }
}
