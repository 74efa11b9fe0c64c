//! The error budget in the deciding metric (`decision_budget.csv`): the
//! first-ranked combinations rerun on the same machines with every sensor,
//! and each sensor alone, read exactly. The rerun is paired with the main
//! study (it reproduces its value bit for bit), its parts add up, and the
//! verdict quotes it in the deciding metric's words.

use tricept_calib::config::{parse_raw, Config, Truth};
use tricept_calib::montecarlo::{budget::restricted, run_in_memory};

const STUDY: &str = "[sweep]\nencoder_arcsec = [1.0, 8.0]\nscale_um = [1.0, 6.0]\npose_counts = [17, 51]\ntrials = 300\nvolumetric = true\nvolumetric_grid_step = 60.0\n[decision]\nmetric = \"dv_after_p95_p95\"\nthreshold = 1.0\n";

#[test]
fn the_deciding_metric_s_budget_is_paired_with_the_study_and_adds_up() {
    let cfg = Config::from_raw(parse_raw(STUDY, "t").unwrap(), "t").unwrap();
    let study = cfg.study().build().unwrap();
    let result = run_in_memory(&cfg, &study, 2).unwrap();
    let b = &result.decision_budget;
    assert!(!b.is_empty() && b.len() <= 8, "{}", b.len());
    // The reruns are counted: four studies of one combination each.
    let want = 300 * result.summary.len() as u64 + 4 * 300 * b.len() as u64;
    assert_eq!((result.calibrations, result.computed), (want, want));
    let first = &result.ranking[0];
    assert_eq!(
        (b[0].encoder_arcsec, b[0].scale_um, b[0].pose_count),
        (first.encoder_arcsec, first.scale_um, first.pose_count)
    );
    for row in b {
        assert_eq!(row.measure, "dv_after_p95_p95");
        assert_eq!(row.calibrations, 300);
        let parts = row.floor_mm + row.psi_encoder_mm + row.theta_encoder_mm + row.scale_mm;
        assert!((parts - row.total_mm).abs() < 1e-12, "{row:?}");
        assert!(row.floor_mm > 0.0 && row.floor_mm < row.total_mm, "{row:?}");
    }
    // Paired: the restricted study with the sensors as they are reproduces
    // the main study's value of the combination exactly (same machines,
    // same draws, same pose subset), so the savings are differences on the
    // same machines.
    for r in result.ranking.iter().take(4) {
        let sub = restricted(&study, r, result.trials, [false; 3], Truth::DATASHEET).unwrap();
        let again = run_in_memory(&cfg, &sub, 1).unwrap();
        // (To rounding: the first-order map sums a grade's directions in
        // groups that depend on the grades studied together.)
        let (a, m) = (
            again.summary[0].dv.dv_after_p95_p95.unwrap(),
            result.summary[r.row].dv.dv_after_p95_p95.unwrap(),
        );
        assert!(
            (a - m).abs() < 1e-12 * m,
            "{a} vs {m}: {} {} {}",
            r.encoder_arcsec,
            r.scale_um,
            r.pose_count
        );
        // Every sensor read exactly: the floor, below the study's value.
        let floor = run_in_memory(
            &cfg,
            &restricted(&study, r, result.trials, [true; 3], Truth::DATASHEET).unwrap(),
            1,
        )
        .unwrap();
        assert!(
            floor.summary[0].dv.dv_after_p95_p95.unwrap()
                < result.summary[r.row].dv.dv_after_p95_p95.unwrap()
        );
    }
    // The verdict and verdict.json quote the first-ranked combination's
    // budget in the deciding metric.
    let v = tricept_calib::export::verdict::of(&result);
    let vb = v.budget.as_ref().unwrap();
    assert_eq!(vb.measure, "dv_after_p95_p95");
    assert_eq!(vb.total_mm.to_bits(), b[0].total_mm.to_bits());
    assert_ne!(vb.limiting, "none", "{vb:?}");
    {
        assert!(
            v.text.contains("with that sensor read exactly")
                && v.text.contains(&format!("{:.4} mm", vb.total_mm)),
            "{}",
            v.text
        );
    }
}

/// A ratio metric has no budget in millimetres: none is made, and the
/// verdict falls back on mean μ's.
#[test]
fn a_ratio_metric_gets_the_mean_mu_budget() {
    let cfg = Config::from_raw(
        parse_raw("[sweep]\nencoder_arcsec = [1.0, 8.0]\ntrials = 200\n", "t").unwrap(),
        "t",
    )
    .unwrap();
    let study = cfg.study().build().unwrap();
    let result = run_in_memory(&cfg, &study, 2).unwrap();
    assert!(result.decision_budget.is_empty());
    assert_eq!(
        tricept_calib::export::verdict::of(&result)
            .budget
            .unwrap()
            .measure,
        "mu_mean"
    );
}

/// A catalogue study: the rerun of each first-ranked combination takes
/// that pair's own products (encoder e and scale s of the catalogue,
/// model s·E + e), so it reproduces the study's value; another pair's
/// would not.
#[test]
fn a_catalogue_combination_is_rerun_with_its_own_products() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs");
    let text = format!(
        "[sensors]\nsamples = 3\n[identification]\nmethod = \"gls\"\n[sweep]\ncatalogue = \"{}\"\nencoders = [\"angle-2as-d100\", \"angle-10as-d52\", \"angle-5as-d60\"]\nscales = [\"lin-3um-sp20\", \"lin-1um-sp4\"]\npose_counts = [51]\nmethods = [\"gls\"]\ntrials = 200\nvolumetric = true\nvolumetric_grid_step = 80.0\n[decision]\nmetric = \"dv_after_p95_p95\"\nthreshold = 0.3\n",
        dir.join("sensors.toml").display()
    );
    let cfg = Config::from_raw(parse_raw(&text, "t").unwrap(), "t").unwrap();
    let study = cfg.study().build().unwrap();
    let result = run_in_memory(&cfg, &study, 2).unwrap();
    assert_eq!(result.summary.len(), 6);
    let values: Vec<f64> = result
        .summary
        .iter()
        .map(|s| s.dv.dv_after_p95_p95.unwrap())
        .collect();
    for r in &result.ranking {
        let sub = restricted(&study, r, result.trials, [false; 3], Truth::DATASHEET).unwrap();
        let again = run_in_memory(&cfg, &sub, 1).unwrap();
        assert_eq!(again.summary.len(), 1);
        assert_eq!(
            (&again.summary[0].encoder, &again.summary[0].scale),
            (&r.encoder, &r.scale)
        );
        let (a, m) = (again.summary[0].dv.dv_after_p95_p95.unwrap(), values[r.row]);
        assert!(
            (a - m).abs() < 1e-12 * m,
            "{} + {}: {a} vs {m}",
            r.encoder,
            r.scale
        );
        // Nothing else in the study has this value (the pairs differ).
        assert_eq!(
            values.iter().filter(|v| (*v - m).abs() < 1e-9 * m).count(),
            1
        );
    }
    // Each budget row names its combination, in rank order.
    assert!(!result.decision_budget.is_empty());
    for (b, r) in result.decision_budget.iter().zip(&result.ranking) {
        assert_eq!(
            (&b.encoder, &b.scale, b.method, b.pose_count),
            (&r.encoder, &r.scale, r.method, r.pose_count)
        );
        assert_eq!(b.method, tricept_calib::identify::Method::Gls);
    }
}

/// A Gauss–Newton study is not rerun for the budget (four more studies of
/// iterated calibrations per combination would cost more than the study);
/// the docs say so.
#[test]
fn a_gauss_newton_study_has_no_decision_budget() {
    let text = STUDY
        .replace("[sweep]\n", "[identification]\niterations = 3\n[sweep]\n")
        .replace("trials = 300", "trials = 40");
    let cfg = Config::from_raw(parse_raw(&text, "t").unwrap(), "t").unwrap();
    let study = cfg.study().build().unwrap();
    let result = run_in_memory(&cfg, &study, 2).unwrap();
    assert!(!result.ranking.is_empty());
    assert!(result.decision_budget.is_empty());
}

/// Datasheet sensors with a curve, an interpolation error and jitter (no
/// eccentricity, no quantisation), calibrated by OLS, whose operator does
/// not depend on the sensors: a term read exactly must then be the same
/// study with that term left out of the config.
fn datasheet_study(interpolation: bool, jitter: bool) -> String {
    let (ie, is) = if interpolation {
        (
            "interpolation_arcsec = 1.0\nsignal_period_arcsec = 144.0\n",
            "interpolation_um = 0.2\nsignal_period_um = 20.0\n",
        )
    } else {
        ("", "")
    };
    let (je, js) = if jitter { (0.1, 0.05) } else { (0.0, 0.0) };
    format!(
        "[sensors]\nsamples = 3\n\
         [sensors.encoder]\naccuracy_arcsec = 4.0\nharmonics = [0.8, 0.2]\nnoise_arcsec = {je}\n{ie}\
         [sensors.scale]\naccuracy_um = 2.0\nharmonics = [1.0]\nnoise_um = {js}\n{is}\
         [sweep]\nencoder_arcsec = [0.5]\nscale_um = [0.3]\nmethods = [\"ols\"]\npose_counts = [51]\ntrials = 200\nvolumetric = true\nvolumetric_grid_step = 80.0\n\
         [decision]\nmetric = \"dv_after_p95_p95\"\nthreshold = 5.0\n"
    )
}

fn deciding_value(text: &str) -> (tricept_calib::montecarlo::SweepResult, f64) {
    let cfg = Config::from_raw(parse_raw(text, "t").unwrap(), "t").unwrap();
    let study = cfg.study().build().unwrap();
    let result = run_in_memory(&cfg, &study, 2).unwrap();
    let v = result.summary[0].dv.dv_after_p95_p95.unwrap();
    (result, v)
}

/// The budget by error term: each term read exactly in every sensor on the
/// same machines and draws is the study of sensors without that term (an
/// independent route: the config, not the what-if), a term the sensors lack
/// saves nothing and is not rerun, the shares add up, and the verdict
/// names the term that limits.
#[test]
fn the_budget_by_error_term_is_the_study_without_that_term() {
    let (result, total) = deciding_value(&datasheet_study(true, true));
    let b = &result.decision_budget[0];
    let t = b.terms.expect("datasheet sensors are split by term");
    assert_eq!(b.total_mm.to_bits(), total.to_bits());
    let (_, no_interpolation) = deciding_value(&datasheet_study(false, true));
    let (_, no_jitter) = deciding_value(&datasheet_study(true, false));
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs().max(1e-12);
    let without_interpolation = (b.total_mm - t.saving_interpolation_mm).max(0.0);
    assert!(
        t.saving_interpolation_mm == 0.0 && no_interpolation >= total
            || near(without_interpolation, no_interpolation),
        "interpolation read exactly {without_interpolation} vs the study without it {no_interpolation}"
    );
    assert!(
        t.saving_jitter_mm == 0.0 && no_jitter >= total
            || near(b.total_mm - t.saving_jitter_mm, no_jitter),
        "jitter read exactly {} vs the study without it {no_jitter}",
        b.total_mm - t.saving_jitter_mm
    );
    // The interpolation error of 1″ against a 4″ curve that OLS does not
    // model is a visible part; the term the sensors lack saves nothing.
    assert!(t.saving_interpolation_mm > 0.0, "{t:?}");
    assert_eq!((t.eccentricity_mm, t.saving_eccentricity_mm), (0.0, 0.0));
    assert_eq!(t.present, [true, false, true, true]);
    let shares: f64 = t.shares().iter().sum();
    assert!(
        (b.floor_mm + shares - b.total_mm).abs() < 1e-12,
        "{b:?} {t:?}"
    );
    // Reruns counted: four by sensor, three terms (no eccentricity).
    let rows = result.decision_budget.len() as u64;
    assert_eq!(result.computed, 200 + (4 + 3) * 200 * rows);
    // decision_budget.csv carries both splits, verdict.json the terms.
    let csv = String::from_utf8(
        tricept_calib::export::rows::decision_budget_csv(&result.decision_budget).unwrap(),
    )
    .unwrap();
    let header = csv.lines().next().unwrap();
    for c in [
        "limiting",
        "interpolation_mm",
        "saving_jitter_mm",
        "limiting_term",
    ] {
        assert!(header.split(',').any(|h| h == c), "{header}");
    }
    // The absent eccentricity's columns are empty, not 0, and the verdict
    // does not quote it.
    let cols: Vec<&str> = header.split(',').collect();
    let first: Vec<&str> = csv.lines().nth(1).unwrap().split(',').collect();
    let at = |name: &str| first[cols.iter().position(|c| *c == name).unwrap()];
    assert_eq!(
        (at("eccentricity_mm"), at("saving_eccentricity_mm")),
        ("", "")
    );
    assert!(!at("interpolation_mm").is_empty());
    let v = tricept_calib::export::verdict::of(&result);
    assert_eq!(v.budget_terms, Some(t));
    assert!(!v.text.contains("eccentricity 0."), "{}", v.text);
    if t.limiting_term != "none" {
        assert!(
            v.text.contains(&format!(
                "by error term instead, the {} contributes most",
                t.limiting_term
            )),
            "{}",
            v.text
        );
    }
}

/// The paper's white reading has no terms to split: its budget is by
/// sensor only, and decision_budget.csv leaves the term columns empty.
#[test]
fn a_white_noise_study_is_not_split_by_term() {
    let cfg = Config::from_raw(parse_raw(STUDY, "t").unwrap(), "t").unwrap();
    let study = cfg.study().build().unwrap();
    let result = run_in_memory(&cfg, &study, 2).unwrap();
    assert!(result.decision_budget.iter().all(|b| b.terms.is_none()));
    let csv = String::from_utf8(
        tricept_calib::export::rows::decision_budget_csv(&result.decision_budget).unwrap(),
    )
    .unwrap();
    assert!(csv.lines().nth(1).unwrap().ends_with(",,,,,,,,,"), "{csv}");
}
