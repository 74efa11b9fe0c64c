//! The output contract on every path: an output directory that is one of
//! the inputs refused; a merged catalogue study's report and verdict equal
//! to a single run's; a resume with another seed naming the seed; a
//! catalogue's own defects blamed on the catalogue file and line.

mod common;

use common::{bin, write};
use std::path::Path;

fn study(dir: &Path) -> std::path::PathBuf {
    let cat = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/sensors.toml");
    std::fs::copy(&cat, dir.join("sensors.toml")).unwrap();
    write(
        dir,
        "study.toml",
        r#"
[identification]
method = "gls"
[sweep]
catalogue = "sensors.toml"
encoders = ["angle-2as-d100", "angle-10as-d52"]
scales = ["lin-1um-sp4"]
methods = ["gls"]
trials = 16384
volumetric = true
volumetric_grid_step = 200.0
[decision]
metric = "dv_after_p95_p95"
threshold = 0.25
"#,
    )
}

#[test]
fn a_merged_catalogue_study_equals_a_single_run_and_merge_never_writes_into_a_shard() {
    let t = tempfile::tempdir().unwrap();
    let cfg = study(t.path());
    let single = t.path().join("single");
    bin()
        .args(["sweep", "--no-trials", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&single)
        .assert()
        .success();
    let mut shards = Vec::new();
    for k in 1..=2 {
        let d = t.path().join(format!("s{k}"));
        bin()
            .args([
                "sweep",
                "--no-trials",
                "--shard",
                &format!("{k}/2"),
                "--config",
            ])
            .arg(&cfg)
            .arg("--out")
            .arg(&d)
            .assert()
            .success();
        shards.push(d);
    }
    // merge s1 s2 --out s1: refused, s1 intact.
    let before = std::fs::read(shards[0].join("partial.bin")).unwrap();
    let a = bin()
        .arg("merge")
        .args(&shards)
        .arg("--out")
        .arg(&shards[0])
        .assert()
        .code(2);
    let err = String::from_utf8_lossy(&a.get_output().stderr).into_owned();
    assert!(err.contains("destroy that shard"), "{err}");
    assert_eq!(
        std::fs::read(shards[0].join("partial.bin")).unwrap(),
        before
    );
    let merged = t.path().join("merged");
    bin()
        .arg("merge")
        .args(&shards)
        .arg("--out")
        .arg(&merged)
        .assert()
        .success();
    for f in ["report.html", "verdict.json", "summary.csv", "decision.csv"] {
        assert!(
            std::fs::read(single.join(f)).unwrap() == std::fs::read(merged.join(f)).unwrap(),
            "{f} differs between the single run and the merge"
        );
    }
}

#[test]
fn a_resume_with_another_seed_names_the_seed() {
    let t = tempfile::tempdir().unwrap();
    let cfg = write(t.path(), "s.toml", "[sweep]\ntrials = 100\n");
    let out = t.path().join("o");
    bin()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let a = bin()
        .args(["sweep", "--resume", "--seed", "7", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let err = String::from_utf8_lossy(&a.get_output().stderr).into_owned();
    assert!(err.contains("sweep.seed 1 → 7"), "{err}");
}

#[test]
fn duplicate_catalogue_names_blame_the_catalogue_and_its_line() {
    let t = tempfile::tempdir().unwrap();
    write(
        t.path(),
        "cat.toml",
        "[[encoder]]\nname = \"e\"\nprice = 1.0\naccuracy_arcsec = 2.0\n\n[[encoder]]\nname = \"e\"\nprice = 2.0\naccuracy_arcsec = 3.0\n\n[[scale]]\nname = \"s\"\nprice = 1.0\naccuracy_um = 1.0\n",
    );
    let cfg = write(
        t.path(),
        "s.toml",
        "[sweep]\ncatalogue = \"cat.toml\"\ntrials = 100\n",
    );
    let a = bin()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(t.path().join("o"))
        .assert()
        .code(2);
    let err = String::from_utf8_lossy(&a.get_output().stderr).into_owned();
    assert!(
        err.contains("cat.toml: line 7: [[encoder]] name") && !err.contains("sweep.encoders"),
        "{err}"
    );
}
