//! The `manifest.csv` beside a folder of recordings (columns `file`, `material`, `instrument`):
//! how `tactus fit --family-by manifest` groups recordings into families and how `tactus eval`
//! labels them.

use std::path::Path;

/// One row of a recordings folder's `manifest.csv`: the file named and its `material` and
/// `instrument` cells (trimmed; `None` where the column is absent).
#[derive(Debug, Clone, PartialEq)]
pub struct ManifestRow {
    /// The `file` cell.
    pub file: String,
    /// The `material` cell.
    pub material: Option<String>,
    /// The `instrument` cell (the object family).
    pub instrument: Option<String>,
    /// Line of the row in the file (the header is line 1), for error messages.
    pub line: usize,
}

/// The rows of the manifest at `path`, read by the csv crate (RFC 4180 quoting; headers
/// matched case-insensitively); `Ok(None)` when there is no such file. `required` are the
/// columns besides `file` the caller needs: a manifest without one of them is an error naming
/// the file and the column. Shared by `tactus fit --family-by manifest`
/// ([`crate::fit::family`]) and the labelled evaluation folders
/// ([`crate::eval::labels::label_folder`]).
pub fn read_manifest_rows(path: &Path, required: &[&str]) -> anyhow::Result<Option<Vec<ManifestRow>>> {
    if !path.is_file() {
        return Ok(None);
    }
    let err = |e: &dyn std::fmt::Display| anyhow::anyhow!("{}: {e}", path.display());
    let mut rd = csv::ReaderBuilder::new()
        .flexible(true)
        .from_path(path)
        .map_err(|e| err(&e))?;
    let headers = rd.headers().map_err(|e| err(&e))?.clone();
    let col = |name: &str| headers.iter().position(|h| h.trim().eq_ignore_ascii_case(name));
    let needed = || {
        std::iter::once("file")
            .chain(required.iter().copied())
            .collect::<Vec<_>>()
            .join(", ")
    };
    for name in std::iter::once(&"file").chain(required) {
        if col(name).is_none() {
            return Err(err(&format!("no `{name}` column (need {})", needed())));
        }
    }
    let (fc, mc, ic) = (col("file"), col("material"), col("instrument"));
    let mut rows = Vec::new();
    for (i, row) in rd.records().enumerate() {
        let row = row.map_err(|e| err(&e))?;
        let get = |c: Option<usize>| c.map(|c| row.get(c).unwrap_or("").trim().to_owned());
        rows.push(ManifestRow {
            file: get(fc).unwrap_or_default(),
            material: get(mc),
            instrument: get(ic),
            line: row.position().map_or(i + 2, |p| p.line() as usize),
        });
    }
    Ok(Some(rows))
}
