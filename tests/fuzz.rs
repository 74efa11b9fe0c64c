//! Fuzzing of every input the tool reads: config TOML, the three CSV inputs
//! and the command line. Inputs are valid files mutated at random (byte
//! flips, hostile tokens, deleted and duplicated spans, truncation) plus
//! random text; each must give `Ok` or a library error — never a panic — and
//! a config that validates is run through poses, identification and a sweep
//! trial. Time-bounded: `FUZZ_SECONDS` per target (default 2 in `cargo test`);
//! the long runs are
//!   FUZZ_SECONDS=600 cargo test --release --test fuzz -- --nocapture --test-threads 3
//! A failing input is printed (escaped) so it can be turned into a test.

use clap::Parser;
use rand::rngs::Xoshiro256PlusPlus;
use rand::{RngExt, SeedableRng};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::{Duration, Instant};
use tricept_calib::cli::Cli;
use tricept_calib::config::{parse_raw, Config};
use tricept_calib::identify::tricept::simulate_readings;
use tricept_calib::identify::tricept::{design_matrix, LinearSolver};
use tricept_calib::mechanism::tricept::NominalPoses;
use tricept_calib::montecarlo::{run_trial, Outcome, Scratch, SweepContext};
use tricept_calib::sensors::observation_vector;

const TOKENS: &[&str] = &[
    "NaN",
    "nan",
    "inf",
    "-inf",
    "-1e308",
    "1e400",
    "1e-320",
    "0",
    "-0",
    "-1",
    "99999999999",
    "\"",
    "'",
    "=",
    "[",
    "]",
    "[[",
    "]]",
    "{",
    "}",
    ",",
    "\n",
    "\r\n",
    "#",
    "\0",
    "é",
    "µ",
    "\u{feff}",
    " ",
    "\t",
    "true",
    "false",
    "[sweep]",
    "[errors]",
    "[poses]",
    "list = []",
    "list = [[0,0,1e9]]",
    "trials = 0",
    "layers = 0",
    "dzB1 = 1",
    "dxB1 = 1e9",
    "a = -1",
    "encoder_arcsec = []",
    "scale_um = [0]",
    "method = \"x\"",
    "samples = 0",
    "grid_step = 1e-9",
    "max_tilt_deg = 89.99",
    "platform_angles_deg = [0,0,0]",
    "base_angles_deg = [-90, 90, 0]",
    "ring_fractions = [1e-300]",
    "points_per_ring = 0",
    "volumetric = true",
    "volumetric_grid_step = 0.001",
    "iterations = 100",
    "x_mm",
    "q4_mm",
    "identifiable",
    "dyA3",
];

fn seconds() -> u64 {
    std::env::var("FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2)
}

fn mutate(rng: &mut Xoshiro256PlusPlus, seed: &[u8]) -> Vec<u8> {
    if rng.random_range(0..10) == 0 {
        let n = rng.random_range(0..200);
        return (0..n).map(|_| rng.random_range(0..=255u8)).collect();
    }
    let mut v = seed.to_vec();
    for _ in 0..rng.random_range(1..5) {
        let len = v.len().max(1);
        match rng.random_range(0..7) {
            0 if !v.is_empty() => {
                let i = rng.random_range(0..v.len());
                v[i] = rng.random_range(0..=255u8);
            }
            1 => {
                let i = rng.random_range(0..=v.len());
                let t = TOKENS[rng.random_range(0..TOKENS.len())].as_bytes();
                v.splice(i..i, t.iter().cloned());
            }
            2 if !v.is_empty() => {
                let i = rng.random_range(0..v.len());
                let j = (i + rng.random_range(0..40)).min(v.len());
                v.drain(i..j);
            }
            3 if !v.is_empty() => {
                let i = rng.random_range(0..v.len());
                let j = (i + rng.random_range(0..80)).min(v.len());
                let dup: Vec<u8> = v[i..j].to_vec();
                v.splice(j..j, dup);
            }
            4 => {
                // Replace a number with a hostile token.
                let text = String::from_utf8_lossy(&v).into_owned();
                let starts: Vec<usize> = text
                    .char_indices()
                    .filter(|(_, c)| c.is_ascii_digit())
                    .map(|(i, _)| i)
                    .collect();
                if let Some(&i) = starts.get(rng.random_range(0..starts.len().max(1))) {
                    let j = text[i..]
                        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == 'e' || c == '-'))
                        .map_or(text.len(), |k| i + k);
                    let t = TOKENS[rng.random_range(0..12)];
                    v = format!("{}{}{}", &text[..i], t, &text[j..]).into_bytes();
                }
            }
            5 => v.truncate(rng.random_range(0..len)),
            _ => {
                let i = rng.random_range(0..=v.len());
                let n = rng.random_range(1..8);
                let junk: Vec<u8> = (0..n).map(|_| rng.random_range(32..127u8)).collect();
                v.splice(i..i, junk);
            }
        }
    }
    v
}

/// Run `f` on inputs for the time budget; panics are collected and reported.
fn fuzz(name: &str, seeds: &[&[u8]], mut f: impl FnMut(&[u8])) {
    let budget = Duration::from_secs(seconds());
    let started = Instant::now();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(name.len() as u64 * 7919 + seconds());
    let mut execs = 0u64;
    let prev = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut failures = Vec::new();
    while started.elapsed() < budget {
        let seed = seeds[rng.random_range(0..seeds.len())];
        let input = mutate(&mut rng, seed);
        if catch_unwind(AssertUnwindSafe(|| f(&input))).is_err() {
            failures.push(String::from_utf8_lossy(&input).escape_debug().to_string());
            if failures.len() >= 5 {
                break;
            }
        }
        execs += 1;
    }
    std::panic::set_hook(prev);
    println!(
        "fuzz {name}: {execs} inputs in {:.1} s ({:.0}/s), {} panics",
        started.elapsed().as_secs_f64(),
        execs as f64 / started.elapsed().as_secs_f64(),
        failures.len()
    );
    assert!(
        failures.is_empty(),
        "fuzz {name}: panics on inputs:\n{}",
        failures.join("\n---\n")
    );
}

/// Push a validated config through the model, identification and one sweep trial.
fn exercise(cfg: &Config) {
    if cfg.poses.len() > 300 {
        return;
    }
    let nominal = cfg.nominal();
    let Ok(poses) = NominalPoses::new(&nominal, &cfg.poses) else {
        return;
    };
    let Ok(h) = design_matrix(&nominal, &poses) else {
        return;
    };
    let Ok(w) = cfg
        .identification
        .method
        .weighting(&cfg.sensors, &poses.joints)
    else {
        return;
    };
    let solver = LinearSolver::new(&h, &w, cfg.identification.rank_tolerance);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    let truth = cfg.truth("fuzz").unwrap_or_else(|_| cfg.nominal());
    if let Ok(r) = simulate_readings(&poses, &truth, Some(&cfg.sensors), &mut rng) {
        let joints: Vec<_> = r.iter().map(|x| x.joints.as_vector()).collect();
        let est = solver.estimate(&observation_vector(&poses.joints, &joints));
        assert!(
            est.values.iter().all(|v| v.is_finite()),
            "non-finite estimate"
        );
    }
    if cfg.sweep.volumetric_step_mm.is_none()
        && cfg.sweep.encoder_arcsec.len() * cfg.sweep.scale_um.len() <= 64
    {
        let ctx = cfg
            .study()
            .build()
            .and_then(|study| SweepContext::new(cfg, &study));
        if let Ok(ctx) = ctx {
            let mut s = Scratch::new(&ctx);
            let mut out = vec![Outcome::default(); ctx.grades().len()];
            run_trial(&ctx, 0, &mut s, &mut out);
        }
    }
}

fn seeds_config() -> Vec<&'static [u8]> {
    vec![
        include_bytes!("../configs/paper.toml"),
        include_bytes!("../configs/encoder-sweep.toml"),
        include_bytes!("../configs/second-class.toml"),
        include_bytes!("../configs/full-rank.toml"),
        include_bytes!("../configs/designed-poses.toml"),
        b"[poses]\nlist = [[0.0, 0.0, 650.0], [200.0, 0.0, 700.0], [0.0, 200.0, 800.0]]\n[identification]\nmethod = \"wls\"\niterations = 3\n",
    ]
}

#[test]
fn fuzz_config_reader() {
    fuzz("config", &seeds_config(), |input| {
        let text = String::from_utf8_lossy(input);
        if let Ok(raw) = parse_raw(&text, "fuzz.toml") {
            if let Ok(cfg) = Config::from_raw(raw, "fuzz.toml") {
                exercise(&cfg);
            }
        }
    });
}

#[test]
fn fuzz_csv_readers() {
    let cfg = tricept_calib::config::Config::paper().unwrap();
    let seeds: Vec<&[u8]> = vec![
        include_bytes!("../results/paper/readings.csv"),
        include_bytes!("../results/paper/identified.csv"),
        b"x_mm,y_mm,z_mm\n0,0,750\n100.5,-200,700\n",
        b"parameter,estimate_mm,std_uncertainty_mm,identifiable\ndxB1,0.1,0,true\n",
    ];
    fuzz("csv", &seeds, |input| {
        if let Ok((r, lines)) = tricept_calib::store::inputs::parse_readings::<
            tricept_calib::mechanism::tricept::Reading,
            3,
        >("fuzz.csv", input)
        {
            let _ = tricept_calib::calibration::identify_from(
                &cfg,
                &r,
                tricept_calib::io::Source::new("fuzz.csv", &lines),
            );
        }
        if let Ok(id) = tricept_calib::store::inputs::parse_identified(
            "fuzz.csv",
            input,
            50.0,
            &tricept_calib::mechanism::tricept::second_class::UNKNOWNS,
        ) {
            let m = id.machine(&cfg.homed());
            let _ = m.commands(&nalgebra::Vector3::new(0.0, 0.0, 750.0));
        }
        let _ = tricept_calib::store::inputs::parse_targets("fuzz.csv", input);
    });
}

#[test]
fn fuzz_command_line() {
    let words: &[&str] = &[
        "reproduce",
        "simulate",
        "identify",
        "identifiability",
        "compensate",
        "sweep",
        "merge",
        "design-poses",
        "--config",
        "--out",
        "--seed",
        "--trials",
        "--threads",
        "--noise-free",
        "--readings",
        "--identified",
        "--targets",
        "--format",
        "json",
        "text",
        "--shard",
        "1/4",
        "0/0",
        "5/4",
        "x/y",
        "--target-ci",
        "0.01",
        "-1",
        "nan",
        "--max-trials",
        "--resume",
        "--no-trials",
        "--count",
        "--index",
        "o1",
        "o9",
        "--help",
        "-h",
        "--version",
        "18446744073709551616",
        "",
        "é",
        "=",
    ];
    let seed: Vec<u8> = b"sweep --trials 10 --threads 2 --out x".to_vec();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    fuzz("cli", &[&seed], |input| {
        // Build an argument vector from the input's bytes and the vocabulary.
        let mut args = vec!["tricept-calib".to_string()];
        for chunk in input.chunks(3) {
            let k = chunk.iter().map(|b| *b as usize).sum::<usize>();
            if k % 5 == 0 {
                args.push(String::from_utf8_lossy(chunk).into_owned());
            } else {
                args.push(words[k % words.len()].to_string());
            }
        }
        let _ = rng.random_range(0..2);
        match Cli::try_parse_from(&args) {
            Ok(cli) => {
                // Argument-level validation of the second stage must not panic either.
                if let tricept_calib::cli::Command::Sweep { shard, threads, .. } = &cli.command {
                    let _ = shard
                        .as_deref()
                        .map(tricept_calib::cli::sweep_args::parse_shard);
                    let _ = tricept_calib::cli::threads(*threads);
                }
            }
            Err(e) => {
                let code = e.exit_code();
                let help = matches!(
                    e.kind(),
                    clap::error::ErrorKind::DisplayHelp
                        | clap::error::ErrorKind::DisplayVersion
                        | clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
                );
                assert!(code == 2 || (help && code == 0), "{args:?}: exit {code}");
                assert!(!e.to_string().is_empty());
            }
        }
    });
}

/// Run the command line in this process (panics surface to the fuzzer).
fn run_cli(args: &[&str]) {
    use clap::Parser;
    if let Ok(cli) =
        Cli::try_parse_from(std::iter::once("tricept-calib").chain(args.iter().copied()))
    {
        let _ = tricept_calib::cli::run(cli);
    }
}

/// Files of a real two-shard study and of an interrupted unsharded sweep,
/// to mutate.
struct MergeSeeds {
    dir: tempfile::TempDir,
    config: std::path::PathBuf,
}

fn merge_seeds() -> MergeSeeds {
    let dir = tempfile::TempDir::new().unwrap();
    let config = dir.path().join("s.toml");
    std::fs::write(
        &config,
        "[sweep]\nencoder_arcsec = [2.0]\ntrials = 9000\nseed = 5\n",
    )
    .unwrap();
    for k in 1..=2 {
        let out = dir.path().join(format!("s{k}"));
        run_cli(&[
            "sweep",
            "--shard",
            &format!("{k}/2"),
            "--config",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(out.join("partial.json").exists());
    }
    MergeSeeds { dir, config }
}

#[test]
fn fuzz_merge_inputs() {
    let s = merge_seeds();
    let shard2 = s.dir.path().join("s2");
    let seeds_json = std::fs::read(shard2.join("partial.json")).unwrap();
    let seeds_bin = std::fs::read(shard2.join("partial.bin")).unwrap();
    let seeds_csv = std::fs::read(shard2.join("trials.csv")).unwrap();
    let work = s.dir.path().join("w");
    let out = s.dir.path().join("merged");
    let mut which = 0usize;
    let seeds: [&[u8]; 3] = [&seeds_json, &seeds_bin, &seeds_csv];
    fuzz("merge", &seeds, |input| {
        // Put the mutated file in place of one of shard 2's files.
        which = (which + 1) % 3;
        let _ = std::fs::remove_dir_all(&work);
        std::fs::create_dir_all(&work).unwrap();
        for (name, bytes) in [
            ("partial.json", &seeds_json),
            ("partial.bin", &seeds_bin),
            ("trials.csv", &seeds_csv),
        ] {
            std::fs::write(work.join(name), bytes).unwrap();
        }
        let name = ["partial.json", "partial.bin", "trials.csv"][which];
        std::fs::write(work.join(name), input).unwrap();
        let _ = std::fs::remove_dir_all(&out);
        run_cli(&[
            "merge",
            s.dir.path().join("s1").to_str().unwrap(),
            work.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
    });
}

#[test]
fn fuzz_resume_state() {
    let s = merge_seeds();
    // An interrupted sweep's state: a finished run's block log and trials,
    // put back as if the run had been killed before renaming them.
    let cfg = s.config.to_str().unwrap().to_string();
    let base = s.dir.path().join("base");
    let state = base.join(".sweep-state");
    // Produce a block log by a run that keeps its state: copy it mid-way is
    // not possible in-process, so build it from a complete run's records.
    run_cli(&["sweep", "--config", &cfg, "--out", base.to_str().unwrap()]);
    let trials = std::fs::read(base.join("trials.csv")).unwrap();
    let bin = std::fs::read(s.dir.path().join("s1/partial.bin")).unwrap();
    let part = tricept_calib::store::partial::decode(&bin).unwrap();
    let header_len = tricept_calib::store::TRIALS_HEADER.len();
    let rows_first_block = trials[header_len..]
        .split(|&b| b == b'\n')
        .take(8192)
        .map(|l| l.len() + 1)
        .sum::<usize>();
    let tb = (header_len + rows_first_block) as u64;
    let th = tricept_calib::digest::fnv1a(tricept_calib::digest::FNV_START, &trials[..tb as usize]);
    let log = tricept_calib::store::checkpoint::record(tb, th, &part);
    let config = tricept_calib::cli::load_config(Some(&s.config), |_| {}).unwrap();
    let args = tricept_calib::cli::sweep_args::SweepArgs {
        threads: 2,
        write_trials: true,
        ..Default::default()
    };
    let state_json = tricept_calib::store::state::state_json(&config, &args.mode()).unwrap();
    let _ = std::fs::remove_dir_all(&state);
    let seeds: [&[u8]; 2] = [&log, &trials[..tb as usize]];
    let mut which = 0usize;
    fuzz("resume", &seeds, |input| {
        which = (which + 1) % 2;
        let dir = s.dir.path().join("r");
        let _ = std::fs::remove_dir_all(&dir);
        let st = dir.join(".sweep-state");
        std::fs::create_dir_all(&st).unwrap();
        let (log_bytes, part_bytes) = if which == 0 {
            (input, &trials[..tb as usize])
        } else {
            (&log[..], input)
        };
        std::fs::write(st.join("blocks.bin"), log_bytes).unwrap();
        std::fs::write(st.join("trials.csv.part"), part_bytes).unwrap();
        // state.json exactly as the run writes it, so the log is read.
        std::fs::write(st.join("state.json"), &state_json).unwrap();
        run_cli(&[
            "sweep",
            "--resume",
            "--config",
            &cfg,
            "--out",
            dir.to_str().unwrap(),
        ]);
    });
}
