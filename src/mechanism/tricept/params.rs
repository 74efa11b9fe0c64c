//! The 15 independent geometric errors (docs/method.md §3, Table 2) and the frame gauge
//! that reduces the 21 raw errors to them: ΔzB1 = ΔzB2 = 0, ΔxB2 = ΔxB1,
//! Δz'A1 = Δz'A2 = Δz'A3 = 0, B4 has no error.

use nalgebra::{SVector, Vector3};

/// Number of independent geometric errors.
pub const N_PARAMS: usize = 15;

/// A vector of the 15 errors in canonical order, mm.
pub type ErrorVector = SVector<f64, N_PARAMS>;

/// Canonical names, in Table 2's order.
pub const PARAM_NAMES: [&str; N_PARAMS] = [
    "dxB1", "dyB1", "dyB2", "dxB3", "dyB3", "dzB3", "dxA1", "dyA1", "dxA2", "dyA2", "dxA3", "dyA3",
    "dq1", "dq2", "dq3",
];

/// Table 2 of the paper, mm.
pub const PAPER_ERRORS_MM: [f64; N_PARAMS] = [
    0.2, 0.1, 0.2, 0.2, 0.27, 0.2, 0.25, -0.2, -0.25, 0.25, -0.31, 0.2, 0.45, 0.7, 0.5,
];

/// Index of a canonical name.
pub fn param_index(name: &str) -> Option<usize> {
    PARAM_NAMES.iter().position(|n| *n == name)
}

/// The raw per-limb errors implied by the 15 parameters under the frame gauge.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RawErrors {
    /// ΔBi in the base frame, mm.
    pub db: [Vector3<f64>; 3],
    /// ΔA0i in the platform frame, mm.
    pub da: [Vector3<f64>; 3],
    /// Δqi, mm (actual length = commanded + Δqi).
    pub dq: [f64; 3],
}

/// Expand the 15 independent errors to the raw 21 (docs/method.md §3).
pub fn expand(e: &ErrorVector) -> RawErrors {
    RawErrors {
        db: [
            Vector3::new(e[0], e[1], 0.0),
            Vector3::new(e[0], e[2], 0.0),
            Vector3::new(e[3], e[4], e[5]),
        ],
        da: [
            Vector3::new(e[6], e[7], 0.0),
            Vector3::new(e[8], e[9], 0.0),
            Vector3::new(e[10], e[11], 0.0),
        ],
        dq: [e[12], e[13], e[14]],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn expand_respects_gauge() {
        let e = ErrorVector::from_fn(|i, _| (i + 1) as f64);
        let r = expand(&e);
        assert_eq!(r.db[0].x, r.db[1].x);
        assert_eq!(r.db[0].z, 0.0);
        assert_eq!(r.db[1].z, 0.0);
        assert!(r.da.iter().all(|a| a.z == 0.0));
        assert_eq!(r.dq, [13.0, 14.0, 15.0]);
        assert_eq!(param_index("dzB3"), Some(5));
        assert_eq!(param_index("dzB1"), None);
    }
}
