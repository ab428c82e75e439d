//! Run-time dispatch of the build's hot loops to AVX2 and FMA (DMesh
//! Sec. 4.2's per-vertex passes, issue 27): the one module of the engine
//! with `unsafe` code.
//!
//! `dispatch!` defines a function that runs its body compiled for the
//! `x86-64-v3` features (AVX2, FMA, BMI1/2, LZCNT) when the CPU has them,
//! and as it is otherwise. The `unsafe` call it expands to is written here
//! once. The results are the same bits either way: Rust never
//! contracts a multiply and an add into an FMA unless told to
//! (`mul_add`), and the build's loops do not, so the features only widen
//! the vectors; `examples/digest` prints the same digests from both.

/// Defines `fn NAME(ARGS) -> R` that calls `BODY(ARGS)` compiled for AVX2
/// and FMA where this CPU has them, and as it is otherwise. `BODY` must be
/// an `#[inline(always)]` function, and what it calls `#[inline(always)]`
/// too, to be compiled for the features (a closure, or a function the
/// compiler keeps apart, would only be called).
macro_rules! dispatch {
    ($(#[$m:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty = $body:path;) => {
        $(#[$m])*
        #[inline(never)]
        #[allow(unsafe_code)]
        $vis fn $name($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt")]
                unsafe fn avx2($($arg: $ty),*) -> $ret {
                    $body($($arg),*)
                }
                if $crate::simd::v3() {
                    // SAFETY: `v3` checked that the CPU has every feature
                    // `avx2` is compiled for.
                    return unsafe { avx2($($arg),*) };
                }
            }
            $body($($arg),*)
        }
    };
}
pub(crate) use dispatch;

/// Whether this CPU has the `x86-64-v3` features (detected once; the
/// standard library caches the answer).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn v3() -> bool {
    !PORTABLE.load(std::sync::atomic::Ordering::Relaxed)
        && std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("fma")
        && std::arch::is_x86_feature_detected!("bmi1")
        && std::arch::is_x86_feature_detected!("bmi2")
        && std::arch::is_x86_feature_detected!("lzcnt")
}

/// Set: the portable code runs even where the CPU has AVX2.
static PORTABLE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Runs the portable code from now on (`true`) even where the CPU has
/// AVX2, or the fastest again (`false`): for the test that the two give
/// the same bytes, and for measuring what AVX2 brings. Affects every
/// thread.
pub fn force_portable(portable: bool) {
    PORTABLE.store(portable, std::sync::atomic::Ordering::Relaxed);
}

/// Whether functions defined by `dispatch!` run the AVX2 code now: the CPU has it
/// and [`force_portable`] is not set.
pub fn avx2_in_use() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        v3()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}
