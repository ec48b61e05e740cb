//! Integers in a URL (path ids, query parameters) as the spec's `type: integer` allows them:
//! JSON Schema counts any number with an integral value as an integer, so `1`, `1.0` and
//! `1e3` all name one; the text must be a JSON number (no sign `+`, no leading zeros, no
//! spaces), so `01` and `+1` are malformed.

use std::fmt;

use serde::de::{Deserializer, Error, Visitor};

/// The integer `text` writes, if it writes one (a JSON number of integral value in `T`'s
/// range).
pub fn parse<T: TryFrom<i64>>(text: &str) -> Option<T> {
    let json_number_chars = |b: u8| b.is_ascii_digit() || b"-.eE+".contains(&b);
    if text.is_empty() || !text.bytes().all(json_number_chars) || text.starts_with('+') {
        return None;
    }
    let n: serde_json::Number = serde_json::from_str(text).ok()?;
    let value = if text.bytes().all(|b| b.is_ascii_digit() || b == b'-') {
        // Digits only: exact, or out of range (`-0` is 0).
        text.parse().ok()?
    } else {
        // A fraction or an exponent: a float, within the range floats of i64 hold exactly
        // enough (the ends of i64 are not floats).
        let f = n.as_f64()?;
        let fits = f.fract() == 0.0 && f > i64::MIN as f64 && f < i64::MAX as f64;
        fits.then_some(f as i64)?
    };
    T::try_from(value).ok()
}

/// Reads an integer from a URL's text (or from a number, where the same type is read from
/// JSON).
struct Integral<T>(std::marker::PhantomData<T>);

impl<T: TryFrom<i64>> Visitor<'_> for Integral<T> {
    type Value = T;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("an integer")
    }

    fn visit_str<E: Error>(self, text: &str) -> Result<T, E> {
        parse(text).ok_or_else(|| E::custom(format!("`{text}` is not an integer")))
    }

    fn visit_i64<E: Error>(self, v: i64) -> Result<T, E> {
        T::try_from(v).map_err(|_| E::custom(format!("{v} is out of range")))
    }

    fn visit_u64<E: Error>(self, v: u64) -> Result<T, E> {
        self.visit_str(&v.to_string())
    }

    fn visit_f64<E: Error>(self, v: f64) -> Result<T, E> {
        self.visit_str(&v.to_string())
    }
}

/// `#[serde(default, deserialize_with = "integral::optional")]` for an optional integer query
/// parameter.
pub fn optional<'de, D: Deserializer<'de>, T: TryFrom<i64>>(d: D) -> Result<Option<T>, D::Error> {
    required(d).map(Some)
}

/// `#[serde(deserialize_with = "integral::required")]` for an integer query parameter.
pub fn required<'de, D: Deserializer<'de>, T: TryFrom<i64>>(d: D) -> Result<T, D::Error> {
    d.deserialize_any(Integral(std::marker::PhantomData))
}

#[cfg(test)]
mod tests {
    use super::parse;

    #[test]
    fn any_json_number_of_integral_value_is_an_integer() {
        assert_eq!(parse::<i64>("12"), Some(12));
        assert_eq!(parse::<i64>("-3"), Some(-3));
        assert_eq!(parse::<i64>("-0"), Some(0));
        assert_eq!(parse::<i64>("12.0"), Some(12));
        assert_eq!(parse::<i64>("1e3"), Some(1000));
        assert_eq!(parse::<i64>("1E+16"), Some(10_000_000_000_000_000));
        assert_eq!(parse::<u32>("7.00"), Some(7));
    }

    #[test]
    fn other_text_is_not() {
        for text in [
            "", "01", "+1", " 1", "1 ", "1.5", "1e-3", "0x10", "1e400", "nan", "--1",
        ] {
            assert_eq!(parse::<i64>(text), None, "{text:?}");
        }
        assert_eq!(parse::<u32>("-1"), None);
        assert_eq!(parse::<i64>("9223372036854775808"), None);
        assert_eq!(parse::<i64>("-9223372036854775809"), None);
        assert_eq!(parse::<i64>("-9223372036854775808"), Some(i64::MIN));
        assert_eq!(parse::<i64>("1e19"), None);
    }
}
