//! The buyer's answer (issue #10): a catalogue of sensor products, pose
//! counts, the error budget, the confidence rule and the price ranking.

mod common;
use common::{bad_input, bin, write};
use std::path::Path;

fn catalogue() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("configs/sensors.toml")
        .display()
        .to_string()
}

/// A small catalogue study: two encoders, two scales, two pose counts.
fn study(dir: &Path, threshold: f64) -> std::path::PathBuf {
    write(
        dir,
        "study.toml",
        &format!(
            r#"
[identification]
method = "wls"
[sweep]
catalogue = "{}"
encoders = ["angle-1as-d200", "angle-5as-d60"]
scales = ["lin-0p5um-sp4", "lin-5um-sp20"]
pose_counts = [9, 51]
methods = ["wls"]
trials = 400
volumetric = true
[decision]
metric = "dv_after_p95_p95"
confidence = "upper95"
threshold = {threshold}
"#,
            catalogue()
        ),
    )
}

fn rows(path: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let h = r.headers().unwrap().clone();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            h.iter()
                .zip(rec.iter())
                .map(|(a, b)| (a.to_string(), b.to_string()))
                .collect()
        })
        .collect()
}

fn f(s: &str) -> f64 {
    s.parse().unwrap()
}

#[test]
fn a_catalogue_study_ranks_every_combination_by_price_and_budgets_its_error() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = study(dir.path(), 0.5);
    let out = dir.path().join("out");
    let run = bin()
        .args([
            "sweep",
            "--config",
            cfg.to_str().unwrap(),
            "--no-trials",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    for f in [
        "decision.csv",
        "budget.csv",
        "budget.png",
        "price_accuracy.png",
        "price_accuracy.svg",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // 2 encoders × 2 scales × 2 pose counts, ranked 1…8.
    let d = rows(&out.join("decision.csv"));
    assert_eq!(d.len(), 8);
    for (i, r) in d.iter().enumerate() {
        assert_eq!(r["rank"], (i + 1).to_string());
        // Price: two encoders and a scale, from the catalogue's prices.
        let enc = if r["encoder"] == "angle-1as-d200" {
            6000.0
        } else {
            1500.0
        };
        let sc = if r["scale"] == "lin-0p5um-sp4" {
            4500.0
        } else {
            700.0
        };
        assert_eq!(f(&r["price"]), 2.0 * enc + sc);
        // Feasible means the upper confidence limit meets the threshold.
        assert_eq!(
            r["feasible"] == "true",
            f(&r["upper_limit"]) <= 0.5,
            "{r:?}"
        );
        assert!(f(&r["upper_limit"]) >= f(&r["value"]));
    }
    // Feasible first, by price then pose count; the first feasible is chosen.
    let feasible: Vec<_> = d.iter().take_while(|r| r["feasible"] == "true").collect();
    assert!(d[feasible.len()..].iter().all(|r| r["feasible"] == "false"));
    for w in feasible.windows(2) {
        let (a, b) = (f(&w[0]["price"]), f(&w[1]["price"]));
        assert!(a < b || (a == b && f(&w[0]["pose_count"]) <= f(&w[1]["pose_count"])));
    }
    assert_eq!(d[0]["chosen"] == "true", !feasible.is_empty());
    assert!(stdout.contains("answer: "), "{stdout}");
    if let Some(c) = feasible.first() {
        assert!(
            stdout.contains(&format!(
                "Buy 2 × {} encoders and one {} scale",
                c["encoder"], c["scale"]
            )),
            "{stdout}"
        );
    }
    // The budget: floor + shares = mean μ over every calibration (its terms
    // are checked against identification with a perfect sensor in the
    // library's tests).
    let b = rows(&out.join("budget.csv"));
    assert_eq!(b.len(), 8);
    for r in &b {
        let sum = f(&r["floor_mm"])
            + f(&r["psi_encoder_mm"])
            + f(&r["theta_encoder_mm"])
            + f(&r["scale_mm"]);
        assert!(
            (sum - f(&r["total_mm"])).abs() < 1e-12 * f(&r["total_mm"]).max(1.0) + 1e-15,
            "{r:?}"
        );
        assert!(f(&r["floor_mm"]) > 0.0 && f(&r["floor_mm"]) < f(&r["total_mm"]));
        assert_eq!(r["calibrations"], "400");
    }
    // The summary names the products and the pose count.
    let s = rows(&out.join("summary.csv"));
    assert!(s
        .iter()
        .any(|r| r["encoder"] == "angle-5as-d60" && r["pose_count"] == "9"));
    // Every per-combination file tells its rows apart: products, pose count
    // and estimator (with the parameter, for parameters.csv) are a key.
    let key = |r: &std::collections::HashMap<String, String>, extra: &str| {
        let k = ["encoder", "scale", "pose_count", "method", extra];
        k.iter()
            .map(|c| r.get(*c).cloned().unwrap_or_default())
            .collect::<Vec<_>>()
            .join("|")
    };
    for (file, extra, n) in [
        ("parameters.csv", "parameter", 8 * 15),
        ("budget.csv", "", 8),
        ("decision.csv", "", 8),
        ("summary.csv", "", 8),
    ] {
        let r = rows(&out.join(file));
        for c in ["encoder", "scale", "pose_count", "method"] {
            assert!(r.iter().all(|x| !x[c].is_empty()), "{file}: {c} empty");
        }
        let keys: std::collections::HashSet<String> = r.iter().map(|x| key(x, extra)).collect();
        assert_eq!((keys.len(), r.len()), (n, n), "{file}");
    }
    // An error the poses cannot identify has no predicted spread.
    let p = rows(&out.join("parameters.csv"));
    for r in &p {
        assert_eq!(
            r["identifiable"] == "false",
            r["predicted_std_mm"].is_empty(),
            "{r:?}"
        );
    }
}

#[test]
fn an_unreachable_target_is_said_plainly_and_require_target_exits_3() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = study(dir.path(), 1e-4);
    for (flag, code) in [(None, 0), (Some("--require-target"), 3)] {
        let out = dir.path().join(format!("out{code}"));
        let mut cmd = bin();
        cmd.args([
            "sweep",
            "--config",
            cfg.to_str().unwrap(),
            "--no-trials",
            "--trials",
            "60",
            "--out",
        ])
        .arg(&out);
        if let Some(f) = flag {
            cmd.arg(f);
        }
        let run = cmd.output().unwrap();
        assert_eq!(run.status.code(), Some(code));
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(
            stdout.contains(
                "No combination meets the target dV p95 over the workspace, 95 % of machines ≤ 0.0001 mm"
            ),
            "{stdout}"
        );
        let d = rows(&out.join("decision.csv"));
        assert!(d
            .iter()
            .all(|r| r["feasible"] == "false" && r["chosen"] == "false"));
        // The closest comes first.
        for w in d.windows(2) {
            assert!(f(&w[0]["upper_limit"]) <= f(&w[1]["upper_limit"]));
        }
    }
}

/// An upper 95 % limit of a 95th percentile exists only from 59 machines
/// on: a study with fewer is refused before any work, naming the key.
#[test]
fn too_few_machines_for_the_stated_confidence_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = study(dir.path(), 0.5);
    let c = cfg.to_str().unwrap();
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    bad_input(
        &["sweep", "--config", c, "--trials", "58", "--out", o],
        &[
            "--trials = 58",
            "59 machines",
            "upper 95 % confidence limit",
        ],
        dir.path(),
    );
    bad_input(
        &[
            "sweep",
            "--config",
            c,
            "--target-ci",
            "0.05",
            "--max-trials",
            "5",
            "--out",
            o,
        ],
        &["--max-trials = 5", "59 machines"],
        dir.path(),
    );
    // 59 is enough.
    let run = bin()
        .args([
            "sweep",
            "--config",
            c,
            "--trials",
            "59",
            "--no-trials",
            "--out",
            o,
        ])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}

#[test]
fn bad_catalogue_references_name_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "unknown.toml",
            format!(
                "[sweep]\ncatalogue = \"{}\"\nencoders = [\"nope\"]\n",
                catalogue()
            ),
            vec!["sweep.encoders", "\"nope\""],
        ),
        (
            "nocat.toml",
            "[sweep]\nscales = [\"lin-1um-sp4\"]\n".into(),
            vec!["sweep.scales", "sweep.catalogue"],
        ),
        (
            "missing.toml",
            "[sweep]\ncatalogue = \"no-such-catalogue.toml\"\n".into(),
            vec!["sweep.catalogue", "no-such-catalogue.toml"],
        ),
        (
            "counts.toml",
            "[sweep]\npose_counts = [9, 5]\n".into(),
            vec!["sweep.pose_counts", "increasing"],
        ),
        (
            "range.toml",
            "[sweep]\npose_counts = [1, 51]\n".into(),
            vec!["sweep.pose_counts", "between 2 and the 51 poses"],
        ),
        (
            "conf.toml",
            "[decision]\nmetric = \"mu_median\"\nconfidence = \"upper95\"\n".into(),
            vec!["decision.confidence", "mu_median"],
        ),
        (
            "conf2.toml",
            "[decision]\nconfidence = \"sure\"\n".into(),
            vec!["decision.confidence", "\"sure\""],
        ),
        (
            "grades.toml",
            format!(
                "[sweep]\ncatalogue = \"{}\"\nencoder_arcsec = [1.0, 2.0]\n",
                catalogue()
            ),
            vec!["sweep.encoder_arcsec", "catalogue"],
        ),
    ];
    for (name, text, needles) in cases {
        let cfg = write(dir.path(), name, &text);
        bad_input(
            &["sweep", "--config", cfg.to_str().unwrap(), "--out", o],
            &needles,
            dir.path(),
        );
    }
    // A catalogue entry with harmonics summing above 1: the catalogue file,
    // the entry and the key.
    let cat = write(
        dir.path(),
        "cat.toml",
        "[[encoder]]\nname = \"e\"\nprice = 1.0\naccuracy_arcsec = 2.0\nharmonics = [0.8, 0.4]\n[[scale]]\nname = \"s\"\nprice = 1.0\naccuracy_um = 1.0\n",
    );
    let cfg = write(
        dir.path(),
        "h.toml",
        &format!("[sweep]\ncatalogue = \"{}\"\n", cat.display()),
    );
    bad_input(
        &["sweep", "--config", cfg.to_str().unwrap(), "--out", o],
        &["cat.toml", "encoder \"e\".harmonics", "sum to 1.2:"],
        dir.path(),
    );
    // An unknown field of an entry names the catalogue's line.
    let cat = write(
        dir.path(),
        "cat2.toml",
        "[[scale]]\nname = \"s\"\nprice = 1.0\naccuracy_um = 1.0\ncolour = \"red\"\n",
    );
    let cfg = write(
        dir.path(),
        "u.toml",
        &format!("[sweep]\ncatalogue = \"{}\"\n", cat.display()),
    );
    bad_input(
        &["sweep", "--config", cfg.to_str().unwrap(), "--out", o],
        &["cat2.toml line 5", "colour"],
        dir.path(),
    );
}

/// Issue 20 item 4: a study's identity includes its catalogue's content.
/// A finished study whose catalogue was edited is not "complete" for
/// --resume (it runs again with the new prices), and shards run before and
/// after an edit are refused by merge, naming the catalogue.
#[test]
fn an_edited_catalogue_is_another_study() {
    let dir = tempfile::tempdir().unwrap();
    let cat = |price: f64| {
        write(
            dir.path(),
            "cat.toml",
            &format!("[[encoder]]\nname = \"e\"\nprice = {price}\naccuracy_arcsec = 2.0\n[[scale]]\nname = \"s\"\nprice = 50.0\naccuracy_um = 1.0\n"),
        )
    };
    cat(100.0);
    let cfg = write(
        dir.path(),
        "c.toml",
        "[sweep]\ncatalogue = \"cat.toml\"\ntrials = 8300\n",
    );
    let c = cfg.to_str().unwrap();
    let run = |args: &[&str]| {
        let o = bin().args(args).output().unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr),
        )
    };
    let out = dir.path().join("out");
    let o = out.to_str().unwrap();
    let (code, _) = run(&["sweep", "--config", c, "--no-trials", "--out", o]);
    assert_eq!(code, Some(0));
    let price = || rows(&out.join("decision.csv"))[0]["price"].clone();
    assert_eq!(price(), "250.0");
    let (_, text) = run(&[
        "sweep",
        "--config",
        c,
        "--no-trials",
        "--resume",
        "--out",
        o,
    ]);
    assert!(text.contains("is complete"), "{text}");
    cat(200.0);
    let (code, text) = run(&[
        "sweep",
        "--config",
        c,
        "--no-trials",
        "--resume",
        "--out",
        o,
    ]);
    assert_eq!(code, Some(0));
    assert!(!text.contains("is complete"), "{text}");
    assert!(
        text.contains("the catalogue's content changed since"),
        "{text}"
    );
    assert_eq!(price(), "450.0");
    // Shard 1 with one catalogue, shard 2 with another.
    let s1 = dir.path().join("s1");
    let s2 = dir.path().join("s2");
    let shard = |k: &str, d: &std::path::Path| {
        run(&[
            "sweep",
            "--config",
            c,
            "--shard",
            k,
            "--out",
            d.to_str().unwrap(),
        ])
    };
    assert_eq!(shard("1/2", &s1).0, Some(0));
    cat(300.0);
    assert_eq!(shard("2/2", &s2).0, Some(0));
    let m = dir.path().join("m");
    let merge = || {
        let (s1, s2, m) = (
            s1.to_str().unwrap(),
            s2.to_str().unwrap(),
            m.to_str().unwrap(),
        );
        run(&["merge", s1, s2, "--out", m])
    };
    let (code, text) = merge();
    assert_eq!(code, Some(2), "{text}");
    assert!(
        text.contains("different contents of") && text.contains("cat.toml"),
        "{text}"
    );
    // Both shards of the old catalogue, merged after it changed.
    cat(200.0);
    assert_eq!(shard("2/2", &s2).0, Some(0));
    cat(999.0);
    let (code, text) = merge();
    assert_eq!(code, Some(2), "{text}");
    assert!(
        text.contains("catalogue") && text.contains("has changed"),
        "{text}"
    );
    assert!(!m.join("summary.csv").exists());
}

/// A catalogue entry that states no harmonics is read as an unknown curve
/// shape (no datasheet states it), not as a measured once-per-revolution
/// curve; an empty list of harmonics is refused, naming the key.
#[test]
fn an_entry_without_harmonics_is_an_unknown_shape() {
    let dir = tempfile::tempdir().unwrap();
    let cat = write(
        dir.path(),
        "cat.toml",
        "[[encoder]]\nname = \"e\"\nprice = 1.0\naccuracy_arcsec = 2.0\n[[scale]]\nname = \"s\"\nprice = 1.0\naccuracy_um = 1.0\nharmonics = [0.5, 0.5]\n",
    );
    let text = format!("[sweep]\ncatalogue = \"{}\"\n", cat.display());
    let cfg = tricept_calib::config::Config::from_raw(
        tricept_calib::config::parse_raw(&text, "c.toml").unwrap(),
        "c.toml",
    )
    .unwrap();
    let p = cfg.sweep.products.as_ref().unwrap();
    let m = &p.models[0];
    use tricept_calib::sensors::structured::Shape;
    assert_eq!(m.axes[0].shape, Shape::Unknown);
    assert_eq!(m.axes[0].n_harmonics, 6);
    assert_eq!(m.axes[2].shape, Shape::Listed);
    let empty = write(
        dir.path(),
        "e.toml",
        "[sensors.encoder]\naccuracy_arcsec = 2.0\nharmonics = []\n",
    );
    bad_input(
        &["identifiability", "--config", empty.to_str().unwrap()],
        &["sensors.encoder.harmonics", "lists no harmonic"],
        dir.path(),
    );
}
