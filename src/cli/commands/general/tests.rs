//! What the commands of any mechanism say, on the Tricept (through
//! `Homed`) and the hexapod.

use super::identifiability_text;
use crate::cli::OutputFormat;
use crate::config::general::HomedConfig;
use crate::config::hexapod::HexapodConfig;
use crate::identify::general::Holds;
use crate::mechanism::tricept::poses::{paper_targets, paper_workspace, pattern};
use crate::mechanism::tricept::{Geometry, Tricept, N_PARAMS, N_READINGS};
use crate::mechanism::Homed;

type T = Homed<'static, Tricept, N_PARAMS, N_READINGS>;

/// The paper's layout leaves dyA3 unseen at any poses: identifiability
/// names it and says to hold it, not to add poses.
#[test]
fn identifiability_names_the_error_no_pose_sees() {
    let g: &'static Geometry = Box::leak(Box::new(Geometry::paper()));
    let cfg = HomedConfig::<T> {
        source: "the paper's Tricept".into(),
        machine: Homed::new(g),
        poses: paper_targets(),
        errors: None,
        sigma: (vec![5.0 / 3600.0, 5.0 / 3600.0, 2e-3], "sensors"),
        holds: Holds::default(),
        study: None,
    };
    let text = identifiability_text(&cfg, OutputFormat::Text).unwrap();
    assert!(
        text.starts_with("tricept, 51 poses, 3 readings each: rank 17 of 18 errors\n"),
        "{text}"
    );
    assert!(
        text.contains("not identified at these poses: dyA3; if more poses do not identify it, hold it at a value (identification.fix)"),
        "{text}"
    );
    assert!(
        !text.contains("combinations no internal sensor sees"),
        "{text}"
    );
}

/// Three hexapod poses give 36 readings for 45 free errors: more poses is
/// the answer, and the convention's errors are not named as unseen.
#[test]
fn too_few_hexapod_poses_ask_for_more_poses() {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/hexapod.toml"),
    )
    .unwrap();
    let mut cfg = HexapodConfig::parse(&text, "configs/hexapod.toml").unwrap();
    cfg.poses.truncate(3);
    cfg.pose_list.truncate(3);
    let said = identifiability_text(&cfg, OutputFormat::Text).unwrap();
    assert!(
        said.contains("9 combinations no internal sensor sees at any poses"),
        "{said}"
    );
    assert!(
        said.contains(
            "9 more these poses leave undetermined (36 readings for 45 free errors): add poses"
        ),
        "{said}"
    );
    assert!(!said.contains("not identified at these poses"), "{said}");
    let json: serde_json::Value =
        serde_json::from_str(&identifiability_text(&cfg, OutputFormat::Json).unwrap()).unwrap();
    assert_eq!(
        (
            json["rank"].as_u64(),
            json["rank_after_convention"].as_u64()
        ),
        (Some(36), Some(36))
    );
}

/// What the config holds at a value leaves the free errors, as identify
/// takes it: identifiability states the rank without it too.
#[test]
fn identifiability_states_the_rank_with_what_the_config_holds() {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/hexapod.toml"),
    )
    .unwrap();
    let mut cfg = HexapodConfig::parse(&text, "configs/hexapod.toml").unwrap();
    let plain = identifiability_text(&cfg, OutputFormat::Text).unwrap();
    assert!(
        plain.contains(
            "after the convention: rank 45 of 45 free errors (every free error identified)\n"
        ),
        "{plain}"
    );
    assert!(!plain.contains("held at a value"), "{plain}");
    // dl1 and dphi2: a leg offset and an encoder zero (error 6 and 16).
    cfg.holds.fixed = vec![(6, 0.01), (16, 0.0)];
    let said = identifiability_text(&cfg, OutputFormat::Text).unwrap();
    assert!(
        said.contains("and with the 2 errors held at a value (identification.fix: dl1, dphi2): rank 43 of 43 free errors (every free error identified)\n"),
        "{said}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&identifiability_text(&cfg, OutputFormat::Json).unwrap()).unwrap();
    assert_eq!(json["held"], serde_json::json!(["dl1", "dphi2"]));
    assert_eq!(
        (
            json["rank_after_convention"].as_u64(),
            json["free_after_held"].as_u64(),
            json["rank_after_held"].as_u64()
        ),
        (Some(45), Some(43), Some(43))
    );
}

/// verify of any mechanism with actuators, on the Tricept through
/// `Homed`: a log of the machine taken with the nominal commands passes
/// the machine's own model told so, and fails the nominal model and the
/// right model told the log was taken with its own commands.
#[test]
fn verify_judges_the_tricept_through_homed_by_its_own_sensors() {
    use super::files::Log;
    use super::verify_text;
    use crate::mechanism::general::predict;
    use crate::mechanism::Commanded;
    let g: &'static Geometry = Box::leak(Box::new(Geometry::paper()));
    let m: T = Homed::new(g);
    let targets = pattern(&paper_workspace(), 2, &[0.5, 1.0], 6);
    let mut e: Vec<f64> = (0..N_PARAMS)
        .map(|i| 0.2 * ((i as f64) * 1.3).sin())
        .collect();
    e.extend([0.01, -0.02, 0.05]);
    let readings = predict(&m, &e, &targets).unwrap().as_slice().to_vec();
    let log = Log {
        file: "the fresh log".into(),
        lines: (2..2 + targets.len() as u64).collect(),
        targets: targets.clone(),
        cells: targets.iter().flat_map(|t| t.iter().copied()).collect(),
        readings,
    };
    let (passed, said) = verify_text(&m, &e, &log, 0.01, true).unwrap();
    assert!(passed, "{said}");
    let within: f64 = said
        .split("within ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .unwrap()
        .parse()
        .unwrap();
    assert!(within < 1e-6, "{said}");
    assert!(
        said.starts_with("26 poses: the identified machine puts the tool point within ")
            && said.contains(" mm of where its sensors say it stood (worst at line ")
            && said.ends_with("; threshold 0.01 mm"),
        "{said}"
    );
    // The uncalibrated model is off by the machine's own errors.
    let zero = vec![0.0; e.len()];
    let (passed, said) = verify_text(&m, &zero, &log, 0.01, true).unwrap();
    assert!(!passed, "{said}");
    // The right model, told the log followed its own (compensated)
    // commands, lands where the nominal commands did not take it.
    let (passed, said) = verify_text(&m, &e, &log, 0.01, false).unwrap();
    assert!(!passed, "{said}");
    // Its compensated commands reach the targets exactly, as its forward
    // kinematics says.
    for t in &targets {
        let q = m.commands(&e, t).unwrap();
        let at = m.reach(&e, &q, t).unwrap();
        assert!(m.miss(&at, t)[0] < 1e-9, "{t}: {:?}", m.miss(&at, t));
    }
    assert_eq!(m.command_columns(), ["q1_mm", "q2_mm", "q3_mm"]);
    // A log whose readings do not fill its rows is refused, not indexed.
    let mut short = log;
    short.readings.pop();
    assert!(verify_text(&m, &e, &short, 0.01, true).is_err());
}

/// A Tricept through `Homed` whose layout lets its readings see every
/// error, at the paper's poses, with errors of up to 0.2 mm and readings
/// of the stated σ `sigma` (file units; empty: none stated).
fn seen_whole(sigma: Vec<f64>) -> HomedConfig<T> {
    let g: &'static Geometry = Box::leak(Box::new(Geometry::from_circles(
        100.0,
        288.7,
        [-60.0, 60.0, 180.0],
        [-30.0, 90.0, 210.0],
    )));
    let mut e: Vec<f64> = (0..N_PARAMS)
        .map(|i| 0.2 * ((i as f64) * 1.3).sin())
        .collect();
    e.extend([0.01, -0.02, 0.05]);
    HomedConfig::<T> {
        source: "a Tricept".into(),
        machine: Homed::new(g),
        poses: paper_targets(),
        errors: Some(e),
        sigma: (sigma, "sensors"),
        holds: Holds::default(),
        study: None,
    }
}

/// identified.csv of `id` in `dir`, and the commands.csv compensate
/// writes from it into `dir`/out.
fn compensated(
    cfg: &HomedConfig<T>,
    id: &crate::identify::general::Identified,
    dir: &std::path::Path,
) -> (std::path::PathBuf, String) {
    let path = dir.join(crate::store::names::IDENTIFIED_CSV);
    std::fs::write(&path, super::files::identified_csv(cfg, id)).unwrap();
    let out = dir.join("out");
    super::run_compensate(cfg, &path, &out, None, false, None).unwrap();
    let text = std::fs::read_to_string(out.join(crate::store::names::COMMANDS_CSV)).unwrap();
    (path, text)
}

/// compensate of any mechanism with actuators, on the Tricept through
/// `Homed` (a layout that sees every error): the identified machine's
/// commands take the simulated machine to its targets, the nominal ones
/// leave it off by its errors; the columns are the mechanism's.
#[test]
fn compensate_corrects_the_tricept_through_homed() {
    use crate::identify::general::identify;
    use crate::mechanism::general::predict;
    let cfg = seen_whole(Vec::new());
    let e = cfg.errors.clone().unwrap();
    let read = predict(&cfg.machine, &e, &cfg.poses).unwrap();
    let sigma = [5.0 / 3600.0, 5.0 / 3600.0, 2e-3];
    let id = identify(
        &cfg.machine,
        &cfg.poses,
        &read,
        30,
        &sigma,
        &Holds::default(),
    )
    .unwrap();
    let t = tempfile::tempdir().unwrap();
    let (_, text) = compensated(&cfg, &id, t.path());
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        "x_mm,y_mm,z_mm,q1_mm,q2_mm,q3_mm,nominal_q1_mm,nominal_q2_mm,nominal_q3_mm,position_before_mm,position_after_mm"
    );
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), cfg.poses.len());
    for r in &rows {
        assert!(r[10] < 1e-6, "after {:e} mm", r[10]);
        assert!(r[9] > 1e-2, "before {} mm", r[9]);
    }
}

/// On the paper's layout no reading sees dyA3: a config that holds it
/// compensates a simulated machine (held at the machine's own value when
/// put in the convention's frames), where without the hold the fit is
/// refused in a sentence.
#[test]
fn compensate_holds_what_no_reading_sees() {
    use super::run_compensate;
    use crate::identify::general::identify;
    use crate::mechanism::general::predict;
    const DYA3: usize = 11;
    let g: &'static Geometry = Box::leak(Box::new(Geometry::paper()));
    let mut e: Vec<f64> = (0..N_PARAMS)
        .map(|i| 0.2 * ((i as f64) * 1.3).sin())
        .collect();
    e.extend([0.01, -0.02, 0.05]);
    let holds = Holds {
        fixed: vec![(DYA3, e[DYA3])],
        ..Holds::default()
    };
    let mut cfg = HomedConfig::<T> {
        source: "the paper's Tricept".into(),
        machine: Homed::new(g),
        poses: paper_targets(),
        errors: Some(e.clone()),
        sigma: (Vec::new(), "sensors"),
        holds: holds.clone(),
        study: None,
    };
    let read = predict(&cfg.machine, &e, &cfg.poses).unwrap();
    let sigma = [5.0 / 3600.0, 5.0 / 3600.0, 2e-3];
    let id = identify(&cfg.machine, &cfg.poses, &read, 30, &sigma, &holds).unwrap();
    let t = tempfile::tempdir().unwrap();
    let (path, text) = compensated(&cfg, &id, t.path());
    for l in text.lines().skip(1) {
        let after: f64 = l.split(',').nth(10).unwrap().parse().unwrap();
        assert!(after < 1e-6, "{l}");
    }
    cfg.holds = Holds::default();
    let refused = run_compensate(&cfg, &path, &t.path().join("again"), None, false, None)
        .unwrap_err()
        .to_string();
    assert!(
        refused.contains("cannot be put in the convention's frames at these poses"),
        "{refused}"
    );
}

/// export --format json of any mechanism, on the Tricept through `Homed`
/// (a mechanism that states no layout): geometry.json holds the
/// mechanism's name and convention, each error as identified.csv has it
/// with its σ and source, the correlations identify wrote and its checks,
/// and the units; a log of another mechanism's identify is refused.
#[test]
fn export_json_of_any_mechanism_is_identify_s_fit() {
    use crate::mechanism::Mechanism as _;
    let cfg = seen_whole(vec![5.0 / 3600.0, 5.0 / 3600.0, 2e-3]);
    let t = tempfile::tempdir().unwrap();
    let log = t.path().join(crate::store::names::READINGS_CSV);
    super::run_simulate(&cfg, 7, false, &log).unwrap();
    let id = t.path().join("id");
    super::run_identify(&cfg, &log, &id).unwrap();
    let identified = id.join(crate::store::names::IDENTIFIED_CSV);
    let out = t.path().join("geometry");
    super::run_export_json(&cfg, &identified, &out, false).unwrap();
    let read = |p: std::path::PathBuf| -> serde_json::Value {
        serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
    };
    let geo = read(out.join(crate::store::names::GEOMETRY_JSON));
    let fit = read(id.join(crate::store::names::IDENTIFIABILITY_JSON));
    let m = &cfg.machine;
    assert_eq!(geo["mechanism"], m.name());
    assert_eq!(geo["convention"], m.convention());
    assert_eq!(geo["units"]["length"], "mm");
    assert_eq!(geo["checks"], fit["checks"]);
    assert_eq!(geo["correlations"]["names"], fit["correlations"]["names"]);
    assert_eq!(geo["correlations"]["matrix"], fit["correlations"]["matrix"]);
    let estimates = super::files::read_identified(m, &identified).unwrap();
    let std = super::files::read_std(m, &identified).unwrap();
    let errors = geo["errors"].as_array().unwrap();
    let names = m.error_names();
    assert_eq!(errors.len(), names.len());
    for (j, x) in errors.iter().enumerate() {
        assert_eq!(x["name"], names[j].as_str());
        // serde_json reads a float back to within an ulp.
        let near = |a: f64, b: f64| (a - b).abs() <= 1e-15 * b.abs().max(1e-300);
        assert!(near(x["estimate"].as_f64().unwrap(), estimates[j]), "{x}");
        assert!(near(x["std_uncertainty"].as_f64().unwrap(), std[j]), "{x}");
        assert_eq!(x["source"], m.error_source(j));
        assert_eq!(x["unit"], if m.is_angle(j) { "deg" } else { "mm" });
    }
    assert!(errors
        .iter()
        .any(|x| x["estimate"].as_f64().unwrap().abs() > 0.05));
    // A hexapod's identify output is not this mechanism's.
    let mut other = fit.clone();
    other["mechanism"] = "hexapod".into();
    std::fs::write(
        id.join(crate::store::names::IDENTIFIABILITY_JSON),
        serde_json::to_vec(&other).unwrap(),
    )
    .unwrap();
    let refused = super::run_export_json(&cfg, &identified, &t.path().join("no"), false)
        .unwrap_err()
        .to_string();
    assert!(refused.contains("is not a"), "{refused}");
    assert!(!t.path().join("no").exists());
}
