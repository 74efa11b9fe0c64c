//! The two pieces of arithmetic datasheet sensors need at every pose of
//! every trial, written so that a loop over poses compiles to straight-line
//! code (no libm call, no branch): rounding to the nearest integer and the
//! sine and cosine of a whole number of turns.

/// 2⁵²: from here on every double is an integer; below it, adding and
/// subtracting 2⁵² (with the sign of x) rounds x to the nearest integer, ties
/// to even, in the FPU's own rounding.
const ROUND: f64 = 4_503_599_627_370_496.0;

/// `x` rounded to the nearest integer, ties to even (any finite `x`; values
/// of magnitude 2⁵² or more are integers already and are returned as they
/// are).
#[inline(always)]
pub fn round_even(x: f64) -> f64 {
    let m = ROUND.copysign(x);
    let r = (x + m) - m;
    if x.abs() < ROUND {
        r
    } else {
        x
    }
}

/// 1.5·2⁵²: adding and subtracting it rounds any |x| ≤ 2⁵¹ to the nearest
/// integer, ties to even, with no test of the sign or the magnitude.
const SHIFT: f64 = 6_755_399_441_055_744.0;

/// `x` rounded to the nearest integer, ties to even, for |x| ≤ 2⁵¹ (the
/// caller bounds it): [`round_even`] in two additions.
#[inline(always)]
pub fn round_small(x: f64) -> f64 {
    (x + SHIFT) - SHIFT
}

/// The bound of [`round_small`]: 2⁵¹.
pub const ROUND_SMALL_MAX: f64 = 2_251_799_813_685_248.0;

/// A sample quantised to the step `step` (> 0): the nearest multiple,
/// ties to even. `inverse` is 1/step, passed so that a loop computes it once.
#[inline(always)]
pub fn quantise(x: f64, step: f64, inverse: f64) -> f64 {
    round_even(x * inverse) * step
}

/// sin and cos of 2π·t. The whole turns are removed first (exactly: t minus
/// the nearest integer), so that the result keeps its accuracy however many
/// turns t holds; the rest is reduced to a quarter turn and evaluated by
/// fdlibm's minimax polynomials (error of a few units in the last place).
#[inline(always)]
pub fn sin_cos_turns(t: f64) -> (f64, f64) {
    // Quarter turns: q = nearest integer to 4·frac, r = the rest in radians.
    let frac = t - round_even(t);
    // q rounded by the shift 1.5·2⁵² (|4·frac| ≤ 2): the same integer as
    // round_even, and the shifted value's low bits are q mod 4 in two's
    // complement, read without a float-to-integer conversion (which SSE2
    // lacks for 64-bit lanes, so the loop stays vectorised).
    let y = 4.0 * frac + SHIFT;
    let q = y - SHIFT;
    let r = (frac - 0.25 * q) * std::f64::consts::TAU;
    let z = r * r;
    // fdlibm's coefficients as published (k_sin.c, k_cos.c).
    #[allow(clippy::excessive_precision)]
    const S: [f64; 6] = [
        -1.666_666_666_666_663_24e-1,
        8.333_333_333_322_489_46e-3,
        -1.984_126_982_985_794_93e-4,
        2.755_731_370_707_006_77e-6,
        -2.505_076_025_340_686_34e-8,
        1.589_690_995_211_550_10e-10,
    ];
    #[allow(clippy::excessive_precision)]
    const C: [f64; 6] = [
        4.166_666_666_666_660_19e-2,
        -1.388_888_888_887_410_96e-3,
        2.480_158_728_947_672_94e-5,
        -2.755_731_435_139_066_33e-7,
        2.087_572_321_298_174_83e-9,
        -1.135_964_755_778_819_48e-11,
    ];
    let sp = S[1] + z * (S[2] + z * (S[3] + z * (S[4] + z * S[5])));
    let s = r + r * z * (S[0] + z * sp);
    let cp = C[0] + z * (C[1] + z * (C[2] + z * (C[3] + z * (C[4] + z * C[5]))));
    let c = 1.0 - 0.5 * z + z * z * cp;
    // Quadrant q (mod 4): (s, c), (c, −s), (−s, −c), (−c, s); chosen by bit
    // masks, not branches (the quadrant of a random phase is unpredictable).
    let qi = y.to_bits();
    let swap = 0u64.wrapping_sub(qi & 1);
    let (sb, cb) = (s.to_bits(), c.to_bits());
    let a = (sb & !swap) | (cb & swap);
    let b = (cb & !swap) | (sb & swap);
    let sign_a = (qi & 2) << 62;
    let sign_b = (qi.wrapping_add(1) & 2) << 62;
    (f64::from_bits(a ^ sign_a), f64::from_bits(b ^ sign_b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn small_rounding_is_round_even_up_to_its_bound() {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(3);
        for _ in 0..100_000 {
            let x = rng.random_range(-1e3..1e3) * 10f64.powi(rng.random_range(-3..12));
            assert_eq!(round_small(x).to_bits(), round_even(x).to_bits(), "{x}");
            let tie = x.trunc() + 0.5;
            assert_eq!(round_small(tie), round_even(tie), "{tie}");
        }
        for x in [
            ROUND_SMALL_MAX,
            -ROUND_SMALL_MAX,
            ROUND_SMALL_MAX - 0.5,
            -(ROUND_SMALL_MAX - 1.5),
            2.5,
            -3.5,
        ] {
            assert_eq!(round_small(x), round_even(x), "{x}");
        }
    }

    #[test]
    fn rounding_is_to_the_nearest_integer_with_ties_to_even() {
        for (x, want) in [
            (0.4, 0.0),
            (0.5, 0.0),
            (1.5, 2.0),
            (2.5, 2.0),
            (-0.5, 0.0),
            (-1.5, -2.0),
            (-2.6, -3.0),
            (1e300, 1e300),
            (-4.5e15, -4.5e15),
            (2_251_799_813_685_247.5, 2_251_799_813_685_248.0),
            // Between 2⁵¹ and 2⁵² doubles are half-integers apart.
            (2_251_799_813_685_248.5, 2_251_799_813_685_248.0),
            (-2_251_799_813_685_249.5, -2_251_799_813_685_250.0),
            (4_503_599_627_370_495.5, 4_503_599_627_370_496.0),
            (4_503_599_627_370_497.0, 4_503_599_627_370_497.0),
        ] {
            assert_eq!(round_even(x), want, "{x}");
        }
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(3);
        for _ in 0..10_000 {
            let x: f64 = rng.random_range(-1e6..1e6);
            assert_eq!(round_even(x), x.round_ties_even(), "{x}");
        }
        assert_eq!(quantise(0.37, 0.25, 4.0), 0.25);
        assert_eq!(quantise(-0.38, 0.25, 4.0), -0.5);
    }

    #[test]
    fn sine_and_cosine_of_turns_match_libm() {
        let mut rng = rand::rngs::Xoshiro256PlusPlus::seed_from_u64(4);
        let mut worst = 0.0f64;
        for i in 0..200_000 {
            // Small and large numbers of turns, and the quadrant edges.
            let t: f64 = match i % 3 {
                0 => rng.random_range(-2.0..2.0),
                1 => rng.random_range(-1e6..1e6),
                _ => (rng.random_range(-40..40) as f64) * 0.125,
            };
            let (s, c) = sin_cos_turns(t);
            // The reference: the fractional turn in radians, by libm.
            let x = (t - t.round()) * std::f64::consts::TAU;
            worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
        }
        assert!(worst < 5e-16, "{worst:e}");
        let (s, c) = sin_cos_turns(0.25);
        assert_eq!((s, c.abs() < 1e-16), (1.0, true));
        let (s, c) = sin_cos_turns(-0.5);
        assert!(s.abs() < 1e-15 && c == -1.0, "{s} {c}");
    }
}
