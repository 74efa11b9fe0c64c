//! Command line: clap arguments → one validated [`Config`] → the command
//! (one file per command in [`commands`]; all console output in
//! [`console`]). The command line overrides the file; overrides are applied
//! to the raw values and validated with them.

pub mod commands;
pub mod console;
mod mechanism;
pub mod sweep_args;
use mechanism::{check_kind, hexapod_kind, load_mechanism, mechanism_of, tricept_kind};

use crate::config::{self, Config, RawConfig};
use crate::error::{Error, Result};
use clap::{Parser, Subcommand, ValueEnum};
use std::path::{Path, PathBuf};

#[derive(Debug, Parser)]
#[command(
    name = "tricept-calib",
    version,
    about = "Self-calibration of a Tricept parallel module from its passive-limb sensors, and Monte-Carlo studies of the sensor grades (Hong 2009)"
)]
pub struct Cli {
    /// Print nothing but warnings and errors (and the JSON of --json).
    #[arg(long, short = 'q', global = true)]
    pub quiet: bool,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum ExportFormat {
    /// LinuxCNC's genhexkins: genhexkins.hal (HAL pins) and joints.ini (homes).
    Linuxcnc,
    /// geometry.json: the calibrated geometry with σ, correlations and checks (either machine).
    Json,
}

#[derive(Debug, Clone, Copy, ValueEnum, PartialEq, Eq)]
pub enum OutputFormat {
    Text,
    Json,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Reproduce the paper's case (configs/paper.toml): calibration, identifiability, Fig. 3, Fig. 4, report.
    #[command(allow_negative_numbers = true)]
    Reproduce {
        /// Output directory.
        #[arg(long, default_value = "results/paper")]
        out: PathBuf,
        /// Config of the case [default: configs/paper.toml, or the built-in copy if that file is absent].
        #[arg(long)]
        config: Option<PathBuf>,
        /// Worker threads [default: all cores]; results do not depend on it.
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Simulate the readings of the machine with the config's [errors] at the config's poses.
    #[command(allow_negative_numbers = true)]
    Simulate {
        /// Config file (TOML; `-` reads stdin).
        #[arg(long)]
        config: PathBuf,
        /// Seed of the sensor noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Exact readings, no sensor noise.
        #[arg(long)]
        noise_free: bool,
        /// Readings CSV to write (`-`: stdout; a device or pipe is written through).
        #[arg(long)]
        out: PathBuf,
    },
    /// Identify the errors from a readings file (real or simulated): the Tricept's 15, or a hexapod's 54.
    #[command(allow_negative_numbers = true)]
    Identify {
        /// Config file (TOML; `-` reads stdin).
        #[arg(long)]
        config: PathBuf,
        /// Readings CSV (Tricept: x_mm,y_mm,z_mm,psi4_deg,theta4_deg,q4_mm, reference pose first; hexapod: x_mm,…,c_deg,phi1_deg,psi1_deg,…; `-` reads stdin).
        #[arg(long)]
        readings: PathBuf,
        /// Output directory (identified.csv, identifiability.json).
        #[arg(long)]
        out: PathBuf,
        /// Externally measured tool positions (CSV; docs/outputs.md) to add to the fit.
        #[arg(long, value_name = "FILE")]
        reference: Option<PathBuf>,
        /// Each reference coordinate's standard uncertainty, mm.
        #[arg(
            long,
            value_name = "MM",
            default_value_t = 0.005,
            allow_negative_numbers = true
        )]
        reference_sigma: f64,
        /// Print the estimates and checks as JSON on stdout (nothing else there).
        #[arg(long)]
        json: bool,
    },
    /// Check an identified model against a fresh log of the machine: the passive limb's readings say where the tool was; pass when every row is within the threshold (exit 3 on fail).
    #[command(allow_negative_numbers = true)]
    Verify {
        /// Config file (TOML; `-` reads stdin).
        #[arg(long)]
        config: PathBuf,
        /// identified.csv from `identify`.
        #[arg(long)]
        identified: PathBuf,
        /// The fresh log: readings CSV in identify's columns.
        #[arg(long)]
        readings: PathBuf,
        /// Largest position error that passes, mm.
        #[arg(long, allow_negative_numbers = true)]
        threshold: f64,
        /// The log was taken with the nominal commands (as a calibration log is), not the compensated ones `compensate --targets` writes.
        #[arg(long)]
        nominal_commands: bool,
        /// Externally measured tool positions (CSV; docs/outputs.md): absolute points.
        #[arg(long, value_name = "FILE")]
        reference: Option<PathBuf>,
        /// Output directory for verify.csv (row by row); none: nothing written.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print the result as JSON on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Rank, singular values, condition number and unidentifiable parameters of the config's pose set.
    #[command(allow_negative_numbers = true)]
    Identifiability {
        /// Config file (TOML; `-` reads stdin).
        #[arg(long)]
        config: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value = "text")]
        format: OutputFormat,
    },
    /// Volumetric maps before/after compensation; with --targets, corrected leg commands.
    #[command(allow_negative_numbers = true)]
    Compensate {
        /// Config file (TOML; `-` reads stdin).
        #[arg(long)]
        config: PathBuf,
        /// identified.csv from `identify`.
        #[arg(long)]
        identified: PathBuf,
        /// Output directory (created if needed; held for the run, so a second run into it is refused).
        #[arg(long)]
        out: PathBuf,
        /// Targets CSV (x_mm,y_mm,z_mm; a hexapod's x_mm,y_mm,z_mm,a_deg,b_deg,c_deg): writes commands.csv.
        #[arg(long)]
        targets: Option<PathBuf>,
        /// Worker threads [default: all cores]; results do not depend on it.
        #[arg(long)]
        threads: Option<usize>,
        /// Apply a fit whose checks (identifiability.json beside identified.csv) rejected it.
        #[arg(long)]
        accept_rejected_fit: bool,
    },
    /// Choose N calibration poses from a workspace grid to maximise an observability index.
    #[command(allow_negative_numbers = true)]
    DesignPoses {
        /// Config file (TOML; `-` reads stdin).
        #[arg(long)]
        config: PathBuf,
        /// Poses in the design, the reference included [default: as many as the config's].
        #[arg(long)]
        count: Option<usize>,
        /// Observability index to maximise.
        #[arg(long, value_parser = ["o1", "o2", "o3", "o4", "o5"], default_value = "o1")]
        index: String,
        /// Trials of the short sweep comparing designed and config poses.
        #[arg(long, default_value_t = 500)]
        trials: u64,
        /// Worker threads [default: all cores]; results do not depend on it.
        #[arg(long)]
        threads: Option<usize>,
        /// The [poses] list to write (TOML; `-`: stdout).
        #[arg(long)]
        out: PathBuf,
    },
    /// The Monte-Carlo study of which sensors to buy: thousands of random machines, each self-calibrated with every combination of encoder and scale — grade lists, or products of a sensor catalogue with prices ([sweep] catalogue, encoders, scales; configs/sensors.toml) — pose counts, estimators (ols, wls, gls) and what-if sensors; optionally judged over the workspace (dV, ISO 9283 AP). Writes summary.csv, decision.csv (every combination ranked by price against the [decision] target), budget.csv, parameters.csv, trials.csv, figures and report.html, and prints the verdict. Resumable (--resume), shardable (--shard, then merge), adaptive (--target-ci). A hexapod config ([mechanism] kind = "hexapod") runs its U-joint encoder study instead: summary.csv, verdict.json, price_accuracy.png/.svg, report.html (--config, --out, --trials, --seed, --threads, --require-target, --json).
    #[command(allow_negative_numbers = true)]
    Sweep {
        /// Study config (TOML; `-` reads stdin) [default: the built-in paper config and its [sweep] section].
        #[arg(long)]
        config: Option<PathBuf>,
        /// Trials (random machines) [default: the config's sweep.trials].
        #[arg(long)]
        trials: Option<u64>,
        /// Seed of the study's random streams [default: the config's sweep.seed].
        #[arg(long)]
        seed: Option<u64>,
        /// Worker threads [default: all cores]; results do not depend on it.
        #[arg(long)]
        threads: Option<usize>,
        /// Output directory (created if needed; held for the run, so a second run into it is refused).
        #[arg(long)]
        out: PathBuf,
        /// Do not write trials.csv.
        #[arg(long)]
        no_trials: bool,
        /// How to store the per-calibration rows: csv (trials.csv) or gz (trials.csv.gz, the same CSV gzip-compressed about 3×, read directly by pandas, polars and DuckDB).
        #[arg(long, value_parser = ["csv", "gz"], default_value = "csv", conflicts_with = "no_trials")]
        trials_format: String,
        /// Run only shard K of N (1-based) and write a partial result for `merge`.
        #[arg(long, value_name = "K/N")]
        shard: Option<String>,
        /// Adaptive stopping: add blocks of trials until every grade's 95 % CI half-width of mean μ is below REL × mean μ.
        #[arg(long, value_name = "REL")]
        target_ci: Option<f64>,
        /// Upper limit of trials for --target-ci [default: the config's sweep.trials].
        #[arg(long)]
        max_trials: Option<u64>,
        /// Continue an interrupted sweep in --out from its last complete block (with --shard: skip a complete shard).
        #[arg(long, conflicts_with = "restart")]
        resume: bool,
        /// Discard an interrupted sweep in --out and start again (without it, a resumable state is never thrown away).
        #[arg(long)]
        restart: bool,
        /// Exit with status 3 (after writing every output) when no combination meets the [decision] target.
        #[arg(long)]
        require_target: bool,
        /// Print the verdict (verdict.json) on stdout (nothing else there).
        #[arg(long)]
        json: bool,
    },
    /// Write a commented template config for a new machine (machine.toml) and an example sensor catalogue (sensors.toml); never over an existing file.
    #[command(allow_negative_numbers = true)]
    Init {
        /// Directory to write them into (created if needed).
        #[arg(long, default_value = ".")]
        out: PathBuf,
    },
    /// Print a shell completion script (bash, zsh, fish, elvish, powershell).
    Completions {
        /// The shell.
        shell: clap_complete::Shell,
    },
    /// Write man pages (tricept-calib.1 and one per command) into a directory.
    #[command(allow_negative_numbers = true)]
    Man {
        /// Directory for the pages (created if needed).
        #[arg(long)]
        out: PathBuf,
    },
    /// Write the identified geometry: a hexapod's for LinuxCNC (`--format linuxcnc`: genhexkins.hal, joints.ini), or either machine's as geometry.json (`--format json`).
    Export {
        /// What to write.
        #[arg(long, value_enum)]
        format: ExportFormat,
        /// Config file (TOML; `-` reads stdin).
        #[arg(long)]
        config: PathBuf,
        /// identified.csv from `identify`.
        #[arg(long)]
        identified: PathBuf,
        /// Output directory (created if needed).
        #[arg(long)]
        out: PathBuf,
        /// Export a fit whose misfit check (identifiability.json beside identified.csv) rejected it.
        #[arg(long)]
        accept_rejected_fit: bool,
    },
    /// Merge shard directories (from `sweep --shard K/N`) into the outputs of one run.
    #[command(allow_negative_numbers = true)]
    Merge {
        /// Shard output directories.
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Output directory (created if needed; held for the run, so a second run into it is refused).
        #[arg(long)]
        out: PathBuf,
    },
}

/// Load a config file (or the built-in paper case), apply `edit` to the raw
/// values, then validate. A hexapod's config is refused in one sentence:
/// this command does not run it yet.
pub fn load_config(path: Option<&Path>, edit: impl FnOnce(&mut RawConfig)) -> Result<Config> {
    let (mut raw, source) = match path {
        Some(p) => {
            let (text, source) = config::load_text(p)?;
            check_kind(&text, &source)?;
            if hexapod_kind(&text) {
                return Err(Error::config(
                    &source,
                    "mechanism.kind = \"hexapod\": this command runs the Tricept only so far; identifiability, simulate, identify, compensate, verify, export and sweep run the hexapod",
                ));
            }
            (config::parse_raw(&text, &source)?, source)
        }
        None => {
            let source = "<built-in configs/paper.toml>".to_string();
            (config::parse_raw(config::PAPER_TOML, &source)?, source)
        }
    };
    edit(&mut raw);
    Config::from_raw(raw, &source)
}

/// Number of worker threads: the flag, or all cores.
pub fn threads(flag: Option<usize>) -> Result<usize> {
    match flag {
        Some(0) => Err(Error::Argument("--threads must be at least 1".into())),
        Some(n) if n > 1024 => Err(Error::Argument(format!(
            "--threads must be at most 1024 (got {n})"
        ))),
        Some(n) => Ok(n),
        None => Ok(std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)),
    }
}

/// Largest `--trials` (as `sweep.trials`).
const MAX_TRIALS_FLAG: u64 = 1_000_000_000;

/// Run a parsed command line; a failed write to stdout is reported too.
pub fn run(cli: Cli) -> Result<()> {
    let result = dispatch(cli);
    let flushed = console::finish();
    result.and(flushed)
}

fn dispatch(cli: Cli) -> Result<()> {
    let json = matches!(
        cli.command,
        Command::Sweep { json: true, .. }
            | Command::Identify { json: true, .. }
            | Command::Verify { json: true, .. }
    );
    console::set_quiet(cli.quiet || json);
    match cli.command {
        Command::Init { out } => commands::init::run(&out),
        Command::Completions { shell } => commands::docs::completions(shell),
        Command::Man { out } => commands::docs::man(&out),
        Command::Reproduce {
            out,
            config,
            threads: t,
        } => {
            let cfg = load_config(commands::reproduce::config_path(config).as_deref(), |_| {})?;
            commands::reproduce::run(&cfg, &out, threads(t)?)
        }
        Command::Simulate {
            config,
            seed,
            noise_free,
            out,
        } => {
            refuse_own_config(&config, &out)?;
            let any = mechanism::Simulate {
                seed,
                noise_free,
                out: &out,
            };
            match load_mechanism(&config)?.on_any(any) {
                Ok(done) => done,
                Err(cfg) => commands::simulate::run(&cfg, seed, noise_free, &out),
            }
        }
        Command::Identify {
            config,
            readings,
            out,
            reference,
            reference_sigma,
            json,
        } => {
            let any = mechanism::Identify {
                readings: &readings,
                out: &out,
                tricept_only: reference.is_some() || json,
            };
            let cfg = match load_mechanism(&config)?.on_any(any) {
                Ok(done) => return done,
                Err(cfg) => cfg,
            };
            let reference = reference.as_deref().map(|p| (p, reference_sigma));
            commands::identify::run(&cfg, &readings, &out, reference, json)
        }
        Command::Verify {
            config,
            identified,
            readings,
            threshold,
            nominal_commands,
            reference,
            out,
            json,
        } => {
            let any = mechanism::Verify {
                identified: &identified,
                readings: &readings,
                threshold_mm: threshold,
                nominal_commands,
                tricept_only: reference.is_some() || out.is_some() || json,
            };
            let cfg = match load_mechanism(&config)?.on_any(any) {
                Ok(done) => return done,
                Err(cfg) => cfg,
            };
            commands::verify::run(
                &cfg,
                &commands::verify::VerifyArgs {
                    identified: &identified,
                    readings: &readings,
                    threshold_mm: threshold,
                    nominal_commands,
                    reference: reference.as_deref(),
                    out: out.as_deref(),
                    json,
                },
            )
        }
        Command::Export {
            format,
            config,
            identified,
            out,
            accept_rejected_fit,
        } => {
            let export = mechanism::Export {
                format,
                identified: &identified,
                out: &out,
                accept_rejected_fit,
            };
            match load_mechanism(&config)?.on_any(export) {
                Ok(done) => done,
                Err(cfg) => match format {
                    ExportFormat::Json => {
                        commands::export::run_json(&cfg, &identified, &out, accept_rejected_fit)
                    }
                    ExportFormat::Linuxcnc => Err(Error::config(
                        &cfg.source,
                        "--format linuxcnc writes a hexapod's genhexkins files, and LinuxCNC has no Tricept kinematics to load: for this Tricept use --format json (geometry.json), or compensate's commands.csv",
                    )),
                },
            }
        }
        Command::Identifiability { config, format } => {
            match load_mechanism(&config)?.on_any(mechanism::Identifiability(format)) {
                Ok(done) => done,
                Err(cfg) => commands::identifiability::run(&cfg, format),
            }
        }
        Command::Compensate {
            config,
            identified,
            out,
            targets,
            threads: t,
            accept_rejected_fit,
        } => {
            let t = threads(t)?;
            let any = mechanism::Compensate {
                identified: &identified,
                out: &out,
                targets: targets.as_deref(),
                accept_rejected_fit,
            };
            let cfg = match load_mechanism(&config)?.on_any(any) {
                Ok(done) => return done,
                Err(cfg) => cfg,
            };
            commands::compensate::run(
                &cfg,
                &identified,
                &out,
                targets.as_deref(),
                t,
                accept_rejected_fit,
            )
        }
        Command::DesignPoses {
            config,
            count,
            index,
            trials,
            threads: t,
            out,
        } => {
            if trials == 0 {
                return Err(Error::Argument("--trials must be at least 1".into()));
            }
            refuse_own_config(&config, &out)?;
            let t = threads(t)?;
            let cfg = load_config(Some(&config), |_| {})?;
            let count = count.unwrap_or(cfg.poses.len());
            commands::design_poses::run(&cfg, count, &index, trials, t, &out)
        }
        Command::Sweep {
            config,
            trials,
            seed,
            threads: t,
            out,
            no_trials,
            trials_format,
            shard,
            target_ci,
            max_trials,
            resume,
            restart,
            require_target,
            json,
        } => {
            if let Some(n) = trials.filter(|n| !(1..=MAX_TRIALS_FLAG).contains(n)) {
                return Err(Error::Argument(format!(
                    "--trials must be between 1 and {MAX_TRIALS_FLAG} (got {n})"
                )));
            }
            // Any mechanism's study, on a config of another kind than the
            // Tricept's.
            let other = match config.as_deref() {
                Some(path) => {
                    let (text, source) = config::load_text(path)?;
                    (!tricept_kind(&text)).then_some((text, source))
                }
                None => None,
            };
            if let Some((text, source)) = other {
                let any = mechanism::Sweep {
                    out: &out,
                    threads: threads(t)?,
                    flags: commands::general::SweepFlags {
                        trials,
                        seed,
                        require_target,
                        json,
                        trials_file: (!no_trials).then(|| {
                            crate::store::TrialsFormat::parse(&trials_format).unwrap_or_default()
                        }),
                        max_trials,
                    },
                    tricept_only: &[
                        ("--shard", shard.is_some()),
                        ("--target-ci", target_ci.is_some()),
                        ("--resume", resume),
                        ("--restart", restart),
                    ],
                };
                if let Ok(done) = mechanism_of(&text, &source)?.on_any(any) {
                    return done;
                }
            }
            let mut args = sweep_args::SweepArgs::from_flags(
                threads(t)?,
                !no_trials,
                shard.as_deref(),
                target_ci,
                max_trials,
                resume,
            )?;
            args.require_target = require_target;
            args.json = json;
            args.restart = restart;
            args.trials_from_flag = trials.is_some();
            args.trials_format =
                crate::store::TrialsFormat::parse(&trials_format).unwrap_or_default();
            let cfg = load_config(config.as_deref(), |raw| {
                if let Some(n) = trials {
                    raw.sweep.trials = n;
                }
                if let Some(s) = seed {
                    raw.sweep.seed = s;
                }
            })?;
            commands::sweep::run(&cfg, &out, &args)
        }
        Command::Merge { dirs, out } => commands::merge::run(&dirs, &out),
    }
}

/// `--out` naming the `--config` file itself (the same file by another
/// path or link included) would replace the config with the output.
fn refuse_own_config(config: &Path, out: &Path) -> Result<()> {
    if crate::io::same_file(config, out) {
        return Err(Error::Argument(format!(
            "--out {} is the --config file itself: writing there would replace the config; give another path",
            out.display()
        )));
    }
    Ok(())
}
