//! A minimal floating-point abstraction so that every mapping formula is written once and
//! instantiated twice: `f64` (the reference path) and `f32` (the fast path, and what a GPU
//! computes). Only the operations the formulas need are here.

use core::ops::{Add, Div, Mul, Neg, Sub};

/// `f32` or `f64`.
pub trait Real:
    Copy
    + PartialOrd
    + core::fmt::Debug
    + Send
    + Sync
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + 'static
    + Real64Atan2
{
    const ZERO: Self;
    const ONE: Self;
    const HALF: Self;
    const TWO: Self;
    const NAN: Self;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    fn is_finite(self) -> bool;
    fn is_nan(self) -> bool;
    fn from_f64(v: f64) -> Self;
    fn to_f64(self) -> f64;
    /// `atan2(self, x)`.  f64: the C library's, correctly rounded in practice.  f32: a
    /// branch-free minimax polynomial ([`atan2_fast`]), absolute error ≤ 3e-7 rad (one f32 ulp of π),
    /// and many times faster.
    fn atan2(self, x: Self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn floor(self) -> Self;
    fn copysign(self, sign: Self) -> Self;
    fn max(self, o: Self) -> Self;
    fn min(self, o: Self) -> Self;
    fn hypot(self, o: Self) -> Self;
}

macro_rules! impl_real {
    ($t:ty) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const HALF: Self = 0.5;
            const TWO: Self = 2.0;
            const NAN: Self = <$t>::NAN;
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline(always)]
            fn is_nan(self) -> bool {
                <$t>::is_nan(self)
            }
            #[inline(always)]
            fn from_f64(v: f64) -> Self {
                v as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn atan2(self, x: Self) -> Self {
                Real64Atan2::atan2_impl(self, x)
            }
            #[inline(always)]
            fn sin(self) -> Self {
                <$t>::sin(self)
            }
            #[inline(always)]
            fn cos(self) -> Self {
                <$t>::cos(self)
            }
            #[inline(always)]
            fn floor(self) -> Self {
                Real64Atan2::floor_impl(self)
            }
            #[inline(always)]
            fn copysign(self, sign: Self) -> Self {
                <$t>::copysign(self, sign)
            }
            #[inline(always)]
            fn max(self, o: Self) -> Self {
                <$t>::max(self, o)
            }
            #[inline(always)]
            fn min(self, o: Self) -> Self {
                <$t>::min(self, o)
            }
            #[inline(always)]
            fn hypot(self, o: Self) -> Self {
                // Not the C library's `hypot` (slow, and the inputs here are unit-scale): the
                // plain formula, exact to rounding for |values| in 1e-150..1e150.
                (self * self + o * o).sqrt()
            }
        }
    };
}
impl_real!(f32);
impl_real!(f64);

impl Real64Atan2 for f64 {
    #[inline(always)]
    fn atan2_impl(self, x: f64) -> f64 {
        f64::atan2(self, x)
    }
    #[inline(always)]
    fn floor_impl(self) -> f64 {
        f64::floor(self)
    }
}
impl Real64Atan2 for f32 {
    #[inline(always)]
    fn atan2_impl(self, x: f32) -> f32 {
        atan2_fast(self, x)
    }
    #[inline(always)]
    fn floor_impl(self) -> f32 {
        floor_fast(self)
    }
}

/// Per-type operations (kept out of the macro: f32 and f64 differ).
pub trait Real64Atan2 {
    fn atan2_impl(self, x: Self) -> Self;
    fn floor_impl(self) -> Self;
}

/// `floor` without a libm call (baseline x86-64 has no `roundss`), branch-free so it vectorizes:
/// truncate, step down where truncation rounded up.  |x| ≥ 2²³ is already integral and NaN
/// stays NaN.
#[inline(always)]
pub fn floor_fast(x: f32) -> f32 {
    // Clamped first (NaN becomes −2²³ here and is restored below), so the unchecked
    // conversion is in range; a plain `as` adds a saturating fix-up that stops vectorization.
    // (Not `clamp`: it keeps NaN, which the conversion must not see.)
    #[allow(clippy::manual_clamp)]
    let c = x.max(-8_388_608.0).min(8_388_608.0);
    // SAFETY: |c| ≤ 2²³ fits an i32.
    let t = unsafe { c.to_int_unchecked::<i32>() } as f32;
    let t = if t > x { t - 1.0 } else { t };
    if x.abs() < 8_388_608.0 {
        t
    } else {
        x
    }
}

/// Fast f32 `atan2(y, x)`, branch-free so it vectorizes.
///
/// Reduce to `a = min(|x|,|y|) / max(|x|,|y|) ∈ [0,1]`; `atan(a) = a·P(a²)` with P the degree-7
/// minimax fit below (max abs error 3.7e-8 on [0,1], fitted by Lawson-weighted least squares);
/// then undo the reduction by octant: `π/2 − θ` if |y| > |x|, `π − θ` if x < 0, sign of y.
/// `atan2(0, 0) = 0`; NaN in → NaN out.  Measured against f64: ≤ 2.7e-7 rad (the rounding of π − θ in f32).
#[inline(always)]
pub fn atan2_fast(y: f32, x: f32) -> f32 {
    atan2_poly::<false>(y, x)
}

/// The larger of `a` and `b` as x86's `maxps` has it (with a NaN: `b`): one instruction
/// when vectorized, where `f32::max` takes three for its NaN rule.
#[inline(always)]
pub(crate) fn vmax(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// The smaller of `a` and `b` as x86's `minps` has it (with a NaN: `b`); see [`vmax`].
#[inline(always)]
pub(crate) fn vmin(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// `floor(x)`: one instruction where the code is compiled for AVX2 (`AVX`), else
/// [`floor_fast`] (baseline x86-64 has no rounding instruction; `floor` would be a call).
#[inline(always)]
pub(crate) fn floor_v<const AVX: bool>(x: f32) -> f32 {
    if AVX {
        x.floor()
    } else {
        floor_fast(x)
    }
}

/// `a·b + c`: one fused instruction with `FMA` (for code compiled for a CPU that has it: the
/// vectorized passes of `resample`), else a multiply and an add — elsewhere a fused one would
/// be a slow library call.  The two differ by the rounding of the product only.
#[inline(always)]
pub(crate) fn mad<const FMA: bool>(a: f32, b: f32, c: f32) -> f32 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// [`atan2_fast`] with its polynomial evaluated by [`mad`] (so fused with `FMA`).
#[inline(always)]
pub(crate) fn atan2_poly<const FMA: bool>(y: f32, x: f32) -> f32 {
    atan2_core::<FMA, false>(y, x)
}

/// [`atan2_poly`] for `y` ≥ +0 (or NaN), as a square root gives: the result in [0, π]
/// without y's absolute value or sign (two vector operations fewer).  The same value.
#[inline(always)]
pub(crate) fn atan2_upper<const FMA: bool>(y: f32, x: f32) -> f32 {
    atan2_core::<FMA, true>(y, x)
}

/// [`atan2_poly`], or with `UPPER` [`atan2_upper`].
#[inline(always)]
fn atan2_core<const FMA: bool, const UPPER: bool>(y: f32, x: f32) -> f32 {
    const C: [f32; 8] = [
        0.999_999_34,
        -0.333_298_6,
        0.199_465_66,
        -0.139_086_3,
        0.096_421_98,
        -0.055_912_35,
        0.021_862_98,
        -0.004_054_574,
    ];
    let (ax, ay) = (x.abs(), if UPPER { y } else { y.abs() });
    // (Compare-and-select: one instruction each when vectorized; a NaN is dealt with below.)
    let (mx, mn) = (vmax(ax, ay), vmin(ax, ay));
    let a = if mx > 0.0 { mn / mx } else { 0.0 };
    let s = a * a;
    let p = C[7];
    let p = mad::<FMA>(p, s, C[6]);
    let p = mad::<FMA>(p, s, C[5]);
    let p = mad::<FMA>(p, s, C[4]);
    let p = mad::<FMA>(p, s, C[3]);
    let p = mad::<FMA>(p, s, C[2]);
    let p = mad::<FMA>(p, s, C[1]);
    let p = mad::<FMA>(p, s, C[0]);
    let mut r = a * p;
    if ay > ax {
        r = core::f32::consts::FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = core::f32::consts::PI - r;
    }
    let r = if x.is_nan() || y.is_nan() {
        f32::NAN
    } else {
        r
    };
    if UPPER {
        r
    } else {
        r.copysign(y)
    }
}

#[inline(always)]
pub(crate) fn dot3<T: Real>(a: [T; 3], b: [T; 3]) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan2_fast_matches_f64() {
        let mut worst = 0.0f64;
        let n = 2000;
        for i in 0..n {
            let a = i as f64 / n as f64 * std::f64::consts::TAU;
            for r in [1.0f64, 1e-3, 7.5e3] {
                let (y, x) = ((a.sin() * r) as f32, (a.cos() * r) as f32);
                let e = (atan2_fast(y, x) as f64 - (y as f64).atan2(x as f64)).abs();
                worst = worst.max(e);
            }
        }
        assert!(worst <= 3e-7, "{worst}"); // ≈ 1 ulp of f32 at π
        assert_eq!(atan2_fast(0.0, 0.0), 0.0);
        assert_eq!(atan2_fast(0.0, -1.0), std::f32::consts::PI);
        assert_eq!(atan2_fast(-0.0, -1.0), -std::f32::consts::PI);
        assert!(atan2_fast(f32::NAN, 1.0).is_nan());
        assert!(atan2_fast(1.0, f32::NAN).is_nan());
    }

    /// For y ≥ +0 (a square root's values) the upper-half variant is the same function.
    #[test]
    fn atan2_upper_is_atan2_poly_for_nonnegative_y() {
        let n = 1000;
        for i in 0..=n {
            let a = i as f64 / n as f64 * std::f64::consts::PI;
            for r in [1.0f64, 1e-3, 7.5e3] {
                let (y, x) = ((a.sin() * r).max(0.0) as f32, (a.cos() * r) as f32);
                for fma in [false, true] {
                    let (u, p) = if fma {
                        (atan2_upper::<true>(y, x), atan2_poly::<true>(y, x))
                    } else {
                        (atan2_upper::<false>(y, x), atan2_poly::<false>(y, x))
                    };
                    assert_eq!(u.to_bits(), p.to_bits(), "({y}, {x})");
                }
            }
        }
        for x in [0.0f32, -0.0, 1.0, -1.0] {
            assert_eq!(atan2_upper::<false>(0.0, x), atan2_poly::<false>(0.0, x));
        }
        assert!(atan2_upper::<false>(f32::NAN, 1.0).is_nan());
        assert!(atan2_upper::<false>(1.0, f32::NAN).is_nan());
    }

    #[test]
    fn floor_fast_matches_floor() {
        for x in [
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999,
            -2.001,
            8388607.5,
            -8388607.5,
            1e10,
            -1e10,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ] {
            assert_eq!(floor_fast(x), x.floor(), "{x}");
        }
        assert!(floor_fast(f32::NAN).is_nan());
    }
}
