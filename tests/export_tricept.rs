//! `export --format json` for the Tricept: geometry.json holds the
//! identified joints (the config's nominal ones plus identified.csv's
//! errors under the frame definitions, recomputed here by hand), every
//! error as identified.csv states it, correlations from identify's
//! covariance and its checks; a fit whose checks failed is refused unless
//! accepted; `--format linuxcnc` is the hexapod's and refused in one
//! sentence.

mod common;

use common::bin;
use std::path::Path;

fn paper() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/paper.toml")
}

#[test]
fn the_tricept_geometry_json_is_identify_s_fit() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    bin()
        .args(["simulate", "--config"])
        .arg(paper())
        .arg("--out")
        .arg(d.join("r.csv"))
        .assert()
        .success();
    bin()
        .args(["identify", "--config"])
        .arg(paper())
        .arg("--readings")
        .arg(d.join("r.csv"))
        .arg("--out")
        .arg(d.join("id"))
        .assert()
        .success();
    let export = |out: &str, extra: &[&str]| {
        let mut c = bin();
        c.args(["export", "--format", "json", "--config"])
            .arg(paper())
            .arg("--identified")
            .arg(d.join("id/identified.csv"))
            .arg("--out")
            .arg(d.join(out))
            .args(extra);
        c.assert()
    };
    export("ex", &[]).success();
    let g: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("ex/geometry.json")).unwrap())
            .unwrap();
    assert_eq!(g["mechanism"], "tricept");
    // identified.csv's estimates, by name.
    let csv = std::fs::read_to_string(d.join("id/identified.csv")).unwrap();
    let est = |name: &str| -> f64 {
        csv.lines()
            .find(|l| l.split(',').next() == Some(name))
            .and_then(|l| l.split(',').nth(1))
            .unwrap()
            .parse()
            .unwrap()
    };
    for e in g["errors"].as_array().unwrap() {
        let name = e["name"].as_str().unwrap();
        // serde_json reads floats to within an ulp or two.
        let got = e["estimate"].as_f64().unwrap();
        assert!(
            (got - est(name)).abs() <= 1e-15 * est(name).abs().max(1e-300),
            "{name}: {got}"
        );
        // Its source in identified.csv's words.
        let source = csv
            .lines()
            .find(|l| l.split(',').next() == Some(name))
            .and_then(|l| l.split(',').nth(4))
            .unwrap();
        assert_eq!(e["source"], source, "{name}");
    }
    let sources: Vec<&str> = g["errors"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|e| e["source"].as_str())
        .collect();
    assert!(
        sources.contains(&"readings") && sources.contains(&"unidentifiable"),
        "{sources:?}"
    );
    // The paper's geometry: b = 288.7 at −60°, 60°, 180°; a = 100 likewise.
    // B1 moves by (dxB1, dyB1, 0), B2 by (dxB1, dyB2, 0), B3 by all three;
    // A_i by (dxAi, dyAi, 0) in the platform frame.
    let text = std::fs::read_to_string(paper()).unwrap();
    let num = |key: &str| -> f64 {
        text.lines()
            .find(|l| l.trim_start().starts_with(&format!("{key} =")))
            .and_then(|l| l.split('=').nth(1))
            .and_then(|v| v.split('#').next())
            .unwrap()
            .trim()
            .parse()
            .unwrap()
    };
    let (a, b) = (num("a"), num("b"));
    let at = |r: f64, deg: f64| [r * deg.to_radians().cos(), r * deg.to_radians().sin()];
    let want_base = [
        [
            at(b, -60.0)[0] + est("dxB1"),
            at(b, -60.0)[1] + est("dyB1"),
            0.0,
        ],
        [
            at(b, 60.0)[0] + est("dxB1"),
            at(b, 60.0)[1] + est("dyB2"),
            0.0,
        ],
        [
            at(b, 180.0)[0] + est("dxB3"),
            at(b, 180.0)[1] + est("dyB3"),
            est("dzB3"),
        ],
    ];
    let pa = [
        ("dxA1", "dyA1", -60.0),
        ("dxA2", "dyA2", 60.0),
        ("dxA3", "dyA3", 180.0),
    ];
    for (i, limb) in g["limbs"].as_array().unwrap().iter().enumerate() {
        for k in 0..3 {
            let got = limb["base_identified_mm"][k].as_f64().unwrap();
            assert!(
                (got - want_base[i][k]).abs() < 1e-9,
                "B{} {k}: {got}",
                i + 1
            );
        }
        let (x, y, deg) = pa[i];
        let want = [at(a, deg)[0] + est(x), at(a, deg)[1] + est(y), 0.0];
        for k in 0..3 {
            let got = limb["platform_identified_mm"][k].as_f64().unwrap();
            assert!((got - want[k]).abs() < 1e-9, "A{} {k}: {got}", i + 1);
        }
        let dq = est(&format!("dq{}", i + 1));
        assert!((limb["length_offset_mm"].as_f64().unwrap() - dq).abs() < 1e-15);
    }
    // Correlations: symmetric, 1 on the diagonal of every identifiable
    // error, within [−1, 1]; checks as identify wrote them.
    let fit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("id/identifiability.json")).unwrap())
            .unwrap();
    assert_eq!(g["checks"], fit["checks"]);
    let m = g["correlations"]["matrix"].as_array().unwrap();
    let names = g["correlations"]["names"].as_array().unwrap();
    assert_eq!(m.len(), names.len());
    let cov = &fit["covariance"]["matrix"];
    for i in 0..m.len() {
        for j in 0..m.len() {
            let (r, s) = (&m[i][j], &m[j][i]);
            assert_eq!(r, s);
            if let Some(r) = r.as_f64() {
                assert!((-1.0..=1.0).contains(&r));
                let c = cov[i][j].as_f64().unwrap()
                    / (cov[i][i].as_f64().unwrap() * cov[j][j].as_f64().unwrap()).sqrt();
                assert!((r - c).abs() < 1e-12, "{r} {c}");
            }
        }
        if cov[i][i].as_f64().unwrap() > 0.0 {
            assert_eq!(m[i][i].as_f64(), Some(1.0), "{}", names[i]);
        }
    }
    // A fit identify's checks rejected: refused, then accepted.
    let mut bad = fit.clone();
    bad["checks"]["misfit"]["rejected"] = serde_json::json!(true);
    std::fs::write(
        d.join("id/identifiability.json"),
        serde_json::to_string(&bad).unwrap(),
    )
    .unwrap();
    let out = export("ex-bad", &[]).code(2);
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        err.contains("identified.csv") && err.contains("--accept-rejected-fit"),
        "{err}"
    );
    assert!(!d.join("ex-bad/geometry.json").exists());
    export("ex-ok", &["--accept-rejected-fit"]).success();
    // LinuxCNC has no Tricept kinematics: refused naming the format.
    let out = bin()
        .args(["export", "--format", "linuxcnc", "--config"])
        .arg(paper())
        .arg("--identified")
        .arg(d.join("id/identified.csv"))
        .arg("--out")
        .arg(d.join("cnc"))
        .assert()
        .code(2);
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(err.contains("--format json"), "{err}");
}
