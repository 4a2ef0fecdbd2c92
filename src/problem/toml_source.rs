//! Locating keys and values of a TOML file by line, for error messages.
//!
//! serde reports a byte span; validation reports a key path such as
//! `scene.obstacles[2].size`. Both are turned into "file:line: key: message"
//! by walking toml's spanned document once per error.

use std::fmt;
use std::ops::Range;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// A path of keys and array indices into a TOML document.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct KeyPath(Vec<Segment>);

#[derive(Debug, Clone, PartialEq, Eq)]
enum Segment {
    Key(String),
    Index(usize),
}

impl KeyPath {
    pub(crate) fn root() -> KeyPath {
        KeyPath(Vec::new())
    }

    /// This path followed by key `key`.
    pub(crate) fn key(&self, key: &str) -> KeyPath {
        let mut p = self.clone();
        p.0.push(Segment::Key(key.to_string()));
        p
    }

    /// This path followed by array index `i`.
    pub(crate) fn index(&self, i: usize) -> KeyPath {
        let mut p = self.clone();
        p.0.push(Segment::Index(i));
        p
    }
}

impl fmt::Display for KeyPath {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (n, s) in self.0.iter().enumerate() {
            match s {
                Segment::Key(k) if n == 0 => write!(f, "{k}")?,
                Segment::Key(k) => write!(f, ".{k}")?,
                Segment::Index(i) => write!(f, "[{i}]")?,
            }
        }
        Ok(())
    }
}

/// 1-based line of byte `offset` in `text`.
pub(crate) fn line_of(text: &str, offset: usize) -> u32 {
    let end = offset.min(text.len());
    1 + text.as_bytes()[..end].iter().filter(|&&b| b == b'\n').count() as u32
}

/// The line where `path` is written (its key, or its value for array
/// items); the closest existing ancestor when the key is absent.
pub(crate) fn line_of_path(text: &str, path: &KeyPath) -> Option<u32> {
    let doc = DeTable::parse(text).ok()?;
    let mut best: Option<Range<usize>> = None;
    let mut table: Option<&DeTable> = Some(doc.get_ref());
    let mut value: Option<&Spanned<DeValue>> = None;
    for seg in &path.0 {
        let next = match (seg, table, value.map(Spanned::get_ref)) {
            (Segment::Key(k), Some(t), _) => t.get_key_value(k.as_str()).map(|(key, v)| {
                best = Some(key.span());
                v
            }),
            (Segment::Index(i), _, Some(DeValue::Array(items))) => items.get(*i).inspect(|v| {
                best = Some(v.span());
            }),
            _ => None,
        };
        let Some(next) = next else { break };
        value = Some(next);
        table = match next.get_ref() {
            DeValue::Table(t) => Some(t),
            _ => None,
        };
    }
    best.map(|span| line_of(text, span.start))
}

/// The deepest key path whose key or value contains byte `offset`.
pub(crate) fn path_at(text: &str, offset: usize) -> Option<KeyPath> {
    let doc = DeTable::parse(text).ok()?;
    let mut path = KeyPath::root();
    let found = walk_table(doc.get_ref(), offset, &mut path);
    found.then_some(path)
}

fn walk_table(table: &DeTable, offset: usize, path: &mut KeyPath) -> bool {
    for (key, value) in table.iter() {
        let in_key = key.span().contains(&offset);
        let in_value = value.span().contains(&offset) || span_holds(value.get_ref(), offset);
        if in_key || in_value {
            path.0.push(Segment::Key(key.get_ref().to_string()));
            if in_value {
                walk_value(value.get_ref(), offset, path);
            }
            return true;
        }
    }
    false
}

fn walk_value(value: &DeValue, offset: usize, path: &mut KeyPath) {
    match value {
        DeValue::Table(t) => {
            walk_table(t, offset, path);
        }
        DeValue::Array(items) => {
            for (i, item) in items.iter().enumerate() {
                if item.span().contains(&offset) || span_holds(item.get_ref(), offset) {
                    path.0.push(Segment::Index(i));
                    walk_value(item.get_ref(), offset, path);
                    return;
                }
            }
        }
        _ => {}
    }
}

/// Whether a table's entries (which for `[header]` tables lie outside the
/// table's own span) contain `offset`.
fn span_holds(value: &DeValue, offset: usize) -> bool {
    match value {
        DeValue::Table(t) => t
            .iter()
            .any(|(k, v)| k.span().contains(&offset) || v.span().contains(&offset) || span_holds(v.get_ref(), offset)),
        DeValue::Array(items) => items.iter().any(|v| v.span().contains(&offset) || span_holds(v.get_ref(), offset)),
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DOC: &str = "name = \"x\"\n[robot]\nurdf = \"a.urdf\"\n\n[[scene.obstacles]]\nname = \"wall\"\nsize = [1, 2, 3]\n\n[[scene.obstacles]]\nname = \"post\"\nradius = 0.1\n";

    #[test]
    fn paths_map_to_lines_and_back() {
        let p = KeyPath::root().key("scene").key("obstacles").index(1).key("radius");
        assert_eq!(p.to_string(), "scene.obstacles[1].radius");
        assert_eq!(line_of_path(DOC, &p), Some(11));
        assert_eq!(line_of_path(DOC, &KeyPath::root().key("robot").key("urdf")), Some(3));
        // A missing key falls back to the nearest ancestor that exists.
        assert_eq!(line_of_path(DOC, &KeyPath::root().key("robot").key("srdf")), Some(2));
        let offset = DOC.find("[1, 2, 3]").unwrap() + 4;
        assert_eq!(path_at(DOC, offset).unwrap().to_string(), "scene.obstacles[0].size[1]");
    }
}
