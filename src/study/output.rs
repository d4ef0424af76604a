//! Result files: CSV tables written row by row as results arrive (an interrupted run keeps what
//! it finished), and a `meta.json` that records everything needed to regenerate them.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;
use serde_json::Value;

use crate::study::Study;
use crate::{Error, Result};

/// Maps an I/O error to [`Error::Io`] naming the path.
pub fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.display().to_string(),
        source,
    }
}

/// Creates `dir` (and its parents).
pub(crate) fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(io_error(dir))
}

/// Makes `dir` (and its parents) and checks that a file can be written into it. The probe has a
/// unique name and is removed at once: the array tasks of a cluster run start together in one
/// shared folder, and a fixed name would let one task remove another's probe under it.
pub fn make_writable_dir(dir: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    tempfile::Builder::new()
        .prefix(".helixbif-write-check")
        .tempfile_in(dir)?
        .close()
}

/// A CSV file written one serializable row at a time, flushed after each row.
pub(crate) struct CsvWriter {
    path: PathBuf,
    writer: csv::Writer<File>,
}

impl CsvWriter {
    pub(crate) fn create(path: &Path) -> Result<Self> {
        let file = File::create(path).map_err(io_error(path))?;
        Ok(CsvWriter {
            path: path.to_path_buf(),
            writer: csv::Writer::from_writer(file),
        })
    }

    /// A table whose header (the field names of the row type of `sample`) is written at once, so
    /// that a table that stays empty still says what it would hold (and reads as an empty table
    /// where a 0-byte file would be refused).
    pub(crate) fn create_with_header(path: &Path, sample: &impl Serialize) -> Result<Self> {
        let mut header = csv::Writer::from_writer(Vec::new());
        header.serialize(sample).map_err(|e| csv_error(path, e))?;
        let bytes = header
            .into_inner()
            .map_err(|e| csv_error(path, e.into_error().into()))?;
        let first = bytes
            .split_inclusive(|&b| b == b'\n')
            .next()
            .unwrap_or_default();
        std::fs::write(path, first).map_err(io_error(path))?;
        Self::append(path)
    }

    /// Appends rows to the table at `path`, whose header is already written (a resumed run).
    pub(crate) fn append(path: &Path) -> Result<Self> {
        let file = std::fs::OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(io_error(path))?;
        Ok(CsvWriter {
            path: path.to_path_buf(),
            writer: csv::WriterBuilder::new()
                .has_headers(false)
                .from_writer(file),
        })
    }

    pub fn row(&mut self, row: &impl Serialize) -> Result<()> {
        self.writer
            .serialize(row)
            .map_err(|e| csv_error(&self.path, e))?;
        self.writer.flush().map_err(io_error(&self.path))
    }
}

/// A CSV error writing `path`, as an I/O error naming it.
fn csv_error(path: &Path, e: csv::Error) -> Error {
    Error::Io {
        path: path.display().to_string(),
        source: std::io::Error::other(e.to_string()),
    }
}

/// Who asked for a result: the command line (or the call of a front end) that `meta.json`
/// records, so that any result can be made again.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Provenance {
    pub command_line: Vec<String>,
}

impl Provenance {
    /// The provenance of this process's command line.
    pub fn of_process() -> Self {
        Provenance {
            command_line: std::env::args().collect(),
        }
    }
}

/// The provenance written beside every result as `meta.json`.
#[derive(Serialize)]
pub(crate) struct Meta<'a, T: Serialize> {
    pub crate_version: &'static str,
    pub command_line: Vec<String>,
    pub study: &'a Study,
    pub nodes: usize,
    pub scales: crate::model::params::Scales,
    /// What the command adds (timings, stop reason, ...).
    pub run: T,
}

impl<'a, T: Serialize> Meta<'a, T> {
    pub fn new(
        study: &'a Study,
        scales: crate::model::params::Scales,
        run: T,
        provenance: &Provenance,
    ) -> Self {
        Meta {
            crate_version: env!("CARGO_PKG_VERSION"),
            command_line: provenance.command_line.clone(),
            study,
            nodes: study.discretization.nodes,
            scales,
            run,
        }
    }

    pub fn write(&self, path: &Path) -> Result<()> {
        let text =
            serde_json::to_string_pretty(self).map_err(|e| Error::Numerical(e.to_string()))?;
        std::fs::write(path, text + "\n").map_err(io_error(path))
    }
}

/// A CSV file read back: header and rows of strings.
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    pub fn read(path: &Path) -> Result<Self> {
        let mut reader = csv::Reader::from_path(path)
            .map_err(|e| Error::input("csv", format!("{}: {e}", path.display())))?;
        let header = reader
            .headers()
            .map_err(|e| Error::input("csv", format!("{}: {e}", path.display())))?
            .iter()
            .map(String::from)
            .collect();
        let rows = reader
            .records()
            .map(|r| r.map(|r| r.iter().map(String::from).collect()))
            .collect::<std::result::Result<Vec<Vec<String>>, _>>()
            .map_err(|e| Error::input("csv", format!("{}: {e}", path.display())))?;
        Ok(Table { header, rows })
    }

    /// Index of a column; the error names the column and lists the available ones.
    pub fn index(&self, name: &str) -> Result<usize> {
        self.header.iter().position(|h| h == name).ok_or_else(|| {
            Error::input(
                name,
                format!("no such column; the columns are {}", self.header.join(", ")),
            )
        })
    }

    /// The text of column `c` in row `r`.
    pub fn text(&self, r: usize, c: usize) -> &str {
        self.rows[r].get(c).map_or("", String::as_str)
    }

    /// The number in column `c` of row `r`, if it parses.
    pub fn number(&self, r: usize, c: usize) -> Option<f64> {
        self.text(r, c).trim().parse().ok()
    }

    /// The rows that carry a finite number in both columns `x` and `y` (and, where the table
    /// has a `status` column, the status `ok`; where `positive`, values > 0), and every other
    /// row with the reason it was left out: a fit never drops a row silently.
    pub fn usable(
        &self,
        x: usize,
        y: usize,
        positive: bool,
    ) -> (Vec<(usize, f64, f64)>, Vec<LeftOut>) {
        let status = self.header.iter().position(|h| h == "status");
        let kind = self.header.iter().position(|h| h == "kind");
        let id = self
            .header
            .iter()
            .position(|h| h == "point")
            .unwrap_or(usize::MAX);
        let mut kept = Vec::new();
        let mut left_out = Vec::new();
        for r in 0..self.rows.len() {
            let status_text = status.map(|c| self.text(r, c)).unwrap_or("ok");
            let column = |c: usize| match self.number(r, c) {
                None => Some(format!("`{}` is empty or not a number", self.header[c])),
                Some(v) if !v.is_finite() => Some(format!("`{}` is not finite", self.header[c])),
                Some(v) if positive && v <= 0.0 => Some(format!(
                    "`{}` = {v} is not positive (a power law needs x, y > 0)",
                    self.header[c]
                )),
                Some(_) => None,
            };
            let reason = if status_text != "ok" {
                Some(format!("status: {status_text}"))
            } else {
                column(x).or_else(|| column(y)).map(|why| match kind {
                    Some(k) if !self.text(r, k).is_empty() => {
                        format!("{why} (kind: {})", self.text(r, k))
                    }
                    _ => why,
                })
            };
            match (reason, self.number(r, x), self.number(r, y)) {
                (None, Some(vx), Some(vy)) => kept.push((r, vx, vy)),
                (reason, _, _) => left_out.push(LeftOut {
                    row: r + 1,
                    point: (id != usize::MAX).then(|| self.text(r, id).to_string()),
                    reason: reason.unwrap_or_else(|| "no number".into()),
                }),
            }
        }
        (kept, left_out)
    }
}

/// A row a fit left out, and why (`row` counts data rows from 1).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LeftOut {
    pub row: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub point: Option<String>,
    pub reason: String,
}

impl std::fmt::Display for LeftOut {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.point {
            Some(p) => write!(f, "row {} (point {p}): {}", self.row, self.reason),
            None => write!(f, "row {}: {}", self.row, self.reason),
        }
    }
}

/// The rows of the CSV table at `path` (none when `read` is false or the file does not exist):
/// the results an interrupted run had finished, read back on `--resume`.
pub(crate) fn read_rows<T: serde::de::DeserializeOwned>(path: &Path, read: bool) -> Result<Vec<T>> {
    if !read || !path.exists() {
        return Ok(Vec::new());
    }
    let mut reader = csv::Reader::from_path(path)
        .map_err(|e| Error::input("--resume", format!("{}: {e}", path.display())))?;
    reader
        .deserialize()
        .collect::<std::result::Result<Vec<T>, _>>()
        .map_err(|e| Error::input("--resume", format!("{}: {e}", path.display())))
}

/// Replaces `path` by `bytes` atomically: a reader (or a run resumed after a kill) sees the old
/// file or the new one, never a mixture or a truncated file.
pub(crate) fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    let tmp = path.with_file_name(name);
    let mut file = File::create(&tmp).map_err(io_error(&tmp))?;
    file.write_all(bytes).map_err(io_error(&tmp))?;
    file.sync_all().map_err(io_error(&tmp))?;
    drop(file);
    std::fs::rename(&tmp, path).map_err(io_error(path))
}

/// Writes `value` as compact JSON to `path` [atomically](write_atomically) (checkpoints).
pub(crate) fn write_json_atomically(path: &Path, value: &impl Serialize) -> Result<()> {
    let text = serde_json::to_string(value).map_err(|e| Error::Numerical(e.to_string()))?;
    write_atomically(path, text.as_bytes())
}

/// Writes `value` as indented JSON to `path`, its keys in alphabetical order at every level
/// (the layout of every JSON file of a run).
pub(crate) fn write_json(path: &Path, value: &impl Serialize) -> Result<()> {
    let value = serde_json::to_value(value).map_err(|e| Error::Numerical(e.to_string()))?;
    std::fs::write(path, format!("{value:#}\n")).map_err(io_error(path))
}

/// With `resume`, the checkpoint an earlier run left at `path`, parsed (`None` without `resume`
/// or where there is none), provided its record of what that run was made of (`recorded`:
/// absent from the files of versions that kept none) equals `key`. A checkpoint that does not
/// parse, has no record, or records another run (the first field that differs named,
/// [`first_difference`]) is bad input naming `--resume`; one that cannot be read, an I/O error.
pub(crate) fn resumed_checkpoint<T: serde::de::DeserializeOwned>(
    path: &Path,
    resume: bool,
    key: &Value,
    recorded: impl Fn(&T) -> Option<&Value>,
) -> Result<Option<T>> {
    if !(resume && path.exists()) {
        return Ok(None);
    }
    let text = std::fs::read_to_string(path).map_err(io_error(path))?;
    let saved: T = serde_json::from_str(&text)
        .map_err(|e| Error::input("--resume", format!("{}: {e}", path.display())))?;
    let refuse = |why: String| {
        Err(Error::input(
            "--resume",
            format!(
                "{} was written by {why}, or choose another --out",
                path.display()
            ),
        ))
    };
    match recorded(&saved).map(|r| first_difference(key, r)) {
        None => {
            refuse("a version that did not record the run's options: run without --resume".into())
        }
        Some(Some(difference)) => refuse(format!(
            "a run with other options or another study ({difference}): resume with the same ones"
        )),
        Some(None) => Ok(Some(saved)),
    }
}

/// Where the record a run would resume from (`theirs`, read from a file) first differs from the
/// one this run makes (`ours`): the dotted path of the first differing field (keys in order,
/// array entries by index) with both values, e.g. ``physical.rod.E` is 1300000.0 here and
/// 1255000.0 in the file`; `None` where they are equal. Named in a refused `--resume`, so that
/// the user sees which option or study field to set back.
fn first_difference(ours: &Value, theirs: &Value) -> Option<String> {
    fn walk(path: &str, ours: &Value, theirs: &Value) -> Option<String> {
        let at = |key: &str| {
            if path.is_empty() {
                key.to_string()
            } else {
                format!("{path}.{key}")
            }
        };
        match (ours, theirs) {
            (Value::Object(a), Value::Object(b)) => {
                let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
                keys.sort();
                keys.dedup();
                keys.into_iter().find_map(|k| match (a.get(k), b.get(k)) {
                    (Some(x), Some(y)) => walk(&at(k), x, y),
                    (Some(x), None) => {
                        Some(format!("`{}` is {x} here and absent in the file", at(k)))
                    }
                    (None, Some(y)) => {
                        Some(format!("`{}` is absent here and {y} in the file", at(k)))
                    }
                    (None, None) => None,
                })
            }
            (Value::Array(a), Value::Array(b)) if a.len() == b.len() => a
                .iter()
                .zip(b)
                .enumerate()
                .find_map(|(i, (x, y))| walk(&at(&i.to_string()), x, y)),
            _ if ours == theirs => None,
            _ => Some(format!(
                "`{}` is {ours} here and {theirs} in the file",
                if path.is_empty() { "the record" } else { path }
            )),
        }
    }
    walk("", ours, theirs)
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::first_difference;

    #[test]
    fn the_first_difference_of_two_records_is_named_by_its_path() {
        let ours = json!({"physical": {"rod": {"E": 1.3e6, "r0": 1e-3}}, "steps": [40, 2]});
        assert_eq!(first_difference(&ours, &ours.clone()), None);
        let theirs = json!({"physical": {"rod": {"E": 1.255e6, "r0": 1e-3}}, "steps": [40, 3]});
        assert_eq!(
            first_difference(&ours, &theirs).unwrap(),
            "`physical.rod.E` is 1300000.0 here and 1255000.0 in the file"
        );
        let theirs = json!({"physical": {"rod": {"E": 1.3e6, "r0": 1e-3}}, "steps": [40, 3]});
        assert_eq!(
            first_difference(&ours, &theirs).unwrap(),
            "`steps.1` is 2 here and 3 in the file"
        );
        let theirs = json!({"physical": {"rod": {"E": 1.3e6}}, "steps": [40, 2]});
        assert_eq!(
            first_difference(&ours, &theirs).unwrap(),
            "`physical.rod.r0` is 0.001 here and absent in the file"
        );
        let theirs = json!({"physical": {"rod": {"E": 1.3e6, "r0": 1e-3}}, "steps": [40]});
        assert_eq!(
            first_difference(&ours, &theirs).unwrap(),
            "`steps` is [40,2] here and [40] in the file"
        );
    }
}
