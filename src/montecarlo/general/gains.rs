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
