//! Environment maps by firing rays: the classic `gen_sphere_map(width, height, pos, tex)` done
//! properly.
//!
//! For every output texel the generator asks a [`RaySource`] — the classic `fire_ray(pos, ray)` —
//! what the world shows from `pos` in a set of directions spread over the texel's footprint, and
//! averages.  The source may be a closure, an environment map (six cube faces taken around
//! `pos`, or any mapping the conversion engine reads), a ray-traced [`crate::trace::scene::Scene`], or
//! (in the Python package) a Python callable that receives batches of rays as numpy arrays.
//!
//! ## What one texel is (the same rules as [`crate::resample`])
//!
//! * `samples = 1`: exactly one ray, through the texel centre.
//! * `samples = S > 1`: rays on an n_x × n_y grid of strata over the reconstruction filter's
//!   support (the 1-texel **box** by default, so a texel is the plain average over its own
//!   footprint; tent and Gaussian as in `convert`), one jittered ray per stratum, the jitter a
//!   hash of (seed, texel, stratum) — so a run is deterministic for a seed, whatever the number
//!   of threads.  n_x·n_y ≥ S, and **more where the footprint is stretched**: the texel's edge
//!   midpoints become directions, the angles across the texel in x and in y are compared with
//!   the side a₀ = √|Δ_x × Δ_y| of the isotropic texel of the same solid angle, and each axis
//!   gets ⌈√S · span/a₀⌉ strata (the sphere map's rim, where a texel is stretched radially by
//!   1/(1 − ρ²), gets more rays; its centre gets S), at most `max_samples`.
//! * Weights: filter weight × the mapping's solid-angle density (uniform for the equal-area
//!   sphere map, so every ray of a box texel counts the same).
//!
//! ## Which texels are visited
//!
//! For the disc mappings (sphere, angular, dual paraboloid) each row's span is computed from
//! the circle: the texels whose square meets the disc.  Inside that span, a sample that falls
//! outside the disc (a rim texel's outer corner) follows the conversion engine's rule: with
//! the gutter its ray goes in the radially mirrored direction; with `black` it adds weight and
//! no light (the rim texel holds its covered fraction).  Texels wholly outside the disc fire no
//! ray: with the gutter they are filled afterwards from the finished map at the radially
//! mirrored point (the engine's gutter rule, applied to the map itself), else set to 0.
//!
//! ## The view
//!
//! `rotation` takes the map's own frame (the eye of a sphere map: looking down −Z, +Y up) to
//! the world the rays are fired in ([`crate::frame::view`]: `look_up(look, up)`), and `pos` is the
//! world point every ray starts from.

use crate::base::error::{Error, Result};
use crate::base::real::Real;
use crate::images::Image;
use crate::mappings::mapping::Mapping;
use crate::resample::{
    self, jitter, strata, Dst, EnvMap, Filter, Outside, Precision, Progress, Sampler,
    DEFAULT_SAMPLES, IDENTITY,
};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;

/// A ray source, `fire_ray(pos, ray)` batched: what the world shows along each ray.
///
/// `trace` gets ray origins and unit directions (world frame) and writes `channels()` values
/// per ray into `out` (`out.len() == directions.len() * channels()`).  It is called from
/// several threads at once, with batches of a few thousand rays (one output row, or
/// [`RaySource::rows_per_call`] consecutive rows).
pub trait RaySource: Sync {
    fn channels(&self) -> usize;
    fn trace(&self, origins: &[[f32; 3]], directions: &[[f32; 3]], out: &mut [f32]) -> Result<()>;
    /// Consecutive output rows whose rays one `trace` call takes (the first row a multiple of
    /// it; the rays row by row, each row's in order): more than 1 for a source whose work is
    /// shared between neighbouring rays in two dimensions.  The rays and their weights are
    /// the same whatever it is.
    fn rows_per_call(&self) -> usize {
        1
    }
}

/// A per-ray closure as a [`RaySource`]: `f(origin, direction, out)`.
pub struct FnSource<F> {
    channels: usize,
    f: F,
}

impl<F: Fn([f32; 3], [f32; 3], &mut [f32]) + Sync> FnSource<F> {
    pub fn new(channels: usize, f: F) -> Self {
        FnSource { channels, f }
    }
}

impl<F: Fn([f32; 3], [f32; 3], &mut [f32]) + Sync> RaySource for FnSource<F> {
    fn channels(&self) -> usize {
        self.channels
    }
    fn trace(&self, origins: &[[f32; 3]], directions: &[[f32; 3]], out: &mut [f32]) -> Result<()> {
        let c = self.channels;
        for (i, (o, d)) in origins.iter().zip(directions).enumerate() {
            (self.f)(*o, *d, &mut out[i * c..(i + 1) * c]);
        }
        Ok(())
    }
}

/// An environment map as a [`RaySource`] (the two-step method: six cube-face images taken
/// around `pos`, or any mapping): the map is at infinity, so origins are ignored and each ray
/// is one bilinear lookup with the map's wrap rules.  `rotation` takes world directions to the
/// map's frame.
pub struct EnvSource<'a> {
    sampler: Sampler<'a>,
    rotation: [[f32; 3]; 3],
}

impl<'a> EnvSource<'a> {
    pub fn new(env: &EnvMap<'a>, rotation: [[f64; 3]; 3]) -> Self {
        EnvSource {
            sampler: Sampler::new(env),
            rotation: rotation.map(|r| r.map(|v| v as f32)),
        }
    }
}

impl RaySource for EnvSource<'_> {
    fn channels(&self) -> usize {
        self.sampler.channels()
    }
    fn trace(&self, _: &[[f32; 3]], directions: &[[f32; 3]], out: &mut [f32]) -> Result<()> {
        let (c, r) = (self.sampler.channels(), &self.rotation);
        for (d, o) in directions.iter().zip(out.chunks_exact_mut(c)) {
            let v = [0, 1, 2].map(|i| r[i][0] * d[0] + r[i][1] * d[1] + r[i][2] * d[2]);
            self.sampler.sample(v, o);
        }
        Ok(())
    }
}

/// The most values a ray source may return per ray.
pub const MAX_CHANNELS: usize = 8;

/// Options of [`generate`].
#[derive(Clone, Copy, Debug)]
pub struct GenerateOptions {
    /// Rays per texel: 1 = one ray through the centre; S > 1 = at least S, adaptive.
    pub samples: u32,
    /// The most rays one texel may take when adapting.
    pub max_samples: u32,
    pub filter: Filter,
    pub outside: Outside,
    /// Row-major rotation from the map's frame to the world (columns: the map's axes in world
    /// coordinates).
    pub rotation: [[f64; 3]; 3],
    /// The world point all rays start from.
    pub pos: [f32; 3],
    pub seed: u64,
    /// Arithmetic of the sample directions (rays are f32 either way).
    pub precision: Precision,
    /// Refuse a job whose estimated allocation is over this many bytes.
    pub max_memory: u64,
}

impl Default for GenerateOptions {
    fn default() -> Self {
        GenerateOptions {
            samples: DEFAULT_SAMPLES,
            max_samples: 1024,
            filter: Filter::Box,
            outside: Outside::Gutter,
            rotation: IDENTITY,
            pos: [0.0; 3],
            seed: 0,
            precision: Precision::F32,
            max_memory: crate::base::limits::default_max_memory(),
        }
    }
}

/// What a run did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GenerateReport {
    /// Rays fired in all.
    pub rays: u64,
    /// Texels that fired rays (the rest were filled: gutter or black).
    pub texels: u64,
    /// The most rays any texel took.
    pub max_texel_samples: u32,
}

/// The map a ray-firing job makes, as users name it: `spheremap generate`, `from-photo` and
/// `from-fisheye`, and Python's `generate`, `from_mirror_ball` and `from_fisheye` fill the same
/// fields (serde-readable, unknown keys refused), and [`MapRequest::resolve`] checks them once.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MapRequest {
    /// The output mapping and its preset.
    pub to: String,
    pub preset: Option<String>,
    /// The cube layout of a cube map written as one image.
    pub layout: Option<String>,
    /// Output size N (sphere N×N; latlong 2N×N; cube faces N×N).
    pub size: usize,
    /// The point the rays start from (world coordinates; the photo routes ignore it).
    pub pos: [f32; 3],
    /// The map's view: world directions of its eye's −Z and +Y (the photo routes: in the
    /// camera's frame).
    pub look: Option<[f64; 3]>,
    pub up: Option<[f64; 3]>,
    /// Rays per texel (1: through the centre), the most a texel may take, the filter over the
    /// footprint, what goes outside a disc, the jitter's seed, the directions' arithmetic.
    pub samples: u32,
    pub max_samples: u32,
    pub filter: Filter,
    pub outside: Outside,
    pub seed: u64,
    pub precision: Precision,
    /// Refuse a job needing more bytes than this (`None`: the default limit).
    pub max_memory: Option<u64>,
}

impl Default for MapRequest {
    fn default() -> Self {
        MapRequest {
            to: "sphere".into(),
            preset: None,
            layout: None,
            size: 512,
            pos: [0.0; 3],
            look: None,
            up: None,
            samples: DEFAULT_SAMPLES,
            max_samples: 1024,
            filter: Filter::default(),
            outside: Outside::default(),
            seed: 0,
            precision: Precision::default(),
            max_memory: None,
        }
    }
}

/// A [`MapRequest`] checked: the mapping, layout and canvas, the output's view (for its note)
/// and the options of [`generate`].
#[derive(Clone, Copy, Debug)]
pub struct ResolvedMap {
    pub mapping: Mapping,
    pub layout: Option<crate::images::cube_layout::Layout>,
    pub width: usize,
    pub height: usize,
    pub view: [[f64; 3]; 3],
    pub options: GenerateOptions,
}

impl MapRequest {
    /// Checks every field with the core's parsers and limits; errors name the field.
    pub fn resolve(&self) -> Result<ResolvedMap> {
        let mapping = Mapping::parse(&self.to, self.preset.as_deref())
            .map_err(|e| crate::mappings::mapping::name_fields(e, "to", "preset"))?;
        let layout = self
            .layout
            .as_deref()
            .map(crate::images::cube_layout::Layout::parse)
            .transpose()?;
        crate::base::limits::check_map_size("size", self.size)?;
        let (width, height) = mapping.canvas(self.size);
        Ok(ResolvedMap {
            mapping,
            layout,
            width,
            height,
            view: crate::frame::view::output_view(self.look, self.up, None)?,
            options: GenerateOptions {
                samples: self.samples,
                max_samples: self.max_samples,
                filter: self.filter,
                outside: self.outside,
                rotation: crate::frame::view::conversion_rotation(
                    self.look, self.up, None, None, None,
                )?,
                pos: self.pos,
                seed: self.seed,
                precision: self.precision,
                max_memory: self
                    .max_memory
                    .unwrap_or_else(crate::base::limits::default_max_memory),
            },
        })
    }
}

/// The report of `spheremap generate --json`: what was traced, how, and how fast.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct GenerateSummary {
    /// The scene file (or built-in) and the environment map the rays saw.
    pub scene: Option<String>,
    pub env: Option<String>,
    pub output: Vec<String>,
    pub to: &'static str,
    pub preset: &'static str,
    pub size: usize,
    pub width: usize,
    pub height: usize,
    pub samples: u32,
    pub filter: &'static str,
    pub outside: &'static str,
    /// The scene's triangles (zero-area ones are ignored) and lights.
    pub triangles: Option<usize>,
    pub degenerate_triangles: Option<usize>,
    pub lights: Option<usize>,
    pub rays: u64,
    pub texels_traced: u64,
    pub rays_per_texel: f64,
    pub max_texel_samples: u32,
    pub seconds: f64,
    pub rays_per_second: f64,
    /// Values the output format clipped, and values beyond the half range.
    pub clipped: u64,
    pub clamped_half: u64,
}

/// Makes a `width`×`height` canvas of `mapping` (for a cube: the F×6F face stack) by firing
/// rays into `source`.
pub fn generate(
    mapping: Mapping,
    width: usize,
    height: usize,
    source: &dyn RaySource,
    opts: &GenerateOptions,
    progress: Option<&Progress>,
) -> Result<(Image, GenerateReport)> {
    let c = source.channels();
    check_canvas(mapping, width, height, c, opts)?;
    let mut out = Image::new(width, height, c);
    let report = match opts.precision {
        Precision::F32 => run::<f32>(mapping, &mut out, source, opts, progress)?,
        Precision::F64 => run::<f64>(mapping, &mut out, source, opts, progress)?,
    };
    if progress.is_some_and(|p| p.cancel.load(Ordering::Relaxed)) {
        return Err(Error::cancelled("the generation"));
    }
    if mapping.has_outside() {
        fill_outside(mapping, &mut out, opts.outside, opts.samples == 1);
    }
    Ok((out, report))
}

/// The checks of [`generate`]'s arguments: the canvas's size, the samples, `c` channels, the
/// position and rotation, the memory the image takes.
fn check_canvas(
    mapping: Mapping,
    width: usize,
    height: usize,
    c: usize,
    opts: &GenerateOptions,
) -> Result<()> {
    mapping
        .size_of(width, height, "size")
        .map_err(|e| Error::param("size", e.to_string()))?;
    crate::base::limits::check_samples(opts.samples, opts.max_samples)?;
    if !(1..=MAX_CHANNELS).contains(&c) {
        return Err(Error::param(
            "fire_ray",
            format!("returns {c} channels; 1 to {MAX_CHANNELS} are supported"),
        ));
    }
    if opts.pos.iter().any(|v| !v.is_finite()) {
        return Err(Error::param("pos", "must be finite"));
    }
    resample::check_rotation(&opts.rotation)?;
    // The output, its copy for the gutter, and an encoder's buffer.
    crate::base::limits::check_memory(
        "size",
        3 * (width as u128 * height as u128 * c as u128 * 4),
        opts.max_memory,
    )?;
    Ok(())
}

/// What [`generate_all`] calls with every ray's direction: `channels` values per ray.
pub type CanvasEval<'a> = dyn Fn(&[[f32; 3]]) -> Result<Vec<f32>> + 'a;

/// [`generate`] for a source that takes the whole canvas at once, because its rays share work
/// beyond neighbouring rows (e.g. the irradiance at antipodal normals): one ray per texel
/// (`opts.samples == 1`), the rays [`generate`] would fire listed row by row, `eval` gets all of
/// them and returns `channels` values per ray, and each texel takes its ray's value — the
/// image [`generate`] makes from the same values, bit for bit.  `eval_bytes` is the memory
/// `eval` takes per ray, counted against `opts.max_memory` with the list's own.
#[allow(clippy::too_many_arguments)]
pub fn generate_all(
    mapping: Mapping,
    width: usize,
    height: usize,
    channels: usize,
    eval: &CanvasEval<'_>,
    eval_bytes: u64,
    opts: &GenerateOptions,
    progress: Option<&Progress>,
) -> Result<(Image, GenerateReport)> {
    if opts.samples != 1 {
        return Err(Error::param(
            "samples",
            format!(
                "{} rays per texel; a whole-canvas source takes 1",
                opts.samples
            ),
        ));
    }
    check_canvas(mapping, width, height, channels, opts)?;
    let (w, h, c) = (width, height, channels);
    // Per ray its direction (twice: by rows, then listed), its values, what `eval` takes.
    crate::base::limits::check_memory(
        "size",
        (w as u128 * h as u128) * (24 + 4 * c as u128 + eval_bytes as u128),
        opts.max_memory,
    )?;
    let rows: Vec<(Vec<u32>, Vec<[f32; 3]>)> = match opts.precision {
        Precision::F32 => centre_rays::<f32>(mapping, w, h, opts),
        Precision::F64 => centre_rays::<f64>(mapping, w, h, opts),
    };
    let dirs: Vec<[f32; 3]> = rows.iter().flat_map(|r| r.1.iter().copied()).collect();
    let values = eval(&dirs)?;
    if values.len() != dirs.len() * c {
        return Err(Error::param(
            "eval",
            format!(
                "returned {} values for {} rays of {c} channels",
                values.len(),
                dirs.len()
            ),
        ));
    }
    if progress.is_some_and(|p| p.cancel.load(Ordering::Relaxed)) {
        return Err(Error::cancelled("the generation"));
    }
    // Each row's values start where its rays do.
    let mut starts = Vec::with_capacity(h);
    let mut at = 0;
    for r in &rows {
        starts.push(at);
        at += r.1.len();
    }
    let mut out = Image::new(w, h, c);
    out.data
        .par_chunks_mut(w * c)
        .zip(rows.par_iter().zip(starts.par_iter()))
        .for_each(|(row, ((xs, _), &at))| {
            for (k, &x) in xs.iter().enumerate() {
                row[x as usize * c..][..c].copy_from_slice(&values[(at + k) * c..][..c]);
            }
        });
    if mapping.has_outside() {
        fill_outside(mapping, &mut out, opts.outside, true);
    }
    if let Some(p) = progress {
        p.total.store(h, Ordering::Relaxed);
        p.done.store(h, Ordering::Relaxed);
    }
    let n = dirs.len() as u64;
    let report = GenerateReport {
        rays: n,
        texels: n,
        max_texel_samples: (n > 0) as u32,
    };
    Ok((out, report))
}

/// Per row: the texels that fire a ray with one ray per texel, and their rays' directions,
/// exactly as [`run`] makes them.
fn centre_rays<T: Real>(
    m: Mapping,
    w: usize,
    h: usize,
    opts: &GenerateOptions,
) -> Vec<(Vec<u32>, Vec<[f32; 3]>)> {
    let d = Dst::<T>::new(m, w, h, &opts.rotation, opts.outside);
    (0..h)
        .into_par_iter()
        .map_init(Batch::default, |b, y| {
            b.dirs.clear();
            b.owner.clear();
            let mut xs = Vec::new();
            let mut wsum = 0.0;
            for (x0, x1) in row_spans(m, w, h, y) {
                for x in x0..x1 {
                    if fires(m, w, h, x, y, opts) {
                        texel_rays(&d, x, y, x, opts, b, &mut wsum);
                        xs.push(x as u32);
                    }
                }
            }
            (xs, b.dirs.clone())
        })
        .collect()
}

/// The rays [`generate`] fires for a `width`×`height` canvas of `mapping` with `channels`
/// channels under `opts`, counted from the sample rules without firing any (with
/// [`Outside::Black`] the samples that fall off a disc are dropped, so at most this many):
/// what a caller weighs against another way to the same image.  The canvas is checked as
/// [`generate`] checks it.
pub fn planned_rays(
    mapping: Mapping,
    width: usize,
    height: usize,
    channels: usize,
    opts: &GenerateOptions,
) -> Result<u64> {
    check_canvas(mapping, width, height, channels, opts)?;
    Ok(match opts.precision {
        Precision::F32 => count_rays::<f32>(mapping, width, height, opts),
        Precision::F64 => count_rays::<f64>(mapping, width, height, opts),
    })
}

fn count_rays<T: Real>(m: Mapping, w: usize, h: usize, opts: &GenerateOptions) -> u64 {
    let d = Dst::<T>::new(m, w, h, &opts.rotation, opts.outside);
    (0..h)
        .into_par_iter()
        .map(|y| {
            let mut n = 0u64;
            for (x0, x1) in row_spans(m, w, h, y) {
                for x in x0..x1 {
                    if fires(m, w, h, x, y, opts) {
                        n += texel_samples(&d, x, y, opts) as u64;
                    }
                }
            }
            n
        })
        .sum()
}

/// Whether texel (x, y) of a row's span fires rays: all do, but with one sample per texel
/// only those whose centre lies on the map.
fn fires(m: Mapping, w: usize, h: usize, x: usize, y: usize, opts: &GenerateOptions) -> bool {
    opts.samples != 1 || centre_on_map(m, w, h, x, y)
}

/// The samples texel (x, y) takes: 1, or its strata ([`footprint_strata`]).
fn texel_samples<T: Real>(d: &Dst<T>, x: usize, y: usize, opts: &GenerateOptions) -> usize {
    if opts.samples == 1 {
        return 1;
    }
    let (nx, ny) = footprint_strata(d, x as f64 + 0.5, y as f64 + 0.5, opts);
    nx * ny
}

/// The texel spans of row `y` that meet the map (the whole row for mappings without discs).
/// Disc mappings: discs of diameter `h` centred at ((k + ½)h, ½h); a texel square [x, x+1] ×
/// [y, y+1] meets the disc when its point nearest the centre is within the radius.
pub fn row_spans(mapping: Mapping, w: usize, h: usize, y: usize) -> Vec<(usize, usize)> {
    if !mapping.has_outside() {
        return vec![(0, w)];
    }
    let r = 0.5 * h as f64;
    let dy = (r.clamp(y as f64, y as f64 + 1.0) - r).abs();
    if dy >= r {
        return Vec::new();
    }
    let hw = (r * r - dy * dy).sqrt();
    (0..w / h)
        .map(|k| {
            let cx = (k as f64 + 0.5) * h as f64;
            let x0 = (cx - hw).floor().max(k as f64 * h as f64) as usize;
            let x1 = ((cx + hw).ceil() as usize).min((k + 1) * h);
            (x0, x1)
        })
        .collect()
}

/// Whether the texel centre lies on the map (inside the disc for disc mappings; every centre
/// of the others, which cover their canvas).
pub(crate) fn centre_on_map(m: Mapping, w: usize, h: usize, x: usize, y: usize) -> bool {
    !m.has_outside()
        || m.uv_to_dir([(x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64])
            .is_some()
}

/// One call's rays and where their colours go.
#[derive(Default)]
struct Batch {
    origins: Vec<[f32; 3]>,
    dirs: Vec<[f32; 3]>,
    /// (texel index in the call's rows, weight) per ray.
    owner: Vec<(u32, f32)>,
    colours: Vec<f32>,
}

fn run<T: Real>(
    m: Mapping,
    out: &mut Image,
    source: &dyn RaySource,
    opts: &GenerateOptions,
    progress: Option<&Progress>,
) -> Result<GenerateReport> {
    let (w, h, c) = (out.width, out.height, out.channels);
    let d = Dst::<T>::new(m, w, h, &opts.rotation, opts.outside);
    if let Some(p) = progress {
        p.total.store(h, Ordering::Relaxed);
    }
    let rays = AtomicU64::new(0);
    let texels = AtomicU64::new(0);
    let max_n = AtomicUsize::new(0);
    let failure: Mutex<Option<Error>> = Mutex::new(None);
    let rows = source.rows_per_call().clamp(1, h.max(1));
    out.data
        .par_chunks_mut(rows * w * c)
        .enumerate()
        .for_each_init(Batch::default, |b, (chunk, block)| {
            if progress.is_some_and(|p| p.cancel.load(Ordering::Relaxed)) {
                return;
            }
            b.origins.clear();
            b.dirs.clear();
            b.owner.clear();
            let n_rows = block.len() / (w * c);
            // Per texel of the rows: Σ weights (rays or not).
            let mut wsum = vec![0f64; n_rows * w];
            let mut n_texels = 0u64;
            let mut row_max = 0usize;
            for r in 0..n_rows {
                let y = chunk * rows + r;
                for (x0, x1) in row_spans(m, w, h, y) {
                    for x in x0..x1 {
                        if !fires(m, w, h, x, y, opts) {
                            continue;
                        }
                        n_texels += 1;
                        let n = texel_rays(&d, x, y, r * w + x, opts, b, &mut wsum[r * w + x]);
                        row_max = row_max.max(n);
                    }
                }
            }
            let k = b.dirs.len();
            b.origins.resize(k, opts.pos);
            b.colours.clear();
            b.colours.resize(k * c, 0.0);
            if k > 0 {
                if let Err(e) = source.trace(&b.origins, &b.dirs, &mut b.colours) {
                    let mut f = failure.lock().unwrap_or_else(|p| p.into_inner());
                    f.get_or_insert(e);
                    if let Some(p) = progress {
                        p.cancel.store(true, Ordering::Relaxed);
                    }
                    return;
                }
            }
            let mut acc = vec![0f64; n_rows * w * c];
            for (i, &(x, wt)) in b.owner.iter().enumerate() {
                for ch in 0..c {
                    acc[x as usize * c + ch] += wt as f64 * b.colours[i * c + ch] as f64;
                }
            }
            for x in 0..n_rows * w {
                if wsum[x] > 0.0 {
                    for ch in 0..c {
                        block[x * c + ch] = (acc[x * c + ch] / wsum[x]) as f32;
                    }
                }
            }
            rays.fetch_add(k as u64, Ordering::Relaxed);
            texels.fetch_add(n_texels, Ordering::Relaxed);
            max_n.fetch_max(row_max, Ordering::Relaxed);
            if let Some(p) = progress {
                p.done.fetch_add(n_rows, Ordering::Relaxed);
            }
        });
    if let Some(e) = failure.into_inner().unwrap_or_else(|p| p.into_inner()) {
        return Err(e);
    }
    Ok(GenerateReport {
        rays: rays.into_inner(),
        texels: texels.into_inner(),
        max_texel_samples: max_n.into_inner() as u32,
    })
}

/// Queues the rays of texel (x, y), `slot` its index in the batch's rows; adds the texel's
/// total weight to `wsum`; returns the number of samples it took.
fn texel_rays<T: Real>(
    d: &Dst<T>,
    x: usize,
    y: usize,
    slot: usize,
    opts: &GenerateOptions,
    b: &mut Batch,
    wsum: &mut f64,
) -> usize {
    let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
    let dir = |px: f64, py: f64| d.dir(T::from_f64(px), T::from_f64(py));
    let mut push = |v: [T; 3], wt: f64| {
        let v = v.map(|a| a.to_f64());
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        b.dirs.push(v.map(|a| (a / l) as f32));
        b.owner.push((slot as u32, wt as f32));
    };
    if opts.samples == 1 {
        push(dir(cx, cy).0, 1.0);
        *wsum += 1.0;
        return 1;
    }
    let (nx, ny) = footprint_strata(d, cx, cy, opts);
    let radius = opts.filter.radius();
    let support = 2.0 * radius;
    for j in 0..ny {
        for i in 0..nx {
            let (jx, jy) = jitter(opts.seed, x as u64, y as u64, (j * nx + i) as u64);
            let ox = -radius + (i as f64 + jx) / nx as f64 * support;
            let oy = -radius + (j as f64 + jy) / ny as f64 * support;
            let (sx, sy) = (cx + ox, cy + oy);
            let wt = opts.filter.weight(ox)
                * opts.filter.weight(oy)
                * d.density(T::from_f64(sx), T::from_f64(sy));
            *wsum += wt;
            let (v, on) = dir(sx, sy);
            if !on && d.outside == Outside::Black {
                continue;
            }
            push(v, wt);
        }
    }
    nx * ny
}

/// The strata grid of a texel from its angular footprint (see the module docs).
fn footprint_strata<T: Real>(
    d: &Dst<T>,
    cx: f64,
    cy: f64,
    opts: &GenerateOptions,
) -> (usize, usize) {
    let unit = |px: f64, py: f64| {
        let v = d
            .dir(T::from_f64(px), T::from_f64(py))
            .0
            .map(|a| a.to_f64());
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|a| a / l)
    };
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let hx = sub(unit(cx + 0.5, cy), unit(cx - 0.5, cy));
    let hy = sub(unit(cx, cy + 0.5), unit(cx, cy - 0.5));
    let len = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let cr = [
        hx[1] * hy[2] - hx[2] * hy[1],
        hx[2] * hy[0] - hx[0] * hy[2],
        hx[0] * hy[1] - hx[1] * hy[0],
    ];
    let a0 = len(cr).sqrt();
    let base = (opts.samples as f64).sqrt().ceil();
    let cap = opts.max_samples as usize;
    let axis = |l: f64| {
        let k = l / a0;
        if k.is_finite() {
            (base * k.max(1.0)).ceil().min(cap as f64) as usize
        } else {
            cap
        }
    };
    strata(axis(len(hx)), axis(len(hy)), opts.samples as usize, cap)
}

/// Texels wholly off a disc mapping (never traced): the engine's gutter — the value at the
/// radially mirrored canvas point, looked up bilinearly in the finished map — or 0.
pub(crate) fn fill_outside(m: Mapping, out: &mut Image, outside: Outside, centres_only: bool) {
    let (w, h, c) = (out.width, out.height, out.channels);
    let traced: Vec<bool> = (0..h)
        .flat_map(|y| {
            let spans = row_spans(m, w, h, y);
            (0..w).map(move |x| spans.iter().any(|&(a, b)| (a..b).contains(&x)))
        })
        .collect();
    let copy = out.data.clone();
    let env = EnvMap {
        mapping: m,
        width: w,
        height: h,
        channels: c,
        data: &copy,
    };
    let sampler = Sampler::new(&env);
    let d = Dst::<f64>::new(m, w, h, &IDENTITY, Outside::Gutter);
    out.data
        .par_chunks_mut(w * c)
        .enumerate()
        .for_each(|(y, row)| {
            for x in 0..w {
                // With one centre ray per texel, a texel whose centre is off the map fired
                // nothing even inside the span.
                let on = centre_on_map(m, w, h, x, y);
                if on || (traced[y * w + x] && !centres_only) {
                    continue;
                }
                let px = &mut row[x * c..(x + 1) * c];
                match outside {
                    Outside::Black => px.fill(0.0),
                    Outside::Gutter => {
                        let (v, _) = d.dir(x as f64 + 0.5, y as f64 + 0.5);
                        sampler.sample(v.map(|a| a as f32), px);
                    }
                }
            }
        });
}
