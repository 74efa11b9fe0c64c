//! The study's linear gains: least squares in the convention's free
//! directions with fixed errors held and a prior's rows, unweighted or
//! whitened, through the SVD of the column-scaled design.

use nalgebra::{DMatrix, DVector};

/// The gain of least squares in the free directions with the `fixed`
/// ones (free column, value) held, weighted by `w` (GLS) or not, and a
/// prior: rows `prior[c]`·x_c = 0 below the (weighted) readings' rows
/// (`prior` empty or 0 where none: the weight on the rows' scale, σ/σp
/// unweighted, 1/σp whitened). (f × rows gain, its rows at the fixed
/// columns zero; the f-vector it adds: the fixed values less the gain
/// times their part of the readings.) Without fixed errors the plain
/// pseudo-inverse and an empty offset.
pub(super) fn held_gain(
    a: &DMatrix<f64>,
    w: Option<&DMatrix<f64>>,
    fixed: &[(usize, f64)],
    prior: &[f64],
) -> Option<(DMatrix<f64>, DVector<f64>)> {
    let keep: Vec<usize> = (0..a.ncols())
        .filter(|c| !fixed.iter().any(|(f, _)| f == c))
        .collect();
    let ar = a.select_columns(&keep);
    let weighted = match w {
        Some(w) => w * &ar,
        None => ar,
    };
    // The prior's rows, one per kept column it holds.
    let held: Vec<(usize, f64)> = keep
        .iter()
        .enumerate()
        .filter_map(|(k, &c)| prior.get(c).copied().filter(|&p| p > 0.0).map(|p| (k, p)))
        .collect();
    let rows = weighted.nrows();
    let pinv = if held.is_empty() {
        pseudo_inverse(&weighted)?
    } else {
        let mut aug = weighted.clone().resize_vertically(rows + held.len(), 0.0);
        for (r, &(k, p)) in held.iter().enumerate() {
            aug[(rows + r, k)] = p;
        }
        // The readings' columns: the prior rows' right-hand side is 0.
        pseudo_inverse(&aug)?.columns(0, rows).into_owned()
    };
    let gr = match w {
        Some(w) => pinv * w,
        None => pinv,
    };
    if fixed.is_empty() {
        return Some((gr, DVector::zeros(0)));
    }
    let mut g = DMatrix::zeros(a.ncols(), a.nrows());
    for (k, &c) in keep.iter().enumerate() {
        g.set_row(c, &gr.row(k));
    }
    let mut values = DVector::zeros(a.ncols());
    for &(c, v) in fixed {
        values[c] = v;
    }
    let offset = &values - &g * (a * &values);
    Some((g, offset))
}

/// An estimate plus its gain's offset (none without fixed errors).
pub(super) fn held(estimate: DVector<f64>, offset: &DVector<f64>) -> DVector<f64> {
    if offset.is_empty() {
        estimate
    } else {
        estimate + offset
    }
}

/// The pseudo-inverse of `a` through the SVD of its column-scaled form;
/// None when `a` is rank-deficient (fewer rows than columns included).
fn pseudo_inverse(a: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    if a.nrows() < a.ncols() || a.ncols() == 0 {
        return None;
    }
    let scale: Vec<f64> = (0..a.ncols())
        .map(|c| a.column(c).norm().max(1e-300))
        .collect();
    let s = DMatrix::from_fn(a.nrows(), a.ncols(), |i, j| a[(i, j)] / scale[j]);
    let svd = s.svd(true, true);
    let top = svd.singular_values.max();
    if svd.singular_values.min() <= 1e-9 * top {
        return None;
    }
    let p = svd.pseudo_inverse(0.0).ok()?;
    Some(DMatrix::from_fn(p.nrows(), p.ncols(), |i, j| {
        p[(i, j)] / scale[i]
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A design of 12 rows and 5 columns of unequal sizes (the column
    /// scaling matters), a whitening (lower triangular) and readings.
    fn case() -> (DMatrix<f64>, DMatrix<f64>, DVector<f64>) {
        let a = DMatrix::from_fn(12, 5, |i, j| {
            ((i * 7 + j * 3) as f64 * 0.37).sin() * 10f64.powi(j as i32 - 2)
                + if i == j { 1.0 } else { 0.0 }
        });
        let w = DMatrix::from_fn(12, 12, |i, j| match i.cmp(&j) {
            std::cmp::Ordering::Equal => 1.0 + 0.1 * i as f64,
            std::cmp::Ordering::Greater => 0.05 * ((i + 2 * j) as f64).cos(),
            std::cmp::Ordering::Less => 0.0,
        });
        let y = DVector::from_fn(12, |i, _| (i as f64 * 1.7).cos());
        (a, w, y)
    }

    /// The independent route: the normal equations of the free columns,
    /// ‖W(A_k x_k + A_f v − y)‖² + Σ p_c² x_c², solved by LU.
    fn normal(
        a: &DMatrix<f64>,
        w: &DMatrix<f64>,
        y: &DVector<f64>,
        fixed: &[(usize, f64)],
        prior: &[f64],
    ) -> DVector<f64> {
        let keep: Vec<usize> = (0..a.ncols())
            .filter(|c| !fixed.iter().any(|(f, _)| f == c))
            .collect();
        let mut v = DVector::zeros(a.ncols());
        for &(c, x) in fixed {
            v[c] = x;
        }
        let ak = w * a.select_columns(&keep);
        let rhs = w * (y - a * &v);
        let mut n = ak.transpose() * &ak;
        for (k, &c) in keep.iter().enumerate() {
            let p = prior.get(c).copied().unwrap_or(0.0);
            n[(k, k)] += p * p;
        }
        let xk = n.lu().solve(&(ak.transpose() * rhs)).unwrap();
        for (k, &c) in keep.iter().enumerate() {
            v[c] = xk[k];
        }
        v
    }

    fn close(a: &DVector<f64>, b: &DVector<f64>) {
        assert_eq!(a.len(), b.len());
        let scale = b.amax().max(1e-12);
        assert!((a - b).amax() <= 1e-9 * scale, "{a} against {b}");
    }

    #[test]
    fn gains_equal_the_normal_equations_with_fixed_errors_and_a_prior() {
        let (a, w, y) = case();
        let identity = DMatrix::identity(12, 12);
        let fixed = [(1, 0.3), (4, -0.02)];
        let prior = [0.0, 0.0, 2.0, 0.0, 0.0];
        for (wt, fx, pr) in [
            (None, &[][..], &[][..]),
            (Some(&w), &[][..], &[][..]),
            (None, &fixed[..], &[][..]),
            (Some(&w), &fixed[..], &[][..]),
            (None, &[][..], &prior[..]),
            (Some(&w), &fixed[..], &prior[..]),
            (Some(&w), &[][..], &[0.5, 0.0, 0.0, 3.0, 0.0][..]),
        ] {
            let (g, offset) = held_gain(&a, wt, fx, pr).unwrap();
            assert_eq!(offset.len(), if fx.is_empty() { 0 } else { 5 });
            let got = held(&g * &y, &offset);
            let want = normal(&a, wt.unwrap_or(&identity), &y, fx, pr);
            close(&got, &want);
            for &(c, v) in fx {
                assert!((got[c] - v).abs() < 1e-15, "fixed {c}: {}", got[c]);
            }
        }
        // A prior moves the estimate: the rows count.
        let (g0, _) = held_gain(&a, Some(&w), &[], &[]).unwrap();
        let (g1, _) = held_gain(&a, Some(&w), &[], &prior).unwrap();
        assert!(((&g0 - &g1) * &y).amax() > 1e-3);
    }

    #[test]
    fn a_square_design_of_full_rank_is_inverted_and_a_deficient_one_refused() {
        let (a, _, y) = case();
        let sq = a.rows(0, 5).into_owned();
        let (g, _) = held_gain(&sq, None, &[], &[]).unwrap();
        close(&(&g * &sq * y.rows(0, 5)), &y.rows(0, 5).into_owned());
        // Fewer rows than columns, no columns, two equal columns.
        assert!(held_gain(&a.rows(0, 4).into_owned(), None, &[], &[]).is_none());
        assert!(pseudo_inverse(&DMatrix::zeros(3, 0)).is_none());
        let mut twin = a.clone();
        let c0 = twin.column(0).into_owned();
        twin.set_column(3, &(c0 * 4.0));
        assert!(held_gain(&twin, None, &[], &[]).is_none());
        // Holding one of the twins leaves a design of full rank.
        assert!(held_gain(&twin, None, &[(3, 0.1)], &[]).is_some());
    }

    /// A design is refused where its column-scaled singular values fall to
    /// 1e-9 of the largest: columns (1, 0) and (1, t) have them √2 and
    /// t/√2 to first order, so t = 1.5e-9 is refused, t = 3e-9 taken.
    #[test]
    fn the_rank_tolerance_is_1e_9_of_the_largest_singular_value() {
        let design = |t: f64| DMatrix::from_row_slice(3, 2, &[1.0, 1.0, 0.0, t, 0.0, 0.0]);
        assert!(held_gain(&design(1.5e-9), None, &[], &[]).is_none());
        assert!(held_gain(&design(3e-9), None, &[], &[]).is_some());
    }
}
