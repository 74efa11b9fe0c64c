//! The calibration poses of a pose count (`[sweep] pose_counts`): which
//! poses a subset takes and the rows of the observation they give (their
//! nominal poses for Gauss–Newton are the mechanism's to pick).

/// The calibration poses of one pose count: which poses, and which rows of
/// the full observation they give.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseSubset {
    pub poses: Vec<usize>,
    /// Rows of l (`per_pose` a pose after the reference); all rows when `full`.
    pub rows: Vec<usize>,
    pub full: bool,
}

impl PoseSubset {
    /// `count` of `total` poses by [`spread_poses`], of a mechanism that
    /// reads `per_pose` readings a pose.
    pub fn new(total: usize, count: usize, per_pose: usize) -> Self {
        let poses = spread_poses(total, count);
        let rows = poses[1..]
            .iter()
            .flat_map(|&p| (per_pose * (p - 1))..(per_pose * p))
            .collect();
        PoseSubset {
            poses,
            rows,
            full: count == total,
        }
    }

    /// This subset's rows of `from`: `from` itself when the subset is every
    /// pose, else the rows gathered into `buf` (no allocation).
    #[inline]
    pub fn rows_of<'a>(&self, from: &'a [f64], buf: &'a mut [f64]) -> &'a [f64] {
        if self.full {
            return from;
        }
        for (t, &r) in buf.iter_mut().zip(&self.rows) {
            *t = from[r];
        }
        &buf[..self.rows.len()]
    }
}

/// The poses of a pose-count study (docs/method.md §10): the reference
/// (pose 0) and the `count − 1` poses at indices round(k·(total − 1)/(count − 1)),
/// k = 1 … count − 1, spread evenly along the config's pose list (for the
/// default pattern: across layers and rings). Deterministic; `count = total`
/// gives every pose.
pub fn spread_poses(total: usize, count: usize) -> Vec<usize> {
    if count >= total {
        return (0..total).collect();
    }
    let step = (total - 1) as f64 / (count - 1) as f64;
    (0..count)
        .map(|k| (k as f64 * step).round() as usize)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A subset's rows are its poses' readings after the reference, as many
    /// a pose as the mechanism reads (3 for the Tricept, 12 for a hexapod).
    #[test]
    fn a_subset_reads_its_poses_rows_whatever_the_readings_a_pose() {
        for per in [1, 3, 12] {
            let s = PoseSubset::new(9, 5, per);
            assert_eq!(s.poses, vec![0, 2, 4, 6, 8]);
            assert!(!s.full);
            let want: Vec<usize> = [2, 4, 6, 8]
                .iter()
                .flat_map(|&p| per * (p - 1)..per * p)
                .collect();
            assert_eq!(s.rows, want);
            assert_eq!(s.rows.len(), 4 * per);
            let all = PoseSubset::new(9, 9, per);
            assert!(all.full && all.rows.len() == 8 * per);
            let from: Vec<f64> = (0..8 * per).map(|k| k as f64).collect();
            let mut buf = vec![0.0; 8 * per];
            let got = s.rows_of(&from, &mut buf);
            assert_eq!(got.len(), 4 * per);
            // Pose 2's first reading is row per·1, pose 4's row per·3.
            assert_eq!((got[0], got[per]), (per as f64, (3 * per) as f64));
        }
    }
}
