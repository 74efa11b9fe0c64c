//! `[sensors.encoder]`, `[sensors.encoder_psi]`, `[sensors.encoder_theta]`
//! and `[sensors.scale]`: sensors as their datasheets describe them
//! (docs/method.md §11), validated into [`Structured`] axes in internal units.

use super::raw::{EncoderSection, Harmonics, ScaleSection, SensorsSection};
use super::validate::{shown, Check};
use crate::error::Result;
use crate::mechanism::{Quantity, ReadingFact};
use crate::sensors::structured::{
    Shape, ECCENTRICITY_ARCSEC_PER_UM_MM, MAX_HARMONICS, MAX_LISTED_HARMONICS,
};
use crate::sensors::{Axis, Structured, ARCSEC_PER_RAD};

/// The longest measuring length a scale may have, mm.
const MAX_LENGTH_MM: f64 = 100_000.0;

/// The datasheet fields of one sensor in its datasheet unit.
struct Sheet<'a> {
    key: String,
    /// The unit suffix of its keys: `_arcsec` or `_um`.
    unit: &'static str,
    accuracy: f64,
    harmonics: &'a Harmonics,
    curve_order: Option<i64>,
    interpolation: f64,
    signal_period: f64,
    noise: f64,
    resolution: f64,
    /// Encoders only: eccentricity µm, ring diameter mm, readheads.
    mounting: Option<(f64, f64, i64)>,
    /// The interpolation error's coherence length (degrees for an
    /// encoder, mm for the scale; None: stationary) and its key.
    coherence: Option<f64>,
    coherence_key: &'static str,
}

/// The curve order of `harmonics = "unknown"` when none is given.
pub const DEFAULT_CURVE_ORDER: usize = 6;

/// Largest ring diameter, mm.
const MAX_RING_DIAMETER_MM: f64 = 10_000.0;

/// The curve's shape and its harmonic fractions (listed) or order (unknown).
fn shape(c: &Check, s: &Sheet) -> Result<(Shape, [f64; MAX_HARMONICS], usize)> {
    let k = |f: &str| format!("{}.{f}", s.key);
    let mut harmonics = [0.0; MAX_HARMONICS];
    let list = match s.harmonics {
        Harmonics::Word(w) if w == "unknown" => {
            let order = match s.curve_order {
                None => DEFAULT_CURVE_ORDER,
                Some(n) if (1..=MAX_HARMONICS as i64).contains(&n) => n as usize,
                Some(n) => {
                    return c.fail(
                        &k("curve_order"),
                        format_args!(
                        "must be a whole number of harmonics from 1 to {MAX_HARMONICS} (got {n})"
                    ),
                    )
                }
            };
            return Ok((Shape::Unknown, harmonics, order));
        }
        Harmonics::Word(w) => {
            return c.fail(
                &k("harmonics"),
                format_args!(
                    "must be a list of fractions of the accuracy or \"unknown\" (got \"{w}\")"
                ),
            )
        }
        Harmonics::List(list) => list,
    };
    if s.curve_order.is_some() {
        return c.fail(
            &k("curve_order"),
            "is the order of an unknown curve shape: it needs harmonics = \"unknown\" (a listed shape has its own orders)",
        );
    }
    if list.is_empty() {
        return c.fail(
            &k("harmonics"),
            "lists no harmonic: give the datasheet's fractions, or harmonics = \"unknown\" when it states none",
        );
    }
    if list.len() > MAX_LISTED_HARMONICS {
        return c.fail(
            &k("harmonics"),
            format_args!(
                "lists {} harmonics; at most {MAX_LISTED_HARMONICS} (or harmonics = \"unknown\" with curve_order up to {MAX_HARMONICS})",
                list.len()
            ),
        );
    }
    if let Some(h) = list.iter().find(|h| !(h.is_finite() && **h >= 0.0)) {
        return c.fail(
            &k("harmonics"),
            format_args!("must be fractions ≥ 0 of the accuracy (got {h})"),
        );
    }
    let sum: f64 = list.iter().sum();
    if sum > 1.0 + 1e-12 {
        return c.fail(
            &k("harmonics"),
            format_args!("sum to {}: the fractions of the accuracy must sum to at most 1 (the grade bounds the curve)", (sum * 1e9).round() / 1e9),
        );
    }
    harmonics[..list.len()].copy_from_slice(list);
    Ok((Shape::Listed, harmonics, list.len()))
}

/// An encoder's mounting: the eccentricity's bound (rad) and the readheads.
fn mounting(c: &Check, s: &Sheet) -> Result<(f64, u8, f64)> {
    let Some((e, d, heads)) = s.mounting else {
        return Ok((0.0, 1, 0.0));
    };
    let k = |f: &str| format!("{}.{f}", s.key);
    if !(e.is_finite() && (0.0..=1000.0).contains(&e)) {
        return c.fail(
            &k("eccentricity_um"),
            format_args!(
                "must be an eccentricity between 0 and 1000 µm (got {})",
                shown(e)
            ),
        );
    }
    if !(d.is_finite() && (0.0..=MAX_RING_DIAMETER_MM).contains(&d)) {
        return c.fail(
            &k("ring_diameter_mm"),
            format_args!(
                "must be a diameter between 0 and {MAX_RING_DIAMETER_MM} mm (got {})",
                shown(d)
            ),
        );
    }
    if e > 0.0 && d < 1.0 {
        return c.fail(
            &k("ring_diameter_mm"),
            format_args!(
                "must be given (at least 1 mm) with eccentricity_um = {}: the error an eccentricity makes is 412·e/D arc-seconds",
                shown(e)
            ),
        );
    }
    if heads != 1 && heads != 2 {
        return c.fail(
            &k("readheads"),
            format_args!("must be 1 or 2 (two diametrically opposite heads averaged; got {heads})"),
        );
    }
    let bound = if e > 0.0 {
        ECCENTRICITY_ARCSEC_PER_UM_MM * e / d / ARCSEC_PER_RAD
    } else {
        0.0
    };
    Ok((bound, heads as u8, d))
}

fn axis(c: &Check, s: &Sheet, unit: f64, period: f64) -> Result<Axis> {
    // The amplitudes' keys carry the unit (`accuracy_um`): the error names
    // the key as the file spells it.
    let ku = |f: &str| format!("{}.{f}{}", s.key, s.unit);
    // Amplitudes are bounded like the grade lists (3600″, 1000 µm); a
    // signal period by one turn of the encoder or the scale's length.
    let (max, max_period, what) = match s.unit {
        "_arcsec" => (
            super::validate::MAX_ENCODER_ARCSEC,
            360.0 * 3600.0,
            "one turn (1296000″)",
        ),
        _ => (
            super::validate::MAX_SCALE_UM,
            period * 1e3,
            "the scale's measuring length",
        ),
    };
    for (name, v, most) in [
        ("accuracy", s.accuracy, max),
        ("interpolation", s.interpolation, max),
        ("signal_period", s.signal_period, max_period),
        ("noise", s.noise, max),
        ("resolution", s.resolution, max),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return c.fail(
                &ku(name),
                format_args!("must be a finite amplitude ≥ 0 (got {})", shown(v)),
            );
        }
        if v > most {
            let bound = match name {
                "signal_period" => format!("at most {what}"),
                _ => format!("at most {most}, the largest grade a study may compare"),
            };
            return c.fail(
                &ku(name),
                format_args!("must be {bound} (got {})", shown(v)),
            );
        }
    }
    let (shape, harmonics, n_harmonics) = shape(c, s)?;
    let (eccentricity, readheads, ring_diameter) = mounting(c, s)?;
    if s.signal_period > 0.0 && s.interpolation == 0.0 {
        return c.fail(
            &ku("signal_period"),
            "is given without an interpolation amplitude",
        );
    }
    if s.interpolation > 0.0 && s.signal_period == 0.0 {
        return c.fail(
            &ku("interpolation"),
            "needs the signal period it repeats over",
        );
    }
    // The interpolation error's coherence: stationary unless stated.
    let coherence = match s.coherence {
        None => 0.0,
        Some(_) if s.interpolation == 0.0 => {
            return c.fail(
                &format!("{}.{}", s.key, s.coherence_key),
                "is given without an interpolation amplitude",
            )
        }
        Some(v) => {
            // Up to one turn (360°), or the scale's measuring length.
            let (most, to_internal) = match s.unit {
                "_arcsec" => (360.0, std::f64::consts::PI / 180.0),
                _ => (period, 1.0),
            };
            if !(v.is_finite() && v > 0.0 && v <= most) {
                return c.fail(
                    &format!("{}.{}", s.key, s.coherence_key),
                    format_args!(
                        "must be a coherence length in (0, {}] (got {}); leave it out for a stationary interpolation error",
                        // Rounded down: the bound a user can type.
                        (most * 10.0).floor() / 10.0,
                        shown(v)
                    ),
                );
            }
            v * to_internal
        }
    };
    // Two heads: their jitter and quantisation are averaged (σ/√2, r/√2:
    // the variance a pair's mean has); the interpolation's halving comes
    // from the two heads' own phases.
    let pair = if readheads == 2 {
        std::f64::consts::FRAC_1_SQRT_2
    } else {
        1.0
    };
    Ok(Axis {
        accuracy: s.accuracy * unit,
        shape,
        harmonics,
        n_harmonics,
        eccentricity,
        ring_diameter,
        readheads,
        period,
        interpolation: s.interpolation * unit,
        signal_period: s.signal_period * unit,
        noise: s.noise * unit * pair,
        resolution: s.resolution * unit * pair,
        // Set from [identification] once the config is read.
        weight_coherence: 0.0,
        coherence,
    })
}

fn encoder_sheet<'a>(key: &str, e: &'a EncoderSection) -> Sheet<'a> {
    Sheet {
        key: key.to_string(),
        unit: "_arcsec",
        accuracy: e.accuracy_arcsec,
        harmonics: &e.harmonics,
        curve_order: e.curve_order,
        interpolation: e.interpolation_arcsec,
        signal_period: e.signal_period_arcsec,
        noise: e.noise_arcsec,
        resolution: e.resolution_arcsec,
        mounting: Some((e.eccentricity_um, e.ring_diameter_mm, e.readheads)),
        coherence: e.interpolation_coherence_deg,
        coherence_key: "interpolation_coherence_deg",
    }
}

fn scale_sheet<'a>(key: &str, e: &'a ScaleSection) -> Sheet<'a> {
    Sheet {
        key: key.to_string(),
        unit: "_um",
        accuracy: e.accuracy_um,
        harmonics: &e.harmonics,
        curve_order: e.curve_order,
        interpolation: e.interpolation_um,
        signal_period: e.signal_period_um,
        noise: e.noise_um,
        resolution: e.resolution_um,
        mounting: None,
        coherence: e.interpolation_coherence_mm,
        coherence_key: "interpolation_coherence_mm",
    }
}

/// The paper's reading of a grade for an axis without a section: jitter of
/// σ = grade, no curve.
fn paper_axis(grade: f64, period: f64) -> Axis {
    Axis {
        period,
        noise: grade,
        readheads: 1,
        ..Axis::default()
    }
}

/// What a mechanism's scale must cover: its length reading's travel over
/// the workspace (mm), and that reading's symbol for a message.
#[derive(Debug, Clone, Copy)]
pub struct Stroke {
    pub span_mm: f64,
    pub symbol: &'static str,
}

/// A mechanism's `[sensors]` as its reading slots read them: each slot's
/// facts, and for an angle slot the section of its own encoder (its key
/// and the section as given; `[sensors.encoder]` is every angle slot's
/// otherwise), with the stroke its scale must cover.
pub struct SlotSections<'a, const R: usize> {
    pub slots: &'a [ReadingFact; R],
    pub own: [Option<(&'static str, &'a Option<EncoderSection>)>; R],
    pub stroke: Stroke,
}

/// The structured model, when any datasheet section is present: each
/// angle slot's encoder is its own section, else `[sensors.encoder]`,
/// else the paper's reading of the encoder grade; each length slot's
/// scale is `[sensors.scale]`, else the paper's reading of the scale
/// grade.
pub(super) fn structured<const R: usize>(
    c: &Check,
    s: &SensorsSection,
    by: &SlotSections<R>,
) -> Result<Option<Structured<R>>> {
    let own_given = by
        .own
        .iter()
        .any(|o| o.is_some_and(|(_, section)| section.is_some()));
    if s.encoder.is_none() && !own_given && s.scale.is_none() {
        return Ok(None);
    }
    let rad = 1.0 / ARCSEC_PER_RAD;
    let turn = std::f64::consts::TAU;
    let grade_rad = s.encoder_arcsec * rad;
    let mut from_section = [false; R];
    let mut axes = [Axis::default(); R];
    let mut scale: Option<Option<Axis>> = None;
    for k in 0..R {
        let given = match by.slots[k].quantity {
            Quantity::Angle => match (
                by.own[k].and_then(|(key, e)| Some((key, e.as_ref()?))),
                &s.encoder,
            ) {
                (Some((key, e)), _) => Some(axis(c, &encoder_sheet(key, e), rad, turn)?),
                (None, Some(e)) => Some(axis(c, &encoder_sheet("sensors.encoder", e), rad, turn)?),
                (None, None) => None,
            },
            Quantity::Length => match scale {
                Some(a) => a,
                None => {
                    let a = match &s.scale {
                        Some(sc) => Some(scale_axis(c, "sensors.scale", sc, by.stroke)?),
                        None => None,
                    };
                    scale = Some(a);
                    a
                }
            },
        };
        from_section[k] = given.is_some();
        axes[k] = given.unwrap_or_else(|| match by.slots[k].quantity {
            Quantity::Angle => paper_axis(grade_rad, turn),
            Quantity::Length => paper_axis(s.scale_um * 1e-3, 1.0),
        });
    }
    Ok(Some(Structured { from_section, axes }))
}

/// The scale's axis; a measuring length of 0 is the length reading's
/// travel over the workspace (`stroke`).
fn scale_axis(c: &Check, key: &str, sc: &ScaleSection, stroke: Stroke) -> Result<Axis> {
    if !(sc.length_mm.is_finite() && sc.length_mm >= 0.0) {
        return c.fail(
            &format!("{key}.length_mm"),
            format_args!("must be a length ≥ 0 in mm (got {})", shown(sc.length_mm)),
        );
    }
    let span = stroke.span_mm;
    if sc.length_mm > 0.0 && sc.length_mm < span {
        return c.fail(
            &format!("{key}.length_mm"),
            format_args!(
                "= {} mm is shorter than the {:.1} mm of {} travel the workspace needs: the scale must cover the stroke (0 = that span)",
                sc.length_mm, span, stroke.symbol
            ),
        );
    }
    if sc.length_mm > MAX_LENGTH_MM {
        return c.fail(
            &format!("{key}.length_mm"),
            format_args!(
                "must be at most {MAX_LENGTH_MM} mm (got {})",
                shown(sc.length_mm)
            ),
        );
    }
    let length = if sc.length_mm > 0.0 {
        sc.length_mm
    } else {
        span
    };
    axis(c, &scale_sheet(key, sc), 1e-3, length)
}

/// The datasheet model of one angle encoder (radians, one turn), its
/// errors naming `key`: a hexapod's U-joint encoder.
pub(super) fn encoder_axis(c: &Check, key: &str, enc: &EncoderSection) -> Result<Axis> {
    axis(
        c,
        &encoder_sheet(key, enc),
        1.0 / ARCSEC_PER_RAD,
        std::f64::consts::TAU,
    )
}

/// The datasheet model of a catalogue pair on reading slots `slots`:
/// encoder `enc` on every angle slot (the Tricept's two Hooke axes), scale
/// `sc` on every length slot (its UP limb); errors name the products' keys.
pub(super) fn product_model<const R: usize>(
    c: &Check,
    enc_key: &str,
    enc: &EncoderSection,
    sc_key: &str,
    sc: &ScaleSection,
    (stroke, slots): (Stroke, &[ReadingFact; R]),
) -> Result<Structured<R>> {
    let e = axis(
        c,
        &encoder_sheet(enc_key, enc),
        1.0 / ARCSEC_PER_RAD,
        std::f64::consts::TAU,
    )?;
    let s = scale_axis(c, sc_key, sc, stroke)?;
    Ok(Structured {
        from_section: [true; R],
        axes: slots.map(|r| match r.quantity {
            Quantity::Angle => e,
            Quantity::Length => s,
        }),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A layout that is not the Tricept's: length, angle, angle. Each
    /// angle slot reads its own section where it has one and
    /// `[sensors.encoder]` otherwise; the length slot reads the scale; a
    /// scale shorter than the stroke is refused naming the reading.
    #[test]
    fn each_slot_reads_its_own_section_in_any_layout() {
        const SLOTS: [ReadingFact; 3] = [
            ReadingFact::named("l", Quantity::Length),
            ReadingFact::named("a", Quantity::Angle),
            ReadingFact::named("b", Quantity::Angle),
        ];
        let c = Check { source: "t.toml" };
        let own = EncoderSection {
            accuracy_arcsec: 3.0,
            ..EncoderSection::default()
        };
        let shared = EncoderSection {
            accuracy_arcsec: 7.0,
            ..EncoderSection::default()
        };
        let none: Option<EncoderSection> = None;
        let given = Some(own);
        let s = SensorsSection {
            encoder: Some(shared),
            scale: Some(ScaleSection::default()),
            ..SensorsSection::default()
        };
        let stroke = Stroke {
            span_mm: 300.0,
            symbol: "l",
        };
        let by = SlotSections {
            slots: &SLOTS,
            own: [
                None,
                Some(("sensors.encoder_b", &none)),
                Some(("sensors.encoder_b", &given)),
            ],
            stroke,
        };
        let st = structured(&c, &s, &by).unwrap().unwrap();
        assert_eq!(st.from_section, [true; 3]);
        let want = |e: &EncoderSection, key: &str| {
            axis(
                &c,
                &encoder_sheet(key, e),
                1.0 / ARCSEC_PER_RAD,
                std::f64::consts::TAU,
            )
            .unwrap()
        };
        assert_eq!(
            st.axes[1],
            want(s.encoder.as_ref().unwrap(), "sensors.encoder")
        );
        assert_eq!(
            st.axes[2],
            want(&given.clone().unwrap(), "sensors.encoder_b")
        );
        assert_ne!(st.axes[1], st.axes[2]);
        let scale = scale_axis(&c, "sensors.scale", s.scale.as_ref().unwrap(), stroke).unwrap();
        assert_eq!(st.axes[0], scale);
        // Without any section: the paper's reading, no datasheet model.
        let unset = SlotSections {
            own: [None, Some(("sensors.encoder_b", &none)), None],
            ..by
        };
        assert!(structured(&c, &SensorsSection::default(), &unset)
            .unwrap()
            .is_none());
        // A slot's own section alone is a datasheet model.
        let st = structured(&c, &SensorsSection::default(), &by)
            .unwrap()
            .unwrap();
        assert_eq!(st.from_section, [false, false, true]);
        // Only the angle slots' sections: the scale is the paper's grade.
        let angles_only = SensorsSection {
            encoder: Some(EncoderSection::default()),
            ..SensorsSection::default()
        };
        let st = structured(&c, &angles_only, &unset).unwrap().unwrap();
        assert_eq!(st.from_section, [false, true, true]);
        // The paper's reading of the scale grade: jitter of σ = grade on a
        // 1 mm period, one readhead, no curve.
        let paper = Axis {
            period: 1.0,
            noise: angles_only.scale_um * 1e-3,
            readheads: 1,
            ..Axis::default()
        };
        assert_eq!(st.axes[0], paper);
        // A scale shorter than the stroke names the length reading.
        let short = SensorsSection {
            scale: Some(ScaleSection {
                length_mm: 100.0,
                ..ScaleSection::default()
            }),
            ..SensorsSection::default()
        };
        let err = structured(&c, &short, &by).unwrap_err().to_string();
        assert!(err.contains("300.0 mm of l travel"), "{err}");
    }
}
