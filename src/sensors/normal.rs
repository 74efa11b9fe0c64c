//! Standard normal draws for the datasheet kernel: the draws of
//! `rand_distr::StandardNormal`, bit for bit, with its common case written
//! out in the caller's loop.
//!
//! `StandardNormal` is the ziggurat of Marsaglia and Tsang: one `u64` gives
//! a layer i (its low 8 bits) and u in [−1, 1) (its top 52), x = u·X[i], and
//! x is returned when |x| < X[i+1] (about 99 % of draws); otherwise it goes
//! on to the wedge or the tail, with more draws. [`Normals::fill`] does the
//! common case itself and, for any other draw, rewinds the generator to
//! where that draw started and hands it to `StandardNormal`: every value,
//! and the generator's state after it, are `StandardNormal`'s. The layer
//! widths X are not public; they are read from `StandardNormal` itself
//! ([`Normals::probe`]) by handing it draws of known u, since u·X[i] with u
//! a power of two is exact. The tests hold [`Normals::fill`] to
//! `StandardNormal` over a million draws.

use rand::{Rng, TryRng};
use rand_distr::{Distribution, StandardNormal};
use std::convert::Infallible;
use std::sync::OnceLock;

/// The layers whose width and the next one's are both read: 0 … 253 (the
/// next width of layer 254 is the top layer's, which `StandardNormal` never
/// returns through the common case, so it cannot be read exactly; layers
/// 254 and 255 always go to `StandardNormal`).
const LAYERS: usize = 254;

/// The 52 top bits of a draw for u = 2⁻²⁰: the double 3 + 2⁻²⁰, whose
/// fraction field is 2⁵¹ + 2³¹, less 3.
const U_PROBE: u64 = (1 << 51) | (1 << 31);

/// The top 52 bits of the two draws each layer is checked at: u = 2·(1 +
/// bits/2⁵²) − 3, about −0.38 and 0.29.
const CHECKS: [u64; 2] = [0x4_F0F0_F0F0_F0F1, 0xA_5A5A_5A5A_5A5B];

/// `StandardNormal`'s layer widths X[0] … X[254], read from it, and each
/// layer's bound of the common case: X[i+1] where the layer is confirmed,
/// 0 (no draw is below it: all go to `StandardNormal`) for the top two and
/// any layer the check rejects. Both tables have all 256 layers, so that a
/// draw's layer bits index them with no test.
#[derive(Debug, Clone)]
pub struct Normals {
    width: [f64; 256],
    limit: [f64; 256],
}

/// A generator that returns one chosen value, then counts further calls.
struct Scripted {
    value: u64,
    calls: u32,
}

impl TryRng for Scripted {
    type Error = Infallible;
    fn try_next_u32(&mut self) -> Result<u32, Infallible> {
        Ok(self.try_next_u64()? as u32)
    }
    fn try_next_u64(&mut self) -> Result<u64, Infallible> {
        self.calls += 1;
        // After the chosen draw: u near 1 in layer 0, so that whatever
        // `StandardNormal` does next it ends (in its tail or its wedge).
        Ok(if self.calls == 1 {
            self.value
        } else {
            0xFFFF_FFFF_FFFF_F000
        })
    }
    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Infallible> {
        for b in dst {
            *b = self.try_next_u64()? as u8;
        }
        Ok(())
    }
}

impl Normals {
    /// The shared table, read once.
    pub fn get() -> &'static Normals {
        static TABLE: OnceLock<Normals> = OnceLock::new();
        TABLE.get_or_init(Normals::probe)
    }

    /// Read `StandardNormal`'s layer widths: for each layer i, the draw
    /// with layer bits i and u = 2⁻²⁰ returns 2⁻²⁰·X[i] through the common
    /// case (2⁻²⁰·X[i] < X[i+1] for every layer below the top one), which
    /// must take exactly one `u64`. A layer that does not (some other
    /// `rand_distr`) gets width 0: its draws then all go to
    /// `StandardNormal`, which stays right, only slower.
    pub fn probe() -> Normals {
        let mut width = [0.0; 256];
        for (i, w) in width.iter_mut().enumerate().take(LAYERS + 1) {
            let mut rng = Scripted {
                value: (U_PROBE << 12) | i as u64,
                calls: 0,
            };
            let x: f64 = StandardNormal.sample(&mut rng);
            let read = x * 1_048_576.0;
            if rng.calls == 1 && read.is_finite() && read > 0.0 {
                *w = read;
            }
        }
        Normals::checked(width)
    }

    /// Each layer's common case checked against `StandardNormal` at two
    /// draws inside it (u ≈ −0.38 and u ≈ 0.29, with mixed low bits so that
    /// the product rounds): where these widths return a value,
    /// `StandardNormal` must return the same one from one `u64`; a layer
    /// that disagrees gets limit 0 (left to `StandardNormal`).
    fn checked(width: [f64; 256]) -> Normals {
        let mut limit = [0.0; 256];
        limit[..LAYERS].copy_from_slice(&width[1..=LAYERS]);
        for i in 0..LAYERS {
            for top in CHECKS {
                let value = (top << 12) | i as u64;
                let mut rng = Scripted { value, calls: 0 };
                let x: f64 = StandardNormal.sample(&mut rng);
                if let Some(fast) = (Normals { width, limit }).common(value) {
                    if rng.calls != 1 || fast.to_bits() != x.to_bits() {
                        limit[i] = 0.0;
                    }
                }
            }
        }
        Normals { width, limit }
    }

    /// The common case of the draw `bits`: x = u·X[i] when |x| < X[i+1]
    /// (the layer's limit).
    #[inline(always)]
    fn common(&self, bits: u64) -> Option<f64> {
        let i = (bits & 0xff) as usize;
        let u = f64::from_bits((bits >> 12) | 0x4000_0000_0000_0000) - 3.0;
        let x = u * self.width[i];
        (x.abs() < self.limit[i]).then_some(x)
    }

    /// Fill `out` with `StandardNormal` draws from `rng`, in order.
    #[inline(always)]
    pub fn fill<R: Rng + Clone>(&self, rng: &mut R, out: &mut [f64]) {
        // The generator's state in a local that is never borrowed in the
        // loop (so it stays in registers); the rare draw goes out of line.
        let mut state = rng.clone();
        for o in out.iter_mut() {
            let start = state.clone();
            let bits = state.next_u64();
            *o = match self.common(bits) {
                Some(x) => x,
                None => {
                    let x;
                    (state, x) = uncommon(start);
                    x
                }
            };
        }
        *rng = state;
    }
}

/// `StandardNormal`'s draw from `rng`, and the generator after it.
#[cold]
#[inline(never)]
fn uncommon<R: Rng>(mut rng: R) -> (R, f64) {
    let x = StandardNormal.sample(&mut rng);
    (rng, x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// A million draws from ten streams equal `StandardNormal`'s bit for
    /// bit, and leave the generator where it leaves it; every layer below
    /// the top two is read (so the common case is taken).
    #[test]
    fn the_draws_are_standard_normals_bit_for_bit() {
        let t = Normals::probe();
        assert!(t.width[..=LAYERS].iter().all(|&w| w > 0.0));
        assert!(t.limit[..LAYERS].iter().all(|&w| w > 0.0));
        assert_eq!((t.limit[LAYERS], t.limit[LAYERS + 1]), (0.0, 0.0));
        // The widths fall from the base layer's to the top's.
        let w = &t.width[..=LAYERS];
        assert!(w.windows(2).all(|w| w[0] > w[1]), "{w:?}");
        assert!((t.width[1] - 3.654_152_885_361_009).abs() < 1e-15);
        for seed in 0..10 {
            fills_as_standard_normal(&t, seed, 100_000);
        }
    }

    /// `n` draws of `t.fill` from stream `seed` equal `StandardNormal`'s
    /// bit for bit and leave the generator where it leaves it.
    fn fills_as_standard_normal(t: &Normals, seed: u64, n: usize) {
        let mut a = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut b = a.clone();
        let mut out = vec![0.0; n];
        t.fill(&mut a, &mut out);
        for &x in &out {
            let want: f64 = StandardNormal.sample(&mut b);
            assert_eq!(x.to_bits(), want.to_bits());
        }
        assert_eq!(a.next_u64(), b.next_u64());
    }

    /// The common case is taken (about 98 % of draws: 254 layers of 256,
    /// each below its next width's share) and, where taken, is
    /// `StandardNormal`'s value from one `u64`; the probe's checks pass
    /// for every layer.
    #[test]
    fn the_common_case_is_taken_and_is_standard_normals() {
        let t = Normals::probe();
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(9);
        let n = 200_000;
        let mut taken = 0;
        for _ in 0..n {
            let bits = rng.next_u64();
            if let Some(x) = t.common(bits) {
                taken += 1;
                let mut one = Scripted {
                    value: bits,
                    calls: 0,
                };
                let want: f64 = StandardNormal.sample(&mut one);
                assert_eq!((x.to_bits(), one.calls), (want.to_bits(), 1));
            }
        }
        let rate = taken as f64 / n as f64;
        assert!(rate > 0.97 && rate < 0.99, "{rate}");
        // The checks are inside each layer's common case (so they check).
        for i in 0..250 {
            for top in CHECKS {
                assert!(t.common((top << 12) | i as u64).is_some(), "layer {i}");
            }
        }
    }

    /// A wrong width is caught by the check and its layer left to
    /// `StandardNormal` (limit 0); the others are kept, and the draws are
    /// still `StandardNormal`'s.
    #[test]
    fn a_wrong_width_is_left_to_standard_normal() {
        let right = Normals::probe();
        let mut width = right.width;
        width[5] *= 1.0 + 1e-15;
        width[40] *= 0.5;
        let t = Normals::checked(width);
        for i in 0..256 {
            // A layer's limit is the next width as given (layer 4's is the
            // perturbed one: its common case still gives the same values).
            let want = match i {
                5 | 40 => 0.0,
                i if i < LAYERS => width[i + 1],
                _ => 0.0,
            };
            assert_eq!(t.limit[i].to_bits(), want.to_bits(), "layer {i}");
            assert_eq!(t.width[i].to_bits(), width[i].to_bits(), "layer {i}");
        }
        assert_ne!(width[5], right.width[5]);
        fills_as_standard_normal(&t, 6, 100_000);
        // A layer given width 0 (the reading failed) is left alone too:
        // its draws would otherwise all be 0.
        let mut width = right.width;
        width[7] = 0.0;
        let t = Normals::checked(width);
        assert_eq!(t.limit[7], 0.0);
        fills_as_standard_normal(&t, 7, 100_000);
    }

    /// A layer the reading could not confirm goes to `StandardNormal`: a
    /// table of zeros still gives its draws.
    #[test]
    fn an_unread_table_still_gives_standard_normals() {
        let t = Normals::checked([0.0; 256]);
        fills_as_standard_normal(&t, 5, 1000);
    }
}
