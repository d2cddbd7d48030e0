//! Zeroing and zero-testing of an idle block's two output buffers.

use super::simd::Kernel;

/// True when every element of `a` and `b` is +0.0 (bit pattern 0; −0.0 and NaN count as
/// non-zero). Why: an idle block's outputs usually hold the zeros written one block earlier (a
/// host commonly hands the same buffers back); reading 2 × 64 samples costs less than storing
/// them, so the idle path checks first and writes only over dirty buffers. Nothing else clears
/// them: nice-plug's CLAP and VST3 wrappers zero-fill only output channels beyond a main input's,
/// and an instrument has no main input.
pub fn all_zero_pair(kernel: Kernel, a: &[f32], b: &[f32]) -> bool {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    match kernel {
        // SAFETY: AVX-512F was detected at runtime for this kernel (`dsp::simd` invariant).
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { all_zero_avx512(a, b) },
        _ => a.iter().chain(b).all(|v| v.to_bits() == 0),
    }
}

/// [`all_zero_pair`] with unaligned 64-byte loads OR-ed together, the remainder scalar.
///
/// # Safety
/// AVX-512F must be available; `a` and `b` must have the same length.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn all_zero_avx512(a: &[f32], b: &[f32]) -> bool {
    use std::arch::x86_64::*;
    debug_assert_eq!(a.len(), b.len());
    let full = a.len() / 16;
    let mut acc = _mm512_setzero_si512();
    for i in 0..full {
        // SAFETY: lanes 16·i..16·i + 16 ≤ a.len() = b.len() are inside both slices; the loads
        // are unaligned (`loadu`).
        unsafe {
            acc = _mm512_or_si512(acc, _mm512_loadu_si512(a.as_ptr().add(16 * i).cast()));
            acc = _mm512_or_si512(acc, _mm512_loadu_si512(b.as_ptr().add(16 * i).cast()));
        }
    }
    _mm512_test_epi32_mask(acc, acc) == 0
        && a[16 * full..]
            .iter()
            .chain(&b[16 * full..])
            .all(|v| v.to_bits() == 0)
}

/// Makes both buffers zero: with AVX-512, reads them first and stores only if one is dirty
/// ([`all_zero_pair`]: a clean idle block costs loads, not stores); otherwise [`zero_pair`]
/// (a baseline-SSE2 check measured slower than the stores, 9.8–13.5 vs 5.0–7.4 ns per pair of
/// 64-sample blocks; an AVX2 check was not measured).
pub fn clear_pair(kernel: Kernel, a: &mut [f32], b: &mut [f32]) {
    if kernel != Kernel::Avx512 || !all_zero_pair(kernel, a, b) {
        zero_pair(a, b);
    }
}

/// Zeroes the first `min(a.len(), b.len())` elements of both buffers. Plain `fill` (a `memset`
/// call each): hand-written `asm!` stores measured no faster where it matters (docs/bench
/// README, "Zeroing the idle outputs": equal at 64-sample blocks, AVX2 stores slower at 64 and
/// 512, AVX-512 line stores 11 ns faster per 512-sample block, 0.3 % of one ringing voice, and
/// only over dirty buffers, which the plugin wrapper never hands over).
pub fn zero_pair(a: &mut [f32], b: &mut [f32]) {
    let n = a.len().min(b.len());
    a[..n].fill(0.0);
    b[..n].fill(0.0);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_zero_pair_sees_every_nonzero_bit() {
        let mut a = vec![0.0f32; 80];
        let mut b = vec![0.0f32; 80];
        for kernel in [Kernel::Portable, Kernel::Avx2, Kernel::Avx512] {
            if !kernel.is_supported() {
                continue;
            }
            for n in 0..=70 {
                for off in [0, 1, 3, 7] {
                    assert!(all_zero_pair(kernel, &a[off..off + n], &b[off..off + n]));
                    for i in 0..n {
                        for v in [1.0, -0.0, f32::NAN, f32::from_bits(1)] {
                            for which in 0..2 {
                                let buf = if which == 0 { &mut a } else { &mut b };
                                buf[off + i] = v;
                                assert!(
                                    !all_zero_pair(kernel, &a[off..off + n], &b[off..off + n]),
                                    "{kernel:?} n {n} off {off} [{i}] = {v} in {which}"
                                );
                                let (l, r) = (&mut a[off..off + n], &mut b[off..off + n]);
                                clear_pair(kernel, l, r);
                                assert!(l.iter().chain(r.iter()).all(|x| x.to_bits() == 0));
                            }
                        }
                    }
                    // Outside the slices nothing counts.
                    a[off + n] = 1.0;
                    assert!(all_zero_pair(kernel, &a[off..off + n], &b[off..off + n]));
                    a[off + n] = 0.0;
                }
            }
        }
    }

    #[test]
    fn clear_pair_zeroes_exactly_the_slices() {
        // 64-byte aligned storage: one line of guard elements, then dirty slices starting at
        // every 4-byte offset within a line (`a` and `b` independently, as their alignments may
        // differ, and the AVX-512 check reads whole vectors) of every length 0..=70, then guard
        // elements up to the end. Every element outside the slices must keep its value.
        #[repr(C, align(64))]
        struct Lines([f32; 16 * 7]);
        let mut a = Box::new(Lines([0.0; 16 * 7]));
        let mut b = Box::new(Lines([0.0; 16 * 7]));
        let (a, b) = (&mut a.0, &mut b.0);
        for kernel in [Kernel::Portable, Kernel::Avx2, Kernel::Avx512] {
            if !kernel.is_supported() {
                continue;
            }
            for n in 0..=70 {
                for off_a in 16..32 {
                    for off_b in 16..32 {
                        a.fill(1.0);
                        b.fill(2.0);
                        clear_pair(kernel, &mut a[off_a..off_a + n], &mut b[off_b..off_b + n]);
                        for (buf, off, guard) in [(&a, off_a, 1.0), (&b, off_b, 2.0)] {
                            for (i, &v) in buf.iter().enumerate() {
                                let want = if (off..off + n).contains(&i) { 0.0 } else { guard };
                                assert_eq!(v, want, "{kernel:?} n {n} offsets {off_a} {off_b}: [{i}]");
                            }
                        }
                    }
                }
            }
        }
    }
}
