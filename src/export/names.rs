//! Every output file name, in one place.

pub const READINGS_CSV: &str = "readings.csv";
pub const IDENTIFIED_CSV: &str = "identified.csv";
pub const IDENTIFIABILITY_JSON: &str = "identifiability.json";
pub const VOLUMETRIC_CSV: &str = "volumetric.csv";
pub const VOLUMETRIC_SUMMARY_CSV: &str = "volumetric_summary.csv";
pub const FIG3_PNG: &str = "fig3.png";
pub const COMMANDS_CSV: &str = "commands.csv";
pub const FIG4_CSV: &str = "fig4.csv";
pub const FIG4_PNG: &str = "fig4.png";
pub const FIG4_SVG: &str = "fig4.svg";
pub const METHODS_CSV: &str = "methods.csv";
pub const REPORT_MD: &str = "report.md";
pub const TRIALS_CSV: &str = "trials.csv";
pub const SUMMARY_CSV: &str = "summary.csv";
pub const PARAMETERS_CSV: &str = "parameters.csv";
pub const PARAMETERS_PNG: &str = "parameters.png";
pub const DECISION_CSV: &str = "decision.csv";
pub const GRADE_MAP_PNG: &str = "grade_map.png";
pub const GRADE_MAP_SVG: &str = "grade_map.svg";
pub const MANIFEST_JSON: &str = "manifest.json";
pub const PARTIAL_BIN: &str = "partial.bin";
pub const PARTIAL_JSON: &str = "partial.json";
/// The folder of an unsharded sweep's block log.
pub const SWEEP_STATE_DIR: &str = ".sweep-state";
