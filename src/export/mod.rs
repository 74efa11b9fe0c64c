//! Exporters: everything a command writes is rendered to bytes first (CSV
//! rows from `#[derive(Serialize)]` structs, JSON, PNG, SVG) and then written
//! atomically, so a failure never leaves a half-written file.

pub mod plot;

use crate::error::Result;

/// One output format of a result: returns the file's bytes.
pub trait Exporter<T: ?Sized> {
    /// File name inside the output directory.
    fn file_name(&self) -> &str;
    fn render(&self, data: &T) -> Result<Vec<u8>>;
}

/// CSV of any serialisable rows.
pub struct CsvExporter<'a> {
    pub name: &'a str,
}

impl<R: serde::Serialize> Exporter<[R]> for CsvExporter<'_> {
    fn file_name(&self) -> &str {
        self.name
    }
    fn render(&self, rows: &[R]) -> Result<Vec<u8>> {
        crate::io::csv_bytes(rows)
    }
}

/// Pretty JSON of any serialisable value, with a trailing newline.
pub struct JsonExporter<'a> {
    pub name: &'a str,
}

impl<T: serde::Serialize + ?Sized> Exporter<T> for JsonExporter<'_> {
    fn file_name(&self) -> &str {
        self.name
    }
    fn render(&self, data: &T) -> Result<Vec<u8>> {
        let mut v = serde_json::to_vec_pretty(data).map_err(|e| {
            crate::error::Error::Internal(format!("JSON serialisation failed: {e}"))
        })?;
        v.push(b'\n');
        Ok(v)
    }
}
