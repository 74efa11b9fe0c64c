//! What the user holds besides the readings (`[identification] fix` and
//! `prior_std_mm`), honoured by identify, the sweep and the predicted
//! uncertainty. The estimator itself is checked against the constrained
//! least squares with Σ⁻¹ formed outright in the library's tests
//! (`identify/linear_tests.rs`); here its statistics: a prior's posterior
//! covariance is the Monte-Carlo spread of the error when the machines'
//! errors have the prior's variance, a fixed error is held at its value on
//! every machine, and identify writes what it held and why.

mod common;

use common::{bin, identify_cmd, simulate_log, write};
use tricept_calib::config::{parse_raw, Config};
use tricept_calib::io::Source;
use tricept_calib::montecarlo::run_in_memory;

/// Datasheet sensors of unknown curve shape with reading noise (no
/// interpolation error: with machines of micrometres its phase does not
/// change from pose to pose, so it is not the white term Σ takes it for).
const SENSORS: &str = "[sensors]\nsamples = 3\n[sensors.encoder]\naccuracy_arcsec = 5.0\nharmonics = \"unknown\"\ncurve_order = 4\nnoise_arcsec = 0.2\n[sensors.scale]\naccuracy_um = 2.0\nharmonics = \"unknown\"\ncurve_order = 4\nnoise_um = 0.1\n";

fn study(extra: &str) -> tricept_calib::montecarlo::SweepResult {
    let text = format!("{SENSORS}[poses]\nlayers = 1\nring_fractions = [1.0]\npoints_per_ring = 8\n[sweep]\nencoder_arcsec = [5.0]\nscale_um = [2.0]\nmethods = [\"gls\"]\ntrials = 8000\nerrors = \"random\"\nerror_bound = 0.002\nseed = 3\n{extra}");
    let cfg = Config::from_raw(parse_raw(&text, "t").unwrap(), "t").unwrap();
    let s = cfg.study().build().unwrap();
    run_in_memory(&cfg, &s, 2).unwrap()
}

/// Machines of ±2 µm (one linearisation exact). With σp = bound/√3 (the
/// uniform draw's standard deviation) the MAP
/// error's covariance is the posterior (HᵀΣ⁻¹H + I/σp²)⁻¹ exactly, for
/// every error, the ones the readings cannot see included: Monte-Carlo
/// spread over predicted within [0.9, 1.1] for all 15 on a 9-pose single
/// layer that leaves several combinations poorly determined.
#[test]
fn a_prior_s_posterior_is_the_monte_carlo_spread() {
    let sp = 0.002 / 3f64.sqrt();
    let r = study(&format!(
        "[identification]\nmethod = \"gls\"\nprior_std_mm = {sp}\n"
    ));
    let plain = study("[identification]\nmethod = \"gls\"\n");
    assert_eq!(r.parameters.len() % 15, 0);
    let unseen = plain.parameters.iter().filter(|p| !p.identifiable).count();
    assert!(unseen >= 1, "the layout leaves some error unseen");
    for p in &r.parameters {
        assert!(p.identifiable, "{}: the prior holds it", p.parameter);
        assert!(
            (0.9..=1.1).contains(&p.ratio_mc_to_predicted),
            "{}: spread {} predicted {}",
            p.parameter,
            p.mc_std_mm,
            p.predicted_std_mm
        );
        assert!(p.predicted_std_mm <= sp * (1.0 + 1e-9));
    }
    // The prior shrinks what the readings leave: mean μ no worse than the
    // readings alone on the same machines.
    assert!(r.summary[0].mu_mean <= plain.summary[0].mu_mean * 1.001);
}

/// A fixed error is the machine's (every machine carries the measured
/// value) and held: no error in its estimate, and the others identified
/// from what the readings leave.
#[test]
fn a_fixed_error_is_held_on_every_machine() {
    let r = study("[identification]\nmethod = \"gls\"\nfix = { dxB1 = 0.0012, dq3 = -0.002 }\n");
    for p in &r.parameters {
        if p.parameter == "dxB1" || p.parameter == "dq3" {
            assert!(p.identifiable);
            assert_eq!((p.bias_mm, p.mc_std_mm), (0.0, 0.0), "{}", p.parameter);
        }
    }
    let plain = study("[identification]\nmethod = \"gls\"\n");
    assert!(r.summary[0].mu_mean < plain.summary[0].mu_mean);
}

/// identify writes what it held and why (`source`), with no uncertainty
/// stated for a fixed value; compensate takes the file; a prior keeps the
/// error no reading sees at 0 ± σp instead of refusing the log; a prior
/// with another estimator, an unknown name and a fix of every error are
/// refused in one sentence naming the key.
#[test]
fn identify_writes_what_it_held_and_why() {
    let t = tempfile::tempdir().unwrap();
    let conf = |id: &str| {
        format!("{SENSORS}[identification]\n{id}\n[errors]\ndxB1 = 0.0\ndyA2 = -0.03\ndq2 = 0.03\n")
    };
    let cfg = write(
        t.path(),
        "c.toml",
        &conf("method = \"gls\"\nprior_std_mm = 0.05\nfix = { dxB1 = 0.0 }"),
    );
    let readings = t.path().join("r.csv");
    simulate_log(&cfg, &readings);
    let out = t.path().join("id");
    identify_cmd(&cfg, &readings, &out).assert().success();
    let mut rd = csv::Reader::from_path(out.join("identified.csv")).unwrap();
    let rows: Vec<csv::StringRecord> = rd.records().map(|r| r.unwrap()).collect();
    let get = |name: &str| rows.iter().find(|r| &r[0] == name).unwrap().clone();
    let dxb1 = get("dxB1");
    assert_eq!(
        (&dxb1[1], &dxb1[2], &dxb1[3], &dxb1[4]),
        ("0.0", "", "true", "fixed")
    );
    let dya3 = get("dyA3");
    assert_eq!(&dya3[4], "prior", "{dya3:?}");
    let sd: f64 = dya3[2].parse().unwrap();
    assert!((sd / 0.05 - 1.0).abs() < 1e-3, "{sd}");
    assert!(rows.iter().filter(|r| &r[4] == "readings").count() >= 12);
    let targets = write(t.path(), "t.csv", "x_mm,y_mm,z_mm\n0,0,750\n");
    bin()
        .args(["compensate", "--config"])
        .arg(&cfg)
        .arg("--identified")
        .arg(out.join("identified.csv"))
        .arg("--targets")
        .arg(&targets)
        .arg("--out")
        .arg(t.path().join("comp"))
        .assert()
        .success();
    for (edit, key) in [
        (
            "method = \"gls\"\nprior_std_mm = 0.05",
            "identification.prior_std_mm",
        ),
        (
            "method = \"wls\"\nprior_std_mm = 0.05",
            "identification.prior_std_mm",
        ),
        (
            "method = \"gls\"\nfix = { dzz = 1.0 }",
            "identification.fix.dzz",
        ),
        (
            "method = \"gls\"\nprior_std_mm = -1.0",
            "identification.prior_std_mm",
        ),
    ] {
        if edit.contains("gls\"\nprior_std_mm = 0.05") {
            continue;
        }
        let bad = write(t.path(), "bad.toml", &conf(edit));
        let o = bin()
            .args(["identify", "--config"])
            .arg(&bad)
            .arg("--readings")
            .arg(&readings)
            .arg("--out")
            .arg(t.path().join("x"))
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2), "{edit}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains(key) && err.lines().count() == 1,
            "{edit}: {err}"
        );
    }
}

/// A fixed error of 0.2 mm (the machine's true value) is held through the
/// checks too: the held-out folds predict the other poses from what the
/// readings leave once its part is taken out (RMS about 1, not the
/// hundreds a fold reading it as free would give), and the misfit is what
/// the sensors explain.
#[test]
fn the_checks_hold_a_fixed_error_too() {
    let text = format!(
        "{SENSORS}[identification]\nmethod = \"gls\"\nfix = {{ dxB1 = 0.2 }}\n[errors]\ndxB1 = 0.2\ndyA2 = -0.003\ndq2 = 0.003\n"
    );
    let cfg = Config::from_raw(parse_raw(&text, "t").unwrap(), "t").unwrap();
    let poses = cfg.nominal_poses().unwrap();
    let readings = tricept_calib::calibration::simulate(&cfg, &poses, 2, false).unwrap();
    let cal = tricept_calib::calibration::identify_from(&cfg, &readings, Source::new("r.csv", &[]))
        .unwrap();
    let k = tricept_calib::mechanism::tricept::params::param_index("dxB1").unwrap();
    assert_eq!(
        (cal.estimate.values[k], cal.estimate.source[k]),
        (0.2, "fixed")
    );
    let c = tricept_calib::calibration::checks(&cfg, &cal, &readings);
    let h = c.held_out.unwrap();
    assert!(h.rms_z > 0.6 && h.rms_z < 1.5, "{h:?}");
    assert!(!c.misfit.unwrap().rejected, "{:?}", c.misfit);
}

/// Every free error fixed, a prior with a non-GLS sweep estimator, and a
/// prior that is not a finite positive σ are refused in one sentence
/// naming the key.
#[test]
fn impossible_constraints_are_refused_naming_the_key() {
    let all: Vec<String> = tricept_calib::mechanism::tricept::PARAM_NAMES
        .iter()
        .map(|n| format!("{n} = 0.0"))
        .collect();
    for (text, key) in [
        (
            format!("[identification]\nfix = {{ {} }}\n", all.join(", ")),
            "identification.fix",
        ),
        (
            format!("{SENSORS}[identification]\nmethod = \"gls\"\nprior_std_mm = 0.05\n[sweep]\nmethods = [\"wls\", \"gls\"]\n"),
            "sweep.methods",
        ),
        (
            format!("{SENSORS}[identification]\nmethod = \"gls\"\nprior_std_mm = inf\n"),
            "identification.prior_std_mm",
        ),
        (
            "[identification]\nfix = { dxB1 = nan }\n".to_string(),
            "identification.fix.dxB1",
        ),
    ] {
        let err = Config::from_raw(parse_raw(&text, "c.toml").unwrap(), "c.toml")
            .err()
            .unwrap_or_else(|| panic!("accepted: {text}"));
        let msg = err.to_string();
        assert!(msg.contains(key) && msg.lines().count() == 1, "{key}: {msg}");
        assert_eq!(err.exit_code(), 2);
    }
}
