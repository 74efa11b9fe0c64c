//! The binary end to end (SPEC §10): commands, files, exit codes, messages.

use assert_cmd::Command;
use predicates::prelude::*;
use std::path::{Path, PathBuf};
use tempfile::TempDir;

/// Say that a test was skipped where `cargo test` shows it: libtest
/// captures `eprintln!`, not writes to the stderr handle itself.
fn skipped(test: &str, why: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "SKIPPED {test}: {why}");
}

fn bin() -> Command {
    Command::cargo_bin("tricept-calib").unwrap()
}

fn paper_config() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/paper.toml")
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn files_in(dir: &Path) -> Vec<String> {
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
fn identified(path: &Path) -> Vec<(String, f64, bool)> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let h = r.headers().unwrap().clone();
    assert_eq!(
        &h,
        &csv::StringRecord::from(vec![
            "parameter",
            "estimate_mm",
            "std_uncertainty_mm",
            "identifiable"
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

const FULL_RANK_TOML: &str = r#"
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

#[test]
fn simulate_identify_compensate_roundtrip() {
    let t = TempDir::new().unwrap();
    let cfg = write(t.path(), "full.toml", FULL_RANK_TOML);
    let readings = t.path().join("r.csv");
    bin()
        .args(["simulate", "--config"])
        .arg(&cfg)
        .args(["--noise-free", "--out"])
        .arg(&readings)
        .assert()
        .success();
    let text = std::fs::read_to_string(&readings).unwrap();
    assert!(text.starts_with("x_mm,y_mm,z_mm,psi4_deg,theta4_deg,q4_mm\n"));
    assert_eq!(text.lines().count(), 52);
    let out = t.path().join("id");
    bin()
        .args(["identify", "--config"])
        .arg(&cfg)
        .arg("--readings")
        .arg(&readings)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let est = identified(&out.join("identified.csv"));
    let truth = [
        0.2, 0.1, 0.2, 0.2, 0.27, 0.2, 0.25, -0.2, -0.25, 0.25, -0.31, 0.2, 0.45, 0.7, 0.5,
    ];
    assert_eq!(est.len(), 15);
    for ((name, v, ident), t) in est.iter().zip(truth) {
        assert!(ident, "{name}");
        assert!((v - t).abs() < 1e-7, "{name}: {v} vs {t}");
    }
    let comp = t.path().join("comp");
    let targets = write(
        t.path(),
        "targets.csv",
        "x_mm,y_mm,z_mm\n0,0,750\n100.5,-200,700\n",
    );
    bin()
        .args(["compensate", "--config"])
        .arg(&cfg)
        .arg("--identified")
        .arg(out.join("identified.csv"))
        .arg("--out")
        .arg(&comp)
        .arg("--targets")
        .arg(&targets)
        .assert()
        .success();
    let mut r = csv::Reader::from_path(comp.join("volumetric_summary.csv")).unwrap();
    let rows: Vec<csv::StringRecord> = r.records().map(|x| x.unwrap()).collect();
    assert_eq!(&rows[0][0], "before");
    assert_eq!(&rows[1][0], "after");
    let before_max: f64 = rows[0][1].parse().unwrap();
    let after_max: f64 = rows[1][1].parse().unwrap();
    assert!(before_max > 0.3, "{before_max}");
    assert!(
        after_max < 1e-6,
        "perfect identification must compensate exactly: {after_max}"
    );
    let vol = std::fs::read_to_string(comp.join("volumetric.csv")).unwrap();
    assert!(vol.starts_with("x_mm,y_mm,z_mm,before_mm,after_mm\n"));
    assert_eq!(vol.lines().count(), 1258);
    let cmds = std::fs::read_to_string(comp.join("commands.csv")).unwrap();
    assert!(cmds.starts_with("x_mm,y_mm,z_mm,q1_mm,q2_mm,q3_mm\n"));
    assert_eq!(cmds.lines().count(), 3);
}

#[test]
fn noisy_identify_flags_dya3_in_paper_layout() {
    let t = TempDir::new().unwrap();
    let readings = t.path().join("r.csv");
    bin()
        .args(["simulate", "--config"])
        .arg(paper_config())
        .args(["--seed", "7", "--out"])
        .arg(&readings)
        .assert()
        .success();
    let out = t.path().join("id");
    bin()
        .args(["identify", "--config"])
        .arg(paper_config())
        .arg("--readings")
        .arg(&readings)
        .arg("--out")
        .arg(&out)
        .assert()
        .success()
        .stderr(predicate::str::contains("dyA3"));
    let est = identified(&out.join("identified.csv"));
    let dya3 = est.iter().find(|e| e.0 == "dyA3").unwrap();
    assert!(!dya3.2 && dya3.1 == 0.0);
    assert!(est.iter().filter(|e| e.2).count() == 14);
}

#[test]
fn identifiability_json_reports_rank() {
    let out = bin()
        .args(["identifiability", "--format", "json", "--config"])
        .arg(paper_config())
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["rank"], 14);
    assert_eq!(v["parameters"], 15);
    assert_eq!(v["singular_values"].as_array().unwrap().len(), 15);
    assert_eq!(v["unidentifiable"], serde_json::json!(["dyA3"]));
    assert!(v["observability"]["o1"].as_f64().unwrap() > 0.0);
    bin()
        .args(["identifiability", "--config"])
        .arg(paper_config())
        .assert()
        .success()
        .stdout(predicate::str::contains("rank 14 of 15"));
    let t = TempDir::new().unwrap();
    let full = write(t.path(), "f.toml", FULL_RANK_TOML);
    bin()
        .args(["identifiability", "--config"])
        .arg(&full)
        .assert()
        .success()
        .stdout(predicate::str::contains("rank 15 of 15"));
}

/// Run a command expecting bad-input exit 2, a one-line message containing
/// every `needle`, and no output files in `dir`.
fn bad_input(args: &[&str], needles: &[&str], dir: &Path) {
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

#[test]
fn bad_configs_exit_2_naming_the_key() {
    let t = TempDir::new().unwrap();
    let d = t.path();
    let out = d.join("o.csv");
    let out = out.to_str().unwrap();
    let cases: &[(&str, &str, &[&str])] = &[
        (
            "malformed.toml",
            "[geometry]\na = = 3\n",
            &["malformed.toml line 2"],
        ),
        (
            "unknown.toml",
            "[geometry]\nradius = 3.0\n",
            &["unknown.toml line 2", "unknown field `radius`"],
        ),
        (
            "section.toml",
            "[geometri]\na = 3.0\n",
            &["section.toml", "geometri"],
        ),
        (
            "neg.toml",
            "[geometry]\na = -100.0\n",
            &["geometry.a", "positive"],
        ),
        (
            "zero.toml",
            "[workspace]\nradius = 0.0\n",
            &["workspace.radius"],
        ),
        (
            "parallel.toml",
            "[geometry]\nbase_angles_deg = [-50.0, 60.0, 180.0]\n",
            &["geometry.base_angles_deg", "parallel"],
        ),
        (
            "param.toml",
            "[errors]\ndzB1 = 0.1\n",
            &["errors.dzB1", "frame convention"],
        ),
        (
            "name.toml",
            "[errors]\nfoo = 0.1\n",
            &["errors.foo", "dxB1"],
        ),
        (
            "pose.toml",
            "[poses]\nlist = [[0.0, 0.0, 650.0], [0.0, 0.0, -10.0]]\n",
            &["pose 1", "not reachable"],
        ),
        (
            "tilt.toml",
            "[poses]\nlist = [[0.0, 0.0, 650.0], [3000.0, 0.0, 100.0]]\n",
            &["pose 1", "max_tilt_deg"],
        ),
        (
            "method.toml",
            "[identification]\nmethod = \"svd\"\n",
            &["identification.method"],
        ),
        (
            "type.toml",
            "[sensors]\nsamples = \"three\"\n",
            &["type.toml line 2"],
        ),
    ];
    for (name, text, needles) in cases {
        let cfg = write(d, name, text);
        let before = files_in(d);
        let o = bin()
            .args(["simulate", "--config", cfg.to_str().unwrap(), "--out", out])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{name}: {err}");
        for n in *needles {
            assert!(err.contains(n), "{name}: '{n}' not in: {err}");
        }
        assert_eq!(files_in(d), before, "{name}");
    }
    bad_input(
        &["simulate", "--config", "/nonexistent/c.toml", "--out", out],
        &["/nonexistent/c.toml", "does not exist"],
        d,
    );
}

#[test]
fn bad_csvs_exit_2_naming_the_line() {
    let t = TempDir::new().unwrap();
    let d = t.path();
    let cfg = paper_config();
    let cfg = cfg.to_str().unwrap();
    let outdir = d.join("out");
    let outdir = outdir.to_str().unwrap();
    let good =
        "x_mm,y_mm,z_mm,psi4_deg,theta4_deg,q4_mm\n0,0,650,0,0,650\n200,0,650,0,17.1,680.1\n";
    let cases: &[(&str, String, &[&str])] = &[
        (
            "nan.csv",
            good.replace("680.1", "NaN"),
            &["nan.csv", "line 3", "q4_mm", "finite"],
        ),
        (
            "text.csv",
            good.replace("17.1", "abc"),
            &["text.csv", "line 3", "theta4_deg", "not a number"],
        ),
        (
            "missing.csv",
            good.replace(",q4_mm", ""),
            &["missing.csv", "q4_mm"],
        ),
        (
            "empty.csv",
            "x_mm,y_mm,z_mm,psi4_deg,theta4_deg,q4_mm\n".into(),
            &["empty.csv", "no data rows"],
        ),
        (
            "short.csv",
            good.replace(",680.1", ""),
            &["short.csv", "line 3"],
        ),
        (
            "unreach.csv",
            good.replace("200,0,650", "200,0,-650"),
            &["unreach.csv", "line 3", "not reachable"],
        ),
    ];
    for (name, text, needles) in cases {
        let p = write(d, name, text);
        bad_input(
            &[
                "identify",
                "--config",
                cfg,
                "--readings",
                p.to_str().unwrap(),
                "--out",
                outdir,
            ],
            needles,
            d,
        );
    }
    // identified.csv with an unknown parameter and a missing one.
    let bad_param = write(
        d,
        "idp.csv",
        "parameter,estimate_mm,std_uncertainty_mm,identifiable\ndzB1,0.1,0,true\n",
    );
    bad_input(
        &[
            "compensate",
            "--config",
            cfg,
            "--identified",
            bad_param.to_str().unwrap(),
            "--out",
            outdir,
        ],
        &["idp.csv", "line 2", "dzB1"],
        d,
    );
    // Targets: unreachable and non-numeric rows name their line.
    let idf = Path::new(env!("CARGO_MANIFEST_DIR")).join("results/paper/identified.csv");
    let idf = idf.to_str().unwrap();
    let far = write(d, "far.csv", "x_mm,y_mm,z_mm\n0,0,750\n0,0,-5\n");
    bad_input(
        &[
            "compensate",
            "--config",
            cfg,
            "--identified",
            idf,
            "--out",
            outdir,
            "--targets",
            far.to_str().unwrap(),
        ],
        &["far.csv", "line 3", "not reachable"],
        d,
    );
    let nan = write(d, "nant.csv", "x_mm,y_mm,z_mm\n0,0,750\n1,inf,700\n");
    bad_input(
        &[
            "compensate",
            "--config",
            cfg,
            "--identified",
            idf,
            "--out",
            outdir,
            "--targets",
            nan.to_str().unwrap(),
        ],
        &["nant.csv", "line 3", "y_mm"],
        d,
    );
    let one = write(
        d,
        "id1.csv",
        "parameter,estimate_mm,std_uncertainty_mm,identifiable\ndxB1,0.1,0,true\n",
    );
    bad_input(
        &[
            "compensate",
            "--config",
            cfg,
            "--identified",
            one.to_str().unwrap(),
            "--out",
            outdir,
        ],
        &["id1.csv", "missing"],
        d,
    );
}

#[test]
fn bad_arguments_exit_2() {
    let t = TempDir::new().unwrap();
    let d = t.path();
    let o = d.join("s");
    let o = o.to_str().unwrap();
    let cfg = paper_config();
    let cfg = cfg.to_str().unwrap();
    bad_input(
        &["sweep", "--config", cfg, "--threads", "0", "--out", o],
        &["--threads"],
        d,
    );
    bad_input(
        &["sweep", "--config", cfg, "--trials", "0", "--out", o],
        &["--trials"],
        d,
    );
    let cases: &[(&str, &str, &str)] = &[
        (
            "g0.toml",
            "[sweep]\nencoder_arcsec = [1.0, 0.0]\n",
            "sweep.encoder_arcsec",
        ),
        (
            "gneg.toml",
            "[sweep]\nscale_um = [-0.5]\n",
            "sweep.scale_um",
        ),
        (
            "gempty.toml",
            "[sweep]\nencoder_arcsec = []\n",
            "sweep.encoder_arcsec",
        ),
        ("trials.toml", "[sweep]\ntrials = 0\n", "sweep.trials"),
        (
            "metric.toml",
            "[decision]\nmetric = \"mu_max\"\n",
            "decision.metric",
        ),
        (
            "errs.toml",
            "[sweep]\nerrors = \"gaussian\"\n",
            "sweep.errors",
        ),
    ];
    for (name, text, key) in cases {
        let p = write(d, name, text);
        bad_input(
            &["sweep", "--config", p.to_str().unwrap(), "--out", o],
            &[key],
            d,
        );
    }
    let out = bin().args(["simulate", "--bogus"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn unwritable_output_is_exit_1_with_the_path() {
    let t = TempDir::new().unwrap();
    let blocker = write(t.path(), "file", "x");
    let target = blocker.join("sub");
    bin()
        .args(["identifiability", "--config"])
        .arg(paper_config())
        .assert()
        .success();
    let o = bin()
        .args(["simulate", "--config"])
        .arg(paper_config())
        .arg("--out")
        .arg(target.join("r.csv"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains(&target.display().to_string()));
    let o = bin()
        .args(["sweep", "--trials", "10", "--config"])
        .arg(paper_config())
        .arg("--out")
        .arg(&target)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains(&target.display().to_string()));
}

fn sweep_toml(extra: &str) -> String {
    format!(
        "[sweep]\nencoder_arcsec = [1.0, 4.0]\nscale_um = [0.5, 2.0]\ntrials = 300\nerrors = \"random\"\nerror_bound = 0.5\nseed = 11\nmethods = [\"ols\", \"wls\"]\n{extra}"
    )
}

#[test]
fn sweep_is_byte_identical_across_thread_counts() {
    let t = TempDir::new().unwrap();
    let cfg = write(t.path(), "s.toml", &sweep_toml(""));
    let a = t.path().join("a");
    let b = t.path().join("b");
    for (dir, threads) in [(&a, "1"), (&b, "2")] {
        bin()
            .args(["sweep", "--threads", threads, "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(dir)
            .assert()
            .success();
    }
    for f in [
        "trials.csv",
        "summary.csv",
        "parameters.csv",
        "decision.csv",
        "fig4.svg",
        "fig4.png",
        "grade_map.svg",
        "grade_map.png",
        "parameters.png",
    ] {
        let x = std::fs::read(a.join(f)).unwrap();
        let y = std::fs::read(b.join(f)).unwrap();
        assert!(x == y, "{f} differs between --threads 1 and 2");
    }
    let trials = std::fs::read_to_string(a.join("trials.csv")).unwrap();
    assert!(trials.starts_with("encoder_arcsec,scale_um,method,trial,mu,mu0"));
    assert_eq!(trials.lines().count(), 1 + 300 * 2 * 2 * 2);
    let summary = std::fs::read_to_string(a.join("summary.csv")).unwrap();
    let header = summary.lines().next().unwrap();
    for col in [
        "encoder_arcsec",
        "scale_um",
        "trials",
        "mu_mean",
        "mu_median",
        "mu_p95",
        "mu0_mean",
        "ratio_median",
        "ratio_p95",
    ] {
        assert!(
            header.split(',').any(|c| c == col),
            "summary.csv lacks {col}"
        );
    }
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["seed"], 11);
    assert!(m["calibrations_per_second"].as_f64().unwrap() > 0.0);
    // A different seed gives different trials.
    let c = t.path().join("c");
    bin()
        .args(["sweep", "--seed", "12", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&c)
        .assert()
        .success();
    assert_ne!(
        std::fs::read(a.join("trials.csv")).unwrap(),
        std::fs::read(c.join("trials.csv")).unwrap()
    );
}

#[test]
fn sweep_mu0_of_uniform_errors_is_half_the_bound() {
    let t = TempDir::new().unwrap();
    let cfg = write(
        t.path(),
        "s.toml",
        "[sweep]\nencoder_arcsec = [2.0]\ntrials = 4000\nerrors = \"random\"\nerror_bound = 0.4\nseed = 5\n",
    );
    let out = t.path().join("o");
    bin()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let mut r = csv::Reader::from_path(out.join("trials.csv")).unwrap();
    let h = r.headers().unwrap().clone();
    let i = h.iter().position(|c| c == "mu0").unwrap();
    let v: Vec<f64> = r
        .records()
        .map(|x| x.unwrap()[i].parse().unwrap())
        .collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    // E|U(-b, b)| = b/2; the mean of 15 has sd b/(2·√3·√15).
    assert!(
        (mean - 0.2).abs() < 3.0 * sd / n.sqrt(),
        "mean mu0 {mean} vs 0.2 (sd {sd})"
    );
    assert!(
        (sd - 0.4 / (2.0 * 3f64.sqrt() * 15f64.sqrt())).abs() < 0.1 * sd,
        "{sd}"
    );
}

#[test]
fn sweep_without_noise_matches_identify() {
    // Fixed errors and (practically) zero noise: the sweep's μ must equal μ
    // of `identify` on noise-free readings of the same machine.
    let t = TempDir::new().unwrap();
    let cfg = write(
        t.path(),
        "s.toml",
        "[errors]\ndxB1 = 0.2\ndyB1 = 0.1\ndyB2 = 0.2\ndxB3 = 0.2\ndyB3 = 0.27\ndzB3 = 0.2\ndxA1 = 0.25\ndyA1 = -0.2\ndxA2 = -0.25\ndyA2 = 0.25\ndxA3 = -0.31\ndyA3 = 0.2\ndq1 = 0.45\ndq2 = 0.7\ndq3 = 0.5\n[sweep]\nencoder_arcsec = [1e-12]\nscale_um = [1e-12]\ntrials = 3\nerrors = \"fixed\"\n",
    );
    let sw = t.path().join("sw");
    bin()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&sw)
        .assert()
        .success();
    let readings = t.path().join("r.csv");
    bin()
        .args(["simulate", "--noise-free", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&readings)
        .assert()
        .success();
    let id = t.path().join("id");
    bin()
        .args(["identify", "--config"])
        .arg(&cfg)
        .arg("--readings")
        .arg(&readings)
        .arg("--out")
        .arg(&id)
        .assert()
        .success();
    let truth = [
        0.2, 0.1, 0.2, 0.2, 0.27, 0.2, 0.25, -0.2, -0.25, 0.25, -0.31, 0.2, 0.45, 0.7, 0.5,
    ];
    let est = identified(&id.join("identified.csv"));
    let mu_identify: f64 = est
        .iter()
        .zip(truth)
        .map(|(e, t)| (e.1 - t).abs())
        .sum::<f64>()
        / 15.0;
    let mut r = csv::Reader::from_path(sw.join("trials.csv")).unwrap();
    let h = r.headers().unwrap().clone();
    let i = h.iter().position(|c| c == "mu").unwrap();
    for rec in r.records() {
        let mu: f64 = rec.unwrap()[i].parse().unwrap();
        assert!(
            (mu - mu_identify).abs() < 1e-9,
            "sweep mu {mu} vs identify {mu_identify}"
        );
    }
}

#[test]
fn reproduce_writes_every_artifact() {
    let t = TempDir::new().unwrap();
    let cfg = std::fs::read_to_string(paper_config())
        .unwrap()
        .replace("fig4_draws = 1000", "fig4_draws = 60");
    let cfg = write(t.path(), "paper.toml", &cfg);
    let out = t.path().join("rp");
    bin()
        .args(["reproduce", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    for f in [
        "identified.csv",
        "volumetric.csv",
        "volumetric_summary.csv",
        "fig3.png",
        "fig4.csv",
        "fig4.png",
        "identifiability.json",
        "report.md",
    ] {
        assert!(
            out.join(f).metadata().map(|m| m.len() > 0).unwrap_or(false),
            "{f} missing"
        );
    }
    let id = std::fs::read_to_string(out.join("identified.csv")).unwrap();
    assert!(id.lines().next().unwrap().contains("true_mm"));
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(
        report.contains("| μ0 for Table 2 (mm) | 0.285 | 0.2853 |"),
        "{report}"
    );
    let png = std::fs::read(out.join("fig3.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
}

#[test]
fn design_poses_writes_a_usable_pose_list_that_beats_the_pattern() {
    let t = TempDir::new().unwrap();
    let out = t.path().join("poses.toml");
    let o = bin()
        .args(["design-poses", "--trials", "100", "--config"])
        .arg(paper_config())
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.contains("[poses]"));
    assert_eq!(text.matches("    [").count(), 51);
    // The index of the design is at least that of the default pattern.
    let stdout = String::from_utf8_lossy(&o.stdout);
    let value = |label: &str| -> f64 {
        let line = stdout.lines().find(|l| l.starts_with(label)).unwrap();
        line.split_whitespace()
            .rev()
            .nth(2)
            .unwrap()
            .parse()
            .unwrap()
    };
    assert!(value("designed") >= value("config poses"), "{stdout}");
    // The file is a valid config on its own.
    bin()
        .args(["identifiability", "--config"])
        .arg(&out)
        .assert()
        .success()
        .stdout(predicate::str::contains("51 poses"));
    let before = files_in(t.path());
    let o = bin()
        .args(["design-poses", "--count", "1", "--config"])
        .arg(paper_config())
        .arg("--out")
        .arg(t.path().join("x.toml"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(files_in(t.path()), before);
}

#[test]
fn sweep_volumetric_accuracy_feeds_the_decision() {
    let t = TempDir::new().unwrap();
    let cfg = write(
        t.path(),
        "v.toml",
        "[sweep]\nencoder_arcsec = [1.0]\nscale_um = [0.1]\ntrials = 40\nvolumetric = true\nvolumetric_grid_step = 100.0\n[decision]\nmetric = \"dv_after_max_p95\"\nthreshold = 0.5\n",
    );
    let out = t.path().join("o");
    bin()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let mut r = csv::Reader::from_path(out.join("summary.csv")).unwrap();
    let h = r.headers().unwrap().clone();
    let rec = r.records().next().unwrap().unwrap();
    let col = |name: &str| -> f64 {
        rec[h.iter().position(|c| c == name).unwrap()]
            .parse()
            .unwrap()
    };
    let (after, before) = (col("dv_after_max_p95"), col("dv_before_max_median"));
    assert!(
        after > 0.0 && after < before,
        "after {after} before {before}"
    );
    assert_eq!(
        &rec[h.iter().position(|c| c == "meets_target").unwrap()],
        "true"
    );
    // A dV metric without the volumetric option is bad input.
    let bad = write(
        t.path(),
        "b.toml",
        "[decision]\nmetric = \"dv_after_max_p95\"\n",
    );
    let o = bin()
        .args(["sweep", "--config"])
        .arg(&bad)
        .arg("--out")
        .arg(t.path().join("x"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("sweep.volumetric"));
}

#[test]
fn second_class_errors_bias_the_identification() {
    // Exact readings: without second-class errors the full-rank layout is
    // identified exactly; a 0.05° guide twist that the model ignores biases it.
    let t = TempDir::new().unwrap();
    let mu_of = |extra: &str, name: &str| -> f64 {
        let cfg = write(t.path(), name, &format!("{FULL_RANK_TOML}{extra}"));
        let r = t.path().join(format!("{name}.csv"));
        bin()
            .args(["simulate", "--noise-free", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(&r)
            .assert()
            .success();
        let out = t.path().join(format!("{name}-id"));
        bin()
            .args(["identify", "--config"])
            .arg(&cfg)
            .arg("--readings")
            .arg(&r)
            .arg("--out")
            .arg(&out)
            .assert()
            .success();
        let truth = [
            0.2, 0.1, 0.2, 0.2, 0.27, 0.2, 0.25, -0.2, -0.25, 0.25, -0.31, 0.2, 0.45, 0.7, 0.5,
        ];
        identified(&out.join("identified.csv"))
            .iter()
            .zip(truth)
            .map(|(e, t)| (e.1 - t).abs())
            .sum::<f64>()
            / 15.0
    };
    let clean = mu_of("", "clean.toml");
    let biased = mu_of("[second_class]\nguide_twist_deg = 0.05\n", "twist.toml");
    assert!(clean < 1e-7, "{clean}");
    assert!(biased > 1e-3, "{biased}");
    let d = t.path().join("bad");
    std::fs::create_dir(&d).unwrap();
    let bad = write(&d, "b.toml", "[second_class]\nguide_twist_deg = 30.0\n");
    bad_input(
        &[
            "simulate",
            "--config",
            bad.to_str().unwrap(),
            "--out",
            d.join("r.csv").to_str().unwrap(),
        ],
        &["second_class.guide_twist_deg"],
        &d,
    );
}

#[test]
fn shards_merge_to_the_bytes_of_a_single_run() {
    let t = TempDir::new().unwrap();
    // 36000 trials = 5 blocks of 8192 (the last partial) over 4 shards.
    let cfg = write(t.path(), "s.toml", "[sweep]\nencoder_arcsec = [1.0, 4.0]\nscale_um = [0.5]\ntrials = 36000\nseed = 9\nmethods = [\"ols\", \"wls\"]\n");
    let single = t.path().join("single");
    bin()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&single)
        .assert()
        .success();
    let mut shard_dirs = Vec::new();
    for k in 1..=4 {
        let d = t.path().join(format!("s{k}"));
        bin()
            .args([
                "sweep",
                "--threads",
                "1",
                "--shard",
                &format!("{k}/4"),
                "--config",
            ])
            .arg(&cfg)
            .arg("--out")
            .arg(&d)
            .assert()
            .success();
        shard_dirs.push(d);
    }
    let merged = t.path().join("merged");
    bin()
        .arg("merge")
        .args(&shard_dirs)
        .arg("--out")
        .arg(&merged)
        .assert()
        .success();
    for f in [
        "summary.csv",
        "trials.csv",
        "parameters.csv",
        "decision.csv",
        "fig4.svg",
    ] {
        assert!(
            std::fs::read(single.join(f)).unwrap() == std::fs::read(merged.join(f)).unwrap(),
            "{f} differs"
        );
    }
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(merged.join("manifest.json")).unwrap()).unwrap();
    assert_eq!(m["shards"].as_array().unwrap().len(), 4);
    // Refusals: missing, duplicated, and foreign shards; nothing written.
    let bad_out = t.path().join("bad");
    let run = |dirs: &[&PathBuf], needle: &str| {
        let o = bin()
            .arg("merge")
            .args(dirs)
            .arg("--out")
            .arg(&bad_out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(needle), "'{needle}' not in {err}");
        assert!(!bad_out.exists());
    };
    run(
        &[&shard_dirs[0], &shard_dirs[1], &shard_dirs[3]],
        "shard 3/4 is missing",
    );
    run(
        &[
            &shard_dirs[0],
            &shard_dirs[1],
            &shard_dirs[1],
            &shard_dirs[3],
        ],
        "appears twice",
    );
    let other = t.path().join("other");
    bin()
        .args(["sweep", "--seed", "10", "--shard", "3/4", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&other)
        .assert()
        .success();
    run(
        &[&shard_dirs[0], &shard_dirs[1], &other, &shard_dirs[3]],
        "different configs or seeds",
    );
    // --resume skips a complete shard.
    bin()
        .args(["sweep", "--resume", "--shard", "2/4", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&shard_dirs[1])
        .assert()
        .success()
        .stdout(predicate::str::contains("already complete"));
    bad_input(
        &[
            "sweep",
            "--shard",
            "5/4",
            "--out",
            t.path().join("x").to_str().unwrap(),
        ],
        &["--shard"],
        t.path(),
    );
}

#[test]
fn adaptive_stopping_meets_its_target_deterministically() {
    let t = TempDir::new().unwrap();
    let cfg = write(t.path(), "a.toml", "[sweep]\nencoder_arcsec = [1.0, 4.0]\ntrials = 100000\nseed = 2\n[decision]\nmetric = \"mu_mean\"\nthreshold = 0.1\n");
    let a = t.path().join("a");
    let b = t.path().join("b");
    for (d, th) in [(&a, "2"), (&b, "1")] {
        bin()
            .args([
                "sweep",
                "--no-trials",
                "--target-ci",
                "0.01",
                "--max-trials",
                "100000",
                "--threads",
                th,
                "--config",
            ])
            .arg(&cfg)
            .arg("--out")
            .arg(d)
            .assert()
            .success()
            .stdout(predicate::str::contains("met for every grade"));
    }
    assert_eq!(
        std::fs::read(a.join("summary.csv")).unwrap(),
        std::fs::read(b.join("summary.csv")).unwrap()
    );
    let mut r = csv::Reader::from_path(a.join("summary.csv")).unwrap();
    let h = r.headers().unwrap().clone();
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.join("manifest.json")).unwrap()).unwrap();
    let used = m["adaptive"]["trials_used"].as_u64().unwrap();
    assert!(used < 100000 && used.is_multiple_of(8192), "{used}");
    for rec in r.records() {
        let rec = rec.unwrap();
        let rel: f64 = rec[h.iter().position(|c| c == "mu_mean_ci_rel").unwrap()]
            .parse()
            .unwrap();
        assert!(rel <= 0.01, "{rel}");
        let n: u64 = rec[h.iter().position(|c| c == "trials").unwrap()]
            .parse()
            .unwrap();
        assert_eq!(n, used);
    }
}

/// Every file under a final name in `dir` is complete (temporary files start with '.').
fn assert_no_partial_files(dir: &Path, trials: usize, grades: usize) {
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

#[test]
fn sigkill_at_any_moment_leaves_no_half_written_file_and_resume_gives_the_same_bytes() {
    let t = TempDir::new().unwrap();
    let cfg = write(
        t.path(),
        "k.toml",
        "[sweep]\nencoder_arcsec = [1.0, 4.0]\ntrials = 60000\nseed = 4\n",
    );
    let clean = t.path().join("clean");
    bin()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&clean)
        .assert()
        .success();
    for (i, delay_ms) in [5u64, 40, 120, 250, 400, 700, 1000].iter().enumerate() {
        let dir = t.path().join(format!("k{i}"));
        let mut child = std::process::Command::new(assert_cmd::cargo::cargo_bin("tricept-calib"))
            .args(["sweep", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(&dir)
            .stdout(std::process::Stdio::null())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(*delay_ms));
        let _ = child.kill(); // SIGKILL
        let _ = child.wait();
        if dir.exists() {
            assert_no_partial_files(&dir, 60000, 2);
        }
        // --resume continues from the last complete block: same final bytes.
        bin()
            .args(["sweep", "--resume", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(&dir)
            .assert()
            .success();
        for f in ["summary.csv", "trials.csv", "parameters.csv"] {
            assert!(
                std::fs::read(clean.join(f)).unwrap() == std::fs::read(dir.join(f)).unwrap(),
                "kill at {delay_ms} ms: {f} differs after --resume"
            );
        }
        assert!(!dir.join(".sweep-state").exists());
    }
    // A killed shard, rerun with --resume, merges to the bytes of the clean run.
    let shard = |k: u32, dir: &Path| {
        bin()
            .args([
                "sweep",
                "--resume",
                "--shard",
                &format!("{k}/3"),
                "--config",
            ])
            .arg(&cfg)
            .arg("--out")
            .arg(dir)
            .assert()
            .success();
    };
    let dirs: Vec<PathBuf> = (1..=3).map(|k| t.path().join(format!("sh{k}"))).collect();
    shard(1, &dirs[0]);
    let mut child = std::process::Command::new(assert_cmd::cargo::cargo_bin("tricept-calib"))
        .args(["sweep", "--shard", "2/3", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&dirs[1])
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(30));
    let _ = child.kill();
    let _ = child.wait();
    for (k, d) in dirs.iter().enumerate() {
        shard(k as u32 + 1, d);
    }
    let merged = t.path().join("merged");
    bin()
        .arg("merge")
        .args(&dirs)
        .arg("--out")
        .arg(&merged)
        .assert()
        .success();
    for f in ["summary.csv", "trials.csv"] {
        assert!(
            std::fs::read(clean.join(f)).unwrap() == std::fs::read(merged.join(f)).unwrap(),
            "{f} differs"
        );
    }
}

#[test]
fn full_device_is_exit_1_naming_the_path() {
    // Needs permission to mount a tmpfs; elsewhere the read-only case above covers exit 1.
    let t = TempDir::new().unwrap();
    let mnt = t.path().join("tiny");
    std::fs::create_dir(&mnt).unwrap();
    let ok = std::process::Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=64k", "tmpfs"])
        .arg(&mnt)
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    if !ok {
        skipped(
            "full_device_is_exit_1_naming_the_path",
            "cannot mount a tmpfs here",
        );
        return;
    }
    let out = mnt.join("sw");
    let o = bin()
        .args(["sweep", "--trials", "3000", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let _ = std::process::Command::new("umount").arg(&mnt).status();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("sw/trials.csv") && err.contains("No space left"),
        "{err}"
    );
}

#[test]
fn iterated_wls_runs_in_identify_and_sweep() {
    let t = TempDir::new().unwrap();
    let cfg = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/wls-gn.toml");
    let r = t.path().join("r.csv");
    bin()
        .args(["simulate", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&r)
        .assert()
        .success();
    bin()
        .args(["identify", "--config"])
        .arg(&cfg)
        .arg("--readings")
        .arg(&r)
        .arg("--out")
        .arg(t.path().join("id"))
        .assert()
        .success()
        .stdout(predicate::str::contains("method wls"));
    let out = t.path().join("sw");
    bin()
        .args(["sweep", "--trials", "20", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert!(summary.lines().next().unwrap().contains("not_converged"));
    assert_eq!(summary.lines().count(), 1 + 2 * 2);
    for f in ["parameters.png", "fig4.png", "fig4.svg"] {
        assert!(out.join(f).exists(), "{f}");
    }
}
