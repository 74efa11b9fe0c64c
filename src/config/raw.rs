//! The first stage: the TOML as written (serde, `deny_unknown_fields`, the
//! paper's values as defaults per field). Nothing here is validated; see
//! [`super::Config::from_raw`].

use crate::error::{Error, Result};
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
pub struct MechanismSection {
    pub kind: String,
}

impl MechanismSection {
    pub fn is_tricept(&self) -> bool {
        self.kind == "tricept"
    }
}

impl Default for MechanismSection {
    fn default() -> Self {
        MechanismSection {
            kind: "tricept".into(),
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
    /// Both Hooke-joint encoders as their datasheets describe them (docs/method.md §11).
    pub encoder: Option<EncoderSection>,
    /// One encoder alone (ψ4 or θ4); overrides `encoder` for that axis.
    pub encoder_psi: Option<EncoderSection>,
    pub encoder_theta: Option<EncoderSection>,
    /// The linear scale as its datasheet describes it.
    pub scale: Option<ScaleSection>,
}

/// An angle encoder's datasheet (docs/method.md §11), arc-seconds.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EncoderSection {
    pub accuracy_arcsec: f64,
    pub harmonics: Harmonics,
    /// The orders an unknown shape may hold (None: 6).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub curve_order: Option<i64>,
    pub interpolation_arcsec: f64,
    pub signal_period_arcsec: f64,
    pub noise_arcsec: f64,
    pub resolution_arcsec: f64,
    /// Mounting eccentricity of the ring, µm (up to), and its graduation
    /// diameter, mm.
    pub eccentricity_um: f64,
    pub ring_diameter_mm: f64,
    /// 1, or 2 opposite readheads averaged.
    pub readheads: i64,
    /// Coherence length of the interpolation error, degrees of rotation
    /// (None: stationary, a fixed sinusoid of the signal period).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interpolation_coherence_deg: Option<f64>,
}

impl Default for EncoderSection {
    fn default() -> Self {
        EncoderSection {
            accuracy_arcsec: 2.0,
            harmonics: Harmonics::List(vec![1.0]),
            curve_order: None,
            interpolation_arcsec: 0.0,
            signal_period_arcsec: 0.0,
            noise_arcsec: 0.0,
            resolution_arcsec: 0.0,
            eccentricity_um: 0.0,
            ring_diameter_mm: 0.0,
            readheads: 1,
            interpolation_coherence_deg: None,
        }
    }
}

/// `harmonics`: the datasheet's fractions of the grade, or "unknown".
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Harmonics {
    List(Vec<f64>),
    Word(String),
}

impl<'de> Deserialize<'de> for Harmonics {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Harmonics;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a list of fractions of the grade, or \"unknown\"")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> std::result::Result<Harmonics, E> {
                Ok(Harmonics::Word(v.to_string()))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut seq: A,
            ) -> std::result::Result<Harmonics, A::Error> {
                let mut out = Vec::new();
                while let Some(x) = seq.next_element::<f64>()? {
                    out.push(x);
                }
                Ok(Harmonics::List(out))
            }
        }
        d.deserialize_any(V)
    }
}

/// A linear scale's datasheet (docs/method.md §11), µm.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ScaleSection {
    pub accuracy_um: f64,
    pub harmonics: Harmonics,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub curve_order: Option<i64>,
    /// Measuring length, mm (0: the q4 span of the workspace).
    pub length_mm: f64,
    pub interpolation_um: f64,
    pub signal_period_um: f64,
    pub noise_um: f64,
    pub resolution_um: f64,
    /// Coherence length of the interpolation error, mm of travel (None:
    /// stationary).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interpolation_coherence_mm: Option<f64>,
}

impl Default for ScaleSection {
    fn default() -> Self {
        ScaleSection {
            accuracy_um: 0.5,
            harmonics: Harmonics::List(vec![1.0]),
            curve_order: None,
            length_mm: 0.0,
            interpolation_um: 0.0,
            signal_period_um: 0.0,
            noise_um: 0.0,
            resolution_um: 0.0,
            interpolation_coherence_mm: None,
        }
    }
}

impl Default for SensorsSection {
    fn default() -> Self {
        SensorsSection {
            encoder_arcsec: 0.8,
            scale_um: 0.5,
            samples: 3,
            noise_model: "sigma".into(),
            encoder: None,
            encoder_psi: None,
            encoder_theta: None,
            scale: None,
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
    /// Largest move of a generated pose in x and y, mm, so that no two read
    /// a sensor within `reading_separation` of its signal period (default
    /// 0: the layout as generated).
    pub spread_mm: Option<f64>,
    /// Fraction of a signal period within which two readings count as one
    /// (default 0.25).
    pub reading_separation: Option<f64>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IdentificationSection {
    pub method: String,
    pub iterations: usize,
    pub tolerance: f64,
    pub rank_tolerance: f64,
    /// Errors measured elsewhere, held at these values (mm).
    pub fix: Option<BTreeMap<String, f64>>,
    /// A Gaussian prior N(0, σ²) on every free error, σ in mm.
    pub prior_std_mm: Option<f64>,
    /// Identify the Hooke axes' yaw, pitch and skew too.
    pub second_class: bool,
    /// The coherence length GLS assumes for the encoders' interpolation
    /// error, degrees of rotation (default 3; 0: weighted as white noise).
    pub interpolation_coherence_deg: Option<f64>,
    /// The same for the scale, mm (default 5 % of its travel).
    pub interpolation_coherence_mm: Option<f64>,
}

impl Default for IdentificationSection {
    fn default() -> Self {
        IdentificationSection {
            method: "ols".into(),
            iterations: 1,
            tolerance: 1e-9,
            rank_tolerance: 1e-9,
            fix: None,
            prior_std_mm: None,
            second_class: false,
            interpolation_coherence_deg: None,
            interpolation_coherence_mm: None,
        }
    }
}

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CompensationSection {
    pub grid_step: f64,
    /// z of the map plane, mm (default: the mid-plane H + h/2).
    pub plane_z: Option<f64>,
    /// Planes of the workspace grid, top face to bottom face (1: mid-plane).
    pub layers: usize,
}

impl Default for CompensationSection {
    fn default() -> Self {
        CompensationSection {
            grid_step: 20.0,
            plane_z: None,
            layers: 5,
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
    /// dV by exact kinematics at every point instead of first-order
    /// propagation from precomputed sensitivities.
    pub volumetric_exact: bool,
    /// A sensor catalogue (path relative to this config's folder): the study
    /// then compares its products instead of the grade lists.
    pub catalogue: Option<String>,
    /// Encoder products of the catalogue to compare (default: all).
    pub encoders: Option<Vec<String>>,
    /// Scale products of the catalogue to compare (default: all).
    pub scales: Option<Vec<String>>,
    /// Numbers of calibration poses compared (subsets of the poses, the
    /// reference always in; default: all poses).
    pub pose_counts: Option<Vec<usize>>,
    /// The true sensors' curves as multiples of the datasheet's (what the
    /// estimators assume): what-if rows beside the datasheet's (default [1]).
    pub truth_amplitude: Option<Vec<f64>>,
    /// A harmonic the datasheets omit, as a fraction of each datasheet
    /// sensor's accuracy: one more what-if whose true curves carry it.
    pub truth_extra_harmonic: Option<f64>,
    /// The true sensors' white terms (interpolation error and jitter) as a
    /// multiple of the datasheet's: one more what-if (e.g. 2).
    pub truth_white: Option<f64>,
    /// One more what-if whose true curves sit whole at the grade's bound
    /// in one harmonic just outside the orders the datasheet model holds.
    pub truth_outside_order: bool,
    /// One more what-if whose encoder rings are mounted with up to this
    /// eccentricity, µm (the mounting tolerance).
    pub truth_eccentricity_um: Option<f64>,
    /// One more what-if whose interpolation errors are coherent over this
    /// fraction of the length the estimator assumes
    /// (`[identification] interpolation_coherence_*`).
    pub truth_coherence_fraction: Option<f64>,
    /// What-if studies whose machines draw each of the four second-class
    /// errors (the UP limb's Hooke axes and guide) uniformly within ± each
    /// tolerance listed, degrees.
    pub second_class_tolerance_deg: Option<Vec<f64>>,
    /// When the study has not decided after `trials` machines (a
    /// combination's interval holds the threshold), add blocks of machines
    /// until it has, or `max_trials`.
    pub until_decided: bool,
    /// The budget of machines `until_decided` may run (default 200,000).
    pub max_trials: Option<u64>,
    /// GLS weights each simulated machine's interpolation error by its
    /// kernel at that machine's readings, as identify weights a real log
    /// (one operator per machine); false: as white noise with one operator
    /// per combination; unset: wherever it applies (one linearisation of
    /// the 15 errors).
    pub gls_per_machine: Option<bool>,
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
            volumetric_grid_step: 100.0,
            volumetric_exact: false,
            catalogue: None,
            encoders: None,
            scales: None,
            pose_counts: None,
            truth_amplitude: None,
            truth_extra_harmonic: None,
            truth_white: None,
            truth_outside_order: false,
            truth_eccentricity_um: None,
            truth_coherence_fraction: None,
            second_class_tolerance_deg: None,
            until_decided: false,
            max_trials: None,
            gls_per_machine: None,
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
    /// "estimate": the metric's estimate must meet the threshold;
    /// "upper95": its upper 95 % confidence limit must; "auto" (the
    /// default): "upper95" where the metric has a limit, else "estimate".
    pub confidence: String,
}

impl Default for DecisionSection {
    fn default() -> Self {
        DecisionSection {
            metric: "ratio_p95".into(),
            threshold: 0.5,
            confidence: "auto".into(),
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

/// Second-class errors of the simulated true machine (docs/method.md §3), degrees.
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
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawConfig {
    /// Which machine: "tricept" (this config) or "hexapod" (its own
    /// config, read by the hexapod's own config module). Left out of
    /// a manifest when it is the Tricept, so a study's identity is as it was.
    #[serde(skip_serializing_if = "MechanismSection::is_tricept")]
    pub mechanism: MechanismSection,
    pub geometry: GeometrySection,
    pub workspace: WorkspaceSection,
    /// The simulated machine's true errors; absent for a real machine.
    pub errors: Option<BTreeMap<String, f64>>,
    pub second_class: SecondClassSection,
    pub sensors: SensorsSection,
    pub poses: PosesSection,
    pub identification: IdentificationSection,
    pub compensation: CompensationSection,
    pub sweep: SweepSection,
    pub decision: DecisionSection,
    pub reproduce: ReproduceSection,
}

/// Parse TOML text into the raw config; errors name the file and line.
pub fn parse_raw(text: &str, source: &str) -> Result<RawConfig> {
    toml::from_str::<RawConfig>(text).map_err(|e| toml_error(text, source, &e))
}

/// A TOML error of `text` as one sentence naming `source` and the line.
pub(crate) fn toml_error(text: &str, source: &str, e: &toml::de::Error) -> Error {
    let line = e
        .span()
        .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
    let mut msg = e.message().trim().replace('\n', " ");
    // A value where the config has a section: say so in its words, not
    // the parser's type names.
    if msg.contains("expected struct") && msg.contains("Section") {
        let key = line
            .and_then(|l| text.lines().nth(l - 1))
            .and_then(|t| t.split_once('='))
            .map(|(k, _)| k.trim().trim_matches('"').to_string())
            .filter(|k| !k.is_empty() && !k.contains(['[', ' ']));
        if let Some(k) = key {
            msg = format!("`{k}` names the [{k}] section, not a value: give its keys under a [{k}] header (docs/config.md)");
            if k == "second_class" {
                msg.push_str("; to identify the Hooke axes, write second_class = true under [identification]");
            }
        }
    }
    match line {
        Some(l) => Error::config(format!("{source} line {l}"), msg),
        None => Error::config(source, msg),
    }
}

/// The largest config or catalogue file read (a pose list of 100,000 poses
/// is about 4 MB).
pub const MAX_CONFIG_BYTES: u64 = 64 << 20;

/// Read a config file's raw values; errors name the file (and line).
pub fn load_raw(path: &Path) -> Result<RawConfig> {
    let (text, source) = load_text(path)?;
    parse_raw(&text, &source)
}

/// A config's text and its name for messages (`-`: stdin).
pub fn load_text(path: &Path) -> Result<(String, String)> {
    if path.as_os_str() == "-" {
        let mut text = String::new();
        std::io::Read::read_to_string(&mut std::io::stdin(), &mut text)
            .map_err(|e| Error::config("<stdin>", format!("the config cannot be read ({e})")))?;
        return Ok((text, "<stdin>".into()));
    }
    let source = path.display().to_string();
    let text = crate::io::read_text(path, MAX_CONFIG_BYTES)
        .map_err(|why| Error::config(&source, format!("the config file {why}")))?;
    Ok((text, source))
}
