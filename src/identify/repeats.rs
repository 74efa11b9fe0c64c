//! Rows of a log that repeat a pose. A repeat reads the sensors again at
//! the same angles: it averages their noise, the part of a reading's error
//! drawn afresh each time, but not their error at those angles (an
//! encoder's curve and interpolation error come back with the pose). So
//! the held-out check leaves out whole poses (a fold never predicts a pose
//! the fit has read), and the repeats' own scatter decides how they count
//! ([`Repeats::fresh`]): as fresh readings when they scatter as the stated
//! noise says, else (copies of a row, a steady value the controller logs
//! again) each pose once, at the mean of its readings, as one reading.
//! Loggings that differ by a steady offset (a log homed again, then
//! appended) are not fresh either ([`Repeats::offset`]): counted at the
//! pose's mean where every pose is logged equally often (the means share
//! one offset), refused otherwise.
//!
//! Poses are the same when their commanded targets are equal to the bit
//! (a log repeats a commanded pose exactly). O(n) in rows.

use statrs::distribution::{ChiSquared, ContinuousCDF, StudentsT};
use std::collections::HashMap;

/// A log's rows grouped by pose, in the order each pose first appears.
#[derive(Debug, Clone, PartialEq)]
pub struct Repeats {
    /// Each distinct pose's first row.
    pub first: Vec<usize>,
    /// Each row's distinct pose.
    pub of_row: Vec<usize>,
    /// Each distinct pose's rows.
    pub counts: Vec<usize>,
}

impl Repeats {
    /// Group rows by their targets, `width` values a row in `targets`.
    pub fn of(targets: &[f64], width: usize) -> Self {
        assert!(width > 0 && targets.len().is_multiple_of(width));
        let rows = targets.len() / width;
        let mut seen: HashMap<Vec<u64>, usize> = HashMap::with_capacity(rows);
        let mut r = Repeats {
            first: Vec::new(),
            of_row: Vec::with_capacity(rows),
            counts: Vec::new(),
        };
        for (i, row) in targets.chunks_exact(width).enumerate() {
            // −0.0 and 0.0 are one target.
            let key: Vec<u64> = row.iter().map(|x| (x + 0.0).to_bits()).collect();
            let next = r.first.len();
            let g = *seen.entry(key).or_insert(next);
            if g == next {
                r.first.push(i);
                r.counts.push(0);
            }
            r.counts[g] += 1;
            r.of_row.push(g);
        }
        r
    }

    /// Rows that repeat a pose logged before.
    pub fn repeated(&self) -> usize {
        self.of_row.len() - self.first.len()
    }

    /// The mean of each distinct pose's `per` values (`values` row after
    /// row), in the poses' order.
    pub fn means(&self, values: &[f64], per: usize) -> Vec<f64> {
        assert_eq!(values.len(), self.of_row.len() * per);
        let mut sum = vec![0.0; self.first.len() * per];
        for (row, &g) in values.chunks_exact(per).zip(&self.of_row) {
            for (s, v) in sum[g * per..(g + 1) * per].iter_mut().zip(row) {
                *s += v;
            }
        }
        for (g, &c) in self.counts.iter().enumerate() {
            for s in &mut sum[g * per..(g + 1) * per] {
                *s /= c as f64;
            }
        }
        sum
    }

    /// Each of the `per` readings' scatter among the repeats of a pose:
    /// (RMS about each pose's mean, pooled over the repeated poses; degrees
    /// of freedom, rows less distinct poses).
    pub fn scatter(&self, values: &[f64], per: usize) -> (Vec<f64>, usize) {
        let means = self.means(values, per);
        let mut sq = vec![0.0; per];
        for (row, &g) in values.chunks_exact(per).zip(&self.of_row) {
            for (k, (v, m)) in row.iter().zip(&means[g * per..(g + 1) * per]).enumerate() {
                sq[k] += (v - m) * (v - m);
            }
        }
        let dof = self.repeated();
        let rms = sq.iter().map(|s| (s / dof.max(1) as f64).sqrt()).collect();
        (rms, dof)
    }

    /// Do the repeats scatter as fresh readings of noise σ (`white`, one
    /// per reading of a pose, or one for all)? No when some reading
    /// scatters less than its σ allows: below the 1 % point of σ²·χ²(dof)
    /// / dof, shared over the readings (copies of a row scatter by
    /// nothing). No where a σ is not positive (nothing there averages).
    pub fn fresh(&self, values: &[f64], per: usize, white: &[f64]) -> bool {
        let (rms, dof) = self.scatter(values, per);
        if dof == 0 || white.is_empty() {
            return false;
        }
        let Ok(chi) = ChiSquared::new(dof as f64) else {
            return false;
        };
        let low = chi.inverse_cdf(0.01 / per as f64) / dof as f64;
        rms.iter().enumerate().all(|(k, s)| {
            let sigma = white[if white.len() == 1 { 0 } else { k }];
            sigma > 0.0 && (s / sigma).powi(2) >= low
        })
    }

    /// A steady offset between a pose's loggings, as a log homed again
    /// (or a sensor that slipped between passes) puts there: for each
    /// logging o ≥ 2 (a pose's o-th row) and each reading, the mean of the
    /// differences from the pose's first row over the poses logged o
    /// times, against their own scatter (Student's t, two-sided, 1 %
    /// shared over the tests). Fresh readings, curves and interpolation
    /// included, differ from their first logging by noise about zero.
    /// The strongest offset beyond its point, if any. O(n) in rows.
    pub fn offset(&self, values: &[f64], per: usize) -> Option<Offset> {
        assert_eq!(values.len(), self.of_row.len() * per);
        let most = self.counts.iter().copied().max().unwrap_or(0);
        if most < 2 {
            return None;
        }
        let (n, mean) = self.logging_means(values, per, most);
        let mut sq = vec![0.0; most * per];
        self.differences(values, per, &mut |_, o, k, d| {
            let e = d - mean[o * per + k];
            sq[o * per + k] += e * e;
        });
        let tested: Vec<usize> = (1..most).filter(|&o| n[o] >= 2).collect();
        let tests = (tested.len() * per) as f64;
        let mut strongest: Option<(f64, Offset)> = None;
        for &o in &tested {
            let Ok(t_dist) = StudentsT::new(0.0, 1.0, (n[o] - 1) as f64) else {
                continue;
            };
            let point = t_dist.inverse_cdf(1.0 - 0.005 / tests);
            for k in 0..per {
                let (m, s) = (
                    mean[o * per + k],
                    (sq[o * per + k] / (n[o] - 1) as f64).sqrt(),
                );
                let t = if s > 0.0 {
                    m / (s / (n[o] as f64).sqrt())
                } else if m != 0.0 {
                    m.signum() * f64::INFINITY
                } else {
                    0.0
                };
                let beyond = t.abs() / point;
                if beyond > 1.0 && strongest.as_ref().is_none_or(|(b, _)| beyond > *b) {
                    let found = Offset {
                        reading: k,
                        logging: o + 1,
                        mean: m,
                        t,
                        poses: n[o],
                    };
                    strongest = Some((beyond, found));
                }
            }
        }
        strongest.map(|(_, o)| o)
    }

    /// Each row after its pose's first: `f(row, logging − 1, reading,
    /// difference from the first row)`, rows in order.
    fn differences(&self, values: &[f64], per: usize, f: &mut dyn FnMut(usize, usize, usize, f64)) {
        let mut seen = vec![0usize; self.first.len()];
        for (i, &g) in self.of_row.iter().enumerate() {
            let o = seen[g];
            seen[g] += 1;
            if o == 0 {
                continue;
            }
            let (row, first) = (i * per, self.first[g] * per);
            for k in 0..per {
                f(i, o, k, values[row + k] - values[first + k]);
            }
        }
    }

    /// Per logging (index o − 1 for the o-th, `most` of them) the rows
    /// in it, and per logging and reading the mean difference from the
    /// pose's first row (0 for the first logging).
    fn logging_means(&self, values: &[f64], per: usize, most: usize) -> (Vec<usize>, Vec<f64>) {
        let mut n = vec![0usize; most];
        let mut sum = vec![0.0; most * per];
        self.differences(values, per, &mut |_, o, k, d| {
            sum[o * per + k] += d;
            if k == 0 {
                n[o] += 1;
            }
        });
        let mean = (0..most * per)
            .map(|i| sum[i] / n[i / per].max(1) as f64)
            .collect();
        (n, mean)
    }

    /// `values` less each logging's mean offset from the pose's first row
    /// ([`Repeats::offset`]'s means): what the repeats scatter by about
    /// their pose once the offsets are taken out.
    pub fn without_offsets(&self, values: &[f64], per: usize) -> Vec<f64> {
        let most = self.counts.iter().copied().max().unwrap_or(0);
        let (_, mean) = self.logging_means(values, per, most);
        let mut out = values.to_vec();
        self.differences(values, per, &mut |i, o, k, _| {
            out[i * per + k] -= mean[o * per + k];
        });
        out
    }

    /// How the repeats count and the note identify prints (None when no
    /// row repeats); `Err` a sentence refusing the log. A steady offset
    /// between loggings ([`Repeats::offset`]) is not fresh: where every
    /// pose is logged equally often their means share one offset, as one
    /// logging's would, and each pose counts once at its mean; otherwise
    /// the log is refused. Else [`Repeats::fresh`] with σ `white` (stated
    /// by `what`, one per reading of a pose or one for all): the note says
    /// the scatter in units of σ at the reading that scatters most so,
    /// with its RMS and σ in its own unit (`units`, each reading's name
    /// and scale from `values`' unit), where every reading's σ is stated,
    /// else the largest RMS in its unit.
    pub fn judged(
        &self,
        (values, per): (&[f64], usize),
        white: &[f64],
        what: &str,
        units: &[Unit],
    ) -> Result<(Counted, Option<String>), String> {
        if self.repeated() == 0 {
            return Ok((Counted::Once, None));
        }
        assert_eq!(units.len(), per, "one unit per reading");
        if let Some(off) = self.offset(values, per) {
            let u = &units[off.reading];
            let nth = ordinal(off.logging);
            let steady = |whose: &str| {
                format!(
                "{whose} {nth} logging reads a steady {:+.3}{} of {} off the pose's first ({} over {} poses, beyond the 1 % point), as a log homed again does",
                off.mean * u.scale,
                u.symbol,
                u.name,
                match off.t.is_finite() {
                    true => format!("t = {:.1}", off.t),
                    false => "no scatter about it".to_string(),
                },
                off.poses
            )
            };
            let least = self.counts.iter().copied().min().unwrap_or(0);
            let most = self.counts.iter().copied().max().unwrap_or(0);
            if least != most {
                return Err(format!(
                    "{}, and its poses are not all logged equally often ({least} to {most} times), so their means would not share one offset: identify each homing's log on its own",
                    steady("its poses'")
                ));
            }
            // Fresh about their offsets, the loggings' noise averages;
            // copies with an offset average nothing.
            let fresh = self.fresh(&self.without_offsets(values, per), per, white);
            let (counted, averaged) = match fresh {
                true => (
                    Counted::Means(most),
                    format!("its fresh noise stated √{most} smaller"),
                ),
                false => (
                    Counted::Once,
                    "as one reading (about their offsets they scatter less than fresh readings would, or no σ says)".to_string(),
                ),
            };
            let note = format!(
                "note: {} of the log's {} rows repeat a pose (its {} distinct poses logged {most} times each), and {}: each pose is fitted once, at the mean of its {most} loggings, {averaged} (every pose is logged equally often, so the means share one offset, as one logging's would)",
                self.repeated(),
                self.of_row.len(),
                self.first.len(),
                steady("their")
            );
            return Ok((counted, Some(note)));
        }
        let fresh = self.fresh(values, per, white);
        let (rms, dof) = self.scatter(values, per);
        let sigma = |k: usize| {
            let at = if white.len() == 1 { 0 } else { k };
            white.get(at).copied().unwrap_or(0.0)
        };
        let stated = (0..per).all(|k| sigma(k) > 0.0);
        let most = |key: &dyn Fn(usize) -> f64| {
            (0..per)
                .max_by(|&a, &b| key(a).total_cmp(&key(b)))
                .unwrap_or(0)
        };
        let over = format!("over {dof} degrees of freedom");
        let said = if stated {
            let k = most(&|k| rms[k] / sigma(k));
            let u = &units[k];
            let ratio = rms[k] / sigma(k);
            let about = format!(
                "by up to {ratio:.2} σ, at {} ({:.3}{unit} RMS about their pose's mean {over}; σ = {:.3}{unit}, from {what})",
                u.name,
                rms[k] * u.scale,
                sigma(k) * u.scale,
                unit = u.symbol
            );
            match fresh {
                true => about,
                false => format!(
                    "{about}, less than fresh readings would: copies, or a value the controller logged again"
                ),
            }
        } else {
            let k = most(&|k| rms[k] * units[k].scale);
            let u = &units[k];
            format!(
                "by up to {:.3}{} RMS about their pose's mean, at {} ({over}), with no σ stated for every reading to tell fresh readings from copies",
                rms[k] * u.scale,
                u.symbol,
                u.name
            )
        };
        let counted = if fresh { Counted::Rows } else { Counted::Once };
        Ok((counted, self.note(fresh, &said)))
    }

    /// What identify says when rows repeat (None when none does): how the
    /// repeats were counted, `fresh` or not, with their scatter in words
    /// (`said`: "by … RMS …").
    pub fn note(&self, fresh: bool, said: &str) -> Option<String> {
        let (rows, poses) = (self.of_row.len(), self.first.len());
        let most = self.counts.iter().copied().max().unwrap_or(0);
        let least = self.counts.iter().copied().min().unwrap_or(0);
        let times = match least == most {
            true => format!("{most} times each"),
            false => format!("up to {most} times"),
        };
        (self.repeated() > 0).then(|| match fresh {
            true => format!(
                "note: {} of the log's {rows} rows repeat a pose (its {poses} distinct poses logged {times}) and scatter {said}, as fresh readings do: each counts as a reading (it averages the noise, not the sensors' error at that pose), and the held-out check leaves out whole poses",
                self.repeated()
            ),
            false => format!(
                "note: {} of the log's {rows} rows repeat a pose (its {poses} distinct poses logged {times}) and scatter {said}: each pose is fitted once, at the mean of its readings, as one reading",
                self.repeated()
            ),
        })
    }
}

/// How a log's repeated poses count ([`Repeats::judged`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Counted {
    /// Each row a reading: fresh readings of the stated noise.
    Rows,
    /// Each pose once, at the mean of its `n` loggings (a steady offset
    /// between them): their fresh noise, σ/√n, averaged.
    Means(usize),
    /// Each pose once, at its mean, as one reading (copies, or no repeat).
    Once,
}

/// A reading as the repeats' note names it: its symbol ("ψ4"), and its
/// unit (a value in the log's unit times `scale` is in `symbol`'s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Unit<'a> {
    pub name: &'a str,
    pub scale: f64,
    pub symbol: &'a str,
}

/// A steady offset between loggings ([`Repeats::offset`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Offset {
    /// Which of a pose's readings.
    pub reading: usize,
    /// Which logging (2: a pose's second row).
    pub logging: usize,
    /// The mean difference from the pose's first row (the log's unit).
    pub mean: f64,
    /// Student's t of that mean.
    pub t: f64,
    /// The poses logged that often.
    pub poses: usize,
}

/// "first", "second", "third", then "4th" … "11th", "21st", "22nd".
fn ordinal(n: usize) -> String {
    let suffix = match (n % 10, n % 100) {
        (_, 11..=13) => "th",
        (1, _) => "st",
        (2, _) => "nd",
        (3, _) => "rd",
        _ => "th",
    };
    match n {
        1 => "first".into(),
        2 => "second".into(),
        3 => "third".into(),
        _ => format!("{n}{suffix}"),
    }
}

#[cfg(test)]
#[path = "repeats_tests.rs"]
mod tests;
