//! File input and output, the bottom layer: outputs written so that no
//! half-written or stale file ever carries a final name ([`output`]), and
//! CSV tables read as text cells whose errors name the file and the line
//! (the files themselves are parsed above it, in `store::inputs`). `-` reads
//! stdin.

pub mod output;

pub use output::{claim_dir, is_stdout, write_output, DirLock, Outputs};

use crate::error::{Error, Result};
use std::path::Path;

/// A CSV file read as text cells, with the header mapped to required columns.
pub struct Table {
    pub file: String,
    /// (line number, cells in the order of the requested columns)
    pub rows: Vec<(u64, Vec<String>)>,
}

/// The bytes of an input file, or of stdin for `-`; errors name the file.
pub fn read_bytes(path: &Path) -> Result<(String, Vec<u8>)> {
    if path.as_os_str() == "-" {
        let mut buf = Vec::new();
        std::io::Read::read_to_end(&mut std::io::stdin(), &mut buf)
            .map_err(|e| Error::csv("<stdin>", format!("cannot be read ({e})")))?;
        return Ok(("<stdin>".into(), buf));
    }
    let file = path.display().to_string();
    let text = std::fs::read(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            Error::csv(&file, "the file does not exist")
        } else {
            Error::csv(&file, format!("the file cannot be read ({e})"))
        }
    })?;
    Ok((file, text))
}

/// The rows of a CSV file named `file` (for messages): the `required`
/// columns, then the `optional` ones (empty cells where absent), with
/// whether each optional column is present. Blank rows are skipped; a file
/// without data rows is refused.
pub fn read_table(
    file: &str,
    text: &[u8],
    required: &[&str],
    optional: &[&str],
) -> Result<(Table, Vec<bool>)> {
    let file = file.to_string();
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .trim(csv::Trim::All)
        .from_reader(text);
    let headers = rdr
        .headers()
        .map_err(|e| Error::csv(&file, format!("line 1: the header cannot be read ({e})")))?
        .clone();
    let mut idx = Vec::new();
    for col in required {
        match headers.iter().position(|h| h == *col) {
            Some(i) => idx.push(Some(i)),
            None => {
                return Err(Error::csv(
                    &file,
                    format!(
                        "line 1: the header has no column {col} (expected {})",
                        required.join(",")
                    ),
                ))
            }
        }
    }
    let mut present = Vec::new();
    for col in optional {
        let p = headers.iter().position(|h| h == *col);
        present.push(p.is_some());
        idx.push(p);
    }
    let mut rows = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| {
            let line = e.position().map(|p| p.line()).unwrap_or(0);
            Error::csv(&file, format!("line {line}: the row cannot be read ({e})"))
        })?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        if rec.iter().all(|c| c.is_empty()) {
            continue;
        }
        let cells = idx
            .iter()
            .map(|i| i.and_then(|i| rec.get(i)).unwrap_or("").to_string())
            .collect();
        rows.push((line, cells));
    }
    if rows.is_empty() {
        return Err(Error::csv(&file, "the file has a header but no data rows"));
    }
    Ok((Table { file, rows }, present))
}

/// A cell as a finite number; errors name the file, the line and the column.
pub fn number(file: &str, line: u64, col: &str, cell: &str) -> Result<f64> {
    match cell.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(Error::csv(
            file,
            format!("line {line}: {col} is not a finite number (\"{cell}\")"),
        )),
        Err(_) if cell.is_empty() => {
            Err(Error::csv(file, format!("line {line}: {col} is missing")))
        }
        Err(_) => Err(Error::csv(
            file,
            format!("line {line}: {col} is not a number (\"{cell}\")"),
        )),
    }
}

/// The line of each row in a targets or readings file (for messages about
/// rows that parse but cannot be reached).
pub fn data_line(row: usize) -> usize {
    row + 2
}
