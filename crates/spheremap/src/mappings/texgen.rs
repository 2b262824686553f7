//! `GL_SPHERE_MAP` texture-coordinate generation for meshes, exactly as OpenGL computes it.
//!
//! What a real OpenGL does (Mesa's fixed-function vertex program, `ffvertex_prog.c`, checked
//! against Mesa 22.3 llvmpipe), per vertex with object position `p` and normal `n`:
//!
//! ```text
//! e  = M p                                  (p = (x,y,z,1) or (x,y,z,w); M the modelview)
//! û  = e.xyz · rsq(e.xyz · e.xyz)           (e.w is ignored, even when negative)
//! n' = N n,   N = transpose(upper-left 3×3 of M⁻¹)   (the inverse of the full 4×4!)
//!      GL_NORMALIZE:      n' = n' · rsq(n'·n')
//!      GL_RESCALE_NORMAL: n' = n' / |row 2 of M⁻¹ (xyz)|   (skipped when Mesa classifies M as
//!                          length preserving; NORMALIZE wins when both are on)
//!      neither:           n' used as is — NOT normalized
//! r  = û − 2 (n'·û) n'
//! k  = rsq(r_x² + r_y² + (r_z + 1)²) · ½     (= 1/m)
//! s  = r_x k + ½,   t = r_y k + ½
//! ```
//!
//! `rsq(0) = ∞` and `0·∞ = NaN`: an eye position at the origin, a zero normal with
//! GL_NORMALIZE, and `r = (0,0,−1)` give NaN ([`Singular::Nan`]).  [`Singular::Center`] follows
//! legacy Mesa (`t_vb_texgen.c`): a zero-length vector normalizes to zero and `m = 0` gives
//! (½,½).  A singular modelview (no inverse) uses the identity as its inverse, as Mesa does.
//! Non-finite input propagates to NaN output.
//!
//! Two paths: [`sphere_texgen`] (f32, what GL computes — rearranged exactly to save two square
//! roots, see `Kernel::block` — vectorised and multi-threaded) and [`sphere_texgen_f64`] (f64
//! reference, GL's operations in GL's order).

use crate::base::error::{Error, Result};
use crate::frame::conventions::Singular;
use rayon::prelude::*;

crate::base::named::named_enum! {
    /// GL's normal-vector state.
    #[derive(Default)]
    pub enum NormalMode: "value" as "normalize" {
        /// `glEnable(GL_NORMALIZE)`: normals normalized after the transform.  The default:
        /// what a user of sphere maps wants.
        #[default]
        On = "on",
        /// Neither GL_NORMALIZE nor GL_RESCALE_NORMAL: the transformed normal is used as is.
        Off = "off",
        /// `glEnable(GL_RESCALE_NORMAL)` only.
        Rescale = "rescale",
    }
}

/// What GL derives from the modelview once per draw: the normal matrix and the rescale factor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelviewState {
    /// The modelview, row-major, math convention (`e = M p`).
    pub m: [[f64; 4]; 4],
    /// `transpose(upper-left 3×3 of M⁻¹)`, row-major: `n' = normal_matrix · n`.
    pub normal_matrix: [[f64; 3]; 3],
    /// GL_RESCALE_NORMAL factor (1 where Mesa skips the rescale).
    pub rescale: f64,
    /// M had no inverse; the identity was used (as Mesa does).
    pub singular: bool,
}

impl ModelviewState {
    /// Analyses `m` as Mesa does on `glLoadMatrix`.  Non-finite entries are an error.
    pub fn new(m: [[f64; 4]; 4]) -> Result<Self> {
        if m.iter().flatten().any(|v| !v.is_finite()) {
            return Err(Error::param("modelview", "contains a non-finite value"));
        }
        let (inv, singular) = match invert4(&m) {
            Some(inv) => (inv, false),
            None => (IDENTITY4, true),
        };
        let mut normal_matrix = [[0.0; 3]; 3];
        for (i, row) in normal_matrix.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = inv[j][i];
            }
        }
        // Mesa update_modelview_scale(): f = |row 2 of M⁻¹ (xyz)|², guarded, unless M is
        // classified length preserving.
        let rescale = if mesa_length_preserving(&m) {
            1.0
        } else {
            let f = (inv[2][0] * inv[2][0] + inv[2][1] * inv[2][1] + inv[2][2] * inv[2][2]) as f32;
            let f = if f < 1e-12 { 1.0 } else { f };
            (1.0 / f.sqrt()) as f64
        };
        Ok(ModelviewState {
            m,
            normal_matrix,
            rescale,
            singular,
        })
    }
}

use crate::base::vec::IDENTITY4;

/// 4×4 inverse by Gaussian elimination with partial pivoting (as Mesa's
/// `invert_matrix_general`/`util_invert_mat4x4`), in f64.  `None` when a pivot is exactly zero
/// or the result is not finite.
pub fn invert4(m: &[[f64; 4]; 4]) -> Option<[[f64; 4]; 4]> {
    let mut a = [[0.0f64; 8]; 4];
    for i in 0..4 {
        a[i][..4].copy_from_slice(&m[i]);
        a[i][4 + i] = 1.0;
    }
    for col in 0..4 {
        let piv =
            (col..4).max_by(|&x, &y| a[x][col].abs().partial_cmp(&a[y][col].abs()).unwrap())?;
        if a[piv][col] == 0.0 {
            return None;
        }
        a.swap(col, piv);
        let p = a[col][col];
        for v in a[col].iter_mut() {
            *v /= p;
        }
        for r in 0..4 {
            if r != col {
                let f = a[r][col];
                if f != 0.0 {
                    let pivot_row = a[col];
                    for (x, p) in a[r].iter_mut().zip(pivot_row) {
                        *x -= f * p;
                    }
                }
            }
        }
    }
    let mut inv = [[0.0; 4]; 4];
    for i in 0..4 {
        inv[i].copy_from_slice(&a[i][4..]);
    }
    inv.iter().flatten().all(|v| v.is_finite()).then_some(inv)
}

/// Mesa's `_math_matrix_is_length_preserving` after `analyse_from_scratch` (`m_matrix.c`), on the
/// f32 matrix GL stores.  Length preserving = only the ROTATION and TRANSLATION flags are set.
/// Mesa indexes column-major (`m[col*4 + row]`); the tolerances are Mesa's.
fn mesa_length_preserving(mm: &[[f64; 4]; 4]) -> bool {
    let m = |i: usize| mm[i % 4][i / 4] as f32;
    let zero = |i: usize| m(i) == 0.0;
    let sq = |x: f32| x * x;
    let tol = sq(1e-6);
    // Bottom row must be (0,0,0,1), else MATRIX_GENERAL / PERSPECTIVE.
    if !(zero(3) && zero(7) && zero(11) && m(15) == 1.0) {
        return false;
    }
    let identity_like = (0..16).all(|i| {
        let diag = i % 5 == 0;
        if diag {
            m(i) == 1.0
        } else {
            zero(i)
        }
    });
    if identity_like {
        return true;
    }
    let no_z = zero(2) && zero(6) && zero(8) && zero(9) && m(10) == 1.0 && zero(14);
    if no_z && zero(1) && zero(4) {
        // MATRIX_2D_NO_ROT: scaled unless m0 == m5 == 1.
        return m(0) == 1.0 && m(5) == 1.0;
    }
    if no_z {
        // MATRIX_2D
        let mm0 = m(0) * m(0) + m(1) * m(1);
        let m4m4 = m(4) * m(4) + m(5) * m(5);
        let mm4 = m(0) * m(4) + m(1) * m(5);
        let scaled = sq(mm0 - 1.0) > tol || sq(m4m4 - 1.0) > tol;
        let general = sq(mm4) > tol;
        return !scaled && !general;
    }
    if zero(1) && zero(2) && zero(4) && zero(6) && zero(8) && zero(9) {
        // MATRIX_3D_NO_ROT: length preserving only with no scale at all.
        let uniform = sq(m(0) - m(5)) < tol && sq(m(0) - m(10)) < tol;
        return uniform && !(sq(m(0) - 1.0) > tol);
    }
    // MATRIX_3D
    let col = |c: usize| [m(4 * c), m(4 * c + 1), m(4 * c + 2)];
    let (a, b, c) = (col(0), col(1), col(2));
    let dot = |u: [f32; 3], v: [f32; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
    let (c1, c2, c3, d1) = (dot(a, a), dot(b, b), dot(c, c), dot(a, b));
    let uniform = sq(c1 - c2) < tol && sq(c1 - c3) < tol;
    let scaled = !uniform || sq(c1 - 1.0) > tol;
    if scaled || !(sq(d1) < tol) {
        return false;
    }
    let cp = [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ];
    let e = [cp[0] - c[0], cp[1] - c[1], cp[2] - c[2]];
    dot(e, e) < tol
}

/// Vertex attribute storage accepted by the texgen kernels: f32 or f64, read as f32 (as GL
/// converts `glVertex3d` input).
pub trait Elem: Copy + Send + Sync + 'static {
    fn f32(self) -> f32;
    fn f64(self) -> f64;
}
impl Elem for f32 {
    #[inline(always)]
    fn f32(self) -> f32 {
        self
    }
    #[inline(always)]
    fn f64(self) -> f64 {
        self as f64
    }
}
impl Elem for f64 {
    #[inline(always)]
    fn f32(self) -> f32 {
        self as f32
    }
    #[inline(always)]
    fn f64(self) -> f64 {
        self
    }
}

/// Options of one texgen call.
#[derive(Clone, Copy, Debug, Default)]
pub struct TexgenOptions {
    pub normalize: NormalMode,
    pub singular: Singular,
}

fn check_lengths(
    positions_len: usize,
    pw: usize,
    normals_len: usize,
    out_len: usize,
) -> Result<usize> {
    if pw != 3 && pw != 4 {
        return Err(Error::param(
            "positions",
            format!("must have 3 or 4 components per vertex, not {pw}"),
        ));
    }
    if positions_len % pw != 0 {
        return Err(Error::param(
            "positions",
            format!("length {positions_len} is not a multiple of {pw}"),
        ));
    }
    let n = positions_len / pw;
    if normals_len != 3 * n {
        return Err(Error::param(
            "normals",
            format!("must hold {n} normals (3 values each), got {normals_len} values"),
        ));
    }
    if out_len != 2 * n {
        return Err(Error::param(
            "out",
            format!("must hold {} values, got {out_len}", 2 * n),
        ));
    }
    Ok(n)
}

/// Vertices per block: the kernel gathers a block into structure-of-arrays form, then runs the
/// arithmetic as straight-line loops that the compiler vectorises.
const BLOCK: usize = 64;
/// Vertices per parallel task.
const TASK: usize = 64 * 1024;

/// GL_SPHERE_MAP texgen, float32 (what GL computes).
///
/// `positions`: `pw` (3 or 4) values per vertex, interleaved; `normals`: 3 per vertex;
/// `out`: 2 per vertex, (s,t).  Runs in parallel for large inputs.
pub fn sphere_texgen<P: Elem, N: Elem>(
    positions: &[P],
    pw: usize,
    normals: &[N],
    mv: &ModelviewState,
    opts: TexgenOptions,
    out: &mut [f32],
) -> Result<()> {
    let n = check_lengths(positions.len(), pw, normals.len(), out.len())?;
    // GL stores the modelview in float32 and derives the normal matrix and the rescale factor
    // from that: do the same, so a float64 matrix and its float32 rounding give the same result.
    let gl_mv = ModelviewState::new(mv.m.map(|r| r.map(|v| v as f32 as f64)))?;
    let k = Kernel::new(&gl_mv, opts);
    let run = |first: usize, out: &mut [f32]| {
        let count = out.len() / 2;
        let pos = &positions[first * pw..(first + count) * pw];
        let nrm = &normals[first * 3..(first + count) * 3];
        if pw == 3 {
            k.dispatch::<P, N, 3>(pos, nrm, out)
        } else {
            k.dispatch::<P, N, 4>(pos, nrm, out)
        }
    };
    if n < 2 * TASK {
        run(0, out);
    } else {
        out.par_chunks_mut(2 * TASK)
            .enumerate()
            .for_each(|(i, o)| run(i * TASK, o));
    }
    Ok(())
}

/// De-interleaves `len` vertices (positions of `PW` values, normals of 3) into
/// structure-of-arrays rows, as f32.
#[inline(always)]
fn gather<P: Elem, N: Elem, const PW: usize>(
    pos: &[P],
    nrm: &[N],
    p: &mut [[f32; BLOCK]; 4],
    n: &mut [[f32; BLOCK]; 3],
    len: usize,
) {
    let (pos, nrm) = (&pos[..len * PW], &nrm[..len * 3]);
    for i in 0..len.min(BLOCK) {
        for c in 0..PW {
            p[c][i] = pos[i * PW + c].f32();
        }
        for c in 0..3 {
            n[c][i] = nrm[i * 3 + c].f32();
        }
    }
}

/// The interleaved (s,t) of one block, aligned for streaming stores.
#[repr(align(16))]
struct Aligned16([f32; 2 * BLOCK]);

/// The output is written with non-temporal (streaming) stores where it is 16-byte aligned: the
/// result is not read back here, and streaming skips the read-for-ownership of every output
/// line (8 of the 40 MB a 1M-vertex call moves).
#[inline(always)]
fn stream_store_ok(out: &[f32]) -> bool {
    cfg!(target_arch = "x86_64") && (out.as_ptr() as usize) % 16 == 0
}

#[inline(always)]
fn stream_store(src: &[f32; 2 * BLOCK], out: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    {
        assert!(out.len() == 2 * BLOCK);
        for j in (0..2 * BLOCK).step_by(4) {
            // SAFETY: `out` holds 2·BLOCK floats and is 16-byte aligned (stream_store_ok), `src`
            // is 16-byte aligned (Aligned16); SSE is part of x86-64.
            unsafe {
                let v = core::arch::x86_64::_mm_load_ps(src.as_ptr().add(j));
                core::arch::x86_64::_mm_stream_ps(out.as_mut_ptr().add(j), v);
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    out.copy_from_slice(src);
}

/// Orders the streaming stores before anything that follows (the thread's return).
#[inline(always)]
fn stream_fence() {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a store fence has no preconditions.
    unsafe {
        core::arch::x86_64::_mm_sfence()
    };
}

/// GL's `RSQ` in float32: `1/√x`, correctly rounded square root then division (llvmpipe
/// computes the same).  `x = 0` → ∞, so `0·rsq(0)` is NaN as in Mesa; legacy `CENTER` mode
/// (t_vb_texgen.c) gives 0 instead, which also turns m = 0 into (½,½).
#[inline(always)]
pub fn rsq_f32<const CENTER: bool>(x: f32) -> f32 {
    let r = 1.0 / x.sqrt();
    if CENTER && x == 0.0 {
        0.0
    } else {
        r
    }
}

/// The per-call constants of the f32 kernel.
#[derive(Clone, Copy)]
struct Kernel {
    m: [[f32; 4]; 3],
    nm: [[f32; 3]; 3],
    normalize: bool,
    scale: f32,
    center: bool,
}

// The kernel indexes its fixed-size scratch arrays with plain counted loops on purpose: that is
// the shape the vectoriser turns into straight SIMD code.
#[allow(clippy::needless_range_loop)]
impl Kernel {
    fn new(mv: &ModelviewState, opts: TexgenOptions) -> Self {
        let m: [[f32; 4]; 3] = std::array::from_fn(|i| mv.m[i].map(|v| v as f32));
        let nm: [[f32; 3]; 3] = mv.normal_matrix.map(|row| row.map(|v| v as f32));
        let (normalize, scale) = match opts.normalize {
            NormalMode::On => (true, 1.0),
            NormalMode::Off => (false, 1.0),
            NormalMode::Rescale => (false, mv.rescale as f32),
        };
        Kernel {
            m,
            nm,
            normalize,
            scale,
            center: opts.singular == Singular::Center,
        }
    }

    fn dispatch<P: Elem, N: Elem, const PW: usize>(&self, pos: &[P], nrm: &[N], out: &mut [f32]) {
        // The two flags become constants of the inner loop (no per-vertex test).
        match (self.normalize, self.center) {
            (false, false) => self.dispatch_isa::<P, N, PW, false, false>(pos, nrm, out),
            (false, true) => self.dispatch_isa::<P, N, PW, false, true>(pos, nrm, out),
            (true, false) => self.dispatch_isa::<P, N, PW, true, false>(pos, nrm, out),
            (true, true) => self.dispatch_isa::<P, N, PW, true, true>(pos, nrm, out),
        }
    }

    fn dispatch_isa<P: Elem, N: Elem, const PW: usize, const NORM: bool, const CENTER: bool>(
        &self,
        pos: &[P],
        nrm: &[N],
        out: &mut [f32],
    ) {
        #[cfg(target_arch = "x86_64")]
        {
            use crate::base::cpu::{simd, Simd};
            match simd() {
                // SAFETY: the CPU supports AVX-512F (`simd` detected it).
                Simd::Avx512 => unsafe { self.run_avx512::<P, N, PW, NORM, CENTER>(pos, nrm, out) },
                // SAFETY: the CPU supports AVX2 (`simd` detected it).  No FMA is used (Rust never
                // contracts a*b+c on its own), so every path gives bit-identical results.
                Simd::Avx2 => unsafe { self.run_avx2::<P, N, PW, NORM, CENTER>(pos, nrm, out) },
                Simd::Portable => self.run::<P, N, PW, NORM, CENTER>(pos, nrm, out),
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.run::<P, N, PW, NORM, CENTER>(pos, nrm, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn run_avx2<P: Elem, N: Elem, const PW: usize, const NORM: bool, const CENTER: bool>(
        &self,
        pos: &[P],
        nrm: &[N],
        out: &mut [f32],
    ) {
        self.run::<P, N, PW, NORM, CENTER>(pos, nrm, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn run_avx512<
        P: Elem,
        N: Elem,
        const PW: usize,
        const NORM: bool,
        const CENTER: bool,
    >(
        &self,
        pos: &[P],
        nrm: &[N],
        out: &mut [f32],
    ) {
        self.run::<P, N, PW, NORM, CENTER>(pos, nrm, out)
    }

    #[inline(always)]
    fn run<P: Elem, N: Elem, const PW: usize, const NORM: bool, const CENTER: bool>(
        &self,
        pos: &[P],
        nrm: &[N],
        out: &mut [f32],
    ) {
        let count = out.len() / 2;
        // Scratch in structure-of-arrays form, initialised once per call: w stays 1 when the
        // positions have 3 components; lanes past the end of a short last block hold stale but
        // finite-or-not values whose results are never stored.
        let mut p = [[1.0f32; BLOCK]; 4];
        let mut n = [[0.0f32; BLOCK]; 3];
        let mut st = [[0.0f32; BLOCK]; 2];
        let mut inter = Aligned16([0.0f32; 2 * BLOCK]);
        let mut start = 0;
        while start < count {
            let len = BLOCK.min(count - start);
            let (pos, nrm) = (
                &pos[start * PW..(start + len) * PW],
                &nrm[start * 3..(start + len) * 3],
            );
            if len == BLOCK {
                // A constant trip count: the de-interleave vectorises with no scalar epilogue.
                gather::<P, N, PW>(pos, nrm, &mut p, &mut n, BLOCK);
            } else {
                gather::<P, N, PW>(pos, nrm, &mut p, &mut n, len);
            }
            self.block::<NORM, CENTER, PW>(&p, &n, &mut st);
            let out = &mut out[start * 2..(start + len) * 2];
            if len == BLOCK && stream_store_ok(out) {
                for i in 0..BLOCK {
                    inter.0[2 * i] = st[0][i];
                    inter.0[2 * i + 1] = st[1][i];
                }
                stream_store(&inter.0, out);
            } else {
                for i in 0..len {
                    out[2 * i] = st[0][i];
                    out[2 * i + 1] = st[1][i];
                }
            }
            start += len;
        }
        stream_fence();
    }

    /// The arithmetic of one block: GL's formula, rearranged to need two square roots instead of
    /// three (they and the divisions are most of the cost).
    ///
    /// With `u = e/√a` (`a = e·e`) and `n = n'·κ` (κ = rsq(n'·n') for GL_NORMALIZE, the rescale
    /// factor, or 1), `r = u − 2(n·u)n = R/√a` with `R = e − 2κ²(n'·e) n'`.  Then
    /// `m = 2|r + ẑ| = 2√(R_x² + R_y² + (R_z + √a)²)/√a`, and the √a cancels in `r_x/m`:
    ///
    /// ```text
    /// s = ½ R_x / √Q + ½,   t = ½ R_y / √Q + ½,   Q = R_x² + R_y² + (R_z + √a)²
    /// ```
    ///
    /// For GL_NORMALIZE (κ² = 1/b, b = n'·n') the same holds for `b·R = b e − 2(n'·e) n'` with
    /// `√a` replaced by `b√a`: b cancels as √a did, so no division is needed for it.  Per vertex:
    /// two square roots and one division, instead of three of each.
    ///
    /// Special values fall out as in GL: a vertex at the eye gives R = 0, Q = 0, `0·∞` = NaN; a
    /// zero normal with GL_NORMALIZE gives b = 0, bR = 0, Q = 0, NaN (Mesa: `0·rsq(0)` = NaN);
    /// r = (0,0,−1) gives Q = 0 exactly.  Legacy ("center") mode turns a zero normal into
    /// R = e (r = u) and Q = 0 into (½,½), as legacy Mesa.  Against GL's own order of operations
    /// the result differs by rounding only (the Mesa oracle test bounds it) — except for
    /// transformed normals longer than ~1e19 with GL_NORMALIZE, where `b` overflows (GL's
    /// `rsq(∞) = 0` makes such a normal zero; here the result is NaN).
    #[inline(always)]
    fn block<const NORM: bool, const CENTER: bool, const PW: usize>(
        &self,
        p: &[[f32; BLOCK]; 4],
        n: &[[f32; BLOCK]; 3],
        st: &mut [[f32; BLOCK]; 2],
    ) {
        let (m, nm) = (&self.m, &self.nm);
        let scale2 = self.scale * self.scale;
        for i in 0..BLOCK {
            let (x, y, z) = (p[0][i], p[1][i], p[2][i]);
            // With 3-component positions w = 1 and m·w = m exactly: skip the multiply.
            let wt = |r: usize| if PW == 4 { m[r][3] * p[3][i] } else { m[r][3] };
            let ex = m[0][0] * x + m[0][1] * y + m[0][2] * z + wt(0);
            let ey = m[1][0] * x + m[1][1] * y + m[1][2] * z + wt(1);
            let ez = m[2][0] * x + m[2][1] * y + m[2][2] * z + wt(2);
            let sa = (ex * ex + ey * ey + ez * ez).sqrt();
            let (ox, oy, oz) = (n[0][i], n[1][i], n[2][i]);
            let nx = nm[0][0] * ox + nm[0][1] * oy + nm[0][2] * oz;
            let ny = nm[1][0] * ox + nm[1][1] * oy + nm[1][2] * oz;
            let nz = nm[2][0] * ox + nm[2][1] * oy + nm[2][2] * oz;
            let ne = nx * ex + ny * ey + nz * ez;
            // GL_NORMALIZE: scale R by b = n'·n' (κ² = 1/b), which cancels in s: no division.
            let (bb, f) = if NORM {
                let b = nx * nx + ny * ny + nz * nz;
                // Legacy Mesa normalizes a zero normal to zero: r = u, i.e. R = e.
                (if CENTER && b == 0.0 { 1.0 } else { b }, 2.0 * ne)
            } else {
                (1.0, 2.0 * scale2 * ne)
            };
            let rx = bb * ex - f * nx;
            let ry = bb * ey - f * ny;
            let rz = bb * ez - f * nz;
            let az = rz + bb * sa;
            let q = rx * rx + ry * ry + az * az;
            let k = rsq_f32::<CENTER>(q) * 0.5;
            st[0][i] = rx * k + 0.5;
            st[1][i] = ry * k + 0.5;
        }
    }
}

/// GL_SPHERE_MAP texgen, float64 reference: GL's operations in GL's order (the formula in the
/// module docs), in double precision, on the input values as given.
pub fn sphere_texgen_f64<P: Elem, N: Elem>(
    positions: &[P],
    pw: usize,
    normals: &[N],
    mv: &ModelviewState,
    opts: TexgenOptions,
    out: &mut [f64],
) -> Result<()> {
    let n = check_lengths(positions.len(), pw, normals.len(), out.len())?;
    let center = opts.singular == Singular::Center;
    let rsq = |x: f64| {
        if center && x == 0.0 {
            0.0
        } else {
            1.0 / x.sqrt()
        }
    };
    let (m, nm) = (&mv.m, &mv.normal_matrix);
    for i in 0..n {
        let pv = |c: usize| {
            if c < pw {
                positions[i * pw + c].f64()
            } else {
                1.0
            }
        };
        let (x, y, z, w) = (pv(0), pv(1), pv(2), pv(3));
        let e: [f64; 3] =
            std::array::from_fn(|r| m[r][0] * x + m[r][1] * y + m[r][2] * z + m[r][3] * w);
        let ku = rsq(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
        let u = [e[0] * ku, e[1] * ku, e[2] * ku];
        let o = [
            normals[3 * i].f64(),
            normals[3 * i + 1].f64(),
            normals[3 * i + 2].f64(),
        ];
        let mut nv: [f64; 3] =
            std::array::from_fn(|r| nm[r][0] * o[0] + nm[r][1] * o[1] + nm[r][2] * o[2]);
        let kn = match opts.normalize {
            NormalMode::On => rsq(nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2]),
            NormalMode::Off => 1.0,
            NormalMode::Rescale => mv.rescale,
        };
        nv.iter_mut().for_each(|v| *v *= kn);
        let r = crate::mappings::sphere::reflect(u, nv);
        let az = r[2] + 1.0;
        let k = rsq(r[0] * r[0] + r[1] * r[1] + az * az) * 0.5;
        out[2 * i] = r[0] * k + 0.5;
        out[2 * i + 1] = r[1] * k + 0.5;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SIMD paths (AVX-512/AVX2, chosen at run time) and the portable path give the same
    /// bits: only IEEE operations, no FMA.
    #[test]
    fn simd_and_portable_paths_are_bit_identical() {
        let mut x = 0x2545F4914F6CDD1Du64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 40) as f32 / (1u64 << 24) as f32 * 4.0 - 2.0
        };
        let n = 1000; // 15 full blocks and a tail
        let pos: Vec<f32> = (0..4 * n).map(|_| next()).collect();
        let nrm: Vec<f32> = (0..3 * n).map(|_| next()).collect();
        let m = [
            [0.9, 0.1, 0.0, 0.2],
            [-0.1, 0.9, 0.2, 0.0],
            [0.0, -0.2, 1.1, -5.0],
            [0.0, 0.0, 0.0, 1.0],
        ];
        let mv = ModelviewState::new(m).unwrap();
        for normalize in [NormalMode::On, NormalMode::Off, NormalMode::Rescale] {
            for singular in [Singular::Nan, Singular::Center] {
                let k = Kernel::new(
                    &mv,
                    TexgenOptions {
                        normalize,
                        singular,
                    },
                );
                let (mut a, mut b) = (vec![0.0f32; 2 * n], vec![0.0f32; 2 * n]);
                k.dispatch::<f32, f32, 4>(&pos, &nrm, &mut a);
                match (k.normalize, k.center) {
                    (false, false) => k.run::<f32, f32, 4, false, false>(&pos, &nrm, &mut b),
                    (false, true) => k.run::<f32, f32, 4, false, true>(&pos, &nrm, &mut b),
                    (true, false) => k.run::<f32, f32, 4, true, false>(&pos, &nrm, &mut b),
                    (true, true) => k.run::<f32, f32, 4, true, true>(&pos, &nrm, &mut b),
                }
                let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&a), bits(&b), "{normalize:?} {singular:?}");
            }
        }
    }

    #[test]
    fn rsq_special_values() {
        assert_eq!(rsq_f32::<false>(0.0), f32::INFINITY);
        assert_eq!(rsq_f32::<true>(0.0), 0.0);
        assert_eq!(rsq_f32::<false>(4.0), 0.5);
        assert!(rsq_f32::<false>(f32::NAN).is_nan());
    }

    #[test]
    fn mesa_length_preserving_classification() {
        let rot = |a: f64| {
            [
                [a.cos(), -a.sin(), 0.0, 1.0],
                [a.sin(), a.cos(), 0.0, 2.0],
                [0.0, 0.0, 1.0, 3.0],
                [0.0, 0.0, 0.0, 1.0],
            ]
        };
        assert!(mesa_length_preserving(&IDENTITY4));
        assert!(mesa_length_preserving(&rot(0.3)));
        let mut s = rot(0.3);
        s[0][0] *= 2.0;
        assert!(!mesa_length_preserving(&s));
        // Uniform scale is not length preserving; a projective bottom row is "general".
        let mut u = IDENTITY4;
        (0..3).for_each(|i| u[i][i] = 2.0);
        assert!(!mesa_length_preserving(&u));
        let mut g = IDENTITY4;
        g[3][2] = -1.0;
        assert!(!mesa_length_preserving(&g));
        // A 3D rotation about an oblique axis.
        let (c, s_) = (0.6f64, 0.8f64);
        let r3 = [
            [c, 0.0, s_, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [-s_, 0.0, c, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ];
        assert!(mesa_length_preserving(&r3));
        // A mirror is not (Mesa's rotation test checks col0 × col1 = col2).
        let mut mirror = IDENTITY4;
        mirror[0][0] = -1.0;
        mirror[1][1] = 0.5;
        assert!(!mesa_length_preserving(&mirror));
    }

    #[test]
    fn singular_modelview_uses_identity() {
        let mut m = IDENTITY4;
        m[1][1] = 0.0;
        let st = ModelviewState::new(m).unwrap();
        assert!(st.singular);
        assert_eq!(
            st.normal_matrix,
            [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        );
        let mut bad = IDENTITY4;
        bad[0][1] = f64::NAN;
        assert!(ModelviewState::new(bad)
            .unwrap_err()
            .to_string()
            .starts_with("modelview:"));
    }
}
