//! Undefined numbers are empty cells: a statistic of no samples, a
//! confidence limit of one sample, a ratio to μ0 = 0. No output holds NaN or
//! infinity; `#[serde(serialize_with = "…")]` on every float column.

use serde::Serializer;

/// A finite number, or an empty cell (CSV) / null (JSON).
pub fn number<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    if v.is_finite() {
        s.serialize_f64(*v)
    } else {
        s.serialize_none()
    }
}

/// [`number`] for an optional value.
pub fn optional<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match v {
        Some(x) if x.is_finite() => s.serialize_f64(*x),
        _ => s.serialize_none(),
    }
}

#[cfg(test)]
mod tests {
    #[derive(serde::Serialize)]
    struct Row {
        #[serde(serialize_with = "super::number")]
        a: f64,
        #[serde(serialize_with = "super::number")]
        b: f64,
        #[serde(serialize_with = "super::optional")]
        c: Option<f64>,
    }

    #[test]
    fn non_finite_values_are_empty_cells() {
        let rows = [
            Row {
                a: f64::NAN,
                b: 1.5,
                c: Some(f64::INFINITY),
            },
            Row {
                a: f64::NEG_INFINITY,
                b: 0.25,
                c: None,
            },
        ];
        let mut w = csv::Writer::from_writer(Vec::new());
        for r in &rows {
            w.serialize(r).unwrap();
        }
        let text = String::from_utf8(w.into_inner().unwrap()).unwrap();
        assert_eq!(text, "a,b,c\n,1.5,\n,0.25,\n");
    }
}
