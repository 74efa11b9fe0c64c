//! Helpers shared by the integration tests that drive the binary.
#![allow(dead_code)]

use assert_cmd::Command;
use std::path::{Path, PathBuf};

/// Say that a test was skipped where `cargo test` shows it: libtest
/// captures `eprintln!`, not writes to the stderr handle itself.
pub fn skipped(test: &str, why: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "SKIPPED {test}: {why}");
}

pub fn bin() -> Command {
    Command::cargo_bin("tricept-calib").unwrap()
}

pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

pub fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Parse identified.csv into (name, estimate, identifiable).
pub fn identified(path: &Path) -> Vec<(String, f64, bool)> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let h = r.headers().unwrap().clone();
    assert_eq!(
        &h,
        &csv::StringRecord::from(vec![
            "parameter",
            "estimate_mm",
            "std_uncertainty_mm",
            "identifiable",
            "source"
        ])
    );
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            (
                rec[0].to_string(),
                rec[1].parse().unwrap(),
                &rec[3] == "true",
            )
        })
        .collect()
}

/// Run a command expecting bad-input exit 2, a one-line message containing
/// every `needle`, and no output files in `dir`.
pub fn bad_input(args: &[&str], needles: &[&str], dir: &Path) {
    let before = files_in(dir);
    let out = bin().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "args {args:?}: stderr {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "one line expected: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: '{n}' not in: {err}");
    }
    assert_eq!(
        files_in(dir),
        before,
        "no files may be written on bad input"
    );
}

pub fn sweep_toml(extra: &str) -> String {
    format!(
        "[sweep]\nencoder_arcsec = [1.0, 4.0]\nscale_um = [0.5, 2.0]\ntrials = 300\nerrors = \"random\"\nerror_bound = 0.5\nseed = 11\nmethods = [\"ols\", \"wls\"]\n{extra}"
    )
}

/// Every file under a final name in `dir` is complete (temporary files start with '.').
pub fn assert_no_partial_files(dir: &Path, trials: usize, grades: usize) {
    for name in files_in(dir) {
        if name.starts_with('.') {
            continue;
        }
        let bytes = std::fs::read(dir.join(&name)).unwrap();
        match name.as_str() {
            "trials.csv" => assert_eq!(
                bytes.iter().filter(|b| **b == b'\n').count(),
                1 + trials * grades,
                "trials.csv incomplete"
            ),
            "summary.csv" => assert_eq!(
                bytes.iter().filter(|b| **b == b'\n').count(),
                1 + grades,
                "summary.csv incomplete"
            ),
            "manifest.json" => {
                serde_json::from_slice::<serde_json::Value>(&bytes)
                    .expect("manifest.json incomplete");
            }
            n if n.ends_with(".png") => {
                assert!(bytes.ends_with(&[0xAE, 0x42, 0x60, 0x82]), "{n} incomplete")
            }
            n if n.ends_with(".svg") => assert!(
                String::from_utf8_lossy(&bytes)
                    .trim_end()
                    .ends_with("</svg>"),
                "{n} incomplete"
            ),
            "partial.json" => {
                serde_json::from_slice::<serde_json::Value>(&bytes)
                    .expect("partial.json incomplete");
            }
            _ => {}
        }
    }
}

pub fn exe() -> std::process::Command {
    std::process::Command::new(assert_cmd::cargo::cargo_bin("tricept-calib"))
}

/// The shipped paper config (`configs/paper.toml`).
pub fn paper() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/paper.toml")
}

/// Run and expect exit 2 with every needle in stderr.
pub fn refused(args: &[&str], needles: &[&str]) -> String {
    let o = bin().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "'{n}' not in: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
    err
}

/// No cell of any CSV, and no value of any JSON, in `dir` is NaN or infinite.
pub fn assert_all_finite(dir: &Path) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let ext = p.extension().and_then(|x| x.to_str()).unwrap_or("");
        if ext != "csv" && ext != "json" {
            continue;
        }
        let text = std::fs::read_to_string(&p).unwrap();
        for cell in text.split([',', '\n', ' ', ':', '[', ']']) {
            let c = cell.trim().trim_matches('"');
            let bad = ["NaN", "nan", "inf", "-inf", "+inf", "Infinity", "-Infinity"];
            assert!(!bad.contains(&c), "{}: holds {c}", p.display());
        }
    }
}

pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let dst = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &dst);
        } else {
            std::fs::copy(e.path(), dst).unwrap();
        }
    }
}

/// Wait until the run writing `out` has paused at its test hook (see
/// `TRICEPT_CALIB_TEST_PAUSE_AFTER_BLOCKS`); panics if it ended instead or
/// two minutes pass.
pub fn wait_paused(child: &mut std::process::Child, out: &Path) {
    let marker = out.join(".sweep-state/paused");
    let start = std::time::Instant::now();
    while !marker.exists() {
        if let Ok(Some(s)) = child.try_wait() {
            panic!("the run ended ({s}) before pausing at its test hook");
        }
        assert!(start.elapsed().as_secs() < 120, "the run never paused");
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
}

/// A sweep killed (SIGKILL) once `blocks` blocks are durable in its block
/// log, paused there by the test hook; the directory it left.
pub fn interrupted(dir: &Path, cfg: &Path, blocks: u64) -> PathBuf {
    let out = dir.join("killed");
    let mut child = exe()
        .args(["sweep", "--threads", "2", "--config"])
        .arg(cfg)
        .arg("--out")
        .arg(&out)
        .env("TRICEPT_CALIB_TEST_PAUSE_AFTER_BLOCKS", blocks.to_string())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    wait_paused(&mut child, &out);
    let _ = child.kill();
    let _ = child.wait();
    let _ = std::fs::remove_file(out.join(".sweep-state/paused"));
    out
}

/// The paper case on a layout where all 15 errors are identifiable.
pub const FULL_RANK_TOML: &str = r#"
[geometry]
platform_angles_deg = [-30.0, 90.0, 210.0]
[errors]
dxB1 = 0.2
dyB1 = 0.1
dyB2 = 0.2
dxB3 = 0.2
dyB3 = 0.27
dzB3 = 0.2
dxA1 = 0.25
dyA1 = -0.2
dxA2 = -0.25
dyA2 = 0.25
dxA3 = -0.31
dyA3 = 0.2
dq1 = 0.45
dq2 = 0.7
dq3 = 0.5
[identification]
iterations = 10
"#;

/// Every PNG figure in `dir` has its SVG beside it (same name, `.svg`).
pub fn assert_every_png_has_its_svg(dir: &Path) {
    let files = files_in(dir);
    let pngs: Vec<&String> = files.iter().filter(|f| f.ends_with(".png")).collect();
    assert!(!pngs.is_empty(), "no figure in {}", dir.display());
    for png in pngs {
        let svg = png.replace(".png", ".svg");
        let text = std::fs::read_to_string(dir.join(&svg))
            .unwrap_or_else(|_| panic!("{png} has no {svg} in {}", dir.display()));
        assert!(text.starts_with("<svg"), "{svg} is not an SVG");
        assert!(!text.contains("NaN"), "{svg} holds NaN");
    }
}

/// `simulate --config cfg --out readings` (seed 1), which must succeed.
pub fn simulate_log(cfg: &Path, readings: &Path) {
    bin()
        .args(["simulate", "--config"])
        .arg(cfg)
        .arg("--out")
        .arg(readings)
        .assert()
        .success();
}

/// `identify --config cfg --readings readings --out out`, to be asserted.
pub fn identify_cmd(cfg: &Path, readings: &Path, out: &Path) -> Command {
    let mut c = bin();
    c.args(["identify", "--config"])
        .arg(cfg)
        .arg("--readings")
        .arg(readings)
        .arg("--out")
        .arg(out);
    c
}
