//! The binary end to end (docs/method.md §10): simulate, identify, compensate,
//! identifiability, reproduce, design-poses — files, exit codes, messages.

mod common;

use common::*;
use predicates::prelude::*;
use std::path::Path;
use tempfile::TempDir;

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
    assert_every_png_has_its_svg(&comp);
    let vol = std::fs::read_to_string(comp.join("volumetric.csv")).unwrap();
    assert!(vol.starts_with("x_mm,y_mm,z_mm,before_mm,after_mm\n"));
    assert_eq!(vol.lines().count(), 1258);
    let cmds = std::fs::read_to_string(comp.join("commands.csv")).unwrap();
    assert!(cmds.starts_with("x_mm,y_mm,z_mm,q1_mm,q2_mm,q3_mm\n"));
    assert_eq!(cmds.lines().count(), 3);
}

/// `simulate` says which sensors made the readings: a datasheet axis by its
/// grade ±a, the others by the paper's reading of their grade.
#[test]
fn simulate_names_the_sensors_it_read_with() {
    let t = TempDir::new().unwrap();
    let cfg = write(
        t.path(),
        "d.toml",
        "[errors]\ndq1 = 0.1\n[sensors]\nencoder_arcsec = 1.5\nscale_um = 1.0\nsamples = 2\n\
         [sensors.encoder_psi]\naccuracy_arcsec = 2.5\n\
         [sensors.scale]\naccuracy_um = 0.7\n",
    );
    let r = t.path().join("r.csv");
    for (config, want) in [
        (
            cfg,
            "psi4 encoder datasheet ±2.5″, theta4 encoder 1.5″, \
             scale datasheet ±0.7 µm, mean of 2 samples, seed 3",
        ),
        (
            paper(),
            "encoder 0.8″, scale 0.5 µm, mean of 3 samples, seed 3",
        ),
    ] {
        bin()
            .args(["simulate", "--config"])
            .arg(&config)
            .args(["--seed", "3", "--out"])
            .arg(&r)
            .assert()
            .success()
            .stdout(predicate::str::contains(want));
    }
}

#[test]
fn noisy_identify_flags_dya3_in_paper_layout() {
    let t = TempDir::new().unwrap();
    let readings = t.path().join("r.csv");
    bin()
        .args(["simulate", "--config"])
        .arg(paper())
        .args(["--seed", "7", "--out"])
        .arg(&readings)
        .assert()
        .success();
    let out = t.path().join("id");
    bin()
        .args(["identify", "--config"])
        .arg(paper())
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
        .arg(paper())
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
        .arg(paper())
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
    let cfg = paper();
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
    let cfg = paper();
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
        .arg(paper())
        .assert()
        .success();
    let o = bin()
        .args(["simulate", "--config"])
        .arg(paper())
        .arg("--out")
        .arg(target.join("r.csv"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains(&target.display().to_string()));
    let o = bin()
        .args(["sweep", "--trials", "10", "--config"])
        .arg(paper())
        .arg("--out")
        .arg(&target)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains(&target.display().to_string()));
}

#[test]
fn reproduce_writes_every_artifact() {
    let t = TempDir::new().unwrap();
    let cfg = std::fs::read_to_string(paper())
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
    assert_every_png_has_its_svg(&out);
    // Fig. 4 per pose count: 5, 9, 17 and all 51 poses at every grade; on
    // the same noise draws fewer poses leave a larger μ at every grade.
    let mut r = csv::Reader::from_path(out.join("fig4_poses.csv")).unwrap();
    let rows: Vec<(usize, f64, f64)> = r
        .records()
        .map(|x| {
            let x = x.unwrap();
            (
                x[0].parse().unwrap(),
                x[1].parse().unwrap(),
                x[3].parse().unwrap(),
            )
        })
        .collect();
    assert_eq!(rows.len(), 4 * 12);
    for grade in [0.5, 4.0, 8.0] {
        let mu = |n: usize| rows.iter().find(|r| r.0 == n && r.1 == grade).unwrap().2;
        assert!(
            mu(5) > mu(9) && mu(9) > mu(17) && mu(17) > mu(51),
            "{grade}"
        );
    }
    assert!(out.join("fig4_poses.png").is_file());
    assert!(report.contains("## Fig. 4 per pose count"), "{report}");
    assert!(report.contains("The paper chose 2″."), "{report}");
}

#[test]
fn design_poses_writes_a_usable_pose_list_that_beats_the_pattern() {
    let t = TempDir::new().unwrap();
    let out = t.path().join("poses.toml");
    let o = bin()
        .args(["design-poses", "--trials", "100", "--config"])
        .arg(paper())
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
        .arg(paper())
        .arg("--out")
        .arg(t.path().join("x.toml"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(files_in(t.path()), before);
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
