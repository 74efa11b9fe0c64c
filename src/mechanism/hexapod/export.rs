//! Controller-ready geometry, and a neutral file for other tools.
//!
//! LinuxCNC's genhexkins takes a hexapod's
//! joints as HAL pins (`genhexkins.base.N.x|y|z`, the U-joints in world
//! coordinates, and `genhexkins.platform.N.x|y|z`, the spherical joints in
//! platform coordinates, N = 0…5 for legs 1…6), set with `setp`; each
//! strut's length at the home pose goes to the INI file's `[JOINT_N]`.

use super::{error_index, Errors, Hexapod, LEGS};
use serde_json::{json, Map, Value};

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

/// What geometry.json says of the hexapod beside its errors: units, which
/// encoders it has, the home pose and each leg's nominal and identified
/// joints, home length and encoder zeros.
pub fn layout(hex: &Hexapod, errors: &Errors) -> Map<String, Value> {
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
    let encoders = match hex.encoders {
        super::Encoders::Both => "both",
        super::Encoders::First => "first",
        super::Encoders::Second => "second",
    };
    let mut map = Map::new();
    map.insert(
        "units".into(),
        json!({"length": "mm", "angle": "deg", "pose": "x, y, z mm; a, b, c deg, R = Rz(c)·Ry(b)·Rx(a)"}),
    );
    map.insert("encoders".into(), encoders.into());
    map.insert("home_pose".into(), json!(hex.home.to_xyzabc().map(clean)));
    map.insert("legs".into(), legs.into());
    map
}
