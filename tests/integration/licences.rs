//! The licence notices that ship with the bundles (`cargo xtask dist`): every crate compiled into
//! the plugin and the CLI, on each platform the project builds for, is named with its version in
//! docs/licenses/third-party.md, so a dependency added or updated without regenerating the
//! notices (the command is in that file) fails here.

use std::collections::BTreeSet;
use std::path::Path;
use std::process::Command;

/// The `(name, version)` of every crate `cargo tree` lists as compiled into the package (normal
/// dependencies, default features) for `triple`, the package itself left out.
fn compiled_crates(root: &Path, triple: &str) -> BTreeSet<(String, String)> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(cargo)
        .current_dir(root)
        .args([
            "tree", "-p", "tactus", "-e", "normal", "--prefix", "none", "-f", "{p}", "--target", triple,
        ])
        .output()
        .expect("run cargo tree");
    assert!(
        out.status.success(),
        "cargo tree: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| {
            let mut w = l.split_whitespace();
            let (name, version) = (w.next()?, w.next()?.strip_prefix('v')?);
            (name != "tactus").then(|| (name.to_string(), version.to_string()))
        })
        .collect()
}

#[test]
fn third_party_notices_name_every_compiled_crate() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let notices = std::fs::read_to_string(root.join("docs/licenses/third-party.md")).unwrap();
    let named: BTreeSet<(String, String)> = notices
        .lines()
        .filter_map(|l| {
            let mut w = l.strip_prefix("- ")?.split_whitespace();
            Some((w.next()?.to_string(), w.next()?.to_string()))
        })
        .collect();
    for triple in ["x86_64-unknown-linux-gnu", "x86_64-pc-windows-gnu"] {
        let compiled = compiled_crates(root, triple);
        assert!(
            compiled.len() > 100,
            "{triple}: only {} crates listed",
            compiled.len()
        );
        let missing: Vec<_> = compiled.difference(&named).collect();
        assert!(
            missing.is_empty(),
            "{triple}: {} crate(s) compiled in but not in docs/licenses/third-party.md (regenerate it: see its header): {missing:?}",
            missing.len()
        );
    }
    assert!(
        std::fs::read_to_string(root.join("docs/licenses/measured-data.txt"))
            .unwrap()
            .contains("Massachusetts Institute of Technology"),
        "the measured data's notice is missing"
    );
}
