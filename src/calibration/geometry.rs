//! An identified geometry as a neutral file (`export --format json`), for
//! any mechanism of fixed sizes, in the same shape as the hexapod's: the
//! mechanism, units, the convention that fixes what the readings cannot
//! set, its joints nominal and identified, every error with its σ and
//! source, the correlations and identify's checks.

use crate::mechanism::{AxisAngles, Homed, Unknowns};
use crate::store::inputs::IdentifiedModel;
use nalgebra::SVector;
use serde_json::{json, Value};

/// A printed value: −0 as 0.
fn clean(x: f64) -> f64 {
    x + 0.0
}

/// geometry.json of the model identified on `homed`'s layout, its
/// unknowns named by `names`: `fit` is the identifiability.json identify
/// wrote beside identified.csv (its covariance gives the correlations,
/// its checks are copied; Null when there is none).
pub fn geometry_json<T, const P: usize, const R: usize, const A: usize>(
    homed: &Homed<T, P, R>,
    names: &Unknowns<P, A>,
    model: &IdentifiedModel<P, A>,
    fit: &Value,
) -> Value
where
    T: AxisAngles<P, R, A>,
{
    let m = model.machine(homed);
    let nominal = T::machine(homed.layout(), &SVector::zeros());
    let finite = |x: f64| if x.is_finite() { json!(x) } else { Value::Null };
    let mut errors: Vec<Value> = (0..P)
        .map(|p| {
            json!({
                "name": names.errors[p],
                "unit": "mm",
                "estimate": clean(model.errors[p]),
                "std_uncertainty": finite(model.std_mm[p]),
                "identifiable": model.identifiable[p],
                "source": model.source[p],
            })
        })
        .collect();
    if let Some(a) = &model.angles {
        for (k, name) in names.angles.iter().enumerate() {
            errors.push(json!({
                "name": name,
                "unit": "deg",
                "estimate": clean(a[k]),
                "std_uncertainty": Value::Null,
                "identifiable": true,
                "source": format!("identified (second class: {})", names.angles_turn),
            }));
        }
    }
    let mut out = T::joints_json(&nominal, &m);
    for (key, value) in [
        ("mechanism", json!(T::NAME)),
        ("units", json!({"length": "mm", "angle": "deg"})),
        ("convention", json!(T::CONVENTION)),
        ("errors", json!(errors)),
        ("correlations", correlations(fit)),
        ("checks", fit.get("checks").cloned().unwrap_or(Value::Null)),
    ] {
        out.insert(key.to_string(), value);
    }
    Value::Object(out)
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
