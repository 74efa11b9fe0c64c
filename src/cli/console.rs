//! All console output of the commands, in one place: tables on stdout,
//! warnings and notes on stderr. A failed write to stdout (a full device)
//! never panics: the first failure is kept and [`finish`] reports it, so the
//! command ends with exit 1 and a message.

/// The first failed write to stdout.
static STDOUT_ERROR: Mutex<Option<std::io::Error>> = Mutex::new(None);

/// `--quiet` (or `--json`, whose stdout is the JSON alone): no tables,
/// progress or notes; warnings and errors still go to stderr.
static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Silence everything but warnings and errors.
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, std::sync::atomic::Ordering::Relaxed);
}

fn quiet() -> bool {
    QUIET.load(std::sync::atomic::Ordering::Relaxed)
}

/// A JSON document on stdout, printed whatever `--quiet` says.
pub fn json<T: serde::Serialize>(value: &T) -> crate::error::Result<()> {
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| crate::error::Error::Internal(e.to_string()))?;
    write_out(format_args!("{text}"), true);
    Ok(())
}

fn emit(args: std::fmt::Arguments, newline: bool) {
    if quiet() {
        return;
    }
    write_out(args, newline);
}

fn write_out(args: std::fmt::Arguments, newline: bool) {
    let mut out = std::io::stdout().lock();
    let r = out.write_fmt(args).and_then(|_| {
        if newline {
            out.write_all(b"\n")
        } else {
            Ok(())
        }
    });
    if let Err(e) = r {
        if let Ok(mut slot) = STDOUT_ERROR.lock() {
            slot.get_or_insert(e);
        }
    }
}

macro_rules! println {
    () => { emit(format_args!(""), true) };
    ($($arg:tt)*) => { emit(format_args!($($arg)*), true) };
}

macro_rules! print {
    ($($arg:tt)*) => { emit(format_args!($($arg)*), false) };
}

macro_rules! eprintln {
    ($($arg:tt)*) => {{
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

/// Flush stdout and report the first write that failed.
pub fn finish() -> Result<()> {
    if let Err(e) = std::io::stdout().lock().flush() {
        if let Ok(mut slot) = STDOUT_ERROR.lock() {
            slot.get_or_insert(e);
        }
    }
    match STDOUT_ERROR.lock().ok().and_then(|mut s| s.take()) {
        Some(e) => Err(Error::io("write", "<stdout>", e)),
        None => Ok(()),
    }
}

use crate::compensate::VolumetricMap;
use crate::error::{Error, Result};
use crate::identify::curves::CurveEstimate;
use crate::identify::{EstimateOf, Identifiability};
use crate::montecarlo::SweepResult;
use crate::store::state::{Adaptive, ResumeNote};
use std::io::Write;
use std::sync::Mutex;

/// An identification's table: one row per error, by `names` (the
/// mechanism's error names, in order), with the true value where known.
pub fn print_estimate<const P: usize>(
    est: &EstimateOf<P>,
    names: &[&str],
    truth: Option<&nalgebra::SVector<f64, P>>,
) {
    println!(
        "{:<9} {:>12} {:>18} {:>12} {:>14}{}",
        "parameter",
        "estimate_mm",
        "std_uncertainty_mm",
        "identifiable",
        "source",
        if truth.is_some() { "      true_mm" } else { "" }
    );
    assert_eq!(names.len(), P, "one name per error");
    for (k, name) in names.iter().enumerate() {
        let std = if est.std_mm[k].is_finite() && est.identifiable[k] {
            format!("{:.6}", est.std_mm[k])
        } else {
            "n/a".to_string()
        };
        print!(
            "{:<9} {:>12.6} {:>18} {:>12} {:>14}",
            name, est.values[k], std, est.identifiable[k], est.source[k]
        );
        if let Some(t) = truth {
            print!(" {:>12.6}", t[k]);
        }
        println!();
    }
}

/// Each datasheet sensor's estimated curve, harmonic by harmonic, and a
/// warning for each that exceeds the datasheet by more than 3 standard
/// deviations.
pub fn print_curves(curves: &[CurveEstimate]) {
    println!(
        "{:<15} {:>8} {:>22} {:>22} {:>10}",
        "sensor", "harmonic", "amplitude ± std", "datasheet amplitude", "unit"
    );
    for c in curves {
        println!(
            "{:<15} {:>8} {:>22} {:>22} {:>10}",
            c.sensor,
            c.harmonic,
            format!("{:.4} ± {:.4}", c.amplitude, c.amplitude_std),
            format!("{:.4}", c.datasheet),
            c.unit
        );
    }
    for c in curves.iter().filter(|c| c.exceeds) {
        eprintln!(
            "warning: the {} curve's harmonic {} is {:.3} ± {:.3} {}, more than 3 standard deviations above the datasheet's {:.3} {}: the datasheet model does not fit this machine's sensor (check its mounting and eccentricity, or describe it with a larger accuracy in [sensors]); GLS weights the readings by the datasheet, so its estimate and uncertainties rest on it",
            c.sensor, c.harmonic, c.amplitude, c.amplitude_std, c.unit, c.datasheet, c.unit
        );
    }
}

pub fn warn_unidentifiable(a: &Identifiability) {
    if !a.unidentifiable.is_empty() {
        eprintln!(
            "warning: rank {} of {}: {} not identifiable from these poses and sensors (estimate set to 0); null directions: {}",
            a.rank,
            a.parameters,
            a.unidentifiable.join(", "),
            a.unidentifiable_combinations.join("; ")
        );
    }
}

pub fn print_summary(result: &SweepResult) {
    let several_counts = result
        .summary
        .iter()
        .any(|r| r.pose_count != result.summary[0].pose_count);
    let shown: Vec<usize> = if result.summary.len() > SUMMARY_ROWS {
        let whatif = match result.truth.len() {
            0 => String::new(),
            n => format!(" and {n} what-if rows (summary.csv)"),
        };
        println!(
            "{} combinations (summary.csv, decision.csv){whatif}; the first 10 by rank:",
            result.summary.len()
        );
        result.ranking.iter().take(10).map(|r| r.row).collect()
    } else {
        (0..result.summary.len()).collect()
    };
    println!(
        "{:>14} {:>8} {:>6} {:>8} {:>9} {:>9} {:>9} {:>9} {:>12} {:>9} {:>12}",
        "encoder_arcsec",
        "scale_um",
        "method",
        "trials",
        "mu_mean",
        "mu_median",
        "mu_p95",
        "mu0_mean",
        "ratio_median",
        "ratio_p95",
        "meets_target"
    );
    for r in shown.iter().map(|&i| &result.summary[i]) {
        if !r.encoder.is_empty() || several_counts {
            println!(
                "{:>14} {} + {}, {} poses{}",
                "",
                if r.encoder.is_empty() {
                    "grades"
                } else {
                    &r.encoder
                },
                if r.scale.is_empty() { "" } else { &r.scale },
                r.pose_count,
                r.price.map_or(String::new(), |p| format!(", price {p:.0}"))
            );
        }
        println!(
            "{:>14} {:>8} {:>6} {:>8} {:>9.5} {:>9.5} {:>9.5} {:>9.5} {:>12.4} {:>9.4} {:>12}",
            r.encoder_arcsec,
            r.scale_um,
            r.method.name(),
            r.trials,
            r.mu_mean,
            r.mu_median,
            r.mu_p95,
            r.mu0_mean,
            r.ratio_median,
            r.ratio_p95,
            r.meets_target
        );
        if let (Some(med), Some(p95), Some(before)) = (
            r.dv.dv_after_max_median,
            r.dv.dv_after_max_p95,
            r.dv.dv_before_max_median,
        ) {
            println!("         dV after compensation, max over the workspace: median {med:.4} mm, p95 {p95:.4} mm (before: median {before:.4} mm)");
            if let (Some(p), Some(ap)) = (r.dv.dv_after_p95_p95, r.dv.ap_after_max_p95) {
                println!("         dV_p95 over the workspace, p95 across machines {p:.4} mm; worst ISO 9283 AP, p95 across machines {ap:.4} mm");
            }
        }
        if let Some(n) = r.dv.dv_failed.filter(|&n| n > 0) {
            println!(
                "         warning: {n} of {} calibrations have no dV (a map point the true machine cannot reach); dV statistics use the others",
                r.trials
            );
        }
        if r.failed > 0 || r.not_converged > 0 {
            println!(
                "         ({} failed, {} not converged)",
                r.failed, r.not_converged
            );
        }
    }
    for d in &result.decisions {
        println!("decision: {}", d.verdict);
    }
    println!("answer: {}", crate::export::verdict::of(result).text);
    if result.threads == 0 {
        println!(
            "merged {} calibrations of {} trials in {:.3} s (none computed here: see the shards' own throughput lines)",
            result.calibrations, result.trials, result.wall_seconds
        );
        return;
    }
    println!(
        "throughput: {} calibrations computed in {:.3} s = {:.0} calibrations/s on {} thread(s){}",
        result.computed,
        result.wall_seconds,
        result.calibrations_per_second(),
        result.threads,
        if result.computed < result.calibrations {
            format!(
                " ({} of the {} calibrations restored from the block log)",
                result.calibrations - result.computed,
                result.calibrations
            )
        } else {
            String::new()
        }
    );
}

/// Print the summary table, the decision and throughput. (Where the
/// linear model's predicted spread misses the simulated one, report.html
/// says so in words; parameters.csv has the numbers.)
pub fn sweep_report(result: &SweepResult) {
    print_summary(result);
}

/// Where a sweep's wall time went, by phase.
pub struct Phases {
    /// Config checks, poses, solvers, workspace map: before the first trial.
    pub setup: f64,
    /// The trials (the parallel part; with trials.csv, its rows too).
    pub trials: f64,
    /// Quantiles, parameters, budget and decision (parallel over
    /// combinations only).
    pub summary: f64,
    /// Figures, CSV, report and manifest, written in one thread.
    pub outputs: f64,
    pub total: f64,
}

/// One line: each phase's seconds and the share of the wall time outside
/// the trials, which more threads do not shorten (Amdahl's serial part).
pub fn phases(p: &Phases) {
    let serial = p.total - p.trials;
    println!(
        "phases: set-up {:.3} s, trials {:.3} s, summary {:.3} s, outputs {:.3} s; outside the trials {:.1} % of {:.3} s",
        p.setup,
        p.trials,
        p.summary,
        p.outputs,
        100.0 * serial / p.total.max(1e-9),
        p.total
    );
}

/// Summary rows printed in full; a larger study prints its first rows by rank.
const SUMMARY_ROWS: usize = 24;

/// dV statistics of a map, before and after compensation.
pub fn print_map(map: &VolumetricMap, plane_z_mm: f64) {
    let (b, a) = (map.before(), map.after());
    println!(
        "dV on z = {} mm ({} points)   max      min      mean (mm)",
        plane_z_mm,
        map.points.len()
    );
    println!(
        "  before compensation      {:.4}   {:.4}   {:.4}",
        b.max_mm, b.min_mm, b.mean_mm
    );
    println!(
        "  after compensation       {:.4}   {:.4}   {:.4}",
        a.max_mm, a.min_mm, a.mean_mm
    );
}

/// Workspace accuracy (docs/method.md §12) and ISO 9283 AP, before and after.
pub fn print_workspace(ws: &VolumetricMap, iso: &VolumetricMap, layers: usize) {
    let p95 = |v: &[f64]| {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        crate::metrics::stats::quantile_sorted(&s, 0.95)
    };
    let (b, a) = (ws.before(), ws.after());
    println!(
        "dV over the workspace ({layers} layers, {} points)   max      p95      mean (mm)",
        ws.points.len()
    );
    println!(
        "  before compensation      {:.4}   {:.4}   {:.4}",
        b.max_mm,
        p95(&ws.before_mm),
        b.mean_mm
    );
    println!(
        "  after compensation       {:.4}   {:.4}   {:.4}",
        a.max_mm,
        p95(&ws.after_mm),
        a.mean_mm
    );
    let worst = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
    println!(
        "ISO 9283 pose accuracy AP at P1–P5 (one approach): worst {:.4} mm before, {:.4} mm after compensation",
        worst(&iso.before_mm),
        worst(&iso.after_mm)
    );
}

/// The correction map of a real machine.
pub fn print_correction(map: &VolumetricMap, plane_z_mm: f64) {
    let c = map.before();
    println!(
        "real machine (no [errors]): the identified model's correction on z = {} mm ({} points): max {:.4}, min {:.4}, mean {:.4} mm",
        plane_z_mm,
        map.points.len(),
        c.max_mm,
        c.min_mm,
        c.mean_mm
    );
}

/// What a command wrote to `out`: a line, or aside (stderr) when `out`
/// is stdout, so the written data stays clean.
pub fn wrote(out: &std::path::Path, message: impl std::fmt::Display) {
    if crate::io::is_stdout(out) {
        note(message);
    } else {
        line(message);
    }
}

/// One line on stdout.
pub fn line(text: impl std::fmt::Display) {
    println!("{text}");
}

/// Text already formatted (ends with its own newline).
pub fn text(text: impl std::fmt::Display) {
    print!("{text}");
}

/// A note or warning on stderr (a note is silent with `--quiet`; a
/// warning never is).
pub fn note(text: impl std::fmt::Display) {
    let text = text.to_string();
    if quiet() && !text.starts_with("warning") {
        return;
    }
    eprintln!("{text}");
}

/// What adaptive stopping achieved, per grade.
pub fn adaptive_report(a: &Adaptive, result: &SweepResult) {
    println!(
        "adaptive: {} trials used of at most {}; target half-width {} × mean {}",
        a.trials_used,
        a.max_trials,
        a.target_rel_half_width,
        if a.target_met {
            "met for every grade"
        } else {
            "NOT met: raise --max-trials"
        }
    );
    for r in &result.summary {
        println!(
            "  {}″ / {} µm / {}: mean μ {:.5} ± {:.5} mm (relative {:.4})",
            r.encoder_arcsec,
            r.scale_um,
            r.method.name(),
            r.mu_mean,
            (r.mu_mean_ci_high - r.mu_mean_ci_low) / 2.0,
            (r.mu_mean_ci_high - r.mu_mean_ci_low) / 2.0 / r.mu_mean
        );
    }
}

/// Progress of a sweep on stderr: a bar as wide as the terminal when stderr
/// is one, else (Slurm logs, pipes) one line every 10 s or so.
pub struct SweepProgress {
    bar: Option<indicatif::ProgressBar>,
    heartbeat: Mutex<Heartbeat>,
    label: String,
}

struct Heartbeat {
    started: std::time::Instant,
    last: std::time::Instant,
    total: u64,
    done: u64,
    at_start: u64,
}

/// Seconds between two heartbeat lines.
const HEARTBEAT_SECONDS: f64 = 10.0;

impl SweepProgress {
    pub fn new(label: &str) -> Self {
        let tty = std::io::IsTerminal::is_terminal(&std::io::stderr()) && !quiet();
        let bar = tty.then(|| {
            let b = indicatif::ProgressBar::new(0);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{wide_bar} {pos}/{len} trials  {rate}  eta {eta}",
                )
                .map(|s| {
                    // A whole number of trials a second (indicatif's own
                    // {per_sec} prints four decimals).
                    s.with_key(
                        "rate",
                        |st: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                            let _ = write!(w, "{:.0} trials/s", st.per_sec());
                        },
                    )
                })
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b
        });
        let now = std::time::Instant::now();
        SweepProgress {
            bar,
            heartbeat: Mutex::new(Heartbeat {
                started: now,
                last: now,
                total: 0,
                done: 0,
                at_start: 0,
            }),
            label: label.to_string(),
        }
    }
}

impl crate::montecarlo::Progress for SweepProgress {
    fn start(&self, total: u64, done: u64) {
        if let Some(b) = &self.bar {
            b.set_length(total);
            b.set_position(done);
        }
        if let Ok(mut h) = self.heartbeat.lock() {
            h.total = total;
            h.done = done;
            h.at_start = done;
        }
    }

    fn advance(&self, trials: u64) {
        if let Some(b) = &self.bar {
            b.inc(trials);
            return;
        }
        let Ok(mut h) = self.heartbeat.lock() else {
            return;
        };
        h.done += trials;
        if !quiet() && h.last.elapsed().as_secs_f64() >= HEARTBEAT_SECONDS {
            h.last = std::time::Instant::now();
            let rate = (h.done - h.at_start) as f64 / h.started.elapsed().as_secs_f64().max(1e-9);
            eprintln!(
                "{}: {}/{} trials ({:.0} %), {:.0} trials/s",
                self.label,
                h.done,
                h.total,
                100.0 * h.done as f64 / h.total.max(1) as f64,
                rate
            );
        }
    }

    fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// What `--resume` found.
pub fn resume_note(found: ResumeNote, out: &std::path::Path, state_dir: &std::path::Path) {
    match found {
        ResumeNote::Resumed { trials, dropped } => {
            line(format_args!(
                "resuming after {trials} completed trials from {}",
                state_dir.display()
            ));
            if dropped > 0 {
                note(format_args!(
                    "note: {dropped} later block(s) of the log did not verify against trials.csv; they are computed again"
                ));
            }
        }
        ResumeNote::StartedAgain => note(format_args!(
            "note: nothing in {} verified (damaged or incomplete state); starting from the beginning",
            state_dir.display()
        )),
        ResumeNote::NothingToResume => line(format_args!(
            "no interrupted sweep in {}; starting from the beginning",
            out.display()
        )),
        ResumeNote::Fresh => {}
    }
}

/// From here on, Ctrl-C (SIGINT) says how to continue the sweep, then ends
/// the process as the signal would (status 130): what the block log holds
/// stays, and `--resume` picks it up. Unix only.
pub fn resume_on_interrupt() {
    #[cfg(unix)]
    {
        extern "C" fn on_sigint(_: libc::c_int) {
            const MSG: &[u8] = b"\ninterrupted: run the same command with --resume to continue from the last complete block (--restart starts again)\n";
            // SAFETY: write(2) and _exit(2) are async-signal-safe; MSG is static.
            unsafe {
                libc::write(2, MSG.as_ptr().cast(), MSG.len());
                libc::_exit(130);
            }
        }
        let handler: extern "C" fn(libc::c_int) = on_sigint;
        // SAFETY: installs a handler that only calls async-signal-safe functions.
        unsafe {
            libc::signal(libc::SIGINT, handler as libc::sighandler_t);
        }
    }
}

/// A file's size in words: "2.8 GB" from 1 GB on, else whole MB.
pub fn size_words(bytes: u64) -> String {
    match bytes >= 1_000_000_000 {
        true => format!("{:.1} GB", bytes as f64 / 1e9),
        false => format!("{} MB", bytes / 1_000_000),
    }
}
