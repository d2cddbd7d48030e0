//! The bank's per-block kernels (free ringing and excited, see the module docs of
//! [`super`]) and their SIMD variants ([`crate::engine::dsp::simd`]).

use super::{Kernel, K, MAX_IMPULSE_N_S, PAN_GROUPS, W};

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

/// The stereo kernels' view of the pan groups: `order[..ends[i]]` are the slots of the first
/// `i + 1` non-empty pan groups (`count` of them), `coef[i]` the side coefficient of that
/// cumulative sum (see [`project_step_stereo`]), `side` the per-slot side weights (partial
/// steps), `resp` the summed side impulse response.
pub(super) struct Side<'a> {
    pub(super) order: &'a [u16],
    pub(super) count: usize,
    pub(super) ends: [usize; PAN_GROUPS + 1],
    pub(super) coef: [f32; PAN_GROUPS + 1],
    pub(super) side: &'a [f32],
    pub(super) resp: &'a [f64; 2 * K],
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

/// Adds the free ringing of the state over one full step, `o[k] += Re(p^{k+1}·z)` summed over
/// the modes (f32 projection), without advancing the state.
#[inline(always)]
fn project_step<const FMA: bool>(s: &State<'_>, o: &mut [f32; K]) {
    let n_modes = s.cr.len();
    // Two accumulator sets (even/odd modes) so consecutive modes' multiply-adds do not
    // wait on each other's latency.
    let mut a0 = [0.0f32; K];
    let mut a1 = [0.0f32; K];
    let mut m = 0;
    while m + 1 < n_modes {
        let (zr0, zi0) = (s.zr[m] as f32, -(s.zi[m] as f32));
        let (zr1, zi1) = (s.zr[m + 1] as f32, -(s.zi[m + 1] as f32));
        let (c0r, c0i) = (&s.cr[m], &s.ci[m]);
        let (c1r, c1i) = (&s.cr[m + 1], &s.ci[m + 1]);
        for k in 0..K {
            a0[k] = madd32::<FMA>(c0r[k], zr0, a0[k]);
            a1[k] = madd32::<FMA>(c1r[k], zr1, a1[k]);
            a0[k] = madd32::<FMA>(c0i[k], zi0, a0[k]);
            a1[k] = madd32::<FMA>(c1i[k], zi1, a1[k]);
        }
        m += 2;
    }
    if m < n_modes {
        let (zr0, zi0) = (s.zr[m] as f32, -(s.zi[m] as f32));
        for k in 0..K {
            a0[k] = madd32::<FMA>(s.cr[m][k], zr0, a0[k]);
            a0[k] = madd32::<FMA>(s.ci[m][k], zi0, a0[k]);
        }
    }
    for k in 0..K {
        o[k] += a0[k] + a1[k];
    }
}

/// Adds the free ringing of the modes `idx` over one full step, `Σ_m Re(p^{k+1}·z_m)`, to the
/// two accumulator sets (even and odd positions), as [`project_step`] sums it.
#[inline(always)]
fn project_indexed<const FMA: bool>(s: &State<'_>, idx: &[u16], a0: &mut [f32; K], a1: &mut [f32; K]) {
    let mut pairs = idx.chunks_exact(2);
    for p in &mut pairs {
        let (m0, m1) = (p[0] as usize, p[1] as usize);
        let (zr0, zi0) = (s.zr[m0] as f32, -(s.zi[m0] as f32));
        let (zr1, zi1) = (s.zr[m1] as f32, -(s.zi[m1] as f32));
        let (c0r, c0i) = (&s.cr[m0], &s.ci[m0]);
        let (c1r, c1i) = (&s.cr[m1], &s.ci[m1]);
        for k in 0..K {
            a0[k] = madd32::<FMA>(c0r[k], zr0, a0[k]);
            a1[k] = madd32::<FMA>(c1r[k], zr1, a1[k]);
            a0[k] = madd32::<FMA>(c0i[k], zi0, a0[k]);
            a1[k] = madd32::<FMA>(c1i[k], zi1, a1[k]);
        }
    }
    if let [m] = *pairs.remainder() {
        let m = m as usize;
        let (zr0, zi0) = (s.zr[m] as f32, -(s.zi[m] as f32));
        for k in 0..K {
            a0[k] = madd32::<FMA>(s.cr[m][k], zr0, a0[k]);
            a0[k] = madd32::<FMA>(s.ci[m][k], zi0, a0[k]);
        }
    }
}

/// Stereo [`project_step`]. The side `Σ_g w_g·Y_g` (`Y_g` the sum of pan group g's modes) is
/// summed by parts, `Σ_g (w_g − w_{g+1})·C_g` over the cumulative sums `C_g = Y_0 + … + Y_g`:
/// the accumulators run on through every group as in mono (no reset, no per-group
/// combine), and at each group's end the side takes one multiply-add of the running sum. So the
/// per-mode work is the mono kernel's and a pan group costs K adds and K multiply-adds per step.
#[inline(always)]
fn project_step_stereo<const FMA: bool>(s: &State<'_>, st: &Side<'_>, om: &mut [f32; K], os: &mut [f32; K]) {
    let mut a0 = [0.0f32; K];
    let mut a1 = [0.0f32; K];
    let mut q = [0.0f32; K];
    let mut start = 0;
    for i in 0..st.count {
        let end = st.ends[i];
        project_indexed::<FMA>(s, &st.order[start..end], &mut a0, &mut a1);
        let c = st.coef[i];
        if c != 0.0 {
            for k in 0..K {
                q[k] = madd32::<FMA>(c, a0[k] + a1[k], q[k]);
            }
        }
        start = end;
    }
    for k in 0..K {
        om[k] += a0[k] + a1[k];
        os[k] += q[k];
    }
}

/// Stereo [`project_partial`] (per-mode side weights; partial steps are rare).
#[inline(always)]
fn project_partial_stereo<const FMA: bool>(s: &State<'_>, st: &Side<'_>, om: &mut [f32], os: &mut [f32]) {
    let r = om.len().min(os.len()).min(K);
    for m in 0..s.cr.len() {
        let (zr, zi) = (s.zr[m] as f32, -(s.zi[m] as f32));
        let w = st.side[m];
        for k in 0..r {
            let y = madd32::<FMA>(s.cr[m][k], zr, s.ci[m][k] * zi);
            om[k] += y;
            os[k] = madd32::<FMA>(w, y, os[k]);
        }
    }
}

/// Adds the free ringing of a partial step of `o.len()` < K samples (no state advance).
#[inline(always)]
fn project_partial<const FMA: bool>(s: &State<'_>, o: &mut [f32]) {
    let r = o.len().min(K);
    for m in 0..s.cr.len() {
        let (zr, zi) = (s.zr[m] as f32, -(s.zi[m] as f32));
        for k in 0..r {
            o[k] = madd32::<FMA>(s.cr[m][k], zr, madd32::<FMA>(s.ci[m][k], zi, o[k]));
        }
    }
}

/// `z ← p^r·z` for every mode (1 ≤ r ≤ K), in f64, vectorised across modes (padding slots
/// have p = 0 and z = 0).
#[inline(always)]
fn advance<const FMA: bool>(s: &mut State<'_>, r: usize) {
    let (zr, _) = s.zr.as_chunks_mut::<W>();
    let (zi, _) = s.zi.as_chunks_mut::<W>();
    for ((zr, zi), (tr, ti)) in zr.iter_mut().zip(zi.iter_mut()).zip(s.tpr.iter().zip(s.tpi)) {
        let (qr, qi) = (&tr[r - 1], &ti[r - 1]);
        let (ar, ai) = (*zr, *zi);
        for l in 0..W {
            zr[l] = madd64::<FMA>(qr[l], ar[l], -(qi[l] * ai[l]));
            zi[l] = madd64::<FMA>(qr[l], ai[l], qi[l] * ar[l]);
        }
    }
}

/// Free ringing over `out` (adds). Full K-sample steps use the f32 projection; a final partial
/// step of r < K samples uses the same coefficients and advances by the f64 `p^r`.
#[inline(always)]
fn free_generic<const FMA: bool>(mut s: State<'_>, out: &mut [f32]) {
    let mut chunks = out.chunks_exact_mut(K);
    for o in &mut chunks {
        let o: &mut [f32; K] = o.try_into().expect("chunk of K");
        project_step::<FMA>(&s, o);
        advance::<FMA>(&mut s, K);
    }
    let o = chunks.into_remainder();
    if !o.is_empty() {
        project_partial::<FMA>(&s, o);
        advance::<FMA>(&mut s, o.len());
    }
}

/// Stereo [`free_generic`]: mid into `om`, side into `os` (adds; equal lengths).
#[inline(always)]
fn free_stereo_generic<const FMA: bool>(mut s: State<'_>, st: &Side<'_>, om: &mut [f32], os: &mut [f32]) {
    let mut cm = om.chunks_exact_mut(K);
    let mut cs = os.chunks_exact_mut(K);
    for (m, x) in (&mut cm).zip(&mut cs) {
        let m: &mut [f32; K] = m.try_into().expect("chunk of K");
        let x: &mut [f32; K] = x.try_into().expect("chunk of K");
        project_step_stereo::<FMA>(&s, st, m, x);
        advance::<FMA>(&mut s, K);
    }
    let (m, x) = (cm.into_remainder(), cs.into_remainder());
    if !m.is_empty() {
        project_partial_stereo::<FMA>(&s, st, m, x);
        advance::<FMA>(&mut s, m.len());
    }
}

/// Excited path in steps of up to K samples (module docs): free ringing of the state, plus the
/// input convolved with the summed response, then the state advance with the input folded in.
#[inline(always)]
fn excited_generic<const FMA: bool>(mut s: State<'_>, input: &[f32], out: &mut [f32]) {
    for (o, x) in out.chunks_mut(K).zip(input.chunks(K)) {
        let r = o.len().min(x.len());
        // Sanitised input, zero-padded to K.
        let mut xb = [0.0f64; K];
        for (d, &v) in xb.iter_mut().zip(&x[..r]) {
            let v = v as f64;
            *d = if v.is_finite() {
                v.clamp(-MAX_IMPULSE_N_S, MAX_IMPULSE_N_S)
            } else {
                0.0
            };
        }
        // Free ringing of the state at the step start.
        if r == K {
            let o: &mut [f32; K] = (&mut o[..K]).try_into().expect("chunk of K");
            project_step::<FMA>(&s, o);
        } else {
            project_partial::<FMA>(&s, &mut o[..r]);
        }
        // The step's input through the summed response: y[k] += Σ_{j≤k} h[k−j]·x[j]
        // (`resp` holds h at K.., zeros before, so every j runs over all K outputs).
        let mut acc = [0.0f64; K];
        for (j, &xj) in xb[..r].iter().enumerate() {
            let h: &[f64; K] = (&s.resp[K - j..2 * K - j]).try_into().expect("K taps");
            for k in 0..K {
                acc[k] = madd64::<FMA>(h[k], xj, acc[k]);
            }
        }
        for (o, a) in o[..r].iter_mut().zip(&acc) {
            *o += *a as f32;
        }
        // Input sum per mode u = Σ_j p^{r−1−j}·x[j] = x[r−1] + Σ_k p^{k+1}·x[r−2−k]
        // (k ≤ r−2), vertical multiply-adds over the transposed powers; even and odd k in two
        // accumulator sets to halve the dependency chain.
        let x_last = xb[r - 1];
        advance::<FMA>(&mut s, r);
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
                let (x0, x1) = (xb[r - 2 - k], xb[r - 3 - k]);
                for l in 0..W {
                    ur0[l] = madd64::<FMA>(tr[k][l], x0, ur0[l]);
                    ui0[l] = madd64::<FMA>(ti[k][l], x0, ui0[l]);
                    ur1[l] = madd64::<FMA>(tr[k + 1][l], x1, ur1[l]);
                    ui1[l] = madd64::<FMA>(ti[k + 1][l], x1, ui1[l]);
                }
                k += 2;
            }
            if k + 1 < r {
                let x0 = xb[r - 2 - k];
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
}

/// Stereo [`excited_generic`]: the mid as in mono, the side through the side response.
#[inline(always)]
fn excited_stereo_generic<const FMA: bool>(
    mut s: State<'_>,
    st: &Side<'_>,
    input: &[f32],
    om: &mut [f32],
    os: &mut [f32],
) {
    for ((o, q), x) in om.chunks_mut(K).zip(os.chunks_mut(K)).zip(input.chunks(K)) {
        let r = o.len().min(q.len()).min(x.len());
        // Sanitised input, zero-padded to K.
        let mut xb = [0.0f64; K];
        for (d, &v) in xb.iter_mut().zip(&x[..r]) {
            let v = v as f64;
            *d = if v.is_finite() {
                v.clamp(-MAX_IMPULSE_N_S, MAX_IMPULSE_N_S)
            } else {
                0.0
            };
        }
        // Free ringing of the state at the step start.
        if r == K {
            let o: &mut [f32; K] = (&mut o[..K]).try_into().expect("chunk of K");
            let q: &mut [f32; K] = (&mut q[..K]).try_into().expect("chunk of K");
            project_step_stereo::<FMA>(&s, st, o, q);
        } else {
            project_partial_stereo::<FMA>(&s, st, &mut o[..r], &mut q[..r]);
        }
        // The step's input through the summed response: y[k] += Σ_{j≤k} h[k−j]·x[j]
        // (`resp` holds h at K.., zeros before, so every j runs over all K outputs).
        let mut acc = [0.0f64; K];
        let mut acs = [0.0f64; K];
        for (j, &xj) in xb[..r].iter().enumerate() {
            let h: &[f64; K] = (&s.resp[K - j..2 * K - j]).try_into().expect("K taps");
            let hs: &[f64; K] = (&st.resp[K - j..2 * K - j]).try_into().expect("K taps");
            for k in 0..K {
                acc[k] = madd64::<FMA>(h[k], xj, acc[k]);
                acs[k] = madd64::<FMA>(hs[k], xj, acs[k]);
            }
        }
        for (o, a) in o[..r].iter_mut().zip(&acc) {
            *o += *a as f32;
        }
        for (q, a) in q[..r].iter_mut().zip(&acs) {
            *q += *a as f32;
        }
        // Input sum per mode u = Σ_j p^{r−1−j}·x[j] = x[r−1] + Σ_k p^{k+1}·x[r−2−k]
        // (k ≤ r−2), vertical multiply-adds over the transposed powers; even and odd k in two
        // accumulator sets to halve the dependency chain.
        let x_last = xb[r - 1];
        advance::<FMA>(&mut s, r);
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
                let (x0, x1) = (xb[r - 2 - k], xb[r - 3 - k]);
                for l in 0..W {
                    ur0[l] = madd64::<FMA>(tr[k][l], x0, ur0[l]);
                    ui0[l] = madd64::<FMA>(ti[k][l], x0, ui0[l]);
                    ur1[l] = madd64::<FMA>(tr[k + 1][l], x1, ur1[l]);
                    ui1[l] = madd64::<FMA>(ti[k + 1][l], x1, ui1[l]);
                }
                k += 2;
            }
            if k + 1 < r {
                let x0 = xb[r - 2 - k];
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
}

fn free_portable(s: State<'_>, out: &mut [f32]) {
    free_generic::<false>(s, out)
}

fn excited_portable(s: State<'_>, input: &[f32], out: &mut [f32]) {
    excited_generic::<false>(s, input, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn free_avx2(s: State<'_>, out: &mut [f32]) {
    free_generic::<true>(s, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn excited_avx2(s: State<'_>, input: &[f32], out: &mut [f32]) {
    excited_generic::<true>(s, input, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn free_avx512(s: State<'_>, out: &mut [f32]) {
    free_generic::<true>(s, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn excited_avx512(s: State<'_>, input: &[f32], out: &mut [f32]) {
    excited_generic::<true>(s, input, out)
}

fn free_stereo_portable(s: State<'_>, st: &Side<'_>, om: &mut [f32], os: &mut [f32]) {
    free_stereo_generic::<false>(s, st, om, os)
}

fn excited_stereo_portable(s: State<'_>, st: &Side<'_>, input: &[f32], om: &mut [f32], os: &mut [f32]) {
    excited_stereo_generic::<false>(s, st, input, om, os)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn free_stereo_avx2(s: State<'_>, st: &Side<'_>, om: &mut [f32], os: &mut [f32]) {
    free_stereo_generic::<true>(s, st, om, os)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn excited_stereo_avx2(s: State<'_>, st: &Side<'_>, input: &[f32], om: &mut [f32], os: &mut [f32]) {
    excited_stereo_generic::<true>(s, st, input, om, os)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn free_stereo_avx512(s: State<'_>, st: &Side<'_>, om: &mut [f32], os: &mut [f32]) {
    free_stereo_generic::<true>(s, st, om, os)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn excited_stereo_avx512(s: State<'_>, st: &Side<'_>, input: &[f32], om: &mut [f32], os: &mut [f32]) {
    excited_stereo_generic::<true>(s, st, input, om, os)
}

pub(super) fn dispatch_free_stereo(
    kernel: Kernel,
    s: State<'_>,
    st: &Side<'_>,
    om: &mut [f32],
    os: &mut [f32],
) {
    match kernel {
        // SAFETY: as in `dispatch_free`.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { free_stereo_avx512(s, st, om, os) },
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { free_stereo_avx2(s, st, om, os) },
        _ => free_stereo_portable(s, st, om, os),
    }
}

pub(super) fn dispatch_excited_stereo(
    kernel: Kernel,
    s: State<'_>,
    st: &Side<'_>,
    input: &[f32],
    om: &mut [f32],
    os: &mut [f32],
) {
    match kernel {
        // SAFETY: as in `dispatch_free`.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { excited_stereo_avx512(s, st, input, om, os) },
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { excited_stereo_avx2(s, st, input, om, os) },
        _ => excited_stereo_portable(s, st, input, om, os),
    }
}

pub(super) fn dispatch_free(kernel: Kernel, s: State<'_>, out: &mut [f32]) {
    match kernel {
        // SAFETY: `kernel` is only ever a variant whose features were detected at runtime
        // (`Kernel::detect` / `ModalBank::set_kernel` check `is_supported`).
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { free_avx512(s, out) },
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { free_avx2(s, out) },
        _ => free_portable(s, out),
    }
}

pub(super) fn dispatch_excited(kernel: Kernel, s: State<'_>, input: &[f32], out: &mut [f32]) {
    match kernel {
        // SAFETY: as in `dispatch_free`.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx512 => unsafe { excited_avx512(s, input, out) },
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx2 => unsafe { excited_avx2(s, input, out) },
        _ => excited_portable(s, input, out),
    }
}
