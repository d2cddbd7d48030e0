//! DSP primitives shared by the engine's components: the SIMD dispatch ([`simd::Kernel`]),
//! perceptual scales and the threshold of hearing ([`scales`]), fast trigonometry ([`trig`]),
//! Cholesky factorisation ([`linalg`]) and output-buffer zeroing ([`zero`]). No state, no plugin
//! types.

pub mod linalg;
pub mod scales;
pub mod simd;
pub mod trig;
pub mod zero;
