//! Result files: CSV tables written row by row as results arrive (an interrupted run keeps what
//! it finished), and a `meta.json` that records everything needed to regenerate them.

use std::fs::File;
use std::path::{Path, PathBuf};

use serde::Serialize;

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
pub fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(io_error(dir))
}

/// A CSV file written one serializable row at a time, flushed after each row.
pub struct CsvWriter {
    path: PathBuf,
    writer: csv::Writer<File>,
}

impl CsvWriter {
    pub fn create(path: &Path) -> Result<Self> {
        let file = File::create(path).map_err(io_error(path))?;
        Ok(CsvWriter {
            path: path.to_path_buf(),
            writer: csv::Writer::from_writer(file),
        })
    }

    pub fn row(&mut self, row: &impl Serialize) -> Result<()> {
        let to_io = |e: csv::Error| Error::Io {
            path: self.path.display().to_string(),
            source: std::io::Error::other(e.to_string()),
        };
        self.writer.serialize(row).map_err(to_io)?;
        self.writer.flush().map_err(io_error(&self.path))
    }
}

/// The provenance written beside every result as `meta.json`.
#[derive(Serialize)]
pub struct Meta<'a, T: Serialize> {
    pub crate_version: &'static str,
    pub command_line: Vec<String>,
    pub study: &'a Study,
    pub nodes: usize,
    pub scales: crate::params::Scales,
    /// What the command adds (timings, stop reason, ...).
    pub run: T,
}

impl<'a, T: Serialize> Meta<'a, T> {
    pub fn new(study: &'a Study, scales: crate::params::Scales, run: T) -> Self {
        Meta {
            crate_version: env!("CARGO_PKG_VERSION"),
            command_line: std::env::args().collect(),
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
}
