//! Zeroing and zero-testing of an idle block's two output buffers, with the widest stores the
//! [`Kernel`] allows.

use super::simd::Kernel;
#[cfg(target_arch = "x86_64")]
use std::arch::asm;

/// True when every element of `a` and `b` is +0.0 (bit pattern 0; −0.0 and NaN count as
/// non-zero). Why: an idle block's outputs usually hold the zeros written one block earlier, or
/// the wrapper cleared them already (nice-plug zero-fills an instrument's output channels before
/// `process`); reading 2 × 64 samples costs less than storing them, so the idle path checks
/// first and writes only over dirty buffers.
pub fn all_zero_pair(kernel: Kernel, a: &[f32], b: &[f32]) -> bool {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    match kernel {
        // SAFETY: AVX-512F was detected at runtime for this kernel (see `dispatch_free`).
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
/// elsewhere (a baseline-SSE2 check measured slower than the stores, 9.8–13.5 vs 5.0–7.4 ns per
/// pair of 64-sample blocks; an AVX2 check was not measured).
pub fn clear_pair(kernel: Kernel, a: &mut [f32], b: &mut [f32]) {
    if kernel != Kernel::Avx512 || !all_zero_pair(kernel, a, b) {
        zero_pair(kernel, a, b);
    }
}

/// Zeroes two buffers (an idle block's outputs) with the widest stores `kernel` allows. Why not
/// `fill`: LLVM turns any zeroing loop (intrinsic stores included) into two `memset` calls, which
/// cost more than the idle engine's whole bookkeeping at small blocks; the stores are therefore
/// written in `asm!`, which the optimiser leaves alone. Both SIMD variants store whole aligned
/// cache lines / vectors wherever they can: a store split across two cache lines costs about
/// two, and host buffers are often only 16-byte aligned (measured: 512-sample blocks at a
/// 16-byte offset took twice as long with unaligned 64-byte stores).
pub fn zero_pair(kernel: Kernel, a: &mut [f32], b: &mut [f32]) {
    let n = a.len().min(b.len());
    let (a, b) = (&mut a[..n], &mut b[..n]);
    match kernel {
        // SAFETY: the features as in `dispatch_free` (AVX2 implies AVX); `a` and `b` both have
        // `n` elements, n ≥ 8 for `zero_avx`.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { zero_lines_avx512(a, b) },
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 if n >= 8 => unsafe { zero_avx(a, b) },
        _ => {
            a.fill(0.0);
            b.fill(0.0);
        }
    }
}

/// `kmovw` masks for [`zero_lines_avx512`], indexed by a *byte* offset within a cache line
/// (a multiple of 4 for `f32` data, hence `u32` entries; `kmovw` reads the low 16 bits).
/// `head[o/4]`: lanes `o/4..16` (the slice starts `o` bytes into its first line).
/// `tail[o/4]`: lanes `0..o/4` (the slice ends `o` bytes into its last line; 0 = a full line).
#[cfg(target_arch = "x86_64")]
#[repr(C, align(64))]
struct LineMasks {
    head: [u32; 16],
    tail: [u32; 16],
}

#[cfg(target_arch = "x86_64")]
static LINE_MASKS: LineMasks = {
    let mut head = [0; 16];
    let mut tail = [0; 16];
    let mut i = 0;
    while i < 16 {
        head[i] = (0xFFFF << i) & 0xFFFF;
        tail[i] = if i == 0 { 0xFFFF } else { (1 << i) - 1 };
        i += 1;
    }
    LineMasks { head, tail }
};

/// AVX-512 zeroing with exactly one 64-byte store per cache line each slice touches: a masked
/// store to the line holding the first element (lanes from the slice start on), aligned full
/// stores to the lines in between, a masked store to the line holding the last element (lanes
/// up to the slice end); a slice within one line gets one store with both masks. No store
/// crosses a line, whatever the slices' alignment (they may differ).
///
/// # Safety
/// AVX-512F must be available; `b` must be at least as long as `a` (only `a.len()` elements of
/// each are written).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn zero_lines_avx512(a: &mut [f32], b: &mut [f32]) {
    let bytes = 4 * a.len();
    if bytes == 0 {
        return;
    }
    debug_assert!(b.len() >= a.len());
    for p in [a.as_mut_ptr(), b.as_mut_ptr()] {
        // SAFETY: `p` starts a live, exclusively borrowed `[f32]` of at least `bytes` > 0 bytes
        // (this function's contract), so `p` and `p + bytes` are 4-byte aligned; below, "the
        // slice" is its first `bytes` bytes, the only ones written. Let `first` = p & !63 and
        // `last` = (p + bytes − 1) & !63 be the lines holding its first and last byte. Stores:
        // - `vmovaps [q]` for first < q < last: q ≥ first + 64 > p and q + 64 ≤ last < p + bytes,
        //   so the whole line is inside the slice (and 64-byte aligned, as vmovaps requires);
        // - `vmovups [first]{head}`, head = lanes from (p − first)/4 on: with last > first these
        //   are the bytes [p, first + 64) ⊂ [p, last) of the slice;
        // - `vmovups [last]{tail}`, tail = lanes below (p + bytes − last)/4 (all 16 when the
        //   slice ends on a line boundary): the bytes [last, p + bytes), inside the slice since
        //   last > first implies last > p;
        // - first = last: one store, mask head ∧ tail = the bytes [p, p + bytes).
        // Masked-off lanes of an AVX-512 masked store are neither written nor checked for
        // faults (AVX-512 memory fault suppression), so no byte outside the slice is touched,
        // not even rewritten with its own value; besides, a 64-byte line never straddles a page
        // and each stored line holds bytes of the slice. The mask loads read `LINE_MASKS`
        // (32 `u32`s; offsets 0..=60 and 64..=124). AVX-512F is enabled for this function; the
        // asm clobbers only the declared registers and flags, and uses no stack.
        unsafe {
            asm!(
                "vpxord {z}, {z}, {z}",
                "lea {last}, [{p} + {bytes}]",
                "mov {t}, {p}",
                "and {t}, 63",
                "kmovw {head}, word ptr [{masks} + {t}]",
                "sub {p}, {t}",
                "mov {t}, {last}",
                "and {t}, 63",
                "kmovw {tail}, word ptr [{masks} + {t} + 64]",
                "dec {last}",
                "and {last}, -64",
                "cmp {p}, {last}",
                "jne 2f",
                "kandw {head}, {head}, {tail}",
                "vmovups zmmword ptr [{p}] {{{head}}}, {z}",
                "jmp 4f",
                "2:",
                "vmovups zmmword ptr [{p}] {{{head}}}, {z}",
                "vmovups zmmword ptr [{last}] {{{tail}}}, {z}",
                "add {p}, 64",
                "cmp {p}, {last}",
                "jae 4f",
                "3:",
                "vmovaps zmmword ptr [{p}], {z}",
                "add {p}, 64",
                "cmp {p}, {last}",
                "jb 3b",
                "4:",
                p = inout(reg) p => _,
                bytes = in(reg) bytes,
                masks = in(reg) &LINE_MASKS,
                last = out(reg) _,
                t = out(reg) _,
                head = out(kreg) _,
                tail = out(kreg) _,
                z = out(zmm_reg) _,
                options(nostack),
            );
        }
    }
    // SAFETY: clears the upper vector state the stores dirtied (no live vector values cross
    // it); without it the SSE code after the return pays transition stalls.
    unsafe { asm!("vzeroupper", options(nostack, preserves_flags)) };
}

/// AVX zeroing for slices of at least 8 elements: an unaligned 32-byte store at each end and
/// 32-byte aligned stores in between (overlapping the ends), so at most the two end stores can
/// split a cache line. (AVX has masked stores, `vmaskmovps`, but they are slow on several
/// AVX2-only CPUs.)
///
/// # Safety
/// AVX must be available; `a.len()` ≥ 8 and `b` at least as long as `a` (only `a.len()`
/// elements of each are written).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn zero_avx(a: &mut [f32], b: &mut [f32]) {
    let bytes = 4 * a.len();
    debug_assert!(bytes >= 32 && b.len() >= a.len());
    for p in [a.as_mut_ptr(), b.as_mut_ptr()] {
        // SAFETY: `p` starts a live, exclusively borrowed `[f32]` of at least `bytes` ≥ 32 bytes
        // (this function's contract); only its first `bytes` are written. Let e =
        // p + bytes − 32. The stores cover [p, p + 32), [e, e + 32) and [q, q + 32) for the
        // 32-byte aligned q with (p + 32) & !31 ≤ q < e: all inside the slice (q > p, q + 32 ≤
        // e + 32 = its end), and together all of it, since (p + 32) & !31 ≤ p + 32 and the loop
        // runs until q ≥ e. AVX is enabled for this function; the asm clobbers only the
        // declared registers and flags, and uses no stack.
        unsafe {
            asm!(
                "vxorps {z}, {z}, {z}",
                "lea {e}, [{p} + {bytes} - 32]",
                "vmovups ymmword ptr [{p}], {z}",
                "vmovups ymmword ptr [{e}], {z}",
                "add {p}, 32",
                "and {p}, -32",
                "cmp {p}, {e}",
                "jae 3f",
                "2:",
                "vmovaps ymmword ptr [{p}], {z}",
                "add {p}, 32",
                "cmp {p}, {e}",
                "jb 2b",
                "3:",
                p = inout(reg) p => _,
                bytes = in(reg) bytes,
                e = out(reg) _,
                z = out(ymm_reg) _,
                options(nostack),
            );
        }
    }
    // SAFETY: as in `zero_lines_avx512`.
    unsafe { asm!("vzeroupper", options(nostack, preserves_flags)) };
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
    fn zero_pair_zeroes_exactly_the_slices() {
        // 64-byte aligned storage: one line of guard elements, then slices starting at every
        // 4-byte offset within a line (`a` and `b` independently, as their alignments may
        // differ) of every length 0..=70, then guard elements up to the end. Every element
        // outside the slices must keep its value.
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
                        zero_pair(kernel, &mut a[off_a..off_a + n], &mut b[off_b..off_b + n]);
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
