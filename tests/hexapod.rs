//! The hexapod from the command line: identifiability's rank with both
//! encoders and with one, readings from exact kinematics identified back,
//! and bad input refused in one sentence naming the key.

mod common;

use common::bin;
use std::path::{Path, PathBuf};

/// `simulate --config CONFIG --out OUT` with `flags`, which must succeed.
fn simulate(config: impl AsRef<Path>, out: impl AsRef<Path>, flags: &[&str]) {
    bin()
        .arg("simulate")
        .args(flags)
        .arg("--config")
        .arg(config.as_ref())
        .arg("--out")
        .arg(out.as_ref())
        .assert()
        .success();
}

/// `identify --config CONFIG --readings READINGS --out OUT`, run.
fn run_identify(
    config: impl AsRef<Path>,
    readings: impl AsRef<Path>,
    out: impl AsRef<Path>,
) -> assert_cmd::assert::Assert {
    bin()
        .args(["identify", "--config"])
        .arg(config.as_ref())
        .arg("--readings")
        .arg(readings.as_ref())
        .arg("--out")
        .arg(out.as_ref())
        .assert()
}

/// `identify`, which must succeed.
fn identify(config: impl AsRef<Path>, readings: impl AsRef<Path>, out: impl AsRef<Path>) {
    run_identify(config, readings, out).success();
}

/// `identify`, which must be refused with exit 2: its stderr.
fn identify_refused(
    config: impl AsRef<Path>,
    readings: impl AsRef<Path>,
    out: impl AsRef<Path>,
) -> String {
    let done = run_identify(config, readings, out).code(2);
    String::from_utf8_lossy(&done.get_output().stderr).to_string()
}

/// A quiet `sweep` of 400 machines of `config` into `out`, which must
/// succeed.
fn sweep_400(config: &Path, out: &Path) {
    bin()
        .args(["sweep", "-q", "--trials", "400", "--config"])
        .arg(config)
        .arg("--out")
        .arg(out)
        .assert()
        .success();
}

fn shipped() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/hexapod.toml")
}

fn with(edit: impl Fn(String) -> String, dir: &Path) -> PathBuf {
    let text = edit(std::fs::read_to_string(shipped()).unwrap());
    let path = dir.join("hexapod.toml");
    std::fs::write(&path, text).unwrap();
    // The study's catalogue, beside the config as shipped.
    std::fs::copy(
        shipped().with_file_name("sensors.toml"),
        dir.join("sensors.toml"),
    )
    .unwrap();
    path
}

/// A CSV of numbers: its header and its rows.
fn numbers(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    (head, rows)
}

/// `compensate` of `config` with `identified` at `targets` into `out`.
fn compensate(
    config: &Path,
    identified: &Path,
    targets: &Path,
    out: &Path,
) -> assert_cmd::assert::Assert {
    compensate_with(&[], config, identified, targets, out)
}

/// `compensate` with `flags` before the paths.
fn compensate_with(
    flags: &[&str],
    config: &Path,
    identified: &Path,
    targets: &Path,
    out: &Path,
) -> assert_cmd::assert::Assert {
    bin()
        .arg("compensate")
        .args(flags)
        .arg("--config")
        .arg(config)
        .arg("--identified")
        .arg(identified)
        .arg("--targets")
        .arg(targets)
        .arg("--out")
        .arg(out)
        .assert()
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
    simulate(shipped(), &readings, &["--noise-free"]);
    let out = t.path().join("id");
    identify(shipped(), &readings, &out);
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
        let v: f64 = if c[1].is_empty() { c[3] } else { c[1] }.parse().unwrap();
        if c[0].starts_with("dl") || c[0].starts_with("dphi") || c[0].starts_with("dpsi") {
            assert!((v - truth(c[0])).abs() < 1e-8, "{row}");
        }
        if c[5] == "convention" {
            assert_eq!(v, 0.0, "{row}");
        }
    }
}

/// The what-ifs run the chosen combination again on the same machines:
/// at a factor of 1 the white what-if is the chosen row to the bit, twice
/// the white terms do worse, and the eccentricity what-if applies to the
/// chosen one-head ring; the verdict says them.
#[test]
fn the_hexapod_what_ifs_rerun_the_choice() {
    let t = tempfile::tempdir().unwrap();
    let verdict = |white: &str, out: &str| -> serde_json::Value {
        let cfg = with(|s| s.replace("truth_white = 2.0", white), t.path());
        sweep_400(&cfg, &t.path().join(out));
        serde_json::from_str(
            &std::fs::read_to_string(t.path().join(out).join("verdict.json")).unwrap(),
        )
        .unwrap()
    };
    let one = verdict("truth_white = 1.0", "one");
    let chosen = one["chosen"]["position_p95_upper95_mm"].as_f64().unwrap();
    let w = &one["what_ifs"];
    assert_eq!(w.as_array().unwrap().len(), 2, "{w}");
    assert_eq!(w[0]["position_p95_upper95_mm"].as_f64().unwrap(), chosen);
    assert_eq!(w[1]["applies"], true, "{w}");
    let two = verdict("truth_white = 2.0", "two");
    assert_eq!(two["chosen"], one["chosen"]);
    assert!(
        two["what_ifs"][0]["position_p95_upper95_mm"]
            .as_f64()
            .unwrap()
            > 1.2 * chosen
    );
    let sentence = two["verdict"].as_str().unwrap();
    assert!(
        sentence.contains("interpolation error and jitter 2× the datasheet's")
            && sentence.contains("5 µm of eccentricity"),
        "{sentence}"
    );
}

/// The machine's travel: a pose, a workspace or a target outside an
/// actuator's stroke or a U-joint's angle is refused in one sentence that
/// names where and which leg; the shipped limits hold all of its poses.
#[test]
fn poses_outside_the_machines_travel_are_refused() {
    let t = tempfile::tempdir().unwrap();
    let refused = |edit: &dyn Fn(String) -> String, words: &[&str]| {
        let cfg = with(edit, t.path());
        let out = bin()
            .args(["identifiability", "--config"])
            .arg(&cfg)
            .assert()
            .code(2);
        let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
        for w in words {
            assert!(err.contains(w), "{w}: {err}");
        }
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    };
    // poses.list[2] needs actuator 2 at 74.7 mm and turns U-joint 3's φ
    // axis 10.6°.
    refused(
        &|s| s.replace("stroke_mm = [-150, 150]", "stroke_mm = [-50, 50]"),
        &[
            "poses.list[2]",
            "actuator 2 at 74.706 mm",
            "hexapod.stroke_mm",
        ],
    );
    refused(
        &|s| s.replace("joint_angle_deg = 20", "joint_angle_deg = 10"),
        &[
            "poses.list[2]",
            "U-joint 3's φ axis -10.643°",
            "hexapod.joint_angle_deg",
        ],
    );
    // The workspace's corner (−80, −80, 440) tilted 8° needs 108.6 mm.
    refused(
        &|s| {
            let s = s.replace("stroke_mm = [-150, 150]", "stroke_mm = [-100, 100]");
            let from = s.find("list = [\n").unwrap();
            let end = from + s[from..].find("\n]\n").unwrap() + 3;
            s[..from].to_string()
                + "list = [[0, 0, 500, 0, 0, 0], [10, 0, 500, 0, 0, 0]]\n"
                + &s[end..]
        },
        &["workspace", "actuator 6 at -108.640 mm"],
    );
    refused(
        &|s| s.replace("stroke_mm = [-150, 150]", "stroke_mm = [5, 150]"),
        &["hexapod.stroke_mm", "home"],
    );
    refused(
        &|s| s.replace("joint_angle_deg = 20", "joint_angle_deg = 0"),
        &["hexapod.joint_angle_deg"],
    );
    // A compensate target beyond the stroke, named by its line.
    let readings = t.path().join("r.csv");
    simulate(shipped(), &readings, &["--noise-free"]);
    let id = t.path().join("id");
    identify(shipped(), &readings, &id);
    let targets = t.path().join("targets.csv");
    std::fs::write(
        &targets,
        "x_mm,y_mm,z_mm,a_deg,b_deg,c_deg\n0,0,500,0,0,0\n0,0,700,0,0,0\n",
    )
    .unwrap();
    let out = compensate(
        &shipped(),
        &id.join("identified.csv"),
        &targets,
        &t.path().join("c"),
    )
    .code(2);
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        err.contains("targets.csv") && err.contains("line 3") && err.contains("stroke"),
        "{err}"
    );
    assert!(!t.path().join("c/commands.csv").exists());
    // A target the nominal machine reaches within the stroke but the
    // identified one needs past it: its corrected commands are refused.
    std::fs::write(
        &targets,
        "x_mm,y_mm,z_mm,a_deg,b_deg,c_deg\n0,0,500,0,0,0\n0,0,640,0,0,0\n",
    )
    .unwrap();
    let identified = id.join("identified.csv");
    compensate(&shipped(), &identified, &targets, &t.path().join("free")).success();
    let (_, rows) = numbers(&t.path().join("free/commands.csv"));
    let row = &rows[1];
    let (corrected, nominal) = (&row[6..12], &row[12..18]);
    let most = nominal.iter().copied().fold(f64::MIN, f64::max);
    assert!(corrected.iter().any(|&q| q > most + 1e-6), "{row:?}");
    let dir = tempfile::tempdir().unwrap();
    let cfg = with(
        |s| {
            s.replace(
                "stroke_mm = [-150, 150]",
                &format!("stroke_mm = [-150, {}]", most + 1e-7),
            )
        },
        dir.path(),
    );
    let out = compensate(&cfg, &identified, &targets, &t.path().join("tight")).code(2);
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        err.contains("line 3") && err.contains("identified machine needs actuator"),
        "{err}"
    );
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
    // A kind neither machine's, and platform joints 1–3 in a line.
    let cases: [(&dyn Fn(String) -> String, &str); 2] = [
        (
            &|s| s.replace("kind = \"hexapod\"", "kind = \"hexapd\""),
            "mechanism.kind",
        ),
        (
            &|s| {
                let from = s.find("platform_joints_mm = [").unwrap();
                let end = from + s[from..].find("],\n]").unwrap() + 4;
                s[..from].to_string()
                + "platform_joints_mm = [[0, 0, 0], [50, 0, 0], [100, 0, 0], [0, 80, 0], [-60, -40, 0], [60, -70, 0]]"
                + &s[end..]
            },
            "hexapod.platform_joints_mm",
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
            err.contains(key) && err.trim().lines().count() == 1,
            "{key}: {err}"
        );
    }
    // A number TOML cannot hold is the hexapod parser's to report, at its
    // line (the file is still a hexapod's though TOML cannot read it whole).
    let cfg = with(
        |s| s.replace("trials = ", "trials = 99999999999999999999 #"),
        t.path(),
    );
    let line = std::fs::read_to_string(&cfg)
        .unwrap()
        .lines()
        .position(|l| l.starts_with("trials = 9"))
        .unwrap()
        + 1;
    let out = bin()
        .args(["identifiability", "--config"])
        .arg(&cfg)
        .assert()
        .code(2);
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        err.contains(&format!("hexapod.toml line {line}:")) && err.trim().lines().count() == 1,
        "{err}"
    );
    // A reading wrapped by 360°: named by its line and column before any fit.
    let readings = t.path().join("r.csv");
    simulate(shipped(), &readings, &[]);
    let text = std::fs::read_to_string(&readings).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut cells: Vec<String> = lines[4].split(',').map(String::from).collect();
    cells[8] = format!("{}", cells[8].parse::<f64>().unwrap() + 360.0);
    lines[4] = cells.join(",");
    let wrapped = t.path().join("wrapped.csv");
    std::fs::write(&wrapped, lines.join("\n") + "\n").unwrap();
    let err = identify_refused(shipped(), &wrapped, t.path().join("w-id"));
    assert!(err.contains("line 5") && err.contains("phi2_deg"), "{err}");
    // A log longer than identify reads: refused before any work.
    let mut long = String::from("x_mm,y_mm,z_mm,a_deg,b_deg,c_deg");
    for i in 1..=6 {
        long += &format!(",phi{i}_deg,psi{i}_deg");
    }
    long.push('\n');
    for _ in 0..10_001 {
        long += "0,0,500,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0\n";
    }
    let log = t.path().join("long.csv");
    std::fs::write(&log, long).unwrap();
    let err = identify_refused(shipped(), &log, t.path().join("long-id"));
    assert!(
        err.contains("long.csv") && err.contains("at most 10000"),
        "{err}"
    );
    let out = bin()
        .args(["design-poses", "--config"])
        .arg(shipped())
        .args(["--count", "10", "--out"])
        .arg(t.path().join("s"))
        .assert()
        .code(2);
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(err.contains("mechanism.kind"), "{err}");
    // The Tricept's study flags a hexapod sweep does not take.
    let out = bin()
        .args(["sweep", "--resume", "--config"])
        .arg(shipped())
        .arg("--out")
        .arg(t.path().join("s"))
        .assert()
        .code(2);
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(err.contains("--resume") && err.contains("hexapod"), "{err}");
    // Bad study keys, each named.
    let cases: [(&dyn Fn(String) -> String, &str); 6] = [
        (
            &|s| {
                s.replace(
                    "per_joint = [\"both\", \"first\"]",
                    "per_joint = [\"three\"]",
                )
            },
            "sweep.per_joint",
        ),
        (
            &|s| s.replace("pose_counts = [12, 20, 30]", "pose_counts = [12, 31]"),
            "sweep.pose_counts",
        ),
        (
            &|s| {
                s.replace(
                    "estimators = [\"linear\", \"gls\"]",
                    "estimators = [\"ols\"]",
                )
            },
            "sweep.estimators",
        ),
        (
            &|s| s.replace("position_mm = 0.02", "position_mm = -1"),
            "decision.position_mm",
        ),
        (&|s| s.replace("tilt_deg = 8", "tilt_deg = 80"), "workspace"),
        (
            &|s| s.replace("truth_white = 2.0", "truth_white = -1"),
            "sweep.truth_white",
        ),
    ];
    for (edit, key) in cases {
        let cfg = with(edit, t.path());
        let out = bin()
            .args(["sweep", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(t.path().join("bad-sweep"))
            .assert()
            .code(2);
        let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
        assert!(
            err.contains(key) && err.contains("hexapod.toml"),
            "{key}: {err}"
        );
        assert!(
            !t.path().join("bad-sweep").exists(),
            "{key}: an output folder was made"
        );
    }
}

/// `sweep` on the shipped hexapod study (fewer machines): a row for each
/// encoder, encoders per joint and pose count; the same bytes on one
/// thread and on two; the verdict names a combination that meets the
/// target, and no cheaper row meets it; both encoders per joint never do
/// worse than one of the same encoder at the same poses.
#[test]
fn the_hexapod_study_ranks_the_encoders() {
    let t = tempfile::tempdir().unwrap();
    let run = |threads: &str, out: &str| {
        bin()
            .args(["sweep", "--trials", "600", "--threads", threads, "--config"])
            .arg(shipped())
            .arg("--out")
            .arg(t.path().join(out))
            .assert()
            .success();
        std::fs::read_to_string(t.path().join(out).join("summary.csv")).unwrap()
    };
    let one = run("1", "a");
    assert_eq!(one, run("2", "b"));
    let rows: Vec<Vec<String>> = one
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    assert_eq!(rows.len(), 6 * 2 * 3 * 2);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(t.path().join("a/verdict.json")).unwrap())
            .unwrap();
    // report.html says the verdict and holds the figure; both figures
    // are written (every encoder has a price).
    let page = std::fs::read_to_string(t.path().join("a/report.html")).unwrap();
    let sentence = v["verdict"].as_str().unwrap().replace('&', "&amp;");
    assert!(page.contains(&sentence), "the page lacks the verdict");
    assert!(page.contains("<svg") && !page.contains("<script"));
    for f in ["price_accuracy.png", "price_accuracy.svg"] {
        assert!(t.path().join("a").join(f).is_file(), "{f}");
    }
    let chosen = &v["chosen"];
    let price = chosen["price"].as_f64().unwrap();
    assert!(chosen["position_p95_upper95_mm"].as_f64().unwrap() <= 0.02);
    for r in &rows {
        let p: f64 = r[3].parse().unwrap();
        if p < price {
            assert_eq!(r[14], "false", "{r:?} is cheaper and meets the target");
        }
        if r[1] == "both" {
            let one_per_joint = rows
                .iter()
                .find(|o| o[0] == r[0] && o[1] == "first" && o[4] == r[4] && o[5] == r[5])
                .unwrap();
            let (b, f): (f64, f64) = (r[9].parse().unwrap(), one_per_joint[9].parse().unwrap());
            assert!(b <= f * 1.02, "{r:?} against {one_per_joint:?}");
        }
        // Weighting each encoder by its datasheet does no worse than
        // weighting its readings alike (within the sampling of 600).
        if r[5] == "gls" {
            let alike = rows
                .iter()
                .find(|o| o[0] == r[0] && o[1] == r[1] && o[4] == r[4] && o[5] == "linear")
                .unwrap();
            let (g, l): (f64, f64) = (r[9].parse().unwrap(), alike[9].parse().unwrap());
            assert!(g <= l * 1.05, "{r:?} against {alike:?}");
        }
    }
    // Bare grades have no price: no figure, the coarsest grade that meets
    // the target is chosen, and a grade twice as coarse does worse.
    let cfg = with(
        |s| {
            s.replace(
                "catalogue = \"sensors.toml\"",
                "encoder_arcsec = [1.0, 2.0]",
            )
            // The grades' own jitter: small, so that the grade decides.
            .replace("encoder_noise_arcsec = 1.0", "encoder_noise_arcsec = 0.05")
        },
        t.path(),
    );
    bin()
        .args(["sweep", "--trials", "400", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(t.path().join("g"))
        .assert()
        .success();
    assert!(!t.path().join("g/price_accuracy.png").exists());
    assert!(t.path().join("g/report.html").is_file());
    let summary = std::fs::read_to_string(t.path().join("g/summary.csv")).unwrap();
    let p95 = |grade: &str, per: &str, poses: &str| -> f64 {
        summary
            .lines()
            .map(|l| l.split(',').collect::<Vec<_>>())
            .find(|c| c[0] == grade && c[1] == per && c[4] == poses)
            .unwrap()[9]
            .parse()
            .unwrap()
    };
    for per in ["both", "first"] {
        assert!(
            p95("±2″", per, "30") > 1.3 * p95("±1″", per, "30"),
            "{summary}"
        );
    }
}

/// export --format linuxcnc: genhexkins.hal's 36 pins are the config's
/// joints plus identified.csv's errors (read back from the two files as a
/// controller would), joints.ini each leg's home length; and where Debian's
/// linuxcnc-uspace is installed (CI installs it), halrun loads genhexkins,
/// sources the file and shows every pin at that value (to its 7 digits).
#[test]
fn the_linuxcnc_export_loads_in_genhexkins() {
    let t = tempfile::tempdir().unwrap();
    let readings = t.path().join("r.csv");
    simulate(shipped(), &readings, &[]);
    let id = t.path().join("id");
    identify(shipped(), &readings, &id);
    let out = t.path().join("lc");
    bin()
        .args(["export", "--format", "linuxcnc", "--config"])
        .arg(shipped())
        .arg("--identified")
        .arg(id.join("identified.csv"))
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    // The expected pins, from the config's text and identified.csv.
    let config: toml::Table = toml::from_str(&std::fs::read_to_string(shipped()).unwrap()).unwrap();
    let joints = |key: &str| -> Vec<Vec<f64>> {
        config["hexapod"][key]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| {
                p.as_array()
                    .unwrap()
                    .iter()
                    .map(|x| x.as_float().or(x.as_integer().map(|i| i as f64)).unwrap())
                    .collect()
            })
            .collect()
    };
    let identified = std::fs::read_to_string(id.join("identified.csv")).unwrap();
    let est = |name: &str| -> f64 {
        let row = identified
            .lines()
            .find(|l| l.starts_with(&format!("{name},")))
            .unwrap();
        let c: Vec<&str> = row.split(',').collect();
        if c[1].is_empty() { c[3] } else { c[1] }.parse().unwrap()
    };
    let mut want = std::collections::BTreeMap::new();
    for (what, key, prefix) in [
        ("base", "base_joints_mm", "db"),
        ("platform", "platform_joints_mm", "dp"),
    ] {
        for (n, p) in joints(key).iter().enumerate() {
            for (k, axis) in ["x", "y", "z"].iter().enumerate() {
                let v = p[k] + est(&format!("{prefix}{axis}{}", n + 1));
                want.insert(format!("genhexkins.{what}.{n}.{axis}"), v);
            }
        }
    }
    let hal = std::fs::read_to_string(out.join("genhexkins.hal")).unwrap();
    let setp: Vec<&str> = hal.lines().filter(|l| l.starts_with("setp ")).collect();
    assert_eq!(setp.len(), 36);
    for line in setp {
        let c: Vec<&str> = line.split_whitespace().collect();
        let v: f64 = c[2].parse().unwrap();
        assert!(
            (v - want[c[1]]).abs() < 1e-9,
            "{line} against {}",
            want[c[1]]
        );
    }
    let ini = std::fs::read_to_string(out.join("joints.ini")).unwrap();
    assert_eq!(ini.matches("[JOINT_").count(), 6);
    assert_eq!(ini.matches("HOME_OFFSET = ").count(), 6);

    // LinuxCNC itself (skipped, saying why, where CI could not set it up).
    if let Ok(why) = std::env::var("TRICEPT_NO_LINUXCNC") {
        eprintln!("skipped: the genhexkins load ({why})");
        return;
    }
    let halrun = ["/usr/bin/halrun", "/usr/local/bin/halrun"]
        .into_iter()
        .find(|p| Path::new(p).exists());
    let Some(halrun) = halrun else {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI must load the export in LinuxCNC: .ci/run installs Debian's linuxcnc-uspace"
        );
        eprintln!("skipped: the genhexkins load (no halrun: Debian's linuxcnc-uspace is not installed here)");
        return;
    };
    // halrun refuses root: as root, run it as the user CI names.
    let root = std::process::Command::new("id")
        .arg("-u")
        .output()
        .map(|o| o.stdout == b"0\n")
        .unwrap_or(false);
    let dir = tempfile::Builder::new()
        .prefix("hal")
        .tempdir_in("/tmp")
        .unwrap();
    let hal_file = dir.path().join("g.hal");
    std::fs::copy(out.join("genhexkins.hal"), &hal_file).unwrap();
    let script = dir.path().join("load.hal");
    std::fs::write(
        &script,
        format!(
            "loadrt genhexkins\nsource {}\nshow pin genhexkins\n",
            hal_file.display()
        ),
    )
    .unwrap();
    let user = std::env::var("TRICEPT_HAL_USER").ok();
    if root && user.is_none() {
        assert!(
            std::env::var_os("CI").is_none(),
            "as root, TRICEPT_HAL_USER names a non-root user for halrun (.ci/run sets it)"
        );
        eprintln!("skipped: the genhexkins load (halrun refuses root: set TRICEPT_HAL_USER to a non-root user with a home)");
        return;
    }
    let mut cmd = if let (true, Some(user)) = (root, user) {
        use std::os::unix::fs::PermissionsExt;
        for p in [dir.path(), &hal_file, &script] {
            std::fs::set_permissions(p, std::fs::Permissions::from_mode(0o755)).unwrap();
        }
        let mut c = std::process::Command::new("runuser");
        c.args(["-u", &user, "--", halrun]);
        c
    } else {
        std::process::Command::new(halrun)
    };
    let shown = cmd
        .arg("-f")
        .arg(&script)
        .current_dir(dir.path())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&shown.stdout).to_string()
        + &String::from_utf8_lossy(&shown.stderr);
    let mut seen = 0;
    for line in text.lines() {
        let c: Vec<&str> = line.split_whitespace().collect();
        if c.len() == 5 && want.contains_key(c[4]) {
            let v: f64 = c[3].parse().unwrap();
            let w = want[c[4]];
            assert!(
                (v - w).abs() <= 5e-7 * w.abs().max(1.0),
                "{}: LinuxCNC shows {v}, identified {w}",
                c[4]
            );
            seen += 1;
        }
    }
    assert_eq!(seen, 36, "halrun's output:\n{text}");
}

/// compensate: the identified machine's inverse kinematics. From
/// noise-free readings the corrected commands put the true machine (by its
/// exact forward kinematics, judged in the convention's frames) on every
/// target to 1e-6 mm and 0.01″, where the nominal commands miss by tenths
/// of a mm: on a machine whose errors obey the convention (legs 1–3's
/// joints nominal) and on the shipped one, whose do not.
#[test]
fn compensated_commands_reach_the_targets() {
    let t = tempfile::tempdir().unwrap();
    let obeys = with(
        |s| {
            s.lines()
                .filter(|l| {
                    let b = l.as_bytes();
                    !(b.len() > 3
                        && (l.starts_with("db")
                            || (l.starts_with("dp")
                                && !l.starts_with("dph")
                                && !l.starts_with("dps")))
                        && matches!(b[3], b'1'..=b'3'))
                })
                .collect::<Vec<_>>()
                .join("\n")
        },
        t.path(),
    );
    let kept = t.path().join("obeys.toml");
    std::fs::rename(&obeys, &kept).unwrap();
    for cfg in [kept, shipped()] {
        compensate_case(&cfg, t.path());
    }
}

fn compensate_case(cfg: &Path, dir: &Path) {
    let t = tempfile::tempdir_in(dir).unwrap();
    let readings = t.path().join("r.csv");
    simulate(cfg, &readings, &["--noise-free"]);
    let id = t.path().join("id");
    identify(cfg, &readings, &id);
    let targets = t.path().join("targets.csv");
    std::fs::write(
        &targets,
        "x_mm,y_mm,z_mm,a_deg,b_deg,c_deg\n0,0,500,0,0,0\n50,-40,540,3,-4,6\n-70,20,460,-6,5,-2\n",
    )
    .unwrap();
    let out = t.path().join("c");
    compensate(cfg, &id.join("identified.csv"), &targets, &out).success();
    let (head, rows) = numbers(&out.join("commands.csv"));
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    assert_eq!(rows.len(), 3);
    for r in &rows {
        assert!(r[col("position_after_mm")] < 1e-6, "{r:?}");
        assert!(r[col("orientation_after_arcsec")] < 0.01, "{r:?}");
        assert!(r[col("position_before_mm")] > 0.05, "{r:?}");
        // The corrected commands differ from the nominal ones.
        assert!((r[col("q1_mm")] - r[col("nominal_q1_mm")]).abs() > 1e-3);
    }
    // The accuracy over [workspace]: 189 poses (27 positions × 7
    // orientations), each after to 1e-6 mm and 0.01″ (a noise-free fit),
    // before off by tenths of a mm; the figure of the position error in
    // three planes.
    let (head, rows) = numbers(&out.join("workspace_accuracy.csv"));
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    assert_eq!(rows.len(), 189);
    for r in &rows {
        assert!(r[col("position_after_mm")] < 1e-6, "{r:?}");
        assert!(r[col("orientation_after_arcsec")] < 0.01, "{r:?}");
        assert!(r[col("position_before_mm")] > 0.05, "{r:?}");
    }
    let svg = std::fs::read_to_string(out.join("workspace_layers.svg")).unwrap();
    for t in [
        "Tool-point position error at the home orientation per layer",
        "z = 440 mm",
        "z = 560 mm",
        "position error after (mm)",
    ] {
        assert!(svg.contains(t), "{t}");
    }
}

/// A simulated machine identified from noisy readings: over the workspace
/// compensation leaves a small part of what was there, and the map's
/// largest after-error is where the readings' noise puts it, far below
/// before (the console says both).
#[test]
fn compensate_maps_the_workspace_before_and_after() {
    let t = tempfile::tempdir().unwrap();
    let cfg = with(|s| s, t.path());
    let readings = t.path().join("r.csv");
    simulate(&cfg, &readings, &[]);
    let id = t.path().join("id");
    identify(&cfg, &readings, &id);
    let out = t.path().join("c");
    let run = bin()
        .args(["compensate", "--config"])
        .arg(&cfg)
        .arg("--identified")
        .arg(id.join("identified.csv"))
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let said = String::from_utf8_lossy(&run.get_output().stdout).to_string()
        + &String::from_utf8_lossy(&run.get_output().stderr);
    assert!(said.contains("over the workspace's 189 poses"), "{said}");
    let text = std::fs::read_to_string(out.join("workspace_accuracy.csv")).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    let max = |c: usize| rows.iter().map(|r| r[c]).fold(0.0, f64::max);
    let (before, after) = (max(6), max(7));
    assert!(before > 0.2 && after < 0.1 * before, "{before} {after}");
    assert!(max(9) < 0.1 * max(8), "orientation {} {}", max(8), max(9));
    assert!(out.join("workspace_layers.png").is_file());
}

/// export --format json: geometry.json holds each leg's nominal and
/// identified joints (the identified ones the nominal plus identified.csv's
/// errors), every error with its σ and source, the correlations (unit
/// diagonal, symmetric, within ±1) and identify's misfit check, which
/// passes on readings with the stated noise and fails on readings 10× as
/// noisy.
#[test]
fn the_json_export_holds_the_geometry_its_uncertainty_and_checks() {
    let t = tempfile::tempdir().unwrap();
    let run = |config: &Path, tag: &str, accept: bool| -> serde_json::Value {
        let readings = t.path().join(format!("{tag}.csv"));
        simulate(config, &readings, &[]);
        let id = t.path().join(format!("{tag}-id"));
        identify(shipped(), &readings, &id);
        let out = t.path().join(format!("{tag}-json"));
        let export = || {
            let mut c = bin();
            c.args(["export", "--format", "json", "--config"])
                .arg(shipped())
                .arg("--identified")
                .arg(id.join("identified.csv"))
                .arg("--out")
                .arg(&out);
            c
        };
        if accept {
            // A rejected fit is refused unless accepted.
            export().assert().code(2);
            export().arg("--accept-rejected-fit").assert().success();
        } else {
            export().assert().success();
        }
        serde_json::from_str(&std::fs::read_to_string(out.join("geometry.json")).unwrap()).unwrap()
    };
    let g = run(&shipped(), "stated", false);
    assert_eq!(g["mechanism"], "hexapod");
    assert_eq!(g["legs"].as_array().unwrap().len(), 6);
    let errors = g["errors"].as_array().unwrap();
    assert_eq!(errors.len(), 54);
    let est = |name: &str| {
        errors.iter().find(|e| e["name"] == name).unwrap()["estimate"]
            .as_f64()
            .unwrap()
    };
    let leg2 = &g["legs"][1];
    for (k, axis) in ["x", "y", "z"].iter().enumerate() {
        let nominal = leg2["base_nominal_mm"][k].as_f64().unwrap();
        let identified = leg2["base_identified_mm"][k].as_f64().unwrap();
        assert!((identified - nominal - est(&format!("db{axis}2"))).abs() < 1e-12);
    }
    for e in errors {
        let sd = e["std_uncertainty"].as_f64().unwrap();
        match e["source"].as_str().unwrap() {
            "convention" => assert_eq!(sd, 0.0, "{e}"),
            "identified" => assert!(sd > 0.0 && sd < 0.1, "{e}"),
            // Confined to a direction: a component across it is held.
            _ => assert!((0.0..0.1).contains(&sd), "{e}"),
        }
    }
    let names = g["correlations"]["names"].as_array().unwrap();
    let m = g["correlations"]["matrix"].as_array().unwrap();
    assert_eq!((names.len(), m.len()), (45, 45));
    let at = |a: usize, b: usize| m[a][b].as_f64().unwrap();
    for (a, b) in (0..45).flat_map(|a| (0..45).map(move |b| (a, b))) {
        assert!((at(a, b) - at(b, a)).abs() < 1e-9 && at(a, b).abs() <= 1.0 + 1e-9);
        if a == b {
            assert!((at(a, a) - 1.0).abs() < 1e-9);
        }
    }
    assert_eq!(g["checks"]["misfit"]["passed"], true, "{}", g["checks"]);
    // Readings 10× noisier than the config states: the misfit fails.
    let noisy = with(
        |s| s.replace("encoder_noise_arcsec = 1.0", "encoder_noise_arcsec = 10.0"),
        t.path(),
    );
    let g = run(&noisy, "noisy", true);
    assert_eq!(g["checks"]["misfit"]["passed"], false, "{}", g["checks"]);
}

/// verify: a fresh log of the shipped machine (taken with the nominal
/// commands) against the model identified from another log passes where
/// the readings and the model agree (within a few hundredths of a mm),
/// and the uncalibrated model (every error zero) fails it (exit 3), as
/// does the right model told the log was taken with its own commands.
#[test]
fn verify_passes_the_identified_machine_and_fails_the_nominal_one() {
    let t = tempfile::tempdir().unwrap();
    let log = |seed: &str, name: &str| {
        let p = t.path().join(name);
        bin()
            .args(["simulate", "--seed", seed, "--config"])
            .arg(shipped())
            .arg("--out")
            .arg(&p)
            .assert()
            .success();
        p
    };
    let (calibration, fresh) = (log("1", "cal.csv"), log("7", "fresh.csv"));
    let id = t.path().join("id");
    identify(shipped(), &calibration, &id);
    let identified = id.join("identified.csv");
    let text = std::fs::read_to_string(&identified).unwrap();
    let mut zero = String::new();
    for (i, line) in text.lines().enumerate() {
        if i == 0 {
            zero += line;
        } else {
            let name = line.split(',').next().unwrap();
            let angle = name.starts_with("dph") || name.starts_with("dps");
            zero += &format!(
                "\n{name},{},0,{},0,given",
                if angle { "" } else { "0" },
                if angle { "0" } else { "" }
            );
        }
    }
    let zero_path = t.path().join("zero.csv");
    std::fs::write(&zero_path, zero + "\n").unwrap();
    let verify = |identified: &Path, nominal: bool| {
        let mut c = bin();
        c.args(["verify", "--threshold", "0.05", "--config"])
            .arg(shipped())
            .arg("--identified")
            .arg(identified)
            .arg("--readings")
            .arg(&fresh);
        if nominal {
            c.arg("--nominal-commands");
        }
        c.assert()
    };
    let out = verify(&identified, true).success();
    let said = String::from_utf8_lossy(&out.get_output().stdout).to_string();
    assert!(
        said.contains("PASS relative to the encoders only"),
        "{said}"
    );
    assert!(
        said.contains("what it cannot see") && said.contains("external measurement"),
        "{said}"
    );
    let out = verify(&zero_path, true).code(3);
    assert!(String::from_utf8_lossy(&out.get_output().stderr).contains("FAIL"));
    verify(&identified, false).code(3);
}

/// A log with a slip is refused naming the slip, by the same readings
/// diagnosis the Tricept's identify uses (read from the hexapod's reading
/// facts): two columns swapped, a sign flipped, radians in the degree
/// columns; a reading off for no such reason says what to check. One
/// sentence, exit 2, nothing written.
#[test]
fn a_log_with_a_slip_is_refused_naming_the_slip() {
    let t = tempfile::tempdir().unwrap();
    let readings = t.path().join("readings.csv");
    simulate(shipped(), &readings, &["--noise-free"]);
    let text = std::fs::read_to_string(&readings).unwrap();
    let mut lines = text.lines();
    let head: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    let (phi2, psi2) = (col("phi2_deg"), col("psi2_deg"));
    type Slip<'a> = &'a dyn Fn(&mut Vec<f64>);
    let z = col("z_mm");
    let cases: [(&str, Slip, &str); 6] = [
        // A target the machine cannot reach: named by its stroke, not by
        // the readings it could not have given.
        (
            "unreachable",
            &|r| r[z] = 5000.0,
            "the target needs actuator 1 at",
        ),
        // A reading too large to print in full: in scientific notation.
        (
            "huge",
            &|r| r[psi2] = 1e300,
            "psi2_deg = 1.0000e300° is 1.0000e300° from",
        ),
        (
            "swapped",
            &|r| r.swap(phi2, psi2),
            "phi2_deg and psi2_deg look swapped",
        ),
        (
            "flipped",
            &|r| r[psi2] = -r[psi2],
            "psi2_deg's sign looks flipped",
        ),
        (
            "radians",
            &|r| r[6..].iter_mut().for_each(|v| *v = v.to_radians()),
            "the angles look like radians in the _deg columns",
        ),
        ("off", &|r| r[psi2] += 12.0, "psi2_deg = "),
    ];
    for (name, slip, words) in cases {
        let mut csv = head.join(",");
        for row in &rows {
            let mut r = row.clone();
            slip(&mut r);
            let cells: Vec<String> = r.iter().map(|v| v.to_string()).collect();
            csv.push('\n');
            csv.push_str(&cells.join(","));
        }
        csv.push('\n');
        let path = t.path().join(format!("{name}.csv"));
        std::fs::write(&path, csv).unwrap();
        let out_dir = t.path().join(format!("out-{name}"));
        let err = identify_refused(shipped(), &path, &out_dir);
        assert!(err.contains(words), "{name}: {err}");
        assert!(err.contains(&format!("{name}.csv: line ")), "{name}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(!out_dir.exists(), "{name}: wrote {}", out_dir.display());
        if name == "unreachable" {
            assert!(err.contains("(hexapod.stroke_mm)"), "{err}");
        }
        if name == "off" {
            assert!(
                err.contains("check the units (degrees), the column order and the signs, or whether the log is another machine's"),
                "{err}"
            );
        }
    }
}

/// `[identification] fix` and the prior from the command line: a leg
/// offset and an encoder zero fixed at the simulated machine's values are
/// written as "fixed" with those values and no uncertainty, and the fit
/// still explains the readings; a joint centre cannot be fixed (it is in
/// the convention's frames) and a prior needs the readings' σ, each
/// refused naming the key; with a prior, a log too short to determine the
/// free errors is taken (the prior holds what it cannot see).
#[test]
fn identify_holds_fixed_errors_and_a_prior() {
    let t = tempfile::tempdir().unwrap();
    let readings = t.path().join("readings.csv");
    simulate(shipped(), &readings, &[]);
    let fixed = with(
        |s| {
            s.replace(
                "[identification]\n",
                "[identification]\nfix = { dl3 = -0.0692, dphi2 = -0.0017 }\n",
            )
        },
        t.path(),
    );
    let out = t.path().join("fixed");
    identify(&fixed, &readings, &out);
    let text = std::fs::read_to_string(out.join("identified.csv")).unwrap();
    let row = |name: &str| -> Vec<String> {
        text.lines()
            .find(|l| l.starts_with(&format!("{name},")))
            .unwrap()
            .split(',')
            .map(String::from)
            .collect()
    };
    assert_eq!(row("dl3")[1..3], ["-0.0692", "0"]);
    assert_eq!(row("dl3")[5], "fixed");
    assert_eq!(row("dphi2")[3..5], ["-0.0017", "0"]);
    assert_eq!(row("dphi2")[5], "fixed");
    assert_eq!(row("dl4")[5], "identified");
    let fit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("identifiability.json")).unwrap())
            .unwrap();
    assert_eq!(fit["checks"]["misfit"]["passed"], true, "{fit}");

    let refused = |edit: &dyn Fn(String) -> String, words: &[&str]| {
        let cfg = with(edit, t.path());
        let err = identify_refused(&cfg, &readings, t.path().join("refused"));
        for w in words {
            assert!(err.contains(w), "{w}: {err}");
        }
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    };
    refused(
        &|s| {
            s.replace(
                "[identification]\n",
                "[identification]\nfix = { dbx2 = 0.01 }\n",
            )
        },
        &["identification.fix.dbx2", "convention"],
    );
    refused(
        &|s| {
            s.replace("encoder_noise_arcsec = 1.0", "encoder_noise_arcsec = 0.0")
                .replace(
                    "[identification]\n",
                    "[identification]\nprior_std_mm = 0.5\n",
                )
        },
        &[
            "identification.prior_std_mm",
            "sensors.encoder_noise_arcsec",
        ],
    );

    // Three poses: 36 readings for 45 free errors, too few to determine
    // them (identify refuses without a prior), taken with one.
    let (head, rows) = numbers(&readings);
    let short = t.path().join("short.csv");
    let mut csv = head.join(",");
    for r in rows.iter().take(3) {
        let cells: Vec<String> = r.iter().map(|v| v.to_string()).collect();
        csv += &format!("\n{}", cells.join(","));
    }
    std::fs::write(&short, csv + "\n").unwrap();
    let err = identify_refused(shipped(), &short, t.path().join("short-without"));
    assert!(err.contains("log more poses"), "{err}");
    let prior = with(
        |s| {
            s.replace(
                "[identification]\n",
                "[identification]\nprior_std_mm = 0.2\nprior_std_deg = 0.05\n",
            )
        },
        t.path(),
    );
    identify(&prior, &short, t.path().join("short-prior"));
    let text = std::fs::read_to_string(t.path().join("short-prior/identified.csv")).unwrap();
    assert!(text.contains(",prior\n"), "{text}");
}

/// identify states the accuracy the compensated machine is predicted to
/// reach (identifiability.json and its console line); where the readings
/// are noisier than the config states, the misfit rejects the σ and the
/// prediction scales the covariance by √(χ²/dof), giving what the true σ
/// gives (within 15 %) instead of a fivefold optimistic figure.
#[test]
fn identify_predicts_the_accuracy_and_scales_it_by_a_rejected_misfit() {
    let t = tempfile::tempdir().unwrap();
    let readings = t.path().join("readings.csv");
    simulate(shipped(), &readings, &[]);
    let fit = |cfg: &Path, name: &str| -> serde_json::Value {
        let out = t.path().join(name);
        let done = run_identify(cfg, &readings, &out).success();
        let said = String::from_utf8_lossy(&done.get_output().stdout).to_string();
        assert!(said.contains("predicted after compensation"), "{said}");
        let text = std::fs::read_to_string(out.join("identifiability.json")).unwrap();
        serde_json::from_str(&text).unwrap()
    };
    let honest = fit(&shipped(), "honest");
    let a = &honest["checks"]["predicted_accuracy"];
    let p95 = a["position_mm"]["p95"].as_f64().unwrap();
    let median = a["position_mm"]["median"].as_f64().unwrap();
    assert!(p95 > median && median > 0.0, "{a}");
    assert_eq!(a["covariance_scale"], 1.0);
    assert_eq!(a["draws"], 1000);
    let claims = with(
        |s| s.replace("encoder_noise_arcsec = 1.0", "encoder_noise_arcsec = 0.2"),
        t.path(),
    );
    let scaled = fit(&claims, "scaled");
    assert_eq!(scaled["checks"]["misfit"]["passed"], false);
    let b = &scaled["checks"]["predicted_accuracy"];
    let scale = b["covariance_scale"].as_f64().unwrap();
    assert!((4.0..6.0).contains(&scale), "{b}");
    for key in ["position_mm", "orientation_arcsec"] {
        let (x, y) = (
            b[key]["p95"].as_f64().unwrap(),
            a[key]["p95"].as_f64().unwrap(),
        );
        assert!((x / y - 1.0).abs() < 0.15, "{key}: {x} against {y}");
    }
}

/// identify's held-out check: on the shipped machine's log the poses left
/// out are predicted as well as the encoders allow (RMS of the
/// standardised predictions about 1), naming the CSV line of the worst;
/// a fit whose held-out check failed is refused by compensate, naming the
/// check and its figure, unless --accept-rejected-fit.
#[test]
fn identify_holds_out_poses_and_compensate_refuses_a_failed_check() {
    let t = tempfile::tempdir().unwrap();
    let readings = t.path().join("readings.csv");
    simulate(shipped(), &readings, &[]);
    let id = t.path().join("id");
    let said = run_identify(shipped(), &readings, &id).success();
    let said = String::from_utf8_lossy(&said.get_output().stdout).to_string();
    assert!(said.contains("held out: 360 readings"), "{said}");
    let path = id.join("identifiability.json");
    let mut fit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    let held = &fit["checks"]["held_out"];
    let rms = held["rms_z"].as_f64().unwrap();
    assert!((0.8..1.25).contains(&rms), "{held}");
    assert_eq!(held["passed"], true);
    assert_eq!(held["folds"], 5);
    assert!(
        (2..=31).contains(&held["worst_line"].as_u64().unwrap()),
        "{held}"
    );
    // The same fit, its held-out check failed.
    fit["checks"]["held_out"]["passed"] = serde_json::json!(false);
    fit["checks"]["held_out"]["rms_z"] = serde_json::json!(3.1);
    std::fs::write(&path, fit.to_string()).unwrap();
    let targets = t.path().join("targets.csv");
    std::fs::write(
        &targets,
        "x_mm,y_mm,z_mm,a_deg,b_deg,c_deg\n10,0,500,0,0,0\n",
    )
    .unwrap();
    let identified = id.join("identified.csv");
    let out = compensate(&shipped(), &identified, &targets, &t.path().join("comp")).code(2);
    let err = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        err.contains("held-out check rejected") && err.contains("3.10 times"),
        "{err}"
    );
    assert!(!t.path().join("comp").exists());
    compensate_with(
        &["--accept-rejected-fit"],
        &shipped(),
        &identified,
        &targets,
        &t.path().join("comp"),
    )
    .success();
}

/// `identification.fix` reaches the study: with every leg offset
/// measured (fixed), each GLS row is at least as accurate as without, and
/// the whole study better (the mean of the rows' p95 falls). An encoder's
/// zero fixed, or a prior on the zeros, is refused in a sentence naming
/// the key: the study homes its readings at the reference pose, where a
/// zero cancels, so it cannot say what measuring one buys.
#[test]
fn a_study_with_fixed_errors_holds_them() {
    let t = tempfile::tempdir().unwrap();
    let names: Vec<String> = (1..=6).map(|i| format!("dl{i} = 0.0")).collect();
    let fix = format!("[identification]\nfix = {{ {} }}\n", names.join(", "));
    let p95 = |edit: &dyn Fn(String) -> String, out: &str| -> Vec<(String, f64)> {
        let cfg = with(edit, t.path());
        sweep_400(&cfg, &t.path().join(out));
        let text = std::fs::read_to_string(t.path().join(out).join("summary.csv")).unwrap();
        let mut lines = text.lines();
        let head: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = |n: &str| head.iter().position(|h| *h == n).unwrap();
        let (est, p) = (col("estimator"), col("position_p95_mm"));
        lines
            .map(|l| {
                let c: Vec<&str> = l.split(',').collect();
                (c[est].to_string(), c[p].parse().unwrap())
            })
            .collect()
    };
    let plain = p95(&|s| s, "plain");
    let fixed = p95(&|s| s.replace("[identification]\n", &fix), "fixed");
    assert_eq!(plain.len(), fixed.len());
    let mut gls = 0;
    for ((est, a), (_, b)) in plain.iter().zip(&fixed) {
        if est == "gls" {
            gls += 1;
            assert!(*b <= a * 1.02, "{b} fixed against {a}");
        }
    }
    assert!(gls >= 12, "{gls} GLS rows");
    let mean = |v: &[(String, f64)]| v.iter().map(|r| r.1).sum::<f64>() / v.len() as f64;
    assert!(
        mean(&fixed) < 0.9 * mean(&plain),
        "{} against {}",
        mean(&fixed),
        mean(&plain)
    );
    for (key, line) in [
        ("identification.fix.dphi2", "fix = { dphi2 = 0.0 }"),
        (
            "identification.prior_std_deg",
            "prior_std_mm = 0.2\nprior_std_deg = 0.05",
        ),
    ] {
        let cfg = with(
            |s| s.replace("[identification]\n", &format!("[identification]\n{line}\n")),
            t.path(),
        );
        let out = bin()
            .args(["sweep", "-q", "--trials", "10", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(t.path().join("refused"))
            .assert()
            .code(2);
        let said = String::from_utf8_lossy(&out.get_output().stderr).to_string();
        assert!(
            said.contains(key) && said.contains("homes its readings"),
            "{said}"
        );
        assert!(
            !t.path().join("refused").exists(),
            "nothing written before the refusal"
        );
    }
}

/// The Tricept's own flags of identify and verify are refused for a
/// hexapod config in one sentence naming its kind (exit 2), before any
/// file is read.
#[test]
fn the_tricepts_own_flags_are_refused_for_a_hexapod() {
    let t = tempfile::tempdir().unwrap();
    let missing = t.path().join("no-such.csv");
    let out = bin()
        .args(["identify", "--json", "--config"])
        .arg(shipped())
        .arg("--readings")
        .arg(&missing)
        .arg("--out")
        .arg(t.path().join("id"))
        .assert()
        .code(2);
    let said = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        said.contains("mechanism.kind = \"hexapod\": identify takes no --reference or --json for the hexapod yet"),
        "{said}"
    );
    let out = bin()
        .args(["verify", "--threshold", "0.05", "--out"])
        .arg(t.path().join("v"))
        .arg("--config")
        .arg(shipped())
        .arg("--identified")
        .arg(&missing)
        .arg("--readings")
        .arg(&missing)
        .assert()
        .code(2);
    let said = String::from_utf8_lossy(&out.get_output().stderr).to_string();
    assert!(
        said.contains("verify takes no --reference, --out or --json for the hexapod yet"),
        "{said}"
    );
    assert!(!t.path().join("id").exists() && !t.path().join("v").exists());
}

/// `--json` prints verdict.json on stdout and nothing else there;
/// `--require-target` exits 3 after writing every output when no
/// combination meets the target, 0 when one does, and is refused (exit 2,
/// naming the key) when the config states no target.
#[test]
fn the_hexapod_study_prints_its_verdict_and_requires_its_target() {
    let t = tempfile::tempdir().unwrap();
    let run = |cfg: &Path, out: &str, code: i32| {
        let done = bin()
            .args(["sweep", "--trials", "60", "--json", "--require-target"])
            .arg("--config")
            .arg(cfg)
            .arg("--out")
            .arg(t.path().join(out))
            .assert()
            .code(code);
        let stdout = String::from_utf8_lossy(&done.get_output().stdout).to_string();
        let stderr = String::from_utf8_lossy(&done.get_output().stderr).to_string();
        (stdout, stderr)
    };
    let (stdout, _) = run(&shipped(), "met", 0);
    let printed: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    let written: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(t.path().join("met/verdict.json")).unwrap())
            .unwrap();
    assert_eq!(printed, written);
    assert!(printed["chosen"].is_object());
    // A target no encoder reaches: every output written, then exit 3.
    let cfg = with(
        |s| s.replace("position_mm = 0.02", "position_mm = 0.0001"),
        t.path(),
    );
    let (stdout, stderr) = run(&cfg, "missed", 3);
    let printed: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert!(printed["chosen"].is_null());
    assert!(
        stderr.contains("no combination meets the target"),
        "{stderr}"
    );
    for f in ["summary.csv", "verdict.json", "report.html"] {
        assert!(t.path().join("missed").join(f).is_file(), "{f}");
    }
    // No target to require.
    let cfg = with(
        |s| {
            s.replace("position_mm = 0.02\n", "")
                .replace("orientation_arcsec = 20\n", "")
        },
        t.path(),
    );
    let (_, stderr) = run(&cfg, "none", 2);
    assert!(
        stderr.contains("--require-target") && stderr.contains("position_mm"),
        "{stderr}"
    );
    assert!(!t.path().join("none").exists());
    // A pose count whose poses cannot determine the free errors is refused
    // before any machine runs, as identify refuses such a log: 2 poses give
    // 24 homed readings for 33 coordinates with both encoders; 4 poses,
    // 18 with one a joint. 7 poses with one a joint (36) determine them.
    for (counts, said) in [
        ("[2, 30]", "the first 2 poses of poses.list determine 24 of the 45 free errors with a φ and a ψ encoder per U-joint"),
        ("[4, 30]", "the first 4 poses of poses.list determine 24 of the 39 free errors with one φ encoder per U-joint"),
    ] {
        let cfg = with(
            |s| s.replace("pose_counts = [12, 20, 30]", &format!("pose_counts = {counts}")),
            t.path(),
        );
        let (_, stderr) = run(&cfg, "few", 2);
        assert!(
            stderr.contains("sweep.pose_counts") && stderr.contains(said),
            "{stderr}"
        );
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(!t.path().join("few").exists());
    }
    let cfg = with(
        |s| s.replace("pose_counts = [12, 20, 30]", "pose_counts = [7, 30]"),
        t.path(),
    );
    run(&cfg, "seven", 0);
    // A calibration that leaves the median machine further off than
    // uncalibrated (7 poses, one 10″ encoder a joint: full rank, but
    // barely redundant) does not meet a target, however loose: the
    // verdict says so and chooses the 30 poses.
    let cfg = with(
        |s| {
            s.replace("pose_counts = [12, 20, 30]", "pose_counts = [7, 30]")
                .replace(
                    "per_joint = [\"both\", \"first\"]",
                    "per_joint = [\"first\"]",
                )
                .replace(
                    "estimators = [\"linear\", \"gls\"]",
                    "estimators = [\"linear\"]",
                )
                .replace(
                    "catalogue = \"sensors.toml\"",
                    "catalogue = \"sensors.toml\"\nencoders = [\"angle-10as-d52\"]",
                )
                .replace("position_mm = 0.02", "position_mm = 50")
                .replace("orientation_arcsec = 20", "orientation_arcsec = 100000")
        },
        t.path(),
    );
    let (stdout, _) = run(&cfg, "harms", 0);
    let summary = std::fs::read_to_string(t.path().join("harms/summary.csv")).unwrap();
    let rows: Vec<Vec<&str>> = summary
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 2, "{summary}");
    let (before, after): (f64, f64) = (rows[0][7].parse().unwrap(), rows[0][8].parse().unwrap());
    assert!(rows[0][4] == "7" && after >= before, "{summary}");
    assert_eq!((rows[0][14], rows[1][14]), ("false", "true"), "{summary}");
    let printed: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(printed["chosen"]["poses"], 30);
    assert!(
        printed["verdict"].as_str().unwrap().contains("Not feasible whatever the threshold: 1 combination(s) whose calibration leaves the typical machine worse than not calibrating"),
        "{}",
        printed["verdict"]
    );
    // An output path that is a file: that alone is said, in one line
    // (too few machines for an upper limit would otherwise be noted first).
    let file = t.path().join("a-file");
    std::fs::write(&file, "kept").unwrap();
    let done = bin()
        .args(["sweep", "--trials", "20", "--config"])
        .arg(shipped())
        .arg("--out")
        .arg(&file)
        .assert()
        .code(2);
    let stderr = String::from_utf8_lossy(&done.get_output().stderr).to_string();
    assert!(
        stderr.contains("is not a directory") && stderr.trim().lines().count() == 1,
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "kept");
}

/// trials.csv: one row per machine and combination, machine by machine in
/// summary.csv's order of combinations; each summary row's medians are the
/// medians of its rows (301 machines, past the first block of 256 stored
/// together: the 151st value, whatever the quantile's definition). `--trials-format gz` stores the same bytes
/// gzip-compressed; `--no-trials` writes neither and removes a stale one.
#[test]
fn the_hexapod_studys_trials_are_the_rows_its_summary_summarises() {
    let t = tempfile::tempdir().unwrap();
    let sweep = |out: &str, extra: &[&str]| {
        bin()
            .args(["sweep", "-q", "--trials", "301", "--config"])
            .arg(shipped())
            .arg("--out")
            .arg(t.path().join(out))
            .args(extra)
            .assert()
            .success();
        t.path().join(out)
    };
    let out = sweep("csv", &[]);
    let trials = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let mut lines = trials.lines();
    assert_eq!(
        lines.next().unwrap(),
        "trial,encoder,per_joint,encoders_fitted,poses,estimator,position_before_mm,position_after_mm,orientation_before_arcsec,orientation_after_arcsec"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    let combos: Vec<Vec<&str>> = summary
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 301 * combos.len());
    let num = |s: &str| s.parse::<f64>().unwrap();
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[150]
    };
    for (k, c) in combos.iter().enumerate() {
        // summary.csv: encoder, per_joint, encoders_fitted, price, poses,
        // estimator, trials, before median, median, p95, upper,
        // orientation median, …
        let mine: Vec<&Vec<&str>> = rows.iter().skip(k).step_by(combos.len()).collect();
        for (m, r) in mine.iter().enumerate() {
            assert_eq!(r[0], m.to_string(), "machine order");
            assert_eq!(
                [r[1], r[2], r[3], r[4], r[5]],
                [c[0], c[1], c[2], c[4], c[5]],
                "combination {k}"
            );
        }
        let col = |i: usize| median(mine.iter().map(|r| num(r[i])).collect());
        assert_eq!(col(6), num(c[7]), "before, combination {k}");
        assert_eq!(col(7), num(c[8]), "after, combination {k}");
        assert_eq!(col(9), num(c[11]), "orientation, combination {k}");
    }
    // gzip: the same rows.
    let gz = sweep("gz", &["--trials-format", "gz"]);
    let mut text = String::new();
    std::io::Read::read_to_string(
        &mut flate2::read::MultiGzDecoder::new(
            std::fs::File::open(gz.join("trials.csv.gz")).unwrap(),
        ),
        &mut text,
    )
    .unwrap();
    assert_eq!(text, trials);
    assert!(!gz.join("trials.csv").exists());
    // Into the gz study's folder as CSV: the stale .gz goes; then
    // --no-trials removes the CSV.
    sweep("gz", &[]);
    assert!(gz.join("trials.csv").is_file() && !gz.join("trials.csv.gz").exists());
    sweep("gz", &["--no-trials"]);
    assert!(!gz.join("trials.csv").exists());
    assert!(gz.join("summary.csv").is_file());
}

/// `sweep.until_decided`: a study whose choice is undecided runs again
/// with more machines (at least twice as many, as many as the open
/// combinations ask, at most `max_trials`) until it decides; its files
/// are those of a plain run of that many machines. `--max-trials`
/// without it, or a bound under `sweep.trials`, is refused.
#[test]
fn an_undecided_hexapod_study_grows_until_it_decides() {
    let t = tempfile::tempdir().unwrap();
    let grows = |s: String| {
        s.replace("position_mm = 0.02", "position_mm = 0.014")
            .replace(
                "trials = 10000\n",
                "trials = 200\nuntil_decided = true\nmax_trials = 5000\n",
            )
    };
    let cfg = with(grows, t.path());
    let run = bin()
        .args(["sweep", "--no-trials", "--config"])
        .arg(&cfg)
        .arg("--out")
        .arg(t.path().join("grown"))
        .assert()
        .success();
    let said = String::from_utf8_lossy(&run.get_output().stderr).to_string();
    assert!(
        said.contains("undecided at 200 machines; running"),
        "{said}"
    );
    let read = |dir: &str, f: &str| std::fs::read(t.path().join(dir).join(f)).unwrap();
    let verdict: serde_json::Value =
        serde_json::from_slice(&read("grown", "verdict.json")).unwrap();
    let machines = verdict["trials"].as_u64().unwrap();
    assert!((400..=5000).contains(&machines), "{machines}");
    assert!(
        verdict["status"] != "undecided" || machines == 5000,
        "{verdict}"
    );
    // The same files as a plain run of that many machines.
    let plain = with(
        |s| s.replace("position_mm = 0.02", "position_mm = 0.014"),
        t.path(),
    );
    bin()
        .args([
            "sweep",
            "-q",
            "--no-trials",
            "--trials",
            &machines.to_string(),
            "--config",
        ])
        .arg(&plain)
        .arg("--out")
        .arg(t.path().join("plain"))
        .assert()
        .success();
    for f in ["summary.csv", "verdict.json", "report.html"] {
        assert!(read("grown", f) == read("plain", f), "{f}");
    }
    // --max-trials bounds until_decided only; a bound under the trials is
    // refused, naming the key.
    let refused = |flags: &[&str], cfg: &Path| {
        let out = bin()
            .arg("sweep")
            .args(flags)
            .arg("--config")
            .arg(cfg)
            .arg("--out")
            .arg(t.path().join("no"))
            .assert()
            .code(2);
        String::from_utf8_lossy(&out.get_output().stderr).to_string()
    };
    let said = refused(&["--max-trials", "3000"], &plain);
    assert!(
        said.contains("--max-trials bounds sweep.until_decided"),
        "{said}"
    );
    let low = with(
        |s| grows(s).replace("max_trials = 5000", "max_trials = 100"),
        t.path(),
    );
    let said = refused(&[], &low);
    assert!(
        said.contains("sweep.max_trials must be from sweep.trials (200)"),
        "{said}"
    );
    assert!(!t.path().join("no").exists());
}
