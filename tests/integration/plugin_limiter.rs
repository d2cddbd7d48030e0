//! The plugin's output limiter (`limiter` parameter, [`tactus::engine::limiter`]) through the
//! plugin's own `process`: with every control at its maximum no sample leaves above the
//! ceiling, with the limiter off the unlimited peak returns, and quiet material passes
//! bit-identical either way.

use crate::counting_alloc::allocs;
use crate::fit_harness::{self, loudest_plugin, loudest_render, note, set};
use nice_plug::prelude::*;
use tactus::engine::limiter::CEILING;

fn counted(f: &mut dyn FnMut()) -> u64 {
    let before = allocs();
    f();
    allocs() - before
}

fn peak(x: &[f32]) -> f32 {
    x.iter().fold(0.0f32, |m, v| m.max(v.abs()))
}

fn dbfs(x: f32) -> f64 {
    20.0 * (x.max(1e-30) as f64).log10()
}

/// Every control at its maximum, the worst-case preset, 64 notes at full velocity and every
/// gesture, while scraping and rolling: on, no sample exceeds the ceiling (and the limiter did
/// work, without allocating); off, the unlimited peak, tens of dB over full scale, returns.
#[test]
fn the_loudest_setting_never_passes_the_ceiling_and_off_restores_the_peak() {
    let mut on = loudest_plugin(true);
    let limited = loudest_render(&mut on, &counted);
    let min_gain = on.take_limiter_min_gain();
    let mut off = loudest_plugin(false);
    let unlimited = loudest_render(&mut off, &counted);
    let (p_on, p_off) = (peak(&limited), peak(&unlimited));
    eprintln!(
        "loudest setting: peak {p_off} ({:+.1} dBFS) unlimited, {p_on} ({:+.2} dBFS) limited, \
         smallest limiter gain {min_gain:e} ({:.1} dB)",
        dbfs(p_off),
        dbfs(p_on),
        dbfs(min_gain)
    );
    assert!(limited.iter().all(|v| v.is_finite()));
    assert!(p_on <= CEILING, "a sample above the ceiling: {p_on}");
    assert!(min_gain < 1.0, "the limiter never acted");
    assert_eq!(off.take_limiter_min_gain(), 1.0, "off, the limiter must not act");
    // The unlimited output is what the limiter had to catch: over +40 dBFS.
    assert!(p_off > 100.0, "unlimited peak only {p_off}");
    // Limited, not muted: the loud material still reaches within 1 dB of the ceiling.
    assert!(
        p_on > CEILING * 10f32.powf(-1.0 / 20.0),
        "limited peak only {p_on}"
    );
}

/// A quiet render (the default object, gain −24 dB, notes at velocity 0.8, then idle blocks)
/// is bit-identical with the limiter on and off, and the limiter never changes its gain; so are
/// the same notes at the default gain (0 dB) while they stay 6 dB under the ceiling.
#[test]
fn quiet_material_passes_bit_identical() {
    let render = |limiter: bool, gain_db: f32| {
        let mut p = fit_harness::plugin(ProcessMode::Realtime);
        set(&p, "gain", gain_db);
        set(&p, "limiter", limiter as u8 as f32);
        let (mut l, mut r) = (vec![0f32; 256], vec![0f32; 256]);
        let mut out = Vec::new();
        for b in 0..300 {
            // From block 10 on: the Gain smoother has reached its value.
            let events = if b % 50 == 10 {
                vec![note(b % 7, 48 + (b % 24) as u8)]
            } else {
                vec![]
            };
            fit_harness::block(&mut p, &mut l, &mut r, events, &counted);
            out.extend(l.iter().chain(&r).map(|v| v.to_bits()));
        }
        (out, p.take_limiter_min_gain())
    };
    let (on, gain_on) = render(true, -24.0);
    let (off, _) = render(false, -24.0);
    let p = on.iter().fold(0.0f32, |m, &b| m.max(f32::from_bits(b).abs()));
    eprintln!("quiet render: peak {:.1} dBFS", dbfs(p));
    assert!(p > 0.0, "the notes must sound");
    assert!(
        p <= CEILING * 0.5,
        "not 6 dB under the ceiling ({p}): the test needs quiet material"
    );
    assert_eq!(gain_on, 1.0);
    assert!(on == off, "the limiter changed quiet material");
    let peak_bits = |v: &[u32]| v.iter().fold(0.0f32, |m, &b| m.max(f32::from_bits(b).abs()));
    let (loud_off, _) = render(false, 0.0);
    let (loud_on, _) = render(true, 0.0);
    eprintln!(
        "the same notes at Gain 0 dB: peak {:+.1} dBFS unlimited, {:+.2} dBFS limited",
        dbfs(peak_bits(&loud_off)),
        dbfs(peak_bits(&loud_on))
    );
    if peak_bits(&loud_off) <= CEILING / 2.0 {
        assert!(loud_on == loud_off, "the limiter changed the default notes");
    }
}
