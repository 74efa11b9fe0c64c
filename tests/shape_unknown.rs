//! `harmonics = "unknown"` (a curve of some shape bounded by the grade,
//! holding the first K harmonics in unknown proportion), mounting
//! eccentricity and two readheads, against what GLS claims of them: its
//! predicted covariance is the Monte-Carlo spread of its estimates, and a
//! finer grade or more poses never does worse.

mod common;

use common::{bin, write};
use proptest::prelude::*;
use proptest::test_runner::{Config as ProptestConfig, RngSeed};
use tricept_calib::config::{parse_raw, Config};
use tricept_calib::metrics::GradeSummary;
use tricept_calib::montecarlo::run_in_memory;

/// Three unknown shapes of different orders, one encoder with a ring
/// eccentricity, the other read by two heads; small geometric errors so
/// that one linearisation is exact to well under the sensors' share.
const SPREAD_STUDY: &str = "\
[sensors]
samples = 3
[sensors.encoder_psi]
accuracy_arcsec = 5.0
harmonics = \"unknown\"
noise_arcsec = 0.2
eccentricity_um = 1.0
ring_diameter_mm = 100.0
[sensors.encoder_theta]
accuracy_arcsec = 5.0
harmonics = \"unknown\"
curve_order = 4
readheads = 2
noise_arcsec = 0.2
[sensors.scale]
accuracy_um = 2.0
harmonics = \"unknown\"
curve_order = 3
noise_um = 0.1
[identification]
method = \"gls\"
[sweep]
encoder_arcsec = [5.0]
scale_um = [2.0]
methods = [\"ols\", \"wls\", \"gls\"]
trials = 8000
errors = \"random\"
error_bound = 0.002
seed = 3
";

/// Every identifiable estimate's Monte-Carlo spread over its predicted
/// standard deviation is within [0.9, 1.1] for all three estimators (the
/// predictions are op·Σ·opᵀ with Σ the shape-unknown covariance, GLS's
/// (HᵀΣ⁻¹H)⁻¹), and GLS's spread is below WLS's by 10 % or more for most.
#[test]
fn the_spread_is_the_predicted_covariance_when_the_shape_is_unknown() {
    let t = tempfile::tempdir().unwrap();
    let cfg = write(t.path(), "spread.toml", SPREAD_STUDY);
    let out = t.path().join("out");
    bin()
        .args([
            "sweep",
            "--config",
            cfg.to_str().unwrap(),
            "--no-trials",
            "--out",
        ])
        .arg(&out)
        .assert()
        .success();
    let mut r = csv::Reader::from_path(out.join("parameters.csv")).unwrap();
    let h = r.headers().unwrap().clone();
    let col = |n: &str| h.iter().position(|x| x == n).unwrap();
    let (m, p, id, mc, ratio) = (
        col("method"),
        col("parameter"),
        col("identifiable"),
        col("mc_std_mm"),
        col("ratio_mc_to_predicted"),
    );
    let mut spread = std::collections::HashMap::new();
    let mut checked = 0;
    for rec in r.records() {
        let rec = rec.unwrap();
        if &rec[id] != "true" {
            continue;
        }
        spread.insert(
            (rec[m].to_string(), rec[p].to_string()),
            rec[mc].parse::<f64>().unwrap(),
        );
        let q: f64 = rec[ratio].parse().unwrap();
        assert!(
            (0.9..=1.1).contains(&q),
            "{} {}: Monte-Carlo/predicted = {q}",
            &rec[m],
            &rec[p]
        );
        checked += 1;
    }
    assert_eq!(checked, 3 * 14, "14 identifiable errors per estimator");
    let better = spread
        .iter()
        .filter(|((m, _), _)| m == "gls")
        .filter(|((_, p), &g)| g < 0.9 * spread[&("wls".to_string(), p.clone())])
        .count();
    assert!(better >= 12, "GLS beats WLS by 10 % on {better} of 14");
}

fn study_summary(text: &str) -> Vec<GradeSummary> {
    let cfg = Config::from_raw(parse_raw(text, "t").unwrap(), "t").unwrap();
    let study = cfg.study().build().unwrap();
    run_in_memory(&cfg, &study, 2).unwrap().summary
}

/// A grade study of unknown shapes of order `k` (the encoders with
/// eccentricity `ecc` µm and `heads` heads) over two grades of each sensor
/// and three pose counts, GLS.
fn shape_study(k: u32, ecc: f64, heads: u32, jitter: f64, bound: f64, seed: u64) -> String {
    format!(
        "[sensors]\nsamples = 3\n\
         [sensors.encoder]\naccuracy_arcsec = 4.0\nharmonics = \"unknown\"\ncurve_order = {k}\n\
         noise_arcsec = {je}\neccentricity_um = {ecc}\nring_diameter_mm = 80.0\nreadheads = {heads}\n\
         [sensors.scale]\naccuracy_um = 2.0\nharmonics = \"unknown\"\ncurve_order = {k}\nnoise_um = {js}\n\
         [identification]\nmethod = \"gls\"\n\
         [sweep]\nencoder_arcsec = [1.0, 5.0]\nscale_um = [0.5, 3.0]\npose_counts = [9, 17, 51]\n\
         methods = [\"gls\"]\ntrials = 1500\nerrors = \"random\"\nerror_bound = {bound}\nseed = {seed}\n",
        je = jitter,
        js = jitter / 5.0,
    )
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 5,
        rng_seed: RngSeed::Fixed(27),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// On common random numbers, a finer grade (the eccentricity is the
    /// mounting's, the same for both) or a superset of the poses never
    /// gives a worse GLS mean μ beyond the coarser one's 95 % confidence
    /// interval, for random curve orders, mountings and jitter.
    #[test]
    fn gls_never_does_worse_with_finer_sensors_or_more_poses_when_the_shape_is_unknown(
        k in 1u32..12,
        ecc in prop_oneof![Just(0.0f64), 0.1f64..2.0],
        heads in 1u32..=2,
        jitter in 0.0f64..0.5,
        large in any::<bool>(),
        seed in 1u64..1000,
    ) {
        let bound = if large { 0.5 } else { 0.05 };
        let rows = study_summary(&shape_study(k, ecc, heads, jitter, bound, seed));
        let mut pairs = Vec::new();
        for a in &rows {
            for b in &rows {
                let same = a.encoder_arcsec == b.encoder_arcsec && a.scale_um == b.scale_um;
                let finer = a.pose_count == b.pose_count
                    && a.encoder_arcsec <= b.encoder_arcsec
                    && a.scale_um <= b.scale_um
                    && !same;
                if finer || (same && a.pose_count > b.pose_count) {
                    pairs.push((a, b));
                }
            }
        }
        prop_assert_eq!(pairs.len(), 4 * 3 + 5 * 3);
        let worst = pairs
            .iter()
            .map(|(a, b)| a.mu_mean - b.mu_mean_ci_high)
            .fold(f64::NEG_INFINITY, f64::max);
        prop_assert!(worst <= 0.0, "a finer grade or more poses did worse by {} mm", worst);
    }
}

/// What a datasheet cannot say is refused by key: an unknown curve order
/// out of range, a curve order with a listed shape, an eccentricity without
/// the ring's diameter, three readheads, a harmonics word other than
/// "unknown".
#[test]
fn shape_and_mounting_keys_are_checked() {
    let base = "[sensors.encoder]\naccuracy_arcsec = 2.0\n";
    for (extra, key, words) in [
        (
            "harmonics = \"unknown\"\ncurve_order = 0\n",
            "sensors.encoder.curve_order",
            "from 1 to 32",
        ),
        (
            "harmonics = \"unknown\"\ncurve_order = 33\n",
            "sensors.encoder.curve_order",
            "from 1 to 32",
        ),
        (
            "harmonics = [1.0]\ncurve_order = 4\n",
            "sensors.encoder.curve_order",
            "needs harmonics = \"unknown\"",
        ),
        (
            "harmonics = \"some\"\n",
            "sensors.encoder.harmonics",
            "\"unknown\"",
        ),
        (
            "eccentricity_um = 2.0\n",
            "sensors.encoder.ring_diameter_mm",
            "412·e/D",
        ),
        (
            "readheads = 3\n",
            "sensors.encoder.readheads",
            "must be 1 or 2",
        ),
        (
            "eccentricity_um = -1.0\n",
            "sensors.encoder.eccentricity_um",
            "between 0 and 1000",
        ),
    ] {
        let text = format!("{base}{extra}");
        let err = Config::from_raw(parse_raw(&text, "t.toml").unwrap(), "t.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains(key) && err.contains(words), "{extra}: {err}");
    }
    // The datasheet's word is accepted, and curve_order defaults to 6.
    let cfg = Config::from_raw(
        parse_raw(&format!("{base}harmonics = \"unknown\"\n"), "t").unwrap(),
        "t",
    )
    .unwrap();
    let st = cfg.sensors.structured.unwrap();
    assert_eq!(st.axes[0].n_harmonics, 6);
}
