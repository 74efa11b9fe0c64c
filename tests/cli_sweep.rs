//! The sweep end to end: determinism, statistics, shards and merge, adaptive
//! stopping, kills and resume.

mod common;

use common::*;
use predicates::prelude::*;
use std::path::{Path, PathBuf};
use tempfile::TempDir;

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
        "report.html",
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
        "different studies (their configs differ at sweep.seed)",
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

/// Issue 20 item 6: what a person reads. Help names the capabilities, units
/// have one spelling, a large trials.csv is announced, Ctrl-C says how to
/// resume, a resumable state is never discarded without --restart, and the
/// linear model's spread misses are one sentence in the report, not notes.
#[cfg(unix)]
#[test]
fn the_console_speaks_to_a_person() {
    let help = bin().args(["sweep", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    for word in [
        "catalogue",
        "gls",
        "--restart",
        "--resume",
        "--shard",
        "report.html",
    ] {
        assert!(help.contains(word), "sweep --help lacks {word}: {help}");
    }
    let t = TempDir::new().unwrap();
    let cfg = write(t.path(), "s.toml", &sweep_toml(""));
    let out = t.path().join("o");
    let run = bin()
        .args(["sweep", "--no-trials", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&run.stdout).to_string() + &String::from_utf8_lossy(&run.stderr);
    assert!(text.contains("µm scale") && text.contains("≤"), "{text}");
    assert!(
        !text.contains(" um ") && !text.contains("<=") && !text.contains("parameter × grade"),
        "{text}"
    );
    // The report counts the misses parameters.csv holds.
    let mut r = csv::Reader::from_path(out.join("parameters.csv")).unwrap();
    let h = r.headers().unwrap().clone();
    let (id, ratio) = (
        h.iter().position(|c| c == "identifiable").unwrap(),
        h.iter().position(|c| c == "ratio_mc_to_predicted").unwrap(),
    );
    let (mut n, mut off) = (0, 0);
    for rec in r.records() {
        let rec = rec.unwrap();
        if &rec[id] == "true" {
            n += 1;
            let q: f64 = rec[ratio].parse().unwrap_or(f64::NAN);
            off += !(0.9..=1.1).contains(&q) as usize;
        }
    }
    let report = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert_eq!(
        report.contains(&format!("by more than 10 % in {off} of {n} cases")),
        off > 0,
        "{off} of {n}"
    );
    // A long run: its trials.csv is announced; Ctrl-C says how to resume.
    let big = write(
        t.path(),
        "b.toml",
        "[sweep]\nencoder_arcsec = [1.0, 2.0, 4.0, 8.0]\nscale_um = [0.5, 1.0]\ntrials = 400000\n",
    );
    let killed = t.path().join("k");
    let child = exe()
        .args(["sweep", "--threads", "1", "--config"])
        .arg(&big)
        .arg("--out")
        .arg(&killed)
        .env("TRICEPT_CALIB_TEST_PAUSE_AFTER_BLOCKS", "1")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut child = child;
    common::wait_paused(&mut child, &killed);
    unsafe {
        libc::kill(child.id() as i32, libc::SIGINT);
    }
    let o = child.wait_with_output().unwrap();
    let _ = std::fs::remove_file(killed.join(".sweep-state/paused"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(
        err.contains("trials.csv will be about") && err.contains("--no-trials"),
        "{err}"
    );
    assert!(
        err.contains("interrupted: run the same command with --resume"),
        "{err}"
    );
    // Without --resume or --restart the state is kept and the run refused.
    let k = killed.to_str().unwrap();
    let b = big.to_str().unwrap();
    bad_input(
        &["sweep", "--threads", "1", "--config", b, "--out", k],
        &["interrupted sweep", "--resume", "--restart"],
        t.path(),
    );
    assert!(killed.join(".sweep-state/blocks.bin").exists());
}

/// Issue 21 item 6: trials.csv.gz is the same CSV gzip-compressed, the
/// same bytes for any thread count, for shards merged as for one run, and
/// a resumable run's block log covers it as it covers trials.csv.
#[test]
fn a_gzip_trials_file_holds_the_csv_bytes() {
    use std::io::Read;
    let t = TempDir::new().unwrap();
    let cfg = write(
        t.path(),
        "s.toml",
        "[sweep]\nencoder_arcsec = [1.0, 4.0]\nscale_um = [0.5]\ntrials = 9000\nseed = 5\n",
    );
    let run = |out: &Path, extra: &[&str]| {
        bin()
            .args(["sweep", "--config"])
            .arg(&cfg)
            .args(extra)
            .arg("--out")
            .arg(out)
            .assert()
            .success();
    };
    let (csv, gz1, gz2) = (t.path().join("c"), t.path().join("g1"), t.path().join("g2"));
    run(&csv, &[]);
    run(&gz1, &["--trials-format", "gz", "--threads", "1"]);
    run(&gz2, &["--trials-format", "gz", "--threads", "2"]);
    let gz = std::fs::read(gz1.join("trials.csv.gz")).unwrap();
    assert_eq!(gz, std::fs::read(gz2.join("trials.csv.gz")).unwrap());
    let plain = std::fs::read(csv.join("trials.csv")).unwrap();
    let mut text = Vec::new();
    flate2::read::MultiGzDecoder::new(&gz[..])
        .read_to_end(&mut text)
        .unwrap();
    assert!(
        text == plain,
        "trials.csv.gz does not decompress to trials.csv"
    );
    assert!(
        gz.len() * 3 < plain.len(),
        "{} vs {}",
        gz.len(),
        plain.len()
    );
    assert!(!gz1.join("trials.csv").exists());
    assert_eq!(
        std::fs::read(csv.join("summary.csv")).unwrap(),
        std::fs::read(gz1.join("summary.csv")).unwrap()
    );
    // --resume on the finished csv study with gz asked: run again, saying why.
    bin()
        .args(["sweep", "--resume", "--trials-format", "gz", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&csv)
        .assert()
        .success()
        .stderr(predicate::str::contains(
            "the trials file (--no-trials or --trials-format) changed",
        ));
    assert!(csv.join("trials.csv.gz").exists() && !csv.join("trials.csv").exists());
    // A csv run into the gz folder leaves one trials file.
    run(&gz2, &[]);
    assert!(gz2.join("trials.csv").exists() && !gz2.join("trials.csv.gz").exists());
    // Shards in gz merge to a single run's bytes; mixed formats are refused.
    let s = |k: &str, fmt: &str| {
        let d = t.path().join(format!("s{}{fmt}", &k[..1]));
        run(&d, &["--shard", k, "--trials-format", fmt]);
        d
    };
    let (a, b) = (s("1/2", "gz"), s("2/2", "gz"));
    let m = t.path().join("m");
    bin()
        .arg("merge")
        .args([&a, &b])
        .arg("--out")
        .arg(&m)
        .assert()
        .success();
    assert!(
        std::fs::read(m.join("trials.csv.gz")).unwrap() == gz,
        "merged gz differs"
    );
    let b_csv = s("2/2", "csv");
    let o = bin()
        .arg("merge")
        .args([&a, &b_csv])
        .arg("--out")
        .arg(t.path().join("m2"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("different formats"));
    // A damaged stream is bad input (exit 2), named, before anything is written.
    let gz_b = b.join("trials.csv.gz");
    let bytes = std::fs::read(&gz_b).unwrap();
    std::fs::write(&gz_b, &bytes[..bytes.len() / 2]).unwrap();
    let m3 = t.path().join("m3");
    let o = bin()
        .arg("merge")
        .args([&a, &b])
        .arg("--out")
        .arg(&m3)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("damaged gzip stream") && err.contains("trials.csv.gz"),
        "{err}"
    );
    assert!(!m3.exists());
}

/// A killed gzip run resumes to the bytes of an uninterrupted one.
#[test]
fn a_killed_gzip_run_resumes_to_the_same_bytes() {
    let t = TempDir::new().unwrap();
    let cfg = write(
        t.path(),
        "s.toml",
        "[sweep]\nencoder_arcsec = [1.0, 4.0]\nscale_um = [0.5]\ntrials = 120000\nseed = 4\n",
    );
    let whole = t.path().join("whole");
    bin()
        .args(["sweep", "--trials-format", "gz", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&whole)
        .assert()
        .success();
    let killed = t.path().join("killed");
    let mut child = exe()
        .args([
            "sweep",
            "--threads",
            "1",
            "--trials-format",
            "gz",
            "--config",
        ])
        .arg(&cfg)
        .arg("--out")
        .arg(&killed)
        .env("TRICEPT_CALIB_TEST_PAUSE_AFTER_BLOCKS", "2")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    common::wait_paused(&mut child, &killed);
    let _ = child.kill();
    let _ = child.wait();
    let _ = std::fs::remove_file(killed.join(".sweep-state/paused"));
    bin()
        .args(["sweep", "--resume", "--trials-format", "gz", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&killed)
        .assert()
        .success()
        .stdout(predicate::str::contains("resuming").or(predicate::str::contains("Resum")));
    for f in ["trials.csv.gz", "summary.csv"] {
        assert!(
            std::fs::read(whole.join(f)).unwrap() == std::fs::read(killed.join(f)).unwrap(),
            "{f} differs from an uninterrupted run"
        );
    }
}
