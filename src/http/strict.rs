//! Request bodies as the spec describes them: where a struct is expected, only a JSON object.
//!
//! serde's derived `Deserialize` for a struct also accepts a sequence of its fields in order,
//! so `{"pose": [1, 2, 3, 1, 0, 0, 0]}` was taken as a pose and `["name"]` created a cell.
//! [`from_value`] deserializes through [`Strict`], a view of a parsed [`Value`] that refuses
//! anything but an object for `deserialize_struct`, at every nesting level and for every type,
//! and names the path of the offending value (`pose: invalid type: sequence, expected an object
//! (struct PoseValues)`). Numbers reach the target exactly as `serde_json` parsed them
//! (`float_roundtrip`), so poses are bit-identical to a direct parse.

use serde::de::value::{MapDeserializer, SeqDeserializer};
use serde::de::{
    self, DeserializeOwned, DeserializeSeed, EnumAccess, Error as _, IntoDeserializer, Unexpected,
    VariantAccess, Visitor,
};
use serde::forward_to_deserialize_any;
use serde_json::{Error, Value};

/// Deserializes `T` from `value`, refusing non-objects where `T` (or anything inside it)
/// expects a struct. The error names the path of the offending value.
pub fn from_value<T: DeserializeOwned>(
    value: &Value,
) -> Result<T, serde_path_to_error::Error<Error>> {
    serde_path_to_error::deserialize(Strict(value))
}

/// A parsed JSON value that deserializes like `serde_json::Value`, except that structs must be
/// objects.
#[derive(Clone, Copy)]
pub struct Strict<'de>(&'de Value);

fn unexpected(v: &Value) -> Unexpected<'_> {
    match v {
        Value::Null => Unexpected::Unit,
        Value::Bool(b) => Unexpected::Bool(*b),
        Value::Number(n) => match (n.as_u64(), n.as_i64(), n.as_f64()) {
            (Some(u), _, _) => Unexpected::Unsigned(u),
            (_, Some(i), _) => Unexpected::Signed(i),
            (_, _, Some(f)) => Unexpected::Float(f),
            _ => Unexpected::Other("number"),
        },
        Value::String(s) => Unexpected::Str(s),
        Value::Array(_) => Unexpected::Seq,
        Value::Object(_) => Unexpected::Map,
    }
}

impl<'de> Strict<'de> {
    fn visit_map<V: Visitor<'de>>(
        map: &'de serde_json::Map<String, Value>,
        visitor: V,
    ) -> Result<V::Value, Error> {
        let mut access = MapDeserializer::new(map.iter().map(|(k, v)| (k.as_str(), Strict(v))));
        let out = visitor.visit_map(&mut access)?;
        access.end()?;
        Ok(out)
    }

    fn visit_seq<V: Visitor<'de>>(items: &'de [Value], visitor: V) -> Result<V::Value, Error> {
        let mut access = SeqDeserializer::new(items.iter().map(Strict));
        let out = visitor.visit_seq(&mut access)?;
        access.end()?;
        Ok(out)
    }
}

impl<'de> IntoDeserializer<'de, Error> for Strict<'de> {
    type Deserializer = Strict<'de>;

    fn into_deserializer(self) -> Strict<'de> {
        self
    }
}

/// The largest magnitude below which every integer is exactly an `f64` (2⁵³).
const EXACT_F64_INTEGER: f64 = 9_007_199_254_740_992.0;

/// Integer targets also take a number written with a zero fraction (`5.0`): JSON Schema counts
/// it an integer, so a schema-valid body must not be refused for it. Within ±2⁵³, where it is
/// exact; anything else goes to the target as parsed (and is refused there, with its path).
macro_rules! integers {
    ($($method:ident)*) => {
        $(
            fn $method<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
                if let Value::Number(n) = self.0
                    && let Some(f) = n.as_f64().filter(|_| n.is_f64())
                    && f.fract() == 0.0
                    && f.abs() <= EXACT_F64_INTEGER
                {
                    return if f >= 0.0 {
                        visitor.visit_u64(f as u64)
                    } else {
                        visitor.visit_i64(f as i64)
                    };
                }
                de::Deserializer::deserialize_any(self, visitor)
            }
        )*
    };
}

impl<'de> de::Deserializer<'de> for Strict<'de> {
    type Error = Error;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        match self.0 {
            Value::Null => visitor.visit_unit(),
            Value::Bool(b) => visitor.visit_bool(*b),
            Value::Number(n) => de::Deserializer::deserialize_any(n, visitor),
            Value::String(s) => visitor.visit_borrowed_str(s),
            Value::Array(items) => Self::visit_seq(items, visitor),
            Value::Object(map) => Self::visit_map(map, visitor),
        }
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        name: &'static str,
        _fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, Error> {
        match self.0 {
            Value::Object(map) => Self::visit_map(map, visitor),
            other => Err(Error::invalid_type(
                unexpected(other),
                &format!("an object (struct {name})").as_str(),
            )),
        }
    }

    fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        match self.0 {
            Value::Null => visitor.visit_none(),
            _ => visitor.visit_some(self),
        }
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value, Error> {
        visitor.visit_newtype_struct(self)
    }

    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, Error> {
        match self.0 {
            // A unit variant.
            Value::String(s) => visitor.visit_enum(s.as_str().into_deserializer()),
            // `{"variant": content}`
            Value::Object(map) if map.len() == 1 => {
                let (variant, content) = map.iter().next().ok_or_else(|| {
                    Error::invalid_value(Unexpected::Map, &"an object with one entry")
                })?;
                visitor.visit_enum(Variant { variant, content })
            }
            other => Err(Error::invalid_type(
                unexpected(other),
                &"a string or an object with one entry",
            )),
        }
    }

    integers! {
        deserialize_i8 deserialize_i16 deserialize_i32 deserialize_i64 deserialize_i128
        deserialize_u8 deserialize_u16 deserialize_u32 deserialize_u64 deserialize_u128
    }

    forward_to_deserialize_any! {
        bool f32 f64 char str string bytes byte_buf
        unit unit_struct seq tuple tuple_struct map identifier ignored_any
    }
}

/// The variant of an enum given as `{"variant": content}`, its content strict too.
struct Variant<'de> {
    variant: &'de str,
    content: &'de Value,
}

impl<'de> EnumAccess<'de> for Variant<'de> {
    type Error = Error;
    type Variant = Strict<'de>;

    fn variant_seed<S: DeserializeSeed<'de>>(
        self,
        seed: S,
    ) -> Result<(S::Value, Strict<'de>), Error> {
        let variant = seed.deserialize(self.variant.into_deserializer())?;
        Ok((variant, Strict(self.content)))
    }
}

impl<'de> VariantAccess<'de> for Strict<'de> {
    type Error = Error;

    fn unit_variant(self) -> Result<(), Error> {
        match self.0 {
            Value::Null => Ok(()),
            other => Err(Error::invalid_type(unexpected(other), &"null")),
        }
    }

    fn newtype_variant_seed<S: DeserializeSeed<'de>>(self, seed: S) -> Result<S::Value, Error> {
        seed.deserialize(self)
    }

    fn tuple_variant<V: Visitor<'de>>(self, _len: usize, visitor: V) -> Result<V::Value, Error> {
        de::Deserializer::deserialize_seq(self, visitor)
    }

    fn struct_variant<V: Visitor<'de>>(
        self,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, Error> {
        de::Deserializer::deserialize_struct(self, "variant", fields, visitor)
    }
}

#[cfg(test)]
mod tests {
    use serde::Deserialize;
    use serde_json::json;

    use super::*;

    #[test]
    fn integers_written_with_a_zero_fraction_are_integers() {
        #[derive(Debug, Deserialize, PartialEq)]
        struct Ints {
            a: i64,
            b: u32,
            c: Option<Vec<i64>>,
        }
        let v = json!({ "a": -1577279.0, "b": 7.0, "c": [3.0, 4] });
        let ints: Ints = from_value(&v).unwrap();
        assert_eq!(
            ints,
            Ints {
                a: -1577279,
                b: 7,
                c: Some(vec![3, 4])
            }
        );
        for bad in [
            json!({ "a": 1.5, "b": 1 }),
            json!({ "a": 1, "b": -1.0 }),
            json!({ "a": 1e300, "b": 1 }),
        ] {
            assert!(from_value::<Ints>(&bad).is_err(), "{bad}");
        }
    }

    #[derive(Debug, Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct Point {
        x: f64,
        y: f64,
    }

    #[derive(Debug, Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct Body {
        name: String,
        at: Option<Point>,
        trail: Option<Vec<Point>>,
        shape: Option<Shape>,
    }

    #[derive(Debug, Deserialize, PartialEq)]
    #[serde(rename_all = "snake_case")]
    enum Shape {
        Dot,
        Box { w: f64, h: f64 },
    }

    #[test]
    fn objects_are_taken_as_serde_json_takes_them() {
        let v = json!({"name": "a", "at": {"x": 0.1, "y": 2}, "trail": [{"x": 1, "y": 2}],
                       "shape": {"box": {"w": 1, "h": 2}}});
        let strict: Body = from_value(&v).unwrap();
        let direct: Body = serde_json::from_value(v).unwrap();
        assert_eq!(strict, direct);
        let dot: Body = from_value(&json!({"name": "a", "shape": "dot"})).unwrap();
        assert_eq!(dot.shape, Some(Shape::Dot));
    }

    #[test]
    fn sequences_are_refused_where_a_struct_is_expected_at_every_level() {
        for (v, path) in [
            (json!(["a"]), "."),
            (json!({"name": "a", "at": [1, 2]}), "at"),
            (
                json!({"name": "a", "trail": [{"x": 1, "y": 2}, [3, 4]]}),
                "trail[1]",
            ),
            (json!({"name": "a", "shape": {"box": [1, 2]}}), "shape.box"),
        ] {
            let e = from_value::<Body>(&v).unwrap_err();
            assert_eq!(e.path().to_string(), path, "{v}: {e}");
            assert!(e.to_string().contains("expected an object"), "{v}: {e}");
        }
        // Serde's derive alone takes them.
        let fields = json!(["a", [1, 2], null, null]);
        assert!(serde_json::from_value::<Body>(fields.clone()).is_ok());
        assert!(from_value::<Body>(&fields).is_err());
    }

    #[test]
    fn unknown_fields_missing_fields_and_wrong_types_are_still_errors() {
        for v in [
            json!({"name": "a", "colour": 1}),
            json!({"at": {"x": 1, "y": 2}}),
            json!({"name": 1}),
            json!({"name": "a", "at": {"x": "1", "y": 2}}),
            json!({"name": "a", "shape": "triangle"}),
        ] {
            assert!(from_value::<Body>(&v).is_err(), "{v}");
        }
    }

    #[test]
    fn numbers_are_bit_identical_to_a_direct_parse() {
        let text = r#"{"x": 0.30000000000000004, "y": 123.45678901234567}"#;
        let direct: Point = serde_json::from_str(text).unwrap();
        let strict: Point = from_value(&serde_json::from_str(text).unwrap()).unwrap();
        assert_eq!(direct.x.to_bits(), strict.x.to_bits());
        assert_eq!(direct.y.to_bits(), strict.y.to_bits());
        for x in [
            "5e-324",
            "1.7976931348623157e308",
            "-0.0",
            "2.2250738585072014e-308",
        ] {
            let text = format!(r#"{{"x": {x}, "y": 1}}"#);
            let direct: Point = serde_json::from_str(&text).unwrap();
            let strict: Point = from_value(&serde_json::from_str(&text).unwrap()).unwrap();
            assert_eq!(direct.x.to_bits(), strict.x.to_bits(), "{x}");
        }
    }
}
