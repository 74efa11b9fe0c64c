//! Calibration pose sets (docs/method.md §5), their nominal configurations, and the
//! mid-plane grid (docs/method.md §7).

use super::geometry::Machine;
use super::jacobian::jacobian_at;
use super::kinematics::Joints;
use super::near::Anchor;
use super::params::{ErrorVector, N_PARAMS};
use crate::error::PoseError;
use nalgebra::Vector3;

/// The paper's 51 calibration targets: three layers of Table 1's cylinder,
/// rings at half and full radius, eight points each (the reference first).
pub fn paper_targets() -> Vec<Vector3<f64>> {
    pattern(&paper_workspace(), 3, &[0.5, 1.0], 8)
}

pub use crate::mechanism::workspace::{
    iso9283_positions, midplane_grid, pattern, workspace_grid, Workspace,
};

/// The workspace cylinder of Table 1.
pub fn paper_workspace() -> Workspace {
    Workspace {
        radius_mm: 400.0,
        height_mm: 200.0,
        top_mm: 650.0,
    }
}

/// How a generated layout is spread so that its poses do not read one
/// sensor at nearly the same value (docs/method.md §18).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    /// Largest move of a pose in x and in y, mm (0: none).
    pub spread_mm: f64,
    /// Each sensor's signal period in its internal unit (rad, rad, mm; 0:
    /// no interpolation error, nothing to avoid).
    pub periods: [f64; 3],
    /// Two readings of a sensor closer than this fraction of its signal
    /// period count as the same reading.
    pub fraction: f64,
}

/// Readings of one sensor already taken, bucketed by `width` so that a
/// reading's neighbours within `width` are found in O(1).
struct Taken {
    width: f64,
    cells: std::collections::HashMap<i64, Vec<f64>>,
}

impl Taken {
    fn new(width: f64) -> Self {
        Taken {
            width,
            cells: std::collections::HashMap::new(),
        }
    }

    fn cell(&self, v: f64) -> i64 {
        (v / self.width).floor() as i64
    }

    /// Is some reading taken within `width` of `v`?
    fn near(&self, v: f64) -> bool {
        let c = self.cell(v);
        (c - 1..=c + 1).any(|k| {
            self.cells
                .get(&k)
                .is_some_and(|xs| xs.iter().any(|x| (x - v).abs() < self.width))
        })
    }

    fn insert(&mut self, v: f64) {
        let c = self.cell(v);
        self.cells.entry(c).or_default().push(v);
    }
}

/// Move the poses of a generated layout (all but the reference, the first)
/// by up to ±`spread_mm` in x and y along a low-discrepancy sequence (R2),
/// kept within the workspace radius, so that no two poses read a sensor
/// with a signal period within `fraction` of it: a pose that still would
/// takes the sequence's next point (up to 64; after them the point that
/// cleared the most sensors). Readings are compared by their distance, not
/// their phase: two a whole signal period apart still share the carrier
/// (only a weighting by its kernel accounts for that). Repeated readings share
/// their interpolation error, and the regular pattern repeats by
/// construction (every pose with y = 0 reads
/// ψ4 = 0). O(n) in poses. Off by default: measured, the repeats help GLS
/// (a reading at the reference's value has no homed interpolation error;
/// docs/method.md §18).
pub fn spread(nominal: &Machine, targets: &mut [Vector3<f64>], radius_mm: f64, s: &Spread) {
    if s.spread_mm.is_nan()
        || s.spread_mm <= 0.0
        || s.periods.iter().all(|&p| p.is_nan() || p <= 0.0)
    {
        return;
    }
    let mut taken: Vec<Option<Taken>> = s
        .periods
        .iter()
        .map(|&p| (p > 0.0 && s.fraction > 0.0).then(|| Taken::new(s.fraction * p)))
        .collect();
    let record = |taken: &mut Vec<Option<Taken>>, j: &Joints| {
        for (t, v) in taken.iter_mut().zip(j.as_vector().iter()) {
            if let Some(t) = t {
                t.insert(*v);
            }
        }
    };
    if let Some(first) = targets.first() {
        if let Ok(p) = nominal.inverse(first) {
            record(&mut taken, &p.joints);
        }
    }
    // R2 sequence: the plastic number's inverse powers.
    const A1: f64 = 0.754_877_666_246_692_8;
    const A2: f64 = 0.569_840_290_998_053_2;
    let mut step = 0u64;
    for r in targets.iter_mut().skip(1) {
        let base = *r;
        let (mut best, mut best_clear) = (base, 0);
        for _ in 0..64 {
            step += 1;
            let u = (0.5 + A1 * step as f64).fract() * 2.0 - 1.0;
            let w = (0.5 + A2 * step as f64).fract() * 2.0 - 1.0;
            let mut c = Vector3::new(base.x + s.spread_mm * u, base.y + s.spread_mm * w, base.z);
            let rho = c.x.hypot(c.y);
            if rho > radius_mm {
                c.x *= radius_mm / rho;
                c.y *= radius_mm / rho;
            }
            let Ok(p) = nominal.inverse(&c) else {
                continue;
            };
            let v = p.joints.as_vector();
            let clear = taken
                .iter()
                .zip(v.iter())
                .filter(|(t, x)| t.as_ref().is_none_or(|t| !t.near(**x)))
                .count();
            // The candidate that clears the most sensors (the first of
            // them), every one ends the search.
            if clear > best_clear {
                (best, best_clear) = (c, clear);
            }
            if clear == taken.len() {
                break;
            }
        }
        *r = best;
        if let Ok(p) = nominal.inverse(r) {
            record(&mut taken, &p.joints);
        }
    }
}

/// Nominal configuration and nominal-IK commands at each pose.
#[derive(Debug, Clone)]
pub struct NominalPoses {
    pub targets: Vec<Vector3<f64>>,
    pub joints: Vec<Joints>,
    pub commands: Vec<[f64; 3]>,
    /// Each nominal configuration prepared for [`Machine::forward_near`].
    pub anchors: Vec<Anchor>,
}

impl NominalPoses {
    /// Nominal IK at every target; the error names the pose index.
    pub fn new(nominal: &Machine, targets: &[Vector3<f64>]) -> Result<Self, PoseError> {
        let mut joints = Vec::with_capacity(targets.len());
        let mut commands = Vec::with_capacity(targets.len());
        for (k, r) in targets.iter().enumerate() {
            let pose = nominal.inverse(r).map_err(|e| PoseError::new(k, e))?;
            joints.push(pose.joints);
            commands.push([
                pose.legs_mm[0] - nominal.dq[0],
                pose.legs_mm[1] - nominal.dq[1],
                pose.legs_mm[2] - nominal.dq[2],
            ]);
        }
        Ok(NominalPoses {
            anchors: joints.iter().map(Anchor::new).collect(),
            targets: targets.to_vec(),
            joints,
            commands,
        })
    }

    /// The poses at indices `at` (the reference first), e.g. a pose
    /// count's subset for Gauss–Newton.
    pub fn pick(&self, at: &[usize]) -> NominalPoses {
        fn pick<T: Copy>(at: &[usize], v: &[T]) -> Vec<T> {
            at.iter().map(|&p| v[p]).collect()
        }
        NominalPoses {
            targets: pick(at, &self.targets),
            joints: pick(at, &self.joints),
            commands: pick(at, &self.commands),
            anchors: pick(at, &self.anchors),
        }
    }

    pub fn len(&self) -> usize {
        self.targets.len()
    }

    pub fn is_empty(&self) -> bool {
        self.targets.is_empty()
    }

    /// Actual passive joints of `truth` at every pose (exact FK from the
    /// nominal solution), written into `out`.
    pub fn actual_joints_into(
        &self,
        truth: &Machine,
        out: &mut [Vector3<f64>],
    ) -> Result<(), PoseError> {
        for (k, (q, guess)) in self.commands.iter().zip(&self.joints).enumerate() {
            out[k] = truth
                .forward(q, guess)
                .map_err(|e| PoseError::new(k, e))?
                .as_vector();
        }
        Ok(())
    }
}

/// The first-order prediction of a machine's passive joints at every pose,
/// nominal_k + J_k·ε, stored by error (15 columns of 3n values) so that one
/// prediction is 15 vectorised multiply-adds over all poses.
#[derive(Debug, Clone)]
pub struct FirstOrder {
    nominal: Vec<f64>,
    columns: Vec<f64>,
}

impl FirstOrder {
    /// J_k at the nominal configuration of every pose of `poses`.
    pub fn new(nominal: &Machine, poses: &NominalPoses) -> Result<Self, PoseError> {
        let n = 3 * poses.len();
        let mut columns = vec![0.0; N_PARAMS * n];
        for (k, j) in poses.joints.iter().enumerate() {
            let jac = jacobian_at(&nominal.pose(j)).map_err(|e| PoseError::new(k, e))?;
            for p in 0..N_PARAMS {
                for c in 0..3 {
                    columns[p * n + 3 * k + c] = jac[(c, p)];
                }
            }
        }
        let nominal = poses
            .joints
            .iter()
            .flat_map(|j| [j.psi_rad, j.theta_rad, j.q4_mm])
            .collect();
        Ok(FirstOrder { nominal, columns })
    }

    /// nominal_k + J_k·ε for every pose k, into `out` (3 values per pose).
    #[inline]
    pub fn predict(&self, errors: &ErrorVector, out: &mut [f64]) {
        let n = self.nominal.len();
        out.copy_from_slice(&self.nominal);
        for (p, col) in self.columns.chunks_exact(n).enumerate() {
            let e = errors[p];
            for (o, c) in out.iter_mut().zip(col) {
                *o += c * e;
            }
        }
    }
}

impl NominalPoses {
    /// [`NominalPoses::actual_joints_into`] with Newton started from
    /// `guesses` (3 values per pose, e.g. a [`FirstOrder`] prediction) and
    /// four poses iterated in lock-step ([`Machine::forward_near_group`]):
    /// the same solutions to within forward kinematics' tolerance, in fewer
    /// iterations. A pose where that start fails is retried from the
    /// nominal joints.
    pub fn actual_joints_near(
        &self,
        truth: &Machine,
        guesses: &[f64],
        out: &mut [Vector3<f64>],
    ) -> Result<(), PoseError> {
        const GROUP: usize = 4;
        let n = self.len();
        let mut k = 0;
        while k < n {
            let g = GROUP.min(n - k);
            // A short last group repeats its poses to fill the lanes.
            let idx: [usize; GROUP] = std::array::from_fn(|i| k + (i % g));
            let guess = idx.map(|i| Joints {
                psi_rad: guesses[3 * i],
                theta_rad: guesses[3 * i + 1],
                q4_mm: guesses[3 * i + 2],
            });
            let solved = truth.forward_near_group(
                idx.map(|i| &self.commands[i]),
                idx.map(|i| &self.anchors[i]),
                std::array::from_fn(|i| &guess[i]),
            );
            for (i, r) in solved.into_iter().enumerate().take(g) {
                let p = k + i;
                out[p] = match r {
                    Ok(j) => j,
                    Err(_) => truth
                        .forward(&self.commands[p], &self.joints[p])
                        .map_err(|e| PoseError::new(p, e))?,
                }
                .as_vector();
            }
            k += g;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first-order prediction, column-stored, equals nominal + J_k·ε
    /// computed pose by pose, and is within second order of the exact joints.
    #[test]
    fn first_order_prediction_is_nominal_plus_j_times_errors() {
        use crate::mechanism::tricept::{ErrorVector, Geometry};
        let g = Geometry::paper();
        let nominal = Machine::nominal(&g);
        let ws = paper_workspace();
        let targets = pattern(&ws, 3, &[0.5, 1.0], 8);
        let poses = NominalPoses::new(&nominal, &targets).unwrap();
        let fo = FirstOrder::new(&nominal, &poses).unwrap();
        let e = ErrorVector::from_fn(|i, _| 0.02 * (i as f64 - 7.0));
        let mut out = vec![0.0; 3 * poses.len()];
        fo.predict(&e, &mut out);
        let truth = Machine::with_errors(&g, &e);
        for (k, j) in poses.joints.iter().enumerate() {
            let by_pose = j.as_vector() + jacobian_at(&nominal.pose(j)).unwrap() * e;
            for c in 0..3 {
                assert!((out[3 * k + c] - by_pose[c]).abs() < 1e-12, "pose {k}");
            }
            let exact = truth.forward(&poses.commands[k], j).unwrap().as_vector();
            let first = Vector3::new(out[3 * k], out[3 * k + 1], out[3 * k + 2]);
            // Second order in errors of ~0.1 mm over ~300 mm.
            assert!(
                (exact - first).amax() < 1e-3 * (exact - j.as_vector()).amax(),
                "pose {k}"
            );
        }
    }
}

#[cfg(test)]
mod spread_tests {
    use super::*;
    use crate::mechanism::tricept::Geometry;

    /// A spread layout reads no sensor within the fraction of its period of
    /// an earlier pose (checked pair by pair), keeps the reference, z and
    /// the radius, and moves no pose more than the spread; spread 0 leaves
    /// it as generated.
    #[test]
    fn a_spread_layout_repeats_no_reading() {
        let ws = paper_workspace();
        let nominal = Machine::nominal(&Geometry::paper());
        let base = pattern(&ws, 4, &[0.33, 0.67, 1.0], 6);
        let periods = [144.0 / 206_264.8, 144.0 / 206_264.8, 0.02];
        let s = Spread {
            spread_mm: 3.0,
            periods,
            fraction: 0.25,
        };
        let mut spread_targets = base.clone();
        spread(&nominal, &mut spread_targets, ws.radius_mm, &s);
        assert_eq!(spread_targets[0], base[0]);
        let joints: Vec<Joints> = spread_targets
            .iter()
            .map(|r| nominal.inverse(r).unwrap().joints)
            .collect();
        for (i, (a, b)) in spread_targets.iter().zip(&base).enumerate() {
            assert_eq!(a.z, b.z);
            assert!(
                (a.x - b.x).abs() <= 3.0 + 1e-12 && (a.y - b.y).abs() <= 3.0 + 1e-12,
                "{i}"
            );
            assert!(a.x.hypot(a.y) <= ws.radius_mm + 1e-9, "{i}");
        }
        let mut before = 0;
        for k in 0..3 {
            for i in 0..joints.len() {
                for j in 0..i {
                    let d = (joints[i].as_vector()[k] - joints[j].as_vector()[k]).abs();
                    assert!(d >= 0.25 * periods[k], "sensor {k}: poses {j} and {i} {d}");
                }
            }
        }
        // The pattern as generated repeats ψ4 = 0 at every pose with y = 0.
        let plain: Vec<Joints> = base
            .iter()
            .map(|r| nominal.inverse(r).unwrap().joints)
            .collect();
        for i in 1..plain.len() {
            if (0..i).any(|j| (plain[i].psi_rad - plain[j].psi_rad).abs() < 0.25 * periods[0]) {
                before += 1;
            }
        }
        assert!(before >= 20, "{before}");
        let mut same = base.clone();
        spread(
            &nominal,
            &mut same,
            ws.radius_mm,
            &Spread {
                spread_mm: 0.0,
                ..s
            },
        );
        assert_eq!(same, base);
    }
}
