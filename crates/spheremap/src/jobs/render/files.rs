//! `spheremap render` on files: the mesh and the environment read, the image (or a turntable's
//! frames) drawn by a [`RenderRequest`], made display-ready for an LDR file (tone-mapped, or
//! the error mode's heat map) and written, with its report.

use super::{
    heat_colour, render, EnvInput, GlCamera, Mode, PixelError, RenderOptions, RenderRequest,
    RenderStats, RenderSummary, TurntableReport,
};
use crate::base::error::{Error, Result};
use crate::images::codec::{check_nonfinite, write_gif, write_image, Losses, NonFinite};
use crate::images::codec::{ReadOptions, WriteOptions};
use crate::images::envmap::{read_env, read_note};
use crate::images::format::Format;
use crate::images::tonemap::{tone_map, ToneMap};
use crate::images::Image;
use crate::jobs::source::Source;
use crate::mappings::mapping::Mapping;
use crate::mesh::Mesh;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// What `spheremap render` reads and how it writes.  `Default` gives every documented default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RenderFiles {
    /// How the environment is read (default its note, else a sphere map; its view is not
    /// applied: a render looks maps up in the world's frame).
    #[serde(flatten)]
    pub source: Source,
    pub nonfinite: NonFinite,
    /// Read LDR textures as linear values (no sRGB decoding).
    pub linear: bool,
    /// Exposure in stops and the operator of PNG/JPEG outputs (linear files stay untouched).
    pub exposure: f32,
    pub tonemap: ToneMap,
    /// The error mode's hottest colour in PNG/JPEG outputs, in degrees.
    pub error_max: f32,
    /// A turntable of this many frames (the eye orbiting the target about its up): the output
    /// is an animated GIF or a pattern with `{frame}`.
    pub turntable: Option<u32>,
    /// Milliseconds per frame of the animated GIF.
    pub frame_ms: u32,
}

impl Default for RenderFiles {
    fn default() -> Self {
        RenderFiles {
            source: Source::default(),
            nonfinite: NonFinite::default(),
            linear: false,
            exposure: 0.0,
            tonemap: ToneMap::default(),
            error_max: 5.0,
            turntable: None,
            frame_ms: 80,
        }
    }
}

/// The report of `spheremap render --json`: one image's, or a turntable's.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum RenderReport {
    Image(Box<RenderSummary>),
    Turntable(TurntableReport),
}

impl crate::jobs::Report for RenderReport {
    fn lines(&self) -> Vec<String> {
        match self {
            RenderReport::Image(r) => r.lines(),
            RenderReport::Turntable(r) => r.lines(),
        }
    }
}

/// The error render (degrees, coverage) as heat colours (0 → dark, `max` and above → pale
/// yellow) over the background by coverage.
pub fn heat_image(img: &Image, max: f32, bg: [f32; 3]) -> Image {
    let mut out = Image::new(img.width, img.height, 3);
    for (o, p) in out.data.chunks_exact_mut(3).zip(img.data.chunks_exact(2)) {
        let h = heat_colour(p[0] / max);
        for k in 0..3 {
            o[k] = p[1] * h[k] + (1.0 - p[1]) * bg[k];
        }
    }
    out
}

impl RenderFiles {
    /// A drawn image made ready for a file: as it is for a linear format, else the error
    /// mode's heat map or the tone-mapped colours.
    fn finish(&self, img: Image, opts: &RenderOptions, linear_out: bool) -> Image {
        if linear_out {
            img
        } else if opts.mode == Mode::Error {
            heat_image(&img, self.error_max, opts.background)
        } else {
            let mut i = img;
            tone_map(&mut i, self.exposure, self.tonemap);
            i
        }
    }
}

impl RenderFiles {
    /// The environment map at `path` as a render reads it: its mapping and cube layout given
    /// by the source fields, else its note's, else a sphere map's; its texels with the NaN/Inf
    /// rule.  A view is refused (a render looks maps up in the world's frame).
    pub fn read_env(&self, path: &str) -> Result<(Mapping, Image)> {
        if self.source.src_look.is_some() || self.source.src_up.is_some() {
            return Err(Error::param(
                "src_look",
                "render reads the map in the world's frame; turn it first (spheremap convert IN \
                 OUT --from-look X Y Z)",
            ));
        }
        let note = read_note(path)?;
        let r = self.source.resolve(note.as_ref(), path, Some("sphere"))?;
        let ropts = ReadOptions {
            linear: self.linear,
            ..Default::default()
        };
        let mut img = read_env(path, r.mapping, r.layout, &ropts)?;
        check_nonfinite(&mut img, self.nonfinite, path)?;
        Ok((r.mapping, img))
    }
}

impl RenderRequest {
    /// Draws `mesh` through each of `cams`, lit by `env` (its mapping and texels, named `what`
    /// in errors; not needed for the normals and error modes).
    fn draw(
        &self,
        mesh: &Mesh,
        env: Option<(Mapping, Image)>,
        what: &str,
        cams: &[GlCamera],
    ) -> Result<Vec<(Image, RenderStats)>> {
        let (mapping, img) = match env {
            Some((m, img)) => (m, Some(img)),
            None => (Mapping::parse("sphere", None)?, None),
        };
        let (mapping, img) = self.environment(mapping, img, what)?;
        let input = EnvInput::new(mapping, img.as_ref(), self.wrap, what)?;
        input.check(self.mode())?;
        let opts = self.options()?;
        cams.iter()
            .map(|c| render(mesh, c, input.env(), &opts))
            .collect()
    }

    /// Draws `mesh` lit by `env` (its mapping and texels, named `what` in errors; not needed
    /// for the normals and error modes): the image (linear; the error mode's degrees and
    /// coverage), what was drawn and the camera.
    pub fn run_image(
        &self,
        mesh: &Mesh,
        env: Option<(Mapping, Image)>,
        what: &str,
    ) -> Result<(Image, RenderStats, GlCamera)> {
        let cam = self.camera(&mesh.positions)?;
        let (img, stats) = self
            .draw(mesh, env, what, std::slice::from_ref(&cam))?
            .remove(0);
        Ok((img, stats, cam))
    }

    /// Draws the mesh at `mesh` (OBJ, glTF/GLB) with the environment at `env` (read as
    /// `files` says; not needed for the normals and error modes) and writes it to `output`, or
    /// a turntable's frames; errors name the field or the file.
    pub fn run_files(
        &self,
        mesh: &str,
        env: Option<&str>,
        files: &RenderFiles,
        output: &str,
        write: &WriteOptions,
    ) -> Result<RenderReport> {
        if !(files.error_max > 0.0 && files.error_max.is_finite()) {
            return Err(Error::param(
                "error_max",
                "must be a positive number of degrees",
            ));
        }
        let mode = self.mode();
        let m = crate::mesh::load_mesh(Path::new(mesh))?;
        let env = env.map(|e| files.read_env(e).map(|i| (i, e))).transpose()?;
        let what = env.as_ref().map_or("env", |e| e.1);
        let opts = self.options()?;
        let t0 = std::time::Instant::now();
        if let Some(n) = files.turntable {
            crate::base::limits::check_range(
                "turntable",
                n,
                1,
                crate::base::limits::TURNTABLE_FRAMES,
            )?;
            let gif = output.to_ascii_lowercase().ends_with(".gif");
            if !gif && !output.contains("{frame}") {
                return Err(Error::param(
                    "output",
                    format!("{output}: with a turntable, the output is a .gif or a pattern with {{frame}}"),
                ));
            }
            let linear_out =
                !gif && Format::from_extension(Path::new(output)).is_some_and(|f| !f.is_ldr());
            let cam = self.camera(&m.positions)?;
            let cams = (0..n)
                .map(|k| cam.orbited(360.0 * k as f64 / n as f64))
                .collect::<Result<Vec<_>>>()?;
            let frames: Vec<Image> = self
                .draw(&m, env.map(|e| e.0), what, &cams)?
                .into_iter()
                .map(|(img, _)| files.finish(img, &opts, linear_out))
                .collect();
            let written = if gif {
                write_gif(Path::new(output), &frames, files.frame_ms)?;
                vec![output.to_string()]
            } else {
                let digits = (n - 1).to_string().len().max(3);
                let mut w = vec![];
                for (k, f) in frames.iter().enumerate() {
                    let p = output.replace("{frame}", &format!("{k:0digits$}"));
                    write_image(Path::new(&p), f, write)?;
                    w.push(p);
                }
                w
            };
            return Ok(RenderReport::Turntable(TurntableReport {
                output: written,
                frames: n,
                mode: self.mode,
                width: cam.width,
                height: cam.height,
                seconds: t0.elapsed().as_secs_f64(),
            }));
        }
        let (img, stats, cam) = self.run_image(&m, env.map(|e| e.0), what)?;
        let seconds = t0.elapsed().as_secs_f64();
        let error_deg = (mode == Mode::Error).then(|| PixelError::of(&img));
        let format = Format::from_extension(Path::new(output));
        let out = files.finish(img, &opts, format.is_some_and(|f| !f.is_ldr()));
        write_image(Path::new(output), &out, write)?;
        let losses = format
            .map(|f| Losses::of(&out, f, write))
            .unwrap_or_default();
        Ok(RenderReport::Image(Box::new(RenderSummary {
            output: output.to_string(),
            mode: self.mode.to_string(),
            width: cam.width,
            height: cam.height,
            triangles_drawn: stats.triangles,
            covered_pixels: stats.covered_pixels,
            modelview: cam.modelview,
            projection: cam.projection,
            seconds,
            clipped: losses.clipped,
            clamped_half: losses.beyond_half,
            error_deg,
            error_scale_deg: error_deg.map(|_| files.error_max as f64),
        })))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::jobs::Report;

    #[test]
    fn a_mesh_file_is_drawn_written_and_reported_or_turned_into_frames() {
        let dir = std::env::temp_dir().join(format!("spheremap-render-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let obj = dir.join("ball.obj");
        let ball = super::super::tests::uv_sphere(6, 12);
        let st = vec![0.5; 2 * ball.positions.len()];
        crate::mesh::write::write_obj_with_uv(&obj, &ball, &st, None).unwrap();
        let (obj, png) = (obj.to_str().unwrap(), dir.join("n.png"));
        let r = RenderRequest {
            mode: super::super::ModeName::Normals,
            view: super::super::CameraRequest {
                width: 24,
                height: 16,
                ..Default::default()
            },
            ..Default::default()
        };
        let files = RenderFiles::default();
        let w = WriteOptions::default();
        let rep = r
            .run_files(obj, None, &files, png.to_str().unwrap(), &w)
            .unwrap();
        let RenderReport::Image(s) = &rep else {
            panic!("one image")
        };
        assert_eq!((s.width, s.height), (24, 16));
        assert!(s.covered_pixels > 0 && png.is_file());
        assert!(rep.lines()[0].starts_with(&format!("-> {} (24x16, normals", png.display())));
        let gif = dir.join("t.gif");
        let spin = RenderFiles {
            turntable: Some(3),
            ..Default::default()
        };
        let rep = r
            .run_files(obj, None, &spin, gif.to_str().unwrap(), &w)
            .unwrap();
        assert!(matches!(&rep, RenderReport::Turntable(t) if t.frames == 3) && gif.is_file());
        let e = |r: &RenderRequest, f: &RenderFiles, out: &str| {
            r.run_files(obj, None, f, out, &w).unwrap_err().to_string()
        };
        let out = dir.join("x.png");
        let out = out.to_str().unwrap();
        let bad = RenderFiles {
            error_max: 0.0,
            ..Default::default()
        };
        assert!(e(&r, &bad, out).starts_with("error_max: "));
        assert!(e(&r, &spin, out).starts_with("output: "));
        let lit = RenderRequest {
            mode: super::super::ModeName::PerPixel,
            ..r.clone()
        };
        assert!(e(&lit, &files, out).starts_with("env: "));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
