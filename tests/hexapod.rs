//! The hexapod from the command line: identifiability's rank with both
//! encoders and with one, readings from exact kinematics identified back,
//! and bad input refused in one sentence naming the key.

mod common;

use common::bin;
use std::path::{Path, PathBuf};

fn shipped() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/hexapod.toml")
}

fn with(edit: impl Fn(String) -> String, dir: &Path) -> PathBuf {
    let text = edit(std::fs::read_to_string(shipped()).unwrap());
    let path = dir.join("hexapod.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn rank(config: &Path) -> (u64, u64, u64) {
    let out = bin()
        .args(["identifiability", "--format", "json", "--config"])
        .arg(config)
        .assert()
        .success();
    let v: serde_json::Value = serde_json::from_slice(&out.get_output().stdout).unwrap();
    (
        v["rank"].as_u64().unwrap(),
        v["parameters"].as_u64().unwrap(),
        v["rank_after_convention"].as_u64().unwrap(),
    )
}

/// Rank 45 of 54 with both encoders, 39 of 48 with one; the convention
/// leaves every free error identified.
#[test]
fn identifiability_gives_the_rank() {
    let t = tempfile::tempdir().unwrap();
    assert_eq!(rank(&shipped()), (45, 54, 45));
    for which in ["first", "second"] {
        let cfg = with(
            |s| {
                let s = s.replace("encoders = \"both\"", &format!("encoders = \"{which}\""));
                // The absent encoder's zeros are not this machine's errors.
                let drop = if which == "first" { "dpsi" } else { "dphi" };
                s.lines()
                    .filter(|l| !l.starts_with(drop))
                    .collect::<Vec<_>>()
                    .join("\n")
            },
            t.path(),
        );
        assert_eq!(rank(&cfg), (39, 48, 39), "{which}");
    }
}

/// Noise-free readings of the shipped machine, identified from the file:
/// identified.csv lists the 54 errors, each leg offset and encoder zero
/// (which no convention touches) as the config's to 1e-8, the convention's
/// errors at zero; with noise, within a few hundredths of a mm.
#[test]
fn simulated_readings_are_identified_back() {
    let t = tempfile::tempdir().unwrap();
    let readings = t.path().join("r.csv");
    bin()
        .args(["simulate", "--noise-free", "--config"])
        .arg(shipped())
        .arg("--out")
        .arg(&readings)
        .assert()
        .success();
    let out = t.path().join("id");
    bin()
        .args(["identify", "--config"])
        .arg(shipped())
        .arg("--readings")
        .arg(&readings)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let text = std::fs::read_to_string(out.join("identified.csv")).unwrap();
    let config = std::fs::read_to_string(shipped()).unwrap();
    let truth = |name: &str| -> f64 {
        let line = config
            .lines()
            .find(|l| l.starts_with(&format!("{name} =")))
            .unwrap();
        line.split('=').nth(1).unwrap().trim().parse().unwrap()
    };
    let rows: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(rows.len(), 54);
    for row in rows {
        let c: Vec<&str> = row.split(',').collect();
        let v: f64 = if c[1].is_empty() { c[2] } else { c[1] }.parse().unwrap();
        if c[0].starts_with("dl") || c[0].starts_with("dphi") || c[0].starts_with("dpsi") {
            assert!((v - truth(c[0])).abs() < 1e-8, "{row}");
        }
        if c[3] == "convention" {
            assert_eq!(v, 0.0, "{row}");
        }
    }
}

/// A wrong key, a wrong value, too few joints, and a command that does not
/// run the hexapod: exit 2, one sentence naming the file and the key.
#[test]
fn bad_hexapod_input_is_refused_naming_the_key() {
    let t = tempfile::tempdir().unwrap();
    let cases: [(&dyn Fn(String) -> String, &str); 5] = [
        (
            &|s| s.replace("encoders = \"both\"", "encoders = \"three\""),
            "hexapod.encoders",
        ),
        (&|s| s.replace("dl1 =", "dq1 ="), "errors.dq1"),
        (
            &|s| s.replace("iterations = 10", "iterations = 0"),
            "identification.iterations",
        ),
        (
            &|s| {
                s.replace(
                    "home_pose = [0, 0, 500, 0, 0, 0]",
                    "home_pose = [0, 0, 500, 0, 0, 95]",
                )
            },
            "hexapod.home_pose",
        ),
        (
            &|s| s.replace("list = [\n", "list = [\n    [0, 0, 500, 0, 120, 0],\n"),
            "poses.list[1]",
        ),
    ];
    for (edit, key) in cases {
        let cfg = with(edit, t.path());
        let out = bin()
            .args(["identifiability", "--config"])
            .arg(&cfg)
            .assert()
            .code(2);
        let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
        assert!(
            err.contains(key) && err.contains("hexapod.toml"),
            "{key}: {err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
    let out = bin()
        .args(["sweep", "--config"])
        .arg(shipped())
        .arg("--out")
        .arg(t.path().join("s"))
        .assert()
        .code(2);
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(err.contains("mechanism.kind"), "{err}");
}
