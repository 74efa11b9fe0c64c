//! What no internal sensor sees, and the convention that fixes it.
//!
//! Translating the whole machine (every U-joint centre by one vector, 3
//! combinations) and choosing another platform frame (a rigid motion of the
//! spherical-joint centres, 6) leave every leg vector, and so every
//! reading, as it was: at most 45 of the 54 errors are identifiable (39 of
//! 48 with one encoder a joint). The convention: b_1 and p_1 stay nominal,
//! p_2 moves only along p_1→p_2, and p_3 only in the plane of p_1, p_2, p_3.
//! Rotations of the base are not among them: the encoders' axes are fixed
//! in {O}, so they see them.

use super::{error_index, Hexapod, N_ERRORS};
use nalgebra::{DMatrix, Vector3};

/// The convention's words, for reports and identified.csv.
pub const CONVENTION: &str = "b1 and p1 nominal; p2 moves only along p1→p2; p3 only in the plane of p1, p2, p3 (what no internal sensor sees: a translation of the machine and the choice of the platform frame)";

/// The free directions of the errors under the convention: a basis N
/// (errors × free, orthonormal columns) with every admissible error vector
/// N·y, over the errors the machine has ([`Hexapod::error_indices`]).
pub fn basis(hex: &Hexapod) -> DMatrix<f64> {
    let present = hex.error_indices();
    let p = &hex.platform;
    let u = (p[1] - p[0]).normalize();
    let in_plane = {
        let d = p[2] - p[0];
        (d - u * u.dot(&d)).normalize()
    };
    let mut cols: Vec<Vec<(usize, f64)>> = Vec::new();
    let block = |leg: usize, v: &Vector3<f64>| -> Vec<(usize, f64)> {
        (0..3).map(|k| (error_index(leg, 3 + k), v[k])).collect()
    };
    for &j in &present {
        let (leg, e) = (j / super::PER_LEG, j % super::PER_LEG);
        match (leg, e) {
            // b_1, p_1 nominal.
            (0, 0..=5) => {}
            // p_2 along p1→p2: one column for its block.
            (1, 3) => cols.push(block(1, &u)),
            (1, 4 | 5) => {}
            // p_3 in the plane: two.
            (2, 3) => {
                cols.push(block(2, &u));
                cols.push(block(2, &in_plane));
            }
            (2, 4 | 5) => {}
            _ => cols.push(vec![(j, 1.0)]),
        }
    }
    let mut n = DMatrix::zeros(N_ERRORS, cols.len());
    for (c, entries) in cols.iter().enumerate() {
        for &(r, v) in entries {
            n[(r, c)] = v;
        }
    }
    n
}

pub use crate::mechanism::general::{column_of, error_of};

/// Which of the 54 errors the convention holds at nominal outright (b_1,
/// p_1), and which it confines to a direction (p_2, p_3).
pub fn source(index: usize) -> &'static str {
    match (index / super::PER_LEG, index % super::PER_LEG) {
        (0, 0..=5) => "convention",
        (1, 3..=5) => "identified along p1→p2",
        (2, 3..=5) => "identified in the plane of p1, p2, p3",
        _ => "identified",
    }
}
