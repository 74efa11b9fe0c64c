//! `compensate` for the hexapod: the identified machine's commands for
//! target poses (verify is any mechanism's, `general::run_verify`).

use super::hexapod_errors;
use crate::cli::commands::general::files::{gate_rejected_fit, read_identified, read_targets};
use crate::cli::console;
use crate::config::general::MechanismConfig;
use crate::config::hexapod::HexapodConfig;
use crate::error::{Error, Result};
use crate::identify::general::{identify, predict, Holds};
use crate::io;
use crate::mechanism::hexapod::convention::CONVENTION;
use crate::mechanism::hexapod::LEGS;
use std::path::Path;

/// `compensate`: each target pose's actuator commands by the identified
/// machine's inverse kinematics (the config's poses without `--targets`),
/// in `out`/commands.csv beside the nominal ones. With the config's
/// [errors] (a simulated machine), each row also says how far the true
/// machine lands from the target with either, by its exact forward
/// kinematics: the platform origin's position error (mm) and the
/// orientation error (arc seconds).
pub fn run_compensate(
    cfg: &HexapodConfig,
    identified: &Path,
    out: &Path,
    targets: Option<&Path>,
    accept_rejected_fit: bool,
) -> Result<()> {
    use crate::mechanism::hexapod::kinematics::rotation_angle;
    use crate::mechanism::hexapod::Hexapod;
    gate_rejected_fit(identified, accept_rejected_fit)?;
    let errors = hexapod_errors(identified, read_identified(&cfg.hexapod, identified)?)?;
    let (list, poses) = match targets {
        None => (cfg.pose_rows(), cfg.poses.clone()),
        Some(path) => read_targets(path, cfg)?,
    };
    let hex = &cfg.hexapod;
    let model = hex.actual(&errors);
    // A simulated machine judged in the convention's frames, as the
    // identified one is: its errors carried into the convention by a
    // noise-free fit at the config's poses (the same leg lengths, so the
    // same machine, in the frames the convention fixes).
    let truth = match cfg.errors {
        None => None,
        Some(e) => {
            let exact =
                predict(hex, &e, &cfg.poses).map_err(|why| Error::config(&cfg.source, why))?;
            let fit = identify(hex, &cfg.poses, &exact, 30, &[], &Holds::default()).map_err(|why| {
                Error::config(
                    &cfg.source,
                    format!("poses: the simulated machine cannot be put in the convention's frames at these poses ({why})"),
                )
            })?;
            let errors: crate::mechanism::hexapod::Errors =
                fit.errors.as_slice().try_into().map_err(|_| {
                    Error::config(&cfg.source, "the fit gave the wrong number of errors")
                })?;
            Some(hex.actual(&errors))
        }
    };
    let mut csv = String::from("x_mm,y_mm,z_mm,a_deg,b_deg,c_deg");
    for i in 1..=LEGS {
        csv += &format!(",q{i}_mm");
    }
    for i in 1..=LEGS {
        csv += &format!(",nominal_q{i}_mm");
    }
    if truth.is_some() {
        csv += ",position_before_mm,position_after_mm,orientation_before_arcsec,orientation_after_arcsec";
    }
    csv.push('\n');
    let mut worst = [0.0f64; 4];
    for (j, (x, target)) in list.iter().zip(&poses).enumerate() {
        let corrected = hex.commands_of(&model, target);
        // The identified machine's commands stay within the stroke too: a
        // target near the end of travel can need more than the nominal one.
        if let Some([lo, hi]) = cfg.limits.stroke_mm {
            if let Some((i, q)) = corrected
                .iter()
                .enumerate()
                .find(|(_, q)| !(lo..=hi).contains(*q))
            {
                let why = format!(
                    "the identified machine needs actuator {} at {q:.3} mm, outside its stroke [{lo}, {hi}] mm (hexapod.stroke_mm): keep the targets further from the end of travel",
                    i + 1
                );
                return Err(match targets {
                    Some(path) => {
                        Error::csv(path.display().to_string(), format!("line {}: {why}", j + 2))
                    }
                    None => Error::config(&cfg.source, format!("poses.list[{}]: {why}", j + 1)),
                });
            }
        }
        let nominal = hex.commands(target);
        let mut cells: Vec<String> = x.iter().map(|v| format!("{v}")).collect();
        cells.extend(corrected.iter().chain(&nominal).map(|v| format!("{v}")));
        if let Some(m) = &truth {
            let reach = |q: &[f64; LEGS]| {
                Hexapod::forward(m, q, target).map_err(|why| {
                    Error::csv(
                        targets.map_or(cfg.source.clone(), |p| p.display().to_string()),
                        format!("target {}: the simulated machine {why}", j + 1),
                    )
                })
            };
            let (before, after) = (reach(&nominal)?, reach(&corrected)?);
            let errs = [
                (before.t - target.t).norm(),
                (after.t - target.t).norm(),
                rotation_angle(&(before.r * target.r.transpose())).to_degrees() * 3600.0,
                rotation_angle(&(after.r * target.r.transpose())).to_degrees() * 3600.0,
            ];
            for (w, e) in worst.iter_mut().zip(errs) {
                *w = w.max(e);
            }
            cells.extend(errs.iter().map(|v| format!("{v}")));
        }
        csv += &cells.join(",");
        csv.push('\n');
    }
    // A simulated machine: its accuracy over the workspace before and
    // after, computed before anything is written.
    let maps = match &truth {
        None => None,
        Some(m) => Some(workspace_maps(cfg, m, &model)?),
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
    if truth.is_some() {
        msg += &format!(
            "; the simulated machine, in the convention's frames ({CONVENTION}), lands within {:.4} mm and {:.2}″ of the targets with them, {:.4} mm and {:.1}″ with the nominal commands",
            worst[1], worst[3], worst[0], worst[2]
        );
    }
    console::line(msg);
    if let Some(maps) = &maps {
        console::line(format!(
            "over the workspace's {} poses (tool point {:?} mm in the platform frame): largest position error {:.4} mm before, {:.4} mm after; orientation {:.1}″ before, {:.2}″ after (workspace_accuracy.csv{})",
            cfg.workspace.len(),
            [cfg.tool_mm.x, cfg.tool_mm.y, cfg.tool_mm.z],
            maps.worst[0],
            maps.worst[1],
            maps.worst[2],
            maps.worst[3],
            if maps.figure.is_some() { "; the position error per layer: workspace_layers.png" } else { "" }
        ));
    }
    Ok(())
}

/// What compensate maps for a simulated machine.
struct Maps {
    /// workspace_accuracy.csv: every `[workspace]` pose.
    csv: String,
    /// Largest position before, after (mm), orientation before, after (″).
    worst: [f64; 4],
    /// The position error over planes at the home orientation (PNG, SVG);
    /// None when the workspace is one position.
    figure: Option<(Vec<u8>, Vec<u8>)>,
}

/// The simulated machine `truth` (in the convention's frames) commanded
/// nominally and by `model`, over the `[workspace]` poses and over a grid
/// of positions filling the workspace's box in three planes (home z and ±
/// its half extent) at the home orientation, each mapped where the tool
/// point is asked to be: the tool point's position error and the
/// platform's orientation error, by exact forward kinematics.
fn workspace_maps(
    cfg: &HexapodConfig,
    truth: &crate::mechanism::hexapod::kinematics::Actual,
    model: &crate::mechanism::hexapod::kinematics::Actual,
) -> Result<Maps> {
    use crate::mechanism::hexapod::kinematics::landing_error;
    use crate::mechanism::hexapod::{Pose, N_ERRORS};
    let hex = &cfg.hexapod;
    let nominal = hex.actual(&[0.0; N_ERRORS]);
    let fail = |w: &[f64; 6], why: String| {
        Error::config(
            &cfg.source,
            format!("workspace: the simulated machine cannot reach {w:?}: {why}"),
        )
    };
    let arcsec = |rad: f64| rad.to_degrees() * 3600.0;
    let mut csv = String::from("x_mm,y_mm,z_mm,a_deg,b_deg,c_deg,position_before_mm,position_after_mm,orientation_before_arcsec,orientation_after_arcsec\n");
    let mut worst = [0.0f64; 4];
    for w in &cfg.workspace {
        let x = w.to_xyzabc();
        let (pb, ob) =
            landing_error(hex, truth, &nominal, w, &cfg.tool_mm).map_err(|e| fail(&x, e))?;
        let (pa, oa) =
            landing_error(hex, truth, model, w, &cfg.tool_mm).map_err(|e| fail(&x, e))?;
        let row = [pb, pa, arcsec(ob), arcsec(oa)];
        for (m, v) in worst.iter_mut().zip(row) {
            *m = m.max(v);
        }
        let cells: Vec<String> = x.iter().chain(&row).map(|v| format!("{v}")).collect();
        csv += &cells.join(",");
        csv.push('\n');
    }
    let [hx, hy, hz] = cfg.half_extent_mm;
    // The box's x-y extent on a square grid, the circle drawn around it.
    let radius = hx.hypot(hy);
    let figure = if radius > 0.0 {
        let step = hx.max(hy) / 5.0;
        let h = hex.home.to_xyzabc();
        let zs: Vec<f64> = if hz > 0.0 {
            vec![h[2] - hz, h[2], h[2] + hz]
        } else {
            vec![h[2]]
        };
        let mut map = crate::compensate::VolumetricMap {
            points: Vec::new(),
            before_mm: Vec::new(),
            after_mm: Vec::new(),
        };
        for &z in &zs {
            for i in -5i32..=5 {
                for j in -5i32..=5 {
                    let (dx, dy) = (f64::from(i) * step, f64::from(j) * step);
                    if dx.abs() > hx + 1e-9 || dy.abs() > hy + 1e-9 {
                        continue;
                    }
                    let x = [h[0] + dx, h[1] + dy, z, h[3], h[4], h[5]];
                    let p = Pose::from_xyzabc(&x);
                    let (b, _) = landing_error(hex, truth, &nominal, &p, &cfg.tool_mm)
                        .map_err(|e| fail(&x, e))?;
                    let (a, _) = landing_error(hex, truth, model, &p, &cfg.tool_mm)
                        .map_err(|e| fail(&x, e))?;
                    // Mapped where the tool point is asked to be.
                    map.points.push(p.t + p.r * cfg.tool_mm);
                    map.before_mm.push(b);
                    map.after_mm.push(a);
                }
            }
        }
        let draw = |format| {
            crate::export::figures::layers_of(
                &map,
                zs.len(),
                step,
                radius,
                (
                    "Tool-point position error at the home orientation",
                    "position error",
                ),
                format,
            )
        };
        use crate::export::figures::Format;
        Some((draw(Format::Png)?, draw(Format::Svg)?))
    } else {
        None
    };
    Ok(Maps { csv, worst, figure })
}
