//! Adversarial inputs, output paths and interruptions (issue #9): one test
//! per class, each checking what the tool now does — exit code, message,
//! files — not only that it does not crash.

use assert_cmd::Command;
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use tempfile::TempDir;

fn bin() -> Command {
    Command::cargo_bin("tricept-calib").unwrap()
}

fn exe() -> std::process::Command {
    std::process::Command::new(assert_cmd::cargo::cargo_bin("tricept-calib"))
}

fn paper() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/paper.toml")
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn skipped(test: &str, why: &str) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "SKIPPED {test}: {why}");
}

/// Run and expect exit 2 with every needle in stderr.
fn refused(args: &[&str], needles: &[&str]) -> String {
    let o = bin().args(args).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "'{n}' not in: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
    err
}

/// No cell of any CSV, and no value of any JSON, in `dir` is NaN or infinite.
fn assert_all_finite(dir: &Path) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let ext = p.extension().and_then(|x| x.to_str()).unwrap_or("");
        if ext != "csv" && ext != "json" {
            continue;
        }
        let text = std::fs::read_to_string(&p).unwrap();
        for cell in text.split([',', '\n', ' ', ':', '[', ']']) {
            let c = cell.trim().trim_matches('"');
            let bad = ["NaN", "nan", "inf", "-inf", "+inf", "Infinity", "-Infinity"];
            assert!(!bad.contains(&c), "{}: holds {c}", p.display());
        }
    }
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let dst = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &dst);
        } else {
            std::fs::copy(e.path(), dst).unwrap();
        }
    }
}

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

/// A sweep of `trials` trials killed once its block log holds `records`
/// records; the directory it left (None if it finished first).
fn interrupted(dir: &Path, cfg: &Path, min_log_bytes: u64) -> Option<PathBuf> {
    let out = dir.join("killed");
    let mut child = exe()
        .args(["sweep", "--threads", "2", "--config"])
        .arg(cfg)
        .arg("--out")
        .arg(&out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let log = out.join(".sweep-state/blocks.bin");
    loop {
        if let Ok(Some(_)) = child.try_wait() {
            return None;
        }
        if std::fs::metadata(&log).is_ok_and(|m| m.len() >= min_log_bytes) {
            let _ = child.kill();
            let _ = child.wait();
            return Some(out);
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
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
    let Some(killed) = interrupted(t.path(), &cfg, 3 * 8192 * 26) else {
        skipped("class3", "the sweep finished before it could be killed");
        return;
    };
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
        &["different configs"],
    );
    merge(
        &edit("first", "\"first_trial\": 8192", "\"first_trial\": 8000"),
        &["holds trials 8192"],
    );
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
fn class5_memory_is_estimated_before_the_run() {
    let t = TempDir::new().unwrap();
    let huge = write(t.path(), "h.toml", "[sweep]\ntrials = 1000000000\n");
    let out = t.path().join("o");
    let o = out.to_str().unwrap();
    refused(
        &["sweep", "--config", huge.to_str().unwrap(), "--out", o],
        &["GiB", "--shard"],
    );
    refused(
        &[
            "sweep",
            "--target-ci",
            "0.001",
            "--max-trials",
            "100000000000000",
            "--out",
            o,
        ],
        &["GiB"],
    );
    let grades: Vec<String> = (1..=1001)
        .map(|k| format!("{}", k as f64 * 0.001))
        .collect();
    let many = write(
        t.path(),
        "g.toml",
        &format!("[sweep]\nencoder_arcsec = [{}]\n", grades.join(", ")),
    );
    refused(
        &["sweep", "--config", many.to_str().unwrap(), "--out", o],
        &["sweep.encoder_arcsec", "at most 1000"],
    );
    let poses = write(
        t.path(),
        "p.toml",
        "[poses]\nlayers = 1000\nring_fractions = [0.5, 1.0]\npoints_per_ring = 100000\n",
    );
    refused(
        &["sweep", "--config", poses.to_str().unwrap(), "--out", o],
        &["poses", "at most 100000"],
    );
    assert!(!out.exists());
}

#[test]
fn class6_no_output_holds_nan_or_infinity() {
    let t = TempDir::new().unwrap();
    // One trial: confidence limits are undefined, so their cells are empty.
    let one = t.path().join("one");
    bin()
        .args(["sweep", "--trials", "1", "--out"])
        .arg(&one)
        .assert()
        .success();
    assert_all_finite(&one);
    let summary = std::fs::read_to_string(one.join("summary.csv")).unwrap();
    assert!(summary.lines().nth(1).unwrap().contains(",,"), "{summary}");
    // parameters.csv of the paper layout: dyA3 has no predicted spread.
    assert_all_finite(&t.path().join("one"));
    // Zero errors, fixed: μ0 = 0, so a ratio decision is refused ...
    let zero = write(
        t.path(),
        "z.toml",
        "[errors]\ndxB1 = 0.0\n[sweep]\nerrors = \"fixed\"\ntrials = 5\n",
    );
    let o = t.path().join("z");
    refused(
        &[
            "sweep",
            "--config",
            zero.to_str().unwrap(),
            "--out",
            o.to_str().unwrap(),
        ],
        &["errors", "μ0 = 0"],
    );
    // ... and a μ decision runs with empty ratio cells.
    let zero_mu = write(
        t.path(),
        "zm.toml",
        "[errors]\ndxB1 = 0.0\n[sweep]\nerrors = \"fixed\"\ntrials = 5\n[decision]\nmetric = \"mu_mean\"\nthreshold = 0.1\n",
    );
    bin()
        .args(["sweep", "--config"])
        .arg(&zero_mu)
        .arg("--out")
        .arg(&o)
        .assert()
        .success();
    assert_all_finite(&o);
    // Absurd grades are refused with the key.
    let big = write(t.path(), "b.toml", "[sweep]\nencoder_arcsec = [1e300]\n");
    refused(
        &[
            "sweep",
            "--config",
            big.to_str().unwrap(),
            "--out",
            o.to_str().unwrap(),
        ],
        &["sweep.encoder_arcsec", "at most 3600"],
    );
    // identify/compensate/reproduce outputs are finite too.
    let r = t.path().join("r");
    bin()
        .args(["reproduce", "--out"])
        .arg(&r)
        .assert()
        .success();
    assert_all_finite(&r);
}

#[test]
fn class7_valid_inputs_never_crash() {
    let t = TempDir::new().unwrap();
    let zero = write(t.path(), "z.toml", "[sensors]\nencoder_arcsec = 0.0\n");
    refused(
        &[
            "design-poses",
            "--config",
            zero.to_str().unwrap(),
            "--out",
            t.path().join("p.toml").to_str().unwrap(),
        ],
        &["sensors.encoder_arcsec"],
    );
    let full = std::fs::OpenOptions::new().write(true).open("/dev/full");
    match full {
        Ok(f) => {
            let o = exe()
                .args(["identifiability", "--config"])
                .arg(paper())
                .stdout(f)
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(1), "{err}");
            assert!(
                err.contains("No space left") && !err.contains("panicked"),
                "{err}"
            );
        }
        Err(_) => skipped("class7 (/dev/full)", "no /dev/full here"),
    }
}

#[test]
fn class8_failures_are_counted_and_nothing_identifiable_is_refused() {
    let t = TempDir::new().unwrap();
    let same = write(
        t.path(),
        "same.toml",
        "[poses]\nlist = [[0.0, 0.0, 700.0], [0.0, 0.0, 700.0], [0.0, 0.0, 700.0]]\n",
    );
    refused(
        &[
            "sweep",
            "--config",
            same.to_str().unwrap(),
            "--out",
            t.path().join("o").to_str().unwrap(),
        ],
        &["rank 0"],
    );
    let vol = write(
        t.path(),
        "v.toml",
        "[sweep]\nencoder_arcsec = [2.0]\ntrials = 50\nvolumetric = true\nvolumetric_grid_step = 100.0\n",
    );
    let o = t.path().join("v");
    bin()
        .args(["sweep", "--config"])
        .arg(&vol)
        .arg("--out")
        .arg(&o)
        .assert()
        .success();
    let s = std::fs::read_to_string(o.join("summary.csv")).unwrap();
    let mut lines = s.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let row: Vec<&str> = lines.next().unwrap().split(',').collect();
    let k = header.iter().position(|h| *h == "dv_failed").unwrap();
    assert_eq!(row[k], "0", "{s}");
}

#[test]
fn class9_readings_that_are_not_what_they_claim() {
    let t = TempDir::new().unwrap();
    let cfg = paper();
    let r = t.path().join("r.csv");
    bin()
        .args(["simulate", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(&r)
        .assert()
        .success();
    let text = std::fs::read_to_string(&r).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let edit_line = |name: &str, line: usize, f: &dyn Fn(Vec<f64>) -> Vec<f64>| -> PathBuf {
        let mut out = lines
            .clone()
            .into_iter()
            .map(String::from)
            .collect::<Vec<_>>();
        let v: Vec<f64> = out[line - 1]
            .split(',')
            .map(|c| c.parse().unwrap())
            .collect();
        out[line - 1] = f(v)
            .iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(",");
        write(t.path(), name, &(out.join("\n") + "\n"))
    };
    let id = |p: &Path, needles: &[&str]| {
        refused(
            &[
                "identify",
                "--config",
                cfg.to_str().unwrap(),
                "--readings",
                p.to_str().unwrap(),
                "--out",
                t.path().join("o").to_str().unwrap(),
            ],
            needles,
        )
    };
    id(
        &edit_line("huge.csv", 7, &|mut v| {
            v[5] = 1e308;
            v
        }),
        &["line 7"],
    );
    id(
        &edit_line("swap.csv", 12, &|mut v| {
            v.swap(3, 4);
            v
        }),
        &["line 12", "swapped"],
    );
    id(
        &edit_line("rad.csv", 20, &|mut v| {
            v[3] = v[3].to_radians();
            v[4] = v[4].to_radians();
            v
        }),
        &["line 20", "radians"],
    );
    id(
        &edit_line("sign.csv", 30, &|mut v| {
            v[3] = -v[3];
            v
        }),
        &["line 30", "sign"],
    );
    // An exactly determined fit has no degrees of freedom: uncertainty is
    // not estimable (empty), never 0.
    let full = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/full-rank.toml");
    let mut fr = std::fs::read_to_string(&full).unwrap();
    fr.push_str("\n[poses]\nlist = [[0.0, 0.0, 700.0], [300.0, 0.0, 650.0], [-150.0, 260.0, 700.0], [-150.0, -260.0, 750.0], [0.0, 300.0, 850.0], [200.0, -200.0, 800.0]]\n");
    let exact = write(t.path(), "exact.toml", &fr);
    let er = t.path().join("er.csv");
    bin()
        .args(["simulate", "--config"])
        .arg(&exact)
        .arg("--out")
        .arg(&er)
        .assert()
        .success();
    let eo = t.path().join("eo");
    bin()
        .args(["identify", "--config"])
        .arg(&exact)
        .arg("--readings")
        .arg(&er)
        .arg("--out")
        .arg(&eo)
        .assert()
        .success();
    let ident = std::fs::read_to_string(eo.join("identified.csv")).unwrap();
    for row in ident.lines().skip(1) {
        assert_eq!(row.split(',').nth(2), Some(""), "{ident}");
    }
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
fn class11_a_real_machine_has_no_truth() {
    let t = TempDir::new().unwrap();
    let text = std::fs::read_to_string(paper()).unwrap();
    let start = text.find("[errors]").unwrap();
    let end = text[start..].find("\n[").unwrap() + start + 1;
    let real = write(
        t.path(),
        "real.toml",
        &format!("{}{}", &text[..start], &text[end..]),
    );
    refused(
        &[
            "simulate",
            "--config",
            real.to_str().unwrap(),
            "--out",
            t.path().join("r.csv").to_str().unwrap(),
        ],
        &["no [errors] table"],
    );
    refused(
        &[
            "reproduce",
            "--config",
            real.to_str().unwrap(),
            "--out",
            t.path().join("rep").to_str().unwrap(),
        ],
        &["no [errors] table"],
    );
    // The real machine's readings (here simulated with the paper config).
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
        .arg(&real)
        .arg("--readings")
        .arg(&r)
        .arg("--out")
        .arg(&id)
        .assert()
        .success();
    let comp = t.path().join("comp");
    let o = bin()
        .args(["compensate", "--config"])
        .arg(&real)
        .arg("--identified")
        .arg(id.join("identified.csv"))
        .arg("--targets")
        .arg(write(t.path(), "t.csv", "x_mm,y_mm,z_mm\n0,0,750\n"))
        .arg("--out")
        .arg(&comp)
        .output()
        .unwrap();
    assert!(o.status.success());
    assert!(String::from_utf8_lossy(&o.stdout).contains("real machine"));
    assert!(comp.join("commands.csv").exists() && comp.join("correction_map.csv").exists());
    assert!(!comp.join("volumetric.csv").exists() && !comp.join("fig3.png").exists());
}

#[test]
fn class12_the_smaller_ones() {
    let t = TempDir::new().unwrap();
    // A command-line value is blamed, not the config file.
    let err = refused(
        &[
            "sweep",
            "--trials",
            "2000000000",
            "--out",
            t.path().join("o").to_str().unwrap(),
        ],
        &["--trials"],
    );
    assert!(!err.contains("paper.toml"), "{err}");
    // --help describes --config, --out and --threads of every command.
    for cmd in [
        "simulate",
        "identify",
        "identifiability",
        "compensate",
        "design-poses",
        "sweep",
        "reproduce",
    ] {
        let o = bin().args([cmd, "--help"]).output().unwrap();
        let help = String::from_utf8_lossy(&o.stdout).to_string();
        for line in help.lines().filter(|l| {
            l.trim_start().starts_with("--config")
                || l.trim_start().starts_with("--out ")
                || l.trim_start().starts_with("--threads")
        }) {
            let words: Vec<&str> = line.split_whitespace().collect();
            assert!(words.len() > 2, "{cmd}: undocumented option: {line}");
        }
    }
    // Console tables use the CSV column names.
    let o = bin()
        .args(["sweep", "--trials", "30", "--out"])
        .arg(t.path().join("s"))
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("encoder_arcsec") && out.contains("ratio_p95") && out.contains("meets_target"),
        "{out}"
    );
    assert!(out.contains("calibrations computed"), "{out}");
}
