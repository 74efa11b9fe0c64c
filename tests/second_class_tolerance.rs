//! `[sweep] second_class_tolerance_deg`: what-if studies whose machines
//! draw the four second-class errors within ± each tolerance. Their rows,
//! the verdict's tolerance, and the draw itself.

use tricept_calib::config::{parse_raw, Config};
use tricept_calib::montecarlo::run_in_memory;
use tricept_calib::montecarlo::tricept::second_class_draw;

const STUDY: &str = "\
[sensors]
samples = 3
[sensors.encoder]
accuracy_arcsec = 2.0
harmonics = \"unknown\"
noise_arcsec = 0.02
[sensors.scale]
accuracy_um = 1.0
harmonics = \"unknown\"
noise_um = 0.01
[identification]
method = \"gls\"
[sweep]
encoder_arcsec = [1.0, 10.0]
scale_um = [1.0]
methods = [\"gls\"]
trials = 600
volumetric = true
volumetric_grid_step = 100.0
second_class_tolerance_deg = [0.0005, 0.002, 0.02]
[decision]
metric = \"dv_after_p95_p95\"
threshold = 0.15
";

fn result(text: &str, threads: usize) -> tricept_calib::montecarlo::SweepResult {
    let cfg = Config::from_raw(parse_raw(text, "t").unwrap(), "t").unwrap();
    let study = cfg.study().build().unwrap();
    run_in_memory(&cfg, &study, threads).unwrap()
}

/// Rows per tolerance, labelled; the accuracy worsens as the tolerance
/// grows for every combination; the verdict names the largest tolerance
/// its choice survives, which the rows confirm; the bytes do not depend on
/// the thread count.
#[test]
fn tolerance_rows_and_the_tolerance_the_verdict_names() {
    let r = result(STUDY, 2);
    assert_eq!(r.tolerances.len(), 3);
    for enc in [1.0, 10.0] {
        let mut last = 0.0;
        let base = r
            .summary
            .iter()
            .find(|s| s.encoder_arcsec == enc)
            .unwrap()
            .dv
            .dv_after_p95_p95
            .unwrap();
        for deg in [0.0005, 0.002, 0.02] {
            let row = r
                .truth
                .iter()
                .find(|s| s.encoder_arcsec == enc && s.second_class_deg == Some(deg))
                .unwrap();
            assert_eq!(row.truth, format!("second-class errors within ±{deg}°"));
            let v = row.dv.dv_after_p95_p95.unwrap();
            assert!(v > last && v > base, "{enc}″ at ±{deg}°: {v} after {last}");
            last = v;
        }
    }
    let v = tricept_calib::export::verdict::of(&r);
    assert_eq!(v.status, "buy", "{}", v.text);
    let c = v.choice.as_ref().unwrap();
    // The verdict's tolerance is the largest at which the choice's own row
    // (and every smaller tolerance's) meets the target.
    let meets = |deg: f64| {
        r.truth
            .iter()
            .find(|s| {
                s.second_class_deg == Some(deg)
                    && s.encoder_arcsec == c.encoder_arcsec
                    && s.pose_count == c.poses
            })
            .unwrap()
            .meets_target
    };
    assert!(meets(0.0005) && meets(0.002) && !meets(0.02));
    assert_eq!(v.holds_to_deg, Some(0.002));
    assert!(
        v.text
            .contains("It holds if the UP limb's Hooke-joint axes and guide are within ±0.002°"),
        "{}",
        v.text
    );
    assert!(v.text.contains("within ±0.02°, none"), "{}", v.text);
    // Same seed, same numbers, whatever the thread count.
    let one = result(STUDY, 1);
    let key = |x: &tricept_calib::montecarlo::SweepResult| {
        x.truth
            .iter()
            .map(|s| (s.mu_mean.to_bits(), s.dv.dv_after_p95_p95.map(f64::to_bits)))
            .collect::<Vec<_>>()
    };
    assert_eq!(key(&r), key(&one));
}

/// Each machine's four angles are uniform in ±t: within the bound, mean 0,
/// variance t²/3 (checked through the axes they build: yaw and the guide's
/// twist read back from the unit vectors and the twist matrix).
#[test]
fn the_second_class_draw_is_uniform_within_the_tolerance() {
    let t = 0.01;
    let n = 20_000;
    let (mut sum, mut sq) = (0.0, 0.0);
    for k in 0..n {
        let sc = second_class_draw(7, k, t);
        let yaw = sc.axis1.y.atan2(sc.axis1.x).to_degrees();
        let twist = sc.twist[(1, 0)].atan2(sc.twist[(0, 0)]).to_degrees();
        for a in [yaw, twist] {
            assert!(a.abs() <= t * (1.0 + 1e-9), "{a}");
            sum += a;
            sq += a * a;
        }
    }
    let m = (2 * n) as f64;
    let (mean, var) = (sum / m, sq / m);
    let sd_mean = (t * t / 3.0 / m).sqrt();
    assert!(mean.abs() < 5.0 * sd_mean, "{mean}");
    assert!((var / (t * t / 3.0) - 1.0).abs() < 0.03, "{var}");
}

/// A tolerance list beside a fixed [second_class] is refused, and so is an
/// unordered or out-of-range list.
#[test]
fn tolerance_lists_are_checked() {
    for (extra, words) in [
        ("[sweep]\nsecond_class_tolerance_deg = [0.002, 0.001]\n", "increasing"),
        ("[sweep]\nsecond_class_tolerance_deg = [0.0]\n", "(0, 1]"),
        (
            "[second_class]\nguide_twist_deg = 0.01\n[sweep]\nsecond_class_tolerance_deg = [0.001]\n",
            "keep one of the two",
        ),
    ] {
        let err = Config::from_raw(parse_raw(extra, "t.toml").unwrap(), "t.toml")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("sweep.second_class_tolerance_deg") && err.contains(words),
            "{err}"
        );
    }
}
