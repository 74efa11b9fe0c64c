//! Controller-ready geometry, and a neutral file for other tools.
//!
//! LinuxCNC's genhexkins takes a hexapod's
//! joints as HAL pins (`genhexkins.base.N.x|y|z`, the U-joints in world
//! coordinates, and `genhexkins.platform.N.x|y|z`, the spherical joints in
//! platform coordinates, N = 0…5 for legs 1…6), set with `setp`; each
//! strut's length at the home pose goes to the INI file's `[JOINT_N]`.

use super::{error_index, error_names, is_angle, Errors, Hexapod, LEGS};
use serde_json::{json, Value};

/// `genhexkins.hal`: the 36 `setp` lines of the geometry identified as
/// `errors`, full precision (shortest round-trip decimals), mm.
pub fn genhexkins_hal(hex: &Hexapod, errors: &Errors, header: &[String]) -> String {
    let m = hex.actual(errors);
    let mut s = String::new();
    for line in header {
        s += &format!("# {line}\n");
    }
    for (what, joints) in [("base", &m.base), ("platform", &m.platform)] {
        for (n, p) in joints.iter().enumerate() {
            for (k, axis) in ["x", "y", "z"].iter().enumerate() {
                s += &format!("setp genhexkins.{what}.{n}.{axis} {}\n", clean(p[k]));
            }
        }
    }
    s
}

/// `joints.ini`: each joint's home strut length (the nominal length at the
/// home pose plus the identified leg offset), as `HOME` and `HOME_OFFSET`.
pub fn joints_ini(hex: &Hexapod, errors: &Errors, header: &[String]) -> String {
    let home = hex.home_lengths();
    let mut s = String::new();
    for line in header {
        s += &format!("# {line}\n");
    }
    for i in 0..LEGS {
        let l = clean(home[i] + errors[error_index(i, 6)]);
        s += &format!("\n[JOINT_{i}]\nHOME = {l}\nHOME_OFFSET = {l}\n");
    }
    s
}

/// −0 written as 0.
fn clean(x: f64) -> f64 {
    if x == 0.0 {
        0.0
    } else {
        x
    }
}

/// What identify said of its fit, for the neutral file.
pub struct Fit<'a> {
    /// Each error's standard uncertainty (mm or degrees).
    pub std: &'a Errors,
    /// Correlations over the free errors: (names, row-major matrix).
    pub correlations: (Vec<String>, Vec<Vec<f64>>),
    /// identify's checks as it wrote them (identifiability.json's `checks`).
    pub checks: Value,
    pub sources: Vec<&'static str>,
}

/// `geometry.json`: the mechanism, units, convention, each leg's nominal
/// and identified joints, home length and encoder zeros, every error with
/// its σ and source, the correlations, and identify's checks.
pub fn geometry_json(hex: &Hexapod, errors: &Errors, fit: &Fit, convention: &str) -> Value {
    let m = hex.actual(errors);
    let home = hex.home_lengths();
    let v3 = |v: &nalgebra::Vector3<f64>| json!([clean(v.x), clean(v.y), clean(v.z)]);
    let legs: Vec<Value> = (0..LEGS)
        .map(|i| {
            json!({
                "leg": i + 1,
                "base_nominal_mm": v3(&hex.base[i]),
                "base_identified_mm": v3(&m.base[i]),
                "platform_nominal_mm": v3(&hex.platform[i]),
                "platform_identified_mm": v3(&m.platform[i]),
                "home_length_nominal_mm": home[i],
                "home_length_identified_mm": m.offset[i],
                // An encoder the machine does not have: null.
                "encoder_zeros_deg": (0..2)
                    .map(|k| if hex.encoders.reads(k) { json!(clean(m.zeros[i][k])) } else { Value::Null })
                    .collect::<Vec<_>>(),
            })
        })
        .collect();
    let names = error_names();
    let errs: Vec<Value> = hex
        .error_indices()
        .into_iter()
        .map(|j| {
            json!({
                "name": names[j],
                "unit": if is_angle(j) { "deg" } else { "mm" },
                "estimate": clean(errors[j]),
                "std_uncertainty": fit.std[j],
                "source": fit.sources[j],
            })
        })
        .collect();
    json!({
        "mechanism": "hexapod",
        "units": {"length": "mm", "angle": "deg", "pose": "x, y, z mm; a, b, c deg, R = Rz(c)·Ry(b)·Rx(a)"},
        "convention": convention,
        "encoders": match hex.encoders {
            super::Encoders::Both => "both",
            super::Encoders::First => "first",
            super::Encoders::Second => "second",
        },
        "home_pose": hex.home.to_xyzabc().map(clean),
        "legs": legs,
        "errors": errs,
        "correlations": {"names": fit.correlations.0, "matrix": fit.correlations.1},
        "checks": fit.checks,
    })
}
