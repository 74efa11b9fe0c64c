//! `trials.csv` of any mechanism's study: one row per machine and
//! combination, in machine order and, within a machine, in summary.csv's
//! order of combinations; the numbers each row of summary.csv summarises.
//! The caller stores the rows (plain or gzip, [`crate::store::TrialsFormat`])
//! a block of machines at a time.

use crate::config::general::Spec;
use crate::mechanism::Mechanism;
use crate::montecarlo::general::{Combination, Judged};

/// The header of a mechanism study's trials.csv.
pub const STUDY_TRIALS_HEADER: &str = "trial,encoder,per_joint,encoders_fitted,poses,estimator,position_before_mm,position_after_mm,orientation_before_arcsec,orientation_after_arcsec\n";

/// Bytes a row takes, about (measured on the shipped hexapod study at
/// 2,000 machines: 113 on average), for the size a run announces.
pub const STUDY_TRIALS_ROW_BYTES: u64 = 113;

/// The rows of machines `first_trial ..` (`judged[t][c]`: machine
/// `first_trial + t`, combination `c` of `combinations`). A number that is
/// not finite, or an orientation of a mechanism judged by position alone,
/// is an empty cell.
pub fn trials_rows<M: Mechanism>(
    m: &M,
    spec: &Spec<M::Target, M::Variant>,
    combinations: &[Combination<M::Variant>],
    judged: &[Vec<Judged>],
    first_trial: u64,
) -> String {
    use std::fmt::Write;
    let oriented = m.judged().len() > 1;
    let num = |out: &mut String, x: f64, keep: bool| {
        if keep && x.is_finite() {
            let _ = write!(out, "{x}");
        }
    };
    let mut out = String::with_capacity(judged.len() * combinations.len() * 112);
    for (t, row) in judged.iter().enumerate() {
        for (c, j) in combinations.iter().zip(row) {
            let _ = write!(
                out,
                "{},{},{},{},{},{},",
                first_trial + t as u64,
                spec.sensors[c.sensor].name,
                m.variant_name(c.variant),
                m.fitted(c.variant),
                c.poses,
                c.estimator.name()
            );
            num(&mut out, j.position_before, true);
            out.push(',');
            num(&mut out, j.position_after, true);
            out.push(',');
            num(&mut out, j.orientation_before, oriented);
            out.push(',');
            num(&mut out, j.orientation_after, oriented);
            out.push('\n');
        }
    }
    out
}
