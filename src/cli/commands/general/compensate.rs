//! `compensate` of any mechanism with actuators ([`Commanded`]): the
//! identified machine's commands for targets and, for a simulated machine,
//! how far the true machine lands from them with either.

use super::files::{check_nominal, gate_rejected_fit, read_identified, read_targets};
use crate::cli::console;
use crate::config::general::MechanismConfig;
use crate::error::{Error, Result};
use crate::identify::general::{identify, predict, Holds};
use crate::io;
use crate::mechanism::{Commanded, Judged, Mechanism};
use std::path::Path;

/// What a mechanism adds to compensate for a simulated machine: its
/// accuracy over its workspace before and after (workspace_accuracy.csv, a
/// figure where it draws one) and the sentence that says so.
pub struct Maps {
    pub csv: String,
    pub figure: Option<(Vec<u8>, Vec<u8>)>,
    pub said: String,
}

/// How a mechanism maps a simulated machine (its errors in the
/// convention's frames) commanded nominally and by the identified model
/// (its errors).
pub type MapsOf<'a> = &'a dyn Fn(&[f64], &[f64]) -> Result<Maps>;

/// `compensate`: each target's actuator commands by the identified
/// machine's inverse kinematics (the config's poses without `targets`), in
/// `out`/commands.csv beside the nominal ones. With the config's [errors]
/// (a simulated machine), each row also says how far the true machine
/// lands from the target with either, by its exact forward kinematics, in
/// each quantity accuracy is judged by; and `maps` (where the mechanism
/// gives them) its accuracy over the workspace. Everything is computed
/// before anything is written.
pub fn run_compensate<C: MechanismConfig>(
    cfg: &C,
    identified: &Path,
    out: &Path,
    targets: Option<&Path>,
    accept_rejected_fit: bool,
    maps: Option<MapsOf>,
) -> Result<()>
where
    C::M: Commanded,
{
    check_nominal(cfg, identified)?;
    gate_rejected_fit(identified, accept_rejected_fit)?;
    let m = cfg.machine();
    let errors = read_identified(m, identified)?;
    let (list, poses) = match targets {
        None => (cfg.pose_rows(), cfg.poses().to_vec()),
        Some(path) => read_targets(path, cfg)?,
    };
    let truth = match cfg.simulated() {
        None => None,
        Some(e) => Some(in_convention(cfg, &e)?),
    };
    let (csv, worst) = commands_csv(cfg, &errors, truth.as_deref(), (&list, &poses), targets)?;
    let maps = match (&truth, maps) {
        (Some(t), Some(map)) => Some(map(t, &errors)?),
        _ => None,
    };
    let _lock = io::claim_dir(out)?;
    let path = out.join(crate::store::names::COMMANDS_CSV);
    let mut outputs = io::Outputs::default();
    outputs.replace_all(out, &crate::store::names::COMPENSATE_FILES);
    outputs.add(path.clone(), csv.into_bytes());
    if let Some(maps) = &maps {
        use crate::store::names::{
            WORKSPACE_ACCURACY_CSV, WORKSPACE_LAYERS_PNG, WORKSPACE_LAYERS_SVG,
        };
        outputs.add(
            out.join(WORKSPACE_ACCURACY_CSV),
            maps.csv.clone().into_bytes(),
        );
        if let Some((png, svg)) = &maps.figure {
            outputs.add(out.join(WORKSPACE_LAYERS_PNG), png.clone());
            outputs.add(out.join(WORKSPACE_LAYERS_SVG), svg.clone());
        }
    }
    outputs.write()?;
    let mut msg = format!(
        "wrote {} targets' corrected actuator commands to {}",
        poses.len(),
        path.display()
    );
    if let Some(w) = &worst {
        let judged = m.judged();
        msg += &format!(
            "; the simulated machine, in the convention's frames ({}), lands within {} of the targets with them, {} with the nominal commands",
            m.convention(),
            amounts(judged, w.iter().map(|[_, after]| *after), 2),
            amounts(judged, w.iter().map(|[before, _]| *before), 1),
        );
    }
    console::line(msg);
    if let Some(maps) = &maps {
        console::line(maps.said.clone());
    }
    Ok(())
}

/// The simulated machine's `errors` carried into the convention's frames
/// by a noise-free fit at the config's poses (the same actuator lengths,
/// so the same machine, in the frames the convention fixes): judged in the
/// frames the identified one is. Exact readings: any weights give the
/// same machine, so readings of different units weigh one each. What the
/// config holds is held at the simulated machine's own values (an error no
/// reading sees is then the machine's, not a fit's).
fn in_convention<C: MechanismConfig>(cfg: &C, errors: &[f64]) -> Result<Vec<f64>> {
    let m = cfg.machine();
    let exact = predict(m, errors, cfg.poses()).map_err(|why| Error::config(cfg.source(), why))?;
    let facts = m.reading_facts();
    let mixed = facts.iter().any(|f| f.quantity != facts[0].quantity);
    let sigma = if mixed {
        vec![1.0; facts.len()]
    } else {
        Vec::new()
    };
    let holds = Holds {
        fixed: cfg
            .holds()
            .fixed
            .iter()
            .map(|&(j, _)| (j, errors[j]))
            .collect(),
        ..Holds::default()
    };
    let fit = identify(m, cfg.poses(), &exact, 30, &sigma, &holds).map_err(|why| {
        Error::config(
            cfg.source(),
            format!("poses: the simulated machine cannot be put in the convention's frames at these poses ({why})"),
        )
    })?;
    Ok(fit.errors)
}

/// Each judged quantity's worst before and after.
type Worst = Vec<[f64; 2]>;

/// commands.csv: each target's cells as given, the identified machine's
/// commands and the nominal ones, and with a simulated machine `truth`
/// how far it lands from the target with either (before, after, by each
/// judged quantity); with the worst of each. A corrected command outside
/// the machine's travel is refused naming its target.
fn commands_csv<C: MechanismConfig>(
    cfg: &C,
    errors: &[f64],
    truth: Option<&[f64]>,
    (list, poses): (&[Vec<f64>], &[<C::M as Mechanism>::Target]),
    targets: Option<&Path>,
) -> Result<(String, Option<Worst>)>
where
    C::M: Commanded,
{
    let m = cfg.machine();
    let judged = m.judged();
    let file = || targets.map_or(cfg.source().to_string(), |p| p.display().to_string());
    let at = |j: usize, why: String| match targets {
        Some(path) => Error::csv(path.display().to_string(), format!("line {}: {why}", j + 2)),
        None => Error::config(cfg.source(), format!("poses.list[{}]: {why}", j + 1)),
    };
    let columns = m.command_columns();
    let mut head: Vec<String> = m.target_columns().iter().map(|c| c.to_string()).collect();
    head.extend(columns.iter().cloned());
    head.extend(columns.iter().map(|c| format!("nominal_{c}")));
    if truth.is_some() {
        for q in judged {
            head.push(format!("{}_before_{}", q.name, q.unit));
            head.push(format!("{}_after_{}", q.name, q.unit));
        }
    }
    let mut csv = head.join(",") + "\n";
    let zero = vec![0.0; errors.len()];
    let mut worst = vec![[0.0f64; 2]; judged.len()];
    for (j, (x, target)) in list.iter().zip(poses).enumerate() {
        let corrected = m.commands(errors, target).map_err(|why| at(j, why))?;
        // The identified machine's commands stay within the travel too: a
        // target near the end of travel can need more than the nominal one.
        cfg.check_commands(&corrected).map_err(|why| {
            at(
                j,
                format!("the identified machine needs {why}: keep the targets further from the end of travel"),
            )
        })?;
        let nominal = m.commands(&zero, target).map_err(|why| at(j, why))?;
        let mut cells: Vec<String> = x.iter().map(|v| format!("{v}")).collect();
        cells.extend(corrected.iter().chain(&nominal).map(|v| format!("{v}")));
        if let Some(t) = truth {
            let reach = |q: &[f64]| {
                m.reach(t, q, target).map_err(|why| {
                    Error::csv(
                        file(),
                        format!("target {}: the simulated machine {why}", j + 1),
                    )
                })
            };
            let (before, after) = (reach(&nominal)?, reach(&corrected)?);
            let (b, a) = (m.miss(&before, target), m.miss(&after, target));
            if b.len() != judged.len() || a.len() != judged.len() {
                return Err(Error::Internal(format!(
                    "{} judges {} quantities but measured {}",
                    m.name(),
                    judged.len(),
                    b.len()
                )));
            }
            for (k, w) in worst.iter_mut().enumerate() {
                *w = [w[0].max(b[k]), w[1].max(a[k])];
                cells.push(format!("{}", b[k]));
                cells.push(format!("{}", a[k]));
            }
        }
        csv += &cells.join(",");
        csv.push('\n');
    }
    Ok((csv, truth.map(|_| worst)))
}

/// Amounts by judged quantity: "0.0123 mm and 4.56″" (arc seconds to
/// `arcsec_digits` decimals).
pub(super) fn amounts(
    judged: &[Judged],
    values: impl Iterator<Item = f64>,
    arcsec_digits: usize,
) -> String {
    judged
        .iter()
        .zip(values)
        .map(|(q, v)| match q.unit {
            "arcsec" => format!("{v:.arcsec_digits$}″"),
            unit => format!("{v:.4} {unit}"),
        })
        .collect::<Vec<_>>()
        .join(" and ")
}
