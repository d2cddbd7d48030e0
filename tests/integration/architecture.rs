//! The dependency directions docs/architecture.md draws, checked on the source: a module that
//! names a module it must not use (by a `crate::` path in code, not in comments) fails here,
//! with the file, the line and the rule it breaks.

use std::path::{Path, PathBuf};

/// (files under this path, the paths they must not name, why).
const RULES: &[(&str, &[&str], &str)] = &[
    (
        "src/analysis",
        &[
            "crate::fit",
            "crate::eval",
            "crate::plugin",
            "crate::bench",
            "crate::batch",
            "crate::scene",
        ],
        "the analysis layer stands under fitting and evaluation",
    ),
    (
        "src/fit",
        &[
            "crate::eval",
            "crate::plugin",
            "crate::bench",
            "crate::batch",
            "crate::scene",
        ],
        "fitting never reads the evaluation",
    ),
    (
        "src/fit/recording",
        &[
            "crate::fit::pool",
            "crate::fit::run",
            "crate::fit::plot",
            "crate::fit::traer",
        ],
        "one recording's fit knows nothing of pooling or of many files",
    ),
    (
        "src/fit/error.rs",
        &["crate::fit::recording", "crate::fit::pool", "crate::fit::run"],
        "why a fit stopped is a leaf every room may name",
    ),
    (
        "src/fit/pool",
        &["crate::fit::run", "crate::fit::plot", "crate::fit::traer"],
        "pooling knows nothing of how files are fitted in bulk",
    ),
    (
        "src/eval",
        &["crate::plugin", "crate::bench", "crate::batch"],
        "the evaluation stands on the fitting library, not on a front end",
    ),
    (
        "src/engine",
        &[
            "crate::fit",
            "crate::eval",
            "crate::analysis",
            "crate::plugin",
            "crate::scene",
            "crate::batch",
            "crate::bench",
        ],
        "the engine knows only presets",
    ),
    (
        "src/engine/limits.rs",
        &["crate::preset"],
        "presets read the engine's limits, so the limits do not read presets",
    ),
    (
        "src/engine/force.rs",
        &["crate::preset"],
        "presets read the default contact exponent, so the force does not read presets",
    ),
    (
        "src/engine/dsp",
        &["crate::preset"],
        "presets use the engine's linear algebra, so it does not read presets",
    ),
    (
        "src/preset",
        &[
            "crate::engine::object",
            "crate::engine::dense",
            "crate::engine::library",
            "crate::engine::materials",
            "crate::engine::voices",
            "crate::engine::modal",
            "crate::fit",
            "crate::eval",
            "crate::analysis",
        ],
        "a preset is data: it reads only the engine's limits, force constants and linear algebra",
    ),
];

/// Every `.rs` file under `path` (or `path` itself, or `path.rs` beside a `path/` folder).
fn files(root: &Path, path: &str) -> Vec<PathBuf> {
    let p = root.join(path);
    let mut out = Vec::new();
    let mut stack = vec![p.clone()];
    let file = p.with_extension("rs");
    if file.is_file() && !p.is_file() {
        stack.push(file);
    }
    while let Some(q) = stack.pop() {
        if q.is_dir() {
            for e in std::fs::read_dir(&q).unwrap().flatten() {
                stack.push(e.path());
            }
        } else if q.extension().is_some_and(|x| x == "rs") {
            out.push(q);
        }
    }
    out.sort();
    out
}

/// The lines of `text` (1-based) that name one of `forbidden` outside comments.
fn violations(text: &str, forbidden: &[&str]) -> Vec<(usize, String)> {
    text.lines()
        .enumerate()
        .filter_map(|(i, line)| {
            let code = line.split("//").next().unwrap_or("");
            forbidden
                .iter()
                .find(|f| {
                    code.match_indices(*f).any(|(at, _)| {
                        let next = code[at + f.len()..].chars().next();
                        !next.is_some_and(|c| c.is_alphanumeric() || c == '_')
                    })
                })
                .map(|f| (i + 1, format!("{f}: {}", line.trim())))
        })
        .collect()
}

#[test]
fn the_checker_finds_a_forbidden_path_and_only_in_code() {
    let text = "use crate::fit::recording::FileResult;\n// crate::eval in a comment\nlet x = crate::evaluate;\nuse crate::eval::{features};\n";
    let v = violations(text, &["crate::eval"]);
    assert_eq!(v.iter().map(|(l, _)| *l).collect::<Vec<_>>(), [4], "{v:?}");
}

#[test]
fn modules_import_in_the_documented_direction() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut broken = Vec::new();
    let mut checked = 0;
    for (path, forbidden, why) in RULES {
        let list = files(root, path);
        assert!(
            !list.is_empty(),
            "{path}: no source files (a rule for a moved module?)"
        );
        for f in list {
            let text = std::fs::read_to_string(&f).unwrap();
            checked += 1;
            for (line, what) in violations(&text, forbidden) {
                broken.push(format!(
                    "{}:{line}: {what}  ({why})",
                    f.strip_prefix(root).unwrap_or(&f).display()
                ));
            }
        }
    }
    assert!(checked >= 40, "only {checked} files checked");
    assert!(
        broken.is_empty(),
        "imports against docs/architecture.md:\n{}",
        broken.join("\n")
    );
}
