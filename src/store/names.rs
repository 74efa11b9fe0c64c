//! Every output file name, and the files each command may write, in one
//! place.

pub const READINGS_CSV: &str = "readings.csv";
pub const IDENTIFIED_CSV: &str = "identified.csv";
pub const IDENTIFIABILITY_JSON: &str = "identifiability.json";
pub const VOLUMETRIC_CSV: &str = "volumetric.csv";
pub const VOLUMETRIC_SUMMARY_CSV: &str = "volumetric_summary.csv";
pub const FIG3_PNG: &str = "fig3.png";
pub const FIG3_SVG: &str = "fig3.svg";
pub const COMMANDS_CSV: &str = "commands.csv";
pub const WORKSPACE_ACCURACY_CSV: &str = "workspace_accuracy.csv";
pub const WORKSPACE_LAYERS_PNG: &str = "workspace_layers.png";
pub const WORKSPACE_LAYERS_SVG: &str = "workspace_layers.svg";
pub const ISO9283_CSV: &str = "iso9283.csv";
pub const CORRECTION_CSV: &str = "correction_map.csv";
pub const CORRECTION_PNG: &str = "correction_map.png";
pub const CORRECTION_SVG: &str = "correction_map.svg";
pub const FIG4_CSV: &str = "fig4.csv";
pub const FIG4_PNG: &str = "fig4.png";
pub const FIG4_SVG: &str = "fig4.svg";
pub const METHODS_CSV: &str = "methods.csv";
pub const REPORT_MD: &str = "report.md";
pub const TRIALS_CSV: &str = "trials.csv";
pub const TRIALS_CSV_GZ: &str = "trials.csv.gz";
/// Every form of the trials file: a run removes the one it does not write.
pub const TRIALS_FILES: [&str; 2] = [TRIALS_CSV, TRIALS_CSV_GZ];
pub const SUMMARY_CSV: &str = "summary.csv";
pub const PARAMETERS_CSV: &str = "parameters.csv";
pub const PARAMETERS_PNG: &str = "parameters.png";
pub const PARAMETERS_SVG: &str = "parameters.svg";
pub const DECISION_CSV: &str = "decision.csv";
pub const FIG4_POSES_CSV: &str = "fig4_poses.csv";
pub const FIG4_POSES_PNG: &str = "fig4_poses.png";
pub const FIG4_POSES_SVG: &str = "fig4_poses.svg";
pub const BUDGET_CSV: &str = "budget.csv";
/// The first-ranked combinations' budget in the deciding metric.
pub const DECISION_BUDGET_CSV: &str = "decision_budget.csv";
pub const REPORT_HTML: &str = "report.html";
pub const BUDGET_PNG: &str = "budget.png";
pub const BUDGET_SVG: &str = "budget.svg";
pub const PRICE_PNG: &str = "price_accuracy.png";
pub const PRICE_SVG: &str = "price_accuracy.svg";
pub const GRADE_MAP_PNG: &str = "grade_map.png";
pub const GRADE_MAP_SVG: &str = "grade_map.svg";
pub const WORKSPACE_PNG: &str = "workspace.png";
pub const WORKSPACE_SVG: &str = "workspace.svg";
pub const MANIFEST_JSON: &str = "manifest.json";
/// The verdict for scripts (a study's).
pub const VERDICT_JSON: &str = "verdict.json";
pub const PARTIAL_BIN: &str = "partial.bin";
pub const PARTIAL_JSON: &str = "partial.json";
/// `verify`'s rows: expected against measured position.
pub const VERIFY_CSV: &str = "verify.csv";
/// verify --reference: the externally measured points, row by row.
pub const VERIFY_REFERENCE_CSV: &str = "verify_reference.csv";
/// A datasheet sensor's estimated curve (`identify`).
pub const SENSOR_CURVES_CSV: &str = "sensor_curves.csv";
/// Everything `identify` writes.
pub const IDENTIFY_FILES: [&str; 3] = [IDENTIFIED_CSV, IDENTIFIABILITY_JSON, SENSOR_CURVES_CSV];
/// `export --format linuxcnc`: genhexkins' HAL pins and the joints' homes.
pub const GENHEXKINS_HAL: &str = "genhexkins.hal";
pub const JOINTS_INI: &str = "joints.ini";
/// Everything `export --format linuxcnc` writes.
pub const LINUXCNC_FILES: [&str; 2] = [GENHEXKINS_HAL, JOINTS_INI];
/// `export --format json`: the calibrated geometry for other tools.
pub const GEOMETRY_JSON: &str = "geometry.json";
/// Everything `compensate` writes.
pub const COMPENSATE_FILES: [&str; 12] = [
    WORKSPACE_ACCURACY_CSV,
    WORKSPACE_LAYERS_PNG,
    WORKSPACE_LAYERS_SVG,
    ISO9283_CSV,
    VOLUMETRIC_CSV,
    VOLUMETRIC_SUMMARY_CSV,
    FIG3_PNG,
    FIG3_SVG,
    COMMANDS_CSV,
    CORRECTION_CSV,
    CORRECTION_PNG,
    CORRECTION_SVG,
];
/// Everything `reproduce` writes.
pub const REPRODUCE_FILES: [&str; 16] = [
    FIG4_POSES_CSV,
    FIG4_POSES_PNG,
    FIG4_POSES_SVG,
    READINGS_CSV,
    IDENTIFIED_CSV,
    VOLUMETRIC_CSV,
    VOLUMETRIC_SUMMARY_CSV,
    FIG3_PNG,
    FIG3_SVG,
    FIG4_CSV,
    FIG4_PNG,
    FIG4_SVG,
    METHODS_CSV,
    IDENTIFIABILITY_JSON,
    REPORT_MD,
    COMMANDS_CSV,
];
/// Everything `sweep` and `merge` may write except trials.csv (handled with
/// the run's rows) — a shard's files included, so a directory never mixes a
/// finished study with a partial one.
pub const SWEEP_FILES: [&str; 22] = [
    VERDICT_JSON,
    DECISION_BUDGET_CSV,
    WORKSPACE_PNG,
    WORKSPACE_SVG,
    REPORT_HTML,
    BUDGET_CSV,
    BUDGET_PNG,
    BUDGET_SVG,
    PRICE_PNG,
    PRICE_SVG,
    SUMMARY_CSV,
    PARAMETERS_CSV,
    PARAMETERS_PNG,
    PARAMETERS_SVG,
    DECISION_CSV,
    FIG4_PNG,
    FIG4_SVG,
    GRADE_MAP_PNG,
    GRADE_MAP_SVG,
    MANIFEST_JSON,
    PARTIAL_BIN,
    PARTIAL_JSON,
];

/// The folder of an unsharded sweep's block log.
pub const SWEEP_STATE_DIR: &str = ".sweep-state";
/// In that folder: the study's identity, the block log, the trials file
/// being written, and the marker the tests' pause hook leaves.
pub const STATE_JSON: &str = "state.json";
pub const BLOCKS_BIN: &str = "blocks.bin";
pub const TRIALS_CSV_PART: &str = "trials.csv.part";
pub const PAUSED_MARKER: &str = "paused";
/// What `init` writes: a template config and an example catalogue.
pub const INIT_CONFIG_TOML: &str = "machine.toml";
pub const INIT_CATALOGUE_TOML: &str = "sensors.toml";
