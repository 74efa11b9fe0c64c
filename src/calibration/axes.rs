//! Second-class angles of a mechanism's joint axes in a calibration (the
//! Tricept's Hooke axes, `[identification] second_class = true`), for any
//! mechanism of fixed sizes (P errors, R readings a pose, A angles):
//! identified from the same observation as the errors ([`identify_axes`]),
//! what the readings say of them ([`AxesAnalysis`]), and the refusal of
//! poses that identify fewer of them than the config's own layout does.
//! Their words come from the mechanism's [`Unknowns`].

use crate::error::{Error, Result};
use crate::identify::second_class::SecondClassSolver;
use crate::identify::{EstimateOf, Solver};
use crate::io::Source;
use crate::mechanism::Unknowns;
use crate::sensors::ObservationCovariance;
use nalgebra::{DMatrix, DVector, SVector};

/// A mechanism's second-class angles (A of them, degrees) identified
/// beside its P errors from R readings a pose: the Tricept's first Hooke
/// axis's yaw and pitch and the axes' skew.
#[derive(Debug, Clone)]
pub struct AxesFit<const P: usize, const R: usize, const A: usize> {
    /// The angles' operator (and the errors' estimate's share of them).
    pub solver: SecondClassSolver<P, A, R>,
    /// Degrees.
    pub angles: SVector<f64, A>,
    /// Standard uncertainties, degrees (NaN where not stated).
    pub std_deg: SVector<f64, A>,
    pub identifiable: [bool; A],
}

/// `s`'s possessive: "Hooke axes'" (a plural), "pivot axis's".
fn possessive(s: &str) -> String {
    let singular = ["ss", "is", "us"].iter().any(|e| s.ends_with(e));
    if s.ends_with('s') && !singular {
        format!("{s}'")
    } else {
        format!("{s}'s")
    }
}

/// `s` with its first letter upper case (a sentence's start).
fn sentence(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}

impl<const P: usize, const R: usize, const A: usize> AxesFit<P, R, A> {
    /// What identify says of them, one sentence, in the words of
    /// `unknowns`.
    pub fn in_words(&self, unknowns: &Unknowns<P, A>) -> String {
        let each: Vec<String> = unknowns
            .angles
            .iter()
            .enumerate()
            .map(|(k, n)| match (self.identifiable[k], self.std_deg[k]) {
                (false, _) => format!("{n} not identifiable (0 written)"),
                (true, sd) if sd.is_finite() => format!("{n} = {:.5}° ± {sd:.5}°", self.angles[k]),
                (true, _) => format!("{n} = {:.5}°", self.angles[k]),
            })
            .collect();
        let beyond = match unknowns.beyond {
            "" => String::new(),
            b => format!("; {b} cannot be told from the {P} errors and is not identified"),
        };
        format!(
            "{}, identified with the {P} errors: {}{beyond}",
            sentence(unknowns.axes),
            each.join(", ")
        )
    }
}

/// What the readings say of a mechanism's second-class angles
/// (`second_class = true`): `identifiability` prints it, identify's
/// identifiability.json holds it (under `hooke_axes`, the key the
/// Tricept's files have always used).
#[derive(Debug, Clone, serde::Serialize)]
pub struct AxesAnalysis {
    /// Rank of the design of the errors and angles together.
    pub rank: usize,
    pub names: Vec<&'static str>,
    pub identifiable: Vec<bool>,
    /// Share of each angle's weighted column the errors cannot imitate.
    pub outside_span: Vec<f64>,
    /// Standard deviation of each estimate under the declared sensors, °
    /// (null for an angle the readings do not identify).
    pub predicted_std_deg: Vec<Option<f64>>,
    /// How many errors beside them (not in the file).
    #[serde(skip)]
    pub errors: usize,
    /// The axes the angles turn, and what they leave out, as sentences
    /// name them ([`Unknowns::axes`], [`Unknowns::beyond`]).
    #[serde(skip)]
    pub words: (&'static str, &'static str),
}

impl AxesAnalysis {
    /// From the errors' operator `solver` and the angles' `ext`. `sigma`:
    /// the readings' covariance (a calibration's stated one, or the
    /// declared sensors' at nominal poses when there are no readings).
    pub fn of<const P: usize, const R: usize, const A: usize>(
        solver: &Solver<P, R>,
        ext: &SecondClassSolver<P, A, R>,
        sigma: &ObservationCovariance,
        unknowns: &Unknowns<P, A>,
    ) -> Self {
        let sd = ext.predicted_std(solver, sigma);
        let identifiable = ext.identifiable();
        AxesAnalysis {
            rank: ext.rank(solver),
            names: unknowns.angles.to_vec(),
            identifiable: identifiable.to_vec(),
            outside_span: ext.outside_span(solver).to_vec(),
            predicted_std_deg: (0..A)
                .map(|k| identifiable[k].then_some(sd[P + k]))
                .collect(),
            errors: P,
            words: (unknowns.axes, unknowns.beyond),
        }
    }

    /// The joint design's rank in words, the errors' alone being
    /// `errors_rank`.
    pub fn rank_in_words(&self, errors_rank: usize) -> String {
        format!(
            "with the {}: rank {} of {} (the {} errors' {} and {} of the {} angles)",
            self.words.0,
            self.rank,
            self.errors + self.names.len(),
            self.errors,
            errors_rank,
            self.rank - errors_rank,
            self.names.len()
        )
    }

    /// What `identifiability` says of them, one sentence.
    pub fn in_words(&self) -> String {
        let each: Vec<String> = (0..self.names.len())
            .map(|k| {
                format!(
                    "{} {} ({:.0} % of its effect unlike any error's; σ {})",
                    self.names[k],
                    if self.identifiable[k] {
                        "identifiable"
                    } else {
                        "NOT identifiable"
                    },
                    100.0 * self.outside_span[k],
                    match self.predicted_std_deg[k] {
                        Some(sd) => format!("{sd:.5}°"),
                        None => "n/a".into(),
                    }
                )
            })
            .collect();
        let beyond = match self.words.1 {
            "" => String::new(),
            b => format!(
                " {} is not among them: it moves the readings as the {} errors do.",
                sentence(b),
                self.errors
            ),
        };
        format!(
            "With the {} (second_class = true): rank {} of {}; {}.{beyond}\n",
            self.words.0,
            self.rank,
            self.errors + self.names.len(),
            each.join("; ")
        )
    }
}

/// What an identification of the angles reads beside the observation:
/// the angles' design `h3` (homed rows, as the errors'), the rank
/// tolerance, which angles the config's own pose layout identifies (None:
/// its layout cannot be built), the names, and the log (its poses and
/// file) a refusal names.
pub struct AxesInputs<'a, const P: usize, const A: usize> {
    pub h3: &'a DMatrix<f64>,
    pub rank_tolerance: f64,
    pub layout: Option<[bool; A]>,
    pub unknowns: &'a Unknowns<P, A>,
    pub poses: usize,
    pub file: Source<'a>,
    /// The config file a refusal of `second_class` names.
    pub config: &'a str,
}

/// The angles with the errors from the same observation `l` (one
/// linearisation at the nominal poses) and its stated covariance `sigma`:
/// `estimate` becomes the errors of the joint fit, with their
/// uncertainties. Fewer angles than the config's own layout identifies
/// are refused, naming them.
pub fn identify_axes<const P: usize, const R: usize, const A: usize>(
    inputs: AxesInputs<P, A>,
    solver: &Solver<P, R>,
    (l, sigma): (&DVector<f64>, &ObservationCovariance),
    estimate: &mut EstimateOf<P>,
) -> Result<AxesFit<P, R, A>> {
    let u = inputs.unknowns;
    let ext =
        SecondClassSolver::<P, A, R>::named(solver, inputs.h3, inputs.rank_tolerance, &u.angles)
            .map_err(|why| {
                Error::config(inputs.config, format!("identification.second_class {why}"))
            })?;
    let seen = ext.identifiable();
    if let Some(reach) = inputs.layout {
        let lost: Vec<&str> = (0..A)
            .filter(|&k| reach[k] && !seen[k])
            .map(|k| u.angles[k])
            .collect();
        if !lost.is_empty() {
            return Err(Error::csv(
                inputs.file.name,
                format!(
                    "{} poses identify the {P} errors but not the {} {} that the config's pose layout identifies (second_class = true): log more poses spread over the workspace (design-poses proposes a set), or identify without second_class",
                    inputs.poses,
                    possessive(u.axes),
                    lost.join(", ")
                ),
            ));
        }
    }
    let x = ext.apply(l.as_slice(), &estimate.values);
    let (std, rms) = ext.uncertainties(solver, l, &x, sigma);
    estimate.values = x.errors;
    for k in 0..P {
        if estimate.identifiable[k] {
            estimate.std_mm[k] = std[k];
        }
    }
    estimate.residual_rms = rms;
    estimate.dof = l.len().saturating_sub(ext.rank(solver));
    Ok(AxesFit {
        angles: x.angles,
        std_deg: SVector::from_fn(|i, _| if seen[i] { std[P + i] } else { f64::NAN }),
        identifiable: seen,
        solver: ext,
    })
}

/// What `identifiability` says of a config's poses: how many, the
/// design's rows and its analysis under the config's estimator (the
/// readings' own rank: no fixed error or prior), and with `second_class =
/// true` what they say of the second-class angles.
pub struct PoseAnalysis {
    pub poses: usize,
    pub rows: usize,
    pub analysis: crate::identify::Identifiability,
    pub axes: Option<AxesAnalysis>,
}

#[cfg(test)]
#[path = "axes_tests.rs"]
mod tests;
