//! What a study's verdict rests on, in words: the sensor model the
//! readings were drawn from, the machines' errors, what the identification
//! leaves out; the sentences summary.csv's study carries into verdict.json,
//! report.md and report.html.

use super::trial::{Studied, SweepContext};
use crate::config::Study;

/// What a study's verdict rests on, one sentence each: the sensor model the
/// estimators assume, then the mechanism's own ([`Studied::assumptions`]:
/// the geometric errors drawn, and what else its machines carry).
pub fn assumptions<M: Studied<P, R, A>, const P: usize, const R: usize, const A: usize>(
    ctx: &SweepContext<M, P, R, A>,
    study: &Study<P, R>,
) -> Vec<String> {
    use crate::sensors::structured::Shape;
    let mut out = Vec::new();
    let axes: Vec<&crate::sensors::Axis> = ctx
        .assumed
        .iter()
        .filter_map(|s| s.structured.as_ref())
        .flat_map(|st| {
            st.axes
                .iter()
                .zip(st.from_section)
                .filter(|a| a.1)
                .map(|a| a.0)
        })
        .collect();
    let unknown: Vec<usize> = axes
        .iter()
        .filter(|a| a.shape == Shape::Unknown)
        .map(|a| a.n_harmonics)
        .collect();
    let listed = axes.iter().any(|a| a.shape == Shape::Listed);
    if !unknown.is_empty() {
        let k = unknown.iter().max().copied().unwrap_or(0);
        out.push(format!("each sensor's error curve stays within its grade with a shape of up to {k} harmonics per revolution (encoders) or measuring length (scale), no shape assumed, and interpolation error and jitter as the datasheets state."));
    }
    if listed {
        out.push("the listed sensors' curves have the harmonic fractions their entries give (measured curves, not a datasheet's figure).".into());
    }
    if axes.is_empty() || ctx.assumed.iter().any(|s| s.structured.is_none()) {
        out.push("each sensor's grade is the standard deviation of independent reading noise (the paper's reading).".into());
    }
    if axes
        .iter()
        .any(|a| a.interpolation > 0.0 && a.signal_period > 0.0)
    {
        out.push(if axes.iter().any(|a| a.coherence > 0.0) {
            "each interpolation error keeps its amplitude and phase over the coherence length its entry states (a stationary sinusoid of the signal period where none is stated).".into()
        } else {
            "each interpolation error is a stationary sinusoid of the signal period (no entry states a coherence length; sweep.truth_coherence_fraction shows what a shorter one costs).".into()
        });
    }
    if axes.iter().any(|a| a.eccentricity > 0.0) {
        out.push(
            "installed encoder rings are mounted within the eccentricity their entries state."
                .into(),
        );
    }
    out.extend(ctx.mech.assumptions(study));
    out
}
