//! The Tricept's identified geometry as a neutral file (`export --format
//! json`), in the same shape as the hexapod's: the mechanism, units, the
//! convention that fixes what the readings cannot set, each joint nominal
//! and identified, every error with its σ and source, the correlations
//! and identify's checks.

use crate::mechanism::tricept::second_class::{with_angles, ANGLE_NAMES, N_ANGLES};
use crate::mechanism::tricept::{Geometry, Machine, N_PARAMS, PARAM_NAMES};
use crate::store::inputs::IdentifiedModel;
use serde_json::{json, Value};

/// A Tricept's identified model as identified.csv holds it: its 15
/// errors and, when identified, the Hooke axes' angles.
pub type Identified = IdentifiedModel<N_PARAMS, N_ANGLES>;

impl IdentifiedModel<N_PARAMS, N_ANGLES> {
    /// The identified machine on `geometry`.
    pub fn machine(&self, geometry: &Geometry) -> Machine {
        let m = Machine::with_errors(geometry, &self.errors);
        match &self.angles {
            Some(a) => with_angles(&m, a),
            None => m,
        }
    }
}

/// The frame definitions that fix six of the 21 raw errors (docs/method.md
/// §3), in words.
pub const CONVENTION: &str = "B4 (the passive limb's base joint) is the origin; dzB1 = dzB2 = 0 and dxB2 = dxB1 (the base frame); dz'A1 = dz'A2 = dz'A3 = 0 (the platform frame); every error is relative to the reference pose the sensors are homed at";

/// A printed value: −0 as 0.
fn clean(x: f64) -> f64 {
    x + 0.0
}

/// geometry.json of the model identified on `geometry`: `fit` is the
/// identifiability.json identify wrote beside identified.csv (its
/// covariance gives the correlations, its checks are copied; Null when
/// there is none).
pub fn geometry_json(geometry: &Geometry, model: &Identified, fit: &Value) -> Value {
    let m = model.machine(geometry);
    let nominal = Machine::nominal(geometry);
    let v3 = |v: &nalgebra::Vector3<f64>| json!([clean(v.x), clean(v.y), clean(v.z)]);
    let limbs: Vec<Value> = (0..3)
        .map(|i| {
            json!({
                "limb": i + 1,
                "base_nominal_mm": v3(&nominal.b[i]),
                "base_identified_mm": v3(&m.b[i]),
                "platform_nominal_mm": v3(&nominal.a[i]),
                "platform_identified_mm": v3(&m.a[i]),
                "length_offset_mm": clean(m.dq[i]),
            })
        })
        .collect();
    let finite = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    let mut errors: Vec<Value> = (0..N_PARAMS)
        .map(|p| {
            json!({
                "name": PARAM_NAMES[p],
                "unit": "mm",
                "estimate": clean(model.errors[p]),
                "std_uncertainty": finite(model.std_mm[p]),
                "identifiable": model.identifiable[p],
                "source": model.source[p],
            })
        })
        .collect();
    if let Some(a) = &model.angles {
        for (k, name) in ANGLE_NAMES.iter().enumerate() {
            errors.push(json!({
                "name": name,
                "unit": "deg",
                "estimate": clean(a[k]),
                "std_uncertainty": Value::Null,
                "identifiable": true,
                "source": "identified (second class: the passive limb's Hooke axes)",
            }));
        }
    }
    json!({
        "mechanism": "tricept",
        "units": {"length": "mm", "angle": "deg"},
        "convention": CONVENTION,
        "limbs": limbs,
        "errors": errors,
        "correlations": correlations(fit),
        "checks": fit.get("checks").cloned().unwrap_or(Value::Null),
    })
}

/// The correlations of identify's covariance (identifiability.json's
/// `covariance`: `unknowns` and a row-major `matrix`): C_ij/√(C_ii·C_jj),
/// null where a variance is not positive; Null without a covariance.
pub fn correlations(fit: &Value) -> Value {
    let cov = &fit["covariance"];
    let (Some(names), Some(rows)) = (cov["unknowns"].as_array(), cov["matrix"].as_array()) else {
        return Value::Null;
    };
    let m: Vec<Vec<f64>> = rows
        .iter()
        .map(|r| {
            r.as_array()
                .map(|c| c.iter().map(|x| x.as_f64().unwrap_or(f64::NAN)).collect())
                .unwrap_or_default()
        })
        .collect();
    if m.len() != names.len() || m.iter().any(|r| r.len() != names.len()) {
        return Value::Null;
    }
    let matrix: Vec<Vec<Value>> = (0..m.len())
        .map(|i| {
            (0..m.len())
                .map(|j| {
                    let d = m[i][i] * m[j][j];
                    let r = m[i][j] / d.sqrt();
                    if d > 0.0 && r.is_finite() {
                        json!(r.clamp(-1.0, 1.0))
                    } else {
                        Value::Null
                    }
                })
                .collect()
        })
        .collect();
    json!({"names": names, "matrix": matrix})
}
