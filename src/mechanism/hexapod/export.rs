//! Controller-ready geometry: LinuxCNC's genhexkins takes a hexapod's
//! joints as HAL pins (`genhexkins.base.N.x|y|z`, the U-joints in world
//! coordinates, and `genhexkins.platform.N.x|y|z`, the spherical joints in
//! platform coordinates, N = 0…5 for legs 1…6), set with `setp`; each
//! strut's length at the home pose goes to the INI file's `[JOINT_N]`.

use super::{error_index, Errors, Hexapod, LEGS};

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
