//! Fitting a material in the plugin through the editor's own fit path ([`FitJob`], what the
//! editor's dialogs and file drops start): a failed fit changes nothing, the fitted preset is the
//! one `tactus fit` makes of the same files, and a saved state with a fitted material restores
//! bit-identically.
//!
//! That the audio thread keeps processing without allocating while ten recordings are fitted is
//! `tests/plugin_fit_rt.rs`, under nice-plug's own checker (`assert_process_allocs`, feature
//! `rt-checks`): one run of that 80-second fit, not a second one here under the counting
//! allocator, keeps the test command's time down.

use crate::fit_harness::{block, note, plugin, set, synthetic_set, temp_dir, unguarded, write_wav, FS};
use nice_plug::params::internals::ParamPtr;
use nice_plug::params::InternalParamMut;
use nice_plug::plugin::{ParamValue, PluginState};
use nice_plug::prelude::*;
use std::collections::BTreeMap;
use std::path::PathBuf;
use tactus::plugin::fit_job::{FitJob, FitSettings};
use tactus::plugin::stub_host::StubHost;
use tactus::plugin::user_preset::USER_SLOT;
use tactus::plugin::Tactus;

#[test]
fn a_failed_fit_leaves_the_current_material_playing() {
    let p = plugin(ProcessMode::Realtime);
    let params = p.tactus_params();
    params
        .user_preset
        .set_json(tactus::engine::materials::builtin_presets().remove(2).to_json())
        .unwrap();
    let (json, generation) = (params.user_preset.json(), params.user_preset.generation());
    let silent = temp_dir("failed").join("silent.wav");
    write_wav(&silent, |_| 0.0);
    let err = FitJob::start(params.clone(), vec![silent], FitSettings::default())
        .wait()
        .expect_err("nothing can be fitted");
    assert!(err.contains("keeps playing") && err.contains("silent"), "{err}");
    assert!(!err.contains('\n'), "{err}");
    let missing = FitJob::start(
        params.clone(),
        vec![PathBuf::from("/no/such/take.wav")],
        FitSettings::default(),
    )
    .wait()
    .expect_err("no such file");
    assert!(missing.contains("/no/such/take.wav"), "{missing}");
    assert_eq!(params.user_preset.json(), json);
    assert_eq!(params.user_preset.generation(), generation);
    assert!(params.user_preset.status().is_empty());
}

/// The plugin's state as nice-plug's wrappers save it (`wrapper::state::serialize_object`,
/// which is crate-private): each parameter's unmodulated plain value by id, the persisted
/// fields, then JSON.
fn save_state(p: &Tactus) -> Vec<u8> {
    let params = p.params();
    let values: BTreeMap<String, ParamValue> = params
        .param_map()
        .into_iter()
        .map(|(id, ptr, _)| {
            let v = unsafe {
                match ptr {
                    ParamPtr::FloatParam(x) => ParamValue::F32((*x).unmodulated_plain_value()),
                    ParamPtr::IntParam(x) => ParamValue::I32((*x).unmodulated_plain_value()),
                    ParamPtr::BoolParam(x) => ParamValue::Bool((*x).unmodulated_plain_value()),
                    ParamPtr::EnumParam(x) => match (*x).unmodulated_plain_id() {
                        Some(s) => ParamValue::String(s.to_owned()),
                        None => ParamValue::I32((*x).unmodulated_plain_value()),
                    },
                }
            };
            (id, v)
        })
        .collect();
    let state = PluginState {
        version: Tactus::VERSION.into(),
        params: values,
        fields: params.serialize_fields(),
    };
    serde_json::to_vec(&state).unwrap()
}

/// Loads a saved state as nice-plug's wrappers do (`wrapper::state::deserialize_object`):
/// `filter_state` (migration), parameters by id, then the persisted fields.
fn load_state(p: &Tactus, bytes: &[u8]) {
    let mut state: PluginState = serde_json::from_slice(bytes).unwrap();
    Tactus::filter_state(&mut state);
    let params = p.params();
    let map = params.param_map();
    for (id, value) in &state.params {
        let (_, ptr, _) = map
            .iter()
            .find(|(i, _, _)| i == id)
            .unwrap_or_else(|| panic!("{id}"));
        unsafe {
            // `_internal_set_plain_value` returns whether the value changed (ignored, as by
            // nice-plug); an enum id that is not known is an error.
            match (ptr, value) {
                (ParamPtr::FloatParam(x), ParamValue::F32(v)) => {
                    (**x)._internal_set_plain_value(*v);
                }
                (ParamPtr::IntParam(x), ParamValue::I32(v)) => {
                    (**x)._internal_set_plain_value(*v);
                }
                (ParamPtr::BoolParam(x), ParamValue::Bool(v)) => {
                    (**x)._internal_set_plain_value(*v);
                }
                (ParamPtr::EnumParam(x), ParamValue::I32(v)) => {
                    (**x)._internal_set_plain_value(*v);
                }
                (ParamPtr::EnumParam(x), ParamValue::String(s)) => assert!((**x).set_from_id(s), "{id}: {s}"),
                other => panic!("{id}: {other:?}"),
            }
            ptr._internal_update_smoother(FS, true);
        }
    }
    params.deserialize_fields(&state.fields);
}

/// Two seconds of notes through an offline-activated plugin (objects drawn in `process`).
fn render(p: &mut Tactus) -> Vec<f32> {
    assert!(StubHost::new(FS).activate(p, FS, 512, ProcessMode::Offline));
    p.reset();
    let (mut l, mut r) = (vec![0f32; 512], vec![0f32; 512]);
    let mut out = Vec::new();
    for b in 0..190u32 {
        let events = match b {
            0 => vec![note(0, 60)],
            60 => vec![note(100, 67)],
            120 => vec![note(7, 55)],
            _ => vec![],
        };
        block(p, &mut l, &mut r, events, &unguarded);
        out.extend(l.iter().zip(&r).flat_map(|(a, b)| [*a, *b]));
    }
    out
}

#[test]
fn state_with_a_plugin_fitted_material_restores_bit_identically() {
    let mut a = plugin(ProcessMode::Realtime);
    let report = FitJob::start(
        a.tactus_params(),
        synthetic_set("state", 3),
        FitSettings::default(),
    )
    .wait()
    .expect("the fit succeeds");
    // The editor's fit is `tactus fit` with its defaults (24 modes, families auto).
    let inputs = synthetic_set("state", 3);
    let cli = tactus::fit::run::fit_files(
        &inputs,
        &tactus::fit::pool::Pooling::new("wood"),
        false,
        &tactus::work::Silent,
    )
    .expect("the CLI's fit succeeds");
    let mut editor = tactus::preset::Preset::from_json(&report.json, None).expect("reads back");
    editor.provenance.date.clone_from(&cli.preset.provenance.date);
    assert_eq!(
        tactus::fit::pool::preset::fitted_preset_json(&editor),
        tactus::fit::pool::preset::fitted_preset_json(&cli.preset),
        "the editor's fit differs from tactus fit's"
    );
    set(&a, "material", USER_SLOT as f32);
    set(&a, "seed", 4242.0);
    let saved = save_state(&a);
    let want = render(&mut a);

    let mut b = Tactus::default();
    load_state(&b, &saved);
    assert_eq!(b.tactus_params().user_preset.json(), report.json);
    assert_eq!(save_state(&b), saved, "the restored state saves differently");
    let got = render(&mut b);
    assert_eq!(b.object_key(), a.object_key());
    assert_eq!(b.object_key().material, USER_SLOT);
    let peak = want.iter().fold(0f32, |m, x| m.max(x.abs()));
    assert!(peak > 1e-4, "the fitted material is silent");
    assert_eq!(want.len(), got.len());
    let differ = want
        .iter()
        .zip(&got)
        .filter(|(x, y)| x.to_bits() != y.to_bits())
        .count();
    assert_eq!(
        differ,
        0,
        "{differ} of {} samples differ after the round trip",
        want.len()
    );
}
