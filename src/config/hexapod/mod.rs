//! A hexapod's config: `[mechanism] kind = "hexapod"`, its `[hexapod]`
//! geometry, the simulated machine's `[errors]`, the `[poses]` it is
//! driven through, and how it is identified. Every value is checked here;
//! an error names the file and the key.

use crate::error::{Error, Result};
use crate::identify::general::Holds;
use crate::mechanism::hexapod::kinematics::Limits;
use crate::mechanism::hexapod::{error_names, Encoders, Errors, Hexapod, Pose, LEGS, N_ERRORS};
use crate::mechanism::Mechanism;
use nalgebra::Vector3;

mod raw;
mod study;
pub use crate::config::general::{Estimator, Sensor, WhatIf};
use raw::*;
use study::{study, workspace};

/// The hexapod's study: poses, instrumented with one or two encoders a
/// joint.
pub type Spec = crate::config::general::Spec<Pose, crate::mechanism::hexapod::Encoders>;

pub use crate::config::general::MAX_POSES;
/// Largest |error| accepted: mm for lengths, degrees for the encoders' zeros.
const MAX_ERROR_MM: f64 = 10.0;
const MAX_ERROR_DEG: f64 = 5.0;

/// A validated hexapod config.
#[derive(Debug, Clone)]
pub struct HexapodConfig {
    pub source: String,
    pub hexapod: Hexapod,
    /// The simulated machine's errors (zero where unlisted); None without
    /// an `[errors]` table (a real machine).
    pub errors: Option<Errors>,
    /// The target poses, as written and as poses.
    pub pose_list: Vec<[f64; 6]>,
    pub poses: Vec<Pose>,
    pub iterations: usize,
    pub rank_tolerance: f64,
    pub encoder_noise_arcsec: f64,
    /// The `[sweep]` study; None without that section.
    pub study: Option<StudyConfig>,
    /// `[workspace]`'s poses (the study judges there, and compensate maps
    /// a simulated machine there) and the tool point in {P}, mm.
    pub workspace: Vec<Pose>,
    pub tool_mm: Vector3<f64>,
    /// `[workspace] half_extent_mm`: the box about home the grid spans.
    pub half_extent_mm: [f64; 3],
    /// `hexapod.stroke_mm` and `hexapod.joint_angle_deg`: every pose the
    /// config or a targets file names stays within them.
    pub limits: Limits,
    /// `[identification] fix`, `prior_std_mm` and `prior_std_deg`: what
    /// identify holds besides the readings.
    pub holds: Holds,
}

impl crate::config::general::MechanismConfig for HexapodConfig {
    type M = Hexapod;

    fn source(&self) -> &str {
        &self.source
    }

    fn machine(&self) -> &Hexapod {
        &self.hexapod
    }

    fn simulated(&self) -> Option<Vec<f64>> {
        self.errors.map(|e| e.to_vec())
    }

    fn pose_rows(&self) -> Vec<Vec<f64>> {
        self.pose_list.iter().map(|p| p.to_vec()).collect()
    }

    fn poses(&self) -> &[Pose] {
        &self.poses
    }

    fn iterations(&self) -> usize {
        self.iterations
    }

    fn rank_tolerance(&self) -> f64 {
        self.rank_tolerance
    }

    /// `sensors.encoder_noise_arcsec`, in degrees, for every encoder.
    fn reading_sigma(&self) -> (Vec<f64>, &'static str) {
        (
            (self.encoder_noise_arcsec > 0.0)
                .then(|| self.encoder_noise_arcsec / 3600.0)
                .into_iter()
                .collect(),
            "sensors.encoder_noise_arcsec",
        )
    }

    fn holds(&self) -> &Holds {
        &self.holds
    }

    fn workspace(&self) -> &[Pose] {
        &self.workspace
    }

    fn tool_mm(&self) -> Vector3<f64> {
        self.tool_mm
    }

    fn study(&self) -> Option<&StudyConfig> {
        self.study.as_ref()
    }

    fn study_keys(&self) -> &'static str {
        "sweep.catalogue or sweep.encoder_arcsec; docs/config.md, \"The hexapod\""
    }

    fn limits_words(&self) -> String {
        self.limits.words()
    }
    fn check_commands(&self, q: &[f64]) -> Result<(), String> {
        self.limits.check_commands(q)
    }

    /// Within `hexapod.stroke_mm` and `hexapod.joint_angle_deg`.
    fn target(&self, cells: &[f64]) -> std::result::Result<Pose, String> {
        let p = self.hexapod.target_of(cells)?;
        self.limits.check(&self.hexapod, &p)?;
        Ok(p)
    }
}

/// The mechanism a config's text names (`[mechanism] kind`; "tricept"
/// when absent). None when the text is not TOML (the caller's own parser
/// then says where).
pub fn kind_of(text: &str) -> Option<String> {
    let Ok(table) = toml::from_str::<toml::Table>(text) else {
        // A file TOML cannot read (a number it cannot hold, a syntax
        // error) still says which machine it describes, so that its error
        // is reported by that machine's parser, naming its line.
        return kind_in_lines(text);
    };
    Some(match table.get("mechanism").and_then(|m| m.get("kind")) {
        Some(toml::Value::String(k)) => k.clone(),
        _ => "tricept".into(),
    })
}

/// `[mechanism] kind = "…"` (or `mechanism.kind = "…"` before any table)
/// read line by line, for a file TOML cannot parse whole. None where no
/// such line is found.
fn kind_in_lines(text: &str) -> Option<String> {
    // A quoted string, "…" or '…'.
    let quoted = |v: &str| {
        let v = v.trim();
        ['"', '\'']
            .iter()
            .find_map(|&q| v.strip_prefix(q).and_then(|v| v.strip_suffix(q)))
            .map(str::to_string)
    };
    let mut section = String::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        // A table header names a table: bare keys and dots, no commas (a
        // line of an array, "[1, 2, 3]", is not one).
        if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            let name = name.trim();
            let bare = |c: char| c.is_ascii_alphanumeric() || "_-. ".contains(c);
            if name.starts_with(|c: char| c.is_ascii_alphabetic()) && name.chars().all(bare) {
                section = name.replace(' ', "");
            }
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            continue;
        };
        let key = key.trim().replace(' ', "");
        let full = match section.as_str() {
            "" => key,
            s => format!("{s}.{key}"),
        };
        if full == "mechanism.kind" {
            return quoted(value);
        }
        // An inline table: mechanism = { kind = "hexapod" }.
        if full == "mechanism" {
            let inner = value
                .trim()
                .strip_prefix('{')?
                .trim_end()
                .strip_suffix('}')?;
            return inner.split(',').find_map(|pair| {
                let (k, v) = pair.split_once('=')?;
                (k.trim() == "kind").then(|| quoted(v)).flatten()
            });
        }
    }
    None
}

impl HexapodConfig {
    /// Parse and check the config `text` read from `source`.
    pub fn parse(text: &str, source: &str) -> Result<Self> {
        let fail = |key: &str, why: String| Error::config(source, format!("{key} {why}"));
        // TOML errors in the words the Tricept's config uses, line included.
        let raw: Raw =
            toml::from_str(text).map_err(|e| crate::config::raw::toml_error(text, source, &e))?;
        if raw.mechanism.kind != "hexapod" {
            return Err(fail(
                "mechanism.kind",
                format!("must be \"hexapod\" here (got \"{}\")", raw.mechanism.kind),
            ));
        }
        let h = &raw.hexapod;
        let joints = |key: &str, v: &[[f64; 3]]| -> Result<[Vector3<f64>; LEGS]> {
            if v.len() != LEGS {
                return Err(fail(
                    key,
                    format!("must list 6 joint centres (got {})", v.len()),
                ));
            }
            if let Some(i) = v
                .iter()
                .position(|p| p.iter().any(|x| !x.is_finite() || x.abs() > 1e6))
            {
                return Err(fail(
                    key,
                    format!("joint {} is not a finite point within 1e6 mm", i + 1),
                ));
            }
            Ok(std::array::from_fn(|i| Vector3::from(v[i])))
        };
        let base = joints("hexapod.base_joints_mm", &h.base_joints_mm)?;
        let platform = joints("hexapod.platform_joints_mm", &h.platform_joints_mm)?;
        // The convention fixes the platform frame by joints 1, 2 and 3:
        // they must span a plane.
        let (d2, d3) = (platform[1] - platform[0], platform[2] - platform[0]);
        if d2.norm() < 1.0 || d2.cross(&d3).norm() < 1.0 * d2.norm() {
            return Err(fail(
                "hexapod.platform_joints_mm",
                "joints 1, 2 and 3 must be distinct and not in a line (at least 1 mm apart and off the line through 1 and 2): the convention that fixes the platform frame needs them to span a plane".into(),
            ));
        }
        for (key, set) in [
            ("hexapod.base_joints_mm", &base),
            ("hexapod.platform_joints_mm", &platform),
        ] {
            for a in 0..LEGS {
                for b in 0..a {
                    if (set[a] - set[b]).norm() < 1.0 {
                        return Err(fail(
                            key,
                            format!("joints {} and {} are under 1 mm apart", b + 1, a + 1),
                        ));
                    }
                }
            }
        }
        let encoders = Encoders::parse(&h.encoders).ok_or_else(|| {
            fail(
                "hexapod.encoders",
                format!(
                    "must be \"both\", \"first\" or \"second\" (got \"{}\")",
                    h.encoders
                ),
            )
        })?;
        let pose = |key: &str, x: &[f64; 6]| -> Result<Pose> {
            if x.iter().any(|v| !v.is_finite()) || x[3..].iter().any(|a| a.abs() > 90.0) {
                return Err(fail(
                    key,
                    "must be [x, y, z, a, b, c]: finite mm and angles within ±90°".into(),
                ));
            }
            Ok(Pose::from_xyzabc(x))
        };
        let home = pose("hexapod.home_pose", &h.home_pose)?;
        let hexapod = Hexapod {
            base,
            platform,
            home,
            encoders,
        };
        for (i, l) in hexapod.home_lengths().iter().enumerate() {
            if *l < 1.0 {
                return Err(fail(
                    "hexapod.home_pose",
                    format!(
                        "puts leg {}'s joints {l:.3} mm apart: a leg must be at least 1 mm long",
                        i + 1
                    ),
                ));
            }
        }
        // Every U-joint's encoder frame needs its leg off the vertical.
        let frames_ok = hexapod
            .frames()
            .iter()
            .all(|f| f.iter().all(|v| v.iter().all(|x| x.is_finite())));
        if !frames_ok {
            return Err(fail("hexapod.home_pose", "puts a leg along the base's z axis: its U-joint's first axis (ẑ × leg) is undefined".into()));
        }
        if let Some([lo, hi]) = h.stroke_mm {
            if !(lo.is_finite() && hi.is_finite() && lo <= 0.0 && 0.0 <= hi && lo < hi) {
                return Err(fail(
                    "hexapod.stroke_mm",
                    format!("must be [least, most] of each actuator's reading, mm, with the home pose's 0 inside (got [{lo}, {hi}])"),
                ));
            }
        }
        if let Some(a) = h.joint_angle_deg {
            if !(a.is_finite() && a > 0.0 && a <= 90.0) {
                return Err(fail(
                    "hexapod.joint_angle_deg",
                    format!("must be in (0, 90] degrees (got {a})"),
                ));
            }
        }
        let limits = Limits {
            stroke_mm: h.stroke_mm,
            joint_angle_deg: h.joint_angle_deg,
        };
        let errors = match &raw.errors {
            None => None,
            Some(table) => {
                let mut e = [0.0; N_ERRORS];
                for (k, v) in table {
                    let j = error_value(&fail, &hexapod, &format!("errors.{k}"), k, *v)?;
                    e[j] = *v;
                }
                Some(e)
            }
        };
        let list = &raw.poses.list;
        if list.is_empty() || list.len() > MAX_POSES {
            return Err(fail(
                "poses.list",
                format!("must list 1 to {MAX_POSES} poses (got {})", list.len()),
            ));
        }
        let mut poses = Vec::with_capacity(list.len());
        for (i, x) in list.iter().enumerate() {
            let p = pose(&format!("poses.list[{}]", i + 1), x)?;
            // Reachable by the nominal machine: forward kinematics of its
            // own commands comes back.
            let m = hexapod.actual(&[0.0; N_ERRORS]);
            Hexapod::forward(&m, &hexapod.commands(&p), &p).map_err(|why| {
                fail(
                    &format!("poses.list[{}]", i + 1),
                    format!("cannot be reached: {why}"),
                )
            })?;
            limits
                .check(&hexapod, &p)
                .map_err(|why| fail(&format!("poses.list[{}]", i + 1), why))?;
            poses.push(p);
        }
        let id = &raw.identification;
        if !(1..=100).contains(&id.iterations) {
            return Err(fail(
                "identification.iterations",
                format!("must be 1 to 100 (got {})", id.iterations),
            ));
        }
        if !(id.rank_tolerance > 0.0 && id.rank_tolerance < 1e-2) {
            return Err(fail(
                "identification.rank_tolerance",
                format!("must be in (0, 0.01) (got {})", id.rank_tolerance),
            ));
        }
        let noise = raw.sensors.encoder_noise_arcsec;
        if !(noise.is_finite() && (0.0..=3600.0).contains(&noise)) {
            return Err(fail(
                "sensors.encoder_noise_arcsec",
                format!("must be in [0, 3600] (got {noise})"),
            ));
        }
        let holds = holds(&fail, id, &hexapod, noise)?;
        let workspace_poses = workspace(&fail, &raw.workspace, &hexapod, &limits)?;
        let tool_mm = Vector3::from(raw.workspace.tool_point_mm);
        let study = match &raw.sweep {
            None => None,
            Some(sw) => {
                let mut s = study(
                    &fail,
                    source,
                    sw,
                    (workspace_poses.clone(), tool_mm),
                    &raw.decision,
                    list.len(),
                    noise,
                    id.iterations,
                )?;
                s.spec.fixed = holds.fixed.clone();
                s.spec.prior_std_mm = holds.prior_std_mm;
                s.spec.prior_std_deg = holds.prior_std_deg;
                Some(s)
            }
        };
        Ok(HexapodConfig {
            study,
            workspace: workspace_poses,
            tool_mm,
            half_extent_mm: raw.workspace.half_extent_mm,
            source: source.to_string(),
            hexapod,
            errors,
            pose_list: list.clone(),
            poses,
            iterations: id.iterations,
            rank_tolerance: id.rank_tolerance,
            encoder_noise_arcsec: noise,
            limits,
            holds,
        })
    }
}

/// `[identification] fix`, `prior_std_mm` and `prior_std_deg` checked.
fn holds(
    fail: &dyn Fn(&str, String) -> Error,
    id: &IdentificationSection,
    hexapod: &Hexapod,
    noise_arcsec: f64,
) -> Result<Holds> {
    let mut fixed = Vec::new();
    for (k, v) in id.fix.iter().flatten() {
        let key = format!("identification.fix.{k}");
        let j = error_value(fail, hexapod, &key, k, *v)?;
        if !hexapod.fixable(j) {
            return Err(fail(
                &key,
                "is a joint centre's error, which is in the frames the convention picks (b1 and p1 nominal), not those of a measurement elsewhere: fix leg offsets (dl) and encoder zeros (dphi, dpsi) only".into(),
            ));
        }
        fixed.push((j, *v));
    }
    for (key, v, cap) in [
        ("identification.prior_std_mm", id.prior_std_mm, MAX_ERROR_MM),
        (
            "identification.prior_std_deg",
            id.prior_std_deg,
            MAX_ERROR_DEG,
        ),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && (1e-6..=cap).contains(&v)) {
                return Err(fail(key, format!("must be in [1e-6, {cap}] (got {v})")));
            }
            if noise_arcsec <= 0.0 {
                return Err(fail(
                    key,
                    "needs sensors.encoder_noise_arcsec, the readings' σ (readings and prior on one scale)".into(),
                ));
            }
        }
    }
    Ok(Holds {
        fixed,
        prior_std_mm: id.prior_std_mm,
        prior_std_deg: id.prior_std_deg,
    })
}

/// The index of error `name` given at `key` with value `v`: one of this
/// machine's errors, finite and within ±10 mm or ±5°.
fn error_value(
    fail: &dyn Fn(&str, String) -> Error,
    hexapod: &Hexapod,
    key: &str,
    name: &str,
    v: f64,
) -> Result<usize> {
    let Some(j) = error_names().iter().position(|n| n == name) else {
        return Err(fail(key, "is not a hexapod error (dbx1 … dpsi6: dbx, dby, dbz, dpx, dpy, dpz, dl, dphi, dpsi of legs 1–6)".into()));
    };
    if !hexapod.error_indices().contains(&j) {
        return Err(fail(
            key,
            "is the zero of an encoder this machine does not have (hexapod.encoders)".into(),
        ));
    }
    let cap = if crate::mechanism::hexapod::is_angle(j) {
        MAX_ERROR_DEG
    } else {
        MAX_ERROR_MM
    };
    if !v.is_finite() || v.abs() > cap {
        return Err(fail(
            key,
            format!("must be finite and within ±{cap} (got {v})"),
        ));
    }
    Ok(j)
}

#[cfg(test)]
mod tests {
    use super::{kind_in_lines, kind_of};

    /// A file TOML cannot read whole still names its machine: the kind in
    /// either quote, in a spaced header with a comment, as a dotted key or
    /// an inline table, and not from a line of an array that looks like a
    /// header; none where it is not said.
    #[test]
    fn the_kind_is_read_from_lines_toml_cannot_parse() {
        let broken = "trials = 99999999999999999999\n";
        for (text, kind) in [
            ("[mechanism]\nkind = \"hexapod\"\n", Some("hexapod")),
            ("[mechanism]\nkind = 'hexapod'\n", Some("hexapod")),
            (
                "[ mechanism ]  # which machine\n kind='hexapod' # it is\n",
                Some("hexapod"),
            ),
            ("mechanism.kind = \"hexapod\"\n[sweep]\n", Some("hexapod")),
            ("mechanism = { kind = \"hexapod\" }\n", Some("hexapod")),
            (
                "mechanism = { other = 1, kind = 'tricept' }\n",
                Some("tricept"),
            ),
            (
                "[mechanism]\nlist = [\n[1, 2, 3]\n]\nkind = \"hexapod\"\n",
                Some("hexapod"),
            ),
            ("[sweep]\nkind = \"hexapod\"\n", None),
            ("[poses]\nlist = [\n[mechanism]\n]\n", None),
            ("", None),
        ] {
            let text = format!("{text}{broken}");
            assert_eq!(kind_in_lines(&text).as_deref(), kind, "{text}");
            assert_eq!(kind_of(&text).as_deref(), kind, "{text}");
        }
        // A file TOML reads is read by TOML: no kind is the Tricept.
        assert_eq!(kind_of("[sweep]\ntrials = 5\n").as_deref(), Some("tricept"));
    }
}
