//! A study's rows ([`Row`]), its figure (price against accuracy) and
//! report.html, in the buyer's words: the verdict, the question, the
//! encoders, the figure, the table, the assumptions. The mechanism gives
//! the nouns ([`Mechanism::words`]).

use crate::config::general::{Estimator, MechanismConfig, Spec, Study};
use crate::error::Result;
use crate::export::figures::{PriceChart, PricePoint};
use crate::export::html::{HtmlExporter, SensorLine, StudyPage, Table};
use crate::export::study_verdict::{fragile_rows, RowOf};
use crate::export::Exporter;
use crate::mechanism::Mechanism;

/// The spec of a mechanism's study.
type SpecOf<M> = Spec<<M as Mechanism>::Target, <M as Mechanism>::Variant>;

const VALUE_DESC: &str = "worst tool-point error in the workspace, p95 upper limit (mm)";

/// A row's label on the figure and in the table.
fn label<M: Mechanism>(m: &M, spec: &SpecOf<M>, r: &RowOf<M>) -> String {
    let mut s = format!(
        "{} × {}, {} poses",
        m.fitted(r.c.variant),
        spec.sensors[r.c.sensor].name,
        r.c.poses
    );
    if spec.estimators.len() > 1 {
        s = format!("{s}, {}", r.c.estimator.name());
    }
    s
}

/// Marker classes: encoders per joint (× estimator when there are several).
fn marker<M: Mechanism>(m: &M, spec: &SpecOf<M>, r: &RowOf<M>) -> (usize, Vec<String>) {
    let mut names = Vec::new();
    let mut at = 0;
    for &p in &spec.variants {
        for &e in &spec.estimators {
            if p == r.c.variant && e == r.c.estimator {
                at = names.len();
            }
            names.push(if spec.estimators.len() > 1 {
                format!("{}, {}", m.variant_words(p)[1], e.name())
            } else {
                m.variant_words(p)[1].to_string()
            });
        }
    }
    (at, names)
}

/// The figure, when every encoder has a price and a target is set.
pub fn price_chart<M: Mechanism>(
    m: &M,
    spec: &SpecOf<M>,
    study: &Study<M>,
    rows: &[RowOf<M>],
    chosen: Option<usize>,
) -> Option<PriceChart> {
    let w = m.words();
    let threshold = study.position_mm?;
    if rows.iter().any(|r| r.price.is_none()) || rows.is_empty() {
        return None;
    }
    // A fragile pass is not feasible: the verdict does not choose it.
    let fragile = fragile_rows(rows);
    let points = rows
        .iter()
        .zip(fragile)
        .map(|(r, fragile)| PricePoint {
            price: r.price.unwrap_or(f64::NAN),
            value: r.position_p95_upper.unwrap_or(f64::NAN),
            pose_count: r.c.poses,
            feasible: r.meets == Some(true) && !fragile,
            label: label(m, spec, r),
            method: marker(m, spec, r).0,
        })
        .collect();
    Some(PriceChart {
        title: format!(
            "{} price against accuracy, {} machines per combination",
            capitalised(w.sensor),
            spec.trials
        ),
        x_desc: format!(
            "total encoder price, {} (catalogue prices, in the catalogue's currency units)",
            w.fitted
        ),
        y_desc: VALUE_DESC.into(),
        threshold,
        points,
        chosen,
        chosen_misses: false,
        methods: marker(m, spec, &rows[0]).1,
        also: study.orientation_arcsec.map_or(String::new(), |o| {
            format!(" and the orientation's ≤ {o}″ (which the band does not show)")
        }),
    })
}

/// What the study's estimators do, in one sentence.
fn estimator_words<T, V>(spec: &Spec<T, V>) -> String {
    let words: Vec<&str> = spec
        .estimators
        .iter()
        .map(|e| match e {
            Estimator::Linear => "linear weights every reading alike, once at the nominal machine",
            Estimator::Gls => "gls weights each encoder's readings by its datasheet covariance at the angles it stands at (its curve across them, its interpolation error, jitter and resolution), once at the nominal machine",
            Estimator::GaussNewton => "gauss-newton re-linearises at the estimate's exact kinematics, as identify does",
        })
        .collect();
    format!("Estimators: {}.", words.join("; "))
}

/// report.html's bytes.
pub fn page<C: MechanismConfig>(
    cfg: &C,
    spec: &SpecOf<C::M>,
    study: &Study<C::M>,
    rows: &[RowOf<C::M>],
    answer: &str,
    svg: Option<String>,
) -> Result<Vec<u8>> {
    let m = cfg.machine();
    let w = m.words();
    let f4 = |x: Option<f64>| {
        x.filter(|v| v.is_finite())
            .map_or(String::new(), |v| format!("{v:.4}"))
    };
    let f2 = |x: Option<f64>| {
        x.filter(|v| v.is_finite())
            .map_or(String::new(), |v| format!("{v:.2}"))
    };
    let target = match (study.position_mm, study.orientation_arcsec) {
        (None, _) => "none set ([decision] position_mm): the rows compare the encoders".to_string(),
        (Some(p), o) => format!(
            "95 % of machines within {p} mm{} everywhere in the workspace after compensation, at the upper 95 % confidence limit",
            o.map_or(String::new(), |o| format!(" and {o}″"))
        ),
    };
    let counts: Vec<String> = spec.pose_counts.iter().map(|n| n.to_string()).collect();
    let priced = spec.sensors.iter().all(|s| s.price.is_some());
    let question = vec![
        ("target".to_string(), target),
        (
            "machines".to_string(),
            format!(
                "{} random machines per combination (the same machines for every combination): each {} off by up to ±{} mm, each {} by up to ±{}°",
                spec.trials, w.length_errors[0], spec.length_bound_mm, w.angle_errors[0], spec.zero_bound_deg
            ),
        ),
        (
            "calibration".to_string(),
            format!(
                "the first {} of the config's {} poses, the encoders read as {} say ({} sample{} a pose); estimators: {}",
                counts.join(", "),
                cfg.poses().len(),
                if priced { "their datasheets".to_string() } else { format!("their grades and {}", cfg.reading_sigma().1) },
                spec.samples,
                if spec.samples == 1 { "" } else { "s" },
                spec.estimators.iter().map(|e| e.name()).collect::<Vec<_>>().join(", ")
            ),
        ),
        (
            "workspace".to_string(),
            if m.judged().contains(&crate::mechanism::ORIENTATION) {
                format!(
                    "{} {}, the tool point at ({}, {}, {}) mm in the platform frame",
                    spec.workspace.len(),
                    w.workspace,
                    spec.tool_mm.x,
                    spec.tool_mm.y,
                    spec.tool_mm.z
                )
            } else {
                format!("{} {}", spec.workspace.len(), w.workspace)
            },
        ),
        ("convention".to_string(), m.convention().to_string()),
    ];
    let encoders = spec
        .sensors
        .iter()
        .map(|s| SensorLine {
            name: s.name.clone(),
            price: s.price,
            unit: "″",
            axis: Some(s.axis),
            sigma: None,
        })
        .collect();
    let mut table = Table {
        caption: "Every combination (summary.csv)".into(),
        header: [
            "encoders",
            "per joint",
            "price",
            "poses",
            "estimator",
            "before: median (mm)",
            "after: median (mm)",
            "after: p95 (mm)",
            "after: p95 upper 95 % (mm)",
            "orientation p95 (″)",
            "orientation p95 upper 95 % (″)",
            "meets",
        ]
        .iter()
        .map(|h| h.to_string())
        .collect(),
        rows: rows
            .iter()
            .zip(fragile_rows(rows))
            .map(|(r, fragile)| {
                vec![
                    format!(
                        "{} × {}",
                        m.fitted(r.c.variant),
                        spec.sensors[r.c.sensor].name
                    ),
                    m.variant_words(r.c.variant)[1].into(),
                    r.price.map_or(String::new(), |p| format!("{p:.0}")),
                    r.c.poses.to_string(),
                    r.c.estimator.name().into(),
                    f4(Some(r.position_before_median)),
                    f4(Some(r.position_median)),
                    f4(Some(r.position_p95)),
                    f4(r.position_p95_upper),
                    f2(Some(r.orientation_p95)),
                    f2(r.orientation_p95_upper),
                    r.meets.map_or(String::new(), |m| match (m, fragile) {
                        (true, true) => "yes, fragile".into(),
                        (true, false) => "yes".into(),
                        // Worse than not calibrating: not feasible whatever
                        // the target.
                        (false, _) if crate::export::study_verdict::harms(r) => "no, harms".into(),
                        (false, _) => "no".into(),
                    }),
                ]
            })
            .collect(),
    };
    // Judged by position alone: no orientation columns.
    if m.judged().len() < 2 {
        while let Some(at) = table
            .header
            .iter()
            .position(|h| h.starts_with("orientation"))
        {
            table.header.remove(at);
            for row in &mut table.rows {
                row.remove(at);
            }
        }
    }
    let page = StudyPage {
        title: format!("Which {} to buy for this {}", w.sensor, w.machine),
        answer: answer.to_string(),
        question,
        sensors: vec![(w.sensors_heading.into(), encoders)],
        figures: svg
            .map(|s| {
                vec![(
                    "Price against accuracy: every combination, filled where it meets the target (and is not fragile), the choice circled.".to_string(),
                    s,
                )]
            })
            .unwrap_or_default(),
        tables: vec![table],
        assumptions: vec![
            format!("Readings come from exact forward kinematics of each random machine at the nominal commands, read by {}, plus each encoder's datasheet error at its angle: the curve of its grade (of unknown shape unless the catalogue lists it), interpolation, jitter and resolution.", w.reading),
            w.frames.into(),
            estimator_words(spec),
            format!("The verdict holds for {}.", machines_words(m, spec)),
            cfg.limits_words(),
        ],
    };
    let mut page = page;
    page.assumptions.push(if priced {
        "Prices are the catalogue's; the shipped catalogue's prices are placeholders for the user's quotes.".into()
    } else {
        format!("Bare grades have no price: among the combinations that meet the target the verdict takes the fewest encoders, then the fewest poses, then the coarsest grade. Each grade's jitter is {} ({}″ a reading), which can outweigh the grade itself.", cfg.reading_sigma().1, spec.sensors.first().map_or(0.0, |s| s.axis.noise * crate::sensors::ARCSEC_PER_RAD))
    });
    HtmlExporter.render(&page)
}

/// `s` with its first letter upper case ("U-joint encoder", "Encoder").
fn capitalised(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map_or(String::new(), |f| f.to_uppercase().chain(c).collect())
}

/// The prior every fit of a study holds, in words (empty without one).
fn prior_words(w: &crate::mechanism::Words, mm: Option<f64>, deg: Option<f64>) -> String {
    let parts: Vec<String> = [
        mm.map(|s| {
            format!(
                "{s} mm on the {} (identification.prior_std_mm)",
                w.length_errors[1]
            )
        }),
        deg.map(|s| {
            format!(
                "{s}° on the {} (identification.prior_std_deg)",
                w.angle_errors[1]
            )
        }),
    ]
    .into_iter()
    .flatten()
    .collect();
    match parts.is_empty() {
        true => String::new(),
        false => format!(
            ", each fit holding a Gaussian prior of σ {} in the convention's frames, weighed on each encoder's datasheet σ of one reading (identify weighs it on sensors.encoder_noise_arcsec: state that σ there for identify to hold it alike)",
            parts.join(" and ")
        ),
    }
}

/// The machines a verdict holds for, in words ("machines whose …"): the
/// bounds their errors were drawn within, and the errors fixed at
/// measured values.
pub fn machines_words<M: Mechanism>(m: &M, spec: &SpecOf<M>) -> String {
    let names = m.error_names();
    let w = m.words();
    let fixed: Vec<&str> = spec.fixed.iter().map(|&(j, _)| names[j].as_str()).collect();
    format!(
        "machines whose {} are each within ±{} mm and {} within ±{}° of nominal (sweep.length_bound_mm, sweep.zero_bound_deg){}{}",
        w.length_errors[1],
        spec.length_bound_mm,
        w.angle_errors[1],
        spec.zero_bound_deg,
        if fixed.is_empty() {
            String::new()
        } else {
            format!(", with {} fixed at measured values (identification.fix)", fixed.join(", "))
        },
        prior_words(&w, spec.prior_std_mm, spec.prior_std_deg)
    )
}
