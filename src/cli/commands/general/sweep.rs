//! `sweep` of any mechanism's `[sweep]` study: its rows (summary.csv), its
//! verdict in the buyer's words (verdict.json and the console) and its
//! throughput; the mechanism gives the nouns ([`Mechanism::words`]).

use super::report::{machines_words, page, price_chart};
use crate::cli::console;
use crate::config::general::{MechanismConfig, Sensor, Spec, Study, WhatIf};
use crate::error::{Error, Result};
use crate::export::study_trials::{trials_rows, STUDY_TRIALS_HEADER, STUDY_TRIALS_ROW_BYTES};
use crate::export::study_verdict::{
    choose, harmful_words, passed_over, passed_over_words, row_of, sentence, summary_csv,
    undecided, undecided_lead, verdict_json, Row,
};
use crate::io;
use crate::mechanism::{Commanded, Mechanism};
use crate::montecarlo::general::kernel::{
    check, combinations, run_kernel, run_reporting, KernelFn,
};
use crate::montecarlo::TrialSink;
use crate::store::{names, TrialsFile, TrialsFormat};
use std::path::Path;
use std::time::Instant;

/// The spec of a mechanism's study.
type SpecOf<M> = Spec<<M as Mechanism>::Target, <M as Mechanism>::Variant>;

/// What a sweep writes (stale ones are removed).
const FILES: [&str; 7] = [
    names::SUMMARY_CSV,
    names::VERDICT_JSON,
    names::REPORT_HTML,
    names::PRICE_PNG,
    names::PRICE_SVG,
    names::TRIALS_CSV,
    names::TRIALS_CSV_GZ,
];

/// Machines whose trials.csv rows are formatted and stored at a time (one
/// gzip member in trials.csv.gz, as the Tricept's).
const TRIALS_BLOCK: usize = 256;

/// The chosen combination again, with its encoders reading as each
/// what-if supposes (the same machines and draws; the estimator still
/// weights by the datasheet): its row, or None where the what-if does not
/// apply to that encoder.
#[allow(clippy::type_complexity)]
fn what_ifs<C: MechanismConfig>(
    cfg: &C,
    spec: &SpecOf<C::M>,
    study: &Study<C::M>,
    chosen: &Row<<C::M as Mechanism>::Variant>,
    (threads, sizes): (usize, KernelFn<C::M>),
) -> Result<Vec<(WhatIf, Option<Row<<C::M as Mechanism>::Variant>>)>>
where
    C::M: Commanded,
{
    let sensor = &spec.sensors[chosen.c.sensor];
    let mut out = Vec::new();
    for w in &study.what_ifs {
        let Some(truth) = w.truth(&sensor.axis) else {
            out.push((*w, None));
            continue;
        };
        let sub = Spec {
            sensors: vec![Sensor {
                truth: Some(truth),
                ..sensor.clone()
            }],
            variants: vec![chosen.c.variant],
            pose_counts: vec![chosen.c.poses],
            estimators: vec![chosen.c.estimator],
            ..spec.clone()
        };
        let (combos, judged) = run_kernel(cfg.machine(), cfg.poses(), &sub, threads, sizes)
            .map_err(|why| Error::config(cfg.source(), why))?;
        let c = combos[0];
        out.push((*w, Some(row_of(&judged, 0, &c, chosen.price, study))));
    }
    Ok(out)
}

/// Say, before a long run, when trials.csv will be large (100 MB or more).
fn announce(format: TrialsFormat, trials: u64, combos: usize) {
    let csv = trials * combos as u64 * STUDY_TRIALS_ROW_BYTES;
    // gzip (level 1) stores the rows in about a third.
    let (bytes, hint) = match format {
        TrialsFormat::Csv => (csv, ", --trials-format gz compresses it about 3×"),
        TrialsFormat::Gzip => (csv / 3, ""),
    };
    if bytes >= 100_000_000 {
        console::note(format_args!(
            "note: {} will be about {} (one row per machine and combination: {trials} machines × {combos} combinations); --no-trials leaves it out{hint}",
            format.file_name(),
            console::size_words(bytes)
        ));
    }
}

/// What the flags of `sweep` ask of a study of any mechanism.
#[derive(Debug, Clone, Copy, Default)]
pub struct SweepFlags {
    /// `--trials` and `--seed`, over the config's.
    pub trials: Option<u64>,
    pub seed: Option<u64>,
    /// `--require-target`: exit 3 (after writing every output) when no
    /// combination meets the target.
    pub require_target: bool,
    /// `--json`: verdict.json on stdout, nothing else there.
    pub json: bool,
    /// trials.csv as stored (`--trials-format`), None with `--no-trials`.
    pub trials_file: Option<TrialsFormat>,
    /// `--max-trials`, over the config's `sweep.max_trials`.
    pub max_trials: Option<u64>,
}

/// `sweep`: the config's `[sweep]` study on `threads` threads as `flags`
/// ask, its files in `out`.
pub fn run_sweep<C: MechanismConfig>(
    cfg: &C,
    out: &Path,
    (threads, sizes): (usize, KernelFn<C::M>),
    flags: SweepFlags,
) -> Result<()>
where
    C::M: Commanded,
{
    let SweepFlags {
        trials,
        seed,
        require_target,
        json,
        trials_file,
        max_trials,
    } = flags;
    let m = cfg.machine();
    let Some(study) = cfg.study() else {
        return Err(Error::config(
            cfg.source(),
            format!(
                "has no [sweep] section: a {} study needs one ({})",
                m.name(),
                cfg.study_keys()
            ),
        ));
    };
    if study.orientation_arcsec.is_some() && !m.judged().contains(&crate::mechanism::ORIENTATION) {
        return Err(Error::config(
            cfg.source(),
            format!(
                "decision.orientation_arcsec: the {} is judged by its tool point's position alone (its targets are points); leave it out",
                m.name()
            ),
        ));
    }
    if require_target && study.position_mm.is_none() {
        return Err(Error::config(
            cfg.source(),
            "--require-target asks whether a combination meets the target, and [decision] position_mm states none",
        ));
    }
    let mut spec = study.spec.clone();
    if let Some(n) = trials {
        spec.trials = n;
    }
    if let Some(s) = seed {
        spec.seed = s;
    }
    check(m, cfg.poses(), &spec).map_err(|why| Error::config(cfg.source(), why))?;
    // sweep.until_decided: the most machines the study may grow to
    // (--max-trials over the config's), never fewer than it starts with.
    let until = match (study.until_decided, max_trials) {
        (None, Some(_)) => {
            return Err(Error::config(
                cfg.source(),
                "--max-trials bounds sweep.until_decided, which the config does not set",
            ))
        }
        (None, None) => None,
        (Some(max), flag) => Some(flag.unwrap_or(max).max(spec.trials)),
    };
    let combos = combinations(&spec).len();
    let largest = until.unwrap_or(spec.trials);
    let need = crate::montecarlo::general::result_bytes(combos, largest);
    if need > crate::config::general::MAX_RESULT_BYTES {
        return Err(Error::Argument(format!(
            "{} {largest} × {combos} combinations needs {need} bytes of results, over 1 GiB: fewer trials",
            if until.is_some() { "--max-trials" } else { "--trials" }
        )));
    }
    // The output folder first: a run refused for it says that alone.
    let _lock = io::claim_dir(out)?;
    let fewest = crate::metrics::stats::values_for_upper_limit(0.95, 0.95) as u64;
    if study.position_mm.is_some() && largest < fewest {
        console::note(format_args!(
            "note: a 95th percentile has an upper 95 % confidence limit only from {fewest} machines on: with {}, no combination can meet the target",
            spec.trials
        ));
    }
    if let Some(format) = trials_file {
        announce(format, spec.trials, combos);
    }
    let start = Instant::now();
    let (mut calibrations, mut runs) = (0, 0);
    // Until decided, the study runs again with more machines: each
    // machine is its trial's draws, so the first ones are the same and
    // the last run is the run of that many machines.
    let (combinations, judged, rows, chosen_index, open) = loop {
        let progress = console::SweepProgress::new(&format!("{} study", m.name()));
        let (combinations, judged) =
            run_reporting(m, cfg.poses(), &spec, (threads, &progress), sizes)
                .map_err(|why| Error::config(cfg.source(), why))?;
        calibrations += spec.trials * combos as u64;
        runs += 1;
        let rows: Vec<Row<_>> = combinations
            .iter()
            .enumerate()
            .map(|(ci, c)| {
                let price = spec.sensors[c.sensor]
                    .price
                    .map(|p| p * m.fitted(c.variant) as f64);
                row_of(&judged, ci, c, price, study)
            })
            .collect();
        let chosen_index = choose(m, &spec, &rows);
        let open = undecided(m, (&spec, study), &rows, chosen_index);
        match until {
            Some(max) if !open.is_empty() && spec.trials < max => {
                // What the open ones ask, at least twice as many.
                let asked = open.iter().map(|u| u.machines.unwrap_or(max)).max();
                let next = asked.unwrap_or(max).max(2 * spec.trials).min(max);
                console::note(format_args!(
                    "note: undecided at {} machines; running {next} (sweep.until_decided, at most {max})",
                    spec.trials
                ));
                spec.trials = next;
            }
            _ => break (combinations, judged, rows, chosen_index, open),
        }
    };
    let secs = start.elapsed().as_secs_f64();
    let csv = summary_csv(m, &spec, &rows);
    let chosen = chosen_index.map(|i| &rows[i]);
    let supposed = match chosen {
        Some(r) => what_ifs(cfg, &spec, study, r, (threads, sizes))?,
        None => Vec::new(),
    };
    let holds = machines_words(m, &spec);
    let mut sentence = sentence(m, (&spec, study), (&rows, chosen), &supposed, &holds);
    if let Some(lead) = undecided_lead(m, (&spec, study), (&rows, chosen_index.is_some()), &open) {
        sentence = format!("{lead} {sentence}");
    }
    let passed = passed_over(m, &spec, &rows, chosen_index);
    if let Some(tail) = passed_over_words(m, (&spec, study), &rows, &passed) {
        sentence = format!("{sentence} {tail}");
    }
    if let Some(tail) = harmful_words(study, &rows) {
        sentence = format!("{sentence} {tail}");
    }
    let verdict = verdict_json(
        m,
        (&spec, study),
        chosen,
        &supposed,
        (&rows, &open, &passed),
        &sentence,
    );
    let mut outputs = io::Outputs::default();
    outputs.replace_all(out, &FILES);
    // Kept until the outputs are renamed (dropped, it removes its file).
    let mut streamed = None;
    if let Some(format) = trials_file {
        let file = streamed.insert(TrialsFile::new(out, true, format)?);
        file.write(&format.encode(STUDY_TRIALS_HEADER.into()))?;
        for (k, block) in judged.chunks(TRIALS_BLOCK).enumerate() {
            let first = (k * TRIALS_BLOCK) as u64;
            let rows = trials_rows(m, &spec, &combinations, block, first);
            file.write(&format.encode(rows.into_bytes()))?;
        }
        file.finish()?;
        file.commit_with(&mut outputs);
    }
    outputs.add(out.join(FILES[0]), csv.into_bytes());
    let mut text = serde_json::to_string_pretty(&verdict).unwrap_or_default();
    text.push('\n');
    outputs.add(out.join(FILES[1]), text.into_bytes());
    let figure = price_chart(m, &spec, study, &rows, chosen_index);
    let mut svg = None;
    if let Some(chart) = &figure {
        use crate::export::figures::Format;
        let png = chart.render(Format::Png)?;
        let text = chart.render(Format::Svg)?;
        outputs.add(out.join(names::PRICE_PNG), png);
        outputs.add(out.join(names::PRICE_SVG), text.clone());
        svg = Some(String::from_utf8_lossy(&text).into_owned());
    }
    let page = page(cfg, &spec, study, &rows, &sentence, svg)?;
    outputs.add(out.join(names::REPORT_HTML), page);
    outputs.write()?;
    console::line(format!(
        "{} study: {calibrations} calibrations ({} machines × {combos} combinations{}) in {secs:.2} s on {threads} {}: {:.0} calibrations/s",
        m.name(),
        spec.trials,
        match runs {
            1 => String::new(),
            n => format!(", the last of {n} runs as it grew"),
        },
        if threads == 1 { "thread" } else { "threads" },
        calibrations as f64 / secs.max(1e-9)
    ));
    console::line(format!("verdict: {sentence}"));
    console::line(format!(
        "wrote summary.csv, verdict.json, report.html{}{} to {}",
        trials_file.map_or(String::new(), |f| format!(", {}", f.file_name())),
        if figure.is_some() {
            " and price_accuracy.png/.svg"
        } else {
            ""
        },
        out.display()
    ));
    if json {
        console::json(&verdict)?;
    }
    if require_target && chosen.is_none() {
        return Err(Error::TargetNotMet(
            "no combination meets the target (--require-target); the outputs are written".into(),
        ));
    }
    Ok(())
}
