//! The one validated configuration (SPEC §10).
//!
//! Two stages, like ripgrep's low/high arguments: [`RawConfig`] is what the
//! TOML says (serde, `deny_unknown_fields`, the paper's values as defaults per
//! field); [`Config::from_raw`] checks every value, names the key and the
//! allowed range on failure, and resolves geometry, errors, sensors, poses and
//! options into model types before any work starts. Command-line overrides
//! are applied to the raw values first, so they are validated the same way.

use crate::error::{Error, Result};
use crate::identify::{IdentifyOptions, Method};
use crate::model::geometry::SecondClass;
use crate::model::jacobian::passive_matrix;
use crate::model::kinematics::normalized_det;
use crate::model::params::param_index;
use crate::model::poses::{pattern, Workspace};
use crate::model::{ErrorVector, Geometry, Machine, PAPER_ERRORS_MM, PARAM_NAMES};
use crate::sensors::{GradeReading, SensorModel};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The paper's case, built into the binary (identical to `configs/paper.toml`).
pub const PAPER_TOML: &str = include_str!("../../configs/paper.toml");

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GeometrySection {
    /// Platform circumradius, mm.
    pub a: f64,
    /// Base circumradius, mm.
    pub b: f64,
    pub base_angles_deg: Vec<f64>,
    pub platform_angles_deg: Vec<f64>,
    /// Largest tilt of the UP limb from the base normal a pose may ask for, deg.
    pub max_tilt_deg: f64,
}

impl Default for GeometrySection {
    fn default() -> Self {
        GeometrySection {
            a: 100.0,
            b: 288.7,
            base_angles_deg: vec![-60.0, 60.0, 180.0],
            platform_angles_deg: vec![-60.0, 60.0, 180.0],
            max_tilt_deg: 60.0,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WorkspaceSection {
    pub radius: f64,
    pub height: f64,
    pub top: f64,
}

impl Default for WorkspaceSection {
    fn default() -> Self {
        WorkspaceSection {
            radius: 400.0,
            height: 200.0,
            top: 650.0,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensorsSection {
    pub encoder_arcsec: f64,
    pub scale_um: f64,
    pub samples: u32,
    /// "sigma" (grade = σ, Gaussian; the paper) or "uniform" (grade = ±bound).
    pub noise_model: String,
}

impl Default for SensorsSection {
    fn default() -> Self {
        SensorsSection {
            encoder_arcsec: 0.8,
            scale_um: 0.5,
            samples: 3,
            noise_model: "sigma".into(),
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct PosesSection {
    pub layers: Option<usize>,
    pub ring_fractions: Option<Vec<f64>>,
    pub points_per_ring: Option<usize>,
    pub list: Option<Vec<Vec<f64>>>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentificationSection {
    pub method: String,
    pub iterations: usize,
    pub tolerance: f64,
    pub rank_tolerance: f64,
}

impl Default for IdentificationSection {
    fn default() -> Self {
        IdentificationSection {
            method: "ols".into(),
            iterations: 1,
            tolerance: 1e-9,
            rank_tolerance: 1e-9,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CompensationSection {
    pub grid_step: f64,
    /// z of the map plane, mm (default: the mid-plane H + h/2).
    pub plane_z: Option<f64>,
}

impl Default for CompensationSection {
    fn default() -> Self {
        CompensationSection {
            grid_step: 20.0,
            plane_z: None,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SweepSection {
    pub encoder_arcsec: Vec<f64>,
    pub scale_um: Vec<f64>,
    pub trials: u64,
    pub errors: String,
    pub error_bound: f64,
    pub seed: u64,
    /// Estimators compared on the same trials (default: [identification].method).
    pub methods: Option<Vec<String>>,
    /// Also compute each calibration's volumetric error after compensation
    /// on the map plane (slower).
    pub volumetric: bool,
    /// Grid step of that map, mm (coarser than [compensation] for speed).
    pub volumetric_grid_step: f64,
}

impl Default for SweepSection {
    fn default() -> Self {
        SweepSection {
            encoder_arcsec: vec![0.5, 1.0, 2.0, 3.0, 4.0, 6.0, 8.0],
            scale_um: vec![0.5],
            trials: 2000,
            errors: "random".into(),
            error_bound: 0.5,
            seed: 1,
            methods: None,
            volumetric: false,
            volumetric_grid_step: 50.0,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DecisionSection {
    /// One of the summary columns listed in [`DECISION_METRICS`].
    pub metric: String,
    /// The grade passes when metric ≤ threshold.
    pub threshold: f64,
}

impl Default for DecisionSection {
    fn default() -> Self {
        DecisionSection {
            metric: "ratio_p95".into(),
            threshold: 0.5,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReproduceSection {
    /// Encoder grades of the Fig. 4 study, arc-seconds.
    pub fig4_encoder_arcsec: Vec<f64>,
    /// Noise draws per grade for Fig. 4.
    pub fig4_draws: u64,
    pub seed: u64,
}

impl Default for ReproduceSection {
    fn default() -> Self {
        ReproduceSection {
            fig4_encoder_arcsec: vec![0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0, 7.0, 8.0],
            fig4_draws: 1000,
            seed: 1,
        }
    }
}

/// Second-class errors of the simulated true machine (SPEC §3), degrees.
/// The identification model ignores them; they show the bias they cause.
#[derive(Debug, Clone, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct SecondClassSection {
    /// First Hooke axis rotated about the base z axis.
    pub hooke_axis1_yaw_deg: f64,
    /// First Hooke axis tilted out of the base plane (about y).
    pub hooke_axis1_pitch_deg: f64,
    /// Second Hooke axis not perpendicular to the first (rotation about z).
    pub hooke_axes_skew_deg: f64,
    /// Platform (guide) twisted about the UP-limb axis.
    pub guide_twist_deg: f64,
}

/// The TOML as written, with defaults filled in.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawConfig {
    pub geometry: GeometrySection,
    pub workspace: WorkspaceSection,
    pub errors: BTreeMap<String, f64>,
    pub second_class: SecondClassSection,
    pub sensors: SensorsSection,
    pub poses: PosesSection,
    pub identification: IdentificationSection,
    pub compensation: CompensationSection,
    pub sweep: SweepSection,
    pub decision: DecisionSection,
    pub reproduce: ReproduceSection,
}

impl Default for RawConfig {
    fn default() -> Self {
        RawConfig {
            geometry: Default::default(),
            workspace: Default::default(),
            errors: PARAM_NAMES
                .iter()
                .zip(PAPER_ERRORS_MM)
                .map(|(n, v)| (n.to_string(), v))
                .collect(),
            second_class: Default::default(),
            sensors: Default::default(),
            poses: Default::default(),
            identification: Default::default(),
            compensation: Default::default(),
            sweep: Default::default(),
            decision: Default::default(),
            reproduce: Default::default(),
        }
    }
}

/// How the sweep draws each trial's true errors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ErrorDraw {
    /// Uniform in ±error_bound per parameter, a new set per trial.
    Random,
    /// The [errors] table for every trial (noise draws only; the paper's Fig. 4).
    Fixed,
}

/// Summary columns a decision may use.
pub const DECISION_METRICS: [&str; 11] = [
    "mu_mean",
    "mu_median",
    "mu_p95",
    "ratio_mean",
    "ratio_median",
    "ratio_p95",
    "mu_mean_ci_high",
    "ratio_p95_ci_high",
    "dv_after_max_p95",
    "dv_after_max_median",
    "dv_after_mean_mean",
];

#[derive(Debug, Clone, PartialEq)]
pub struct Decision {
    pub metric: String,
    pub threshold: f64,
}

#[derive(Debug, Clone)]
pub struct SweepConfig {
    pub encoder_arcsec: Vec<f64>,
    pub scale_um: Vec<f64>,
    pub trials: u64,
    pub errors: ErrorDraw,
    pub error_bound_mm: f64,
    pub seed: u64,
    pub methods: Vec<Method>,
    /// Grid step of the per-calibration volumetric map (None: off).
    pub volumetric_step_mm: Option<f64>,
}

#[derive(Debug, Clone)]
pub struct ReproduceConfig {
    pub fig4_encoder_arcsec: Vec<f64>,
    pub fig4_draws: u64,
    pub seed: u64,
}

/// The validated configuration every command works from.
#[derive(Debug, Clone)]
pub struct Config {
    /// Where it came from (file path, or the built-in paper case).
    pub source: String,
    pub raw: RawConfig,
    pub geometry: Geometry,
    pub max_tilt_deg: f64,
    pub workspace: Workspace,
    pub errors: ErrorVector,
    /// Second-class errors of the true machine (None when all zero).
    pub second_class: Option<SecondClass>,
    pub sensors: SensorModel,
    pub poses: Vec<Vector3<f64>>,
    pub identification: IdentifyOptions,
    pub grid_step_mm: f64,
    pub plane_z_mm: f64,
    pub sweep: SweepConfig,
    pub decision: Decision,
    pub reproduce: ReproduceConfig,
}

/// Parse TOML text into the raw config; errors name the file and line.
pub fn parse_raw(text: &str, source: &str) -> Result<RawConfig> {
    toml::from_str::<RawConfig>(text).map_err(|e| {
        let line = e
            .span()
            .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
        let msg = e.message().trim().replace('\n', " ");
        match line {
            Some(l) => Error::config(format!("{source} line {l}"), msg),
            None => Error::config(source, msg),
        }
    })
}

/// Read a config file's raw values; errors name the file (and line).
pub fn load_raw(path: &Path) -> Result<RawConfig> {
    let source = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            Error::config(&source, "the config file does not exist")
        } else {
            Error::config(&source, format!("the config file cannot be read ({e})"))
        }
    })?;
    parse_raw(&text, &source)
}

/// Read and validate a config file.
pub fn load(path: &Path) -> Result<Config> {
    Config::from_raw(load_raw(path)?, &path.display().to_string())
}

/// The built-in paper case.
pub fn paper() -> Result<Config> {
    Config::from_raw(
        parse_raw(PAPER_TOML, "<built-in configs/paper.toml>")?,
        "<built-in configs/paper.toml>",
    )
}

struct Check<'a> {
    source: &'a str,
}

impl Check<'_> {
    fn fail<T>(&self, key: &str, what: impl std::fmt::Display) -> Result<T> {
        Err(Error::config(self.source, format!("{key} {what}")))
    }
    fn positive(&self, key: &str, v: f64) -> Result<f64> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            self.fail(
                key,
                format_args!("must be a positive finite number (got {v})"),
            )
        }
    }
    fn non_negative(&self, key: &str, v: f64) -> Result<f64> {
        if v.is_finite() && v >= 0.0 {
            Ok(v)
        } else {
            self.fail(key, format_args!("must be a finite number ≥ 0 (got {v})"))
        }
    }
    fn angles3(&self, key: &str, v: &[f64]) -> Result<[f64; 3]> {
        if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
            return self.fail(
                key,
                format_args!("must be 3 finite angles in degrees (got {v:?})"),
            );
        }
        Ok([v[0], v[1], v[2]])
    }
    fn grades(&self, key: &str, v: &[f64]) -> Result<Vec<f64>> {
        if v.is_empty() {
            return self.fail(key, "must list at least one grade");
        }
        for x in v {
            self.positive(key, *x)?;
        }
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s.dedup();
        if s.len() != v.len() {
            return self.fail(key, format_args!("lists a grade twice (got {v:?})"));
        }
        Ok(v.to_vec())
    }
    fn method(&self, key: &str, v: &str) -> Result<Method> {
        match v {
            "ols" => Ok(Method::Ols),
            "wls" => Ok(Method::Wls),
            _ => self.fail(
                key,
                format_args!("must be \"ols\" or \"wls\" (got \"{v}\")"),
            ),
        }
    }
}

impl Config {
    /// Validate every value of a raw config.
    pub fn from_raw(raw: RawConfig, source: &str) -> Result<Config> {
        let c = Check { source };
        // [geometry]
        let g = &raw.geometry;
        let a = c.positive("geometry.a", g.a)?;
        let b = c.positive("geometry.b", g.b)?;
        let beta = c.angles3("geometry.base_angles_deg", &g.base_angles_deg)?;
        let alpha = c.angles3("geometry.platform_angles_deg", &g.platform_angles_deg)?;
        let geometry = Geometry::from_circles(a, b, beta, alpha);
        if (geometry.b[0].x - geometry.b[1].x).abs() > 1e-9 * b {
            return c.fail(
                "geometry.base_angles_deg",
                format_args!(
                    "puts B1 and B2 at x = {:.4} and {:.4} mm: B1B2 must be parallel to the y axis (use angles ±β)",
                    geometry.b[0].x, geometry.b[1].x
                ),
            );
        }
        if geometry.b[0].x.abs() < 1e-6 * b || (geometry.b[0] - geometry.b[1]).norm() < 1e-6 * b {
            return c.fail(
                "geometry.base_angles_deg",
                "puts B1, B2 and B4 on one line: they must span the base plane",
            );
        }
        let pts = [(geometry.b, "base"), (geometry.a, "platform")];
        for (p, what) in pts {
            for i in 0..3 {
                for j in i + 1..3 {
                    if (p[i] - p[j]).norm() < 1e-6 * b.max(a) {
                        let key = format!("geometry.{what}_angles_deg");
                        return c.fail(
                            &key,
                            format_args!("puts joints {} and {} at the same point", i + 1, j + 1),
                        );
                    }
                }
            }
        }
        let max_tilt_deg = g.max_tilt_deg;
        if !(max_tilt_deg.is_finite() && max_tilt_deg > 0.0 && max_tilt_deg < 90.0) {
            return c.fail(
                "geometry.max_tilt_deg",
                format_args!("must be in (0, 90) degrees (got {max_tilt_deg})"),
            );
        }
        // [workspace]
        let w = &raw.workspace;
        let workspace = Workspace {
            radius_mm: c.positive("workspace.radius", w.radius)?,
            height_mm: c.positive("workspace.height", w.height)?,
            top_mm: c.positive("workspace.top", w.top)?,
        };
        // [errors]
        let mut errors = ErrorVector::zeros();
        for (name, v) in &raw.errors {
            let Some(k) = param_index(name) else {
                let fixed = ["dzB1", "dzB2", "dxB2", "dzA1", "dzA2", "dzA3"];
                let why = if fixed.contains(&name.as_str()) {
                    " (it is fixed by the frame convention, SPEC §3)"
                } else {
                    ""
                };
                return c.fail(
                    &format!("errors.{name}"),
                    format_args!(
                        "is not one of the 15 error names{why}; use {}",
                        PARAM_NAMES.join(", ")
                    ),
                );
            };
            if !v.is_finite() || v.abs() > 0.1 * a.min(b) {
                return c.fail(
                    &format!("errors.{name}"),
                    format_args!(
                        "must be a finite error in mm smaller than {} (got {v})",
                        0.1 * a.min(b)
                    ),
                );
            }
            errors[k] = *v;
        }
        // [second_class]
        let sc = &raw.second_class;
        let angles = [
            ("second_class.hooke_axis1_yaw_deg", sc.hooke_axis1_yaw_deg),
            (
                "second_class.hooke_axis1_pitch_deg",
                sc.hooke_axis1_pitch_deg,
            ),
            ("second_class.hooke_axes_skew_deg", sc.hooke_axes_skew_deg),
            ("second_class.guide_twist_deg", sc.guide_twist_deg),
        ];
        for (key, v) in angles {
            if !v.is_finite() || v.abs() > 5.0 {
                return c.fail(
                    key,
                    format_args!("must be a small angle in degrees, |x| <= 5 (got {v})"),
                );
            }
        }
        let second_class = if angles.iter().all(|(_, v)| *v == 0.0) {
            None
        } else {
            Some(SecondClass::from_angles_deg(
                sc.hooke_axis1_yaw_deg,
                sc.hooke_axis1_pitch_deg,
                sc.hooke_axes_skew_deg,
                sc.guide_twist_deg,
            ))
        };
        // [sensors]
        let s = &raw.sensors;
        let reading = match s.noise_model.as_str() {
            "sigma" => GradeReading::Sigma,
            "uniform" => GradeReading::Uniform,
            other => {
                return c.fail(
                    "sensors.noise_model",
                    format_args!("must be \"sigma\" (grade = standard deviation) or \"uniform\" (grade = ±bound) (got \"{other}\")"),
                )
            }
        };
        if s.samples == 0 || s.samples > 1_000_000 {
            return c.fail(
                "sensors.samples",
                format_args!("must be between 1 and 1000000 (got {})", s.samples),
            );
        }
        let sensors = SensorModel {
            encoder_arcsec: c.non_negative("sensors.encoder_arcsec", s.encoder_arcsec)?,
            scale_um: c.non_negative("sensors.scale_um", s.scale_um)?,
            samples: s.samples,
            reading,
        };
        // [identification]
        let id = &raw.identification;
        let method = c.method("identification.method", &id.method)?;
        if id.iterations == 0 || id.iterations > 100 {
            return c.fail(
                "identification.iterations",
                format_args!("must be between 1 and 100 (got {})", id.iterations),
            );
        }
        c.positive("identification.tolerance", id.tolerance)?;
        if !(id.rank_tolerance > 0.0 && id.rank_tolerance < 1e-2) {
            return c.fail(
                "identification.rank_tolerance",
                format_args!("must be in (0, 0.01) (got {})", id.rank_tolerance),
            );
        }
        if method == Method::Wls && (sensors.encoder_arcsec == 0.0 || sensors.scale_um == 0.0) {
            return c.fail(
                "identification.method",
                "= \"wls\" needs sensors.encoder_arcsec and sensors.scale_um > 0 (weights are 1/σ)",
            );
        }
        let identification = IdentifyOptions {
            method,
            iterations: id.iterations,
            tolerance_mm: id.tolerance,
            rank_tolerance: id.rank_tolerance,
        };
        // [poses]
        let p = &raw.poses;
        let poses = match &p.list {
            Some(list) => {
                if p.layers.is_some() || p.ring_fractions.is_some() || p.points_per_ring.is_some() {
                    return c.fail("poses.list", "cannot be combined with poses.layers, poses.ring_fractions or poses.points_per_ring");
                }
                let mut out = Vec::with_capacity(list.len());
                for (k, v) in list.iter().enumerate() {
                    if v.len() != 3 || v.iter().any(|x| !x.is_finite()) {
                        return c.fail(
                            &format!("poses.list[{k}]"),
                            format_args!("must be [x, y, z] in mm (got {v:?})"),
                        );
                    }
                    out.push(Vector3::new(v[0], v[1], v[2]));
                }
                out
            }
            None => {
                let layers = p.layers.unwrap_or(3);
                if layers == 0 || layers > 1000 {
                    return c.fail(
                        "poses.layers",
                        format_args!("must be between 1 and 1000 (got {layers})"),
                    );
                }
                let rings = p.ring_fractions.clone().unwrap_or_else(|| vec![0.5, 1.0]);
                for f in &rings {
                    if !(f.is_finite() && *f > 0.0 && *f <= 1.0) {
                        return c.fail(
                            "poses.ring_fractions",
                            format_args!("must be fractions of the radius in (0, 1] (got {f})"),
                        );
                    }
                }
                let ppr = p.points_per_ring.unwrap_or(8);
                if ppr == 0 && !rings.is_empty() || ppr > 100_000 {
                    return c.fail(
                        "poses.points_per_ring",
                        format_args!("must be between 1 and 100000 (got {ppr})"),
                    );
                }
                pattern(&workspace, layers, &rings, ppr)
            }
        };
        if poses.len() < 2 {
            return c.fail(
                "poses",
                format_args!(
                    "must give at least 2 poses (a reference and one more); got {}",
                    poses.len()
                ),
            );
        }
        let nominal = Machine::nominal(&geometry);
        for (k, r) in poses.iter().enumerate() {
            check_reachable(&nominal, r, max_tilt_deg).map_err(|why| {
                Error::config(
                    source,
                    format!(
                        "poses: pose {k} ({:.3}, {:.3}, {:.3}) mm is not reachable: {why}",
                        r.x, r.y, r.z
                    ),
                )
            })?;
        }
        // [compensation]
        let comp = &raw.compensation;
        let grid_step_mm = c.positive("compensation.grid_step", comp.grid_step)?;
        if grid_step_mm > workspace.radius_mm {
            return c.fail(
                "compensation.grid_step",
                format_args!("must not exceed workspace.radius ({})", workspace.radius_mm),
            );
        }
        if (workspace.radius_mm / grid_step_mm).powi(2) > 4.0e6 {
            return c.fail(
                "compensation.grid_step",
                "is too fine: the map would have more than 12 million points",
            );
        }
        let plane_z_mm = match comp.plane_z {
            Some(z) => c.positive("compensation.plane_z", z)?,
            None => workspace.mid_z(),
        };
        // [sweep]
        let sw = &raw.sweep;
        let errors_draw = match sw.errors.as_str() {
            "random" => ErrorDraw::Random,
            "fixed" => ErrorDraw::Fixed,
            other => {
                return c.fail(
                    "sweep.errors",
                    format_args!("must be \"random\" or \"fixed\" (got \"{other}\")"),
                )
            }
        };
        if sw.trials == 0 || sw.trials > 1_000_000_000 {
            return c.fail(
                "sweep.trials",
                format_args!("must be between 1 and 1000000000 (got {})", sw.trials),
            );
        }
        let error_bound_mm = c.positive("sweep.error_bound", sw.error_bound)?;
        if error_bound_mm > 0.1 * a.min(b) {
            return c.fail(
                "sweep.error_bound",
                format_args!("must be below {} mm (got {error_bound_mm})", 0.1 * a.min(b)),
            );
        }
        let methods = match &sw.methods {
            None => vec![method],
            Some(list) if list.is_empty() => {
                return c.fail("sweep.methods", "must list at least one method")
            }
            Some(list) => {
                let mut out = Vec::new();
                for m in list {
                    let m = c.method("sweep.methods", m)?;
                    if out.contains(&m) {
                        return c.fail("sweep.methods", "lists a method twice");
                    }
                    out.push(m);
                }
                out
            }
        };
        let volumetric_step_mm = if sw.volumetric {
            let step = c.positive("sweep.volumetric_grid_step", sw.volumetric_grid_step)?;
            if step > workspace.radius_mm {
                return c.fail(
                    "sweep.volumetric_grid_step",
                    format_args!("must not exceed workspace.radius ({})", workspace.radius_mm),
                );
            }
            if (workspace.radius_mm / step).powi(2) > 1.0e5 {
                return c.fail(
                    "sweep.volumetric_grid_step",
                    "is too fine for a sweep: the map would have more than 300000 points",
                );
            }
            Some(step)
        } else {
            None
        };
        let sweep = SweepConfig {
            volumetric_step_mm,
            encoder_arcsec: c.grades("sweep.encoder_arcsec", &sw.encoder_arcsec)?,
            scale_um: c.grades("sweep.scale_um", &sw.scale_um)?,
            trials: sw.trials,
            errors: errors_draw,
            error_bound_mm,
            seed: sw.seed,
            methods,
        };
        // [decision]
        let d = &raw.decision;
        if !DECISION_METRICS.contains(&d.metric.as_str()) {
            return c.fail(
                "decision.metric",
                format_args!(
                    "must be one of {} (got \"{}\")",
                    DECISION_METRICS.join(", "),
                    d.metric
                ),
            );
        }
        if d.metric.starts_with("dv_") && !sw.volumetric {
            return c.fail(
                "decision.metric",
                format_args!("= \"{}\" needs sweep.volumetric = true", d.metric),
            );
        }
        let decision = Decision {
            metric: d.metric.clone(),
            threshold: c.positive("decision.threshold", d.threshold)?,
        };
        // [reproduce]
        let rp = &raw.reproduce;
        let reproduce = ReproduceConfig {
            fig4_encoder_arcsec: c
                .grades("reproduce.fig4_encoder_arcsec", &rp.fig4_encoder_arcsec)?,
            fig4_draws: if rp.fig4_draws == 0 || rp.fig4_draws > 10_000_000 {
                return c.fail(
                    "reproduce.fig4_draws",
                    format_args!("must be between 1 and 10000000 (got {})", rp.fig4_draws),
                );
            } else {
                rp.fig4_draws
            },
            seed: rp.seed,
        };
        Ok(Config {
            source: source.to_string(),
            raw,
            geometry,
            max_tilt_deg,
            workspace,
            errors,
            second_class,
            sensors,
            poses,
            identification,
            grid_step_mm,
            plane_z_mm,
            sweep,
            decision,
            reproduce,
        })
    }

    pub fn nominal(&self) -> Machine {
        Machine::nominal(&self.geometry)
    }

    /// The simulated true machine: nominal + [errors] + [second_class].
    pub fn truth(&self) -> Machine {
        Machine {
            second: self.second_class,
            ..Machine::with_errors(&self.geometry, &self.errors)
        }
    }
}

/// A pose is usable when nominal IK exists, the UP limb's tilt is within
/// `max_tilt_deg`, and the configuration is not singular.
pub fn check_reachable(
    nominal: &Machine,
    r: &Vector3<f64>,
    max_tilt_deg: f64,
) -> std::result::Result<(), String> {
    let pose = nominal.inverse(r).map_err(|e| match e {
        crate::error::KinematicsError::Unreachable { reason, .. } => reason,
        other => other.to_string(),
    })?;
    let tilt = (r.z / r.norm()).clamp(-1.0, 1.0).acos().to_degrees();
    if tilt > max_tilt_deg {
        return Err(format!(
            "the UP limb would tilt {tilt:.1}° from the base normal, beyond geometry.max_tilt_deg = {max_tilt_deg}°"
        ));
    }
    let det = normalized_det(&passive_matrix(&pose));
    if det.abs() < 1e-6 {
        return Err(format!(
            "the configuration is (nearly) singular (normalised det {det:.2e})"
        ));
    }
    Ok(())
}
