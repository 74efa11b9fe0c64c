//! `identifiability`: rank, singular values, condition number, O1–O5.

use crate::calibration::HookeAxes;
use crate::cli::{console, OutputFormat};
use crate::config::Config;
use crate::error::{Error, Result};
use crate::export::rows::{identifiability_json, with_hooke_axes};
use crate::export::text::identifiability_text;
use crate::identify::tricept::design_matrix;
use crate::identify::tricept::{angle_design, AxesSolver};
use crate::mechanism::tricept::kinematics::Joints;
use crate::mechanism::tricept::second_class::{Angles, ANGLE_NAMES, N_ANGLES};
use crate::mechanism::tricept::{N_PARAMS, PARAM_NAMES};
use crate::sensors::ObservationCovariance;

pub fn run(cfg: &Config, format: OutputFormat) -> Result<()> {
    let poses = cfg.nominal_poses()?;
    let h = design_matrix(&cfg.nominal(), &poses)
        .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
    let method = cfg.identification.method;
    // The readings' own rank: no fixed error or prior.
    let solver = method
        .solver(
            (&cfg.sensors, &poses.joints),
            &h,
            cfg.identification.rank_tolerance,
            (&Default::default(), &PARAM_NAMES),
        )
        .map_err(|why| Error::config(&cfg.source, format!("identification.method {why}")))?;
    let a = &solver.analysis;
    let axes = if cfg.identification.second_class {
        Some(hooke_axes(cfg, &poses, &h, &solver)?)
    } else {
        None
    };
    match format {
        OutputFormat::Json => {
            let bytes = identifiability_json(
                &PARAM_NAMES,
                method,
                poses.len(),
                h.nrows(),
                a,
                None::<&()>,
                None,
            )?;
            let bytes = with_hooke_axes(bytes, axes.as_ref())?;
            console::text(String::from_utf8_lossy(&bytes));
        }
        OutputFormat::Text => {
            console::text(identifiability_text(poses.len(), &cfg.poses[0], method, a));
            if let Some(x) = &axes {
                let each: Vec<String> = (0..N_ANGLES)
                    .map(|k| {
                        format!(
                            "{} {} ({:.0} % of its effect unlike any error's; σ {})",
                            ANGLE_NAMES[k],
                            if x.identifiable[k] {
                                "identifiable"
                            } else {
                                "NOT identifiable"
                            },
                            100.0 * x.outside_span[k],
                            match x.predicted_std_deg[k] {
                                Some(sd) => format!("{sd:.5}°"),
                                None => "n/a".into(),
                            }
                        )
                    })
                    .collect();
                console::text(format!(
                    "With the Hooke axes (second_class = true): rank {} of {}; {}. The guide's twist is not among them: it moves the readings as the 15 errors do.\n",
                    x.rank,
                    N_PARAMS + N_ANGLES,
                    each.join("; ")
                ));
            }
        }
    }
    Ok(())
}

fn hooke_axes(
    cfg: &Config,
    poses: &crate::mechanism::tricept::NominalPoses,
    h: &nalgebra::DMatrix<f64>,
    solver: &crate::identify::tricept::LinearSolver,
) -> Result<HookeAxes> {
    let h3 = angle_design(&cfg.nominal(), &Angles::zeros(), &poses.joints)
        .map_err(|e| Error::config(&cfg.source, format!("poses: {e}")))?;
    let fail =
        |why: String| Error::config(&cfg.source, format!("identification.second_class {why}"));
    let ext = AxesSolver::new(solver, &h3, cfg.identification.rank_tolerance).map_err(fail)?;
    let stated = cfg.sensors.stated_covariances();
    let at_nominal = HookeAxes::of(
        solver,
        &ext,
        &ObservationCovariance::new(&stated, &poses.joints),
    );
    let varies = cfg.sensors.structured.is_some_and(|st| {
        st.axes
            .iter()
            .any(|a| a.interpolation > 0.0 && a.signal_period > 0.0)
    });
    if !varies {
        return Ok(at_nominal);
    }
    // As identify would state it on each machine: weighted and stated at
    // that machine's readings.
    let method = cfg.identification.method;
    let tol = cfg.identification.rank_tolerance;
    let mut sum = [0.0; N_ANGLES];
    let machines = over_machines(cfg, poses, |measured| {
        let solver = method
            .solver(
                (&cfg.sensors, measured),
                h,
                tol,
                (&Default::default(), &PARAM_NAMES),
            )
            .map_err(|why| Error::config(&cfg.source, format!("identification.method {why}")))?;
        let ext = AxesSolver::new(&solver, &h3, tol).map_err(fail)?;
        let x = HookeAxes::of(
            &solver,
            &ext,
            &ObservationCovariance::new(&stated, measured),
        );
        for (s, sd) in sum.iter_mut().zip(&x.predicted_std_deg) {
            *s += sd.map_or(0.0, |x| x * x);
        }
        Ok(())
    })?;
    if machines == 0 {
        return Ok(at_nominal);
    }
    Ok(HookeAxes {
        predicted_std_deg: std::array::from_fn(|k| {
            at_nominal.predicted_std_deg[k].map(|_| (sum[k] / f64::from(machines)).sqrt())
        }),
        ..at_nominal
    })
}

/// Machines a statement without readings averages the interpolation
/// error's kernel over.
const STATED_MACHINES: u64 = 64;

/// Call `each` with the homed true readings of each of [`STATED_MACHINES`]
/// machines drawn as the study draws them (`[sweep] errors`,
/// `error_bound`, `seed`): the interpolation error's kernel depends on
/// where within its signal period each reading falls, which a machine's
/// errors move by a good part of a period, so a statement without
/// readings averages over them. Returns how many machines reached every
/// pose.
fn over_machines(
    cfg: &Config,
    poses: &crate::mechanism::tricept::NominalPoses,
    mut each: impl FnMut(&[Joints]) -> Result<()>,
) -> Result<u32> {
    let sw = &cfg.sweep;
    let mut actual = vec![nalgebra::Vector3::zeros(); poses.len()];
    let mut machines = 0u32;
    for k in 0..STATED_MACHINES {
        let e =
            crate::montecarlo::trial_errors(sw.errors, &cfg.errors, sw.error_bound_mm, sw.seed, k);
        let machine = crate::mechanism::tricept::Machine::with_errors(&cfg.geometry, &e);
        if poses.actual_joints_into(&machine, &mut actual).is_err() {
            continue;
        }
        // Homed at the reference, as the controller reports them.
        let j0 = poses.joints[0].as_vector();
        let measured: Vec<Joints> = actual
            .iter()
            .map(|a| Joints::from_vector(&(j0 + a - actual[0])))
            .collect();
        each(&measured)?;
        machines += 1;
    }
    Ok(machines)
}
