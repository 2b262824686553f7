//! The gathers of the filtered f32 path: a texel's samples, already turned into tap indices
//! and bilinear fractions at the level they read (pass 2b), summed into its value.
//!
//! Three ways, fastest first:
//! - [`sum8`]: AVX2 + FMA, for 3 or 4 channels.  One 8-lane load per tap row holds both taps
//!   of that row (`[r₀ g₀ b₀ r₁ g₁ b₁ · ·]` for RGB), so a sample is two loads and four
//!   vector operations: `m = top + ay·(bottom − top)` per column, then
//!   `acc += x·m` with `x = [wl·(1−ax) ×C, wl·ax ×C, 0 …]` from one FMA.  The left and right
//!   columns are added at the end.  Four accumulators, so no sample waits on the previous.
//!   [`mean8`] runs it over a whole run of texels that read level 0 only (the common case),
//!   with no per-texel decisions.
//! - [`gather0`]: SSE (x86-64's baseline), level 0 and unit weights only: one 4-lane
//!   vector per tap.
//! - [`level_lookup`]: any lane, scalar; the general `Src::lookup` where pass 2b gave `SLOW`.

use super::lanes::Lanes;
use super::rows::{bilerp, bilerp4, prefetch, vec4_limit, SLOW};
use super::source::Src;
use crate::base::cpu::{simd, Simd};

/// Whether this CPU runs [`sum8`] (AVX2 and FMA, not turned off: see [`simd`]); checked
/// once per row by the callers.
#[inline]
pub(crate) fn has_avx2() -> bool {
    simd() != Simd::Portable
}

/// A texel's running sum: channel c in `s[c]`, plus (after [`sum_level`] with AVX) in lanes
/// c and C + c of `v` (the left and right tap columns).
#[derive(Clone, Copy)]
pub(crate) struct Acc<const C: usize> {
    pub(crate) s: [f32; C],
    #[cfg(target_arch = "x86_64")]
    v: std::arch::x86_64::__m256,
}

impl<const C: usize> Acc<C> {
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Acc {
            s: [0.0; C],
            // SAFETY: all-zero bits are a valid __m256 (eight 0.0).  (Not `_mm256_setzero_ps`:
            // that is an AVX instruction, and this also runs where AVX is not enabled.)
            #[cfg(target_arch = "x86_64")]
            v: unsafe { std::mem::zeroed() },
        }
    }

    /// The sum times `k`, per channel.  `AVX`: the caller is compiled for AVX2.
    #[inline(always)]
    pub(crate) fn scaled<const AVX: bool>(&self, k: f32) -> [f32; C] {
        #[cfg(target_arch = "x86_64")]
        if AVX && (C == 3 || C == 4) {
            use std::arch::x86_64::*;
            // SAFETY: AVX2 is enabled in the caller (AVX).
            let v = unsafe {
                // Lanes C.. onto lanes 0.. (a lane-crossing permute), then the first four.
                let c = C as i32;
                let right = _mm256_setr_epi32(c, c + 1, c + 2, c + 3, 0, 0, 0, 0);
                let sum = _mm256_add_ps(self.v, _mm256_permutevar8x32_ps(self.v, right));
                std::mem::transmute::<__m128, [f32; 4]>(_mm256_castps256_ps128(sum))
            };
            return std::array::from_fn(|c| (v[c] + self.s[c]) * k);
        }
        self.s.map(|v| v * k)
    }
}

/// Samples `range` of a texel at level `k` (`s`), weighted by `wl`, added to `acc`: its tap
/// indices `idx` and fractions `ax`, `ay` from pass 2b at that level, its level-0 positions
/// `p` for the lanes that take the general path.  With `AVX` (the caller is compiled for
/// AVX2 and FMA: see `filtered::gather_avx2`) and C = 3 or 4, [`sum8`] when all the lanes
/// are plain; otherwise one by one ([`level_lookup`]).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn sum_level<const C: usize, const AVX: bool>(
    s: &Src<f32>,
    k: usize,
    p: &[Lanes<f32>; 2],
    idx: &[u32],
    ax: &[f32],
    ay: &[f32],
    range: std::ops::Range<usize>,
    wl: f32,
    acc: &mut Acc<C>,
) {
    #[cfg(target_arch = "x86_64")]
    if AVX && (C == 3 || C == 4) {
        let row = s.w * C;
        // A lane is plain when both its 8-value reads end inside the data; the largest
        // index decides (SLOW is larger than any plain one).
        let lim = s
            .data
            .len()
            .checked_sub(row + 8)
            .map(|l| l.min(SLOW as usize - 1));
        let (i, x, y) = (&idx[range.clone()], &ax[range.clone()], &ay[range.clone()]);
        if lim.is_some_and(|l| i.iter().fold(0, |m, &v| m.max(v)) as usize <= l) {
            // SAFETY: AVX2 and FMA are enabled in the caller (AVX); every lane's two 8-value
            // reads end inside the data (checked just above).
            acc.v = unsafe { sum8::<C>(s.data, row, i, x, y, wl, acc.v) };
            return;
        }
    }
    for q in range {
        let pq = [p[0][q], p[1][q]];
        level_lookup::<C>(s, k, pq, idx[q], ax[q], ay[q], wl, &mut acc.s);
    }
}

/// `acc` + Σ wl·bilerp over the lanes, as 8 lanes: channel c of the left taps' column in
/// lane c, of the right ones' in lane C + c.
///
/// # Safety
/// The CPU has AVX2 and FMA; every `idx[q] + row + 8 ≤ data.len()`.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn sum8<const C: usize>(
    data: &[f32],
    row: usize,
    idx: &[u32],
    ax: &[f32],
    ay: &[f32],
    wl: f32,
    acc: std::arch::x86_64::__m256,
) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::*;
    debug_assert!(C == 3 || C == 4);
    let n = idx.len().min(ax.len()).min(ay.len());
    let d = data.as_ptr();
    // x = ax·sx + tx = [wl(1 − ax) ×C, wl·ax ×C, 0 …].
    let (sx, tx) = if C == 3 {
        (
            _mm256_setr_ps(-1.0, -1.0, -1.0, 1.0, 1.0, 1.0, 0.0, 0.0),
            _mm256_setr_ps(1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0),
        )
    } else {
        (
            _mm256_setr_ps(-1.0, -1.0, -1.0, -1.0, 1.0, 1.0, 1.0, 1.0),
            _mm256_setr_ps(1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0),
        )
    };
    let w = _mm256_set1_ps(wl);
    let (sx, tx) = (_mm256_mul_ps(sx, w), _mm256_mul_ps(tx, w));
    let one = |q: usize, acc: __m256| {
        let i = *idx.get_unchecked(q) as usize;
        let x = _mm256_fmadd_ps(_mm256_set1_ps(*ax.get_unchecked(q)), sx, tx);
        let top = _mm256_loadu_ps(d.add(i));
        let bot = _mm256_loadu_ps(d.add(i + row));
        let m = _mm256_fmadd_ps(
            _mm256_set1_ps(*ay.get_unchecked(q)),
            _mm256_sub_ps(bot, top),
            top,
        );
        _mm256_fmadd_ps(x, m, acc)
    };
    let z = _mm256_setzero_ps();
    let (mut a0, mut a1, mut a2, mut a3) = (acc, z, z, z);
    let mut q = 0;
    while q + 4 <= n {
        a0 = one(q, a0);
        a1 = one(q + 1, a1);
        a2 = one(q + 2, a2);
        a3 = one(q + 3, a3);
        q += 4;
    }
    while q < n {
        a0 = one(q, a0);
        q += 1;
    }
    _mm256_add_ps(_mm256_add_ps(a0, a1), _mm256_add_ps(a2, a3))
}

/// The mean of each texel's `n` consecutive samples (level 0, unit weights), for the
/// `out.len() / C` texels of a chunk whose samples all read level 0 through plain lanes
/// (`idx[..]` + row + 8 ≤ data.len(), checked by the caller) — the common case, without
/// any per-texel decision.  Prefetches the source lines `ahead` texels on.
///
/// # Safety
/// The CPU has AVX2 and FMA; C is 3 or 4; `idx`, `ax`, `ay` hold `n · out.len() / C`
/// lanes, each with `idx[q] + row + 8 ≤ data.len()`.
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) unsafe fn mean8<const C: usize>(
    data: &[f32],
    row: usize,
    idx: &[u32],
    ax: &[f32],
    ay: &[f32],
    n: usize,
    ahead: usize,
    out: &mut [std::mem::MaybeUninit<f32>],
) {
    use std::arch::x86_64::*;
    let cnt = out.len() / C;
    debug_assert!(idx.len() >= n * cnt && ax.len() >= n * cnt && ay.len() >= n * cnt);
    let k = 1.0 / n as f32;
    for (t, px) in out.chunks_exact_mut(C).enumerate() {
        let b = t * n;
        for q in [b + ahead * n, b + ahead * n + n / 2] {
            if let Some(&j) = idx.get(q) {
                prefetch::<C>(data, row, j);
            }
        }
        let r = b..b + n;
        let (i, x, y) = (&idx[r.clone()], &ax[r.clone()], &ay[r]);
        let acc = Acc::<C> {
            s: [0.0; C],
            v: sum8::<C>(data, row, i, x, y, 1.0, _mm256_setzero_ps()),
        };
        let v = acc.scaled::<true>(k);
        for ch in 0..C {
            px[ch].write(v[ch]);
        }
    }
}

/// A level's taps for [`mean8_levels`]: its data and row length, and pass 2b's tap indices
/// and fractions there for a run of texels' samples.
#[derive(Clone, Copy)]
pub(crate) struct LevelTaps<'a> {
    pub(crate) data: &'a [f32],
    pub(crate) row: usize,
    pub(crate) idx: &'a [u32],
    pub(crate) ax: &'a [f32],
    pub(crate) ay: &'a [f32],
}

impl LevelTaps<'_> {
    /// Every lane is plain: both its 8-value reads end inside the data (the largest index
    /// decides; SLOW is larger than any plain one).
    #[inline(always)]
    pub(crate) fn plain(&self) -> bool {
        let lim = self.data.len().checked_sub(self.row + 8);
        let top = self.idx.iter().fold(0, |m, &v| m.max(v)) as usize;
        lim.is_some_and(|l| top <= l.min(SLOW as usize - 1))
    }
}

/// The filtered value of each texel of a run that reads two levels (`hi`: none when the
/// texels read `lo` alone) at per-texel weights `1 − fr[t]` and `fr[t]`, with unit sample
/// weights: [`mean8`] for texels whose footprint reaches the levels — the same sums as
/// [`sum_level`] makes for them one texel at a time, without its per-texel decisions.
///
/// # Safety
/// The CPU has AVX2 and FMA; C is 3 or 4; `lo` (and `hi`) hold `n · out.len() / C` lanes,
/// all plain ([`LevelTaps::plain`]); `fr` has a weight per texel.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) unsafe fn mean8_levels<const C: usize>(
    lo: LevelTaps,
    hi: Option<LevelTaps>,
    fr: &[f32],
    n: usize,
    out: &mut [std::mem::MaybeUninit<f32>],
) {
    use std::arch::x86_64::*;
    let k = 1.0 / n as f32;
    for (t, px) in out.chunks_exact_mut(C).enumerate() {
        let r = t * n..(t + 1) * n;
        let f = fr[t];
        // (No closure here: a closure would not be compiled for the caller's AVX2.)
        let (i, x, y) = (&lo.idx[r.clone()], &lo.ax[r.clone()], &lo.ay[r.clone()]);
        let mut v = sum8::<C>(lo.data, lo.row, i, x, y, 1.0 - f, _mm256_setzero_ps());
        if let Some(h) = &hi {
            let (i, x, y) = (&h.idx[r.clone()], &h.ax[r.clone()], &h.ay[r.clone()]);
            v = sum8::<C>(h.data, h.row, i, x, y, f, v);
        }
        let acc = Acc::<C> { s: [0.0; C], v };
        let v = acc.scaled::<true>(k);
        for ch in 0..C {
            px[ch].write(v[ch]);
        }
    }
}

/// The sum of samples `b..b + n` (level 0, unit weights) into `acc`.  (No software
/// prefetch: a texel's samples share their cache lines, and the texels follow each other
/// along the source closely enough for the hardware's prefetcher; measured no faster.)
#[inline(always)]
pub(crate) fn gather0<const C: usize>(
    s: &Src<f32>,
    p: &[Lanes<f32>; 2],
    idx: &[u32],
    frac: &[Lanes<f32>; 2],
    b: usize,
    n: usize,
    acc: &mut [f32; C],
) {
    let (data, row) = (s.data, s.w * C);
    if C == 3 || C == 4 {
        // A texel's channels as one 4-lane vector (for C = 3 the lane after its blue is the
        // next texel's red, unused): 4 loads and 6 vector operations per lookup.  The last
        // lookups of the data would read one value past its end; they go the scalar way.
        let lim = vec4_limit::<C>(data.len(), row);
        let mut a4 = [0.0f32; 4];
        for q in b..b + n {
            let i00 = idx[q];
            if lim.is_some_and(|l| i00 <= l) {
                let v = bilerp4::<C>(data, row, i00 as usize, frac[0][q], frac[1][q]);
                for c in 0..4 {
                    a4[c] += v[c];
                }
            } else {
                let (ax, ay) = (frac[0][q], frac[1][q]);
                level_lookup::<C>(s, 0, [p[0][q], p[1][q]], i00, ax, ay, 1.0, acc);
            }
        }
        for c in 0..C {
            acc[c] += a4[c];
        }
        return;
    }
    for q in b..b + n {
        let (ax, ay) = (frac[0][q], frac[1][q]);
        level_lookup::<C>(s, 0, [p[0][q], p[1][q]], idx[q], ax, ay, 1.0, acc);
    }
}

/// A bilinear lookup at level `k` (`i00`, `ax`, `ay` from pass 2b there; level-0 position
/// `p` for the general path), weighted into `acc`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn level_lookup<const C: usize>(
    s: &Src<f32>,
    k: usize,
    p: [f32; 2],
    i00: u32,
    ax: f32,
    ay: f32,
    wt: f32,
    acc: &mut [f32; C],
) {
    if i00 == SLOW {
        let sc = 1.0 / (1u32 << k) as f32;
        s.lookup([p[0] * sc, p[1] * sc], wt, acc);
    } else if vec4_limit::<C>(s.data.len(), s.w * C).is_some_and(|l| i00 <= l) {
        let v = bilerp4::<C>(s.data, s.w * C, i00 as usize, ax, ay);
        for c in 0..C {
            acc[c] += wt * v[c];
        }
    } else {
        let v = bilerp::<C>(s.data, s.w * C, i00, ax, ay);
        for c in 0..C {
            acc[c] += wt * v[c];
        }
    }
}
