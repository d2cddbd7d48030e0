//! The `tactus` commands, one file each; `main.rs` parses the command line and dispatches
//! here. Each is a thin layer over the library: it checks its arguments, shows progress on a
//! terminal ([`progress::Bar`]), runs the library's function and prints or writes the result.

pub mod batch;
pub mod bench;
pub mod eval;
pub mod fit;
pub mod measured;
pub mod merge;
pub mod preset;
pub mod progress;
pub mod render;
pub mod surfaces;

use std::path::Path;

/// Writes a report's table to stdout (a closed pipe, `| head`, ends it quietly) and, with
/// `json`, `value` as JSON to that file.
pub fn emit<T: serde::Serialize>(
    table: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>,
    json: Option<&Path>,
    value: &T,
) -> anyhow::Result<()> {
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    match table(&mut out).and_then(|()| std::io::Write::flush(&mut out)) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        r => r.map_err(|e| anyhow::anyhow!("cannot write to stdout: {e}"))?,
    }
    if let Some(p) = json {
        let text = serde_json::to_string_pretty(value).map_err(|e| anyhow::anyhow!("{e}"))?;
        std::fs::write(p, text + "\n").map_err(|e| anyhow::anyhow!("cannot write {}: {e}", p.display()))?;
        eprintln!("wrote {}", p.display());
    }
    Ok(())
}

/// Creates (empties) `path` now, so an unwritable output fails before minutes of work.
pub fn check_writable(path: &Path) -> anyhow::Result<()> {
    std::fs::File::create(path).map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
    Ok(())
}
