//! The rows of every table a command writes (CSV columns are the field
//! names) and the functions that render them.

use super::{csv_bytes, Exporter, JsonExporter};
use crate::calibration::AxesAnalysis;
use crate::compensate::{Stats, VolumetricMap};
use crate::error::Result;
use crate::identify::{EstimateOf, Identifiability, Method};
use crate::mechanism::{LogRow, ReadingFact, Unknowns};
use crate::store::inputs::TARGET_COLUMNS;
use nalgebra::{SVector, Vector3};
use serde::Serialize;

/// A row of readings.csv: the target's columns, then each of the
/// mechanism's readings in its file unit under its column
/// ([`LogRow::FACTS`]).
struct ReadingRow<const R: usize> {
    target: Vector3<f64>,
    readings: [f64; R],
    facts: &'static [ReadingFact; R],
}

impl<const R: usize> Serialize for ReadingRow<R> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut row = s.serialize_struct("ReadingRow", TARGET_COLUMNS.len() + R)?;
        for (name, v) in TARGET_COLUMNS.iter().zip(self.target.iter()) {
            row.serialize_field(name, v)?;
        }
        for (r, v) in self.facts.iter().zip(&self.readings) {
            row.serialize_field(r.column, v)?;
        }
        row.end()
    }
}

/// `readings.csv`: the commanded target and the joint values the controller reports.
pub fn readings_csv<L: LogRow<R>, const R: usize>(readings: &[L]) -> Result<Vec<u8>> {
    csv_bytes(readings.iter().map(|r| ReadingRow {
        target: r.target(),
        readings: r.file_values(),
        facts: L::FACTS,
    }))
}

#[derive(Serialize)]
struct IdentifiedRow {
    parameter: &'static str,
    estimate_mm: f64,
    std_uncertainty_mm: f64,
    identifiable: bool,
    source: &'static str,
}

/// Error `k`'s standard uncertainty for identified.csv: NaN (an empty
/// cell) when the error cannot be identified — its estimate is set to 0 by
/// choice, not measured, so it has no uncertainty to give — or when there
/// are no degrees of freedom to estimate it from.
fn std_uncertainty<const P: usize>(est: &EstimateOf<P>, k: usize) -> f64 {
    if est.identifiable[k] {
        est.std_mm[k]
    } else {
        f64::NAN
    }
}

#[derive(Serialize)]
struct IdentifiedAxesRow {
    parameter: &'static str,
    estimate_mm: f64,
    std_uncertainty_mm: f64,
    identifiable: bool,
    source: &'static str,
    estimate_deg: f64,
    std_uncertainty_deg: f64,
}

/// A mechanism's second-class angles as identified (the Tricept's Hooke
/// axes): their values and standard uncertainties, degrees, and which
/// the readings identified.
pub struct FittedAngles<'a, const A: usize> {
    pub values: &'a SVector<f64, A>,
    pub std_deg: &'a SVector<f64, A>,
    pub identifiable: &'a [bool; A],
}

/// `identified.csv` of `identify`: the mechanism's errors (`names`), and
/// with its second-class angles identified (`angles`) one more row each
/// whose value is an angle, in the columns `estimate_deg` and
/// `std_uncertainty_deg` (empty for the errors, as the mm columns are for
/// the angles).
pub fn identified_csv<const P: usize, const A: usize>(
    est: &EstimateOf<P>,
    names: &Unknowns<P, A>,
    angles: Option<FittedAngles<A>>,
) -> Result<Vec<u8>> {
    let Some(a) = angles else {
        return identified_errors_csv(est, names);
    };
    let errors = (0..P).map(|k| IdentifiedAxesRow {
        parameter: names.errors[k],
        estimate_mm: est.values[k],
        std_uncertainty_mm: std_uncertainty(est, k),
        identifiable: est.identifiable[k],
        source: est.source[k],
        estimate_deg: f64::NAN,
        std_uncertainty_deg: f64::NAN,
    });
    let angles = (0..A).map(|k| IdentifiedAxesRow {
        parameter: names.angles[k],
        estimate_mm: f64::NAN,
        std_uncertainty_mm: f64::NAN,
        identifiable: a.identifiable[k],
        source: if a.identifiable[k] {
            "readings"
        } else {
            "unidentifiable"
        },
        estimate_deg: a.values[k],
        std_uncertainty_deg: if a.identifiable[k] {
            a.std_deg[k]
        } else {
            f64::NAN
        },
    });
    csv_bytes(errors.chain(angles))
}

/// The errors' rows.
fn identified_errors_csv<const P: usize, const A: usize>(
    est: &EstimateOf<P>,
    names: &Unknowns<P, A>,
) -> Result<Vec<u8>> {
    csv_bytes((0..P).map(|k| IdentifiedRow {
        parameter: names.errors[k],
        estimate_mm: est.values[k],
        std_uncertainty_mm: std_uncertainty(est, k),
        identifiable: est.identifiable[k],
        source: est.source[k],
    }))
}

#[derive(Serialize)]
struct IdentifiedTruthRow {
    parameter: &'static str,
    estimate_mm: f64,
    std_uncertainty_mm: f64,
    identifiable: bool,
    source: &'static str,
    true_mm: f64,
    error_mm: f64,
}

/// `identified.csv` of a simulation, with the true values beside the
/// estimates of the errors `names`.
pub fn identified_truth_csv<const P: usize>(
    est: &EstimateOf<P>,
    truth: &SVector<f64, P>,
    names: &[&'static str; P],
) -> Result<Vec<u8>> {
    csv_bytes((0..P).map(|k| IdentifiedTruthRow {
        parameter: names[k],
        estimate_mm: est.values[k],
        std_uncertainty_mm: std_uncertainty(est, k),
        identifiable: est.identifiable[k],
        source: est.source[k],
        true_mm: truth[k],
        error_mm: est.values[k] - truth[k],
    }))
}

/// JSON of the identifiability analysis, with the pose set and method.
#[derive(Serialize)]
struct IdentifiabilityReport<'a> {
    poses: usize,
    rows: usize,
    method: Method,
    parameter_names: &'a [&'a str],
    #[serde(flatten)]
    analysis: &'a Identifiability,
    /// identify's checks of its result: the χ² misfit against the declared
    /// sensors, the held-out poses, the predicted accuracy.
    #[serde(skip_serializing_if = "Option::is_none")]
    checks: Option<serde_json::Value>,
    /// The config a fit ran with, and its nominal machine's keys and
    /// values ([`crate::store::nominal`]); absent from identifiability's
    /// own report (no fit).
    #[serde(skip_serializing_if = "Option::is_none")]
    config: Option<&'a str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    nominal: Option<serde_json::Value>,
    /// The log's rows (more than `poses` where it repeats poses).
    #[serde(skip_serializing_if = "Option::is_none")]
    log_rows: Option<usize>,
}

/// The config a fit ran with, its nominal machine and the log's rows, as
/// identifiability.json records them.
pub type Origin<'a> = (&'a str, &'a crate::store::nominal::Nominal, usize);

/// `identifiability.json`'s bytes with a `hooke_axes` object added when
/// the Hooke axes are identified (unchanged otherwise).
pub fn with_hooke_axes(bytes: Vec<u8>, axes: Option<&AxesAnalysis>) -> Result<Vec<u8>> {
    let Some(x) = axes else {
        return Ok(bytes);
    };
    let json =
        |e: serde_json::Error| crate::error::Error::Internal(format!("identifiability JSON: {e}"));
    let mut v: serde_json::Value = serde_json::from_slice(&bytes).map_err(json)?;
    if let Some(obj) = v.as_object_mut() {
        obj.insert("hooke_axes".into(), serde_json::to_value(x).map_err(json)?);
    }
    let mut out = serde_json::to_vec_pretty(&v).map_err(json)?;
    out.push(b'\n');
    Ok(out)
}

/// `bytes` (a JSON object) with `key` set to `value`.
pub fn with_entry<T: Serialize>(bytes: Vec<u8>, key: &str, value: &T) -> Result<Vec<u8>> {
    let json =
        |e: serde_json::Error| crate::error::Error::Internal(format!("identifiability JSON: {e}"));
    let mut v: serde_json::Value = serde_json::from_slice(&bytes).map_err(json)?;
    if let Some(obj) = v.as_object_mut() {
        obj.insert(key.into(), serde_json::to_value(value).map_err(json)?);
    }
    let mut out = serde_json::to_vec_pretty(&v).map_err(json)?;
    out.push(b'\n');
    Ok(out)
}

/// The estimate's covariance in identifiability.json (`covariance`): what
/// verify reads to size what a check by the passive limb cannot see.
#[derive(Debug, Serialize)]
pub struct CovarianceJson {
    /// The unknowns in the matrix's order (the 15 errors, then the Hooke
    /// axes' angles when identified).
    pub unknowns: Vec<&'static str>,
    /// mm² (mm·° between an error and an angle, °² between angles).
    pub matrix: Vec<Vec<f64>>,
}

/// `identifiability.json` of a design of the errors `names`; a fit's with
/// the config it ran with and its nominal machine (`origin`).
pub fn identifiability_json<M: Serialize>(
    names: &[&str],
    method: Method,
    poses: usize,
    rows: usize,
    a: &Identifiability,
    checks: Option<&M>,
    origin: Option<Origin>,
) -> Result<Vec<u8>> {
    JsonExporter.render(&IdentifiabilityReport {
        poses,
        rows,
        method,
        parameter_names: names,
        analysis: a,
        checks: checks.map(|m| serde_json::to_value(m).unwrap_or_default()),
        config: origin.map(|o| o.0),
        nominal: origin.map(|o| crate::store::nominal::to_json(o.1)),
        log_rows: origin.map(|o| o.2),
    })
}

#[derive(Serialize)]
struct VolumetricRow {
    x_mm: f64,
    y_mm: f64,
    z_mm: f64,
    before_mm: f64,
    after_mm: f64,
}

/// `volumetric.csv`: dV per map point before and after compensation.
pub fn volumetric_csv(map: &VolumetricMap) -> Result<Vec<u8>> {
    csv_bytes(
        map.points
            .iter()
            .zip(map.before_mm.iter().zip(&map.after_mm))
            .map(|(p, (b, a))| VolumetricRow {
                x_mm: p.x,
                y_mm: p.y,
                z_mm: p.z,
                before_mm: *b,
                after_mm: *a,
            }),
    )
}

#[derive(Serialize)]
struct WorkspaceRow {
    stage: &'static str,
    max_mm: f64,
    p95_mm: f64,
    mean_mm: f64,
    points: usize,
}

/// `workspace_accuracy.csv` (docs/method.md §12): max, 95th percentile (type 7) and
/// mean of dV over the workspace grid, before and after compensation.
pub fn workspace_accuracy_csv(map: &VolumetricMap) -> Result<Vec<u8>> {
    let row = |stage, v: &[f64]| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        WorkspaceRow {
            stage,
            max_mm: s.last().copied().unwrap_or(f64::NAN),
            p95_mm: crate::metrics::stats::quantile_sorted(&s, 0.95),
            mean_mm: s.iter().sum::<f64>() / s.len().max(1) as f64,
            points: s.len(),
        }
    };
    csv_bytes([row("before", &map.before_mm), row("after", &map.after_mm)])
}

#[derive(Serialize)]
struct IsoRow {
    position: String,
    x_mm: f64,
    y_mm: f64,
    z_mm: f64,
    ap_before_mm: f64,
    ap_after_mm: f64,
}

/// `iso9283.csv`: pose accuracy AP at P1–P5 before and after compensation.
pub fn iso9283_csv(map: &VolumetricMap) -> Result<Vec<u8>> {
    csv_bytes(
        map.points
            .iter()
            .zip(map.before_mm.iter().zip(&map.after_mm))
            .enumerate()
            .map(|(k, (p, (b, a)))| IsoRow {
                position: format!("P{}", k + 1),
                x_mm: p.x,
                y_mm: p.y,
                z_mm: p.z,
                ap_before_mm: *b,
                ap_after_mm: *a,
            }),
    )
}

#[derive(Serialize)]
struct CorrectionRow {
    x_mm: f64,
    y_mm: f64,
    z_mm: f64,
    correction_mm: f64,
    error_x_mm: f64,
    error_y_mm: f64,
    error_z_mm: f64,
}

/// `correction_map.csv` of a real machine: the position error the
/// identified model predicts for nominal commands, per map point: its size
/// and its components (attained − target; compensation moves the other way).
pub fn correction_csv(map: &VolumetricMap, vectors: &[nalgebra::Vector3<f64>]) -> Result<Vec<u8>> {
    csv_bytes(
        map.points
            .iter()
            .zip(&map.before_mm)
            .zip(vectors)
            .map(|((p, c), e)| CorrectionRow {
                x_mm: p.x,
                y_mm: p.y,
                z_mm: p.z,
                correction_mm: *c,
                error_x_mm: e.x,
                error_y_mm: e.y,
                error_z_mm: e.z,
            }),
    )
}

#[derive(Serialize)]
struct StageRow {
    stage: &'static str,
    max_mm: f64,
    min_mm: f64,
    mean_mm: f64,
}

/// `volumetric_summary.csv`: max, min, mean of the map before and after.
pub fn volumetric_summary_csv(map: &VolumetricMap) -> Result<Vec<u8>> {
    let stage = |stage, s: Stats| StageRow {
        stage,
        max_mm: s.max_mm,
        min_mm: s.min_mm,
        mean_mm: s.mean_mm,
    };
    csv_bytes([stage("before", map.before()), stage("after", map.after())])
}

#[derive(Serialize)]
struct CommandRow {
    x_mm: f64,
    y_mm: f64,
    z_mm: f64,
    q1_mm: f64,
    q2_mm: f64,
    q3_mm: f64,
}

/// `commands.csv`: compensated leg commands per target.
pub fn commands_csv(targets: &[Vector3<f64>], commands: &[[f64; 3]]) -> Result<Vec<u8>> {
    csv_bytes(targets.iter().zip(commands).map(|(r, q)| CommandRow {
        x_mm: r.x,
        y_mm: r.y,
        z_mm: r.z,
        q1_mm: q[0],
        q2_mm: q[1],
        q3_mm: q[2],
    }))
}

/// A row of `decision_budget.csv`: the budget by sensor ([`BudgetRow`]'s
/// columns), then by error term ([`crate::metrics::TermSplit`]'s; empty for
/// sensors read as the paper's white noise, which are not split, and for a
/// term the combination's sensors do not have).
struct DecisionBudgetRow<'a>(&'a crate::metrics::BudgetRow);

impl Serialize for DecisionBudgetRow<'_> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let b = self.0;
        let t = b.terms.as_ref();
        let mut row = s.serialize_struct("DecisionBudgetRow", 26)?;
        row.serialize_field("measure", b.measure)?;
        row.serialize_field("encoder_arcsec", &b.encoder_arcsec)?;
        row.serialize_field("scale_um", &b.scale_um)?;
        row.serialize_field("method", &b.method)?;
        row.serialize_field("pose_count", &b.pose_count)?;
        row.serialize_field("encoder", &b.encoder)?;
        row.serialize_field("scale", &b.scale)?;
        row.serialize_field("calibrations", &b.calibrations)?;
        row.serialize_field("total_mm", &b.total_mm)?;
        row.serialize_field("floor_mm", &b.floor_mm)?;
        row.serialize_field("psi_encoder_mm", &b.psi_encoder_mm)?;
        row.serialize_field("theta_encoder_mm", &b.theta_encoder_mm)?;
        row.serialize_field("scale_mm", &b.scale_mm)?;
        row.serialize_field("saving_psi_encoder_mm", &b.saving_psi_encoder_mm)?;
        row.serialize_field("saving_theta_encoder_mm", &b.saving_theta_encoder_mm)?;
        row.serialize_field("saving_scale_mm", &b.saving_scale_mm)?;
        row.serialize_field("limiting", b.limiting)?;
        row.serialize_field("curve_mm", &t.filter(|t| t.present[0]).map(|t| t.curve_mm))?;
        row.serialize_field(
            "eccentricity_mm",
            &t.filter(|t| t.present[1]).map(|t| t.eccentricity_mm),
        )?;
        row.serialize_field(
            "interpolation_mm",
            &t.filter(|t| t.present[2]).map(|t| t.interpolation_mm),
        )?;
        row.serialize_field(
            "jitter_mm",
            &t.filter(|t| t.present[3]).map(|t| t.jitter_mm),
        )?;
        row.serialize_field(
            "saving_curve_mm",
            &t.filter(|t| t.present[0]).map(|t| t.saving_curve_mm),
        )?;
        row.serialize_field(
            "saving_eccentricity_mm",
            &t.filter(|t| t.present[1]).map(|t| t.saving_eccentricity_mm),
        )?;
        row.serialize_field(
            "saving_interpolation_mm",
            &t.filter(|t| t.present[2])
                .map(|t| t.saving_interpolation_mm),
        )?;
        row.serialize_field(
            "saving_jitter_mm",
            &t.filter(|t| t.present[3]).map(|t| t.saving_jitter_mm),
        )?;
        row.serialize_field("limiting_term", &t.map(|t| t.limiting_term))?;
        row.end()
    }
}

/// `decision_budget.csv`: the deciding metric's budget by sensor and by
/// error term.
pub fn decision_budget_csv(rows: &[crate::metrics::BudgetRow]) -> Result<Vec<u8>> {
    csv_bytes(rows.iter().map(DecisionBudgetRow))
}

#[cfg(test)]
#[path = "rows_tests.rs"]
mod tests;
