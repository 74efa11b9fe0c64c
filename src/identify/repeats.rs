//! Rows of a log that repeat a pose. A repeat reads the sensors again at
//! the same angles: it averages their noise, but not their error at those
//! angles (an encoder's curve and interpolation error come back with the
//! pose). Counted as independent rows, repeats would shrink the stated
//! uncertainty by √k while the error they share stays, and a held-out fold
//! would predict a pose the fit had read. So identify fits each distinct
//! pose once, at the mean of its readings, stated as one reading.
//!
//! Poses are the same when their commanded targets are equal to the bit
//! (a log repeats a commanded pose exactly). O(n) in rows.

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

    /// What identify says when rows repeat (None when none does).
    pub fn note(&self) -> Option<String> {
        let (rows, poses) = (self.of_row.len(), self.first.len());
        let most = self.counts.iter().copied().max().unwrap_or(0);
        (self.repeated() > 0).then(|| {
            format!(
                "note: {} of the log's {rows} rows repeat a pose logged before (up to {most} times): each of its {poses} distinct poses is fitted once, at the mean of its readings, as one reading (a repeat averages the sensors' noise but not their error at that pose, which comes back with it; counted as independent rows, repeats would state the accuracy too small)",
                self.repeated()
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_group_by_their_exact_target_in_first_appearance_order() {
        // Targets of width 2: poses A, B, A, C, B, A (−0.0 is 0.0).
        let t = [1.0, 0.0, 2.0, 5.0, 1.0, -0.0, 3.0, 3.0, 2.0, 5.0, 1.0, 0.0];
        let r = Repeats::of(&t, 2);
        assert_eq!(r.first, vec![0, 1, 3]);
        assert_eq!(r.of_row, vec![0, 1, 0, 2, 1, 0]);
        assert_eq!(r.counts, vec![3, 2, 1]);
        assert_eq!(r.repeated(), 3);
        // A target differing in the last bit is another pose.
        let near = [1.0, 0.0, 1.0, f64::from_bits(1)];
        assert_eq!(Repeats::of(&near, 2).repeated(), 0);
        assert!(Repeats::of(&near, 2).note().is_none());
        let note = r.note().unwrap();
        assert!(note.contains("3 of the log's 6 rows") && note.contains("its 3 distinct poses"));
        assert!(note.contains("up to 3 times"));
    }

    #[test]
    fn means_average_each_pose_readings() {
        let r = Repeats::of(&[1.0, 2.0, 1.0, 1.0], 1);
        // Two readings a row: pose 1 is rows 0, 2, 3; pose 2 is row 1.
        let v = [1.0, 10.0, 7.0, 70.0, 2.0, 20.0, 6.0, 60.0];
        assert_eq!(r.means(&v, 2), vec![3.0, 30.0, 7.0, 70.0]);
    }
}
