//! A Monte-Carlo study as the sweep runs it: poses, grades, machines,
//! estimators and the decision. The config's own `[sweep]` is one; reports
//! and pose design build others from it with typed setters, validated by the
//! same checks as the file.

use super::validate::{self, Check};
use super::validate_study;
use super::{Config, ConfigStudy, ErrorDraw, SweepConfig};
use crate::error::Result;
use crate::identify::{IdentifyOptions, Method};
use crate::metrics::Decision;
use crate::sensors::{SensorModel, ARCSEC_PER_RAD};
use nalgebra::Vector3;

/// What a sweep runs, on a mechanism of P errors and R readings a pose.
#[derive(Debug, Clone)]
pub struct Study<const P: usize, const R: usize> {
    /// Calibration poses, the reference first.
    pub poses: Vec<Vector3<f64>>,
    pub sweep: SweepConfig<R>,
    pub identification: IdentifyOptions<P>,
    pub decision: Decision,
}

impl<const P: usize, const R: usize> Study<P, R> {
    /// The sensor sets the study compares, each `base` (the config's
    /// `[sensors]`) at its grades, scale-major: catalogue pairs (their
    /// datasheet models), or the grade lists (the grade axis sets a datasheet
    /// model's accuracy, docs/method.md §11; the paper's reading without one).
    pub fn sensor_sets(&self, base: &SensorModel<R>) -> Vec<SensorModel<R>> {
        let sw = &self.sweep;
        if let Some(p) = &sw.products {
            return (0..p.models.len())
                .map(|i| {
                    let (e, s) = p.pair(i);
                    SensorModel {
                        encoder_arcsec: e.grade,
                        scale_um: s.grade,
                        structured: Some(p.models[i]),
                        ..*base
                    }
                })
                .collect();
        }
        let mut sensors = Vec::new();
        for &s in &sw.scale_um {
            for &e in &sw.encoder_arcsec {
                let structured = base
                    .structured
                    .map(|st| st.at_grades(e / ARCSEC_PER_RAD, s * 1e-3));
                sensors.push(SensorModel {
                    encoder_arcsec: e,
                    scale_um: s,
                    structured,
                    ..*base
                });
            }
        }
        sensors
    }

    /// Calibrations per trial: sensor sets × estimators × pose counts.
    pub fn grades(&self) -> u64 {
        let sensors = match &self.sweep.products {
            Some(p) => p.models.len(),
            None => self.sweep.encoder_arcsec.len() * self.sweep.scale_um.len(),
        };
        (sensors
            * self.sweep.truth.len().max(1)
            * self.sweep.methods.len()
            * self.sweep.pose_counts.len().max(1)) as u64
    }

    /// At most how many grades record their linearisation error in each
    /// trial (GLS weighted per machine, the datasheet truth): every GLS
    /// grade of the datasheet truth unless `gls_per_machine = false`, the
    /// Hooke axes are identified or Gauss–Newton iterates.
    pub fn recorded_grades(&self) -> u64 {
        let gls = self
            .sweep
            .methods
            .iter()
            .filter(|&&m| m == Method::Gls)
            .count();
        if gls == 0
            || self.sweep.gls_per_machine == Some(false)
            || self.identification.second_class
            || self.identification.iterations > 1
        {
            return 0;
        }
        let sensors = match &self.sweep.products {
            Some(p) => p.models.len(),
            None => self.sweep.encoder_arcsec.len() * self.sweep.scale_um.len(),
        };
        (sensors * gls * self.sweep.pose_counts.len().max(1)) as u64
    }

    /// Numbers a GLS solver's weighting keeps per observation row: the
    /// largest factored Σ's columns of any sensor set the study reads with
    /// GLS, each `base` (the config's `[sensors]`) with its datasheet
    /// model (1 without GLS: row weights).
    pub fn weight_columns(&self, base: &SensorModel<R>) -> u64 {
        if !self.sweep.methods.contains(&Method::Gls) {
            return 1;
        }
        let of = |m: &SensorModel<R>| -> u64 {
            m.covariances()
                .iter()
                .map(crate::sensors::factored::factor_columns)
                .max()
                .unwrap_or(1) as u64
        };
        match &self.sweep.products {
            Some(p) => p
                .models
                .iter()
                .map(|st| {
                    of(&SensorModel {
                        structured: Some(*st),
                        ..*base
                    })
                })
                .max()
                .unwrap_or(1),
            None => of(base),
        }
    }
}

/// Builds a [`Study`] from a config, changing only what is set.
#[derive(Debug, Clone)]
pub struct StudyBuilder<'a> {
    cfg: &'a Config,
    study: ConfigStudy,
}

impl<'a> StudyBuilder<'a> {
    pub(super) fn new(cfg: &'a Config) -> Self {
        StudyBuilder {
            cfg,
            study: Study {
                poses: cfg.poses.clone(),
                sweep: cfg.sweep.clone(),
                identification: cfg.identification,
                decision: cfg.decision,
            },
        }
    }

    /// Calibration poses (the first is the reference).
    pub fn poses(mut self, poses: &[Vector3<f64>]) -> Self {
        self.study.poses = poses.to_vec();
        self
    }

    /// Encoder grades, arc-seconds.
    pub fn encoder_arcsec(mut self, grades: &[f64]) -> Self {
        self.study.sweep.encoder_arcsec = grades.to_vec();
        self
    }

    /// Linear-scale grades, µm.
    pub fn scale_um(mut self, grades: &[f64]) -> Self {
        self.study.sweep.scale_um = grades.to_vec();
        self
    }

    /// Numbers of calibration poses compared (subsets by the spread rule).
    pub fn pose_counts(mut self, counts: &[usize]) -> Self {
        self.study.sweep.pose_counts = counts.to_vec();
        self
    }

    pub fn trials(mut self, trials: u64) -> Self {
        self.study.sweep.trials = trials;
        self
    }

    /// Random machines or the config's fixed `[errors]`.
    pub fn errors(mut self, draw: ErrorDraw) -> Self {
        self.study.sweep.errors = draw;
        self
    }

    pub fn seed(mut self, seed: u64) -> Self {
        self.study.sweep.seed = seed;
        self
    }

    /// Estimators compared on the same trials.
    pub fn methods(mut self, methods: &[Method]) -> Self {
        self.study.sweep.methods = methods.to_vec();
        self
    }

    /// Linearisations per calibration (1 = the paper; more = Gauss–Newton).
    pub fn iterations(mut self, iterations: usize) -> Self {
        self.study.identification.iterations = iterations;
        self
    }

    /// Check what was set with the config file's rules.
    pub fn build(self) -> Result<ConfigStudy> {
        let source = format!("{} (study)", self.cfg.source);
        let c = Check { source: &source };
        let mut s = self.study;
        // The default pose count (every pose) follows a new pose list.
        if s.sweep.pose_counts.is_empty() || s.sweep.pose_counts == [self.cfg.poses.len()] {
            s.sweep.pose_counts = vec![s.poses.len()];
        }
        validate_study::check_pose_counts(&c, &s.sweep.pose_counts, s.poses.len())?;
        c.grades(
            "sweep.encoder_arcsec",
            &s.sweep.encoder_arcsec,
            validate::MAX_ENCODER_ARCSEC,
        )?;
        c.grades("sweep.scale_um", &s.sweep.scale_um, validate::MAX_SCALE_UM)?;
        if s.sweep.trials == 0 || s.sweep.trials > validate::MAX_TRIALS {
            return c.fail(
                "sweep.trials",
                format_args!(
                    "must be between 1 and {} (got {})",
                    validate::MAX_TRIALS,
                    s.sweep.trials
                ),
            );
        }
        if s.sweep.methods.is_empty() {
            return c.fail("sweep.methods", "must list at least one method");
        }
        if (1..s.sweep.methods.len()).any(|i| s.sweep.methods[..i].contains(&s.sweep.methods[i])) {
            return c.fail("sweep.methods", "lists a method twice");
        }
        if !(1..=validate::MAX_ITERATIONS).contains(&s.identification.iterations) {
            return c.fail(
                "identification.iterations",
                format_args!(
                    "must be between 1 and {} (got {})",
                    validate::MAX_ITERATIONS,
                    s.identification.iterations
                ),
            );
        }
        if s.poses.len() < 2 {
            return c.fail(
                "poses",
                "must give at least 2 poses (a reference and one more)",
            );
        }
        validate::reachable_poses(&c, &s.poses, &self.cfg.geometry, self.cfg.max_tilt_deg)?;
        Ok(s)
    }
}
