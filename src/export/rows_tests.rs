use super::*;
use crate::identify::Termination;
use crate::mechanism::tricept::second_class::UNKNOWNS;
use crate::mechanism::tricept::{ErrorVector, N_PARAMS, PARAM_NAMES};
type Estimate = EstimateOf<N_PARAMS>;

#[test]
fn an_unidentifiable_error_has_an_empty_uncertainty_cell() {
    let mut identifiable = [true; N_PARAMS];
    identifiable[N_PARAMS - 1] = false;
    let est = Estimate {
        values: ErrorVector::from_element(0.125),
        // What the solver leaves for an error it cannot identify: 0.
        std_mm: ErrorVector::from_fn(|k, _| if identifiable[k] { 0.002 } else { 0.0 }),
        identifiable,
        source: std::array::from_fn(|k| {
            if identifiable[k] {
                "readings"
            } else {
                "unidentifiable"
            }
        }),
        residual_rms: 1.0,
        dof: 10,
        iterations: 1,
        termination: Termination::SingleLinearisation,
    };
    let truth = ErrorVector::zeros();
    for bytes in [
        identified_csv(&est, &UNKNOWNS, None).unwrap(),
        identified_truth_csv(&est, &truth, &PARAM_NAMES).unwrap(),
    ] {
        let text = String::from_utf8(bytes).unwrap();
        let rows: Vec<Vec<&str>> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').collect())
            .collect();
        assert_eq!(rows.len(), N_PARAMS);
        for (k, row) in rows.iter().enumerate() {
            let want = if k == N_PARAMS - 1 { "" } else { "0.002" };
            assert_eq!(row[2], want, "{text}");
            assert_eq!(row[3], if k == N_PARAMS - 1 { "false" } else { "true" });
        }
    }
}

/// A mechanism that is not the Tricept: an angle and a length a pose,
/// three errors and one second-class angle.
#[derive(Debug, PartialEq)]
struct TwoReadings {
    target: Vector3<f64>,
    x: [f64; 2],
}

const TWO: [ReadingFact; 2] = [
    ReadingFact::named("a", crate::mechanism::Quantity::Angle),
    ReadingFact::named("b", crate::mechanism::Quantity::Length),
];

impl LogRow<2> for TwoReadings {
    const FACTS: &'static [ReadingFact; 2] = &TWO;
    fn target(&self) -> Vector3<f64> {
        self.target
    }
    fn readings(&self) -> SVector<f64, 2> {
        SVector::from(self.x)
    }
    fn new(target: Vector3<f64>, x: &SVector<f64, 2>) -> Self {
        TwoReadings {
            target,
            x: [x[0], x[1]],
        }
    }
}

const TWO_UNKNOWNS: Unknowns<3, 1> = Unknowns {
    errors: ["e0", "e1", "e2"],
    angles: ["tilt"],
    angles_are: "the toy's tilt",
    angle_is: "toy tilt",
    angles_turn: "the test's axes",
    axes: "none",
    beyond: "",
};

/// Another mechanism's log and identified model go out and come back
/// through the same files: its columns are its facts', its rows its
/// names', and each value reads back as written (to the file's
/// decimal rendering).
#[test]
fn another_mechanisms_log_and_fit_read_back_as_written() {
    let log = vec![
        TwoReadings {
            target: Vector3::new(1.0, -2.5, 700.0),
            x: [0.012_345_678_9, 1.25],
        },
        TwoReadings {
            target: Vector3::new(-3.0, 4.0, 650.5),
            x: [-0.003, -7.5],
        },
    ];
    let bytes = readings_csv(&log).unwrap();
    let text = String::from_utf8(bytes.clone()).unwrap();
    assert_eq!(text.lines().next(), Some("x_mm,y_mm,z_mm,a,b"), "{text}");
    let (back, lines): (Vec<TwoReadings>, _) =
        crate::store::inputs::parse_readings("two.csv", &bytes).unwrap();
    assert_eq!(lines, [2, 3]);
    assert_eq!(back.len(), 2);
    for (a, b) in log.iter().zip(&back) {
        assert_eq!(a.target, b.target);
        for k in 0..2 {
            assert!(
                (a.x[k] - b.x[k]).abs() < 1e-15,
                "{k}: {} {}",
                a.x[k],
                b.x[k]
            );
        }
    }
    // Only the facts' columns are a log of it: the Tricept's are not.
    let tricept = "x_mm,y_mm,z_mm,psi4_deg,theta4_deg,q4_mm\n0,0,700,0,0,0\n1,0,700,0,0,0\n";
    assert!(
        crate::store::inputs::parse_readings::<TwoReadings, 2>("t.csv", tricept.as_bytes())
            .is_err()
    );

    let est = EstimateOf::<3> {
        values: SVector::from([0.5, -0.25, 0.0]),
        std_mm: SVector::from([0.01, 0.02, 0.0]),
        identifiable: [true, true, false],
        source: ["readings", "prior", "unidentifiable"],
        residual_rms: 1.0,
        dof: 4,
        iterations: 1,
        termination: Termination::SingleLinearisation,
    };
    let tilt = SVector::from([0.125]);
    let std = SVector::from([0.01]);
    let bytes = identified_csv(
        &est,
        &TWO_UNKNOWNS,
        Some(FittedAngles {
            values: &tilt,
            std_deg: &std,
            identifiable: &[true],
        }),
    )
    .unwrap();
    let m = crate::store::inputs::parse_identified("id.csv", &bytes, 10.0, &TWO_UNKNOWNS).unwrap();
    assert_eq!(m.errors, est.values);
    assert_eq!(m.identifiable, est.identifiable);
    assert_eq!(m.source, est.source);
    assert_eq!(m.std_mm[..2], [0.01, 0.02]);
    assert!(m.std_mm[2].is_nan());
    assert_eq!(m.angles, Some(tilt));
    // Its names are its own: the Tricept's identified.csv is not its.
    let text = String::from_utf8(bytes).unwrap().replace("e1,", "dq1,");
    let err =
        crate::store::inputs::parse_identified("id.csv", text.as_bytes(), 10.0, &TWO_UNKNOWNS)
            .unwrap_err()
            .to_string();
    assert!(
        err.contains(
            "\"dq1\" is not one of the 3 error names (e0, e1, e2) or the toy's tilt (tilt)"
        ),
        "{err}"
    );
}
