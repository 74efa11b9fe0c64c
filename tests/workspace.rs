//! Accuracy over the workspace (docs/method.md §12, issue #11): the workspace grid
//! and ISO 9283 pose accuracy of `compensate`, checked against the map of
//! one plane computed by the other route.

use assert_cmd::Command;
use std::path::{Path, PathBuf};
use tempfile::TempDir;

fn bin() -> Command {
    Command::cargo_bin("tricept-calib").unwrap()
}

fn paper() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/paper.toml")
}

fn table(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| l.split(',').map(String::from).collect())
        .collect()
}

fn identified(dir: &Path) -> PathBuf {
    let r = dir.join("r.csv");
    bin()
        .args(["simulate", "--config"])
        .arg(paper())
        .arg("--out")
        .arg(&r)
        .assert()
        .success();
    let id = dir.join("id");
    bin()
        .args(["identify", "--config"])
        .arg(paper())
        .arg("--readings")
        .arg(&r)
        .arg("--out")
        .arg(&id)
        .assert()
        .success();
    id.join("identified.csv")
}

#[test]
fn one_layer_of_the_workspace_is_the_mid_plane_map() {
    let t = TempDir::new().unwrap();
    let ident = identified(t.path());
    let text = std::fs::read_to_string(paper()).unwrap();
    let one = t.path().join("one.toml");
    std::fs::write(
        &one,
        text.replace("grid_step = 20.0", "grid_step = 20.0\nlayers = 1"),
    )
    .unwrap();
    let out = t.path().join("c");
    bin()
        .args(["compensate", "--config"])
        .arg(&one)
        .arg("--identified")
        .arg(&ident)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let ws = table(&out.join("workspace_accuracy.csv"));
    assert_eq!(ws[0], ["stage", "max_mm", "p95_mm", "mean_mm", "points"]);
    let plane = table(&out.join("volumetric_summary.csv"));
    assert_eq!(plane[0], ["stage", "max_mm", "min_mm", "mean_mm"]);
    for (w, p) in ws[1..].iter().zip(&plane[1..]) {
        assert_eq!(w[0], p[0]);
        let f = |s: &str| s.parse::<f64>().unwrap();
        assert!((f(&w[1]) - f(&p[1])).abs() < 1e-12, "max {w:?} vs {p:?}");
        assert!((f(&w[3]) - f(&p[3])).abs() < 1e-12, "mean {w:?} vs {p:?}");
        assert_eq!(w[4], "1257");
        // p95 from the per-point map, sorted here (type 7).
        let map = table(&out.join("volumetric.csv"));
        let col = if w[0] == "before" { 3 } else { 4 };
        let mut v: Vec<f64> = map[1..].iter().map(|r| f(&r[col])).collect();
        v.sort_by(f64::total_cmp);
        let h = (v.len() - 1) as f64 * 0.95;
        let (lo, w8) = (h.floor() as usize, h - h.floor());
        let p95 = v[lo] + w8 * (v[lo + 1] - v[lo]);
        assert!((f(&w[2]) - p95).abs() < 1e-12);
    }
    // ISO 9283: P1 is the centre of the mid-plane, a grid point of the map.
    let iso = table(&out.join("iso9283.csv"));
    assert_eq!(
        iso[0],
        [
            "position",
            "x_mm",
            "y_mm",
            "z_mm",
            "ap_before_mm",
            "ap_after_mm"
        ]
    );
    assert_eq!(iso.len(), 6);
    let map = table(&out.join("volumetric.csv"));
    let centre = map.iter().find(|r| r[0] == "0.0" && r[1] == "0.0").unwrap();
    assert_eq!(iso[1][4], centre[3]);
    assert_eq!(iso[1][5], centre[4]);
}

#[test]
fn five_layers_span_the_workspace_and_after_beats_before() {
    let t = TempDir::new().unwrap();
    let ident = identified(t.path());
    let out = t.path().join("c");
    bin()
        .args(["compensate", "--config"])
        .arg(paper())
        .arg("--identified")
        .arg(&ident)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let ws = table(&out.join("workspace_accuracy.csv"));
    assert_eq!(ws[1][4], (5 * 1257).to_string());
    let f = |s: &str| s.parse::<f64>().unwrap();
    let (before_max, after_max) = (f(&ws[1][1]), f(&ws[2][1]));
    assert!(after_max < 0.25 * before_max, "{ws:?}");
    // The workspace is worse than its mid-plane: the mid-plane's max is not the workspace's.
    let plane = table(&out.join("volumetric_summary.csv"));
    assert!(f(&ws[1][1]) >= f(&plane[1][1]));
    let iso = table(&out.join("iso9283.csv"));
    for row in &iso[1..] {
        assert!(f(&row[5]) < f(&row[4]), "{row:?}");
    }
    assert!(out.join("workspace_layers.png").exists());
}

fn summary(dir: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let mut r = csv::Reader::from_path(dir.join("summary.csv")).unwrap();
    let h = r.headers().unwrap().clone();
    r.records()
        .map(|rec| {
            h.iter()
                .zip(rec.unwrap().iter())
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .collect()
        })
        .collect()
}

#[test]
fn the_sweep_decides_on_the_workspace_and_first_order_matches_exact() {
    let t = TempDir::new().unwrap();
    let base = "[sweep]\nencoder_arcsec = [1.0, 8.0]\ntrials = 60\nseed = 3\nvolumetric = true\n[decision]\nmetric = \"dv_after_p95_p95_ci_high\"\nthreshold = 0.3\n";
    let fast = t.path().join("fast.toml");
    std::fs::write(&fast, base).unwrap();
    let exact = t.path().join("exact.toml");
    std::fs::write(
        &exact,
        base.replace(
            "volumetric = true",
            "volumetric = true\nvolumetric_exact = true",
        ),
    )
    .unwrap();
    let (a, b) = (t.path().join("a"), t.path().join("b"));
    for (cfg, out) in [(&fast, &a), (&exact, &b)] {
        bin()
            .args(["sweep", "--config"])
            .arg(cfg)
            .arg("--out")
            .arg(out)
            .assert()
            .success();
    }
    let (sa, sb) = (summary(&a), summary(&b));
    let f = |s: &str| s.parse::<f64>().unwrap();
    for (ra, rb) in sa.iter().zip(&sb) {
        for col in [
            "dv_after_max_median",
            "dv_after_max_p95",
            "dv_after_p95_p95",
            "dv_after_mean_mean",
            "ap_after_max_p95",
            "dv_before_max_median",
        ] {
            let (x, y) = (f(&ra[col]), f(&rb[col]));
            // The stated bound of first-order propagation: 1 µm + 1 %.
            assert!(
                (x - y).abs() <= 1e-3 + 0.01 * y,
                "{col}: first-order {x} vs exact {y}"
            );
        }
        assert!(f(&ra["dv_after_p95_p95_ci_high"]) >= f(&ra["dv_after_p95_p95"]));
        assert_eq!(ra["dv_failed"], "0");
        let meets = f(&ra["dv_after_p95_p95_ci_high"]) <= 0.3;
        assert_eq!(ra["meets_target"], meets.to_string());
    }
    let decision = std::fs::read_to_string(a.join("decision.csv")).unwrap();
    assert!(decision.contains("dv_after_p95_p95_ci_high"), "{decision}");
    // Per-trial rows carry the workspace metrics.
    let trials = std::fs::read_to_string(a.join("trials.csv")).unwrap();
    assert!(trials
        .lines()
        .next()
        .unwrap()
        .contains("dv_after_p95_mm,ap_after_max_mm,pose_count"));
}

#[test]
fn adaptive_stopping_checks_the_deciding_workspace_metric() {
    let t = TempDir::new().unwrap();
    let cfg = t.path().join("a.toml");
    std::fs::write(
        &cfg,
        "[sweep]\nencoder_arcsec = [2.0]\ntrials = 100000\nseed = 5\nvolumetric = true\n[decision]\nmetric = \"ap_after_max_p95\"\nthreshold = 1.0\n",
    )
    .unwrap();
    let out = t.path().join("o");
    bin()
        .args([
            "sweep",
            "--no-trials",
            "--target-ci",
            "0.02",
            "--max-trials",
            "40000",
            "--config",
        ])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let s = summary(&out);
    let f = |s: &str| s.parse::<f64>().unwrap();
    let (q, hi) = (
        f(&s[0]["ap_after_max_p95"]),
        f(&s[0]["ap_after_max_p95_ci_high"]),
    );
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    if m["adaptive"]["target_met"].as_bool().unwrap() {
        // Met: the CI of the deciding quantile is within 2 % (its upper half
        // at most twice the half-width).
        assert!((hi - q) / q <= 2.0 * 0.02 + 1e-12, "q {q} hi {hi}");
    } else {
        assert_eq!(m["adaptive"]["trials_used"], 40000);
    }
}
