//! Runtime choice of the SIMD code path, one scheme for every kernel (modal bank, transient
//! bands, rolling kinematics, buffer zeroing): each kernel is written once as plain Rust (generic
//! over a `const FMA: bool` where multiply-adds matter), compiled into `#[target_feature]`
//! variants, and selected by `match` on the [`Kernel`] detected once at construction. A
//! component without an AVX-512 variant runs its AVX2 one for [`Kernel::Avx512`]. The bundle
//! therefore runs on any x86-64 (and non-x86) CPU, at the best speed the CPU allows.
//!
//! Safety invariant of every dispatch: a `Kernel` value other than `Portable` exists only when
//! [`Kernel::detect`] found its features, or [`Kernel::is_supported`] confirmed them (the only
//! constructors used by the engine); the `unsafe` calls of the variants rely on it.

use std::sync::atomic::{AtomicU8, Ordering};

/// Which compiled variant of the kernels runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernel {
    /// Portable code (baseline target features only).
    Portable,
    /// x86-64 AVX2 + FMA.
    Avx2,
    /// x86-64 AVX-512F.
    Avx512,
}

/// The most capable variant [`Kernel::detect`] returns in this process ([`Kernel::limit`]), as
/// its rank ([`Kernel::rank`]).
static CEILING: AtomicU8 = AtomicU8::new(u8::MAX);

impl Kernel {
    /// The variant's place in the order Portable < AVX2 < AVX-512.
    fn rank(self) -> u8 {
        match self {
            Kernel::Portable => 0,
            Kernel::Avx2 => 1,
            Kernel::Avx512 => 2,
        }
    }

    /// Makes [`Kernel::detect`] return at most `ceiling` from now on, in every engine this process
    /// builds: `tactus bench --kernel` measures a variant the CPU would not pick on its own (an
    /// AVX2 machine's figures on an AVX-512 one). Components already built keep theirs.
    pub fn limit(ceiling: Kernel) {
        CEILING.store(ceiling.rank(), Ordering::Relaxed);
    }

    /// The fastest variant this CPU supports, at most [`Kernel::limit`]'s.
    pub fn detect() -> Self {
        let ceiling = CEILING.load(Ordering::Relaxed);
        [Self::best(), Kernel::Avx2, Kernel::Portable]
            .into_iter()
            .find(|k| k.rank() <= ceiling && k.is_supported())
            .unwrap_or(Kernel::Portable)
    }

    /// The fastest variant this CPU supports.
    pub fn best() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx512f")
                && std::is_x86_feature_detected!("avx2")
                && std::is_x86_feature_detected!("fma")
            {
                return Kernel::Avx512;
            }
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                return Kernel::Avx2;
            }
        }
        Kernel::Portable
    }

    /// Whether this CPU can run the variant.
    pub fn is_supported(self) -> bool {
        match self {
            Kernel::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2 => std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma"),
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx512 => {
                std::is_x86_feature_detected!("avx512f")
                    && std::is_x86_feature_detected!("avx2")
                    && std::is_x86_feature_detected!("fma")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }
}
