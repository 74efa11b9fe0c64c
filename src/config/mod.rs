//! The one validated configuration (docs/method.md §10).
//!
//! Two stages, like ripgrep's low/high arguments: [`raw::RawConfig`] is what
//! the TOML says; [`Config::from_raw`] hands each section to its validator in
//! [`validate`], which names the key and the allowed range on failure and
//! resolves geometry, errors, sensors, poses and options into model types
//! before any work starts. Command-line overrides are applied to the raw
//! values first, so they are validated the same way. Studies other than the
//! config's own `[sweep]` (reports, pose design) are built with the typed
//! [`study::StudyBuilder`].

mod catalogue;
pub mod general;
pub mod hexapod;
pub mod raw;
mod sensors;
pub mod study;
mod validate;
pub use validate::MAX_TRIALS;
mod validate_study;

pub use catalogue::{encoder_products, Product, Products};
pub use raw::{load_raw, load_text, parse_raw, RawConfig, PAPER_TOML};
pub use study::{Study, StudyBuilder};

/// The study a config states: a [`Study`] at its mechanism's sizes (the
/// Tricept's 15 errors and 3 readings).
pub type ConfigStudy = Study<N_PARAMS, N_READINGS>;

/// A row of the log of the mechanism a [`Config`] describes (the Tricept's
/// target and joints).
pub type ConfigRow = crate::mechanism::tricept::Reading;

use crate::error::Result;
use crate::identify::{IdentifyOptions, Method};
use crate::mechanism::tricept::geometry::SecondClass;
use crate::mechanism::tricept::second_class::{N_ANGLES, UNKNOWNS};
use crate::mechanism::tricept::topology::Tricept;
use crate::mechanism::tricept::{
    length_travel, ErrorVector, Geometry, Machine, NominalPoses, LENGTH_READING, N_PARAMS,
    N_READINGS, SLOTS,
};
use crate::mechanism::Workspace;
use crate::metrics::Decision;
use crate::sensors::SensorModel;
use nalgebra::Vector3;
use serde::Serialize;
use validate::Check;

/// The coherence GLS assumes for an encoder's interpolation error unless
/// `[identification] interpolation_coherence_deg` says: short, so that it
/// never assumes more coherence than the sensor has (docs/method.md §18).
pub const DEFAULT_COHERENCE_DEG: f64 = 1.0;
/// The scale's, as a fraction of its travel (`interpolation_coherence_mm`):
/// 1/60, as 1° is of a Hooke joint's 60°.
pub const DEFAULT_COHERENCE_FRACTION: f64 = 1.0 / 60.0;

/// How the sweep draws each trial's true errors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ErrorDraw {
    /// Uniform in ±error_bound per parameter, a new set per trial.
    Random,
    /// The [errors] table for every trial (noise draws only; the paper's Fig. 4).
    Fixed,
}

/// A study's `[sweep]`, for a mechanism of R readings a pose.
#[derive(Debug, Clone)]
pub struct SweepConfig<const R: usize> {
    pub encoder_arcsec: Vec<f64>,
    pub scale_um: Vec<f64>,
    pub trials: u64,
    pub errors: ErrorDraw,
    pub error_bound_mm: f64,
    pub seed: u64,
    pub methods: Vec<Method>,
    /// Grid step of the per-calibration volumetric map (None: off).
    pub volumetric_step_mm: Option<f64>,
    /// Exact kinematics for that map instead of first-order propagation.
    pub volumetric_exact: bool,
    /// Catalogue products compared instead of the grade lists.
    pub products: Option<Products<R>>,
    /// Numbers of calibration poses compared (the last is every pose).
    pub pose_counts: Vec<usize>,
    /// How the true sensors differ from the datasheets, the datasheet
    /// itself first.
    pub truth: Vec<Truth>,
    /// `[sweep] second_class_tolerance_deg`, increasing.
    pub second_class_tolerance_deg: Vec<f64>,
    /// Set only in the what-if study of one tolerance: every machine draws
    /// its four second-class errors uniformly within ± this, degrees.
    pub second_class_draw_deg: Option<f64>,
    /// Set only in the deciding metric's error budget: the reading slots
    /// (the Tricept's ψ4, θ4, q4) whose reading errors are zero in this
    /// study (the estimators still weight them by their datasheets).
    pub perfect_sensors: [bool; R],
    /// A follow-up study of another (a tolerance, a budget rerun, the
    /// Hooke axes identified): it runs no follow-ups of its own. Internal.
    pub follow_up: bool,
    /// `until_decided`: the most machines to run before the study decides
    /// (None: exactly `trials`).
    pub until_decided_max: Option<u64>,
    /// `gls_per_machine`: GLS weights each machine at its own readings
    /// (None: wherever it applies: GLS of one linearisation without the
    /// Hooke axes, whose datasheet interpolation error has a kernel).
    pub gls_per_machine: Option<bool>,
}

/// How a study's true sensors differ from what their datasheets (and so the
/// estimators) say: their curves `amplitude` × the datasheet's, plus a
/// harmonic one order above the datasheet's last of `extra_harmonic` × the
/// accuracy (0: none), their white terms `white` × the datasheet's, their
/// curves whole at the grade's bound in one order outside the model's
/// (`outside_order`), or their encoder rings mounted with up to
/// `eccentricity_um` of eccentricity; or (the error budget's reruns,
/// internal) the datasheet's sensors with one error term read exactly.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Truth {
    pub amplitude: f64,
    pub extra_harmonic: f64,
    pub white: f64,
    pub outside_order: bool,
    pub eccentricity_um: Option<f64>,
    pub exact_term: Option<crate::sensors::ErrorTerm>,
    /// The interpolation errors coherent over this fraction of the length
    /// the estimator assumes (`truth_coherence_fraction`).
    pub coherence_fraction: Option<f64>,
}

impl Truth {
    /// The datasheet itself.
    pub const DATASHEET: Truth = Truth {
        amplitude: 1.0,
        extra_harmonic: 0.0,
        white: 1.0,
        outside_order: false,
        eccentricity_um: None,
        exact_term: None,
        coherence_fraction: None,
    };

    pub fn is_datasheet(&self) -> bool {
        *self == Truth::DATASHEET
    }

    /// The what-if in words, as a buyer would name it.
    pub fn label(&self) -> String {
        if let Some(t) = self.exact_term {
            format!("the {} read exactly", t.name())
        } else if let Some(f) = self.coherence_fraction {
            format!("interpolation errors coherent over {f}× the length the estimator assumes")
        } else if self.extra_harmonic > 0.0 {
            format!(
                "curves carrying a harmonic the datasheet model omits ({} × the grade)",
                self.extra_harmonic
            )
        } else if self.white != 1.0 {
            format!(
                "white terms (interpolation error, jitter) {}× the datasheet's",
                self.white
            )
        } else if self.outside_order {
            "curves at the grade's bound in one harmonic outside the model's orders".into()
        } else if let Some(e) = self.eccentricity_um {
            format!("installed encoder rings mounted to {e} µm of eccentricity instead of their stated tolerance")
        } else if self.amplitude == 1.0 {
            "the datasheet".into()
        } else {
            format!("curves {}× the datasheet's", self.amplitude)
        }
    }

    /// The datasheet models `st` as these true sensors.
    pub fn apply<const R: usize>(
        &self,
        st: &crate::sensors::Structured<R>,
    ) -> crate::sensors::Structured<R> {
        let mut s = st.with_curves_scaled(self.amplitude);
        if self.extra_harmonic > 0.0 {
            s = s.with_extra_harmonic(self.extra_harmonic);
        }
        if self.white != 1.0 {
            s = s.with_white_scaled(self.white);
        }
        if self.outside_order {
            s = s.with_curve_outside_order();
        }
        if let Some(e) = self.eccentricity_um {
            s = s.with_eccentricity_um(e);
        }
        if let Some(t) = self.exact_term {
            s = s.with_term_exact(t);
        }
        if let Some(f) = self.coherence_fraction {
            s = s.with_coherence_fraction(f);
        }
        s
    }
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
    /// The raw values it was validated from (for manifests and shard
    /// metadata; studies are built with [`Config::study`], never by editing it).
    raw: RawConfig,
    pub geometry: Geometry,
    pub max_tilt_deg: f64,
    pub workspace: Workspace,
    /// The `[errors]` table: the simulated machine's true errors (zero when
    /// absent; see [`Config::has_truth`]).
    pub errors: ErrorVector,
    /// False for a real machine's config (no `[errors]`): its true errors are
    /// unknown, so nothing may be simulated from it or compared with a truth.
    pub has_truth: bool,
    /// Second-class errors of the true machine (None when all zero).
    pub second_class: Option<SecondClass>,
    pub sensors: SensorModel<N_READINGS>,
    pub poses: Vec<Vector3<f64>>,
    pub identification: IdentifyOptions<N_PARAMS>,
    pub grid_step_mm: f64,
    pub plane_z_mm: f64,
    /// Planes of the workspace grid (docs/method.md §12).
    pub layers: usize,
    pub sweep: SweepConfig<N_READINGS>,
    pub decision: Decision,
    pub reproduce: ReproduceConfig,
}

impl Config {
    /// Validate every value of a raw config; errors name `source` and the key.
    pub fn from_raw(mut raw: RawConfig, source: &str) -> Result<Config> {
        let c = Check { source };
        if raw.mechanism.kind != "tricept" {
            return c.fail(
                "mechanism.kind",
                format_args!(
                    "must be \"tricept\" or \"hexapod\" (got \"{}\")",
                    raw.mechanism.kind
                ),
            );
        }
        let (geometry, max_tilt_deg) = validate::geometry(&c, &raw.geometry)?;
        let size_mm = raw.geometry.a.min(raw.geometry.b);
        let workspace = validate::workspace(&c, &raw.workspace)?;
        let errors = match &raw.errors {
            Some(table) => validate::errors(&c, table, size_mm)?,
            None => ErrorVector::zeros(),
        };
        let has_truth = raw.errors.is_some();
        let second_class = validate::second_class(&c, &raw.second_class)?;
        let mut sensors = validate::sensors(&c, &raw.sensors)?;
        // The Tricept's [sensors]: ψ4 and θ4 each may have an encoder
        // section of its own, q4's scale is [sensors.scale].
        let stroke = sensors::Stroke {
            span_mm: length_travel(&workspace),
            symbol: SLOTS[LENGTH_READING].symbol,
        };
        sensors.structured = sensors::structured(
            &c,
            &raw.sensors,
            &sensors::SlotSections {
                slots: SLOTS,
                own: [
                    Some(("sensors.encoder_psi", &raw.sensors.encoder_psi)),
                    Some(("sensors.encoder_theta", &raw.sensors.encoder_theta)),
                    None,
                ],
                stroke,
            },
        )?;
        let identification = validate::identification(&c, &raw.identification, &sensors, size_mm)?;
        let poses = validate::poses(&c, &raw.poses, &workspace, &geometry, max_tilt_deg)?;
        let (grid_step_mm, plane_z_mm, layers) =
            validate::compensation(&c, &raw.compensation, &workspace)?;
        let mut sweep = validate_study::sweep(
            &c,
            &raw.sweep,
            layers,
            &workspace,
            identification.method,
            size_mm,
        )?;
        sweep.products = catalogue::products(&c, &raw.sweep, stroke, SLOTS)?;
        if identification.constraints.prior_std_mm.is_some() {
            if let Some(m) = sweep
                .methods
                .iter()
                .find(|m| **m != crate::identify::Method::Gls)
            {
                return c.fail(
                    "sweep.methods",
                    format_args!(
                        "holds \"{}\", but identification.prior_std_mm needs GLS, whose weights put readings and prior on one scale: set sweep.methods = [\"gls\"]",
                        m.name()
                    ),
                );
            }
        }
        if sensors.reading == crate::sensors::GradeReading::Uniform
            && (sensors.structured.is_some() || sweep.products.is_some())
        {
            return c.fail(
                "sensors.noise_model",
                "= \"uniform\" reads a bare grade, but this config describes its sensors by datasheet ([sensors.encoder]/[sensors.scale] or a catalogue), whose jitter is Gaussian and whose grade-only axes are read as σ: remove the key, or give the bound as the datasheet's accuracy",
            );
        }
        // The coherence GLS assumes for each sensor's interpolation error.
        let (coh_deg, coh_frac) = validate::interpolation_coherence(&c, &raw.identification)?;
        let set_coherence = |st: &mut crate::sensors::Structured<N_READINGS>| {
            for (k, a) in st.axes.iter_mut().enumerate() {
                a.weight_coherence = match k {
                    2 => coh_frac.map_or(DEFAULT_COHERENCE_FRACTION * a.period, |mm| mm),
                    _ => coh_deg.unwrap_or(DEFAULT_COHERENCE_DEG).to_radians(),
                };
            }
        };
        if let Some(st) = sensors.structured.as_mut() {
            set_coherence(st);
        }
        if let Some(p) = sweep.products.as_mut() {
            p.models.iter_mut().for_each(set_coherence);
        }
        // A generated layout spread so that no two poses read a sensor at
        // nearly one value (its interpolation error would be one).
        let mut poses = poses;
        let reading_separation = validate::reading_separation(&c, &raw.poses, &workspace)?;
        {
            let models = sensors
                .structured
                .iter()
                .chain(sweep.products.iter().flat_map(|p| p.models.iter()));
            let mut periods = [0.0f64; 3];
            for st in models {
                for (p, a) in periods.iter_mut().zip(&st.axes) {
                    if a.interpolation > 0.0 && a.signal_period > 0.0 {
                        *p = p.max(a.signal_period);
                    }
                }
            }
            let (spread_mm, fraction) = reading_separation;
            if spread_mm.is_some_and(|s| s > 0.0) && periods.iter().all(|&p| p <= 0.0) {
                return c.fail(
                    "poses.spread_mm",
                    "keeps readings a fraction of a signal period apart, but no sensor of this config has an interpolation error with a signal period: remove it",
                );
            }
            if raw.poses.list.is_none() && spread_mm.is_some_and(|s| s > 0.0) {
                let spread = crate::mechanism::tricept::poses::Spread {
                    spread_mm: spread_mm.unwrap_or(0.0),
                    periods,
                    fraction,
                };
                crate::mechanism::tricept::poses::spread(
                    &Machine::nominal(&geometry),
                    &mut poses,
                    workspace.radius_mm,
                    &spread,
                );
                validate::reachable_poses(&c, &poses, &geometry, max_tilt_deg)?;
            }
        }
        if let Some(p) = &sweep.products {
            // Manifests and shards record the catalogue as resolved, so that
            // `merge` finds it from any folder.
            let path = std::fs::canonicalize(&p.path).unwrap_or_else(|_| p.path.clone());
            raw.sweep.catalogue = Some(path.display().to_string());
        }
        sweep.pose_counts = validate_study::pose_counts(&c, &raw.sweep, poses.len())?;
        sweep.second_class_tolerance_deg =
            validate_study::second_class_tolerances(&c, &raw.sweep, second_class.is_some())?;
        sweep.truth = validate_study::truth(
            &c,
            &raw.sweep,
            sensors.structured.is_some() || sweep.products.is_some(),
        )?;
        let models: Vec<&crate::sensors::Structured<N_READINGS>> = sensors
            .structured
            .iter()
            .chain(sweep.products.iter().flat_map(|p| p.models.iter()))
            .collect();
        if sweep.truth.iter().any(|t| t.extra_harmonic > 0.0) {
            for st in &models {
                let unknown = (0..3).find(|&k| {
                    st.from_section[k]
                        && st.axes[k].shape == crate::sensors::structured::Shape::Unknown
                });
                if let Some(k) = unknown {
                    return c.fail(
                        "sweep.truth_extra_harmonic",
                        format_args!(
                            "adds a harmonic to a listed shape, and the {} has harmonics = \"unknown\": use sweep.truth_outside_order = true (curves at the grade's bound outside curve_order) instead",
                            crate::mechanism::tricept::READINGS[k].sensor
                        ),
                    );
                }
            }
        }
        if let Some(e) = sweep.truth.iter().find_map(|t| t.eccentricity_um) {
            let installed = models
                .iter()
                .any(|st| (0..2).any(|k| st.from_section[k] && st.axes[k].eccentricity > 0.0));
            if !installed {
                return c.fail(
                    "sweep.truth_eccentricity_um",
                    format_args!(
                        "= {e} changes the eccentricity of installed rings, and no encoder of the study states one (eccentricity_um with ring_diameter_mm): nothing would differ"
                    ),
                );
            }
        }
        let decision = validate_study::decision(&c, &raw.decision, raw.sweep.volumetric)?;
        let reproduce = validate_study::reproduce(&c, &raw.reproduce)?;
        Ok(Config {
            source: source.to_string(),
            raw,
            geometry,
            max_tilt_deg,
            workspace,
            errors,
            has_truth,
            second_class,
            sensors,
            poses,
            identification,
            grid_step_mm,
            plane_z_mm,
            layers,
            sweep,
            decision,
            reproduce,
        })
    }

    /// The built-in paper case.
    pub fn paper() -> Result<Config> {
        let source = "<built-in configs/paper.toml>";
        Config::from_raw(parse_raw(PAPER_TOML, source)?, source)
    }

    /// The raw values this config was validated from, with defaults filled
    /// in (what manifests record and shards compare).
    pub fn resolved(&self) -> &RawConfig {
        &self.raw
    }

    /// The keys that set the nominal machine, with their values: what
    /// identify records and compensate, export and verify check
    /// (the store's nominal record).
    pub fn nominal_keys(&self) -> Vec<(String, Vec<f64>)> {
        let g = &self.raw.geometry;
        vec![
            ("geometry.a".into(), vec![g.a]),
            ("geometry.b".into(), vec![g.b]),
            ("geometry.base_angles_deg".into(), g.base_angles_deg.clone()),
            (
                "geometry.platform_angles_deg".into(),
                g.platform_angles_deg.clone(),
            ),
        ]
    }

    pub fn nominal(&self) -> Machine {
        Machine::nominal(&self.geometry)
    }

    /// Its mechanism as any `Kinematic` topology is read: the Tricept on
    /// its nominal geometry.
    pub fn homed(&self) -> crate::mechanism::Homed<'_, Tricept, N_PARAMS, N_READINGS> {
        crate::mechanism::Homed::new(&self.geometry)
    }

    /// Where its tool may go: the Tricept on its nominal geometry, and the
    /// tilt beyond which a target is refused.
    pub fn reach(&self) -> crate::mechanism::Reach<'_, Tricept, N_PARAMS, N_READINGS> {
        crate::mechanism::Reach {
            homed: self.homed(),
            max_tilt_deg: self.max_tilt_deg,
        }
    }

    /// The names its identified model is written and read under: the
    /// Tricept's 15 errors, then the Hooke axes' angles.
    pub fn unknowns(&self) -> &'static crate::mechanism::Unknowns<N_PARAMS, N_ANGLES> {
        &UNKNOWNS
    }

    /// The simulated true machine: nominal + [errors] + [second_class].
    /// A real machine's config (no `[errors]`) has none: `needs` says what
    /// asked for it, in the message.
    pub fn truth(&self, needs: &str) -> Result<Machine> {
        if !self.has_truth {
            return Err(crate::error::Error::config(
                &self.source,
                format!(
                    "errors: {needs} needs the simulated machine's true errors, and this config has no [errors] table (a real machine's config has none; add [errors] to simulate one)"
                ),
            ));
        }
        Ok(Machine {
            second: self.second_class,
            ..Machine::with_errors(&self.geometry, &self.errors)
        })
    }

    /// Nominal configurations of the config's poses (validation already
    /// checked that they are reachable).
    pub fn nominal_poses(&self) -> Result<NominalPoses> {
        NominalPoses::new(&self.nominal(), &self.poses)
            .map_err(|e| crate::error::Error::config(&self.source, format!("poses: {e}")))
    }

    /// A study starting from this config's poses, `[sweep]`, `[identification]`
    /// and `[decision]`, to be changed with typed setters.
    pub fn study(&self) -> StudyBuilder<'_> {
        StudyBuilder::new(self)
    }

    /// The digest of the catalogue's content as read (None without one):
    /// with the resolved config and the version, a study's identity.
    pub fn catalogue_digest(&self) -> Option<&str> {
        self.sweep.products.as_ref().map(|p| p.digest.as_str())
    }

    /// The jitter draws of one simulated machine at `poses` poses: every
    /// sample of every noisy quantised reading (one per reading when not
    /// quantised), the most of any datasheet model the study reads.
    pub fn jitter_draws(&self, poses: usize) -> u64 {
        let samples = self.sensors.samples;
        self.sensors
            .structured
            .iter()
            .chain(self.sweep.products.iter().flat_map(|p| p.models.iter()))
            .map(|st| {
                st.axes
                    .iter()
                    .map(|a| (a.draws_per_reading(samples) * poses) as u64)
                    .sum::<u64>()
            })
            .max()
            .unwrap_or(0)
    }
}
