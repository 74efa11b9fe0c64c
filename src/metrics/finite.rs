//! Undefined numbers are empty cells: a statistic of no samples, a
//! confidence limit of one sample, a ratio to μ0 = 0. No output holds NaN or
//! infinity. Rows keep plain `f64` fields (arithmetic reads them); a CSV row
//! is written through [`Cells`], which makes each non-finite number an empty
//! cell and lays the fields of a nested struct (the workspace statistics of
//! a summary row) out as columns of their own, in place. JSON needs nothing:
//! serde_json writes a non-finite number as null.

use serde::ser::{self, Impossible, Serialize, SerializeStruct, Serializer};
use std::fmt;

/// A CSV row: the struct `T` with every non-finite number (bare or in an
/// `Option`) an empty cell and every nested struct's fields columns of the
/// row. Anything else than a struct is refused. A nested struct must not be
/// optional: its `None` would be one empty cell, not one per field (no row
/// has one; `DvSummary`'s fields are each optional instead).
pub struct Cells<'a, T: ?Sized>(pub &'a T);

impl<T: Serialize + ?Sized> Serialize for Cells<'_, T> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.0.serialize(Row(s))
    }
}

/// What a field is written as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// Itself.
    Value,
    /// An empty cell: a non-finite number.
    Empty,
    /// Its fields, as columns: a struct.
    Columns,
}

fn kind<T: Serialize + ?Sized>(v: &T) -> Kind {
    v.serialize(Probe).unwrap_or_else(|Stop(k)| k)
}

/// One field of a row, in the row's struct serializer.
fn cell<SS: SerializeStruct, T: Serialize + ?Sized>(
    st: &mut SS,
    key: &'static str,
    v: &T,
) -> Result<(), SS::Error> {
    match kind(v) {
        Kind::Value => st.serialize_field(key, v),
        Kind::Empty => st.serialize_field(key, &None::<f64>),
        Kind::Columns => v.serialize(Inline(st)),
    }
}

fn not_a_struct<E: ser::Error>() -> E {
    E::custom("a CSV row is a struct of columns")
}

/// The methods of a serializer that refuse their value: every scalar
/// named, and with `rest` every shape but `Some` and a struct.
macro_rules! refuse {
    ($($f:ident($t:ty)),*) => {
        $(fn $f(self, _: $t) -> Result<Self::Ok, Self::Error> {
            Err(not_a_struct())
        })*
    };
    (rest) => {
        type SerializeSeq = Impossible<Self::Ok, Self::Error>;
        type SerializeTuple = Impossible<Self::Ok, Self::Error>;
        type SerializeTupleStruct = Impossible<Self::Ok, Self::Error>;
        type SerializeTupleVariant = Impossible<Self::Ok, Self::Error>;
        type SerializeMap = Impossible<Self::Ok, Self::Error>;
        type SerializeStructVariant = Impossible<Self::Ok, Self::Error>;
        refuse!(serialize_bool(bool), serialize_i8(i8), serialize_i16(i16),
            serialize_i32(i32), serialize_i64(i64), serialize_u8(u8), serialize_u16(u16),
            serialize_u32(u32), serialize_u64(u64), serialize_char(char),
            serialize_str(&str), serialize_bytes(&[u8]), serialize_unit_struct(&'static str));
        fn serialize_none(self) -> Result<Self::Ok, Self::Error> {
            Err(not_a_struct())
        }
        fn serialize_unit(self) -> Result<Self::Ok, Self::Error> {
            Err(not_a_struct())
        }
        fn serialize_unit_variant(
            self,
            _: &'static str,
            _: u32,
            _: &'static str,
        ) -> Result<Self::Ok, Self::Error> {
            Err(not_a_struct())
        }
        fn serialize_newtype_struct<T: ?Sized + Serialize>(
            self,
            _: &'static str,
            _: &T,
        ) -> Result<Self::Ok, Self::Error> {
            Err(not_a_struct())
        }
        fn serialize_newtype_variant<T: ?Sized + Serialize>(
            self,
            _: &'static str,
            _: u32,
            _: &'static str,
            _: &T,
        ) -> Result<Self::Ok, Self::Error> {
            Err(not_a_struct())
        }
        fn serialize_seq(self, _: Option<usize>) -> Result<Self::SerializeSeq, Self::Error> {
            Err(not_a_struct())
        }
        fn serialize_tuple(self, _: usize) -> Result<Self::SerializeTuple, Self::Error> {
            Err(not_a_struct())
        }
        fn serialize_tuple_struct(
            self,
            _: &'static str,
            _: usize,
        ) -> Result<Self::SerializeTupleStruct, Self::Error> {
            Err(not_a_struct())
        }
        fn serialize_tuple_variant(
            self,
            _: &'static str,
            _: u32,
            _: &'static str,
            _: usize,
        ) -> Result<Self::SerializeTupleVariant, Self::Error> {
            Err(not_a_struct())
        }
        fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, Self::Error> {
            Err(not_a_struct())
        }
        fn serialize_struct_variant(
            self,
            _: &'static str,
            _: u32,
            _: &'static str,
            _: usize,
        ) -> Result<Self::SerializeStructVariant, Self::Error> {
            Err(not_a_struct())
        }
    };
}

/// The row itself: a struct, whose fields go through [`cell`].
struct Row<S>(S);

impl<S: Serializer> Serializer for Row<S> {
    type Ok = S::Ok;
    type Error = S::Error;
    type SerializeStruct = Fields<S::SerializeStruct>;
    refuse!(rest);
    refuse!(serialize_f32(f32), serialize_f64(f64));

    fn serialize_some<T: ?Sized + Serialize>(self, _: &T) -> Result<Self::Ok, Self::Error> {
        Err(not_a_struct())
    }

    fn serialize_struct(
        self,
        name: &'static str,
        len: usize,
    ) -> Result<Self::SerializeStruct, Self::Error> {
        Ok(Fields(self.0.serialize_struct(name, len)?))
    }
}

struct Fields<SS>(SS);

impl<SS: SerializeStruct> SerializeStruct for Fields<SS> {
    type Ok = SS::Ok;
    type Error = SS::Error;

    fn serialize_field<T: ?Sized + Serialize>(
        &mut self,
        key: &'static str,
        v: &T,
    ) -> Result<(), SS::Error> {
        cell(&mut self.0, key, v)
    }

    fn end(self) -> Result<SS::Ok, SS::Error> {
        self.0.end()
    }
}

/// A nested struct: its fields are columns of the row being written.
struct Inline<'a, SS>(&'a mut SS);

impl<'a, SS: SerializeStruct> Serializer for Inline<'a, SS> {
    type Ok = ();
    type Error = SS::Error;
    type SerializeStruct = Self;
    refuse!(rest);
    refuse!(serialize_f32(f32), serialize_f64(f64));

    fn serialize_some<T: ?Sized + Serialize>(self, _: &T) -> Result<(), SS::Error> {
        Err(not_a_struct())
    }

    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Self, SS::Error> {
        Ok(self)
    }
}

impl<SS: SerializeStruct> SerializeStruct for Inline<'_, SS> {
    type Ok = ();
    type Error = SS::Error;

    fn serialize_field<T: ?Sized + Serialize>(
        &mut self,
        key: &'static str,
        v: &T,
    ) -> Result<(), SS::Error> {
        cell(self.0, key, v)
    }

    fn end(self) -> Result<(), SS::Error> {
        Ok(())
    }
}

/// Finds a field's [`Kind`] without writing anything: the answer comes
/// back as `Ok` for a number, as the error [`Stop`] for anything else.
struct Probe;

#[derive(Debug)]
struct Stop(Kind);

impl fmt::Display for Stop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?}", self.0)
    }
}

impl std::error::Error for Stop {}

impl ser::Error for Stop {
    fn custom<M: fmt::Display>(_: M) -> Self {
        Stop(Kind::Value)
    }
}

impl Serializer for Probe {
    type Ok = Kind;
    type Error = Stop;
    type SerializeStruct = Impossible<Kind, Stop>;
    refuse!(rest);

    fn serialize_f32(self, v: f32) -> Result<Kind, Stop> {
        self.serialize_f64(v.into())
    }

    fn serialize_f64(self, v: f64) -> Result<Kind, Stop> {
        Ok(if v.is_finite() {
            Kind::Value
        } else {
            Kind::Empty
        })
    }

    fn serialize_some<T: ?Sized + Serialize>(self, v: &T) -> Result<Kind, Stop> {
        v.serialize(self)
    }

    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Self::SerializeStruct, Stop> {
        Err(Stop(Kind::Columns))
    }
}

#[cfg(test)]
#[path = "finite_tests.rs"]
mod tests;
