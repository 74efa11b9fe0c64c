//! Issue 28, a result an engineer can trust: readings whose rows are out of
//! order, files in a spreadsheet's locale (';', decimal commas), line
//! numbers in CRLF files, identified.csv's uncertainty of an error that
//! cannot be identified, the bound on identified values, and
//! `compensate --threads`.

mod common;

use common::{bad_input, bin, paper, refused, write};
use std::path::{Path, PathBuf};
use tempfile::TempDir;

/// The paper machine's simulated readings, as lines of text (header first).
fn readings(dir: &Path) -> Vec<String> {
    let r = dir.join("r.csv");
    bin()
        .args(["simulate", "--config"])
        .arg(paper())
        .arg("--out")
        .arg(&r)
        .assert()
        .success();
    std::fs::read_to_string(&r)
        .unwrap()
        .lines()
        .map(String::from)
        .collect()
}

/// `identify` of `file` in `dir` (its output folder `dir/o`), expected to be
/// refused with exit 2, one line naming every needle, and no output.
fn identify_refused(dir: &Path, file: &Path, needles: &[&str]) -> String {
    let out = dir.join("o");
    bad_input(
        &[
            "identify",
            "--config",
            paper().to_str().unwrap(),
            "--readings",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        needles,
        dir,
    );
    refused(
        &[
            "identify",
            "--config",
            paper().to_str().unwrap(),
            "--readings",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        needles,
    )
}

/// The lines with the readings columns (4th on) of data lines `a` and `b`
/// (CSV line numbers) exchanged: the targets stay where they are.
fn readings_exchanged(lines: &[String], a: usize, b: usize) -> Vec<String> {
    let mut cells: Vec<Vec<String>> = lines
        .iter()
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    let ra = cells[a - 1].split_off(3);
    let rb = cells[b - 1].split_off(3);
    cells[a - 1].extend(rb);
    cells[b - 1].extend(ra);
    cells.iter().map(|c| c.join(",")).collect()
}

fn save(dir: &Path, name: &str, lines: &[String], eol: &str) -> PathBuf {
    write(dir, name, &(lines.join(eol) + eol))
}

#[test]
fn rows_out_of_order_are_named_as_rows_out_of_order() {
    let t = TempDir::new().unwrap();
    let lines = readings(t.path());
    // Lines 11 and 17 ((400, 0) and (0, -400) at z = 650): exchanged, the
    // readings of each look like the other's with ψ and θ swapped — the
    // old diagnosis said "psi4_deg and theta4_deg look swapped".
    let f = save(
        t.path(),
        "ooo.csv",
        &readings_exchanged(&lines, 11, 17),
        "\n",
    );
    let err = identify_refused(
        t.path(),
        &f,
        &["ooo.csv: line 11: rows out of order", "target of line 17"],
    );
    assert!(
        !err.contains("swapped") && !err.contains("flipped"),
        "{err}"
    );
    // Others that looked like a flipped sign.
    let f = save(
        t.path(),
        "ooo2.csv",
        &readings_exchanged(&lines, 12, 14),
        "\n",
    );
    identify_refused(t.path(), &f, &["line 12: rows out of order", "line 14"]);
    // The reference row's readings exchanged with the next row's: the
    // reference row (line 2) is the first out of order.
    let f = save(t.path(), "ref.csv", &readings_exchanged(&lines, 2, 3), "\n");
    identify_refused(t.path(), &f, &["line 2: rows out of order", "line 3"]);
    // The readings of lines 20–24 rotated by one (a log pasted one row
    // off): the first row out of order is named.
    let mut rotated = lines.clone();
    for l in 20..24 {
        rotated = readings_exchanged(&rotated, l, l + 1);
    }
    let f = save(t.path(), "rot.csv", &rotated, "\n");
    identify_refused(t.path(), &f, &["line 20: rows out of order"]);
    // A row whose two angle columns are swapped is still that, not rows
    // out of order.
    let mut swapped = lines.clone();
    let mut c: Vec<&str> = swapped[11].split(',').collect();
    c.swap(3, 4);
    swapped[11] = c.join(",");
    let f = save(t.path(), "swap.csv", &swapped, "\n");
    let err = identify_refused(t.path(), &f, &["line 12", "swapped"]);
    assert!(!err.contains("out of order"), "{err}");
}

#[test]
fn semicolon_and_decimal_comma_files_are_named_as_such() {
    let t = TempDir::new().unwrap();
    let lines = readings(t.path());
    let semi: Vec<String> = lines.iter().map(|l| l.replace(',', ";")).collect();
    let f = save(t.path(), "semi.csv", &semi, "\n");
    let err = identify_refused(
        t.path(),
        &f,
        &["semi.csv: line 1: the columns are separated by ';'"],
    );
    assert!(
        !err.contains("no column") && !err.contains("decimal comma"),
        "{err}"
    );
    // The usual spreadsheet export of a decimal-comma locale.
    let both: Vec<String> = semi.iter().map(|l| l.replace('.', ",")).collect();
    let f = save(t.path(), "both.csv", &both, "\r\n");
    identify_refused(
        t.path(),
        &f,
        &["both.csv: line 1: ", "separated by ';'", "decimal commas"],
    );
    // Decimal commas in a comma-separated file: more numbers than columns.
    let mut dc = vec![lines[0].clone()];
    dc.extend(lines[1..].iter().map(|l| l.replace('.', ",")));
    let f = save(t.path(), "dc.csv", &dc, "\n");
    let err = identify_refused(t.path(), &f, &["dc.csv: line 2: ", "decimal commas"]);
    assert!(!err.contains("CSV error"), "{err}");
    // One quoted cell with a decimal comma.
    let mut quoted = lines.clone();
    let mut c: Vec<String> = quoted[4].split(',').map(String::from).collect();
    c[5] = "\"680,5\"".into();
    quoted[4] = c.join(",");
    let f = save(t.path(), "quoted.csv", &quoted, "\n");
    identify_refused(
        t.path(),
        &f,
        &[
            "quoted.csv: line 5: q4_mm is \"680,5\"",
            "decimal comma",
            "680.5",
        ],
    );
}

#[test]
fn line_numbers_are_right_in_crlf_files() {
    let t = TempDir::new().unwrap();
    let lines = readings(t.path());
    for (name, eol) in [("lf", "\n"), ("crlf", "\r\n")] {
        // A cell that is no number, on line 7 and on line 2.
        for line in [2, 7, 40] {
            let mut bad = lines.clone();
            let mut c: Vec<&str> = bad[line - 1].split(',').collect();
            c[4] = "abc";
            bad[line - 1] = c.join(",");
            let f = save(t.path(), &format!("{name}{line}.csv"), &bad, eol);
            identify_refused(
                t.path(),
                &f,
                &[&format!("line {line}: theta4_deg is not a number")],
            );
        }
        // A row with a cell too many.
        let mut extra = lines.clone();
        extra[6].push_str(",1");
        let f = save(t.path(), &format!("{name}-extra.csv"), &extra, eol);
        let err = identify_refused(
            t.path(),
            &f,
            &["line 7: the row has 7 cells for the header's 6 columns"],
        );
        assert!(!err.contains("line: 6"), "{err}");
        // A reading with its sign flipped (found after parsing).
        let mut sign = lines.clone();
        let mut c: Vec<String> = sign[29].split(',').map(String::from).collect();
        c[3] = format!("{}", -c[3].parse::<f64>().unwrap());
        sign[29] = c.join(",");
        let f = save(t.path(), &format!("{name}-sign.csv"), &sign, eol);
        identify_refused(t.path(), &f, &["line 30: ", "sign"]);
    }
    // A targets file in CRLF: the unreachable target's line.
    let id = t.path().join("id");
    bin()
        .args(["identify", "--config"])
        .arg(paper())
        .arg("--readings")
        .arg(t.path().join("r.csv"))
        .arg("--out")
        .arg(&id)
        .assert()
        .success();
    let targets = write(
        t.path(),
        "targets.csv",
        "x_mm,y_mm,z_mm\r\n0,0,700\r\n0,0,abc\r\n",
    );
    refused(
        &[
            "compensate",
            "--config",
            paper().to_str().unwrap(),
            "--identified",
            id.join("identified.csv").to_str().unwrap(),
            "--targets",
            targets.to_str().unwrap(),
            "--out",
            t.path().join("c").to_str().unwrap(),
        ],
        &["targets.csv: line 3: z_mm is not a number"],
    );
}

/// identify's output folder for the paper's readings (dyA3 cannot be
/// identified from the paper's poses and sensors).
fn identified(dir: &Path) -> PathBuf {
    readings(dir);
    let id = dir.join("id");
    bin()
        .args(["identify", "--config"])
        .arg(paper())
        .arg("--readings")
        .arg(dir.join("r.csv"))
        .arg("--out")
        .arg(&id)
        .assert()
        .success();
    id.join("identified.csv")
}

#[test]
fn an_error_that_cannot_be_identified_has_no_uncertainty() {
    let t = TempDir::new().unwrap();
    let file = identified(t.path());
    let text = std::fs::read_to_string(&file).unwrap();
    let rows = common::identified(&file);
    assert!(rows.iter().any(|r| !r.2), "{text}");
    for (line, (name, _, ident)) in text.lines().skip(1).zip(&rows) {
        let std = line.split(',').nth(2).unwrap();
        if *ident {
            assert!(std.parse::<f64>().unwrap() > 0.0, "{name}: {text}");
        } else {
            assert_eq!(std, "", "{name}: {text}");
        }
    }
    // compensate reads it (the empty cell is no error).
    bin()
        .args(["compensate", "--config"])
        .arg(paper())
        .arg("--identified")
        .arg(&file)
        .arg("--out")
        .arg(t.path().join("c"))
        .assert()
        .success();
}

#[test]
fn identified_values_beyond_10_mm_are_refused() {
    let t = TempDir::new().unwrap();
    let file = identified(t.path());
    let text = std::fs::read_to_string(&file).unwrap();
    // dq1 (line 14) at 12 mm: within the old bound (50 mm on the paper's
    // machine), beyond 10 mm.
    let edited: Vec<String> = text
        .lines()
        .map(|l| {
            if l.starts_with("dq1,") {
                "dq1,12.0,0.05,true,readings".to_string()
            } else {
                l.to_string()
            }
        })
        .collect();
    let bad = save(t.path(), "big.csv", &edited, "\n");
    let out = t.path().join("c");
    bad_input(
        &[
            "compensate",
            "--config",
            paper().to_str().unwrap(),
            "--identified",
            bad.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &["big.csv: line 14: dq1 estimate_mm = 12 is not a geometric error of this machine (beyond 10 mm"],
        t.path(),
    );
}

#[test]
fn compensate_takes_threads_and_its_results_do_not_depend_on_them() {
    let t = TempDir::new().unwrap();
    let file = identified(t.path());
    let run = |threads: &str| {
        let out = t.path().join(format!("c{threads}"));
        bin()
            .args(["compensate", "--threads", threads, "--config"])
            .arg(paper())
            .arg("--identified")
            .arg(&file)
            .arg("--out")
            .arg(&out)
            .assert()
            .success();
        out
    };
    let (one, three) = (run("1"), run("3"));
    for name in [
        "volumetric.csv",
        "volumetric_summary.csv",
        "workspace_accuracy.csv",
        "iso9283.csv",
    ] {
        assert_eq!(
            std::fs::read(one.join(name)).unwrap(),
            std::fs::read(three.join(name)).unwrap(),
            "{name}"
        );
    }
    refused(
        &[
            "compensate",
            "--threads",
            "0",
            "--config",
            paper().to_str().unwrap(),
            "--identified",
            file.to_str().unwrap(),
            "--out",
            t.path().join("c0").to_str().unwrap(),
        ],
        &["--threads must be at least 1"],
    );
}

/// A blank line is no row, and a message names the line a row stands on:
/// identify's and verify's unreachable target after two blank lines, and
/// compensate's after one, each name their own line (row k is not line
/// k + 2 past a blank line).
#[test]
fn line_numbers_are_right_past_blank_lines() {
    let t = TempDir::new().unwrap();
    let csv = identified(t.path());
    let mut lines = readings(t.path());
    let mut far: Vec<String> = lines[6].split(',').map(String::from).collect();
    far[0] = "5000".into();
    lines[6] = far.join(",");
    lines.insert(3, String::new());
    lines.insert(5, String::new());
    assert!(lines[8].starts_with("5000,"), "{}", lines[8]);
    let bad = save(t.path(), "bad.csv", &lines, "\n");
    identify_refused(t.path(), &bad, &["bad.csv: line 9: target (5000"]);
    let with = |command: &str, extra: &[&str], needle: &str| {
        let (config, identified) = (paper(), csv.to_str().unwrap().to_string());
        let mut args = vec![command, "--config", config.to_str().unwrap()];
        args.extend(["--identified", &identified]);
        args.extend(extra);
        refused(&args, &[needle]);
    };
    let b = bad.to_str().unwrap();
    with(
        "verify",
        &["--readings", b, "--threshold", "0.05"],
        "bad.csv: line 9:",
    );
    let targets = write(t.path(), "t.csv", "x_mm,y_mm,z_mm\n0,0,700\n\n5000,0,700\n");
    let c = t.path().join("c");
    let (t, c) = (targets.to_str().unwrap(), c.to_str().unwrap());
    with(
        "compensate",
        &["--targets", t, "--out", c],
        "t.csv: line 4:",
    );
}
