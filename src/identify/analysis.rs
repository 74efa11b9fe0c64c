//! Identifiability of a topology's errors (the mechanism's 15) from a pose set: rank, singular values,
//! condition number, and which parameters (or combinations) cannot be told
//! apart. Also the observability indices O1–O5 of the pose set.

use nalgebra::DMatrix;
use serde::Serialize;

/// The result of the analysis of one (weighted) design matrix.
#[derive(Debug, Clone, Serialize)]
pub struct Identifiability {
    /// Numerical rank of H.
    pub rank: usize,
    /// Number of parameters (15).
    pub parameters: usize,
    /// Relative tolerance used for rank decisions.
    pub rank_tolerance: f64,
    /// Singular values of the column-equilibrated H, descending.
    pub singular_values: Vec<f64>,
    /// σmax/σmin of the column-equilibrated H (infinite when rank-deficient).
    pub condition_number: f64,
    /// σmax/σmin over the parameters that are identified.
    pub condition_number_identifiable: f64,
    /// Column norms of H (sensitivity of the readings to each error).
    pub column_norms: Vec<f64>,
    /// Per parameter, in canonical order.
    pub identifiable: Vec<bool>,
    /// Names of the parameters that are not identified (estimate 0).
    pub unidentifiable: Vec<String>,
    /// Each null-space direction as a readable combination of errors.
    pub unidentifiable_combinations: Vec<String>,
    /// Observability indices of the equilibrated H (Borm & Menq; Nahvi & Hollerbach).
    pub observability: Observability,
}

/// Observability indices from the singular values σ1 ≥ … ≥ σL of the
/// equilibrated H with m rows: O1 = (σ1⋯σL)^(1/L)/√m (Borm & Menq 1991),
/// O2 = σL/σ1 (inverse condition number, Driels & Pathre), O3 = σL (minimum
/// singular value, Nahvi & Hollerbach 1996), O4 = σL²/σ1 (noise amplification
/// index, Nahvi & Hollerbach), O5 = 1/Σ(1/σi) (Sun & Hollerbach 2008).
#[derive(Debug, Clone, Copy, Serialize, Default)]
pub struct Observability {
    pub o1: f64,
    pub o2: f64,
    pub o3: f64,
    pub o4: f64,
    pub o5: f64,
}

impl Observability {
    pub fn from_singular_values(sv: &[f64], rows: usize) -> Self {
        let l = sv.len();
        if l == 0 || rows == 0 {
            return Self::default();
        }
        let s1 = sv[0];
        let sl = sv[l - 1];
        let log_mean = sv
            .iter()
            .map(|s| s.max(f64::MIN_POSITIVE).ln())
            .sum::<f64>()
            / l as f64;
        Observability {
            o1: log_mean.exp() / (rows as f64).sqrt(),
            o2: if s1 > 0.0 { sl / s1 } else { 0.0 },
            o3: sl,
            o4: if s1 > 0.0 { sl * sl / s1 } else { 0.0 },
            o5: if sl > 0.0 {
                1.0 / sv.iter().map(|s| 1.0 / s).sum::<f64>()
            } else {
                0.0
            },
        }
    }

    /// The index by name ("o1" … "o5").
    pub fn get(&self, name: &str) -> Option<f64> {
        match name {
            "o1" => Some(self.o1),
            "o2" => Some(self.o2),
            "o3" => Some(self.o3),
            "o4" => Some(self.o4),
            "o5" => Some(self.o5),
            _ => None,
        }
    }
}

/// Singular values (descending) and right singular vectors (as columns, same
/// order) of `a`.
fn svd_sorted(a: &DMatrix<f64>) -> (Vec<f64>, DMatrix<f64>) {
    // Fewer rows than columns: zero rows added, so that V is square and
    // every null direction is there (a thin SVD would drop n − m of them).
    let padded;
    let a = if a.nrows() < a.ncols() {
        padded = a.clone().resize_vertically(a.ncols(), 0.0);
        &padded
    } else {
        a
    };
    let svd = a.clone().svd(false, true);
    let v_t = svd.v_t.expect("v_t requested");
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&i, &j| svd.singular_values[j].total_cmp(&svd.singular_values[i]));
    let sv = order.iter().map(|&i| svd.singular_values[i]).collect();
    let v = DMatrix::from_fn(a.ncols(), order.len(), |r, c| v_t[(order[c], r)]);
    (sv, v)
}

/// Greedy column pivoting (modified Gram–Schmidt): the order in which
/// columns add the most new information. The first `rank` are kept.
fn pivot_order(a: &DMatrix<f64>) -> Vec<usize> {
    let mut q = a.clone();
    let n = a.ncols();
    let mut remaining: Vec<usize> = (0..n).collect();
    let mut order = Vec::with_capacity(n);
    while !remaining.is_empty() {
        let (pos, &best) = remaining
            .iter()
            .enumerate()
            .max_by(|a, b| q.column(*a.1).norm().total_cmp(&q.column(*b.1).norm()))
            .expect("non-empty");
        remaining.remove(pos);
        order.push(best);
        let norm = q.column(best).norm();
        if norm == 0.0 {
            order.append(&mut remaining);
            break;
        }
        let u = q.column(best) / norm;
        for &c in &remaining {
            let proj = u.dot(&q.column(c));
            let new = q.column(c) - &u * proj;
            q.set_column(c, &new);
        }
    }
    order
}

/// Analyse a design matrix (already row-weighted for WLS) whose columns are
/// the errors `names` (a mechanism's
/// [`crate::mechanism::Topology::ERROR_NAMES`]).
pub fn analyse_named(h: &DMatrix<f64>, rank_tolerance: f64, names: &[&str]) -> Identifiability {
    assert_eq!(h.ncols(), names.len(), "one name per column of H");
    let norms: Vec<f64> = (0..h.ncols()).map(|c| h.column(c).norm()).collect();
    let max_norm = norms.iter().cloned().fold(0.0, f64::max);
    // 1. Numerically zero columns: no sensor sees the parameter at all.
    let nonzero: Vec<usize> = (0..h.ncols())
        .filter(|&c| max_norm > 0.0 && norms[c] > rank_tolerance * max_norm)
        .collect();
    // 2. Equilibrate the rest and decide the rank on its SVD.
    let mut hs = DMatrix::zeros(h.nrows(), nonzero.len());
    for (k, &c) in nonzero.iter().enumerate() {
        hs.set_column(k, &(h.column(c) / norms[c]));
    }
    let (mut sv, v) = if nonzero.is_empty() || h.nrows() == 0 {
        (Vec::new(), DMatrix::zeros(0, 0))
    } else {
        svd_sorted(&hs)
    };
    let s1 = sv.first().copied().unwrap_or(0.0);
    let rank = sv.iter().filter(|&&s| s > rank_tolerance * s1).count();
    // 3. Keep the `rank` most informative columns (greedy pivoting).
    let mut identifiable = vec![false; h.ncols()];
    let order = pivot_order(&hs);
    for &k in order.iter().take(rank) {
        identifiable[nonzero[k]] = true;
    }
    // 4. Describe every null direction in physical units.
    let mut combos = Vec::new();
    for &c in (0..h.ncols())
        .filter(|c| !nonzero.contains(c))
        .collect::<Vec<_>>()
        .iter()
    {
        combos.push(format!("{} (no reading is sensitive to it)", names[c]));
    }
    for k in rank..sv.len() {
        let phys: Vec<(usize, f64)> = nonzero
            .iter()
            .enumerate()
            .map(|(i, &c)| (c, v[(i, k)] / norms[c]))
            .collect();
        let big = phys.iter().map(|p| p.1.abs()).fold(0.0, f64::max);
        let terms: Vec<String> = phys
            .iter()
            .filter(|p| p.1.abs() > 1e-6 * big)
            .map(|&(c, x)| format!("{:+.4}·{}", x / big, names[c]))
            .collect();
        combos.push(terms.join(" "));
    }
    let condition_number = if rank < h.ncols() || sv.is_empty() {
        f64::INFINITY
    } else {
        s1 / sv[sv.len() - 1]
    };
    let kept: Vec<usize> = (0..h.ncols()).filter(|&c| identifiable[c]).collect();
    let condition_number_identifiable = if kept.is_empty() {
        f64::INFINITY
    } else {
        let mut hk = DMatrix::zeros(h.nrows(), kept.len());
        for (k, &c) in kept.iter().enumerate() {
            hk.set_column(k, &(h.column(c) / norms[c]));
        }
        let (s, _) = svd_sorted(&hk);
        s[0] / s[s.len() - 1]
    };
    let observability = Observability::from_singular_values(&sv[..rank.min(sv.len())], h.nrows());
    sv.resize(h.ncols(), 0.0);
    Identifiability {
        rank,
        parameters: h.ncols(),
        rank_tolerance,
        singular_values: sv,
        condition_number,
        condition_number_identifiable,
        column_norms: norms,
        unidentifiable: (0..h.ncols())
            .filter(|&c| !identifiable[c])
            .map(|c| names[c].to_string())
            .collect(),
        identifiable,
        unidentifiable_combinations: combos,
        observability,
    }
}

#[cfg(test)]
mod tests {
    use crate::mechanism::tricept::PARAM_NAMES;

    /// The Tricept's design matrices, by its error names.
    fn analyse(h: &DMatrix<f64>, rank_tolerance: f64) -> Identifiability {
        analyse_named(h, rank_tolerance, &PARAM_NAMES)
    }

    use super::*;
    use crate::mechanism::tricept::N_PARAMS;

    fn test_matrix() -> DMatrix<f64> {
        DMatrix::from_fn(40, N_PARAMS, |r, c| {
            ((r * 7 + c * 13) as f64 * 0.37).sin() + if r == c { 2.0 } else { 0.0 }
        })
    }

    #[test]
    fn observability_indices_follow_their_definitions() {
        let o = Observability::from_singular_values(&[4.0, 2.0, 1.0], 9);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(o.o1, 2.0 / 3.0), "O1 {}", o.o1); // (4·2·1)^(1/3)/√9
        assert!(close(o.o2, 0.25)); // σL/σ1
        assert!(close(o.o3, 1.0)); // σL
        assert!(close(o.o4, 0.25)); // σL²/σ1
        assert!(close(o.o5, 1.0 / 1.75)); // 1/Σ(1/σ)
        for (name, v) in [
            ("o1", o.o1),
            ("o2", o.o2),
            ("o3", o.o3),
            ("o4", o.o4),
            ("o5", o.o5),
        ] {
            assert_eq!(o.get(name), Some(v));
        }
        assert_eq!(o.get("o6"), None);
        let none = Observability::from_singular_values(&[], 9);
        assert_eq!((none.o1, none.o3, none.o5), (0.0, 0.0, 0.0));
        let no_rows = Observability::from_singular_values(&[1.0], 0);
        assert_eq!(no_rows.o1, 0.0);
        let singular = Observability::from_singular_values(&[0.0, 0.0], 4);
        assert_eq!((singular.o2, singular.o4, singular.o5), (0.0, 0.0, 0.0));
        let last_zero = Observability::from_singular_values(&[2.0, 0.0], 4);
        assert_eq!(last_zero.o5, 0.0);
        assert!(last_zero.o2 == 0.0 && last_zero.o4 == 0.0);
    }

    #[test]
    fn pivoting_takes_the_column_adding_most_new_information_next() {
        // c1 is nearly c0; c2 is small but new: order c0, c2, c1.
        let a = DMatrix::from_column_slice(3, 3, &[3.0, 0.0, 0.0, 2.9, 0.1, 0.0, 0.0, 0.0, 1.0]);
        assert_eq!(pivot_order(&a), vec![0, 2, 1]);
        // A zero column goes last, whatever its position.
        let z = DMatrix::from_column_slice(3, 3, &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0, 0.0]);
        assert_eq!(pivot_order(&z), vec![2, 1, 0]);
        // Rank decisions keep the pivoted columns: with c1 = c0 the second
        // copy is the one dropped.
        let mut h = test_matrix();
        let c0 = h.column(0).clone_owned();
        h.set_column(1, &(c0 * 1.0));
        let a = analyse(&h, 1e-9);
        assert_eq!(a.rank, 14);
        assert_eq!(a.identifiable.iter().filter(|x| !**x).count(), 1);
        assert!(!a.identifiable[0] || !a.identifiable[1]);
        assert!(a.identifiable[2..].iter().all(|x| *x));
    }

    #[test]
    fn condition_numbers_are_ratios_of_extreme_singular_values() {
        // Orthogonal columns of norms 1, 2, 4: equilibrated, every singular
        // value is 1, so both condition numbers are exactly 1.
        let mut diag = DMatrix::zeros(20, N_PARAMS);
        for c in 0..N_PARAMS {
            diag[(c, c)] = (1 << (c % 3)) as f64;
        }
        let a = analyse(&diag, 1e-9);
        assert_eq!(a.rank, 15);
        assert!(
            (a.condition_number - 1.0).abs() < 1e-12,
            "{}",
            a.condition_number
        );
        assert!((a.condition_number_identifiable - 1.0).abs() < 1e-12);
        assert!(a
            .column_norms
            .iter()
            .zip(0..)
            .all(|(n, c)| (n - (1 << (c % 3)) as f64).abs() < 1e-12));
        // Two columns at 45°: equilibrated singular values √(1 ± cos 45°).
        let mut two = diag.clone();
        two[(0, 1)] = 2.0;
        two[(1, 1)] = 2.0;
        let b = analyse(&two, 1e-9);
        let c45 = std::f64::consts::FRAC_1_SQRT_2;
        let want = ((1.0 + c45) / (1.0 - c45)).sqrt();
        assert!(
            (b.condition_number - want).abs() < 1e-9,
            "{} vs {want}",
            b.condition_number
        );
        assert!((b.condition_number_identifiable - want).abs() < 1e-9);
        // Rank-deficient: infinite overall, finite over the identified subset.
        let mut dep = diag.clone();
        dep.set_column(2, &(diag.column(0) * 3.0));
        let d = analyse(&dep, 1e-9);
        assert!(d.condition_number.is_infinite());
        assert!((d.condition_number_identifiable - 1.0).abs() < 1e-12);
        // The null direction: dyB2 = 3 · dxB1 in physical units.
        let combo = &d.unidentifiable_combinations[0];
        assert!(combo.contains("dxB1") && combo.contains("dyB2"), "{combo}");
        assert!(
            combo.contains("+1.0000·dyB2")
                || combo.contains("-1.0000·dyB2")
                || combo.contains("+1.0000·dxB1")
                || combo.contains("-1.0000·dxB1"),
            "{combo}"
        );
        assert!(combo.contains("0.3333"), "{combo}");
    }

    /// Fewer rows than errors (12 for 15): every one of the n − rank null
    /// directions is named, each a combination H maps to zero.
    #[test]
    fn fewer_rows_than_errors_name_every_null_direction() {
        let h = DMatrix::from_fn(12, N_PARAMS, |r, c| {
            ((r * 5 + c * 11) as f64 * 0.29).sin() + if r == c { 1.5 } else { 0.0 }
        });
        let a = analyse(&h, 1e-9);
        assert_eq!(a.rank, 12);
        assert_eq!(a.unidentifiable.len(), 3);
        assert_eq!(a.unidentifiable_combinations.len(), 3);
        assert!(a.unidentifiable_combinations.iter().all(|c| !c.is_empty()));
        // Each direction, read back from its text, is in H's null space.
        for combo in &a.unidentifiable_combinations {
            let mut x = nalgebra::DVector::zeros(N_PARAMS);
            for term in combo.split_whitespace() {
                let (coef, name) = term.split_once('·').unwrap();
                let k = PARAM_NAMES.iter().position(|n| *n == name).unwrap();
                x[k] = coef.parse::<f64>().unwrap();
            }
            let hx = (&h * &x).norm() / (h.norm() * x.norm());
            assert!(hx < 1e-3, "{combo}: |Hx| relative {hx}");
        }
    }

    #[test]
    fn full_rank_matrix() {
        let a = analyse(&test_matrix(), 1e-9);
        assert_eq!(a.rank, 15);
        assert!(a.unidentifiable.is_empty());
        assert!(a.condition_number.is_finite());
    }

    #[test]
    fn tiny_column_is_not_identifiable_even_if_scaled_up() {
        let mut h = test_matrix();
        h.column_mut(4).fill(0.0);
        h[(3, 4)] = 1e-300;
        let a = analyse(&h, 1e-9);
        assert_eq!(a.rank, 14);
        assert_eq!(a.unidentifiable, vec!["dyB3"]);
    }

    #[test]
    fn dependent_columns_are_found() {
        let mut h = test_matrix();
        let c = h.column(0) * 2.0 - h.column(13) * 0.5;
        h.set_column(7, &c);
        let a = analyse(&h, 1e-9);
        assert_eq!(a.rank, 14);
        assert_eq!(a.unidentifiable.len(), 1);
        let combo = &a.unidentifiable_combinations[0];
        assert!(
            combo.contains("dxB1") && combo.contains("dyA1") && combo.contains("dq2"),
            "{combo}"
        );
    }

    #[test]
    fn rank_is_decided_relative_to_the_largest_singular_value() {
        // Two unit columns at an angle ε: singular values √(1 ± cos ε), so
        // σ2/σ1 ≈ ε/2. Rank 2 exactly when σ2 > tolerance·σ1, whatever σ1.
        let tol = 1e-6;
        let at = |eps: f64| {
            let h = DMatrix::from_row_slice(3, 2, &[1.0, eps.cos(), 0.0, eps.sin(), 0.0, 0.0]);
            analyse_named(&h, tol, &["a", "b"])
        };
        assert_eq!(at(2.2 * tol).rank, 2);
        assert_eq!(at(1.8 * tol).rank, 1);
        let named = at(1.8 * tol);
        assert_eq!(named.parameters, 2);
        assert_eq!(named.unidentifiable.len(), 1);
        let combo = &named.unidentifiable_combinations[0];
        assert!(combo.contains("·a") && combo.contains("·b"), "{combo}");
    }
}
