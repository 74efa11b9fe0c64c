//! The cases a probe of the newest surfaces found mishandled (issue 34,
//! item 6), each handled as the docs promise: bad input exit 2 with one
//! sentence naming the key or file, nothing pre-existing replaced, `--json`
//! where it is documented.

mod common;

use common::{bad_input, bin, refused, write};
use std::path::Path;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A prior of 5e-324 mm used to hang (1/σp² overflows), and one of 1e-160
/// gave empty estimates: both are refused naming the key, quickly.
#[test]
fn absurd_priors_are_refused() {
    let t = tempfile::tempdir().unwrap();
    for sp in ["5e-324", "1e-160", "1e-7"] {
        let cfg = write(
            t.path(),
            "p.toml",
            &format!("[identification]\nmethod = \"gls\"\nprior_std_mm = {sp}\n"),
        );
        bad_input(
            &["identifiability", "--config", s(&cfg)],
            &["identification.prior_std_mm", "1e-6"],
            t.path(),
        );
    }
}

/// A prior far tighter than the machine's errors (1e-6 mm on a machine
/// 0.1–0.7 mm off) holds the estimate near zero; the misfit test, which
/// now counts the prior's own term, rejects it, where it used to "fit" at
/// p = 0.70.
#[test]
fn a_prior_tighter_than_the_machine_is_a_misfit() {
    let t = tempfile::tempdir().unwrap();
    let body = "[errors]\ndxB1 = 0.3\ndq2 = 0.5\ndyA1 = 0.1\ndq1 = 0.7\n[sensors]\nencoder_arcsec = 0.8\nscale_um = 0.5\n[identification]\nmethod = \"gls\"\n";
    let cfg = write(t.path(), "m.toml", &format!("{body}prior_std_mm = 1e-6\n"));
    let wide = write(t.path(), "w.toml", &format!("{body}prior_std_mm = 0.5\n"));
    let r = t.path().join("r.csv");
    bin()
        .args([
            "simulate",
            "-q",
            "--seed",
            "1",
            "--config",
            s(&cfg),
            "--out",
            s(&r),
        ])
        .assert()
        .success();
    let misfit = |c: &Path, out: &str| -> serde_json::Value {
        let o = bin()
            .args([
                "identify",
                "--json",
                "--config",
                s(c),
                "--readings",
                s(&r),
                "--out",
            ])
            .arg(t.path().join(out))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v["checks"]["misfit"].clone()
    };
    let tight = misfit(&cfg, "a");
    assert_eq!(tight["rejected"], true, "{tight}");
    assert!(tight["ratio"].as_f64().unwrap() > 10.0, "{tight}");
    let ok = misfit(&wide, "b");
    assert_eq!(ok["rejected"], false, "{ok}");
}

/// simulate and design-poses refuse an --out that is their own --config
/// (by the same or another path), leaving it as it was.
#[test]
fn an_output_over_its_own_config_is_refused() {
    let t = tempfile::tempdir().unwrap();
    let text = "[errors]\ndxB1 = 0.1\n";
    let cfg = write(t.path(), "c.toml", text);
    let other = t.path().join(".").join("c.toml");
    for args in [
        vec!["simulate", "--config", s(&cfg), "--out", s(&cfg)],
        vec!["simulate", "--config", s(&cfg), "--out", s(&other)],
        vec![
            "design-poses",
            "--config",
            s(&cfg),
            "--count",
            "6",
            "--out",
            s(&cfg),
        ],
    ] {
        refused(&args, &["--out", "is the --config file itself"]);
        assert_eq!(std::fs::read_to_string(&cfg).unwrap(), text);
    }
}

/// A length of 1e308 mm is blamed on its own key, not on another.
#[test]
fn a_huge_length_names_its_key() {
    let t = tempfile::tempdir().unwrap();
    for (text, key) in [
        ("[geometry]\na = 1e308\n", "geometry.a"),
        ("[geometry]\nb = 1e308\n", "geometry.b"),
        ("[workspace]\ntop = 1e308\n", "workspace.top"),
        ("[workspace]\nradius = 1e308\n", "workspace.radius"),
    ] {
        let cfg = write(t.path(), "g.toml", text);
        bad_input(
            &["identifiability", "--config", s(&cfg)],
            &[key, "at most 100000"],
            t.path(),
        );
    }
}

/// identify --json gives each error's source; an identified.csv with an
/// angle's value in the mm column is refused naming the line; a device as
/// readings is refused without reading it; a misfit with held errors names
/// them among the likely causes.
#[test]
fn identify_and_its_files() {
    let t = tempfile::tempdir().unwrap();
    let cfg = write(
        t.path(),
        "m.toml",
        "[errors]\ndxB1 = 0.1\ndq2 = 0.2\n[identification]\nmethod = \"wls\"\n",
    );
    let r = t.path().join("r.csv");
    bin()
        .args(["simulate", "-q", "--config", s(&cfg), "--out", s(&r)])
        .assert()
        .success();
    let o = bin()
        .args([
            "identify",
            "--json",
            "--config",
            s(&cfg),
            "--readings",
            s(&r),
            "--out",
        ])
        .arg(t.path().join("id"))
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let sources: Vec<&str> = v["parameters"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["source"].as_str().unwrap())
        .collect();
    assert_eq!(sources.len(), 15);
    assert!(
        sources.contains(&"readings") && sources.contains(&"unidentifiable"),
        "{sources:?}"
    );
    // An angle written in the mm column as well as the degree column.
    let mut text = String::from("parameter,estimate_mm,estimate_deg\n");
    for n in tricept_calib::mechanism::tricept::PARAM_NAMES {
        text.push_str(&format!("{n},0,\n"));
    }
    for n in tricept_calib::mechanism::tricept::second_class::ANGLE_NAMES {
        text.push_str(&format!("{n},0.01,0.01\n"));
    }
    let bad = write(t.path(), "bad.csv", &text);
    refused(
        &[
            "compensate",
            "--config",
            s(&cfg),
            "--identified",
            s(&bad),
            "--out",
        ]
        .iter()
        .copied()
        .chain([t.path().join("c").to_str().unwrap()])
        .collect::<Vec<_>>(),
        &["bad.csv", "line 17", "is an angle", "estimate_mm"],
    );
    // A device is no readings file.
    refused(
        &[
            "identify",
            "--config",
            s(&cfg),
            "--readings",
            "/dev/zero",
            "--out",
        ]
        .iter()
        .copied()
        .chain([t.path().join("z").to_str().unwrap()])
        .collect::<Vec<_>>(),
        &["/dev/zero", "is a device"],
    );
    // A fix that is not the machine's: the misfit's causes name it.
    let fixed = write(
        t.path(),
        "f.toml",
        "[errors]\ndxB1 = 0.1\ndq2 = 0.2\n[identification]\nmethod = \"wls\"\nfix = { dq2 = -0.4 }\n",
    );
    let o = bin()
        .args([
            "identify",
            "--config",
            s(&fixed),
            "--readings",
            s(&r),
            "--out",
        ])
        .arg(t.path().join("f"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("the values [identification] fix holds (dq2"),
        "{err}"
    );
}

/// sweep --shard --json prints the shard's record on stdout; merge of
/// shards of two studies names the key where their configs differ.
#[test]
fn shards_speak_json_and_merge_names_the_difference() {
    let t = tempfile::tempdir().unwrap();
    let study = |bound: &str| {
        format!("[poses]\nlayers = 1\nring_fractions = [1.0]\npoints_per_ring = 6\n[sweep]\nencoder_arcsec = [1.0]\nscale_um = [0.5]\nmethods = [\"ols\"]\ntrials = 16384\nerrors = \"random\"\nerror_bound = {bound}\nseed = 2\nvolumetric = false\n")
    };
    let a = write(t.path(), "a.toml", &study("0.5"));
    let b = write(t.path(), "b.toml", &study("0.4"));
    let run = |cfg: &Path, k: &str, out: &str| {
        let o = bin()
            .args([
                "sweep",
                "--no-trials",
                "--json",
                "--shard",
                k,
                "--config",
                s(cfg),
                "--out",
            ])
            .arg(t.path().join(out))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v
    };
    let v = run(&a, "1/2", "s1");
    assert_eq!(
        (v["shard"].as_u64(), v["shards"].as_u64()),
        (Some(1), Some(2))
    );
    assert_eq!(v["trial_count"].as_u64(), Some(8192));
    run(&b, "2/2", "s2");
    let out = t.path().join("m");
    refused(
        &[
            "merge",
            s(&t.path().join("s1")),
            s(&t.path().join("s2")),
            "--out",
            s(&out),
        ],
        &["different studies", "sweep.error_bound"],
    );
}

/// A device as a config is refused without reading it (it used to fill
/// memory); spreading poses needs a sensor with an interpolation error and
/// reading_separation needs spreading.
#[test]
fn configs_that_cannot_mean_anything() {
    let t = tempfile::tempdir().unwrap();
    bad_input(
        &["identifiability", "--config", "/dev/zero"],
        &["/dev/zero", "is a device"],
        t.path(),
    );
    for (text, needles) in [
        (
            "[poses]\nspread_mm = 2.0\n",
            vec!["poses.spread_mm", "no sensor of this config has an interpolation error"],
        ),
        (
            "[poses]\nreading_separation = 0.2\n",
            vec!["poses.reading_separation", "needs poses.spread_mm"],
        ),
        (
            "[sensors.encoder]\naccuracy_arcsec = 2.0\ninterpolation_arcsec = 0.5\nsignal_period_arcsec = 72.0\n[poses]\nspread_mm = 2.0\nreading_separation = 0.8\n",
            vec!["poses.reading_separation", "(0, 0.5]"],
        ),
    ] {
        let cfg = write(t.path(), "c.toml", text);
        bad_input(&["identifiability", "--config", s(&cfg)], &needles, t.path());
    }
}
