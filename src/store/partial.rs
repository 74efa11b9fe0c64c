//! The codec of [`Partial`]: `partial.bin` of a shard, and the body of each
//! record of a resumable run's block log. The header states the errors a
//! calibration estimates, so the codec is any mechanism's.

use crate::montecarlo::partial::{
    Partial, BUDGET_TERMS, DV_PER_CALIBRATION, ORIENTATION_PER_CALIBRATION,
};

const PARTIAL_MAGIC: &[u8; 8] = b"TCPART05";

/// Do `bytes` open as a partial of another format version (an earlier or
/// later build of the tool)?
pub fn other_version(bytes: &[u8]) -> bool {
    bytes.len() >= 8 && bytes[..6] == PARTIAL_MAGIC[..6] && bytes[..8] != PARTIAL_MAGIC[..]
}

/// The header's word of what is judged per calibration: position over the
/// workspace (volumetric), and orientation too (oriented). A study that
/// judges position alone writes 0 or 1, as the format always has.
const VOLUMETRIC: u64 = 1;
const ORIENTED: u64 = 2;

/// The length of [`encode`] for these dimensions, `errors` a calibration
/// (u128: no overflow whatever a damaged header says).
pub fn encoded_len(
    trials: u64,
    grades: u64,
    (volumetric, oriented): (bool, bool),
    blocks: u64,
    errors: u64,
) -> u128 {
    let (t, g, b) = (trials as u128, grades as u128, blocks as u128);
    let calib = t * g;
    8 + 6 * 8
        + g
        + 8 * t
        + 8 * calib
        + if volumetric {
            8 * DV_PER_CALIBRATION as u128 * calib
        } else {
            0
        }
        + if oriented {
            8 * ORIENTATION_PER_CALIBRATION as u128 * calib
        } else {
            0
        }
        + calib
        + 4 * b * g * errors as u128 * 8
        + b * g * (BUDGET_TERMS as u128 + 2) * 8
}

/// `partial.bin`: the binary form (little-endian) of a shard's partial, and
/// a block's record in the block log.
pub fn encode(p: &Partial) -> Vec<u8> {
    let mut b = Vec::with_capacity(64 + p.mu.len() * 9 + p.mu0.len() * 8 + p.dv.len() * 8);
    b.extend_from_slice(PARTIAL_MAGIC);
    for v in [
        p.first_trial,
        p.trials,
        p.grades as u64,
        p.volumetric as u64 * VOLUMETRIC + p.oriented as u64 * ORIENTED,
        p.blocks() as u64,
        p.errors as u64,
    ] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&p.rank);
    for v in (p.mu0.iter().chain(&p.mu).chain(&p.dv)).chain(&p.orientation) {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&p.failure);
    for v in p.block_err_sum.iter().chain(&p.block_err_sq) {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for v in p.block_budget.iter().flatten() {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for n in &p.block_budget_n {
        b.extend_from_slice(&n.to_le_bytes());
    }
    for v in p.block_lin_sum.iter().chain(&p.block_lin_sq) {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for n in &p.block_lin_n {
        b.extend_from_slice(&n.to_le_bytes());
    }
    b
}

/// Parse [`encode`]; `None` when the bytes are not a complete partial.
pub fn decode(b: &[u8]) -> Option<Partial> {
    let mut pos = 0usize;
    let mut take = |n: usize| -> Option<&[u8]> {
        let s = b.get(pos..pos.checked_add(n)?)?;
        pos += n;
        Some(s)
    };
    if take(8)? != PARTIAL_MAGIC {
        return None;
    }
    let mut u = || -> Option<u64> { Some(u64::from_le_bytes(take(8)?.try_into().ok()?)) };
    let (first_trial, trials, grades, judged, blocks, errors) = (
        u()?,
        u()?,
        u()? as usize,
        u()?,
        u()? as usize,
        u()? as usize,
    );
    if judged & !(VOLUMETRIC | ORIENTED) != 0 {
        return None;
    }
    let (volumetric, oriented) = (judged & VOLUMETRIC != 0, judged & ORIENTED != 0);
    let calib = (trials as usize).checked_mul(grades)?;
    let rank = take(grades)?.to_vec();
    let f64s = |s: &[u8]| -> Vec<f64> {
        s.chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
            .collect()
    };
    let mu0 = f64s(take((trials as usize).checked_mul(8)?)?);
    let mu = f64s(take(calib.checked_mul(8)?)?);
    let dv = if volumetric {
        f64s(take(calib.checked_mul(8 * DV_PER_CALIBRATION)?)?)
    } else {
        Vec::new()
    };
    let orientation = if oriented {
        f64s(take(calib.checked_mul(8 * ORIENTATION_PER_CALIBRATION)?)?)
    } else {
        Vec::new()
    };
    let failure = take(calib)?.to_vec();
    let vecs = |n: usize, take: &mut dyn FnMut(usize) -> Option<Vec<u8>>| -> Option<Vec<f64>> {
        let raw = take(n.checked_mul(grades)?.checked_mul(errors.checked_mul(8)?)?)?;
        Some(f64s(&raw))
    };
    let mut take_vec = |n: usize| take(n).map(|s| s.to_vec());
    let block_err_sum = vecs(blocks, &mut take_vec)?;
    let block_err_sq = vecs(blocks, &mut take_vec)?;
    let cells = blocks.checked_mul(grades)?;
    let block_budget = f64s(&take_vec(cells.checked_mul(BUDGET_TERMS * 8)?)?)
        .chunks_exact(BUDGET_TERMS)
        .map(|c| [c[0], c[1], c[2], c[3], c[4]])
        .collect();
    let u64s = |raw: Vec<u8>| -> Vec<u64> {
        raw.chunks_exact(8)
            .map(|c| u64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
            .collect()
    };
    let block_budget_n = u64s(take_vec(cells.checked_mul(8)?)?);
    let block_lin_sum = vecs(blocks, &mut take_vec)?;
    let block_lin_sq = vecs(blocks, &mut take_vec)?;
    let block_lin_n = u64s(take_vec(cells.checked_mul(8)?)?);
    if pos != b.len() {
        return None;
    }
    Some(Partial {
        first_trial,
        trials,
        grades,
        errors,
        volumetric,
        oriented,
        mu0,
        mu,
        failure,
        rank,
        dv,
        orientation,
        block_err_sum,
        block_err_sq,
        block_budget,
        block_budget_n,
        block_lin_sum,
        block_lin_sq,
        block_lin_n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::montecarlo::partial::tests::sample;

    #[test]
    fn codec_round_trips_and_rejects_damage() {
        for (volumetric, oriented) in [(false, false), (true, false), (true, true)] {
            let p = sample(8192, volumetric, oriented);
            assert_eq!(p.trials, 3);
            let bytes = encode(&p);
            let e = crate::montecarlo::partial::tests::SAMPLE_ERRORS as u64;
            let judged = (volumetric, oriented);
            assert_eq!(encoded_len(3, 2, judged, 1, e), bytes.len() as u128);
            // A study judged by position alone writes the format's old word.
            assert_eq!(bytes[32], volumetric as u8 + 2 * oriented as u8);
            let mut unknown = bytes.clone();
            unknown[32] = 4;
            assert_eq!(decode(&unknown), None);
            assert_eq!(decode(&bytes), Some(p.clone()));
            assert_eq!(decode(&bytes[..bytes.len() - 1]), None);
            let mut longer = bytes.clone();
            longer.push(0);
            assert_eq!(decode(&longer), None);
            let mut magic = bytes.clone();
            magic[0] ^= 1;
            assert_eq!(decode(&magic), None);
            // Another build's format is told from damage.
            assert!(!other_version(&bytes) && !other_version(&magic));
            let mut earlier = bytes.clone();
            earlier[7] = b'4';
            assert!(other_version(&earlier));
            assert_eq!(decode(&earlier), None);
        }
    }
}
