//! Nominal geometry (docs/method.md §2, Table 1) and a machine = geometry + errors.

use super::params::{expand, ErrorVector};
use nalgebra::{Matrix3, Rotation3, Unit, Vector3};

/// Nominal joint centres: Bi in the base frame, A0i in the platform frame, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    pub b: [Vector3<f64>; 3],
    pub a: [Vector3<f64>; 3],
}

impl Geometry {
    /// Bi = b·(cos βi, sin βi, 0), A0i = a·(cos αi, sin αi, 0).
    pub fn from_circles(
        a_mm: f64,
        b_mm: f64,
        base_angles_deg: [f64; 3],
        platform_angles_deg: [f64; 3],
    ) -> Self {
        let on_circle = |r: f64, deg: f64| {
            let t = deg.to_radians();
            Vector3::new(r * t.cos(), r * t.sin(), 0.0)
        };
        Geometry {
            b: base_angles_deg.map(|d| on_circle(b_mm, d)),
            a: platform_angles_deg.map(|d| on_circle(a_mm, d)),
        }
    }

    /// The paper's Table 1 layout.
    pub fn paper() -> Self {
        Self::from_circles(100.0, 288.7, [-60.0, 60.0, 180.0], [-60.0, 60.0, 180.0])
    }
}

/// Errors of the second class (docs/method.md §3): the identification model assumes
/// them zero; a simulated true machine may carry them to show the bias they
/// cause. The encoders read rotations about the *actual* Hooke axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SecondClass {
    /// First Hooke axis in the base frame (nominally x).
    pub axis1: Unit<Vector3<f64>>,
    /// Second Hooke axis in the frame carried by the first rotation (nominally y).
    pub axis2: Unit<Vector3<f64>>,
    /// Platform rotation about the guide axis z' (guide twist).
    pub twist: Matrix3<f64>,
}

impl SecondClass {
    /// From angles: first axis Rz(yaw)·Ry(pitch)·ex, second axis Rz(skew)·ey
    /// (non-perpendicularity), platform twisted by `twist` about z'.
    pub fn from_angles_deg(yaw: f64, pitch: f64, skew: f64, twist: f64) -> Self {
        let rz = |d: f64| Rotation3::from_axis_angle(&Vector3::z_axis(), d.to_radians());
        let ry = |d: f64| Rotation3::from_axis_angle(&Vector3::y_axis(), d.to_radians());
        SecondClass {
            axis1: Unit::new_normalize(rz(yaw) * ry(pitch) * Vector3::x()),
            axis2: Unit::new_normalize(rz(skew) * Vector3::y()),
            twist: rz(twist).into_inner(),
        }
    }
}

/// A machine: joint centres and leg-length offsets. The nominal machine has
/// `dq = 0`; a true or identified machine carries its errors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Machine {
    pub b: [Vector3<f64>; 3],
    pub a: [Vector3<f64>; 3],
    /// Actual leg length = commanded + dq, mm.
    pub dq: [f64; 3],
    /// Second-class errors of a simulated true machine (None: ideal axes).
    pub second: Option<SecondClass>,
}

impl Machine {
    pub fn nominal(g: &Geometry) -> Self {
        Machine {
            b: g.b,
            a: g.a,
            dq: [0.0; 3],
            second: None,
        }
    }

    /// The nominal geometry plus the 15 errors.
    pub fn with_errors(g: &Geometry, e: &ErrorVector) -> Self {
        let r = expand(e);
        Machine {
            b: [g.b[0] + r.db[0], g.b[1] + r.db[1], g.b[2] + r.db[2]],
            a: [g.a[0] + r.da[0], g.a[1] + r.da[1], g.a[2] + r.da[2]],
            dq: r.dq,
            second: None,
        }
    }
}
