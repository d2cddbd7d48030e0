//! Synthetic ground truth for mode extraction: known modes + white noise at 30 dB SNR +
//! leading silence + DC + a fade-out gate.

use rand::{RngExt, SeedableRng};
use tactus::analysis::signal::Mode;
use tactus::fit::recording::extract::{extract, synthesize};
use tactus::fit::traer::{extract_traer, TRAER_MODES};

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
            attack_s: 0.0,
            ring: None,
        });
    }
    v
}

fn gaussian(rng: &mut rand::rngs::StdRng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// The synthetic recording at `fs`: the truth's modes after 0.1 s of silence, DC 0.01, white
/// noise at 30 dB SNR, and a fade-out gate from 1.2 s to 1.4 s.
fn recording(fs: f64) -> Vec<f64> {
    recording_with_attack(fs, 0.0)
}

/// As [`recording`], every mode building up as `1 − e^{−t/attack_s}` (0: none).
fn recording_with_attack(fs: f64, attack_s: f64) -> Vec<f64> {
    let modes: Vec<Mode> = truth().into_iter().map(|m| Mode { attack_s, ..m }).collect();
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
    x
}

/// The truth's 15 strongest modes, each paired with the extracted mode nearest in frequency.
fn matched(got: &[Mode]) -> Vec<(Mode, Mode)> {
    let mut strongest = truth();
    strongest.sort_by(|a, b| b.level_db.total_cmp(&a.level_db));
    strongest[..15]
        .iter()
        .map(|m| {
            let g = got
                .iter()
                .min_by(|a, b| {
                    (a.freq_hz - m.freq_hz)
                        .abs()
                        .total_cmp(&(b.freq_hz - m.freq_hz).abs())
                })
                .expect("some modes found");
            (*m, *g)
        })
        .collect()
}

/// Worst and mean (frequency error relative, decay error relative, level error dB) over the
/// truth's 15 strongest modes, each matched to the nearest extracted frequency.
fn errors(got: &[Mode], print: bool) -> ([f64; 3], [f64; 3]) {
    let (mut worst, mut mean) = ([0.0f64; 3], [0.0f64; 3]);
    for (m, got) in &matched(got) {
        let e = [
            (got.freq_hz - m.freq_hz).abs() / m.freq_hz,
            (got.decay_db_per_s - m.decay_db_per_s).abs() / m.decay_db_per_s,
            (got.level_db - m.level_db).abs(),
        ];
        if print {
            eprintln!(
                "f {:8.2} got {:8.2} ({:.4} %)  b {:7.2} got {:7.2} ({:.2} %)  a {:6.2} got {:6.2}  \
                 attack got {:.3} ms",
                m.freq_hz,
                got.freq_hz,
                100.0 * e[0],
                m.decay_db_per_s,
                got.decay_db_per_s,
                100.0 * e[1],
                m.level_db,
                got.level_db,
                1e3 * got.attack_s
            );
        }
        for i in 0..3 {
            worst[i] = worst[i].max(e[i]);
            mean[i] += e[i] / 15.0;
        }
    }
    (worst, mean)
}

fn run(fs: f64) {
    run_with_attack(fs, 0.0);
}

/// Extracts [`recording_with_attack`] and checks the bounds on the 15 strongest modes
/// and that the attack time is the grid value used to make it (`extract::ATTACK_GRID_S`).
fn run_with_attack(fs: f64, attack_s: f64) {
    let ex = extract(&recording_with_attack(fs, attack_s), fs, 50);
    let ([wf, wd, wl], _) = errors(&ex.modes, true);
    eprintln!(
        "fs {fs}, attack {:.1} ms: worst freq error {:.4} %, decay error {:.2} %, level error {:.2} dB; \
         fitted attack {:.1} ms",
        1e3 * attack_s,
        100.0 * wf,
        100.0 * wd,
        wl,
        1e3 * ex.attack_s
    );
    assert_eq!(ex.attack_s, attack_s, "fitted attack time");
    // Each mode's own attack (`Mode::attack_s`, refined per mode after the common one): the
    // nearest extracted mode to each of the 15 strongest true modes; one miss is allowed
    // (measured: no miss with the 8 ms attack; without an attack one mode at 1 ms in one run).
    let right = matched(&ex.modes)
        .iter()
        .filter(|(_, got)| got.attack_s == attack_s)
        .count();
    assert!(right >= 14, "only {right}/15 modes with the true attack time");
    assert!(wf <= 0.001, "frequency error {wf}");
    assert!(wd <= 0.05, "decay error {wd}");
    assert!(wl <= 1.0, "level error {wl} dB");
}

/// Issue #4 asks to compare the shipped extractor with Traer et al.'s iterative spectrogram
/// matching on synthetic ground truth (`tactus::fit::traer`, docs/presets.md "Extraction on synthetic ground truth").
/// The shipped one must be better on every measure, worst case against the baseline's *mean*;
/// the baseline's own correctness is checked on clean, well-separated modes
/// (`spectrogram_matching_recovers_clean_separated_modes`), so the comparison is not against a
/// broken implementation.
#[test]
fn shipped_extractor_beats_spectrogram_matching() {
    for fs in [44_100.0, 20_000.0] {
        let x = recording(fs);
        let shipped = extract(&x, fs, 50);
        let baseline = extract_traer(&x, fs, TRAER_MODES);
        let (ws, ms) = errors(&shipped.modes, false);
        let (wb, mb) = errors(&baseline.modes, false);
        eprintln!(
            "fs {fs}: worst / mean  freq %  decay %  level dB\n  shipped  {:.4} / {:.4}  {:.2} / {:.2}  {:.2} / {:.2}\n  \
             traer    {:.4} / {:.4}  {:.2} / {:.2}  {:.2} / {:.2}",
            100.0 * ws[0],
            100.0 * ms[0],
            100.0 * ws[1],
            100.0 * ms[1],
            ws[2],
            ms[2],
            100.0 * wb[0],
            100.0 * mb[0],
            100.0 * wb[1],
            100.0 * mb[1],
            wb[2],
            mb[2]
        );
        for i in 0..3 {
            assert!(
                ws[i] < mb[i],
                "measure {i}: shipped worst {} vs baseline mean {}",
                ws[i],
                mb[i]
            );
        }
    }
}

#[test]
fn recovers_synthetic_modes_44k() {
    run(44_100.0);
}

#[test]
fn recovers_synthetic_modes_20k() {
    run(20_000.0);
}

/// A recording whose modes build up over 8 ms (as the marimbas do): the attack time is found
/// and the modes are still within the bounds.
#[test]
fn recovers_attack_and_modes_of_a_slow_build_up() {
    for fs in [44_100.0, 20_000.0] {
        run_with_attack(fs, 8e-3);
    }
}

/// The baseline is exact where spectrogram matching can be: two clean modes far apart.
#[test]
fn spectrogram_matching_recovers_clean_separated_modes() {
    let fs = 44_100.0;
    let modes = [
        Mode {
            freq_hz: 1000.0,
            level_db: -6.0,
            decay_db_per_s: 20.0,
            phase: 0.3,
            attack_s: 0.0,
            ring: None,
        },
        Mode {
            freq_hz: 1500.0,
            level_db: -16.0,
            decay_db_per_s: 40.0,
            phase: 1.1,
            attack_s: 0.0,
            ring: None,
        },
    ];
    let x = synthesize(&modes, fs, (1.5 * fs) as usize);
    let got = extract_traer(&x, fs, 2).modes;
    assert_eq!(got.len(), 2);
    for (m, g) in modes.iter().zip(&got) {
        assert!((g.freq_hz - m.freq_hz).abs() / m.freq_hz < 1e-4, "{g:?} vs {m:?}");
        assert!(
            (g.decay_db_per_s - m.decay_db_per_s).abs() / m.decay_db_per_s < 0.01,
            "{g:?} vs {m:?}"
        );
        assert!((g.level_db - m.level_db).abs() < 0.1, "{g:?} vs {m:?}");
    }
}

/// The transient refit's leakage model (`bands::transient_leakage`) is the *expected*
/// band-energy spread of a decaying noise band: it must match the mean over many noise draws of
/// `synthesize_transient` (within 1.25 dB wherever the mean holds ≥ 10⁻⁴ of the strongest band's
/// energy; 1 dB before the draws were scaled to their expected total energy, which moves a little
/// of a near-cap band's energy from home to its neighbours on average: measured worst 1.06 dB,
/// band 3 at 800 dB/s, against 0.89 dB with plain draws), for a slow band (energy stays home)
/// and a fast one (spreads into its neighbours), in the bands a 44.1 kHz recording is judged in
/// (the transient's own) and in those of a 24 kHz one (centres up to 10.8 kHz, another grid).
#[test]
fn transient_leakage_matches_the_mean_of_noise_draws() {
    use tactus::fit::recording::bands::{
        analysis_high_hz, band_energies_up_to, synthesize_transient, transient_leakage, BANDS,
    };
    for fs in [44_100.0, 24_000.0] {
        let n = (fs / 2.0) as usize;
        let high = analysis_high_hz(fs);
        for (band, decay) in [(12usize, 40.0), (20, 3000.0), (3, 800.0)] {
            let mut decays = vec![None; BANDS];
            decays[band] = Some(decay);
            let expected = &transient_leakage(&decays, fs, n, high)[band];
            let mut one = vec![None; BANDS];
            one[band] = Some((0.0, decay));
            let draws = 64;
            let mut mean = vec![0.0; BANDS];
            for seed in 0..draws {
                let e = band_energies_up_to(&synthesize_transient(&one, fs, n, 100 + seed), fs, high);
                for j in 0..BANDS {
                    mean[j] += e[j] / draws as f64;
                }
            }
            let own = mean.iter().cloned().fold(0.0, f64::max);
            for j in 0..BANDS {
                let db = 10.0 * (expected[j] / mean[j]).log10();
                eprintln!(
                    "fs {fs} band {band} decay {decay}: band {j} mean {:.3e} expected {:.3e} ({db:+.2} dB)",
                    mean[j], expected[j]
                );
                if mean[j] >= 1e-4 * own {
                    assert!(db.abs() <= 1.25, "fs {fs}: band {band} → {j}: {db:+.2} dB");
                }
            }
        }
    }
}
