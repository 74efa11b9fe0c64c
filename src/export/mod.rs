//! Exporters: everything a command writes is rendered to bytes first and
//! then written atomically ([`crate::io`]), so a failure never leaves a
//! half-written file. One exporter per format behind [`Exporter`]
//! ([`csv`], [`json`]; figures render PNG or SVG in [`figures`], one file
//! per figure); [`rows`] are the serialisable rows of every table,
//! [`views`] turn study results into chart inputs, [`text`] the console
//! reports, and [`names`] holds every output file name.

pub mod csv;
pub mod figures;
pub mod html;
pub mod json;
pub mod page;
pub mod rows;
pub mod study_trials;
pub mod study_verdict;
pub mod text;
pub mod verdict;
mod verdict_parts;
mod verdict_words;
pub mod views;

pub use self::csv::{csv_bytes, CsvExporter};
pub use self::json::JsonExporter;

use crate::error::Result;
use crate::store::names;

/// One output format of a result: returns the file's bytes.
pub trait Exporter<T: ?Sized> {
    fn render(&self, data: &T) -> Result<Vec<u8>>;
}

/// A figure as PNG and SVG: every figure the tool writes has both.
fn both(
    png: &'static str,
    svg: &'static str,
    draw: impl Fn(figures::Format) -> Result<Vec<u8>>,
) -> Result<[(&'static str, Vec<u8>); 2]> {
    Ok([
        (png, draw(figures::Format::Png)?),
        (svg, draw(figures::Format::Svg)?),
    ])
}

/// The files of a real machine's correction map: `correction_map.csv`,
/// `correction_map.png` and `.svg`.
pub fn correction_files(
    cfg: &crate::config::Config,
    map: &crate::compensate::VolumetricMap,
    vectors: &[nalgebra::Vector3<f64>],
) -> Result<Vec<(&'static str, Vec<u8>)>> {
    let mut files = vec![(names::CORRECTION_CSV, rows::correction_csv(map, vectors)?)];
    files.extend(both(names::CORRECTION_PNG, names::CORRECTION_SVG, |f| {
        figures::correction(&figures::PlaneMap::of(cfg, map), vectors, f)
    })?);
    Ok(files)
}

/// The files of the workspace (docs/method.md §12) and ISO 9283 evaluation:
/// `workspace_accuracy.csv`, `workspace_layers.png` and `.svg`, `iso9283.csv`.
pub fn workspace_files(
    cfg: &crate::config::Config,
    workspace: &crate::compensate::VolumetricMap,
    iso: &crate::compensate::VolumetricMap,
) -> Result<Vec<(&'static str, Vec<u8>)>> {
    let mut files = vec![(
        names::WORKSPACE_ACCURACY_CSV,
        rows::workspace_accuracy_csv(workspace)?,
    )];
    files.extend(both(
        names::WORKSPACE_LAYERS_PNG,
        names::WORKSPACE_LAYERS_SVG,
        |f| {
            figures::layers(
                workspace,
                cfg.layers,
                cfg.grid_step_mm,
                cfg.workspace.radius_mm,
                f,
            )
        },
    )?);
    files.push((names::ISO9283_CSV, rows::iso9283_csv(iso)?));
    Ok(files)
}

/// The files of a volumetric map: `volumetric.csv`, `volumetric_summary.csv`,
/// `fig3.png` and `fig3.svg`, as (name, bytes).
pub fn map_files(
    cfg: &crate::config::Config,
    map: &crate::compensate::VolumetricMap,
) -> Result<Vec<(&'static str, Vec<u8>)>> {
    let mut files = vec![
        (names::VOLUMETRIC_CSV, rows::volumetric_csv(map)?),
        (
            names::VOLUMETRIC_SUMMARY_CSV,
            rows::volumetric_summary_csv(map)?,
        ),
    ];
    files.extend(both(names::FIG3_PNG, names::FIG3_SVG, |f| {
        figures::fig3(&figures::PlaneMap::of(cfg, map), f)
    })?);
    Ok(files)
}
