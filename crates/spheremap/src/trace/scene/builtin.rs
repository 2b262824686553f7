//! Scenes built in code: the demo's little world, and analytic test scenes whose sphere maps
//! are known in closed form.

use super::{Environment, Light, Material, Scene, SceneBuilder, TriangleInput};
use crate::images::Image;

crate::base::named::named_enum! {
    /// The built-in scenes (`--scene builtin:NAME`, Python's `Scene.builtin`).
    pub enum Builtin: "built-in scene" as "name" {
        /// The demo: a room with a window, a lamp and coloured walls ([`demo_scene`]).
        Demo = "demo",
        /// Inside a sphere whose octants glow in 8 colours ([`octant_sphere_scene`]).
        Octants = "octants",
        /// A chrome ball of radius 1 at the origin ([`mirror_ball_scene`]).
        MirrorBall = "mirror-ball",
    }
}

impl Builtin {
    /// The scene (`reflectance`: the mirror ball's, in [0, 1]).
    pub fn scene(self, reflectance: f32) -> crate::base::error::Result<Scene> {
        if !(0.0..=1.0).contains(&reflectance) {
            return Err(crate::base::error::Error::param(
                "reflectance",
                format!("expected a number in [0, 1], got {reflectance}"),
            ));
        }
        Ok(match self {
            Builtin::Demo => demo_scene(),
            Builtin::Octants => octant_sphere_scene(10.0, 16),
            Builtin::MirrorBall => mirror_ball_scene(reflectance),
        })
    }
}

/// The emission of the octant that direction `d` points into (used by
/// [`octant_sphere_scene`]): each channel is 1 on the positive side of its axis, ¼ on the
/// negative side, so the eight octants are eight different colours.
pub fn octant_colour(d: [f32; 3]) -> [f32; 3] {
    d.map(|v| if v > 0.0 { 1.0 } else { 0.25 })
}

/// The eight faces of the octahedron, each split into `n`² triangles and pushed onto the unit
/// sphere (scaled by `radius`, centred at `centre`).  Every triangle lies inside one octant:
/// grid points on a face's edge lie in a coordinate plane and stay there when normalized, so
/// the cones from the centre through each octant's triangles tile exactly that octant.
fn octant_patches(centre: [f32; 3], radius: f32, n: usize) -> Vec<([f32; 3], [[f32; 3]; 3])> {
    let mut out = Vec::new();
    for oct in 0..8 {
        let s = [0, 1, 2].map(|k| if oct >> k & 1 == 0 { 1.0f32 } else { -1.0 });
        let axes = [[s[0], 0.0, 0.0], [0.0, s[1], 0.0], [0.0, 0.0, s[2]]];
        let point = |i: usize, j: usize| {
            // Barycentric grid point (i, j, n − i − j) over the three axis vertices.
            let (a, b) = (i as f32 / n as f32, j as f32 / n as f32);
            let c = 1.0 - a - b;
            let p = [0, 1, 2].map(|k| a * axes[0][k] + b * axes[1][k] + c * axes[2][k]);
            let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            [0, 1, 2].map(|k| centre[k] + radius * p[k] / l)
        };
        // Outward winding: counter-clockwise seen from outside when the octant's sign product
        // is positive.
        let flip = s[0] * s[1] * s[2] < 0.0;
        let mut tri = |a, b, c| {
            let t = if flip { [a, c, b] } else { [a, b, c] };
            out.push((s, t));
        };
        for i in 0..n {
            for j in 0..n - i {
                tri(point(i, j), point(i + 1, j), point(i, j + 1));
                if i + j + 1 < n {
                    tri(point(i + 1, j), point(i + 1, j + 1), point(i, j + 1));
                }
            }
        }
    }
    out
}

/// A chrome ball: a mirror sphere of radius 1 at the origin reflecting `reflectance` of what
/// it mirrors (real chrome balls: about 0.6 to 0.8); set the environment to see it in a room.
/// With a camera (`spheremap preview`) it makes test photos for `from-photo`.
pub fn mirror_ball_scene(reflectance: f32) -> Scene {
    let mut b = SceneBuilder::new();
    let chrome = b.add_material(Material {
        name: "chrome".into(),
        diffuse: [0.0; 3],
        mirror: [reflectance; 3],
        ..Default::default()
    });
    b.add_sphere([0.0; 3], 1.0, chrome);
    b.build(Environment::Constant([0.0; 3]), "builtin:mirror-ball")
        .expect("a valid built-in scene")
}

/// Inside a sphere of radius `radius` centred at the origin whose octants glow in
/// [`octant_colour`]: from the centre, every ray returns exactly the colour of its octant.
/// `n`² triangles per octant.
pub fn octant_sphere_scene(radius: f32, n: usize) -> Scene {
    let mut b = SceneBuilder::new();
    let mut ids = std::collections::HashMap::new();
    for (s, t) in octant_patches([0.0; 3], radius, n.max(1)) {
        let key = s.map(|v| v > 0.0);
        let m = *ids.entry(key).or_insert_with(|| {
            b.add_material(Material {
                name: format!("octant{key:?}"),
                emission: octant_colour(s),
                diffuse: [0.0; 3],
                ..Material::default()
            })
        });
        b.add_triangle(TriangleInput {
            positions: t,
            material: m,
            ..Default::default()
        });
    }
    b.build(Environment::Constant([0.0; 3]), "octant sphere")
        .expect("the built-in scene is valid")
}

/// An emissive floor y = `floor_y` (a square of half-width `extent`), under a constant sky.
/// From a point above it a ray sees the floor exactly when it points down (and lands within
/// the square).
pub fn floor_scene(floor_y: f32, extent: f32, floor: [f32; 3], sky: [f32; 3]) -> Scene {
    let mut b = SceneBuilder::new();
    let m = b.add_material(Material {
        name: "floor".into(),
        emission: floor,
        diffuse: [0.0; 3],
        ..Material::default()
    });
    add_quad(
        &mut b,
        [0.0, floor_y, 0.0],
        [extent, 0.0, 0.0],
        [0.0, 0.0, extent],
        m,
    );
    b.build(Environment::Constant(sky), "floor scene")
        .expect("the built-in scene is valid")
}

/// A parallelogram centre ± a ± b (two triangles, normal a × b), uv over [0, k]².
fn add_quad(b: &mut SceneBuilder, c: [f32; 3], u: [f32; 3], v: [f32; 3], m: u32) {
    add_quad_uv(b, c, u, v, m, 1.0)
}

fn add_quad_uv(b: &mut SceneBuilder, c: [f32; 3], u: [f32; 3], v: [f32; 3], m: u32, k: f32) {
    let p = |su: f32, sv: f32| [0, 1, 2].map(|i| c[i] + su * u[i] + sv * v[i]);
    let corners = [p(-1.0, -1.0), p(1.0, -1.0), p(1.0, 1.0), p(-1.0, 1.0)];
    let uvs = [[0.0, 0.0], [k, 0.0], [k, k], [0.0, k]];
    for t in [[0, 2, 1], [0, 3, 2]] {
        b.add_triangle(TriangleInput {
            positions: t.map(|i| corners[i]),
            uvs: Some(t.map(|i| uvs[i])),
            normals: None,
            material: m,
        });
    }
}

/// An axis-aligned box (12 triangles).
fn add_box(b: &mut SceneBuilder, c: [f32; 3], h: [f32; 3], m: u32) {
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
            let mut centre = c;
            centre[axis] += side * h[axis];
            let mut u = [0.0; 3];
            let mut v = [0.0; 3];
            u[a1] = h[a1];
            v[a2] = h[a2] * side;
            add_quad(b, centre, u, v, m);
        }
    }
}

/// A grey checkerboard texture (`squares` × `squares`, `px` texels each), linear values.
fn checker(squares: usize, px: usize, a: f32, b: f32) -> Image {
    let n = squares * px;
    let mut img = Image::new(n, n, 3);
    for y in 0..n {
        for x in 0..n {
            let v = if (x / px + y / px) % 2 == 0 { a } else { b };
            img.pixel_mut(x, y).fill(v);
        }
    }
    img
}

/// The demo's world, seen from (0, 1, 0): a checkered floor, three glowing panels (red behind
/// the eye, green to the left, blue to the right), a mirror ball and a white box behind, lit by a low sun and a
/// warm point light under a pale blue sky.  Every material and light kind the tracer knows.
pub fn demo_scene() -> Scene {
    let mut b = SceneBuilder::new();
    let tex = b.add_texture(checker(8, 16, 0.8, 0.1));
    let floor = b.add_material(Material {
        name: "floor".into(),
        diffuse: [1.0; 3],
        diffuse_texture: Some(tex),
        ..Material::default()
    });
    let glow = |b: &mut SceneBuilder, name: &str, c: [f32; 3]| {
        b.add_material(Material {
            name: name.into(),
            emission: c,
            diffuse: [0.0; 3],
            ..Material::default()
        })
    };
    let red = glow(&mut b, "red panel", [4.0, 0.3, 0.2]);
    let green = glow(&mut b, "green panel", [0.3, 3.0, 0.4]);
    let blue = glow(&mut b, "blue panel", [0.3, 0.6, 4.0]);
    let chrome = b.add_material(Material {
        name: "chrome".into(),
        diffuse: [0.0; 3],
        mirror: [0.9; 3],
        ..Material::default()
    });
    let white = b.add_material(Material {
        name: "white".into(),
        diffuse: [0.75; 3],
        ..Material::default()
    });
    add_quad_uv(
        &mut b,
        [0.0, 0.0, 0.0],
        [12.0, 0.0, 0.0],
        [0.0, 0.0, -12.0],
        floor,
        6.0,
    );
    add_quad(
        &mut b,
        [0.0, 1.5, 6.0],
        [2.5, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        red,
    );
    add_quad(
        &mut b,
        [-6.0, 1.5, 0.0],
        [0.0, 0.0, -2.0],
        [0.0, 1.0, 0.0],
        green,
    );
    add_quad(
        &mut b,
        [6.0, 1.5, 0.0],
        [0.0, 0.0, 2.0],
        [0.0, 1.0, 0.0],
        blue,
    );
    add_box(&mut b, [2.0, 0.6, 2.5], [0.6, 0.6, 0.6], white);
    for (_, t) in octant_patches([-1.6, 0.8, 2.2], 0.8, 12) {
        let n = t.map(|p| {
            let d = [p[0] + 1.6, p[1] - 0.8, p[2] - 2.2];
            d.map(|v| v / 0.8)
        });
        b.add_triangle(TriangleInput {
            positions: t,
            normals: Some(n),
            uvs: None,
            material: chrome,
        });
    }
    b.add_light(Light::Directional {
        direction: [0.4, -0.8, 0.45],
        irradiance: [2.2, 2.0, 1.8],
    });
    b.add_light(Light::Point {
        position: [1.0, 2.5, 1.5],
        intensity: [3.0, 2.4, 1.6],
    });
    b.build(Environment::Constant([0.45, 0.6, 0.85]), "demo scene")
        .expect("the built-in scene is valid")
}
