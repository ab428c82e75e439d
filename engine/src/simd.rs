//! Run-time dispatch of the engine's hot loops to AVX2 and FMA, or to
//! AVX-512 (DMesh Sec. 4.2's per-vertex passes, and the depth decode's
//! conversions; issue 27): the one module of the engine with `unsafe`
//! code.
//!
//! `dispatch!` defines a function that runs its body compiled for the
//! `x86-64-v4` features (AVX-512 F, BW, CD, DQ and VL, with those of v3)
//! when the CPU has them, else for the `x86-64-v3` features (AVX2, FMA,
//! BMI1/2, LZCNT) when it has those, and as it is otherwise. The `unsafe`
//! calls it expands to are written here once. The results are the same
//! bits at every tier: Rust never contracts a multiply and an add into an
//! FMA unless told to (`mul_add`), the build's loops do not, and the
//! compiler does not reorder a floating-point sum to widen it; so the
//! features only widen the vectors (and give them masks); `examples/digest`
//! prints the same digests from each, and `tests/simd_dispatch.rs` compares
//! every tier the CPU has.

/// Defines `fn NAME(ARGS) -> R` that calls `BODY(ARGS)` compiled for the
/// best [`Tier`] this CPU has and [`limit`] allows. `BODY` must be an
/// `#[inline(always)]` function, and what it calls `#[inline(always)]`
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
                #[target_feature(enable = "avx512f,avx512bw,avx512cd,avx512dq,avx512vl,avx2,fma,bmi1,bmi2,lzcnt")]
                unsafe fn avx512($($arg: $ty),*) -> $ret {
                    $body($($arg),*)
                }
                #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt")]
                unsafe fn avx2($($arg: $ty),*) -> $ret {
                    $body($($arg),*)
                }
                match $crate::simd::tier_in_use() {
                    // SAFETY: `tier_in_use` names a tier only where the
                    // CPU has every feature of it.
                    $crate::simd::Tier::Avx512 => return unsafe { avx512($($arg),*) },
                    // SAFETY: as above.
                    $crate::simd::Tier::Avx2 => return unsafe { avx2($($arg),*) },
                    $crate::simd::Tier::Portable => {}
                }
            }
            $body($($arg),*)
        }
    };
}
pub(crate) use dispatch;

use std::sync::atomic::{AtomicU8, Ordering};

/// The code a function defined by `dispatch!` runs, slowest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Tier {
    /// As compiled for the target, without run-time features.
    Portable,
    /// `x86-64-v3`: AVX2, FMA, BMI1/2, LZCNT.
    Avx2,
    /// `x86-64-v4`: AVX-512 F, BW, CD, DQ and VL, with v3's.
    Avx512,
}

impl Tier {
    /// Every tier, slowest first.
    pub const ALL: [Tier; 3] = [Tier::Portable, Tier::Avx2, Tier::Avx512];

    /// Whether this CPU has every feature of the tier.
    pub fn available(self) -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            let v3 = || has!("avx2") && has!("fma") && has!("bmi1") && has!("bmi2") && has!("lzcnt");
            let v4 = || has!("avx512f") && has!("avx512bw") && has!("avx512cd") && has!("avx512dq") && has!("avx512vl");
            match self {
                Tier::Portable => true,
                Tier::Avx2 => v3(),
                Tier::Avx512 => v3() && v4(),
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self == Tier::Portable
        }
    }

    /// The tier's name as `profile_build` and the docs spell it.
    pub fn name(self) -> &'static str {
        match self {
            Tier::Portable => "portable",
            Tier::Avx2 => "avx2",
            Tier::Avx512 => "avx512",
        }
    }
}

/// The best tier allowed (a [`Tier`] as `u8`): the best there is, unless
/// [`limit`] lowered it.
static LIMIT: AtomicU8 = AtomicU8::new(Tier::Avx512 as u8);

/// The best tier this CPU has, found once.
fn best() -> Tier {
    static BEST: std::sync::OnceLock<Tier> = std::sync::OnceLock::new();
    *BEST.get_or_init(|| {
        Tier::ALL
            .into_iter()
            .rev()
            .find(|t| t.available())
            .unwrap_or(Tier::Portable)
    })
}

/// Runs no better tier than `tier` from now on (`Tier::Avx512`: the best
/// the CPU has again): for the tests that the tiers give the same bytes,
/// and for measuring what each brings. Affects every thread.
pub fn limit(tier: Tier) {
    LIMIT.store(tier as u8, Ordering::Relaxed);
}

/// The tier functions defined by `dispatch!` run now: the best the CPU
/// has that [`limit`] allows.
#[inline(always)]
pub fn tier_in_use() -> Tier {
    let allowed = match LIMIT.load(Ordering::Relaxed) {
        0 => Tier::Portable,
        1 => Tier::Avx2,
        _ => Tier::Avx512,
    };
    allowed.min(best())
}

/// Runs the portable code from now on (`true`) even where the CPU has
/// AVX2, or the best tier again (`false`). [`limit`] with a [`Tier`].
pub fn force_portable(portable: bool) {
    limit(if portable { Tier::Portable } else { Tier::Avx512 });
}

/// Whether functions defined by `dispatch!` run AVX2 (or better) code now.
pub fn avx2_in_use() -> bool {
    tier_in_use() >= Tier::Avx2
}
