//! The hexapod's part of `compensate` (any mechanism's,
//! `general::run_compensate`, dispatched by `cli/mechanism.rs`): its
//! workspace maps of a simulated machine.

use super::hexapod_errors;
use crate::cli::commands::general;
use crate::config::hexapod::HexapodConfig;
use crate::error::{Error, Result};
use std::path::Path;

/// The hexapod's workspace maps of a simulated machine (`truth`) commanded
/// nominally and by the identified model (`model`, read from
/// `identified`): the tool point's position error and the platform's
/// orientation error over the `[workspace]` poses, and the position error
/// over planes at the home orientation.
pub fn maps(
    cfg: &HexapodConfig,
    identified: &Path,
    truth: &[f64],
    model: &[f64],
) -> Result<general::Maps> {
    {
        let actual =
            |e: &[f64]| hexapod_errors(identified, e.to_vec()).map(|e| cfg.hexapod.actual(&e));
        let maps = workspace_maps(cfg, &actual(truth)?, &actual(model)?)?;
        let said = format!(
            "over the workspace's {} poses (tool point {:?} mm in the platform frame): largest position error {:.4} mm before, {:.4} mm after; orientation {:.1}″ before, {:.2}″ after (workspace_accuracy.csv{})",
            cfg.workspace.len(),
            [cfg.tool_mm.x, cfg.tool_mm.y, cfg.tool_mm.z],
            maps.worst[0],
            maps.worst[1],
            maps.worst[2],
            maps.worst[3],
            if maps.figure.is_some() { "; the position error per layer: workspace_layers.png" } else { "" }
        );
        Ok(general::Maps {
            csv: maps.csv,
            figure: maps.figure,
            said,
        })
    }
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
