//! The second stage: one validator per config section (ripgrep's
//! `hiargs` style). Each checks its section's values, names the key and the
//! allowed range on failure, and returns model types.

use super::raw::{
    CompensationSection, GeometrySection, IdentificationSection, PosesSection, SecondClassSection,
    SensorsSection, WorkspaceSection,
};
use crate::error::{Error, Result};
use crate::identify::{IdentifyOptions, Method};
use crate::mechanism::tricept::geometry::SecondClass;
use crate::mechanism::tricept::params::param_index;
use crate::mechanism::tricept::{
    check_layout, check_pose, ErrorVector, Geometry, Machine, GAUGE_FIXED, N_PARAMS, N_READINGS,
    PARAM_NAMES, SLOTS,
};
use crate::mechanism::workspace::{pattern, Workspace};
use crate::sensors::{GradeReading, SensorModel};
use nalgebra::Vector3;
use std::collections::BTreeMap;

/// Largest encoder grade, arc-seconds (1°).
pub(super) const MAX_ENCODER_ARCSEC: f64 = 3600.0;
/// Largest scale grade, µm (1 mm).
pub(super) const MAX_SCALE_UM: f64 = 1000.0;
/// Most grades in one list.
pub(super) const MAX_GRADES: usize = 1000;
/// Most planes of the workspace grid.
pub(super) const MAX_LAYERS: usize = 50;
/// Most calibration poses.
pub(super) const MAX_POSES: usize = 100_000;
/// A number as an error message shows it: huge or tiny ones in scientific
/// notation (1e300, not three hundred digits).
pub(super) fn shown(v: f64) -> String {
    if v.is_finite() && v != 0.0 && !(1e-6..1e9).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Most samples a reading may average: beyond, the jitter is gone long
/// before (σ/√10000 = 1 % of σ) and the draws only cost time and memory.
pub(super) const MAX_SAMPLES: u32 = 10_000;

/// Largest `sweep.trials` a config may ask for.
pub const MAX_TRIALS: u64 = 1_000_000_000;
/// Largest `identification.iterations`.
pub(super) const MAX_ITERATIONS: usize = 100;

pub(super) struct Check<'a> {
    pub(super) source: &'a str,
}

impl Check<'_> {
    pub(super) fn fail<T>(&self, key: &str, what: impl std::fmt::Display) -> Result<T> {
        Err(Error::config(self.source, format!("{key} {what}")))
    }
    pub(super) fn positive(&self, key: &str, v: f64) -> Result<f64> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            self.fail(
                key,
                format_args!("must be a positive finite number (got {v})"),
            )
        }
    }
    /// A machine's length in mm: positive and at most [`MAX_LENGTH_MM`] (a
    /// larger one is a unit mistake, and its squares would overflow).
    pub(super) fn length(&self, key: &str, v: f64) -> Result<f64> {
        let v = self.positive(key, v)?;
        if v > MAX_LENGTH_MM {
            return self.fail(
                key,
                format_args!(
                    "must be a length in mm of at most {MAX_LENGTH_MM} (100 m; got {v:e}): is it in another unit?"
                ),
            );
        }
        Ok(v)
    }
    /// A grade above `max` is a unit mistake, not a sensor.
    pub(super) fn at_most(&self, key: &str, v: f64, max: f64) -> Result<f64> {
        if v <= max {
            Ok(v)
        } else {
            self.fail(key, format_args!("must be at most {max} (got {v})"))
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
    pub(super) fn grades(&self, key: &str, v: &[f64], max: f64) -> Result<Vec<f64>> {
        if v.is_empty() {
            return self.fail(key, "must list at least one grade");
        }
        if v.len() > MAX_GRADES {
            return self.fail(
                key,
                format_args!("lists {} grades; at most {MAX_GRADES} are allowed", v.len()),
            );
        }
        for x in v {
            self.at_most(key, self.positive(key, *x)?, max)?;
        }
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s.dedup();
        if s.len() != v.len() {
            return self.fail(key, format_args!("lists a grade twice (got {v:?})"));
        }
        Ok(v.to_vec())
    }
    pub(super) fn method(&self, key: &str, v: &str) -> Result<Method> {
        match Method::parse(v) {
            Some(m) => Ok(m),
            None => self.fail(key, format_args!("must be {} (got \"{v}\")", Method::NAMES)),
        }
    }
}

/// `[geometry]`: the nominal layout and the largest tilt a pose may ask for.
pub(super) fn geometry(c: &Check, g: &GeometrySection) -> Result<(Geometry, f64)> {
    let a = c.length("geometry.a", g.a)?;
    let b = c.length("geometry.b", g.b)?;
    let beta = c.angles3("geometry.base_angles_deg", &g.base_angles_deg)?;
    let alpha = c.angles3("geometry.platform_angles_deg", &g.platform_angles_deg)?;
    let geometry = Geometry::from_circles(a, b, beta, alpha);
    if let Err(rule) = check_layout(&geometry) {
        let side = if rule.base { "base" } else { "platform" };
        return c.fail(&format!("geometry.{side}_angles_deg"), rule.why);
    }
    let max_tilt_deg = g.max_tilt_deg;
    if !(max_tilt_deg.is_finite() && max_tilt_deg > 0.0 && max_tilt_deg < 90.0) {
        return c.fail(
            "geometry.max_tilt_deg",
            format_args!("must be in (0, 90) degrees (got {max_tilt_deg})"),
        );
    }
    Ok((geometry, max_tilt_deg))
}

/// `[workspace]`: the cylinder.
pub(super) fn workspace(c: &Check, w: &WorkspaceSection) -> Result<Workspace> {
    Ok(Workspace {
        radius_mm: c.length("workspace.radius", w.radius)?,
        height_mm: c.length("workspace.height", w.height)?,
        top_mm: c.length("workspace.top", w.top)?,
    })
}

/// `[errors]`: the true errors of a simulated machine, bounded by a tenth of
/// the smaller circumradius `size_mm`.
pub(super) fn errors(
    c: &Check,
    table: &BTreeMap<String, f64>,
    size_mm: f64,
) -> Result<ErrorVector> {
    let mut errors = ErrorVector::zeros();
    for (name, v) in table {
        let Some(k) = param_index(name) else {
            let why = if GAUGE_FIXED.contains(&name.as_str()) {
                " (it is fixed by the frame convention, docs/method.md §3)"
            } else {
                ""
            };
            return c.fail(
                &format!("errors.{name}"),
                format_args!(
                    "is not one of the {N_PARAMS} error names{why}; use {}",
                    PARAM_NAMES.join(", ")
                ),
            );
        };
        if !v.is_finite() || v.abs() > 0.1 * size_mm {
            return c.fail(
                &format!("errors.{name}"),
                format_args!(
                    "must be a finite error in mm smaller than {} (got {v})",
                    0.1 * size_mm
                ),
            );
        }
        errors[k] = *v;
    }
    Ok(errors)
}

/// `[second_class]`: small angles of the simulated machine's axes.
pub(super) fn second_class(c: &Check, sc: &SecondClassSection) -> Result<Option<SecondClass>> {
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
    Ok(if angles.iter().all(|(_, v)| *v == 0.0) {
        None
    } else {
        Some(SecondClass::from_angles_deg(
            sc.hooke_axis1_yaw_deg,
            sc.hooke_axis1_pitch_deg,
            sc.hooke_axes_skew_deg,
            sc.guide_twist_deg,
        ))
    })
}

/// `[sensors]`: grades, samples and how a grade becomes noise.
/// (The datasheet sections are validated by `config::sensors`.)
pub(super) fn sensors(c: &Check, s: &SensorsSection) -> Result<SensorModel<N_READINGS>> {
    let Some(reading) = GradeReading::parse(&s.noise_model) else {
        return c.fail(
            "sensors.noise_model",
            format_args!(
                "must be {} (got \"{}\")",
                GradeReading::NAMES,
                s.noise_model
            ),
        );
    };
    if s.samples == 0 || s.samples > MAX_SAMPLES {
        return c.fail(
            "sensors.samples",
            format_args!(
                "must be between 1 and {MAX_SAMPLES} readings averaged per pose (got {})",
                s.samples
            ),
        );
    }
    Ok(SensorModel {
        slots: SLOTS,
        encoder_arcsec: c.at_most(
            "sensors.encoder_arcsec",
            c.non_negative("sensors.encoder_arcsec", s.encoder_arcsec)?,
            MAX_ENCODER_ARCSEC,
        )?,
        scale_um: c.at_most(
            "sensors.scale_um",
            c.non_negative("sensors.scale_um", s.scale_um)?,
            MAX_SCALE_UM,
        )?,
        samples: s.samples,
        reading,
        structured: None,
    })
}

/// `[identification]`: estimator and Gauss–Newton options.
pub(super) fn identification(
    c: &Check,
    id: &IdentificationSection,
    sensors: &SensorModel<N_READINGS>,
    size_mm: f64,
) -> Result<IdentifyOptions<N_PARAMS>> {
    let method = c.method("identification.method", &id.method)?;
    if id.iterations == 0 || id.iterations > MAX_ITERATIONS {
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
    if let Err(why) = method.check_sensors(sensors) {
        return c.fail("identification.method", format_args!("{why} in [sensors]"));
    }
    let mut constraints = crate::identify::Constraints::default();
    for (name, v) in id.fix.iter().flatten() {
        let Some(k) = param_index(name) else {
            return c.fail(
                &format!("identification.fix.{name}"),
                format_args!(
                    "is not one of the {N_PARAMS} error names; use {}",
                    PARAM_NAMES.join(", ")
                ),
            );
        };
        if !v.is_finite() || v.abs() > 0.1 * size_mm {
            return c.fail(
                &format!("identification.fix.{name}"),
                format_args!(
                    "must be a finite error in mm smaller than {} (got {v})",
                    0.1 * size_mm
                ),
            );
        }
        constraints.fixed[k] = Some(*v);
    }
    if constraints.fixed.iter().all(Option::is_some) {
        return c.fail(
            "identification.fix",
            "holds every error: nothing is left to identify (remove one, or skip identify)",
        );
    }
    if let Some(sp) = id.prior_std_mm {
        if !(sp.is_finite() && sp >= MIN_PRIOR_STD_MM && sp <= 0.1 * size_mm) {
            return c.fail(
                "identification.prior_std_mm",
                format_args!(
                    "must be a standard deviation in mm from {MIN_PRIOR_STD_MM:e} (a nanometre: no geometric error is known better) to {} (got {})",
                    0.1 * size_mm,
                    if sp != 0.0 && sp.is_finite() && !(1e-4..1e6).contains(&sp.abs()) { format!("{sp:e}") } else { sp.to_string() }
                ),
            );
        }
        if method != Method::Gls {
            return c.fail(
                "identification.prior_std_mm",
                format_args!(
                    "needs method = \"gls\" (got \"{}\"): only GLS weighs the readings by their declared covariance, so that readings and prior share one scale",
                    method.name()
                ),
            );
        }
        constraints.prior_std_mm = Some(sp);
    }
    if id.second_class {
        let held = if id.prior_std_mm.is_some() {
            Some("identification.prior_std_mm")
        } else if id.fix.as_ref().is_some_and(|f| !f.is_empty()) {
            Some("identification.fix")
        } else {
            None
        };
        if let Some(key) = held {
            return c.fail(
                "identification.second_class",
                format_args!("cannot be combined with {key} yet: identify the Hooke axes from the readings alone, or leave second_class out"),
            );
        }
        if id.iterations > 1 {
            return c.fail(
                "identification.second_class",
                format_args!("identifies the Hooke axes with one linearisation only (got iterations = {}): set iterations = 1", id.iterations),
            );
        }
    }
    Ok(IdentifyOptions {
        method,
        iterations: id.iterations,
        tolerance_mm: id.tolerance,
        rank_tolerance: id.rank_tolerance,
        constraints,
        second_class: id.second_class,
    })
}

/// `[poses]`: an explicit list or the layered pattern, every pose reachable.
pub(super) fn poses(
    c: &Check,
    p: &PosesSection,
    workspace: &Workspace,
    geometry: &Geometry,
    max_tilt_deg: f64,
) -> Result<Vec<Vector3<f64>>> {
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
            let count = (layers as u128) * (1 + rings.len() as u128 * ppr as u128);
            if count > MAX_POSES as u128 {
                return c.fail(
                    "poses",
                    format_args!("make {count} poses (layers × (1 + rings × points_per_ring)); at most {MAX_POSES} are allowed"),
                );
            }
            pattern(workspace, layers, &rings, ppr)
        }
    };
    if poses.len() > MAX_POSES {
        return c.fail(
            "poses.list",
            format_args!("has {} poses; at most {MAX_POSES} are allowed", poses.len()),
        );
    }
    if poses.len() < 2 {
        return c.fail(
            "poses",
            format_args!(
                "must give at least 2 poses (a reference and one more); got {}",
                poses.len()
            ),
        );
    }
    reachable_poses(c, &poses, geometry, max_tilt_deg)?;
    Ok(poses)
}

/// `[identification] interpolation_coherence_deg` and `_mm`: each ≥ 0 (0:
/// the interpolation error weighted as white noise), at most a turn and
/// 10⁵ mm.
pub(super) fn interpolation_coherence(
    c: &Check,
    id: &IdentificationSection,
) -> Result<(Option<f64>, Option<f64>)> {
    for (key, v, max) in [
        (
            "identification.interpolation_coherence_deg",
            id.interpolation_coherence_deg,
            360.0,
        ),
        (
            "identification.interpolation_coherence_mm",
            id.interpolation_coherence_mm,
            MAX_LENGTH_MM,
        ),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && (0.0..=max).contains(&v)) {
                return c.fail(
                    key,
                    format_args!("must be a coherence length from 0 (white: no coherence assumed) to {max} (got {v})"),
                );
            }
        }
    }
    Ok((
        id.interpolation_coherence_deg,
        id.interpolation_coherence_mm,
    ))
}

/// The largest length a config may give, mm (100 m).
pub const MAX_LENGTH_MM: f64 = 1e5;

/// The smallest prior standard deviation, mm: below it 1/σp² swamps the
/// readings' weights to rounding.
pub const MIN_PRIOR_STD_MM: f64 = 1e-6;

/// `[poses] spread_mm` (None: the default for the sensors) and
/// `reading_separation` (default 0.25).
pub(super) fn reading_separation(
    c: &Check,
    p: &PosesSection,
    workspace: &Workspace,
) -> Result<(Option<f64>, f64)> {
    if let Some(s) = p.spread_mm {
        let most = 0.1 * workspace.radius_mm;
        if !(s.is_finite() && (0.0..=most).contains(&s)) {
            return c.fail(
                "poses.spread_mm",
                format_args!(
                    "must be from 0 to a tenth of the workspace radius, {most} mm (got {s})"
                ),
            );
        }
        if p.list.is_some() && s > 0.0 {
            return c.fail(
                "poses.spread_mm",
                "spreads a generated layout, but poses.list is used as written: remove poses.spread_mm",
            );
        }
    }
    if p.reading_separation.is_some() && p.spread_mm.is_none_or(|s| s <= 0.0) {
        return c.fail(
            "poses.reading_separation",
            "says how far poses.spread_mm keeps readings apart: it needs poses.spread_mm > 0",
        );
    }
    let f = p.reading_separation.unwrap_or(0.25);
    if !(f.is_finite() && f > 0.0 && f <= 0.5) {
        return c.fail(
            "poses.reading_separation",
            format_args!("must be a fraction of a signal period in (0, 0.5] (got {f})"),
        );
    }
    Ok((p.spread_mm, f))
}

/// Every pose of a list must be reachable by the nominal machine.
pub(super) fn reachable_poses(
    c: &Check,
    poses: &[Vector3<f64>],
    geometry: &Geometry,
    max_tilt_deg: f64,
) -> Result<()> {
    let nominal = Machine::nominal(geometry);
    for (k, r) in poses.iter().enumerate() {
        check_pose(&nominal, r, max_tilt_deg).map_err(|why| {
            Error::config(
                c.source,
                format!(
                    "poses: pose {k} ({:.3}, {:.3}, {:.3}) mm is not reachable: {why}",
                    r.x, r.y, r.z
                ),
            )
        })?;
    }
    Ok(())
}

/// `[compensation]`: the map's grid step and plane.
pub(super) fn compensation(
    c: &Check,
    comp: &CompensationSection,
    workspace: &Workspace,
) -> Result<(f64, f64, usize)> {
    let grid_step_mm = c.positive("compensation.grid_step", comp.grid_step)?;
    if grid_step_mm > workspace.radius_mm {
        return c.fail(
            "compensation.grid_step",
            format_args!("must not exceed workspace.radius ({})", workspace.radius_mm),
        );
    }
    if !(1..=MAX_LAYERS).contains(&comp.layers) {
        return c.fail(
            "compensation.layers",
            format_args!("must be between 1 and {MAX_LAYERS} (got {})", comp.layers),
        );
    }
    if (workspace.radius_mm / grid_step_mm).powi(2) * comp.layers as f64 > 4.0e6 {
        return c.fail(
            "compensation.grid_step",
            "is too fine: the map would have more than 12 million points",
        );
    }
    let plane_z_mm = match comp.plane_z {
        Some(z) => c.positive("compensation.plane_z", z)?,
        None => workspace.mid_z(),
    };
    Ok((grid_step_mm, plane_z_mm, comp.layers))
}
