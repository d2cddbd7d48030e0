//! The derived built-in presets (`presets/<class>.json` for every spec without a fitted preset,
//! docs/presets.md) are what their specs derive. With `TACTUS_WRITE_DERIVED_PRESETS=1` the test
//! writes them instead (after a spec or the derivation changed), and says so.

use tactus::engine::materials::{derived_preset_json, derived_specs};

#[test]
fn derived_presets_match_their_specs() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let write = std::env::var_os("TACTUS_WRITE_DERIVED_PRESETS").is_some_and(|v| v == "1");
    let mut stale = Vec::new();
    let mut checked = 0;
    for spec in derived_specs() {
        let text = derived_preset_json(spec);
        let path = root.join(format!("presets/{}.json", spec.class));
        if write {
            std::fs::write(&path, &text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            eprintln!("wrote {}", path.display());
        } else if std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())) != text
        {
            stale.push(path.display().to_string());
        }
        checked += 1;
    }
    assert!(checked >= 5, "only {checked} derived presets");
    assert!(
        stale.is_empty(),
        "derived presets differ from their specs: {} (rewrite them with TACTUS_WRITE_DERIVED_PRESETS=1 cargo test --test integration derived_presets)",
        stale.join(", ")
    );
}
