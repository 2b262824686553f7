//! The samples' jitter: a hash of the seed, the texel and the stratum, mirror-symmetric about
//! the canvas's centre lines, and the strata grid a sample count gives.

/// Where the jitter of sample (i, j) of texel (x, y), on its nx×ny strata of a w×h canvas,
/// comes from: the pattern is mirror-symmetric about the canvas's centre lines.  A texel in
/// the right half (x > w − 1 − x) takes the jitter of its mirror image w − 1 − x, stratum
/// nx − 1 − i, reflected (1 − jx); one in the bottom half likewise in y.  So texels that
/// mirror each other have mirror-image samples, and where the canvas's mirrors are folds of
/// the source ([`super::rows::Fold`]: the default view) the filtered path computes a quarter of its
/// samples' positions and folds the rest.  The pattern loses nothing by it: each quadrant's
/// jitter is independent per texel and stratum, as before.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Mirror {
    /// The hash's texel and stratum index (`jc·nx + ic`).
    pub(crate) xc: u32,
    pub(crate) yc: u32,
    pub(crate) kc: u32,
    /// The jitter is reflected in x / in y.
    pub(crate) mx: bool,
    pub(crate) my: bool,
}

/// [`Mirror`] of sample (i, j) of texel (x, y) on nx×ny strata of a w×h canvas.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn mirror(x: u32, y: u32, i: u32, j: u32, nx: u32, ny: u32, w: u32, h: u32) -> Mirror {
    // (x > w − 1 − x without underflow; the middle texel of an odd w is its own image.)
    let (mx, my) = (2 * x + 1 > w, 2 * y + 1 > h);
    let (xc, ic) = if mx {
        (
            w.wrapping_sub(1).wrapping_sub(x),
            nx.wrapping_sub(1).wrapping_sub(i),
        )
    } else {
        (x, i)
    };
    let (yc, jc) = if my {
        (
            h.wrapping_sub(1).wrapping_sub(y),
            ny.wrapping_sub(1).wrapping_sub(j),
        )
    } else {
        (y, j)
    };
    Mirror {
        xc,
        yc,
        kc: jc.wrapping_mul(nx).wrapping_add(ic),
        mx,
        my,
    }
}

/// The jitter in [0, 1]² of sample (i, j) of texel (x, y) on nx×ny strata of a w×h canvas
/// ([`Mirror`]; f64, the generic path's).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn jitter_at(
    seed: u64,
    (x, y): (usize, usize),
    (i, j): (usize, usize),
    (nx, ny): (usize, usize),
    (w, h): (usize, usize),
) -> (f64, f64) {
    let u = |v: usize| v as u32;
    let m = mirror(u(x), u(y), u(i), u(j), u(nx), u(ny), u(w), u(h));
    let (jx, jy) = jitter32(seed, m.xc as usize, m.yc as usize, m.kc as usize);
    (
        if m.mx { 1.0 - jx } else { jx },
        if m.my { 1.0 - jy } else { jy },
    )
}

/// Deterministic jitter in [0,1)² for sample `k` of texel (x, y): a 32-bit integer hash
/// (xor-multiply mixing, "lowbias32"), 16 bits per axis — cheap enough to vectorize.
#[inline(always)]
pub(crate) fn jitter32(seed: u64, x: usize, y: usize, k: usize) -> (f64, f64) {
    let h = hash32(
        seed as u32 ^ (seed >> 32) as u32,
        x as u32,
        y as u32,
        k as u32,
    );
    ((h & 0xFFFF) as f64 / 65536.0, (h >> 16) as f64 / 65536.0)
}

#[inline(always)]
pub(crate) fn hash32(seed: u32, x: u32, y: u32, k: u32) -> u32 {
    hash32_mixed(seed ^ x.wrapping_mul(HX) ^ y.wrapping_mul(HY) ^ k.wrapping_mul(HK))
}

/// [`hash32`]'s multipliers of x, y and k.
pub(crate) const HX: u32 = 0x9E37_79B1;

pub(crate) const HY: u32 = 0x85EB_CA77;

pub(crate) const HK: u32 = 0xC2B2_AE3D;

/// [`hash32`] after its inputs are mixed: `seed ^ x·HX ^ y·HY ^ k·HK` (wrapping), which a
/// caller may assemble from precomputed products.
#[inline(always)]
pub(crate) fn hash32_mixed(mut h: u32) -> u32 {
    h ^= h >> 16;
    h = h.wrapping_mul(0x7FEB_352D);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846C_A68B);
    h ^ (h >> 16)
}

/// The strata grid of one texel: at least `samples` in all, then kept within `cap` (the
/// aspect kept).  Shared with the ray-traced generator, so `samples` means the same there.
#[inline]
pub(crate) fn strata(mut nx: usize, mut ny: usize, samples: usize, cap: usize) -> (usize, usize) {
    while nx * ny < samples {
        nx += 1;
    }
    if nx * ny > cap {
        // Keep the aspect and use as much of the cap as the grid allows.
        let k = (cap as f64 / (nx * ny) as f64).sqrt();
        nx = ((nx as f64 * k).round() as usize).clamp(1, cap);
        ny = (cap / nx).max(1);
    }
    (nx, ny)
}

/// Deterministic jitter in [0,1)² for (texel, sample): a 64-bit mix (SplitMix64 finalizer).
#[inline]
pub(crate) fn jitter(seed: u64, x: u64, y: u64, k: u64) -> (f64, f64) {
    let mut z = seed
        ^ x.wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ y.wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ k.wrapping_mul(0x1656_67B1_9E37_79F9);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    let a = (z >> 40) as f64 / (1u64 << 24) as f64;
    let b = ((z >> 16) & 0xFF_FFFF) as f64 / (1u64 << 24) as f64;
    (a, b)
}
