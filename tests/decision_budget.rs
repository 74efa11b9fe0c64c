//! The error budget in the deciding metric (`decision_budget.csv`): the
//! first-ranked combinations rerun on the same machines with every sensor,
//! and each sensor alone, read exactly. The rerun is paired with the main
//! study (it reproduces its value bit for bit), its parts add up, and the
//! verdict quotes it in the deciding metric's words.

use tricept_calib::config::{parse_raw, Config};
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
        let sub = restricted(&study, r, result.trials, [false; 3]).unwrap();
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
            &restricted(&study, r, result.trials, [true; 3]).unwrap(),
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
        let sub = restricted(&study, r, result.trials, [false; 3]).unwrap();
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
