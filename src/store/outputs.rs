//! The outputs of a study — a sweep or a merge (a finished study) and a
//! shard (a partial one) — as one set: what they replace in `--out`, in
//! which order they are renamed into place, and the list the manifest
//! gives.

use super::names::*;
use super::partial;
use super::state::ShardInfo;
use super::trials_file::TrialsFile;
use crate::error::{Error, Result};
use crate::io::Outputs;
use crate::montecarlo::Partial;
use std::path::{Path, PathBuf};

/// What the manifest of every finished study lists after its trials file.
const STUDY_FILES: [&str; 13] = [
    VERDICT_JSON,
    SUMMARY_CSV,
    PARAMETERS_CSV,
    PARAMETERS_PNG,
    PARAMETERS_SVG,
    DECISION_CSV,
    BUDGET_CSV,
    BUDGET_PNG,
    BUDGET_SVG,
    FIG4_PNG,
    FIG4_SVG,
    REPORT_HTML,
    MANIFEST_JSON,
];

/// The figures a study has only when its config asks for them, listed
/// after [`STUDY_FILES`] in this order when written.
const STUDY_OPTIONAL: [&[&str]; 4] = [
    &[DECISION_BUDGET_CSV],
    &[PRICE_PNG, PRICE_SVG],
    &[WORKSPACE_PNG, WORKSPACE_SVG],
    &[GRADE_MAP_PNG, GRADE_MAP_SVG],
];

/// An outputs set that replaces whatever a sweep, merge or shard left in
/// `out`, with the finished trials file (if any) renamed first.
fn study_set(out: &Path, trials: Option<&TrialsFile>) -> Outputs {
    let mut outputs = Outputs::default();
    outputs.replace_all(out, &SWEEP_FILES);
    outputs.replace_all(out, &TRIALS_FILES);
    if let Some(t) = trials {
        t.commit_with(&mut outputs);
    }
    outputs
}

/// The files of a finished study, rendered one by one, written as a unit
/// with its manifest last.
pub struct StudyOutputs {
    outputs: Outputs,
    out: PathBuf,
    trials: Option<&'static str>,
    added: Vec<&'static str>,
}

impl StudyOutputs {
    /// Into `out`; `trials`: the finished trials file, renamed with them.
    pub fn new(out: &Path, trials: Option<&TrialsFile>) -> Self {
        StudyOutputs {
            outputs: study_set(out, trials),
            out: out.to_path_buf(),
            trials: trials.map(TrialsFile::file_name),
            added: Vec::new(),
        }
    }

    pub fn add(&mut self, name: &'static str, bytes: Vec<u8>) {
        self.outputs.add(self.out.join(name), bytes);
        self.added.push(name);
    }

    /// The files the manifest lists, in its order: the trials file, the
    /// files of every study, then the optional figures written.
    pub fn listed(&self) -> Vec<&'static str> {
        let optional = STUDY_OPTIONAL
            .iter()
            .filter(|group| self.added.contains(&group[0]))
            .flat_map(|group| group.iter());
        self.trials
            .into_iter()
            .chain(STUDY_FILES)
            .chain(optional.copied())
            .collect()
    }

    /// Write everything, `manifest` (manifest.json) last.
    pub fn write(mut self, manifest: Vec<u8>) -> Result<()> {
        self.add(MANIFEST_JSON, manifest);
        self.outputs.write()?;
        Ok(())
    }
}

/// Write a shard's outputs: its trials file, `partial.bin`, and
/// `partial.json` last, whose presence marks a complete shard.
pub fn write_shard(
    out: &Path,
    trials: Option<&TrialsFile>,
    partial: &Partial,
    info: &ShardInfo,
) -> Result<()> {
    let meta = serde_json::to_vec_pretty(info).map_err(|e| Error::Internal(e.to_string()))?;
    let mut outputs = study_set(out, trials);
    outputs.add(out.join(PARTIAL_BIN), partial::encode(partial));
    // The old partial.json goes first, the new one last.
    let _ = std::fs::remove_file(out.join(PARTIAL_JSON));
    outputs.add(out.join(PARTIAL_JSON), meta);
    outputs.write()?;
    Ok(())
}
