//! A walk over JSON text that checks its shape (nesting depth, items per array or object,
//! values in all, string lengths) without building it, so that a hostile document (a million
//! lights in 58 MB) is refused before it is materialised as a tree many times its size.
//!
//! Syntax errors are not reported here: the parser that follows names them, and it stops at
//! the same place, having built no more than this walk allowed.

use serde::de::{self, DeserializeSeed, Deserializer, MapAccess, SeqAccess, Visitor};
use std::fmt;

/// The largest JSON document shape accepted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeLimits {
    /// Deepest nesting of arrays and objects.
    pub max_depth: usize,
    /// Most items in one array or members in one object.
    pub max_items: usize,
    /// Most values (scalars, arrays and objects) in the whole document.
    pub max_values: usize,
    /// Longest string (or member name), bytes.
    pub max_string: usize,
}

impl Default for ShapeLimits {
    /// Room for the largest scene the other limits allow (10 000 objects of a few dozen
    /// values each) and nothing like a million lights.
    fn default() -> Self {
        ShapeLimits {
            max_depth: 32,
            max_items: 10_000,
            max_values: 500_000,
            max_string: 64 << 10,
        }
    }
}

/// Where the document first broke a limit (`path` as `lights[3].name`, `.` for the top).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{path}: {message}")]
pub struct ShapeError {
    pub path: String,
    pub message: String,
}

/// Checks `json` against `lim`; Ok also for text that is not JSON (the parser reports that).
pub fn check_shape(json: &[u8], lim: &ShapeLimits) -> Result<(), ShapeError> {
    let mut walk = Walk {
        lim: *lim,
        values: 0,
        path: Vec::new(),
        broke: None,
    };
    let de = &mut serde_json::Deserializer::from_slice(json);
    // serde_json's own recursion limit (128) is above ours; ours stops first.
    let _ = Node(&mut walk).deserialize(de);
    walk.broke.map_or(Ok(()), Err)
}

struct Walk {
    lim: ShapeLimits,
    values: usize,
    path: Vec<Seg>,
    broke: Option<ShapeError>,
}

enum Seg {
    Index(usize),
    Key(String),
}

impl Walk {
    fn path(&self) -> String {
        let mut s = String::new();
        for seg in &self.path {
            match seg {
                Seg::Index(i) => s.push_str(&format!("[{i}]")),
                Seg::Key(k) => {
                    if !s.is_empty() {
                        s.push('.');
                    }
                    s.push_str(k);
                }
            }
        }
        if s.is_empty() { ".".into() } else { s }
    }

    /// Records the first limit broken and returns the error that stops the walk.
    fn fail<E: de::Error>(&mut self, message: String) -> E {
        if self.broke.is_none() {
            self.broke = Some(ShapeError {
                path: self.path(),
                message,
            });
        }
        E::custom("shape limit")
    }

    fn value<E: de::Error>(&mut self) -> Result<(), E> {
        self.values += 1;
        if self.values > self.lim.max_values {
            let n = self.lim.max_values;
            return Err(self.fail(format!(
                "the document holds more than {n} values, the most this server accepts"
            )));
        }
        Ok(())
    }

    fn string<E: de::Error>(&mut self, len: usize) -> Result<(), E> {
        self.value()?;
        if len > self.lim.max_string {
            let n = self.lim.max_string;
            return Err(self.fail(format!(
                "a string of {len} bytes is longer than the {n} this server accepts"
            )));
        }
        Ok(())
    }

    fn open<E: de::Error>(&mut self) -> Result<(), E> {
        self.value()?;
        if self.path.len() >= self.lim.max_depth {
            let n = self.lim.max_depth;
            return Err(self.fail(format!(
                "nested deeper than the {n} levels this server accepts"
            )));
        }
        Ok(())
    }

    fn item<E: de::Error>(&mut self, i: usize) -> Result<(), E> {
        if i >= self.lim.max_items {
            let n = self.lim.max_items;
            return Err(self.fail(format!(
                "more than {n} items, the most this server accepts in one array or object"
            )));
        }
        Ok(())
    }
}

/// One value of the document.
struct Node<'w>(&'w mut Walk);

impl<'de> DeserializeSeed<'de> for Node<'_> {
    type Value = ();
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for Node<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("any JSON value")
    }

    fn visit_bool<E: de::Error>(self, _: bool) -> Result<(), E> {
        self.0.value()
    }
    fn visit_i64<E: de::Error>(self, _: i64) -> Result<(), E> {
        self.0.value()
    }
    fn visit_u64<E: de::Error>(self, _: u64) -> Result<(), E> {
        self.0.value()
    }
    fn visit_f64<E: de::Error>(self, _: f64) -> Result<(), E> {
        self.0.value()
    }
    fn visit_unit<E: de::Error>(self) -> Result<(), E> {
        self.0.value()
    }
    fn visit_str<E: de::Error>(self, s: &str) -> Result<(), E> {
        self.0.string(s.len())
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let w = self.0;
        w.open()?;
        let mut i = 0;
        loop {
            w.path.push(Seg::Index(i));
            let more = seq.next_element_seed(Item(&mut *w, i))?;
            w.path.pop();
            if more.is_none() {
                return Ok(());
            }
            i += 1;
        }
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        let w = self.0;
        w.open()?;
        let mut i = 0;
        while map.next_key_seed(Key(&mut *w, i))?.is_some() {
            map.next_value_seed(Node(&mut *w))?;
            w.path.pop();
            i += 1;
        }
        Ok(())
    }
}

/// The `i`th item of an array (its index already on the path): counted, then walked.
struct Item<'w>(&'w mut Walk, usize);

impl<'de> DeserializeSeed<'de> for Item<'_> {
    type Value = ();
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        self.0.item(self.1)?;
        Node(self.0).deserialize(d)
    }
}

/// The `i`th member name of an object: checked like a string and counted; pushed on the path
/// (the caller pops it after the value).
struct Key<'w>(&'w mut Walk, usize);

impl<'de> DeserializeSeed<'de> for Key<'_> {
    type Value = ();
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_str(self)
    }
}

impl<'de> Visitor<'de> for Key<'_> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a member name")
    }

    fn visit_str<E: de::Error>(self, s: &str) -> Result<(), E> {
        let w = self.0;
        let long = s.len() > w.lim.max_string;
        let shown = if long {
            let end = (0..=32).rev().find(|&i| s.is_char_boundary(i)).unwrap_or(0);
            format!("{}…", &s[..end])
        } else {
            s.to_string()
        };
        w.path.push(Seg::Key(shown));
        w.item(self.1)?;
        w.string(s.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lim() -> ShapeLimits {
        ShapeLimits {
            max_depth: 4,
            max_items: 3,
            max_values: 20,
            max_string: 8,
        }
    }

    #[test]
    fn names_where_a_document_breaks_each_limit() {
        let err = |s: &str| check_shape(s.as_bytes(), &lim()).unwrap_err();
        assert!(check_shape(br#"{"a": [1, 2, 3], "b": {"c": "12345678"}}"#, &lim()).is_ok());
        let e = err(r#"{"lights": [{}, {}, {}, {}]}"#);
        assert_eq!(e.path, "lights[3]");
        assert!(e.message.contains("more than 3 items"), "{e}");
        let e = err(r#"{"a": {"b": {"c": {"d": {}}}}}"#);
        assert_eq!(e.path, "a.b.c.d");
        assert!(e.message.contains("deeper than the 4"), "{e}");
        let e = err(r#"{"a": [1, "123456789"]}"#);
        assert_eq!(e.path, "a[1]");
        assert!(e.message.contains("9 bytes"), "{e}");
        let e = err(r#"[[1,1,1],[1,1,1],[1,1,1],[1,1]]"#);
        assert!(e.message.contains("more than 3 items"), "{e}");
        let e = err(r#"[[1,1,1],[1,1,1],[[1,1,1],[1,1,1],[1,1,1]]]"#);
        assert!(e.message.contains("more than 20 values"), "{e}");
        assert_eq!(e.path, "[2][2][1]");
        // Escaped strings count their decoded bytes; syntax errors are left to the parser.
        assert_eq!(err(r#"{"k": "\u00e9\u00e9\u00e9\u00e9\u00e9"}"#).path, "k");
        assert!(check_shape(b"{\"a\": [1, 2", &lim()).is_ok());
        assert!(check_shape(b"not json", &lim()).is_ok());
    }

    /// The hostile body of the issue, scaled down: a refusal comes before the end of the text.
    #[test]
    fn a_million_lights_stop_at_the_item_limit() {
        let mut body = String::from(r#"{"scene": "x", "lights": ["#);
        for i in 0..1_000_000 {
            if i > 0 {
                body.push(',');
            }
            body.push_str(r#"{"type":"point","position":[0,1,0]}"#);
        }
        body.push_str("]}");
        let e = check_shape(body.as_bytes(), &ShapeLimits::default()).unwrap_err();
        assert_eq!(e.path, "lights[10000]");
    }
}
