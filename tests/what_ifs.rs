//! The buyer's what-ifs: quoted only where they change the sensors (a
//! ring mounted off centre means nothing to an encoder with its own
//! bearing), and run again for the choice at the second-class tolerance
//! it holds to.

use tricept_calib::config::{parse_raw, Config};
use tricept_calib::montecarlo::run_in_memory;

fn study(encoders: &str, tolerances: &str) -> String {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("configs");
    format!(
        "[sensors]\nsamples = 3\n[identification]\nmethod = \"gls\"\n[sweep]\ncatalogue = \"{}\"\nencoders = [{encoders}]\nscales = [\"lin-3um-sp20\"]\npose_counts = [51]\nmethods = [\"gls\"]\ntrials = 120\nvolumetric = true\nvolumetric_grid_step = 80.0\ntruth_eccentricity_um = 5.0\ntruth_white = 2.0\n{tolerances}[decision]\nmetric = \"dv_after_p95_p95\"\nthreshold = 2.0\n",
        dir.join("sensors.toml").display()
    )
}

const ECCENTRIC: &str = "installed encoder rings mounted to 5 µm";

#[test]
fn a_what_if_is_quoted_only_where_it_changes_the_sensors() {
    // angle-5as-d60 has its own bearing (no eccentricity stated);
    // angle-10as-d52 is a ring installed to a stated eccentricity.
    let text = study("\"angle-5as-d60\", \"angle-10as-d52\"", "");
    let cfg = Config::from_raw(parse_raw(&text, "t").unwrap(), "t").unwrap();
    let result = run_in_memory(&cfg, &cfg.study().build().unwrap(), 2).unwrap();
    let rows = |enc: &str| -> Vec<String> {
        result
            .truth
            .iter()
            .filter(|r| r.encoder == enc)
            .map(|r| r.truth.clone())
            .collect()
    };
    let bearing = rows("angle-5as-d60");
    let ring = rows("angle-10as-d52");
    assert!(
        bearing.iter().all(|t| !t.starts_with(ECCENTRIC)),
        "{bearing:?}"
    );
    assert!(
        bearing.iter().any(|t| t.starts_with("white terms")),
        "{bearing:?}"
    );
    assert!(ring.iter().any(|t| t.starts_with(ECCENTRIC)), "{ring:?}");
    // The verdict's what-ifs are the choice's own.
    let v = tricept_calib::export::verdict::of(&result);
    let chosen = &result.ranking[0];
    assert!(chosen.chosen, "{}", v.text);
    let quoted = v.what_ifs.iter().any(|w| w.truth.starts_with(ECCENTRIC));
    assert_eq!(quoted, chosen.encoder == "angle-10as-d52", "{}", v.text);
}

#[test]
fn the_choice_s_what_ifs_run_again_at_its_second_class_tolerance() {
    let text = study(
        "\"angle-10as-d52\"",
        "second_class_tolerance_deg = [0.001, 0.5]\n",
    );
    let cfg = Config::from_raw(parse_raw(&text, "t").unwrap(), "t").unwrap();
    let result = run_in_memory(&cfg, &cfg.study().build().unwrap(), 2).unwrap();
    let v = tricept_calib::export::verdict::of(&result);
    let holds = v.holds_to_deg.expect("holds to a tolerance");
    assert_eq!(
        v.what_ifs_at_tolerance.len(),
        v.what_ifs.len(),
        "{}",
        v.text
    );
    for (w, plain) in v.what_ifs_at_tolerance.iter().zip(&v.what_ifs) {
        assert_eq!(
            w.truth,
            format!("{}, and second-class errors within ±{holds}°", plain.truth)
        );
        // The same machines, sensors and draws with second-class errors on
        // top: not the plain what-if's value.
        assert_ne!(w.value, plain.value, "{w:?}");
    }
    let at = v
        .text
        .find(&format!(
            "With the second-class errors also drawn within ±{holds}°"
        ))
        .unwrap_or_else(|| panic!("{}", v.text));
    // The sentence on meeting every what-if reads the plain what-ifs: it
    // comes before the ones at the tolerance.
    if let Some(robust) = v.text.find("under every one of them") {
        assert!(robust < at, "{}", v.text);
    }
    // The tolerance's own figures still read the tolerance's rows, not the
    // what-ifs run at it.
    let own_tolerance = v
        .second_class
        .iter()
        .find(|s| s.tolerance_deg == holds)
        .unwrap();
    let own = result
        .truth
        .iter()
        .find(|r| r.truth == format!("second-class errors within ±{holds}°"))
        .unwrap();
    assert_eq!(own_tolerance.value, own.dv.dv_after_p95_p95);
}
