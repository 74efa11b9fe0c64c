//! JSON: pretty-printed, with a trailing newline.

use super::Exporter;
use crate::error::{Error, Result};

/// Pretty JSON of any serialisable value.
pub struct JsonExporter;

impl<T: serde::Serialize + ?Sized> Exporter<T> for JsonExporter {
    fn render(&self, data: &T) -> Result<Vec<u8>> {
        let mut v = serde_json::to_vec_pretty(data)
            .map_err(|e| Error::Internal(format!("JSON serialisation failed: {e}")))?;
        v.push(b'\n');
        Ok(v)
    }
}
