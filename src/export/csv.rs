//! CSV: rows from `#[derive(Serialize)]` structs, the header from the field
//! names (a nested struct's fields in its place); a non-finite number is an
//! empty cell ([`Cells`]).

use super::Exporter;
use crate::error::{Error, Result};
use crate::metrics::finite::Cells;

/// CSV of any serialisable rows.
pub struct CsvExporter;

impl<R: serde::Serialize> Exporter<[R]> for CsvExporter {
    fn render(&self, rows: &[R]) -> Result<Vec<u8>> {
        csv_bytes(rows)
    }
}

/// Serialise rows to CSV bytes (header from the struct's field names).
pub fn csv_bytes<T: serde::Serialize>(rows: impl IntoIterator<Item = T>) -> Result<Vec<u8>> {
    let mut w = ::csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(Cells(&r))
            .map_err(|e| Error::Internal(format!("CSV serialisation failed: {e}")))?;
    }
    w.into_inner()
        .map_err(|e| Error::Internal(format!("CSV serialisation failed: {e}")))
}
