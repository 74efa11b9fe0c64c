//! The hexapod's exact kinematics and what its encoders read.
//!
//! Inverse kinematics is the leg formula itself; forward kinematics solves
//! the six leg lengths for the pose by Newton from a nearby pose (twist
//! steps, to 1e-12 mm). The encoders: each base U-joint's first axis e1 is
//! fixed in {O}, its second axis e2 carried by it (e2 at zero), and
//! e3 = e1 × e2 the leg's direction at the home pose; the leg direction
//! n = sin ψ·e1 + cos ψ·(cos φ·e3 − sin φ·e2), so φ = atan2(−n·e2, n·e3)
//! and ψ = asin(n·e1); a reading is the angle plus its encoder's zero error.

use super::N_ERRORS;
use super::{error_index, Errors, Hexapod, Pose, LEGS};
use nalgebra::{DMatrix, Matrix3, Matrix6, Rotation3, Vector3, Vector6};

/// Newton's stop: every leg within this of its length, mm.
const FK_TOLERANCE_MM: f64 = 1e-12;
const FK_ITERATIONS: usize = 50;

/// A machine with errors: its joints, leg offsets and encoder zeros.
#[derive(Debug, Clone, PartialEq)]
pub struct Actual {
    pub base: [Vector3<f64>; LEGS],
    pub platform: [Vector3<f64>; LEGS],
    /// Each leg's length when its actuator reads 0, mm.
    pub offset: [f64; LEGS],
    /// Each joint's encoder zeros (φ, ψ), degrees.
    pub zeros: [[f64; 2]; LEGS],
}

/// One U-joint's encoder axes (e1, e2, e3) in {O}.
pub type Frame = [Vector3<f64>; 3];

impl Hexapod {
    /// Leg i's vector t + R·p_i − b_i at `pose` with joints `base`, `platform`.
    fn leg(pose: &Pose, b: &Vector3<f64>, p: &Vector3<f64>) -> Vector3<f64> {
        pose.t + pose.r * p - b
    }

    /// Each leg's nominal length at the home pose.
    pub fn home_lengths(&self) -> [f64; LEGS] {
        std::array::from_fn(|i| Self::leg(&self.home, &self.base[i], &self.platform[i]).norm())
    }

    /// Each U-joint's encoder axes: e3 the nominal leg direction at home,
    /// e1 = normalise(ẑ × e3), e2 = e3 × e1.
    pub fn frames(&self) -> [Frame; LEGS] {
        std::array::from_fn(|i| {
            let e3 = Self::leg(&self.home, &self.base[i], &self.platform[i]).normalize();
            let e1 = Vector3::z().cross(&e3).normalize();
            let e2 = e3.cross(&e1);
            [e1, e2, e3]
        })
    }

    /// The actuators' commands for `pose` by nominal inverse kinematics.
    pub fn commands(&self, pose: &Pose) -> [f64; LEGS] {
        self.commands_from(pose, &self.home_lengths())
    }

    /// [`Hexapod::commands`] with the legs' home lengths given.
    pub fn commands_from(&self, pose: &Pose, home: &[f64; LEGS]) -> [f64; LEGS] {
        std::array::from_fn(|i| Self::leg(pose, &self.base[i], &self.platform[i]).norm() - home[i])
    }

    /// The commands that put machine `m` (an identified one) at `pose`:
    /// its own inverse kinematics, each leg's length less its offset.
    pub fn commands_of(&self, m: &Actual, pose: &Pose) -> [f64; LEGS] {
        std::array::from_fn(|i| Self::leg(pose, &m.base[i], &m.platform[i]).norm() - m.offset[i])
    }

    /// The machine with `errors` (in [`super::error_names`]' order).
    pub fn actual(&self, errors: &Errors) -> Actual {
        let home = self.home_lengths();
        let e = |i: usize, k: usize| errors[error_index(i, k)];
        Actual {
            base: std::array::from_fn(|i| self.base[i] + Vector3::new(e(i, 0), e(i, 1), e(i, 2))),
            platform: std::array::from_fn(|i| {
                self.platform[i] + Vector3::new(e(i, 3), e(i, 4), e(i, 5))
            }),
            offset: std::array::from_fn(|i| home[i] + e(i, 6)),
            zeros: std::array::from_fn(|i| [e(i, 7), e(i, 8)]),
        }
    }

    /// The pose machine `m` reaches with actuator commands `q`, by Newton
    /// from `start`. Err when it does not converge (a pose outside the
    /// machine's reach, or a singular one).
    ///
    /// The legs' Jacobian is factored at `start` and kept while each step
    /// shrinks the legs' misfit at least fourfold (a chord step: near the
    /// answer, as from a commanded target, it barely changes); otherwise
    /// it is refactored where the pose has got to, a full Newton step.
    pub fn forward(m: &Actual, q: &[f64; LEGS], start: &Pose) -> Result<Pose, String> {
        Self::forward_counted(m, q, start).map(|(pose, _)| pose)
    }

    /// [`Hexapod::forward`], with the steps it took and the factorisations
    /// of the legs' Jacobian among them.
    pub(crate) fn forward_counted(
        m: &Actual,
        q: &[f64; LEGS],
        start: &Pose,
    ) -> Result<(Pose, [usize; 2]), String> {
        let mut pose = *start;
        let mut lu = None;
        let mut last = f64::INFINITY;
        let mut factored = 0;
        for steps in 0..FK_ITERATIONS {
            let mut g = Vector6::zeros();
            let mut n = [Vector3::zeros(); LEGS];
            for i in 0..LEGS {
                let l = Self::leg(&pose, &m.base[i], &m.platform[i]);
                let len = l.norm();
                n[i] = l / len;
                g[i] = len - (m.offset[i] + q[i]);
            }
            let misfit = g.amax();
            if misfit <= FK_TOLERANCE_MM {
                return Ok((pose, [steps, factored]));
            }
            if lu.is_none() || misfit > 0.25 * last {
                let mut j = Matrix6::zeros();
                for (i, n) in n.iter().enumerate() {
                    let c = (pose.r * m.platform[i]).cross(n);
                    for k in 0..3 {
                        j[(i, k)] = n[k];
                        j[(i, 3 + k)] = c[k];
                    }
                }
                lu = Some(j.lu());
                factored += 1;
            }
            last = misfit;
            let step = lu
                .as_ref()
                .and_then(|lu| lu.solve(&(-g)))
                .ok_or_else(|| "the legs' Jacobian is singular at this pose".to_string())?;
            pose.t += step.fixed_rows::<3>(0);
            pose.r = rotation(&step.fixed_rows::<3>(3).into_owned()) * pose.r;
        }
        Err(format!(
            "forward kinematics did not converge in {FK_ITERATIONS} Newton steps"
        ))
    }

    /// What the encoders read with the machine of `errors` commanded to
    /// `target` by nominal inverse kinematics: per leg φ then ψ (degrees),
    /// the axes [`super::Encoders`] reads.
    pub fn readings(&self, errors: &Errors, target: &Pose) -> Result<Vec<f64>, String> {
        let m = self.actual(errors);
        let pose = Self::forward(&m, &self.commands(target), target)?;
        Ok(self.read_at(&m, &pose))
    }

    /// The encoders' readings of machine `m` standing at `pose`.
    pub fn read_at(&self, m: &Actual, pose: &Pose) -> Vec<f64> {
        let mut out = Vec::with_capacity(self.readings_per_pose());
        self.read_into(m, pose, &self.frames(), &mut out);
        out
    }

    /// [`Hexapod::read_at`] with the U-joints' `frames` given, appended
    /// to `out`.
    pub fn read_into(&self, m: &Actual, pose: &Pose, frames: &[Frame; LEGS], out: &mut Vec<f64>) {
        for i in 0..LEGS {
            let n = Self::leg(pose, &m.base[i], &m.platform[i]).normalize();
            let (phi, psi) = angles(&n, &frames[i]);
            for (k, a) in [phi, psi].into_iter().enumerate() {
                if self.encoders.reads(k) {
                    out.push(a + m.zeros[i][k]);
                }
            }
        }
    }
}

/// How far machine `truth`, commanded at `target` by machine `model`'s
/// inverse kinematics, puts the tool point `tool` (in {P}) from where
/// `target` asks, mm, and the platform's orientation from the target's,
/// radians: exact forward kinematics.
pub fn landing_error(
    hex: &Hexapod,
    truth: &Actual,
    model: &Actual,
    target: &Pose,
    tool: &Vector3<f64>,
) -> Result<(f64, f64), String> {
    let reached = Hexapod::forward(truth, &hex.commands_of(model, target), target)?;
    let d = (reached.t + reached.r * tool) - (target.t + target.r * tool);
    Ok((
        d.norm(),
        rotation_angle(&(reached.r * target.r.transpose())),
    ))
}

/// The pose machine `m` stands at whose encoders read `readings`, by
/// Gauss–Newton on the pose from `start` (the readings' derivative in a
/// twist by central differences): the readings' own account of where the
/// platform is, independent of the actuators. Err when it does not
/// converge.
pub fn pose_from_readings(
    hex: &Hexapod,
    m: &Actual,
    readings: &[f64],
    start: &Pose,
) -> Result<Pose, String> {
    let mut pose = *start;
    let mut last = f64::INFINITY;
    let step_of = |p: &Pose, d: &[f64; 6]| Pose {
        t: p.t + Vector3::new(d[0], d[1], d[2]),
        r: rotation(&Vector3::new(d[3], d[4], d[5])) * p.r,
    };
    for _ in 0..50 {
        let r0 = hex.read_at(m, &pose);
        let res = nalgebra::DVector::from_fn(r0.len(), |i, _| readings[i] - r0[i]);
        let mut j = nalgebra::DMatrix::zeros(r0.len(), 6);
        for c in 0..6 {
            let h = if c < 3 { 1e-4 } else { 1e-7 };
            let mut d = [0.0; 6];
            d[c] = h;
            let up = hex.read_at(m, &step_of(&pose, &d));
            d[c] = -h;
            let down = hex.read_at(m, &step_of(&pose, &d));
            for i in 0..r0.len() {
                j[(i, c)] = (up[i] - down[i]) / (2.0 * h);
            }
        }
        let x = j
            .svd(true, true)
            .solve(&res, 1e-12)
            .map_err(|e| format!("the readings do not fix the pose ({e})"))?;
        let d = [x[0], x[1], x[2], x[3], x[4], x[5]];
        pose = step_of(&pose, &d);
        // mm and radians: 1e-9 of either is far below any reading's noise.
        last = x
            .fixed_rows::<3>(0)
            .amax()
            .max(x.fixed_rows::<3>(3).amax() * 1e3);
        if last < 1e-9 {
            return Ok(pose);
        }
    }
    // The differences' rounding keeps the last steps from vanishing: a
    // step under a micrometre is where the readings put the pose.
    if last < 1e-3 {
        return Ok(pose);
    }
    Err(format!(
        "the pose from the readings did not converge (last step {last:.1e} mm)"
    ))
}

/// (φ, ψ) in degrees of leg direction `n` in U-joint frame `f`.
pub fn angles(n: &Vector3<f64>, f: &Frame) -> (f64, f64) {
    let phi = (-n.dot(&f[1])).atan2(n.dot(&f[2]));
    let psi = n.dot(&f[0]).clamp(-1.0, 1.0).asin();
    (phi.to_degrees(), psi.to_degrees())
}

/// How far the machine may travel: each actuator's stroke (its reading q,
/// mm, 0 at home) and each U-joint axis's angle (φ and ψ, degrees, 0 at
/// home). None: not limited.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Limits {
    pub stroke_mm: Option<[f64; 2]>,
    pub joint_angle_deg: Option<f64>,
}

impl Limits {
    /// Whether actuator commands `q` (mm) are within the stroke, or which
    /// one is not (without a stated stroke every command is).
    pub fn check_commands(&self, q: &[f64]) -> Result<(), String> {
        let Some([lo, hi]) = self.stroke_mm else {
            return Ok(());
        };
        match q.iter().enumerate().find(|(_, q)| !(lo..=hi).contains(*q)) {
            Some((i, q)) => Err(format!(
                "actuator {} at {q:.3} mm, outside its stroke [{lo}, {hi}] mm (hexapod.stroke_mm)",
                i + 1
            )),
            None => Ok(()),
        }
    }

    /// What the limits keep every pose within, a sentence for a report's
    /// assumptions (or that none were given).
    pub fn words(&self) -> String {
        match (self.stroke_mm, self.joint_angle_deg) {
            (None, None) => "The machine's strokes and joint limits were not given (hexapod.stroke_mm, hexapod.joint_angle_deg): keep the poses and the workspace inside the machine's.".to_string(),
            (s, a) => format!(
                "Every calibration pose and workspace pose keeps each actuator within {} and each U-joint axis within {} at the nominal machine.",
                s.map_or("any stroke".to_string(), |[lo, hi]| format!("[{lo}, {hi}] mm of its home reading")),
                a.map_or("any angle".to_string(), |x| format!("±{x}° of home")),
            ),
        }
    }

    /// Does the nominal machine stand within the limits at `pose`? Err
    /// says which actuator or joint leaves them, and by how much.
    pub fn check(&self, hex: &Hexapod, pose: &Pose) -> Result<(), String> {
        if let Some([lo, hi]) = self.stroke_mm {
            for (i, q) in hex.commands(pose).iter().enumerate() {
                if !(lo..=hi).contains(q) {
                    return Err(format!(
                        "needs actuator {} at {q:.3} mm, outside its stroke [{lo}, {hi}] mm (hexapod.stroke_mm)",
                        i + 1
                    ));
                }
            }
        }
        if let Some(max) = self.joint_angle_deg {
            for (i, f) in hex.frames().iter().enumerate() {
                let n = Hexapod::leg(pose, &hex.base[i], &hex.platform[i]).normalize();
                let (phi, psi) = angles(&n, f);
                for (name, a) in [("φ", phi), ("ψ", psi)] {
                    if a.abs() > max {
                        return Err(format!(
                            "turns U-joint {}'s {name} axis {a:.3}°, beyond its ±{max}° (hexapod.joint_angle_deg)",
                            i + 1
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

/// The rotation exp([w]×).
pub fn rotation(w: &Vector3<f64>) -> Matrix3<f64> {
    Rotation3::new(*w).into_inner()
}

/// The angle of rotation matrix `r`, radians.
pub fn rotation_angle(r: &Matrix3<f64>) -> f64 {
    // atan2 of the axis-vector norm and the cosine: accurate near 0, where
    // nalgebra's acos-based angle loses half the digits.
    let v = Vector3::new(
        r[(2, 1)] - r[(1, 2)],
        r[(0, 2)] - r[(2, 0)],
        r[(1, 0)] - r[(0, 1)],
    );
    (0.5 * v.norm()).atan2(0.5 * (r.trace() - 1.0))
}

/// How the tool point (position, mm) and the platform (rotation vector,
/// rad) move at `target` per unit of each error, the machine commanded by
/// nominal inverse kinematics: central differences of exact forward
/// kinematics (6 × 54).
pub fn tool_sensitivity(
    hex: &Hexapod,
    target: &Pose,
    tool: &Vector3<f64>,
) -> Result<DMatrix<f64>, String> {
    let q = hex.commands(target);
    let want = target.t + target.r * tool;
    let mut s = DMatrix::zeros(6, N_ERRORS);
    for j in 0..N_ERRORS {
        let h = 1e-4;
        let mut col = [0.0; 6];
        for sign in [1.0, -1.0] {
            let mut e = [0.0; N_ERRORS];
            e[j] = sign * h;
            let m = hex.actual(&e);
            let p = Hexapod::forward(&m, &q, target)?;
            let dt = p.t + p.r * tool - want;
            let dr = p.r * target.r.transpose();
            let angle = rotation_angle(&dr);
            let axis = Vector3::new(
                dr[(2, 1)] - dr[(1, 2)],
                dr[(0, 2)] - dr[(2, 0)],
                dr[(1, 0)] - dr[(0, 1)],
            );
            let w = if axis.norm() > 0.0 {
                axis.normalize() * angle
            } else {
                Vector3::zeros()
            };
            for r in 0..3 {
                col[r] += sign * dt[r] / (2.0 * h);
                col[3 + r] += sign * w[r] / (2.0 * h);
            }
        }
        for (r, x) in col.iter().enumerate() {
            s[(r, j)] = *x;
        }
    }
    Ok(s)
}

/// Compensation and verification: the actuators' strokes by the identified
/// machine's inverse kinematics, the pose its forward kinematics reaches,
/// and the pose its encoders' readings say.
impl crate::mechanism::Commanded for Hexapod {
    fn command_columns(&self) -> Vec<String> {
        (1..=LEGS).map(|i| format!("q{i}_mm")).collect()
    }

    fn commands(&self, errors: &[f64], target: &Pose) -> Result<Vec<f64>, String> {
        let m = self.actual(&super::errors_of(errors)?);
        Ok(self.commands_of(&m, target).to_vec())
    }

    fn reach(&self, errors: &[f64], commands: &[f64], near: &Pose) -> Result<Pose, String> {
        let m = self.actual(&super::errors_of(errors)?);
        let q: [f64; LEGS] = commands
            .try_into()
            .map_err(|_| format!("{} commands given, the hexapod has {LEGS}", commands.len()))?;
        Hexapod::forward(&m, &q, near)
    }

    fn seen(&self, errors: &[f64], readings: &[f64], near: &Pose) -> Result<Pose, String> {
        let m = self.actual(&super::errors_of(errors)?);
        pose_from_readings(self, &m, readings, near)
    }

    /// The platform origin's distance (mm) and the rotation between the
    /// two orientations (arc seconds).
    fn miss(&self, a: &Pose, b: &Pose) -> Vec<f64> {
        vec![
            (a.t - b.t).norm(),
            rotation_angle(&(a.r * b.r.transpose())).to_degrees() * 3600.0,
        ]
    }
}
