use super::design::pose_design;
use super::kinematics::angles;
use super::*;
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};

/// 30 random poses within ±80 mm, ±60 mm in z and ±8° of home.
pub(crate) fn targets(seed: u64, n: usize) -> Vec<Pose> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let mut u = |s: f64| rng.random_range(-s..=s);
            Pose::from_xyzabc(&[u(80.0), u(80.0), 500.0 + u(60.0), u(8.0), u(8.0), u(8.0)])
        })
        .collect()
}

pub(crate) fn random_errors(seed: u64, mm: f64, deg: f64) -> Errors {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    std::array::from_fn(|j| {
        let s = if is_angle(j) { deg } else { mm };
        rng.random_range(-s..=s)
    })
}

/// Forward kinematics reaches the commanded lengths; the readings invert
/// the direction formula n = sin ψ·e1 + cos ψ·(cos φ·e3 − sin φ·e2) (an
/// independent route: the direction rebuilt from the angles), and a
/// nominal machine at home reads 0.
#[test]
fn the_readings_are_the_leg_directions_angles() {
    let hex = Hexapod::example();
    let frames = hex.frames();
    let zero = [0.0; N_ERRORS];
    for r in hex.readings(&zero, &hex.home).unwrap() {
        assert!(r.abs() < 1e-12, "{r}");
    }
    let errors = random_errors(3, 0.5, 0.05);
    let m = hex.actual(&errors);
    for target in targets(1, 10) {
        let q = hex.commands(&target);
        let pose = Hexapod::forward(&m, &q, &target).unwrap();
        for i in 0..LEGS {
            let l = pose.t + pose.r * m.platform[i] - m.base[i];
            assert!((l.norm() - (m.offset[i] + q[i])).abs() < 1e-9);
            let n = l.normalize();
            let (phi, psi) = angles(&n, &frames[i]);
            let (p, s) = (phi.to_radians(), psi.to_radians());
            let [e1, e2, e3] = frames[i];
            let back = e1 * s.sin() + (e3 * p.cos() - e2 * p.sin()) * s.cos();
            assert!((back - n).amax() < 1e-12);
        }
        let read = hex.readings(&errors, &target).unwrap();
        assert_eq!(read.len(), 12);
        for i in 0..LEGS {
            let n = (pose.t + pose.r * m.platform[i] - m.base[i]).normalize();
            let (phi, psi) = angles(&n, &frames[i]);
            assert!((read[2 * i] - phi - errors[error_index(i, 7)]).abs() < 1e-9);
            assert!((read[2 * i + 1] - psi - errors[error_index(i, 8)]).abs() < 1e-9);
        }
    }
}

/// The analytic design equals central differences of the exact readings,
/// at the nominal machine and at one with errors.
#[test]
fn the_design_is_the_readings_derivative() {
    let hex = Hexapod::example();
    for errors in [[0.0; N_ERRORS], random_errors(5, 0.3, 0.02)] {
        for target in targets(2, 3) {
            let h = pose_design(&hex, &errors, &target).unwrap();
            for j in 0..N_ERRORS {
                let step = 1e-5;
                let (mut up, mut down) = (errors, errors);
                up[j] += step;
                down[j] -= step;
                let a = hex.readings(&up, &target).unwrap();
                let b = hex.readings(&down, &target).unwrap();
                for r in 0..a.len() {
                    let fd = (a[r] - b[r]) / (2.0 * step);
                    assert!(
                        (fd - h[(r, j)]).abs() < 1e-6 * (1.0 + fd.abs()),
                        "row {r} error {j}: {fd} vs {}",
                        h[(r, j)]
                    );
                }
            }
        }
    }
}

/// Forward kinematics from a start far from the answer (40 mm and 10°
/// away, where a Jacobian kept from the start would crawl) reaches the
/// commanded lengths to its tolerance and the pose the commands were
/// computed for; from the target it reaches the same pose as from the far
/// start, and a readings log of several targets (`readings_into`, frames
/// and home lengths built once) equals each target's readings alone.
#[test]
fn forward_kinematics_converges_from_afar_and_readings_into_matches() {
    let hex = Hexapod::example();
    let errors = random_errors(7, 0.2, 0.02);
    let m = hex.actual(&errors);
    let goals = targets(4, 6);
    for goal in &goals {
        let q = hex.commands_of(&m, goal);
        let far = Pose::from_xyzabc(&{
            let mut x = goal.to_xyzabc();
            x[0] += 40.0;
            x[2] -= 30.0;
            x[3] += 10.0;
            x[5] -= 10.0;
            x
        });
        let from_far = Hexapod::forward(&m, &q, &far).unwrap();
        for i in 0..LEGS {
            let l = from_far.t + from_far.r * m.platform[i] - m.base[i];
            assert!((l.norm() - (m.offset[i] + q[i])).abs() <= 1e-12);
        }
        assert!(
            (from_far.t - goal.t).amax() < 1e-9,
            "{:?}",
            from_far.t - goal.t
        );
        assert!((from_far.r - goal.r).amax() < 1e-12);
        let near = Hexapod::forward(&m, &q, goal).unwrap();
        assert!((near.t - from_far.t).amax() < 1e-9);
        // The chord rule: from afar the Jacobian is refactored while steps
        // shrink the misfit less than fourfold; from a start as near as a
        // machine's errors put the commanded target, it is factored once
        // and kept for every step.
        let (_, [_, far_factored]) = Hexapod::forward_counted(&m, &q, &far).unwrap();
        assert!(far_factored >= 2, "{far_factored}");
        let mut x = goal.to_xyzabc();
        x[0] += 0.2;
        x[4] -= 0.02;
        let nearby = Pose::from_xyzabc(&x);
        let (_, [steps, factored]) = Hexapod::forward_counted(&m, &q, &nearby).unwrap();
        assert_eq!(factored, 1, "{steps} steps");
        assert!((3..=6).contains(&steps), "{steps} steps");
    }
    let mut all = Vec::new();
    crate::mechanism::Mechanism::readings_into(&hex, &errors, &goals, &mut all).unwrap();
    let one: Vec<f64> = (goals.iter())
        .flat_map(|g| hex.readings(&errors, g).unwrap())
        .collect();
    assert_eq!(all, one);
}
