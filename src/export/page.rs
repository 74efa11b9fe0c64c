//! The contents of `report.html` from a finished study (see [`super::html`]).

use super::html::{SensorLine, StudyPage, Table};
use crate::config::{Config, ConfigStudy, ErrorDraw};
use crate::montecarlo::SweepResult;
use crate::sensors::ARCSEC_PER_RAD;

/// Rows of a table shown on the page at most.
const MAX_ROWS: usize = 40;

fn num(v: Option<f64>) -> String {
    v.filter(|x| x.is_finite())
        .map_or(String::new(), |x| format!("{x:.4}"))
}

/// The page of a study; `figures` are (caption, SVG) in display order.
pub fn study_page(
    cfg: &Config,
    study: &ConfigStudy,
    result: &SweepResult,
    figures: Vec<(String, String)>,
) -> StudyPage {
    let sw = &study.sweep;
    let d = &study.decision;
    let mut question = vec![
        (
            "target".to_string(),
            format!(
                "{} ≤ {} ({})",
                d.estimate.describe(),
                d.threshold,
                match d.confidence {
                    crate::metrics::Confidence::Upper95 =>
                        format!("its {} must meet it", d.metric.limit_words()),
                    crate::metrics::Confidence::Estimate => "the estimate must meet it".into(),
                }
            ),
        ),
        (
            "machines simulated".into(),
            format!("{} (seed {})", result.trials, sw.seed),
        ),
        (
            "machine errors".into(),
            match sw.errors {
                ErrorDraw::Random => format!(
                    "{} geometric errors uniform in ±{} mm, a new machine per trial",
                    cfg.errors.len(),
                    sw.error_bound_mm
                ),
                ErrorDraw::Fixed => "the config's [errors] table".into(),
            },
        ),
        (
            "calibration poses".into(),
            format!("{:?} of the config's {}", sw.pose_counts, study.poses.len()),
        ),
        (
            "estimators".into(),
            sw.methods
                .iter()
                .map(|m| m.title())
                .collect::<Vec<_>>()
                .join(", "),
        ),
        ("config".into(), cfg.source.clone()),
    ];
    question.extend(set_up(cfg, study));
    if let Some(p) = &sw.products {
        // The file's name and content digest: the same page whether the
        // study ran in one process or was merged from shards (which record
        // the catalogue's absolute path).
        question.push((
            "catalogue".into(),
            format!(
                "{} (content digest {})",
                p.path.file_name().map_or_else(
                    || p.path.display().to_string(),
                    |n| n.to_string_lossy().into_owned()
                ),
                &p.digest[..p.digest.len().min(16)]
            ),
        ));
    }
    let (encoders, scales) = sensor_lines(cfg, study);
    let limit = d
        .estimate
        .upper_limit()
        .map_or("no confidence limit".to_string(), |m| {
            m.limit_words().to_string()
        });
    let ranking = Table {
        caption: format!(
            "decision.csv: every combination ranked (first {MAX_ROWS}); upper limit: the {limit}"
        ),
        header: [
            "rank",
            "encoder",
            "scale",
            "poses",
            "method",
            "price",
            "value",
            "upper limit",
            "feasible",
        ]
        .map(String::from)
        .to_vec(),
        rows: result
            .ranking
            .iter()
            .take(MAX_ROWS)
            .map(|r| {
                vec![
                    r.rank.to_string(),
                    if r.encoder.is_empty() {
                        format!("{}″", r.encoder_arcsec)
                    } else {
                        r.encoder.clone()
                    },
                    if r.scale.is_empty() {
                        format!("{} µm", r.scale_um)
                    } else {
                        r.scale.clone()
                    },
                    r.pose_count.to_string(),
                    r.method.name().to_string(),
                    r.price.map_or(String::new(), |p| format!("{p:.0}")),
                    num(r.value),
                    num(r.upper_limit),
                    if r.chosen {
                        "chosen".into()
                    } else if r.fragile {
                        "fragile".into()
                    } else {
                        r.feasible.to_string()
                    },
                ]
            })
            .collect(),
    };
    // The deciding metric's budget where the study made one, else mean μ's.
    let row_of = |b: &crate::metrics::BudgetRow| {
        vec![
            // A grade study's sensors have no names: their grades.
            if b.encoder.is_empty() {
                format!(
                    "{}″ + {} µm, {} poses, {}",
                    b.encoder_arcsec,
                    b.scale_um,
                    b.pose_count,
                    b.method.name()
                )
            } else {
                format!(
                    "{} + {}, {} poses, {}",
                    b.encoder,
                    b.scale,
                    b.pose_count,
                    b.method.name()
                )
            },
            num(Some(b.total_mm)),
            num(Some(b.floor_mm)),
            num(Some(b.psi_encoder_mm)),
            num(Some(b.theta_encoder_mm)),
            num(Some(b.scale_mm)),
            b.limiting.to_string(),
        ]
    };
    let (caption, measure, rows) = if result.decision_budget.is_empty() {
        (
            format!("budget.csv: mean μ and where it comes from, mm (first {MAX_ROWS} by rank)"),
            "mean μ".to_string(),
            result
                .ranking
                .iter()
                .take(MAX_ROWS)
                .filter_map(|r| result.budget.get(r.row).map(row_of))
                .collect(),
        )
    } else {
        let m = result
            .ranking
            .first()
            .map_or(study.decision.metric, |r| r.metric);
        (
            format!(
                "decision_budget.csv: {} and where it comes from, mm (first {} of the first-ranked estimator by rank)",
                m.describe().trim_end_matches(" (mm)"),
                result.decision_budget.len()
            ),
            m.name().to_string(),
            result.decision_budget.iter().map(row_of).collect(),
        )
    };
    let budget = Table {
        caption,
        header: [
            "combination",
            measure.as_str(),
            "no sensor can fix",
            "ψ4 encoder",
            "θ4 encoder",
            "scale",
            "limiting",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    };
    StudyPage {
        title: format!("tricept-calib study: {}", cfg.source),
        answer: super::verdict::of(result).text,
        question,
        sensors: vec![
            ("Encoders (two fitted: ψ4 and θ4)".to_string(), encoders),
            ("Linear scales".to_string(), scales),
        ],
        figures,
        tables: std::iter::once(ranking)
            .chain(what_if_table(study, result))
            .chain([budget])
            .collect(),
        assumptions: assumptions(study)
            .into_iter()
            .chain(spread_note(result))
            .collect(),
    }
}

/// In words a reviewer reads: how often the linear model's predicted
/// spread of an identified error misses the simulated one by more than
/// 10 %, why (the single linearisation) and what removes it, and why the
/// verdict does not depend on it. None when it never does.
fn spread_note(result: &SweepResult) -> Option<String> {
    let identified: Vec<_> = result
        .parameters
        .iter()
        .filter(|p| p.identifiable)
        .collect();
    let off = identified
        .iter()
        .filter(|p| !(0.9..=1.1).contains(&p.ratio_mc_to_predicted))
        .count();
    let above = identified
        .iter()
        .filter(|p| p.ratio_mc_to_predicted > 1.1)
        .count();
    (off > 0).then(|| format!(
        "The predicted spread of an identified error (the sensors' covariance, the interpolation error's at each machine's readings included, through the estimator) differs from the spread over the simulated machines by more than 10 % in {off} of {} cases (an error under one combination; parameters.csv, ratio_mc_to_predicted){}. The prediction is first order: a single linearisation's own error, which grows with the square of the machines' errors and dominates where the sensors contribute little, is not in it — [identification] iterations = 5 (Gauss–Newton) removes it. The verdict never uses the prediction: it rests on the simulated machines.",
        identified.len(),
        if above > 0 { format!(", {above} of them above it") } else { String::new() }
    ))
}

/// The machine and where it is judged: the geometry, the workspace and
/// the workspace grid's step (with units), from the config and the study.
fn set_up(cfg: &Config, study: &ConfigStudy) -> Vec<(String, String)> {
    let g = &cfg.resolved().geometry;
    let angles = |v: &[f64]| {
        v.iter()
            .map(|a| format!("{a}°"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let w = &cfg.workspace;
    let grid = match study.sweep.volumetric_step_mm {
        Some(step) => format!(
            "grid step {step} mm on {} plane{} from the top face to the bottom face, and the ISO 9283 positions P1–P5 (dV by {})",
            cfg.layers,
            if cfg.layers == 1 { "" } else { "s" },
            if study.sweep.volumetric_exact {
                "exact kinematics"
            } else {
                "first-order propagation"
            }
        ),
        None => "no grid step: the workspace is not judged (sweep.volumetric = false); μ is the parameter error".into(),
    };
    vec![
        (
            "geometry".into(),
            format!(
                "platform circumradius a = {} mm, base circumradius b = {} mm; base joint angles β = {}; platform joint angles α = {}; limb tilt at most {}°",
                g.a,
                g.b,
                angles(&g.base_angles_deg),
                angles(&g.platform_angles_deg),
                cfg.max_tilt_deg
            ),
        ),
        (
            "workspace".into(),
            format!(
                "cylinder of radius {} mm and height {} mm, z from {} mm to {} mm (mid-plane z = {} mm)",
                w.radius_mm,
                w.height_mm,
                w.top_mm,
                w.top_mm + w.height_mm,
                w.top_mm + w.height_mm / 2.0
            ),
        ),
        ("workspace grid".into(), grid),
    ]
}

/// What the first-ranked combination reaches when the true sensors are
/// not the datasheet's (`[sweep] truth_amplitude`, `truth_extra_harmonic`),
/// every estimator on the same machines; None without what-if rows.
fn what_if_table(study: &ConfigStudy, result: &SweepResult) -> Option<Table> {
    let first = result.ranking.first()?;
    if result.truth.is_empty() {
        return None;
    }
    let d = &study.decision;
    let same = |r: &&crate::metrics::GradeSummary| {
        r.encoder == first.encoder
            && r.scale == first.scale
            && r.encoder_arcsec == first.encoder_arcsec
            && r.scale_um == first.scale_um
            && r.pose_count == first.pose_count
    };
    let truth = |r: &crate::metrics::GradeSummary| r.truth.clone();
    let rows = result
        .summary
        .iter()
        .filter(same)
        .chain(result.truth.iter().filter(same))
        .map(|r| {
            vec![
                truth(r),
                r.method.name().to_string(),
                num(d.estimate.value(r)),
                num(d.estimate.upper_limit().and_then(|m| m.value(r))),
                if r.meets_target { "yes" } else { "no" }.to_string(),
            ]
        })
        .collect();
    Some(Table {
        caption: format!(
            "What rests on the datasheets: {} with {} poses read by other sensors than the datasheets describe (the estimators still assume the datasheets; summary.csv)",
            first.sensors(),
            first.pose_count
        ),
        header: [
            "true sensors",
            "estimator",
            d.estimate.describe(),
            "upper limit",
            "meets the target",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    })
}

/// The encoder and scale models of the study.
fn sensor_lines(cfg: &Config, study: &ConfigStudy) -> (Vec<SensorLine>, Vec<SensorLine>) {
    if let Some(p) = &study.sweep.products {
        let ne = p.encoders.len();
        let enc = p
            .encoders
            .iter()
            .enumerate()
            .map(|(i, e)| SensorLine {
                name: e.name.clone(),
                price: Some(e.price),
                unit: "″",
                axis: Some(p.models[i].axes[0]),
                sigma: None,
            })
            .collect();
        let sc = p
            .scales
            .iter()
            .enumerate()
            .map(|(i, s)| SensorLine {
                name: s.name.clone(),
                price: Some(s.price),
                unit: "µm",
                axis: Some(p.models[i * ne].axes[2]),
                sigma: None,
            })
            .collect();
        return (enc, sc);
    }
    let line = |g: f64, unit: &'static str, k: usize| {
        let axis = cfg.sensors.structured.map(|st| {
            let st = st.at_grades(g / ARCSEC_PER_RAD, g * 1e-3);
            st.axes[k]
        });
        SensorLine {
            name: format!("grade {g} {}", if unit == "″" { "arcsec" } else { "µm" }),
            price: None,
            unit,
            sigma: axis.is_none().then_some(g),
            axis: axis.filter(|_| cfg.sensors.structured.is_some_and(|s| s.from_section[k])),
        }
    };
    (
        study
            .sweep
            .encoder_arcsec
            .iter()
            .map(|&g| line(g, "″", 0))
            .collect(),
        study
            .sweep
            .scale_um
            .iter()
            .map(|&g| line(g, "µm", 2))
            .collect(),
    )
}

fn assumptions(study: &ConfigStudy) -> Vec<String> {
    let mut a = vec![
        "Readings come from exact forward kinematics of each simulated machine, never from the linear model; identification is the linearised least squares of the paper (OLS), weighted by 1/σ of each row's sensor (WLS), or whitened by the sensors' error covariance as their datasheet models describe it (GLS, docs/method.md §13). GLS's advantage rests on those models: the what-if rows, where the study has them, show what is left when the true sensors differ.".to_string(),
        "Every combination sees the same machines and the same noise draws (common random numbers), so differences between combinations carry much less sampling noise than with independent draws.".into(),
        "Sensor errors: a white-noise grade is the σ of each sample (the paper's reading); a datasheet model bounds a repeatable curve per revolution or measuring length with random phases per machine, plus interpolation error, jitter and quantisation (docs/method.md §11). A reading is the mean of the configured samples; sensors are homed at the reference pose.".into(),
        "The budget is the same calibrations repeated on the same machines with every sensor read exactly, and with each sensor alone read exactly (the estimator still weighting it by its datasheet): in the deciding metric for the first-ranked combinations of the first-ranked estimator (decision_budget.csv), in mean μ for every combination (budget.csv). With datasheet sensors the deciding metric's budget is also split by error term (curve, eccentricity, interpolation error, jitter and quantisation), each term read exactly in every sensor on the same machines and draws.".into(),
        "Prices are the catalogue's; the shipped catalogue's prices are placeholders for the user's quotes. A combination costs two encoders and one scale.".into(),
    ];
    if study.sweep.volumetric_step_mm.is_some() {
        a.push("Workspace accuracy dV is propagated to first order from sensitivities at the nominal commands (within 1 µm + 1 % of exact kinematics, tested), over the workspace grid and the ISO 9283 positions P1–P5; AP is the distance from commanded to attained position (no repeatability model).".into());
    }
    if study.sweep.products.is_none() {
        a.push("The study compares sensor grades without prices: among those that meet the target the ranking prefers fewer poses, then the coarser grades.".into());
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{parse_raw, Config};

    fn config(text: &str) -> Config {
        Config::from_raw(parse_raw(text, "t").unwrap(), "t").unwrap()
    }

    /// The set-up names the geometry, the workspace and the grid step, each
    /// with its unit, from the config.
    #[test]
    fn set_up_gives_geometry_workspace_and_grid_step() {
        let cfg = config(
            "[geometry]\na = 110.0\n[workspace]\nradius = 350.0\n[compensation]\nlayers = 3\n[sweep]\nvolumetric = true\nvolumetric_grid_step = 50.0\n",
        );
        let lines = set_up(&cfg, &cfg.study().build().unwrap());
        let get = |k: &str| &lines.iter().find(|(l, _)| l == k).unwrap().1;
        assert!(get("geometry").contains("a = 110 mm, base circumradius b = 288.7 mm"));
        assert!(get("geometry").contains("β = -60°, 60°, 180°"));
        assert!(
            get("workspace").contains("radius 350 mm and height 200 mm, z from 650 mm to 850 mm")
        );
        assert!(get("workspace grid").contains("grid step 50 mm on 3 planes"));
        let plain = config("");
        let lines = set_up(&plain, &plain.study().build().unwrap());
        assert!(lines[2].1.contains("not judged"));
    }
}
