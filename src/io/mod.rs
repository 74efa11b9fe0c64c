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

/// Do `a` and `b` name one existing file (by any path or hard link)?
pub fn same_file(a: &Path, b: &Path) -> bool {
    if a.as_os_str() == "-" || b.as_os_str() == "-" {
        return false;
    }
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        std::fs::canonicalize(a).ok() == std::fs::canonicalize(b).ok()
    }
}

/// The largest input file read (a log of 10⁷ poses is about 1 GB).
pub const MAX_INPUT_BYTES: u64 = 4 << 30;

/// Why `path` is no input file (a device — /dev/zero would be read until
/// memory ran out —, a socket or a directory); None for a regular file, a
/// pipe, or a path that does not exist (the reader then says so).
pub fn not_a_file(path: &Path) -> Option<&'static str> {
    let meta = std::fs::metadata(path).ok()?;
    if meta.is_dir() {
        return Some("is a directory, not a file");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_char_device() || t.is_block_device() || t.is_socket() {
            return Some("is a device or socket, not a file");
        }
    }
    None
}

/// A text input (a config, a catalogue) of at most `cap` bytes, refused
/// as [`not_a_file`] says; the error is the reason, for the caller to name.
pub fn read_text(path: &Path, cap: u64) -> std::result::Result<String, String> {
    if let Some(why) = not_a_file(path) {
        return Err(why.to_string());
    }
    let bytes = read_capped(path, cap).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => "does not exist".to_string(),
        _ => format!("cannot be read ({e})"),
    })?;
    String::from_utf8(bytes).map_err(|_| "is not UTF-8 text".to_string())
}

/// The file's bytes, or an error once it passes `cap`.
/// Lines of a regular file (its newlines), counted without holding it: what
/// a memory check counts before the file is parsed. None for stdin, a pipe
/// or a file that cannot be opened (the reader then says why).
pub fn count_lines(path: &Path) -> Option<u64> {
    use std::io::Read;
    if path.as_os_str() == "-" || !std::fs::metadata(path).ok()?.is_file() {
        return None;
    }
    let mut f = std::fs::File::open(path).ok()?;
    let mut buf = vec![0u8; 1 << 16];
    let mut lines = 0u64;
    loop {
        let n = f.read(&mut buf).ok()?;
        if n == 0 {
            return Some(lines);
        }
        lines += buf[..n].iter().filter(|&&b| b == b'\n').count() as u64;
    }
}

fn read_capped(path: &Path, cap: u64) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let f = std::fs::File::open(path)?;
    let mut buf = Vec::new();
    f.take(cap + 1).read_to_end(&mut buf)?;
    if buf.len() as u64 > cap {
        return Err(std::io::Error::other(format!(
            "it is larger than {} MiB, more than this input can be",
            cap >> 20
        )));
    }
    Ok(buf)
}

/// The bytes of an input file, or of stdin for `-`; errors name the file.
/// A device, socket or directory is refused without reading it.
pub fn read_bytes(path: &Path) -> Result<(String, Vec<u8>)> {
    if path.as_os_str() == "-" {
        let mut buf = Vec::new();
        std::io::Read::read_to_end(&mut std::io::stdin(), &mut buf)
            .map_err(|e| Error::csv("<stdin>", format!("cannot be read ({e})")))?;
        return Ok(("<stdin>".into(), buf));
    }
    let file = path.display().to_string();
    if let Some(why) = not_a_file(path) {
        return Err(Error::csv(&file, why));
    }
    let text = read_capped(path, MAX_INPUT_BYTES).map_err(|e| {
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
/// whether each optional column is present. Each data row is handed to
/// `row` with its line number as it is read, and not kept (a long log is
/// parsed without a table of its cells). Blank rows are skipped; a file
/// without data rows is refused.
pub fn for_each_row(
    file: &str,
    text: &[u8],
    required: &[&str],
    optional: &[&str],
    mut row: impl FnMut(u64, &[&str]) -> Result<()>,
) -> Result<Vec<bool>> {
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
                if let Some(why) = foreign_separator(text, required) {
                    return Err(Error::csv(&file, why));
                }
                return Err(Error::csv(
                    &file,
                    format!(
                        "line 1: the header has no column {col} (expected {})",
                        required.join(",")
                    ),
                ));
            }
        }
    }
    let mut present = Vec::new();
    for col in optional {
        let p = headers.iter().position(|h| h == *col);
        present.push(p.is_some());
        idx.push(p);
    }
    let mut any = false;
    let mut lines = LineCounter::default();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| {
            let line = e.position().map(|p| lines.at(text, p.byte())).unwrap_or(0);
            if let csv::ErrorKind::UnequalLengths {
                expected_len, len, ..
            } = e.kind()
            {
                if let Some(why) = decimal_commas(&file, line, text, *expected_len, *len) {
                    return why;
                }
                return Error::csv(
                    &file,
                    format!("line {line}: the row has {len} cells for the header's {expected_len} columns"),
                );
            }
            Error::csv(&file, format!("line {line}: the row cannot be read ({e})"))
        })?;
        let line = rec
            .position()
            .map(|p| lines.at(text, p.byte()))
            .unwrap_or(0);
        if rec.iter().all(|c| c.is_empty()) {
            continue;
        }
        let cells: Vec<&str> = idx
            .iter()
            .map(|i| i.and_then(|i| rec.get(i)).unwrap_or(""))
            .collect();
        row(line, &cells)?;
        any = true;
    }
    if !any {
        return Err(Error::csv(&file, "the file has a header but no data rows"));
    }
    Ok(present)
}

/// Every data row of a CSV table as cells in the order of `required` then
/// `optional` (see [`for_each_row`]), kept in memory.
pub fn read_table(
    file: &str,
    text: &[u8],
    required: &[&str],
    optional: &[&str],
) -> Result<(Table, Vec<bool>)> {
    let mut rows = Vec::new();
    let present = for_each_row(file, text, required, optional, |line, cells| {
        rows.push((line, cells.iter().map(|c| c.to_string()).collect()));
        Ok(())
    })?;
    Ok((
        Table {
            file: file.to_string(),
            rows,
        },
        present,
    ))
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
        Err(_) => match decimal_comma(cell) {
            Some(v) => Err(Error::csv(
                file,
                format!("line {line}: {col} is \"{cell}\", a number with a decimal comma: write it with a decimal point ({v})"),
            )),
            None => Err(Error::csv(
                file,
                format!("line {line}: {col} is not a number (\"{cell}\")"),
            )),
        },
    }
}

/// `cell` read with its one comma as the decimal point ("12,5" → 12.5):
/// None unless it is then a finite number.
fn decimal_comma(cell: &str) -> Option<f64> {
    if cell.matches(',').count() != 1 || cell.contains('.') {
        return None;
    }
    let v = cell.replace(',', ".");
    let ok = v.split('.').all(|p| {
        p.trim_start_matches(['-', '+'])
            .chars()
            .any(|c| c.is_ascii_digit())
    });
    v.parse::<f64>().ok().filter(|x| ok && x.is_finite())
}

/// Lines of CSV records from their byte offsets. The csv crate's own line
/// count is one short after CRLF terminators, and blind to lone CR; here
/// "\r\n", "\n" and "\r" each end one line. Offsets must come in
/// increasing order (a reader's records do).
#[derive(Default)]
struct LineCounter {
    byte: usize,
    line: u64,
    /// The last byte counted was a CR (a following LF ends the same line).
    after_cr: bool,
}

impl LineCounter {
    /// The line (from 1) of the record that starts at `byte` (the record's
    /// start may still be on the previous line's terminator: it is skipped).
    fn at(&mut self, text: &[u8], byte: u64) -> u64 {
        let mut end = (byte as usize).min(text.len());
        while end < text.len() && (text[end] == b'\r' || text[end] == b'\n') {
            end += 1;
        }
        for &b in &text[self.byte.min(end)..end] {
            match b {
                b'\n' if self.after_cr => {}
                b'\n' | b'\r' => self.line += 1,
                _ => {}
            }
            self.after_cr = b == b'\r';
        }
        self.byte = self.byte.max(end);
        self.line + 1
    }
}

/// When a header lacks the `required` columns because its file is
/// separated by ';' (a spreadsheet's CSV in a locale with decimal commas),
/// the sentence that says so.
fn foreign_separator(text: &[u8], required: &[&str]) -> Option<String> {
    let text = String::from_utf8_lossy(text);
    let mut lines = text.lines();
    let header = lines.next()?;
    let cells: Vec<&str> = header
        .split(';')
        .map(|c| c.trim().trim_matches('"'))
        .collect();
    // One cell: the header has no ';' at all, so its columns are not
    // separated by one.
    if cells.len() < 2 || !required.iter().any(|r| cells.contains(r)) {
        return None;
    }
    let commas = lines
        .take(50)
        .flat_map(|l| l.split(';'))
        .any(|c| decimal_comma(c.trim().trim_matches('"')).is_some());
    Some(format!(
        "line 1: the columns are separated by ';'{}: this tool reads ',' between columns and '.' in numbers (export the file as such a CSV)",
        if commas { " and the numbers have decimal commas" } else { "" }
    ))
}

/// A row of `len` cells for the header's `expected` columns (`len` more),
/// every cell digits (an exponent allowed) and none with a decimal point:
/// the decimal commas of a comma-separated file, and the sentence that says
/// so.
fn decimal_commas(file: &str, line: u64, text: &[u8], expected: u64, len: u64) -> Option<Error> {
    let row = String::from_utf8_lossy(text)
        .lines()
        .nth(usize::try_from(line).ok()?.checked_sub(1)?)?
        .to_string();
    let cells: Vec<&str> = row.split(',').map(str::trim).collect();
    let integer = |c: &&str| {
        let d = c.trim_start_matches(['-', '+']);
        d.starts_with(|x: char| x.is_ascii_digit())
            && d.chars().all(|x| x.is_ascii_digit() || "eE+-".contains(x))
    };
    if len <= expected || cells.len() as u64 != len || !cells.iter().all(integer) {
        return None;
    }
    Some(Error::csv(
        file,
        format!(
            "line {line}: {len} numbers for the header's {expected} columns: the file looks like it has decimal commas (\"{row}\"); write numbers with a decimal point and ',' between columns"
        ),
    ))
}

/// The line of data row `row` in a file whose rows follow its header line
/// by line (no blank line between them).
pub fn data_line(row: usize) -> usize {
    row + 2
}

/// A file of data rows as a message names them: its name, and each row's
/// line in it as it was read (a blank line the reader skipped is no row,
/// so row k need not be line k + 2).
#[derive(Debug, Clone, Copy)]
pub struct Source<'a> {
    pub name: &'a str,
    pub lines: &'a [u64],
}

impl<'a> Source<'a> {
    pub fn new(name: &'a str, lines: &'a [u64]) -> Self {
        Source { name, lines }
    }

    /// The line of data row `row` ([`data_line`] for a row it holds no
    /// line of).
    pub fn line(&self, row: usize) -> u64 {
        self.lines
            .get(row)
            .copied()
            .unwrap_or(data_line(row) as u64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines_of(text: &str) -> Vec<u64> {
        let (t, _) = read_table("t.csv", text.as_bytes(), &["a", "b"], &[]).unwrap();
        t.rows.iter().map(|(l, _)| *l).collect()
    }

    #[test]
    fn line_numbers_count_lf_crlf_and_cr_alike() {
        let rows = ["1,2", "3,4", "", "5,6"];
        for eol in ["\n", "\r\n", "\r"] {
            let text = format!("a,b{eol}{}{eol}", rows.join(eol));
            assert_eq!(lines_of(&text), [2, 3, 5], "{eol:?}");
        }
        // A quoted cell over two lines: the next row is on line 4.
        assert_eq!(lines_of("a,b\r\n\"x\r\ny\",2\r\n3,4\r\n"), [2, 4]);
    }

    #[test]
    fn a_decimal_comma_is_named() {
        assert_eq!(decimal_comma("12,5"), Some(12.5));
        assert_eq!(decimal_comma("-0,25"), Some(-0.25));
        for no in ["12", "1,2,3", "1.5,2", "a,b", ",5", "5,"] {
            assert_eq!(decimal_comma(no), None, "{no}");
        }
        let err = number("t.csv", 4, "q4_mm", "680,5")
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            "t.csv: line 4: q4_mm is \"680,5\", a number with a decimal comma: write it with a decimal point (680.5)"
        );
        let semi = read_table("t.csv", b"a;b\n1,5;2\n", &["a", "b"], &[])
            .err()
            .unwrap();
        assert_eq!(
            semi.to_string(),
            "t.csv: line 1: the columns are separated by ';' and the numbers have decimal commas: this tool reads ',' between columns and '.' in numbers (export the file as such a CSV)"
        );
        // A header that is simply wrong is still said to be so.
        let wrong = read_table("t.csv", b"a;c\n1;2\n", &["a", "b"], &[])
            .err()
            .unwrap();
        assert!(wrong.to_string().contains("separated by ';'"), "{wrong}");
        // A header of one required column alone lacks the others: no ';'.
        let one = read_table("t.csv", b"a\n1\n", &["a", "b"], &[])
            .err()
            .unwrap()
            .to_string();
        assert!(one.contains("no column b") && !one.contains(';'), "{one}");
        let wrong = read_table("t.csv", b"x,y\n1,2\n", &["a", "b"], &[])
            .err()
            .unwrap();
        assert!(wrong.to_string().contains("no column a"), "{wrong}");
    }
}
