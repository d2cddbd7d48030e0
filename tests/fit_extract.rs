//! Synthetic ground truth for mode extraction: known modes + white noise at 30 dB SNR +
//! leading silence + DC + a fade-out gate.

use rand::{RngExt, SeedableRng};
use tactus::fit::extract::{extract, synthesize, Mode};

fn truth() -> Vec<Mode> {
    // 20 modes 180 Hz..9 kHz, levels 0..−38 dB, decays 8..160 dB/s.
    let mut v = Vec::new();
    for i in 0..20 {
        let t = i as f64 / 19.0;
        let f = 180.0 * (50.0f64).powf(t) * (1.0 + 0.03 * ((i * 7 % 5) as f64 - 2.0));
        v.push(Mode {
            freq_hz: f,
            level_db: -6.0 - 32.0 * t + 3.0 * ((i * 3 % 4) as f64 - 1.5),
            decay_db_per_s: 8.0 * 20f64.powf(t) * (1.0 + 0.1 * ((i % 3) as f64 - 1.0)),
            phase: 0.37 * i as f64,
        });
    }
    v
}

fn gaussian(rng: &mut rand::rngs::StdRng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

fn run(fs: f64) {
    let modes = truth();
    let n = (1.6 * fs) as usize;
    let lead = (0.1 * fs) as usize;
    let clean = synthesize(&modes, fs, n - lead);
    let rms = (clean[..(0.2 * fs) as usize].iter().map(|v| v * v).sum::<f64>() / (0.2 * fs)).sqrt();
    let noise_rms = rms * 10f64.powf(-30.0 / 20.0);
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let fade_start = (1.2 * fs) as usize;
    let fade_len = (0.2 * fs) as usize;
    let mut x = vec![0.0; n];
    for i in 0..n {
        let s = if i >= lead { clean[i - lead] } else { 0.0 };
        let mut v = 0.01 + s + noise_rms * gaussian(&mut rng);
        if i >= fade_start {
            v *= (1.0 - (i - fade_start) as f64 / fade_len as f64).max(0.0);
        }
        x[i] = v;
    }
    let ex = extract(&x, fs, 50);
    let mut strongest = modes.clone();
    strongest.sort_by(|a, b| b.level_db.total_cmp(&a.level_db));
    let (mut wf, mut wd, mut wl) = (0.0f64, 0.0f64, 0.0f64);
    for m in &strongest[..15] {
        let got = ex
            .modes
            .iter()
            .min_by(|a, b| {
                (a.freq_hz - m.freq_hz)
                    .abs()
                    .total_cmp(&(b.freq_hz - m.freq_hz).abs())
            })
            .expect("some modes found");
        let ef = (got.freq_hz - m.freq_hz).abs() / m.freq_hz;
        let ed = (got.decay_db_per_s - m.decay_db_per_s).abs() / m.decay_db_per_s;
        let el = (got.level_db - m.level_db).abs();
        eprintln!(
            "f {:8.2} got {:8.2} ({:.4} %)  b {:7.2} got {:7.2} ({:.2} %)  a {:6.2} got {:6.2}",
            m.freq_hz,
            got.freq_hz,
            100.0 * ef,
            m.decay_db_per_s,
            got.decay_db_per_s,
            100.0 * ed,
            m.level_db,
            got.level_db
        );
        wf = wf.max(ef);
        wd = wd.max(ed);
        wl = wl.max(el);
    }
    eprintln!(
        "fs {fs}: worst freq error {:.4} %, decay error {:.2} %, level error {:.2} dB",
        100.0 * wf,
        100.0 * wd,
        wl
    );
    assert!(wf <= 0.001, "frequency error {wf}");
    assert!(wd <= 0.05, "decay error {wd}");
    assert!(wl <= 1.0, "level error {wl} dB");
}

#[test]
fn recovers_synthetic_modes_44k() {
    run(44_100.0);
}

#[test]
fn recovers_synthetic_modes_20k() {
    run(20_000.0);
}
