//! The buyer's order: which of two combinations that both meet the target
//! to buy, for any mechanism. The Tricept's ranking ([`super::ranking`])
//! and any other mechanism's choice (`export::study_verdict::choose`) both
//! sort by it, so one study of either kind answers by the same rule:
//!
//! 1. the lower total price (no price counts as 0: a grade study);
//! 2. the fewer sensors fitted;
//! 3. the fewer poses (calibration time on the shop floor);
//! 4. the coarser grades, slot by slot (the encoder's ″, then the scale's
//!    µm): without prices the coarser grade is the cheaper one;
//! 5. a one-step estimator before an iterated one (Gauss–Newton);
//! 6. the more accurate: the smaller upper confidence limit of the deciding
//!    statistic;
//! 7. the estimator listed earlier (OLS, WLS, GLS; linear, GLS).
//!
//! The callers break what is left by their rows' order.
//!
//! Both pass over a fragile combination ([`fragile`]) and say how many
//! machines would settle one the study cannot decide on
//! ([`machines_to_decide`]).

use std::cmp::Ordering;

/// Which combinations are fragile: each `(sensors and estimator, poses,
/// meets, misses)` that meets the target while the same sensors and
/// estimator miss it beyond doubt (`misses`: its lower confidence limit,
/// where it has one, is beyond the target) with more poses. Its pass rests
/// on which poses were picked, not on the sensors, so neither verdict
/// chooses it; a miss the study cannot decide on makes nothing fragile.
/// O(n²) in the combinations, which a study counts in hundreds.
pub fn fragile<K: PartialEq>(rows: &[(K, usize, bool, bool)]) -> Vec<bool> {
    rows.iter()
        .map(|(k, poses, meets, _)| {
            *meets
                && rows
                    .iter()
                    .any(|(o, more, _, misses)| o == k && more > poses && *misses)
        })
        .collect()
}

/// Machines that would settle whether a statistic estimated at `value`
/// from `trials` machines, with the 95 % confidence limits `lower` and
/// `upper`, is within `threshold`: the interval's half-width on the
/// threshold's side shrinks as 1/√n until it no longer holds the
/// threshold; 10 % more for luck, rounded up to two significant figures.
/// None when the estimate sits on the threshold or the limit on its side
/// does not exist at this many machines.
pub fn machines_to_decide(
    trials: u64,
    value: f64,
    threshold: f64,
    (lower, upper): (Option<f64>, Option<f64>),
) -> Option<u64> {
    let gap = (threshold - value).abs();
    let half = if value <= threshold {
        upper? - value
    } else {
        value - lower?
    };
    if !(gap > 0.0 && half > 0.0) {
        return None;
    }
    let n = trials as f64 * (half / gap).powi(2) * 1.1;
    let mag = 10f64.powi((n.log10().floor() as i32 - 1).max(0));
    Some(((n / mag).ceil() * mag).min(1e12) as u64)
}

/// What the buyer's order compares of one combination.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Offer {
    /// Total price of its sensors (None: grades without prices).
    pub price: Option<f64>,
    /// Sensors fitted to the machine.
    pub fitted: usize,
    /// Calibration poses.
    pub poses: usize,
    /// Each sensor slot's grade (″ or µm; the larger the coarser), slots
    /// the mechanism does not have at 0.
    pub grades: [f64; 2],
    /// Calibrated by an iterated estimator (Gauss–Newton).
    pub iterated: bool,
    /// The deciding statistic's upper confidence limit (None: none at this
    /// many machines, ordered last).
    pub upper: Option<f64>,
    /// The estimator's place in the order studies list them.
    pub estimator: u8,
}

impl Offer {
    /// The buyer's order: `Less` when `self` is bought before `other`.
    pub fn buyer_cmp(&self, other: &Offer) -> Ordering {
        let price = |o: &Offer| o.price.unwrap_or(0.0);
        let upper = |o: &Offer| o.upper.unwrap_or(f64::INFINITY);
        price(self)
            .total_cmp(&price(other))
            .then(self.fitted.cmp(&other.fitted))
            .then(self.poses.cmp(&other.poses))
            .then(other.grades[0].total_cmp(&self.grades[0]))
            .then(other.grades[1].total_cmp(&self.grades[1]))
            .then(self.iterated.cmp(&other.iterated))
            .then(upper(self).total_cmp(&upper(other)))
            .then(self.estimator.cmp(&other.estimator))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> Offer {
        Offer {
            price: Some(1000.0),
            fitted: 3,
            poses: 20,
            grades: [4.0, 1.0],
            iterated: false,
            upper: Some(0.01),
            estimator: 1,
        }
    }

    /// Each key decides when every key before it ties, and not before: a
    /// change that would win on a later key loses to an earlier one.
    #[test]
    fn each_key_decides_in_turn() {
        let b = base();
        // Better on key k (the first offer), worse on every key after it.
        let better_then_worse: [(Offer, Offer); 8] = [
            (
                Offer {
                    price: Some(900.0),
                    fitted: 4,
                    poses: 30,
                    grades: [1.0, 0.5],
                    iterated: true,
                    upper: Some(0.02),
                    estimator: 2,
                },
                b,
            ),
            (
                Offer {
                    fitted: 2,
                    poses: 30,
                    grades: [1.0, 0.5],
                    iterated: true,
                    upper: Some(0.02),
                    estimator: 2,
                    ..b
                },
                b,
            ),
            (
                Offer {
                    poses: 10,
                    grades: [1.0, 0.5],
                    iterated: true,
                    upper: Some(0.02),
                    estimator: 2,
                    ..b
                },
                b,
            ),
            (
                Offer {
                    grades: [8.0, 0.5],
                    iterated: true,
                    upper: Some(0.02),
                    estimator: 2,
                    ..b
                },
                b,
            ),
            (
                Offer {
                    grades: [4.0, 2.0],
                    iterated: true,
                    upper: Some(0.02),
                    estimator: 2,
                    ..b
                },
                b,
            ),
            (
                b,
                Offer {
                    iterated: true,
                    upper: Some(0.001),
                    estimator: 0,
                    ..b
                },
            ),
            (
                Offer {
                    upper: Some(0.005),
                    estimator: 2,
                    ..b
                },
                b,
            ),
            (Offer { estimator: 0, ..b }, b),
        ];
        for (k, (first, second)) in better_then_worse.iter().enumerate() {
            assert_eq!(first.buyer_cmp(second), Ordering::Less, "key {k}");
            assert_eq!(second.buyer_cmp(first), Ordering::Greater, "key {k}");
        }
        assert_eq!(b.buyer_cmp(&b), Ordering::Equal);
    }

    /// The machines to decide, by hand: 1,000 machines, p95 0.018 with
    /// its upper limit 0.021 against 0.02 → 1000 × (0.003/0.002)² × 1.1 =
    /// 2475 → 2500; from above, the lower limit's side; none on the
    /// threshold or without the limit.
    #[test]
    fn machines_to_decide_by_hand() {
        let lim = (Some(0.016), Some(0.021));
        assert_eq!(machines_to_decide(1000, 0.018, 0.02, lim), Some(2500));
        // 0.023 above 0.02, lower limit 0.0215: 1000 × (1.5/3)² × 1.1 = 275.
        assert_eq!(
            machines_to_decide(1000, 0.023, 0.02, (Some(0.0215), None)),
            Some(280)
        );
        // Under 100: whole machines; under 10 too (1 × 2.25 × 1.1 = 2.475
        // → 3, not 2.5 cut to 2).
        assert_eq!(machines_to_decide(10, 0.018, 0.02, lim), Some(25));
        assert_eq!(machines_to_decide(1, 0.018, 0.02, lim), Some(3));
        assert_eq!(machines_to_decide(1000, 0.02, 0.02, lim), None);
        assert_eq!(
            machines_to_decide(1000, 0.018, 0.02, (Some(0.01), None)),
            None
        );
        assert_eq!(
            machines_to_decide(1000, 0.023, 0.02, (None, Some(0.03))),
            None
        );
    }

    /// Fragile: met with few poses, missed beyond doubt with more by the
    /// same sensors and estimator; not when the miss is another's, with
    /// fewer poses, or undecided.
    #[test]
    fn fragile_is_a_pass_that_more_poses_undo() {
        let rows = [
            ("a", 12, true, false), // a misses at 20: fragile
            ("a", 20, false, true),
            ("a", 30, true, false), // nothing larger misses: firm
            ("b", 12, true, false), // the miss at 20 is a's: firm
            ("c", 12, false, true), // misses: never fragile
            ("c", 20, true, false), // c misses with fewer poses only: firm
            ("d", 12, true, false), // d's larger miss is undecided: firm
            ("d", 20, false, false),
        ];
        assert_eq!(
            fragile(&rows),
            [true, false, false, false, false, false, false, false]
        );
    }

    /// No price is a grade study's 0; no upper limit comes after any.
    #[test]
    fn missing_prices_and_limits() {
        let b = base();
        let free = Offer {
            price: None,
            poses: 50,
            ..b
        };
        assert_eq!(
            free.buyer_cmp(&Offer {
                price: Some(1.0),
                ..b
            }),
            Ordering::Less
        );
        let grade = |g: f64| Offer {
            price: None,
            grades: [g, 0.0],
            ..b
        };
        assert_eq!(grade(8.0).buyer_cmp(&grade(2.0)), Ordering::Less);
        let unbounded = Offer { upper: None, ..b };
        assert_eq!(b.buyer_cmp(&unbounded), Ordering::Less);
        assert_eq!(unbounded.buyer_cmp(&unbounded), Ordering::Equal);
    }
}
