//! The command-line conventions users expect: init, completions, man pages,
//! --quiet, --json, negative numbers taken as values.

mod common;

use common::bin;

#[test]
fn init_writes_a_template_that_runs_and_never_overwrites() {
    let t = tempfile::tempdir().unwrap();
    let dir = t.path().join("new");
    bin().args(["init", "--out"]).arg(&dir).assert().success();
    let machine = dir.join("machine.toml");
    let text = std::fs::read_to_string(&machine).unwrap();
    assert!(text.starts_with("# A new machine") && dir.join("sensors.toml").exists());
    // The template is a valid config of a real machine (no [errors]) whose
    // catalogue study runs.
    bin()
        .args(["identifiability", "--config"])
        .arg(&machine)
        .assert()
        .success();
    let out = bin()
        .args([
            "sweep",
            "--trials",
            "100",
            "--no-trials",
            "--json",
            "--config",
        ])
        .arg(&machine)
        .arg("--out")
        .arg(t.path().join("study"))
        .assert()
        .success();
    let v: serde_json::Value = serde_json::from_slice(&out.get_output().stdout).unwrap();
    assert!(v["status"].is_string() && v["text"].is_string(), "{v}");
    // A second init refuses, names the file, and changes nothing.
    std::fs::write(&machine, "edited\n").unwrap();
    let a = bin().args(["init", "--out"]).arg(&dir).assert().code(2);
    let err = String::from_utf8_lossy(&a.get_output().stderr).into_owned();
    assert!(err.contains("machine.toml exists"), "{err}");
    assert_eq!(std::fs::read_to_string(&machine).unwrap(), "edited\n");
}

#[test]
fn completions_and_man_pages_come_from_the_command_line() {
    for shell in ["bash", "zsh", "fish"] {
        let a = bin().args(["completions", shell]).assert().success();
        let s = String::from_utf8_lossy(&a.get_output().stdout).into_owned();
        assert!(
            s.contains("tricept-calib") && s.contains("verify"),
            "{shell}"
        );
    }
    let t = tempfile::tempdir().unwrap();
    bin()
        .args(["man", "--out"])
        .arg(t.path())
        .assert()
        .success();
    for page in [
        "tricept-calib.1",
        "tricept-calib-sweep.1",
        "tricept-calib-verify.1",
    ] {
        let text = std::fs::read_to_string(t.path().join(page)).unwrap();
        assert!(text.contains(".TH"), "{page}");
    }
}

#[test]
fn quiet_prints_nothing_and_json_prints_only_json() {
    let t = tempfile::tempdir().unwrap();
    let a = bin()
        .args(["--quiet", "reproduce", "--out"])
        .arg(t.path().join("p"))
        .assert()
        .success();
    assert!(a.get_output().stdout.is_empty());
    assert!(t.path().join("p/report.md").exists());
    let readings = t.path().join("r.csv");
    bin()
        .args(["simulate", "--config", "configs/paper.toml", "--out"])
        .arg(&readings)
        .assert()
        .success();
    let a = bin()
        .args([
            "identify",
            "--json",
            "--config",
            "configs/paper.toml",
            "--readings",
        ])
        .arg(&readings)
        .arg("--out")
        .arg(t.path().join("id"))
        .assert()
        .success();
    let v: serde_json::Value = serde_json::from_slice(&a.get_output().stdout).unwrap();
    assert_eq!(v["parameters"].as_array().unwrap().len(), 15);
    assert_eq!(v["rank"], 14);
    assert!(v["checks"]["misfit"]["p_value"].is_number(), "{v}");
    // dyA3 cannot be identified: its uncertainty is null, not 0.
    let dya3 = &v["parameters"][11];
    assert_eq!(dya3["parameter"], "dyA3");
    assert!(dya3["std_uncertainty_mm"].is_null());
}

#[test]
fn negative_numbers_are_values_and_refused_as_such() {
    let a = bin()
        .args(["sweep", "--seed", "-1", "--out", "x"])
        .assert()
        .code(2);
    let err = String::from_utf8_lossy(&a.get_output().stderr).into_owned();
    assert!(err.contains("invalid value '-1' for '--seed"), "{err}");
    let a = bin()
        .args(["sweep", "--target-ci", "-0.1", "--out", "x"])
        .assert()
        .code(2);
    let err = String::from_utf8_lossy(&a.get_output().stderr).into_owned();
    assert!(
        err.contains("--target-ci") && !err.contains("unexpected argument"),
        "{err}"
    );
}
