//! The bank's per-block kernels (free ringing and excited, see the module docs of
//! [`super`]) and their SIMD variants ([`crate::engine::dsp::simd`]).
//!
//! One state loop serves mono and stereo: the kernels are generic over where their output goes
//! ([`Out`]: one mono sum, or the stereo mid and side), so the state advance and the input sums
//! are written once and only the projection of the state and the input's response differ.

use super::{Kernel, FLUSH_FLOOR, K, MAX_IMPULSE_N_S, PAN_GROUPS, W};

/// Borrowed kernel view. `gain, zr, zi` are padded to whole lane groups;
/// `tpr, tpi` hold the matching column groups; `cr, ci` exactly the active modes; `resp` is the
/// summed impulse response.
pub(super) struct State<'a> {
    pub(super) tpr: &'a [[[f64; W]; K]],
    pub(super) tpi: &'a [[[f64; W]; K]],
    pub(super) cr: &'a [[f32; K]],
    pub(super) ci: &'a [[f32; K]],
    pub(super) gain: &'a [f64],
    pub(super) zr: &'a mut [f64],
    pub(super) zi: &'a mut [f64],
    pub(super) resp: &'a [f64; 2 * K],
}

impl State<'_> {
    /// Whether the per-mode arrays are as long as the projection reads ([`project`]).
    pub(super) fn is_valid(&self) -> bool {
        let n = self.cr.len();
        self.ci.len() == n && self.zr.len() >= n && self.zi.len() >= n
    }
}

/// The non-empty pan groups in the order the stereo kernel visits them: `ends[i]` is the end
/// in `order` of the first `i + 1` of them (`count` in all), `coef[i]` the side coefficient of
/// that cumulative sum (see [`Stereo`]). Rebuilt with the order, so a block only reads it.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Groups {
    pub(super) count: usize,
    pub(super) ends: [usize; PAN_GROUPS + 1],
    pub(super) coef: [f32; PAN_GROUPS + 1],
}

/// The stereo kernels' view of the pan groups: `order` the active slots (each below the
/// state's mode count) grouped by pan group,
/// `groups` their cumulative sums' ends and coefficients, `side` the per-slot side weights
/// (partial steps), `resp` the summed side impulse response.
pub(super) struct Side<'a> {
    pub(super) order: &'a [u16],
    pub(super) groups: &'a Groups,
    pub(super) side: &'a [f32],
    pub(super) resp: &'a [f64; 2 * K],
    /// Full steps weight each mode by its side weight instead of summing by parts over the pan
    /// groups (see [`Stereo`]).
    pub(super) per_mode: bool,
}

/// Where a kernel adds its output. Offsets are in samples from the start of the block.
pub(super) trait Out: Sized {
    /// Samples to render.
    fn len(&self) -> usize;
    /// The first `at` samples and the rest.
    fn split_at(self, at: usize) -> (Self, Self);
    /// Adds the free ringing of the state over the full step `at..at + K`.
    fn step<const FMA: bool>(&mut self, s: &State<'_>, at: usize);
    /// Adds the free ringing of the state over the partial step `at..at + r`, r < K.
    fn partial<const FMA: bool>(&mut self, s: &State<'_>, at: usize, r: usize);
    /// Adds the step's input `x[..r]` through the summed response(s) at `at..at + r`.
    fn input<const FMA: bool>(&mut self, s: &State<'_>, x: &[f64; K], at: usize, r: usize);
    /// Whether every mode index it projects is below `modes`.
    fn is_valid(&self, modes: usize) -> bool;
}

/// The mono sum.
pub(super) struct Mono<'o>(pub(super) &'o mut [f32]);

/// The stereo mid `Σ y` and side `Σ_g w_g·Y_g` (`Y_g` the sum of pan group g's modes), in one
/// of two ways ([`Side::per_mode`]):
///
/// - **By parts**, `Σ_g (w_g − w_{g+1})·C_g` over the cumulative sums `C_g = Y_0 + … + Y_g`:
///   the accumulators run on through every group as in mono (no reset, no per-group combine),
///   reaching the modes through the pan order, and at each group's end the side takes one
///   multiply-add of the running sum. So the per-mode multiply-adds are the mono kernel's, and
///   a pan group costs K adds and K multiply-adds per step plus a short loop of its own (with
///   ~6 modes per group of a 64-mode voice, the loop set-up and the odd mode left over cost
///   more than the multiply-adds, and the pan order scatters the coefficient reads;
///   [`render_free_stereo_batch`] sums by parts over a pan-sorted copy instead).
/// - **Per mode**, `Σ_m s_m·y_m` in a second accumulator pair beside the mid's, over the slots
///   in memory order: twice the multiply-adds, no pan order, no per-group loop. The mid
///   accumulators take exactly the mono kernel's operations, so the mid is the mono render bit
///   for bit. Why this pays on the wide variant: there the mid's projection is bound by the
///   latency of its accumulator chains (two dependent multiply-adds per accumulator per mode
///   pair, four 16-lane accumulators for K = 32), so the side's independent chains fill
///   multiply-add slots that would otherwise idle. With 8-lane vectors the mid's eight chains
///   already keep the multiply-add units busy and per mode would double the cost. Free-ringing
///   banks render through [`render_free_stereo_batch`] on every variant, so this serves the
///   excited steps and banks rendered alone.
pub(super) struct Stereo<'o, 's> {
    pub(super) side: &'s Side<'s>,
    pub(super) mid: &'o mut [f32],
    pub(super) os: &'o mut [f32],
}

/// `a·b + c`, fused when the variant has FMA (in the portable variant `mul_add` would call
/// a slow libm routine).
#[inline(always)]
fn madd32<const FMA: bool>(a: f32, b: f32, c: f32) -> f32 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

#[inline(always)]
fn madd64<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// Adds the free ringing over one full step, `Σ Re(p^{k+1}·z)`, of the `n` modes `idx(0..n)`
/// to two accumulator sets `acc[0]`, `acc[1]` (even and odd positions, so consecutive modes'
/// multiply-adds do not wait on each other's latency), without advancing the state. With
/// `SIDE`, also adds each mode's ringing times its side weight `w[idx(i)]` to `acc[2]`,
/// `acc[3]` (likewise); `acc[0]` and `acc[1]` see exactly the operations they see without it.
///
/// # Safety
/// `idx(i) < s.cr.len()` for every `i < n`, and `s.ci`, `s.zr`, `s.zi` (and `w` with `SIDE`)
/// hold at least `s.cr.len()` entries ([`State::is_valid`]). Why unchecked: the stereo kernel
/// reaches its modes through the pan order, and four bounds checks per mode cost as much as the
/// pan groups themselves; the mono kernel shares this loop.
#[inline(always)]
unsafe fn project<const FMA: bool, const SIDE: bool>(
    s: &State<'_>,
    n: usize,
    idx: impl Fn(usize) -> usize,
    w: &[f32],
    acc: &mut [[f32; K]; 4],
) {
    let [a0, a1, q0, q1] = acc;
    // SAFETY: every index is below `s.cr.len()` and every array is that long (contract).
    let mode = |m: usize| unsafe {
        debug_assert!(m < s.cr.len() && s.is_valid() && (!SIDE || w.len() >= s.cr.len()));
        let (zr, zi) = (*s.zr.get_unchecked(m) as f32, -(*s.zi.get_unchecked(m) as f32));
        let wm = if SIDE { *w.get_unchecked(m) } else { 0.0 };
        (
            zr,
            zi,
            wm * zr,
            wm * zi,
            s.cr.get_unchecked(m),
            s.ci.get_unchecked(m),
        )
    };
    let mut i = 0;
    while i + 1 < n {
        let (zr0, zi0, wr0, wi0, c0r, c0i) = mode(idx(i));
        let (zr1, zi1, wr1, wi1, c1r, c1i) = mode(idx(i + 1));
        for k in 0..K {
            a0[k] = madd32::<FMA>(c0r[k], zr0, a0[k]);
            a1[k] = madd32::<FMA>(c1r[k], zr1, a1[k]);
            a0[k] = madd32::<FMA>(c0i[k], zi0, a0[k]);
            a1[k] = madd32::<FMA>(c1i[k], zi1, a1[k]);
            if SIDE {
                q0[k] = madd32::<FMA>(c0r[k], wr0, q0[k]);
                q1[k] = madd32::<FMA>(c1r[k], wr1, q1[k]);
                q0[k] = madd32::<FMA>(c0i[k], wi0, q0[k]);
                q1[k] = madd32::<FMA>(c1i[k], wi1, q1[k]);
            }
        }
        i += 2;
    }
    if i < n {
        let (zr0, zi0, wr0, wi0, c0r, c0i) = mode(idx(i));
        for k in 0..K {
            a0[k] = madd32::<FMA>(c0r[k], zr0, a0[k]);
            a0[k] = madd32::<FMA>(c0i[k], zi0, a0[k]);
            if SIDE {
                q0[k] = madd32::<FMA>(c0r[k], wr0, q0[k]);
                q0[k] = madd32::<FMA>(c0i[k], wi0, q0[k]);
            }
        }
    }
}

/// Adds the step's input `x[..r]` through the summed response `resp` to `o[..r]`:
/// `y[k] += Σ_{j≤k} h[k−j]·x[j]` (`resp` holds h at K.., zeros before, so every j runs over all
/// K outputs).
#[inline(always)]
fn convolve<const FMA: bool>(resp: &[f64; 2 * K], x: &[f64; K], r: usize, o: &mut [f32]) {
    let mut acc = [0.0f64; K];
    for (j, &xj) in x[..r].iter().enumerate() {
        let h: &[f64; K] = (&resp[K - j..2 * K - j]).try_into().expect("K taps");
        for k in 0..K {
            acc[k] = madd64::<FMA>(h[k], xj, acc[k]);
        }
    }
    for (o, a) in o[..r].iter_mut().zip(&acc) {
        *o += *a as f32;
    }
}

impl Out for Mono<'_> {
    #[inline(always)]
    fn len(&self) -> usize {
        self.0.len()
    }

    #[inline(always)]
    fn split_at(self, at: usize) -> (Self, Self) {
        let (a, b) = self.0.split_at_mut(at);
        (Mono(a), Mono(b))
    }

    #[inline(always)]
    fn step<const FMA: bool>(&mut self, s: &State<'_>, at: usize) {
        let o: &mut [f32; K] = (&mut self.0[at..at + K]).try_into().expect("step of K");
        let mut acc = [[0.0f32; K]; 4];
        // SAFETY: the indices are 0..cr.len(); `render` checked the lengths.
        unsafe { project::<FMA, false>(s, s.cr.len(), |i| i, &[], &mut acc) };
        for k in 0..K {
            o[k] += acc[0][k] + acc[1][k];
        }
    }

    #[inline(always)]
    fn partial<const FMA: bool>(&mut self, s: &State<'_>, at: usize, r: usize) {
        let o = &mut self.0[at..at + r.min(K)];
        for m in 0..s.cr.len() {
            let (zr, zi) = (s.zr[m] as f32, -(s.zi[m] as f32));
            for (k, o) in o.iter_mut().enumerate() {
                *o = madd32::<FMA>(s.cr[m][k], zr, madd32::<FMA>(s.ci[m][k], zi, *o));
            }
        }
    }

    #[inline(always)]
    fn input<const FMA: bool>(&mut self, s: &State<'_>, x: &[f64; K], at: usize, r: usize) {
        convolve::<FMA>(s.resp, x, r, &mut self.0[at..]);
    }

    fn is_valid(&self, _modes: usize) -> bool {
        true
    }
}

impl Out for Stereo<'_, '_> {
    #[inline(always)]
    fn len(&self) -> usize {
        self.mid.len().min(self.os.len())
    }

    #[inline(always)]
    fn split_at(self, at: usize) -> (Self, Self) {
        let (ma, mb) = self.mid.split_at_mut(at);
        let (sa, sb) = self.os.split_at_mut(at);
        let side = self.side;
        (
            Stereo {
                side,
                mid: ma,
                os: sa,
            },
            Stereo {
                side,
                mid: mb,
                os: sb,
            },
        )
    }

    #[inline(always)]
    fn step<const FMA: bool>(&mut self, s: &State<'_>, at: usize) {
        let om: &mut [f32; K] = (&mut self.mid[at..at + K]).try_into().expect("step of K");
        let os: &mut [f32; K] = (&mut self.os[at..at + K]).try_into().expect("step of K");
        let (order, g) = (self.side.order, self.side.groups);
        let mut acc = [[0.0f32; K]; 4];
        if self.side.per_mode {
            // SAFETY: the indices are 0..cr.len(); `render` checked the lengths (`side` as
            // well, in `is_valid`).
            unsafe { project::<FMA, true>(s, s.cr.len(), |i| i, self.side.side, &mut acc) };
        } else {
            let mut start = 0;
            for i in 0..g.count {
                let group = &order[start..g.ends[i]];
                // SAFETY: `order` holds active slots, each < cr.len() (the bank's invariant, see
                // `is_valid`); `render` checked the lengths.
                unsafe { project::<FMA, false>(s, group.len(), |j| group[j] as usize, &[], &mut acc) };
                let c = g.coef[i];
                if c != 0.0 {
                    for k in 0..K {
                        acc[2][k] = madd32::<FMA>(c, acc[0][k] + acc[1][k], acc[2][k]);
                    }
                }
                start = g.ends[i];
            }
        }
        for k in 0..K {
            om[k] += acc[0][k] + acc[1][k];
            os[k] += acc[2][k] + acc[3][k];
        }
    }

    /// Per-mode side weights: partial steps are rare. The mid is summed as [`Mono`] sums, so
    /// with [`Side::per_mode`] it is the mono render bit for bit.
    #[inline(always)]
    fn partial<const FMA: bool>(&mut self, s: &State<'_>, at: usize, r: usize) {
        let r = r.min(K);
        let (om, os) = (&mut self.mid[at..at + r], &mut self.os[at..at + r]);
        for m in 0..s.cr.len() {
            let (zr, zi) = (s.zr[m] as f32, -(s.zi[m] as f32));
            let w = self.side.side[m];
            for k in 0..r {
                let y = madd32::<FMA>(s.cr[m][k], zr, s.ci[m][k] * zi);
                om[k] = madd32::<FMA>(s.cr[m][k], zr, madd32::<FMA>(s.ci[m][k], zi, om[k]));
                os[k] = madd32::<FMA>(w, y, os[k]);
            }
        }
    }

    #[inline(always)]
    fn input<const FMA: bool>(&mut self, s: &State<'_>, x: &[f64; K], at: usize, r: usize) {
        convolve::<FMA>(s.resp, x, r, &mut self.mid[at..]);
        convolve::<FMA>(self.side.resp, x, r, &mut self.os[at..]);
    }

    /// The pan order holds as many slots as there are modes and its groups end, in order,
    /// within it. That each slot is below the mode count is the bank's invariant (its order is
    /// rebuilt from the active slots whenever they change), checked in debug builds: a scan of
    /// the order every block would cost as much as the pan groups themselves.
    fn is_valid(&self, modes: usize) -> bool {
        let (order, g) = (self.side.order, self.side.groups);
        debug_assert!(order.iter().all(|&m| (m as usize) < modes));
        order.len() == modes
            && self.side.side.len() == modes
            && g.count <= g.ends.len()
            && g.ends[..g.count].windows(2).all(|e| e[0] <= e[1])
            && g.ends[..g.count].last().is_none_or(|&e| e <= order.len())
    }
}

/// `z ← p^r·z` for every mode (1 ≤ r ≤ K), in f64, vectorised across modes (padding slots
/// have p = 0 and z = 0).
#[inline(always)]
fn advance<const FMA: bool>(s: &mut State<'_>, r: usize) {
    advance_then::<FMA, false>(s, r)
}

/// [`advance`], then the flush at a block's end (`ModalBank::flush`: a state that is tiny or
/// not finite is zeroed) in the same pass, for the stereo batch's last step of a block: the new
/// state is tested while in registers instead of read back (padding slots stay zero).
#[inline(always)]
fn advance_flushed<const FMA: bool>(s: &mut State<'_>, r: usize) {
    advance_then::<FMA, true>(s, r)
}

/// [`advance`], with [`advance_flushed`]'s flush when `FLUSH`.
#[inline(always)]
fn advance_then<const FMA: bool, const FLUSH: bool>(s: &mut State<'_>, r: usize) {
    let (zr, _) = s.zr.as_chunks_mut::<W>();
    let (zi, _) = s.zi.as_chunks_mut::<W>();
    for ((zr, zi), (tr, ti)) in zr.iter_mut().zip(zi.iter_mut()).zip(s.tpr.iter().zip(s.tpi)) {
        let (qr, qi) = (&tr[r - 1], &ti[r - 1]);
        let (ar, ai) = (*zr, *zi);
        for l in 0..W {
            let nr = madd64::<FMA>(qr[l], ar[l], -(qi[l] * ai[l]));
            let ni = madd64::<FMA>(qr[l], ai[l], qi[l] * ar[l]);
            let keep = !FLUSH || (FLUSH_FLOOR..f64::INFINITY).contains(&(nr * nr + ni * ni));
            zr[l] = if keep { nr } else { 0.0 };
            zi[l] = if keep { ni } else { 0.0 };
        }
    }
}

/// `z ← p^r·z + g·u` with the input sum per mode `u = Σ_j p^{r−1−j}·x[j]
/// = x[r−1] + Σ_k p^{k+1}·x[r−2−k]` (k ≤ r−2): vertical multiply-adds over the transposed
/// powers, even and odd k in two accumulator sets to halve the dependency chain.
#[inline(always)]
fn advance_excited<const FMA: bool>(s: &mut State<'_>, x: &[f64; K], r: usize) {
    let x_last = x[r - 1];
    advance::<FMA>(s, r);
    let (zr, _) = s.zr.as_chunks_mut::<W>();
    let (zi, _) = s.zi.as_chunks_mut::<W>();
    let (gn, _) = s.gain.as_chunks::<W>();
    for (((zr, zi), g), (tr, ti)) in zr
        .iter_mut()
        .zip(zi.iter_mut())
        .zip(gn)
        .zip(s.tpr.iter().zip(s.tpi))
    {
        let (mut ur0, mut ui0) = ([0.0f64; W], [0.0f64; W]);
        let (mut ur1, mut ui1) = ([0.0f64; W], [0.0f64; W]);
        let mut k = 0;
        while k + 2 < r {
            let (x0, x1) = (x[r - 2 - k], x[r - 3 - k]);
            for l in 0..W {
                ur0[l] = madd64::<FMA>(tr[k][l], x0, ur0[l]);
                ui0[l] = madd64::<FMA>(ti[k][l], x0, ui0[l]);
                ur1[l] = madd64::<FMA>(tr[k + 1][l], x1, ur1[l]);
                ui1[l] = madd64::<FMA>(ti[k + 1][l], x1, ui1[l]);
            }
            k += 2;
        }
        if k + 1 < r {
            let x0 = x[r - 2 - k];
            for l in 0..W {
                ur0[l] = madd64::<FMA>(tr[k][l], x0, ur0[l]);
                ui0[l] = madd64::<FMA>(ti[k][l], x0, ui0[l]);
            }
        }
        for l in 0..W {
            zr[l] = madd64::<FMA>(g[l], x_last + (ur0[l] + ur1[l]), zr[l]);
            zi[l] = madd64::<FMA>(g[l], ui0[l] + ui1[l], zi[l]);
        }
    }
}

/// Free ringing over `o` (adds). Full K-sample steps use the f32 projection; a final partial
/// step of r < K samples uses the same coefficients and advances by the f64 `p^r`.
#[inline(always)]
fn free_generic<const FMA: bool, O: Out>(s: &mut State<'_>, mut o: O) {
    let n = o.len();
    let mut at = 0;
    while at + K <= n {
        o.step::<FMA>(s, at);
        advance::<FMA>(s, K);
        at += K;
    }
    if at < n {
        o.partial::<FMA>(s, at, n - at);
        advance::<FMA>(s, n - at);
    }
}

/// Excited path in steps of up to K samples (module docs): free ringing of the state, plus the
/// input convolved with the summed response, then the state advance with the input folded in.
#[inline(always)]
fn excited_generic<const FMA: bool, O: Out>(s: &mut State<'_>, input: &[f32], mut o: O) {
    let n = o.len().min(input.len());
    let mut at = 0;
    while at < n {
        let r = (n - at).min(K);
        // Sanitised input, zero-padded to K.
        let mut x = [0.0f64; K];
        for (d, &v) in x.iter_mut().zip(&input[at..at + r]) {
            let v = v as f64;
            *d = if v.is_finite() {
                v.clamp(-MAX_IMPULSE_N_S, MAX_IMPULSE_N_S)
            } else {
                0.0
            };
        }
        // Free ringing of the state at the step start.
        if r == K {
            o.step::<FMA>(s, at);
        } else {
            o.partial::<FMA>(s, at, r);
        }
        o.input::<FMA>(s, &x, at, r);
        advance_excited::<FMA>(s, &x, r);
        at += r;
    }
}

fn free_portable<O: Out>(s: &mut State<'_>, o: O) {
    free_generic::<false, O>(s, o)
}

fn excited_portable<O: Out>(s: &mut State<'_>, input: &[f32], o: O) {
    excited_generic::<false, O>(s, input, o)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn free_avx2<O: Out>(s: &mut State<'_>, o: O) {
    free_generic::<true, O>(s, o)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn excited_avx2<O: Out>(s: &mut State<'_>, input: &[f32], o: O) {
    excited_generic::<true, O>(s, input, o)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn free_avx512<O: Out>(s: &mut State<'_>, o: O) {
    free_generic::<true, O>(s, o)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn excited_avx512<O: Out>(s: &mut State<'_>, input: &[f32], o: O) {
    excited_generic::<true, O>(s, input, o)
}

fn dispatch_free<O: Out>(kernel: Kernel, s: &mut State<'_>, o: O) {
    match kernel {
        // SAFETY: `kernel` is only ever a variant whose features were detected at runtime
        // (`Kernel::detect` / `ModalBank::set_kernel` check `is_supported`).
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { free_avx512(s, o) },
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { free_avx2(s, o) },
        _ => free_portable(s, o),
    }
}

fn dispatch_excited<O: Out>(kernel: Kernel, s: &mut State<'_>, input: &[f32], o: O) {
    match kernel {
        // SAFETY: as in `dispatch_free`.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { excited_avx512(s, input, o) },
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { excited_avx2(s, input, o) },
        _ => excited_portable(s, input, o),
    }
}

/// Most banks [`render_free_stereo_batch`] renders together.
pub(super) const BATCH: usize = 16;

/// A bank's copy of its projection coefficients in pan-group runs, for
/// [`render_free_stereo_batch`]: row j (`cr[j]`, `ci[j]`) is slot `slot[j]`'s, and
/// `runs[g]` = `(start, end)` are pan group g's rows (g = 0..=[`PAN_GROUPS`], the centre last).
pub(super) struct Runs<'a> {
    pub(super) cr: &'a [[f32; K]],
    pub(super) ci: &'a [[f32; K]],
    pub(super) slot: &'a [u16],
    pub(super) runs: &'a [(usize, usize); PAN_GROUPS + 1],
}

/// One bank of a stereo batch: its state, its pan groups (for a final partial step) and runs.
pub(super) type BatchView<'a> = (State<'a>, Side<'a>, Runs<'a>);

/// Steps [`render_free_stereo_batch`] renders per pass over its banks. Why 4: a bank's rows
/// are read from the outer caches once per pass and from L1 for its other steps (as the mono
/// kernel reads them once per block), while the pass's mid and side sums (4 × 2 × K f32, 1 kB)
/// stay in L1 beside them.
const PASS_STEPS: usize = 4;

/// Adds the free ringing over one full step of the rows `cr`, `ci` (one run) to `acc[0]`,
/// `acc[1]` (even and odd rows), each row's state being slot `slot[j]`'s: [`project`] over
/// the rows in memory order, the state through the slot. A run's odd last row puts its real
/// part in `acc[0]` and its imaginary part in `acc[1]`, so it costs one multiply-add of
/// latency per accumulator, as a row of a pair does: runs are short (about 7 rows in a 64-mode
/// bank of 9 pan groups) and half of them end on an odd row.
///
/// # Safety
/// `cr`, `ci` and `slot` are equally long and every `slot[j]` < `zr.len()`, `zi.len()`.
/// Why unchecked: as in [`project`], two bounds checks per row would cost as much as the run
/// bookkeeping.
#[inline(always)]
unsafe fn project_run<const FMA: bool>(
    zr: &[f64],
    zi: &[f64],
    cr: &[[f32; K]],
    ci: &[[f32; K]],
    slot: &[u16],
    acc: &mut [[f32; K]; 2],
) {
    let [a0, a1] = acc;
    let n = slot.len();
    // SAFETY: j < n, the rows' length, and every slot indexes the state (contract).
    let row = |j: usize| unsafe {
        debug_assert!(
            j < cr.len() && j < ci.len() && (*slot.get_unchecked(j) as usize) < zr.len().min(zi.len())
        );
        let m = *slot.get_unchecked(j) as usize;
        let (zr, zi) = (*zr.get_unchecked(m) as f32, -(*zi.get_unchecked(m) as f32));
        (zr, zi, cr.get_unchecked(j), ci.get_unchecked(j))
    };
    let mut j = 0;
    while j + 1 < n {
        let (zr0, zi0, c0r, c0i) = row(j);
        let (zr1, zi1, c1r, c1i) = row(j + 1);
        for k in 0..K {
            a0[k] = madd32::<FMA>(c0r[k], zr0, a0[k]);
            a1[k] = madd32::<FMA>(c1r[k], zr1, a1[k]);
            a0[k] = madd32::<FMA>(c0i[k], zi0, a0[k]);
            a1[k] = madd32::<FMA>(c1i[k], zi1, a1[k]);
        }
        j += 2;
    }
    if j < n {
        let (zr0, zi0, c0r, c0i) = row(j);
        for k in 0..K {
            a0[k] = madd32::<FMA>(c0r[k], zr0, a0[k]);
            a1[k] = madd32::<FMA>(c0i[k], zi0, a1[k]);
        }
    }
}

/// Free ringing of several stereo banks at once into one mid and side (adds), for banks with
/// the same pan weights (`weights[g]`, the side weight of pan group g).
///
/// Why this way: each bank renders its steps one after another, as in mono, each step reading
/// the bank's pan-sorted copy of its coefficients ([`Runs`]) front to back, so they come from
/// the outer caches once per pass ([`PASS_STEPS`]) and from L1 after, and the prefetchers
/// follow them as they follow the mono kernel's. The side is summed by parts, as by
/// [`Stereo`]: the mid's accumulators run on through the bank's runs with exactly the mono
/// kernel's multiply-adds per mode, and at each pan group's end the side takes the running sum
/// times the difference of that group's weight and the next's, `Σ_g (w_g − w_{g+1})·C_g`
/// (`C_g` the sum of the runs up to g's, the centre last with weight 0). That is
/// `Σ_g w_g·Y_g` (`Y_g` the sum of group g's modes), at K adds and K multiply-adds per group
/// and step, all in registers and off the accumulators' dependency chains, which bound the
/// mono kernel. Reading the coefficients in pan order from the slots instead cost about as much
/// as the multiply-adds again (scattered reads wait on the caches); a sum per group in memory,
/// loaded and stored around each run, took 3 % more instructions than the sum by parts
/// (docs/bench/README.md).
///
/// Each bank's state is flushed (as by `ModalBank::flush`) with its block's last advance. Views
/// whose state or runs would index out of bounds render nothing (as in [`render`]).
pub(super) fn render_free_stereo_batch(
    kernel: Kernel,
    views: &mut [Option<BatchView<'_>>],
    weights: &[f32; PAN_GROUPS],
    mid: &mut [f32],
    side: &mut [f32],
) {
    for v in views.iter_mut() {
        let ok = v.as_ref().is_some_and(|(s, sd, r)| {
            let rows = r.cr.len().min(r.ci.len()).min(r.slot.len());
            let (mut sum, mut prev) = (0, 0);
            let runs_ok = r.runs.iter().all(|&(b, e)| {
                let ok = prev <= b && b <= e && e <= rows;
                sum += e - b;
                prev = e;
                ok
            });
            debug_assert!(r
                .runs
                .iter()
                .all(|&(b, e)| r.slot[b.min(e)..e].iter().all(|&m| (m as usize) < s.cr.len())));
            s.is_valid() && runs_ok && sum == s.cr.len() && sd.side.len() == s.cr.len()
        });
        if !ok {
            *v = None;
        }
    }
    let len = mid.len().min(side.len());
    let (mid, side) = (&mut mid[..len], &mut side[..len]);
    match kernel {
        // SAFETY: as in `dispatch_free`.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { batch_avx512(views, weights, mid, side) },
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { batch_avx2(views, weights, mid, side) },
        _ => batch_generic::<false>(views, weights, mid, side),
    }
}

/// A batch of checked views ([`render_free_stereo_batch`]).
type Views<'v, 'a> = &'v mut [Option<BatchView<'a>>];

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn batch_avx512(v: Views<'_, '_>, w: &[f32; PAN_GROUPS], m: &mut [f32], s: &mut [f32]) {
    batch_generic::<true>(v, w, m, s)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn batch_avx2(v: Views<'_, '_>, w: &[f32; PAN_GROUPS], m: &mut [f32], s: &mut [f32]) {
    batch_generic::<true>(v, w, m, s)
}

/// [`render_free_stereo_batch`] once the views are checked (`mid` and `side` of equal length).
#[inline(always)]
fn batch_generic<const FMA: bool>(
    views: Views<'_, '_>,
    weights: &[f32; PAN_GROUPS],
    mid: &mut [f32],
    side: &mut [f32],
) {
    // The by-parts coefficient of each pan group's running sum: its weight less the next's
    // (the centre's, 0, after the last).
    let coef: [f32; PAN_GROUPS] =
        std::array::from_fn(|g| weights[g] - weights.get(g + 1).copied().unwrap_or(0.0));
    let n = mid.len();
    let mut at = 0;
    while at + K <= n {
        let steps = ((n - at) / K).min(PASS_STEPS);
        // Per step of the pass: the batch's mid and side.
        let mut sums = [[[0.0f32; K]; 2]; PASS_STEPS];
        let last_pass = at + steps * K == n;
        for (s, _, r) in views.iter_mut().flatten() {
            for (i, [sm, ss]) in sums[..steps].iter_mut().enumerate() {
                let mut acc = [[0.0f32; K]; 2];
                let mut q = [0.0f32; K];
                for (g, &(b, e)) in r.runs.iter().enumerate() {
                    // SAFETY: b ≤ e ≤ the rows' length and every slot of a run is below the
                    // state's mode count (checked by the caller, the slots in debug builds).
                    unsafe {
                        let (cr, ci, slot) = (
                            r.cr.get_unchecked(b..e),
                            r.ci.get_unchecked(b..e),
                            r.slot.get_unchecked(b..e),
                        );
                        project_run::<FMA>(s.zr, s.zi, cr, ci, slot, &mut acc);
                    }
                    if let Some(&c) = coef.get(g) {
                        for k in 0..K {
                            q[k] = madd32::<FMA>(c, acc[0][k] + acc[1][k], q[k]);
                        }
                    }
                }
                for k in 0..K {
                    sm[k] += acc[0][k] + acc[1][k];
                    ss[k] += q[k];
                }
                if last_pass && i + 1 == steps {
                    advance_flushed::<FMA>(s, K);
                } else {
                    advance::<FMA>(s, K);
                }
            }
        }
        for (i, [sm, ss]) in sums[..steps].iter().enumerate() {
            for (o, v) in mid[at + i * K..at + (i + 1) * K].iter_mut().zip(sm) {
                *o += v;
            }
            for (o, v) in side[at + i * K..at + (i + 1) * K].iter_mut().zip(ss) {
                *o += v;
            }
        }
        at += steps * K;
    }
    if at < n {
        for (s, sd, _) in views.iter_mut().flatten() {
            let mut o = Stereo {
                side: sd,
                mid: &mut mid[at..],
                os: &mut side[at..],
            };
            o.partial::<FMA>(s, 0, n - at);
            advance_flushed::<FMA>(s, n - at);
        }
    }
}

/// Renders one block into `o` (adds): excited over the input's length, free ringing after it
/// (`None`: free ringing throughout). A state or output whose indices are out of bounds renders
/// nothing (it cannot arise from the bank; the check keeps the unchecked projection sound).
pub(super) fn render<O: Out>(kernel: Kernel, s: &mut State<'_>, input: Option<&[f32]>, o: O) {
    if !s.is_valid() || !o.is_valid(s.cr.len()) {
        return;
    }
    match input {
        Some(x) => {
            let n = o.len();
            let len = n.min(x.len());
            let (head, tail) = o.split_at(len);
            dispatch_excited(kernel, s, &x[..len], head);
            if len < n {
                dispatch_free(kernel, s, tail);
            }
        }
        None => dispatch_free(kernel, s, o),
    }
}
