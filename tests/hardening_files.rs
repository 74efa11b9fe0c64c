//! Adversarial output paths and interruptions (issue #9, classes 1–4 and
//! 10): special files, locks, resume, merge, stale outputs.

mod common;

use common::*;
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use tempfile::TempDir;

#[test]
fn class1_special_outputs_are_written_through_never_replaced() {
    let t = TempDir::new().unwrap();
    let cfg = paper();
    let cfg = cfg.to_str().unwrap();
    // A character device stays one.
    bin()
        .args(["simulate", "--config", cfg, "--out", "/dev/null"])
        .assert()
        .success();
    assert!(std::fs::metadata("/dev/null")
        .unwrap()
        .file_type()
        .is_char_device());
    // A symlink stays a link; its target gets the readings.
    let target = t.path().join("target.csv");
    std::fs::write(&target, "old").unwrap();
    let link = t.path().join("link.csv");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    bin()
        .args(["simulate", "--config", cfg, "--out"])
        .arg(&link)
        .assert()
        .success();
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert!(std::fs::read_to_string(&target)
        .unwrap()
        .starts_with("x_mm,y_mm"));
    // `-` is stdout, and the message goes to stderr.
    let o = bin()
        .args(["simulate", "--config", cfg, "--out", "-"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.starts_with("x_mm,y_mm,z_mm,psi4_deg"), "{out}");
    assert_eq!(out.lines().count(), 52);
    // A named pipe is written through.
    let fifo = t.path().join("pipe");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if made.is_ok_and(|s| s.success()) {
        let f2 = fifo.clone();
        let reader = std::thread::spawn(move || std::fs::read_to_string(f2).unwrap());
        bin()
            .args(["simulate", "--config", cfg, "--out"])
            .arg(&fifo)
            .assert()
            .success();
        assert!(reader.join().unwrap().starts_with("x_mm"));
        assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    } else if cfg!(target_os = "linux") {
        panic!("mkfifo failed on Linux, where fifos exist: the pipe case must run here");
    } else {
        skipped("class1 (pipe)", "mkfifo is not available");
    }
    // `-` reads stdin for --readings and --config.
    let readings = std::fs::read(&target).unwrap();
    let out_dir = t.path().join("id");
    bin()
        .args(["identify", "--config", cfg, "--readings", "-", "--out"])
        .arg(&out_dir)
        .write_stdin(readings)
        .assert()
        .success();
    assert!(out_dir.join("identified.csv").exists());
    bin()
        .args(["identifiability", "--config", "-"])
        .write_stdin(std::fs::read(paper()).unwrap())
        .assert()
        .success();
    // A directory given where a file is expected: exit 2.
    refused(
        &[
            "simulate",
            "--config",
            cfg,
            "--out",
            t.path().to_str().unwrap(),
        ],
        &["is a directory"],
    );
}

#[test]
fn class2_a_second_run_into_the_same_directory_is_refused() {
    let t = TempDir::new().unwrap();
    let out = t.path().join("sw");
    let mut first = exe()
        .args([
            "sweep",
            "--no-trials",
            "--trials",
            "400000",
            "--threads",
            "1",
            "--out",
        ])
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let lock = out.join(".sweep-state");
    let t0 = std::time::Instant::now();
    while !lock.exists() && t0.elapsed().as_secs() < 30 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let err = refused(
        &[
            "sweep",
            "--no-trials",
            "--trials",
            "10",
            "--out",
            out.to_str().unwrap(),
        ],
        &["in use by another tricept-calib run"],
    );
    assert!(err.contains(out.to_str().unwrap()), "{err}");
    let _ = first.kill();
    let _ = first.wait();
}

#[test]
fn class3_resume_verifies_what_it_resumes_from() {
    let t = TempDir::new().unwrap();
    let cfg = write(
        t.path(),
        "s.toml",
        "[sweep]\nencoder_arcsec = [1.0, 4.0]\nscale_um = [0.5]\ntrials = 120000\nseed = 4\n",
    );
    let reference = t.path().join("ref");
    bin()
        .args(["sweep", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&reference)
        .assert()
        .success();
    // One record holds 8192 trials × (8 + 2 × 9) bytes and more.
    let killed = interrupted(t.path(), &cfg, 3);
    let state = killed.join(".sweep-state");
    type Damage = fn(&Path);
    let cases: [(&str, Damage); 4] = [
        ("as killed", |_| {}),
        ("bit flipped in the block log", |s| {
            let p = s.join("blocks.bin");
            let mut b = std::fs::read(&p).unwrap();
            let k = b.len() / 2;
            b[k] ^= 0x20;
            std::fs::write(p, b).unwrap();
        }),
        ("trials.csv.part truncated", |s| {
            let p = s.join("trials.csv.part");
            let len = std::fs::metadata(&p).unwrap().len();
            let f = std::fs::OpenOptions::new().write(true).open(&p).unwrap();
            f.set_len(len / 3).unwrap();
        }),
        ("trials.csv.part lost", |s| {
            std::fs::remove_file(s.join("trials.csv.part")).unwrap();
        }),
    ];
    for (i, (what, damage)) in cases.iter().enumerate() {
        let dir = t.path().join(format!("case{i}"));
        copy_dir(&killed, &dir);
        damage(&dir.join(".sweep-state"));
        bin()
            .args(["sweep", "--resume", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(&dir)
            .assert()
            .success();
        for f in ["summary.csv", "parameters.csv", "trials.csv"] {
            assert!(
                std::fs::read(reference.join(f)).unwrap() == std::fs::read(dir.join(f)).unwrap(),
                "{what}: {f} differs from an uninterrupted run"
            );
        }
        assert!(!dir.join(".sweep-state").exists());
    }
    assert!(state.exists());
    // --resume on a finished sweep says so and computes nothing.
    let o = bin()
        .args(["sweep", "--resume", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&reference)
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&o.stdout).contains("nothing to resume"));
}

#[test]
fn class4_merge_checks_every_field_and_row_count_before_writing() {
    let t = TempDir::new().unwrap();
    let cfg = write(
        t.path(),
        "s.toml",
        "[sweep]\nencoder_arcsec = [2.0]\ntrials = 16384\nseed = 3\n",
    );
    let shards: Vec<PathBuf> = (1..=2)
        .map(|k| {
            let d = t.path().join(format!("s{k}"));
            bin()
                .args(["sweep", "--shard", &format!("{k}/2"), "--config"])
                .arg(&cfg)
                .arg("--out")
                .arg(&d)
                .assert()
                .success();
            d
        })
        .collect();
    let out = t.path().join("merged");
    let edit = |name: &str, from: &str, to: &str| -> PathBuf {
        let d = t.path().join(name);
        copy_dir(&shards[1], &d);
        let p = d.join("partial.json");
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.contains(from), "{from} not in {text}");
        std::fs::write(&p, text.replacen(from, to, 1)).unwrap();
        d
    };
    let merge = |second: &Path, needles: &[&str]| {
        refused(
            &[
                "merge",
                shards[0].to_str().unwrap(),
                second.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            needles,
        );
        assert!(!out.exists(), "merge wrote something");
    };
    merge(&edit("e0", "\"shard\": 2", "\"shard\": 0"), &["shard = 0"]);
    merge(&edit("e9", "\"shard\": 2", "\"shard\": 9"), &["shard = 9"]);
    merge(
        &edit("n0", "\"shards\": 2", "\"shards\": 0"),
        &["shards = 0"],
    );
    merge(
        &edit("n12", "\"shards\": 2", "\"shards\": 1000000000000"),
        &["shards = 1000000000000"],
    );
    merge(
        &edit("nf", "\"shards\": 2", "\"shards\": 1e12"),
        &["partial.json"],
    );
    merge(
        &edit("cfg", "\"seed\\\":3", "\"seed\\\":4"),
        &["different studies", "sweep.seed"],
    );
    merge(
        &edit("first", "\"first_trial\": 8192", "\"first_trial\": 8000"),
        &["holds trials 8192"],
    );
    // Shard 1's rows in place of shard 2's (same length, wrong trials).
    let swapped = t.path().join("swapped");
    copy_dir(&shards[1], &swapped);
    std::fs::copy(shards[0].join("trials.csv"), swapped.join("trials.csv")).unwrap();
    merge(&swapped, &["trials.csv"]);
    // A truncated trials.csv of a shard.
    let cut = t.path().join("cut");
    copy_dir(&shards[1], &cut);
    let csv = cut.join("trials.csv");
    let len = std::fs::metadata(&csv).unwrap().len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&csv)
        .unwrap()
        .set_len(len - 500)
        .unwrap();
    merge(&cut, &["trials.csv", "truncated"]);
    // A shard with nothing to run is refused rather than silently empty.
    refused(
        &[
            "sweep",
            "--shard",
            "1/3",
            "--config",
            cfg.to_str().unwrap(),
            "--out",
            t.path().join("x").to_str().unwrap(),
        ],
        &["--shard 1/3", "use at most 2 shard(s)"],
    );
}

#[test]
fn class10_a_directory_holds_one_runs_files() {
    let t = TempDir::new().unwrap();
    let out = t.path().join("sw");
    let grid = write(
        t.path(),
        "g.toml",
        "[sweep]\nencoder_arcsec = [1.0, 4.0]\nscale_um = [0.5, 2.0]\ntrials = 20\n",
    );
    bin()
        .args(["sweep", "--config"])
        .arg(&grid)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    assert!(out.join("trials.csv").exists() && out.join("grade_map.png").exists());
    let single = write(
        t.path(),
        "s.toml",
        "[sweep]\nencoder_arcsec = [1.0, 4.0]\ntrials = 20\n",
    );
    bin()
        .args(["sweep", "--no-trials", "--config"])
        .arg(&single)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    assert!(!out.join("trials.csv").exists(), "stale trials.csv left");
    assert!(!out.join("grade_map.png").exists(), "stale grade map left");
    // compensate without targets removes an earlier commands.csv.
    let r = t.path().join("r.csv");
    bin()
        .args(["simulate", "--config"])
        .arg(paper())
        .arg("--out")
        .arg(&r)
        .assert()
        .success();
    let id = t.path().join("id");
    bin()
        .args(["identify", "--config"])
        .arg(paper())
        .arg("--readings")
        .arg(&r)
        .arg("--out")
        .arg(&id)
        .assert()
        .success();
    let targets = write(t.path(), "t.csv", "x_mm,y_mm,z_mm\n0,0,750\n");
    let comp = t.path().join("comp");
    let run = |with_targets: bool| {
        let mut c = bin();
        c.args(["compensate", "--config"])
            .arg(paper())
            .arg("--identified")
            .arg(id.join("identified.csv"))
            .arg("--out")
            .arg(&comp);
        if with_targets {
            c.arg("--targets").arg(&targets);
        }
        c.assert().success();
    };
    run(true);
    assert!(comp.join("commands.csv").exists());
    run(false);
    assert!(
        !comp.join("commands.csv").exists(),
        "stale commands.csv left"
    );
}

#[test]
fn full_device_is_exit_1_naming_the_path() {
    // Needs permission to mount a tmpfs; elsewhere the read-only case above covers exit 1.
    let t = TempDir::new().unwrap();
    let mnt = t.path().join("tiny");
    std::fs::create_dir(&mnt).unwrap();
    let ok = std::process::Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=64k", "tmpfs"])
        .arg(&mnt)
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    let root = std::process::Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| o.stdout == b"0\n");
    if !ok && root && cfg!(target_os = "linux") {
        panic!("root on Linux cannot mount a 64 kB tmpfs: the full-device case must run here");
    }
    if !ok {
        skipped(
            "full_device_is_exit_1_naming_the_path",
            "cannot mount a tmpfs here",
        );
        return;
    }
    let out = mnt.join("sw");
    let o = bin()
        .args(["sweep", "--trials", "3000", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let _ = std::process::Command::new("umount").arg(&mnt).status();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("sw/trials.csv") && err.contains("No space left"),
        "{err}"
    );
}
