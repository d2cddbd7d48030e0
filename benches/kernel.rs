//! Modal bank kernel benchmark (docs/model.md §2, §8): ns per mode-sample, free ringing and excited,
//! for 16/64/256 modes, every kernel variant this CPU supports (portable fallback vs SIMD).
//!
//! `cargo bench --bench kernel` first prints a quick table (plain `Instant` timing, median of
//! repeated runs), then runs the criterion benchmarks (throughput in mode-samples).
//! `cargo bench --bench kernel -- --quick-only` prints the table alone.

use criterion::{Criterion, Throughput};
use std::hint::black_box;
use std::time::Instant;
use tactus::engine::modal::{Kernel, ModalBank, ModeParams};

/// A metal-like bank: log-spaced frequencies 80 Hz–20 kHz, light damping.
fn modes(n: usize) -> Vec<ModeParams> {
    (0..n)
        .map(|i| {
            let t = i as f64 / n.max(2) as f64;
            ModeParams {
                freq_hz: 80.0 * (20_000.0f64 / 80.0).powf(t),
                // Why so small: metal rings for seconds; it keeps states far from the flush floor.
                decay_db_per_s: 0.5 + 3.0 * t,
                gain: 1.0 / (1.0 + i as f64),
            }
        })
        .collect()
}

fn bank(n: usize, kernel: Kernel) -> ModalBank {
    let mut b = ModalBank::with_capacity(n);
    b.set_kernel(kernel);
    b.set_sample_rate(48_000.0);
    b.set_modes(&modes(n));
    let mut out = vec![0.0f32; 1];
    b.process(Some(&[1.0]), &mut out);
    b
}

fn kernels() -> Vec<Kernel> {
    [Kernel::Portable, Kernel::Avx2, Kernel::Avx512]
        .into_iter()
        .filter(|k| k.is_supported())
        .collect()
}

/// Minimum ns per mode-sample over 41 short runs (the machine is shared: the minimum is the
/// run least disturbed by preemption, a longer run would almost always be interrupted).
fn time_ns(n: usize, kernel: Kernel, block: usize, excited: bool) -> f64 {
    let mut b = bank(n, kernel);
    let mut out = vec![0.0f32; block];
    let input: Vec<f32> = (0..block).map(|i| ((i * 7919) % 13) as f32 * 1e-6).collect();
    // Why ~200k mode-samples per run: ≥ 10 µs (timer resolution is negligible) yet well under
    // a scheduler time slice, so some runs are not preempted.
    let blocks = (200_000 / (n * block)).max(2);
    let mut runs = Vec::new();
    for _ in 0..41 {
        let t = Instant::now();
        for _ in 0..blocks {
            b.process(excited.then_some(&input[..]), black_box(&mut out));
        }
        runs.push(t.elapsed().as_secs_f64() * 1e9 / (blocks * block * n) as f64);
        // Keep the modes ringing (excitation would otherwise be the only energy source).
        if !excited {
            b.process(Some(&[1.0]), &mut out[..1]);
        }
    }
    runs.sort_by(f64::total_cmp);
    black_box(&out);
    runs[0]
}

fn quick_table() {
    println!(
        "ns per mode-sample (minimum of 41 runs), 48 kHz, kernel detected: {:?}",
        Kernel::detect()
    );
    println!(
        "{:>9} {:>6} {:>6} {:>10} {:>10}",
        "kernel", "modes", "block", "free", "excited"
    );
    for kernel in kernels() {
        for &n in &[16usize, 64, 256] {
            for &block in &[64usize, 512] {
                let f = time_ns(n, kernel, block, false);
                let e = time_ns(n, kernel, block, true);
                println!(
                    "{:>9} {n:>6} {block:>6} {f:>10.4} {e:>10.4}",
                    format!("{kernel:?}")
                );
            }
        }
    }
}

fn criterion_benches(c: &mut Criterion) {
    let block = 256;
    for &n in &[16usize, 64, 256] {
        let mut g = c.benchmark_group(format!("modal_{n}_modes_block_{block}"));
        g.throughput(Throughput::Elements((n * block) as u64));
        for kernel in kernels() {
            let mut b = bank(n, kernel);
            let mut out = vec![0.0f32; block];
            g.bench_function(format!("free/{kernel:?}"), |bench| {
                bench.iter(|| b.process(None, black_box(&mut out)))
            });
            let mut b = bank(n, kernel);
            let input = vec![1e-6f32; block];
            g.bench_function(format!("excited/{kernel:?}"), |bench| {
                bench.iter(|| b.process(Some(&input), black_box(&mut out)))
            });
        }
        g.finish();
    }
}

fn main() {
    quick_table();
    if std::env::args().any(|a| a == "--quick-only") {
        return;
    }
    let mut c = Criterion::default()
        .configure_from_args()
        .warm_up_time(std::time::Duration::from_millis(300))
        .measurement_time(std::time::Duration::from_secs(1));
    criterion_benches(&mut c);
    c.final_summary();
}
