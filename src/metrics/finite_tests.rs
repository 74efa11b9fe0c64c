use super::Cells;
use serde::{Serialize, Serializer};

/// What every float column carried before [`Cells`]: the number when
/// finite, else none (`#[serde(serialize_with = "number")]`).
fn number<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    if v.is_finite() {
        s.serialize_f64(*v)
    } else {
        s.serialize_none()
    }
}

fn optional<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
    match v {
        Some(x) if x.is_finite() => s.serialize_f64(*x),
        _ => s.serialize_none(),
    }
}

#[derive(Serialize)]
enum Tag {
    #[serde(rename = "gls")]
    Gls,
}

#[derive(Serialize)]
struct Inner {
    c: Option<f64>,
    n: Option<u64>,
}

#[derive(Serialize)]
struct Row {
    a: f64,
    b: f32,
    inner: Inner,
    tag: Tag,
    name: &'static str,
    k: usize,
    flag: bool,
}

#[derive(Serialize)]
struct OldRow {
    #[serde(serialize_with = "number")]
    a: f64,
    /// Finite in this test: before, an `f32` column had no attribute.
    b: f32,
    #[serde(serialize_with = "optional")]
    c: Option<f64>,
    n: Option<u64>,
    tag: Tag,
    name: &'static str,
    k: usize,
    flag: bool,
}

fn csv<T: Serialize>(rows: &[T]) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in rows {
        w.serialize(Cells(r)).unwrap();
    }
    String::from_utf8(w.into_inner().unwrap()).unwrap()
}

fn row(a: f64, b: f32, c: Option<f64>, n: Option<u64>) -> (Row, OldRow) {
    let new = Row {
        a,
        b,
        inner: Inner { c, n },
        tag: Tag::Gls,
        name: "x, y",
        k: 7,
        flag: true,
    };
    let old = OldRow {
        a,
        b,
        c,
        n,
        tag: Tag::Gls,
        name: "x, y",
        k: 7,
        flag: true,
    };
    (new, old)
}

#[test]
fn non_finite_values_are_empty_cells_and_nested_fields_are_columns() {
    let (r1, _) = row(f64::NAN, f32::INFINITY, Some(f64::INFINITY), Some(3));
    let (r2, _) = row(f64::NEG_INFINITY, 0.25, None, None);
    let (r3, _) = row(1.5, 2.0, Some(f64::NAN), None);
    assert_eq!(
        csv(&[r1, r2, r3]),
        "a,b,c,n,tag,name,k,flag\n\
         ,,,3,gls,\"x, y\",7,true\n\
         ,0.25,,,gls,\"x, y\",7,true\n\
         1.5,2.0,,,gls,\"x, y\",7,true\n"
    );
}

/// Finite numbers are written exactly as serde writes an `f64`, and every
/// row as the per-field attribute wrote it.
#[test]
fn rows_are_written_as_the_attribute_wrote_them() {
    let values = [
        0.0,
        -0.0,
        0.1,
        1.0 / 3.0,
        1e-300,
        5e-324,
        123456789.125,
        1e21,
        -2.5e-7,
        f64::MAX,
        f64::MIN_POSITIVE,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut new = Vec::new();
    let mut old = Vec::new();
    for (i, &a) in values.iter().enumerate() {
        let c = values[(i + 3) % values.len()];
        let (n, o) = row(a, i as f32 / 3.0, (i % 2 == 0).then_some(c), Some(i as u64));
        new.push(n);
        old.push(o);
    }
    let mut w = csv::Writer::from_writer(Vec::new());
    for r in &old {
        w.serialize(r).unwrap();
    }
    let expected = String::from_utf8(w.into_inner().unwrap()).unwrap();
    assert_eq!(csv(&new), expected);
    assert!(!expected.contains("NaN") && !expected.contains("inf"));
}

/// JSON needs no help: serde_json writes a non-finite number as null.
#[test]
fn json_writes_non_finite_numbers_as_null() {
    #[derive(Serialize)]
    struct J {
        a: f64,
        b: f64,
        c: f64,
        d: Option<f64>,
        e: f64,
    }
    let j = J {
        a: f64::NAN,
        b: f64::INFINITY,
        c: f64::NEG_INFINITY,
        d: Some(f64::NAN),
        e: 0.1,
    };
    assert_eq!(
        serde_json::to_string(&j).unwrap(),
        r#"{"a":null,"b":null,"c":null,"d":null,"e":0.1}"#
    );
}

#[test]
fn a_row_must_be_a_struct() {
    let mut w = csv::Writer::from_writer(Vec::new());
    assert!(w.serialize(Cells(&1.0)).is_err());
    assert!(w.serialize(Cells(&(1.0, 2.0))).is_err());
    assert!(w.serialize(Cells(&Some(1.0))).is_err());
    // A struct in an Option would have columns in some rows only.
    #[derive(Serialize)]
    struct Maybe {
        a: f64,
        inner: Option<Inner>,
    }
    let some = Maybe {
        a: 1.0,
        inner: Some(Inner {
            c: Some(2.0),
            n: None,
        }),
    };
    let err = w.serialize(Cells(&some)).unwrap_err().to_string();
    assert!(err.contains("a CSV row is a struct of columns"), "{err}");
}

#[test]
fn a_probe_stop_names_its_kind() {
    assert_eq!(super::Stop(super::Kind::Empty).to_string(), "Empty");
}
