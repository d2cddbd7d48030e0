//! Shipped presets: every built-in validates, names/order are fixed, and the recordings check
//! (skipped when /work/shared/recordings is absent).

use tactus::engine::materials::{builtin_presets, derived, BUILTIN_SPECS};

#[test]
fn builtins_load_and_validate_in_order() {
    let names: Vec<String> = builtin_presets().iter().map(|p| p.name.clone()).collect();
    assert_eq!(
        names,
        [
            "Wood",
            "Metal",
            "Glass",
            "Ceramic",
            "Plastic",
            "Stone",
            "Cardboard"
        ]
    );
    for p in builtin_presets() {
        p.validate().unwrap_or_else(|e| panic!("{}: {e}", p.name));
    }
}

/// Regenerates the derived JSON presets: `cargo test --test fit_presets -- --ignored write_derived`.
#[test]
#[ignore]
fn write_derived() {
    for s in &BUILTIN_SPECS[2..] {
        let mut p = derived(s);
        p.origin = tactus::preset::Origin::Derived;
        let path = format!("{}/presets/{}.json", env!("CARGO_MANIFEST_DIR"), s.class);
        std::fs::write(&path, p.to_json() + "\n").unwrap();
    }
}
