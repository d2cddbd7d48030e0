//! The `manifest.csv` beside a folder of recordings, read once with every column: how
//! `tactus fit --family-by manifest` groups recordings into families (`instrument`) and objects
//! (`object_id`), which velocity layers an object has (`layer_index`, `velocity_min`,
//! `velocity_max`, `same_recording_as`), how `tactus eval` labels recordings (`material`,
//! `instrument`) and what it knows of their editing and kit (`end_condition`,
//! `end_level_db_re_peak`, `kit`).

use std::path::{Path, PathBuf};

/// The file name a recordings folder's manifest has.
pub const FILE_NAME: &str = "manifest.csv";

/// A recordings folder's manifest: its header and rows, cells trimmed.
#[derive(Debug, Clone, PartialEq)]
pub struct Manifest {
    /// Where it was read from.
    pub path: PathBuf,
    headers: Vec<String>,
    rows: Vec<(Vec<String>, usize)>,
}

/// One row of a [`Manifest`].
#[derive(Debug, Clone, Copy)]
pub struct Row<'a> {
    manifest: &'a Manifest,
    cells: &'a [String],
    /// Line of the row in the file (the header is line 1), for error messages.
    pub line: usize,
}

impl Row<'_> {
    /// The cell of column `name` (matched case-insensitively), trimmed; `""` where the column or
    /// the cell is absent.
    pub fn get(&self, name: &str) -> &str {
        self.manifest
            .column(name)
            .and_then(|c| self.cells.get(c))
            .map_or("", String::as_str)
    }

    /// The `file` cell.
    pub fn file(&self) -> &str {
        self.get("file")
    }
}

impl Manifest {
    /// The manifest at `path`, read by the csv crate (RFC 4180 quoting; rows may have fewer
    /// cells than the header); `Ok(None)` when there is no such file. Errors name the file.
    pub fn read(path: &Path) -> anyhow::Result<Option<Manifest>> {
        if !path.is_file() {
            return Ok(None);
        }
        let err = |e: &dyn std::fmt::Display| anyhow::anyhow!("{}: {e}", path.display());
        let mut rd = csv::ReaderBuilder::new()
            .flexible(true)
            .from_path(path)
            .map_err(|e| err(&e))?;
        let headers = rd
            .headers()
            .map_err(|e| err(&e))?
            .iter()
            .map(|h| h.trim().to_owned())
            .collect();
        let mut rows = Vec::new();
        for (i, row) in rd.records().enumerate() {
            let row = row.map_err(|e| err(&e))?;
            let line = row.position().map_or(i + 2, |p| p.line() as usize);
            rows.push((row.iter().map(|c| c.trim().to_owned()).collect(), line));
        }
        Ok(Some(Manifest {
            path: path.to_path_buf(),
            headers,
            rows,
        }))
    }

    /// The manifest of the folder `dir` ([`FILE_NAME`] in it), if there is one.
    pub fn of_folder(dir: &Path) -> anyhow::Result<Option<Manifest>> {
        Self::read(&dir.join(FILE_NAME))
    }

    /// The index of column `name`, matched case-insensitively.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.headers.iter().position(|h| h.eq_ignore_ascii_case(name))
    }

    /// Whether the manifest has every column of `names`.
    pub fn has(&self, names: &[&str]) -> bool {
        names.iter().all(|n| self.column(n).is_some())
    }

    /// An error naming the file and the first column of `file` and `required` it lacks.
    pub fn require(&self, required: &[&str]) -> anyhow::Result<()> {
        let needed = || {
            std::iter::once("file")
                .chain(required.iter().copied())
                .collect::<Vec<_>>()
                .join(", ")
        };
        for name in std::iter::once(&"file").chain(required) {
            if self.column(name).is_none() {
                anyhow::bail!("{}: no `{name}` column (need {})", self.path.display(), needed());
            }
        }
        Ok(())
    }

    /// The rows, in file order.
    pub fn rows(&self) -> impl Iterator<Item = Row<'_>> {
        self.rows.iter().map(move |(cells, line)| Row {
            manifest: self,
            cells,
            line: *line,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quoted_cells_short_rows_and_case_insensitive_columns() {
        let dir = std::env::temp_dir().join(format!("tactus-manifest-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join(FILE_NAME),
            "File, Instrument ,kit\n\"a, b.wav\",\"marimba \"\"low\"\"\"\nc.wav, block ,x\n",
        )
        .unwrap();
        let m = Manifest::of_folder(&dir).unwrap().unwrap();
        let rows: Vec<(String, String, String, usize)> = m
            .rows()
            .map(|r| {
                (
                    r.file().into(),
                    r.get("instrument").into(),
                    r.get("KIT").into(),
                    r.line,
                )
            })
            .collect();
        assert_eq!(
            rows,
            [
                ("a, b.wav".into(), "marimba \"low\"".into(), String::new(), 2),
                ("c.wav".into(), "block".into(), "x".into(), 3)
            ]
        );
        let e = format!("{:#}", m.require(&["material"]).unwrap_err());
        assert!(
            e.contains("manifest.csv") && e.contains("`material`") && e.contains("need file, material"),
            "{e}"
        );
        assert!(Manifest::read(&dir.join("absent.csv")).unwrap().is_none());
        std::fs::remove_dir_all(&dir).ok();
    }
}
