//! Accuracy over the workspace (SPEC §12, issue #11): the workspace grid
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
