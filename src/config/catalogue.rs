//! The sensor catalogue (`configs/sensors.toml`): named encoder and scale
//! products, each its datasheet model (docs/method.md §11) and a price, and the
//! products a study compares (`[sweep] catalogue`, `encoders`, `scales`).

use super::raw::{toml_error, EncoderSection, Harmonics, ScaleSection, SweepSection};
use super::sensors::{product_model, Stroke};
use super::validate::Check;
use crate::error::{Error, Result};
use crate::mechanism::{Quantity, ReadingFact};
use crate::sensors::Structured;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The dearest a product may be (its currency units): a set's total, a
/// product a reading slot, stays exact and finite.
const MAX_PRICE: f64 = 1e12;

/// An angle encoder product class: two are fitted (ψ4 and θ4).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct EncoderEntry {
    name: String,
    /// Price of one encoder.
    price: f64,
    #[serde(default)]
    ring_diameter_mm: f64,
    #[serde(default)]
    eccentricity_um: f64,
    #[serde(default = "one_head")]
    readheads: i64,
    accuracy_arcsec: f64,
    #[serde(default = "unknown_shape")]
    harmonics: Harmonics,
    #[serde(default)]
    curve_order: Option<i64>,
    #[serde(default)]
    interpolation_arcsec: f64,
    #[serde(default)]
    signal_period_arcsec: f64,
    #[serde(default)]
    noise_arcsec: f64,
    #[serde(default)]
    resolution_arcsec: f64,
    #[serde(default)]
    interpolation_coherence_deg: Option<f64>,
}

/// A linear scale product class.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ScaleEntry {
    name: String,
    price: f64,
    accuracy_um: f64,
    #[serde(default = "unknown_shape")]
    harmonics: Harmonics,
    #[serde(default)]
    curve_order: Option<i64>,
    #[serde(default)]
    length_mm: f64,
    #[serde(default)]
    interpolation_um: f64,
    #[serde(default)]
    signal_period_um: f64,
    #[serde(default)]
    noise_um: f64,
    #[serde(default)]
    resolution_um: f64,
    #[serde(default)]
    interpolation_coherence_mm: Option<f64>,
}

/// A catalogue entry that states no harmonics: no datasheet states the
/// curve's shape, so none is assumed (a pure once-per-revolution curve read
/// as measured made studies 10–30 % optimistic).
fn unknown_shape() -> Harmonics {
    Harmonics::Word("unknown".to_string())
}

fn one_head() -> i64 {
    1
}

#[derive(Debug, Clone, Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct CatalogueFile {
    #[serde(default)]
    encoder: Vec<EncoderEntry>,
    #[serde(default)]
    scale: Vec<ScaleEntry>,
}

/// One product as a study uses it.
#[derive(Debug, Clone, PartialEq)]
pub struct Product {
    pub name: String,
    /// Price of one unit (the user's quote; the shipped figures are placeholders).
    pub price: f64,
    /// Accuracy grade ±a, arc-seconds (encoders) or µm (scales).
    pub grade: f64,
    /// Ring diameter of an encoder, mm (0 when not given; informational).
    pub ring_diameter_mm: f64,
}

/// The products a study compares and the datasheet model of every
/// (scale, encoder) pair, scale-major as the sweep's sensor axis, on a
/// mechanism's `R` reading slots: the encoder on every angle slot, the
/// scale on every length slot.
#[derive(Debug, Clone, PartialEq)]
pub struct Products<const R: usize> {
    /// The catalogue file as resolved.
    pub path: PathBuf,
    /// Its content's digest ([`crate::digest::hex`]): part of a study's
    /// identity, so that resume, shards and merge see an edited catalogue.
    pub digest: String,
    pub encoders: Vec<Product>,
    pub scales: Vec<Product>,
    /// models[s · encoders + e]: encoder e on every angle slot (the
    /// Tricept's two Hooke axes), scale s on every length slot.
    pub models: Vec<Structured<R>>,
    /// The slots the models fill, in order.
    pub slots: &'static [ReadingFact; R],
}

impl<const R: usize> Products<R> {
    /// Total price of sensor set `index` (scale-major): a product in each
    /// slot (the Tricept's two encoders and a scale).
    pub fn price(&self, index: usize) -> f64 {
        let (s, e) = (index / self.encoders.len(), index % self.encoders.len());
        let each = |q: Quantity| match q {
            Quantity::Angle => self.encoders[e].price,
            Quantity::Length => self.scales[s].price,
        };
        let mut slots = self.slots.iter().map(|r| each(r.quantity));
        let first = slots.next().unwrap_or(0.0);
        slots.fold(first, |total, p| total + p)
    }

    /// (encoder, scale) of sensor set `index`.
    pub fn pair(&self, index: usize) -> (&Product, &Product) {
        let (s, e) = (index / self.encoders.len(), index % self.encoders.len());
        (&self.encoders[e], &self.scales[s])
    }
}

/// The catalogue path of `[sweep] catalogue`, relative to the config's folder.
fn resolve(config_source: &str, given: &str) -> PathBuf {
    let p = Path::new(given);
    if p.is_absolute() {
        return p.to_path_buf();
    }
    match Path::new(config_source).parent() {
        Some(dir) if Path::new(config_source).is_file() => dir.join(p),
        _ => p.to_path_buf(),
    }
}

/// `[sweep] catalogue / encoders / scales`: None without a catalogue.
pub(super) fn products<const R: usize>(
    c: &Check,
    sw: &SweepSection,
    stroke: Stroke,
    slots: &'static [ReadingFact; R],
) -> Result<Option<Products<R>>> {
    let Some(given) = &sw.catalogue else {
        for (key, set) in [
            ("sweep.encoders", &sw.encoders),
            ("sweep.scales", &sw.scales),
        ] {
            if set.is_some() {
                return c.fail(key, "names catalogue products: set sweep.catalogue too");
            }
        }
        return Ok(None);
    };
    let grades = SweepSection::default();
    for (key, set, default) in [
        (
            "sweep.encoder_arcsec",
            &sw.encoder_arcsec,
            &grades.encoder_arcsec,
        ),
        ("sweep.scale_um", &sw.scale_um, &grades.scale_um),
    ] {
        if set != default {
            return c.fail(
                key,
                "is a grade list, and a catalogue study compares the catalogue's products: remove it, or remove sweep.catalogue",
            );
        }
    }
    let path = resolve(c.source, given);
    let shown = path.display().to_string();
    let text = crate::io::read_text(&path, super::raw::MAX_CONFIG_BYTES).map_err(|why| {
        Error::config(
            c.source,
            format!("sweep.catalogue: the catalogue {shown} {why}"),
        )
    })?;
    let file: CatalogueFile = toml::from_str(&text).map_err(|e| toml_error(&text, &shown, &e))?;
    let cat = Check { source: &shown };
    duplicates(&cat, &text, &file.encoder, "[[encoder]]", |e| &e.name)?;
    duplicates(&cat, &text, &file.scale, "[[scale]]", |s| &s.name)?;
    let encoders = pick(c, "sweep.encoders", &sw.encoders, &file.encoder, |e| {
        &e.name
    })?;
    let scales = pick(c, "sweep.scales", &sw.scales, &file.scale, |s| &s.name)?;
    let mut models = Vec::new();
    for s in &scales {
        for e in &encoders {
            let ek = format!("encoder \"{}\"", e.name);
            let sk = format!("scale \"{}\"", s.name);
            models.push(product_model(
                &cat,
                &ek,
                &encoder_section(e),
                &sk,
                &scale_section(s),
                (stroke, slots),
            )?);
        }
    }
    let price = |key: String, p: f64| -> Result<f64> {
        if p.is_finite() && (0.0..=MAX_PRICE).contains(&p) {
            // + 0.0 makes a price of -0 a plain 0.
            Ok(p + 0.0)
        } else {
            cat.fail(
                &key,
                format_args!(
                    "must be a price between 0 and {MAX_PRICE:e} (got {})",
                    super::validate::shown(p)
                ),
            )
        }
    };
    for e in &encoders {
        let d = e.ring_diameter_mm;
        if !(d.is_finite() && (0.0..=10_000.0).contains(&d)) {
            return cat.fail(
                &format!("encoder \"{}\".ring_diameter_mm", e.name),
                format_args!(
                    "must be a diameter between 0 and 10000 mm (got {})",
                    super::validate::shown(d)
                ),
            );
        }
    }
    let mut out_e = Vec::new();
    for e in &encoders {
        out_e.push(Product {
            price: price(format!("encoder \"{}\".price", e.name), e.price)?,
            name: e.name.clone(),
            grade: e.accuracy_arcsec,
            ring_diameter_mm: e.ring_diameter_mm,
        });
    }
    let mut out_s = Vec::new();
    for s in &scales {
        out_s.push(Product {
            price: price(format!("scale \"{}\".price", s.name), s.price)?,
            name: s.name.clone(),
            grade: s.accuracy_um,
            ring_diameter_mm: 0.0,
        });
    }
    Ok(Some(Products {
        digest: crate::digest::hex(text.as_bytes()),
        path,
        encoders: out_e,
        scales: out_s,
        models,
        slots,
    }))
}

/// The angle encoders of catalogue `given` (relative to the config
/// `config_source`'s folder), those named in `wanted` (every one when
/// None): a hexapod study's U-joint encoders, each with its datasheet model
/// (radians). Errors name the config key, or the catalogue and its entry.
pub fn encoder_products(
    config_source: &str,
    given: &str,
    wanted: &Option<Vec<String>>,
) -> Result<Vec<(Product, crate::sensors::Axis)>> {
    let c = Check {
        source: config_source,
    };
    let path = resolve(config_source, given);
    let shown = path.display().to_string();
    let text = crate::io::read_text(&path, super::raw::MAX_CONFIG_BYTES).map_err(|why| {
        Error::config(
            config_source,
            format!("sweep.catalogue: the catalogue {shown} {why}"),
        )
    })?;
    let file: CatalogueFile = toml::from_str(&text).map_err(|e| toml_error(&text, &shown, &e))?;
    let cat = Check { source: &shown };
    duplicates(&cat, &text, &file.encoder, "[[encoder]]", |e| &e.name)?;
    let encoders = pick(&c, "sweep.encoders", wanted, &file.encoder, |e| &e.name)?;
    if encoders.is_empty() {
        return c.fail(
            "sweep.catalogue",
            format_args!("{shown} lists no [[encoder]] to compare"),
        );
    }
    let mut out = Vec::new();
    for e in &encoders {
        let key = format!("encoder \"{}\"", e.name);
        let axis = super::sensors::encoder_axis(&cat, &key, &encoder_section(e))?;
        if !(e.price.is_finite() && (0.0..=MAX_PRICE).contains(&e.price)) {
            return cat.fail(
                &format!("{key}.price"),
                format_args!(
                    "must be a price between 0 and {MAX_PRICE:e} (got {})",
                    super::validate::shown(e.price)
                ),
            );
        }
        out.push((
            Product {
                name: e.name.clone(),
                price: e.price + 0.0,
                grade: e.accuracy_arcsec,
                ring_diameter_mm: e.ring_diameter_mm,
            },
            axis,
        ));
    }
    Ok(out)
}

/// Two entries of one kind with one name: the catalogue's defect, named by
/// its file and the line of the second `name`.
fn duplicates<T>(
    cat: &Check,
    text: &str,
    entries: &[T],
    kind: &str,
    name: impl Fn(&T) -> &String,
) -> Result<()> {
    for (i, e) in entries.iter().enumerate() {
        if entries[..i].iter().any(|o| name(o) == name(e)) {
            // The line of this name's second `name = "…"`.
            let line = text
                .lines()
                .enumerate()
                .filter(|(_, l)| {
                    let t = l.trim_start();
                    t.starts_with("name")
                        && t.split_once('=').is_some_and(|(k, v)| {
                            k.trim() == "name"
                                && v.split('#').next().unwrap_or("").trim().trim_matches('"')
                                    == name(e).as_str()
                        })
                })
                .nth(1)
                .map(|(n, _)| n + 1);
            let at = line.map_or(String::new(), |n| format!("line {n}: "));
            return cat.fail(
                &format!("{at}{kind} name"),
                format_args!(
                    "\"{}\" is used by two {kind} entries: each product needs its own name",
                    name(e)
                ),
            );
        }
    }
    Ok(())
}

/// The entries named by `wanted` (all when None), in the order listed;
/// unknown or repeated names fail on `key`.
fn pick<T: Clone>(
    c: &Check,
    key: &str,
    wanted: &Option<Vec<String>>,
    entries: &[T],
    name: impl Fn(&T) -> &String,
) -> Result<Vec<T>> {
    let kind = if key.ends_with("encoders") {
        "[[encoder]]"
    } else {
        "[[scale]]"
    };
    for (i, e) in entries.iter().enumerate() {
        if entries[..i].iter().any(|o| name(o) == name(e)) {
            return c.fail(
                key,
                format_args!("the catalogue has two {kind} entries named \"{}\"", name(e)),
            );
        }
    }
    let out: Vec<T> = match wanted {
        None => entries.to_vec(),
        Some(list) => {
            let mut out = Vec::new();
            for (i, w) in list.iter().enumerate() {
                if list[..i].contains(w) {
                    return c.fail(key, format_args!("lists \"{w}\" twice"));
                }
                match entries.iter().find(|e| name(e) == w) {
                    Some(e) => out.push(e.clone()),
                    None => {
                        let known: Vec<&str> = entries.iter().map(|e| name(e).as_str()).collect();
                        return c.fail(
                            key,
                            format_args!(
                                "names \"{w}\", which the catalogue has no {kind} entry for (it has: {})",
                                known.join(", ")
                            ),
                        );
                    }
                }
            }
            out
        }
    };
    if out.is_empty() {
        return c.fail(
            key,
            format_args!("selects no product: the catalogue needs at least one {kind} entry"),
        );
    }
    Ok(out)
}

fn encoder_section(e: &EncoderEntry) -> EncoderSection {
    EncoderSection {
        accuracy_arcsec: e.accuracy_arcsec,
        harmonics: e.harmonics.clone(),
        curve_order: e.curve_order,
        interpolation_arcsec: e.interpolation_arcsec,
        signal_period_arcsec: e.signal_period_arcsec,
        noise_arcsec: e.noise_arcsec,
        resolution_arcsec: e.resolution_arcsec,
        eccentricity_um: e.eccentricity_um,
        ring_diameter_mm: e.ring_diameter_mm,
        readheads: e.readheads,
        interpolation_coherence_deg: e.interpolation_coherence_deg,
    }
}

fn scale_section(s: &ScaleEntry) -> ScaleSection {
    ScaleSection {
        accuracy_um: s.accuracy_um,
        harmonics: s.harmonics.clone(),
        curve_order: s.curve_order,
        length_mm: s.length_mm,
        interpolation_um: s.interpolation_um,
        signal_period_um: s.signal_period_um,
        noise_um: s.noise_um,
        resolution_um: s.resolution_um,
        interpolation_coherence_mm: s.interpolation_coherence_mm,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn product(name: &str, price: f64) -> Product {
        Product {
            name: name.into(),
            price,
            grade: 1.0,
            ring_diameter_mm: 0.0,
        }
    }

    /// A set's price is a product a slot: the Tricept's two encoders and a
    /// scale, and a layout of three encoders and two scales priced as such;
    /// sets run scale-major (three encoders, two scales).
    #[test]
    fn a_set_is_priced_slot_by_slot() {
        fn products<const R: usize>(slots: &'static [ReadingFact; R]) -> Products<R> {
            Products {
                path: PathBuf::new(),
                digest: String::new(),
                encoders: vec![
                    product("e1", 100.0),
                    product("e2", 250.0),
                    product("e3", 30.0),
                ],
                scales: vec![product("s1", 40.0), product("s2", 7.0)],
                models: Vec::new(),
                slots,
            }
        }
        let tricept = products(crate::mechanism::tricept::SLOTS);
        assert_eq!(tricept.price(0), 2.0 * 100.0 + 40.0);
        assert_eq!(tricept.price(1), 2.0 * 250.0 + 40.0);
        assert_eq!(tricept.price(2), 2.0 * 30.0 + 40.0);
        assert_eq!(tricept.price(4), 2.0 * 250.0 + 7.0);
        let (e, s) = tricept.pair(3);
        assert_eq!((e.name.as_str(), s.name.as_str()), ("e1", "s2"));
        let angle = crate::mechanism::tricept::READINGS[0];
        let length = crate::mechanism::tricept::READINGS[2];
        static FIVE: std::sync::OnceLock<[ReadingFact; 5]> = std::sync::OnceLock::new();
        let five = FIVE.get_or_init(|| [length, angle, angle, length, angle]);
        assert_eq!(products(five).price(1), 3.0 * 250.0 + 2.0 * 40.0);
    }
}
