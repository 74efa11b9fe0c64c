//! Tests of the repeats of a pose (`repeats.rs`).

use super::*;

#[test]
fn rows_group_by_their_exact_target_in_first_appearance_order() {
    // Targets of width 2: poses A, B, A, C, B, A (−0.0 is 0.0).
    let t = [1.0, 0.0, 2.0, 5.0, 1.0, -0.0, 3.0, 3.0, 2.0, 5.0, 1.0, 0.0];
    let r = Repeats::of(&t, 2);
    assert_eq!(r.first, vec![0, 1, 3]);
    assert_eq!(r.of_row, vec![0, 1, 0, 2, 1, 0]);
    assert_eq!(r.counts, vec![3, 2, 1]);
    assert_eq!(r.repeated(), 3);
    // A target differing in the last bit is another pose.
    let near = [1.0, 0.0, 1.0, f64::from_bits(1)];
    assert_eq!(Repeats::of(&near, 2).repeated(), 0);
    assert!(Repeats::of(&near, 2).note(true, "").is_none());
    let note = r.note(false, "by 0″").unwrap();
    assert!(note.contains("3 of the log's 6 rows") && note.contains("its 3 distinct poses"));
    assert!(note.contains("logged up to 3 times") && note.contains("by 0″"));
    assert!(r.note(true, "").unwrap().contains("counts as a reading"));
}

#[test]
fn means_average_each_pose_readings() {
    let r = Repeats::of(&[1.0, 2.0, 1.0, 1.0], 1);
    // Two readings a row: pose 1 is rows 0, 2, 3; pose 2 is row 1.
    let v = [1.0, 10.0, 7.0, 70.0, 2.0, 20.0, 6.0, 60.0];
    assert_eq!(r.means(&v, 2), vec![3.0, 30.0, 7.0, 70.0]);
    // Pose 1's deviations: −2, −1, 3 and −20, −10, 30; two degrees of
    // freedom (4 rows, 2 poses).
    let (rms, dof) = r.scatter(&v, 2);
    assert_eq!(dof, 2);
    assert!((rms[0] - 7f64.sqrt()).abs() < 1e-12 && (rms[1] - 700f64.sqrt()).abs() < 1e-9);
}

/// The test's level is 1 % shared over a pose's readings, on the
/// scatter in units of σ: 20 poses logged twice, 3 readings a pose of
/// σ 0.01, the first reading scattering between the 1 %/3 and the 1 %
/// points of χ²(20)/20 (fresh), then below the 1 %/3 point (not).
#[test]
fn the_scatter_test_is_at_its_level_in_units_of_sigma() {
    use statrs::distribution::{ChiSquared, ContinuousCDF};
    let targets: Vec<f64> = (0..40).map(|i| (i % 20) as f64).collect();
    let r = Repeats::of(&targets, 1);
    let chi = ChiSquared::new(20.0).unwrap();
    let (third, one) = (
        chi.inverse_cdf(0.01 / 3.0) / 20.0,
        chi.inverse_cdf(0.01) / 20.0,
    );
    let sigma = 0.01;
    // Two rows a pose at ±d: the pooled scatter² is 2d².
    let values = |ratio2: f64| -> Vec<f64> {
        let d0 = (ratio2 * sigma * sigma / 2.0).sqrt();
        let d = sigma / 2f64.sqrt();
        (0..40)
            .flat_map(|row| {
                let sign = if row < 20 { 1.0 } else { -1.0 };
                [7.0 + sign * d0, 3.0 + sign * d, -2.0 + sign * d]
            })
            .collect()
    };
    assert!(r.fresh(&values((third + one) / 2.0), 3, &[sigma]));
    assert!(!r.fresh(&values(third * 0.9), 3, &[sigma]));
    assert!(r.fresh(&values(1.0), 3, &[sigma]));
}

/// The scatter of readings far from zero (an angle of 10⁶ in some
/// unit) is their spread about the pose's mean, computed without the
/// cancellation of Σv² − k·m̄²: deviations of a thousandth come out
/// within 1e-6 of their value (the readings themselves are exact to
/// 1e-10).
#[test]
fn scatter_far_from_zero_is_the_spread_about_the_mean() {
    let r = Repeats::of(&[0.0, 0.0, 0.0, 1.0, 1.0], 1);
    let base = 1.0e6;
    let v = [
        base + 0.001,
        base + 0.002,
        base + 0.004,
        -base,
        -base + 0.003,
    ];
    let (rms, dof) = r.scatter(&v, 1);
    assert_eq!(dof, 3);
    // Pose 0: deviations −4, −1, 5 thousandths/3 from the mean
    // 0.00233…: squares 42/9·1e-6; pose 1: ±0.0015, squares 4.5e-6.
    let want = (((42.0 / 9.0) * 1e-6 + 4.5e-6) / 3.0f64).sqrt();
    assert!(
        (rms[0] - want).abs() < 1e-6 * want,
        "{} against {want}",
        rms[0]
    );
}

/// Fresh draws of σ pass the scatter test at about its 1 % level
/// (none of 200 logs fails it by more than chance); copies and
/// readings scattering a tenth of σ fail it; so does a σ of 0.
#[test]
fn the_scatter_test_tells_fresh_readings_from_copies() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    // 10 poses logged 4 times, 3 readings a pose, σ 2.
    let targets: Vec<f64> = (0..40).map(|i| (i % 10) as f64).collect();
    let r = Repeats::of(&targets, 1);
    let mut rng = rand::rngs::StdRng::seed_from_u64(3);
    let mut failed = 0;
    for _ in 0..200 {
        let v: Vec<f64> = (0..120)
            .map(|i| {
                (i / 3 % 10) as f64 + 2.0 * Distribution::<f64>::sample(&StandardNormal, &mut rng)
            })
            .collect();
        failed += usize::from(!r.fresh(&v, 3, &[2.0]));
        let tenth: Vec<f64> = v.iter().map(|x| x / 10.0).collect();
        assert!(!r.fresh(&tenth, 3, &[2.0]));
        assert!(!r.fresh(&v, 3, &[2.0, 0.0, 2.0]));
    }
    assert!(failed <= 6, "{failed} of 200 fresh logs failed at 1 %");
    // No σ stated: nothing tells fresh readings from copies.
    assert!(!r.fresh(&targets.iter().map(|t| t + 0.5).collect::<Vec<_>>(), 1, &[]));
    let copies: Vec<f64> = (0..120).map(|i| (i / 3 % 10) as f64).collect();
    assert!(!r.fresh(&copies, 3, &[2.0]));
    // Too much scatter is the misfit's to judge: still fresh.
    assert!(r.fresh(
        &copies
            .iter()
            .enumerate()
            .map(|(i, x)| x + (i / 30 % 2) as f64 * 50.0)
            .collect::<Vec<_>>(),
        3,
        &[2.0]
    ));
}

/// The note says the scatter in units of σ at the reading that
/// scatters most so, with its RMS in that reading's own unit, whether
/// the repeats count as fresh, and names what states σ; without a σ
/// for every reading, the largest RMS in its unit.
#[test]
fn the_note_says_the_scatter_in_units_of_sigma_at_the_reading_that_scatters_most() {
    // 2 poses logged twice, 2 readings a pose (an angle in rad, a
    // length in mm): each pose's two readings of the first differ by
    // ±2·s0, of the second by ±6·s1 (no steady offset).
    let r = Repeats::of(&[1.0, 2.0, 1.0, 2.0], 1);
    let (s0, s1) = (1e-5, 2e-3);
    let v = [
        0.0,
        0.0,
        1.0,
        0.0,
        2.0 * s0,
        6.0 * s1,
        1.0 - 2.0 * s0,
        -6.0 * s1,
    ];
    let units = [
        Unit {
            name: "ψ4",
            scale: 206_264.8,
            symbol: "″",
        },
        Unit {
            name: "q4",
            scale: 1e3,
            symbol: " µm",
        },
    ];
    let (counted, note) = r
        .judged((&v, 2), &[s0, s1], "the datasheet", &units)
        .unwrap();
    let note = note.unwrap();
    assert_eq!(counted, Counted::Rows, "{note}");
    // The RMS about each pose's mean over 2 degrees of freedom (4
    // squares): √2·s0 and √18·s1 = 4.24 σ, 8.485 µm, at the second
    // reading, whose σ is 2 µm.
    assert!(
        note.contains("by up to 4.24 σ, at q4 (8.485 µm RMS about their pose's mean over 2 degrees of freedom; σ = 2.000 µm, from the datasheet)"),
        "{note}"
    );
    assert!(note.contains("as fresh readings do"), "{note}");
    // A hundredth of it: copies.
    let small: Vec<f64> = v.iter().map(|x| x / 100.0).collect();
    let (counted, note) = r
        .judged((&small, 2), &[s0, s1], "the datasheet", &units)
        .unwrap();
    let note = note.unwrap();
    assert_eq!(counted, Counted::Once);
    assert!(
        note.contains("by up to 0.04 σ, at q4 (0.085 µm RMS"),
        "{note}"
    );
    assert!(note.contains("less than fresh readings would"), "{note}");
    // One σ missing: the largest RMS in its unit, nothing counted fresh.
    let (counted, note) = r
        .judged((&v, 2), &[s0, 0.0], "the datasheet", &units)
        .unwrap();
    let note = note.unwrap();
    assert_eq!(counted, Counted::Once);
    assert!(
        note.contains("by up to 8.485 µm RMS about their pose's mean, at q4")
            && note.contains("no σ stated"),
        "{note}"
    );
    // No repeat: nothing to say.
    assert_eq!(
        Repeats::of(&[1.0, 2.0], 1).judged((&v[..4], 2), &[s0, s1], "x", &units),
        Ok((Counted::Once, None))
    );
}

/// 30 poses logged twice, one reading, σ 1, fresh noise: the offset
/// test finds nothing at about its 1 % level (200 logs); a steady
/// offset of 2σ on the second logging is found in every log, with its
/// sign, size and Student's t; exact differences (no scatter) with an
/// offset are an offset, without one none.
#[test]
fn the_offset_test_is_at_its_level_and_finds_a_steady_offset() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let targets: Vec<f64> = (0..60).map(|i| (i % 30) as f64).collect();
    let r = Repeats::of(&targets, 1);
    let mut rng = rand::rngs::StdRng::seed_from_u64(5);
    let (mut false_alarms, mut found) = (0, 0);
    for _ in 0..200 {
        let v: Vec<f64> = (0..60)
            .map(|_| Distribution::<f64>::sample(&StandardNormal, &mut rng))
            .collect();
        false_alarms += usize::from(r.offset(&v, 1).is_some());
        let shifted: Vec<f64> = v
            .iter()
            .enumerate()
            .map(|(i, x)| x + if i >= 30 { 2.0 } else { 0.0 })
            .collect();
        if let Some(o) = r.offset(&shifted, 1) {
            assert_eq!((o.reading, o.logging, o.poses), (0, 2, 30));
            assert!(o.t > 0.0 && (o.mean - 2.0).abs() < 1.5, "{o:?}");
            found += 1;
        }
    }
    eprintln!("{false_alarms} of 200 fresh logs flagged");
    assert!(false_alarms <= 6, "{false_alarms} of 200 fresh logs");
    assert_eq!(found, 200);
    // Differences 1, 2, 3 (mean 2, s 1, t = 2√3) among 3 poses: the
    // 0.5 % point of t(2) is 9.92, so no offset; among 300 poses
    // (differences 1, 2, 3 repeated, t = 2/(s/√300)) there is.
    let three = Repeats::of(&[0.0, 1.0, 2.0, 0.0, 1.0, 2.0], 1);
    assert_eq!(three.offset(&[0.0, 0.0, 0.0, 1.0, 2.0, 3.0], 1), None);
    let many: Vec<f64> = (0..600).map(|i| (i % 300) as f64).collect();
    let d: Vec<f64> = (0..600)
        .map(|i| if i < 300 { 0.0 } else { (1 + i % 3) as f64 })
        .collect();
    let o = Repeats::of(&many, 1).offset(&d, 1).unwrap();
    let s = (300.0 * 2.0 / 3.0 / 299.0f64).sqrt();
    assert!((o.mean - 2.0).abs() < 1e-12, "{o:?}");
    assert!((o.t - 2.0 / (s / 300f64.sqrt())).abs() < 1e-9, "{o:?}");
    // No scatter: an offset is one, none is none; a second reading
    // with the stronger offset is the one named.
    assert!(three.offset(&[0.0; 6], 1).is_none());
    let steady = three.offset(&[0.0, 0.0, 0.0, 1.0, 1.0, 1.0], 1).unwrap();
    assert!(steady.t.is_infinite() && steady.mean == 1.0);
    let below = three.offset(&[0.0, 0.0, 0.0, -1.0, -1.0, -1.0], 1).unwrap();
    assert!(
        below.t == f64::NEG_INFINITY && below.mean == -1.0,
        "{below:?}"
    );
    // Differences (1, 1.01, 0.99): t = 173; (3, 3.001, 2.999): 5196.
    let v2 = [
        0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 3.0, 1.01, 3.001, 0.99, 2.999,
    ];
    let o = three.offset(&v2, 2).unwrap();
    assert_eq!(o.reading, 1);
    assert!(
        (o.t - 3.0 / (0.001 / 3f64.sqrt())).abs() < 1e-6 * o.t,
        "{o:?}"
    );
    // Two readings offset alike, each pose's first logging its own
    // values: the first reading is named, its offset the mean of the
    // differences from each pose's own first row (1, 1 ± 2⁻⁷ from
    // whole numbers: exact, the two readings' t equal to the bit).
    let first = [5.0, -7.0, 1.0, 2.0, -3.0, 40.0];
    let d = 1.0 / 128.0;
    let twins: Vec<f64> = first
        .iter()
        .copied()
        .chain(
            first
                .iter()
                .zip([1.0, 1.0, 1.0 + d, 1.0 + d, 1.0 - d, 1.0 - d])
                .map(|(a, e)| a + e),
        )
        .collect();
    let o = three.offset(&twins, 2).unwrap();
    assert_eq!(o.reading, 0);
    assert_eq!(o.mean, 1.0, "{o:?}");
}

/// The offset test's point is Student's t on n − 1 degrees of freedom
/// (n poses logged twice) at 1 % two-sided, shared over the loggings
/// × readings tested: an offset whose t lies just above the point of
/// 2 tests is found (not at a point shared over 3); one whose t lies
/// between the points of 5 and of 4 degrees of freedom is not.
#[test]
fn the_offset_test_s_point_has_its_degrees_of_freedom_and_its_share() {
    use statrs::distribution::{ContinuousCDF, StudentsT};
    let point = |dof: f64, tests: f64| {
        StudentsT::new(0.0, 1.0, dof)
            .unwrap()
            .inverse_cdf(1.0 - 0.005 / tests)
    };
    // 5 poses logged twice, 2 readings a pose; the first reading's
    // differences m + (1, −1, 2, −2, 0): s = √2.5, t = m/(s/√5).
    let targets: Vec<f64> = (0..10).map(|i| (i % 5) as f64).collect();
    let r = Repeats::of(&targets, 1);
    let with_t = |t: f64| -> Vec<f64> {
        let m = t * 2.5f64.sqrt() / 5f64.sqrt();
        let e = [1.0, -1.0, 2.0, -2.0, 0.0];
        (0..10)
            .flat_map(|i| match i < 5 {
                true => [0.0, 0.0],
                false => [m + e[i - 5], 0.0],
            })
            .collect()
    };
    let share = (point(4.0, 2.0) + point(4.0, 3.0)) / 2.0;
    let o = r
        .offset(&with_t(share), 2)
        .expect("beyond the point of 2 tests");
    assert!((o.t - share).abs() < 1e-9 * share, "{o:?}");
    let dof = (point(5.0, 2.0) + point(4.0, 2.0)) / 2.0;
    assert_eq!(r.offset(&with_t(dof), 2), None);
}

/// A steady offset counts each pose at the mean of its loggings
/// where all are logged equally often (the note names the reading, the
/// logging, the offset in the reading's unit and t), and is refused
/// where they are not; the third logging is named as such.
#[test]
fn a_steady_offset_is_counted_at_the_means_or_refused() {
    let units = [Unit {
        name: "q4",
        scale: 1e3,
        symbol: " µm",
    }];
    // 4 poses logged 3 times; the third logging 0.5 µm off.
    let targets: Vec<f64> = (0..12).map(|i| (i % 4) as f64).collect();
    let r = Repeats::of(&targets, 1);
    let v: Vec<f64> = (0..12)
        .map(|i| [0.0, 1e-6, -1e-6, 0.0][i % 4] + if i >= 8 { 5e-4 } else { 0.0 })
        .collect();
    // Copies but for the offset (about it they scatter 0.01 σ):
    // nothing averages, each pose one reading at its mean.
    let (counted, note) = r.judged((&v, 1), &[1e-4], "σ", &units).unwrap();
    let note = note.unwrap();
    assert_eq!(counted, Counted::Once);
    assert!(
        note.contains("logged 3 times each")
            && note.contains(
                "their third logging reads a steady +0.500 µm of q4 off the pose's first"
            )
            && note.contains("over 4 poses")
            && note.contains("at the mean of its 3 loggings, as one reading"),
        "{note}"
    );
    // Fresh noise of σ about the offsets: their means average it.
    // 10 poses logged 3 times, the third logging 5σ off.
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let ten: Vec<f64> = (0..30).map(|i| (i % 10) as f64).collect();
    let fresh: Vec<f64> = (0..30)
        .map(|i| {
            let e: f64 = StandardNormal.sample(&mut rng);
            1e-4 * e + if i >= 20 { 5e-4 } else { 0.0 }
        })
        .collect();
    let (counted, note) = Repeats::of(&ten, 1)
        .judged((&fresh, 1), &[1e-4], "σ", &units)
        .unwrap();
    let note = note.unwrap();
    assert_eq!(counted, Counted::Means(3), "{note}");
    assert!(
        note.contains("third logging reads a steady +0.")
            && note.contains("at the mean of its 3 loggings, its fresh noise stated √3 smaller"),
        "{note}"
    );
    // Taking the offsets out leaves each logging's rows about the
    // first's: the third's less its mean difference.
    let flat = r.without_offsets(&v, 1);
    assert!(flat.iter().zip(&v).take(8).all(|(a, b)| a == b));
    assert!(flat[8..]
        .iter()
        .zip(&v[..4])
        .all(|(a, b)| (a - b).abs() < 1e-15));
    // The first pose logged once more, in the first logging's place:
    // 1 to 4 times.
    let mut t2 = targets.clone();
    t2.push(0.0);
    let mut v2 = v.clone();
    v2.push(0.0);
    let why = Repeats::of(&t2, 1)
        .judged((&v2, 1), &[1e-4], "σ", &units)
        .unwrap_err();
    assert!(
        why.starts_with("its poses' third logging reads a steady +0.500 µm of q4")
            && !why.contains("(1 to 4 times)")
            && why.contains("not all logged equally often (3 to 4 times)"),
        "{why}"
    );
    assert_eq!(
        (1..=4)
            .chain([11, 12, 13, 21, 22, 23, 101, 111])
            .map(ordinal)
            .collect::<Vec<_>>(),
        [
            "first", "second", "third", "4th", "11th", "12th", "13th", "21st", "22nd", "23rd",
            "101st", "111th"
        ]
    );
}
