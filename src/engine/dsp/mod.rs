//! DSP primitives shared by the engine's components: the SIMD dispatch ([`simd::Kernel`]),
//! perceptual scales and the threshold of hearing ([`scales`]), fast trigonometry ([`trig`]),
//! Cholesky factorisation ([`linalg`]), output-buffer zeroing ([`zero`]) and the decibel-per-neper
//! factor ([`DB_PER_NEPER`]). No state, no plugin types.

pub mod linalg;
pub mod scales;
pub mod simd;
pub mod trig;
pub mod zero;

/// Decibels of amplitude per neper, `20·log10(e)`: a decay of `d` dB/s is `d / DB_PER_NEPER`
/// nepers per second, the rate `σ` of `e^{−σt}`.
pub const DB_PER_NEPER: f64 = 20.0 * std::f64::consts::LOG10_E;
