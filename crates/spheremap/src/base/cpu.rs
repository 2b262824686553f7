//! The CPU dispatch: which vector instructions the vectorized paths use, chosen once per
//! process.

/// The vector instructions the f32 passes and gathers use, chosen once per process: the
/// widest this CPU has, or none when the environment variable `SPHEREMAP_PORTABLE` is set
/// (to anything) — the code CPUs without AVX2 run — or at most AVX2 when
/// `SPHEREMAP_NO_AVX512` is set (what AVX2-only CPUs run, for testing on an AVX-512 one).
/// Every vectorized path in the crate asks this one function; `scripts/test.sh` runs the
/// conversion tests each way the CPU allows.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub enum Simd {
    Portable,
    /// AVX2 and FMA.
    Avx2,
    /// AVX-512 F/VL/DQ, AVX2 and FMA.
    Avx512,
}

pub fn simd() -> Simd {
    static SIMD: std::sync::OnceLock<Simd> = std::sync::OnceLock::new();
    *SIMD.get_or_init(|| {
        if std::env::var_os("SPHEREMAP_PORTABLE").is_some() {
            return Simd::Portable;
        }
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            let fma = has!("avx2") && has!("fma");
            let wide = std::env::var_os("SPHEREMAP_NO_AVX512").is_none();
            if fma && wide && has!("avx512f") && has!("avx512vl") && has!("avx512dq") {
                return Simd::Avx512;
            }
            if fma {
                return Simd::Avx2;
            }
        }
        Simd::Portable
    })
}

/// Runs `f` compiled for the widest vectors this CPU has (`f` must be `#[inline(always)]`
/// code: it is inlined into the feature-enabled wrapper and vectorized there).
#[inline(always)]
pub(crate) fn vectorized<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx2,fma")]
        unsafe fn avx512<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        #[target_feature(enable = "avx2,fma")]
        unsafe fn avx2<R>(f: impl FnOnce() -> R) -> R {
            f()
        }
        match simd() {
            // SAFETY: the features were detected at run time.
            Simd::Avx512 => return unsafe { avx512(f) },
            // SAFETY: the features were detected at run time.
            Simd::Avx2 => return unsafe { avx2(f) },
            Simd::Portable => {}
        }
    }
    f()
}
