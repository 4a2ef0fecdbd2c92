//! Reading MoveIt message YAML strictly: every mapping's keys checked
//! against the message's fields, numbers finite, vectors and quaternions in
//! either the list form (`[x, y, z]`) or the message form (`{x: …, y: …}`),
//! each error naming the file and key path.

use super::ProblemError;
use super::toml_source::KeyPath;
use nalgebra::{IsometryMatrix3, Quaternion, Translation3, UnitQuaternion, Vector3};
use std::path::Path;
use yaml_rust2::{Yaml, YamlLoader};

/// A node of a YAML document with its key path, for errors.
pub(crate) struct Node<'a> {
    pub(crate) file: &'a str,
    pub(crate) path: KeyPath,
    pub(crate) value: &'a Yaml,
}

impl<'a> Node<'a> {
    /// The document's root.
    pub(crate) fn root(file: &'a str, value: &'a Yaml) -> Node<'a> {
        Node { file, path: KeyPath::root(), value }
    }

    pub(crate) fn error(&self, message: impl Into<String>) -> ProblemError {
        let key = self.path.to_string();
        ProblemError::Invalid {
            file: self.file.to_string(),
            line: None,
            key: (!key.is_empty()).then_some(key),
            message: message.into(),
        }
    }

    /// Whether the key is absent or null.
    pub(crate) fn is_absent(&self) -> bool {
        matches!(self.value, Yaml::BadValue | Yaml::Null)
    }

    /// Child `key` (absent when missing).
    pub(crate) fn get(&self, key: &str) -> Node<'a> {
        Node { file: self.file, path: self.path.key(key), value: &self.value[key] }
    }

    pub(crate) fn required(&self, key: &str) -> Result<Node<'a>, ProblemError> {
        let n = self.get(key);
        if n.is_absent() { Err(n.error("missing")) } else { Ok(n) }
    }

    /// Checks that the node is a mapping whose keys are all in `fields`
    /// (an absent node passes: every field is then absent too).
    pub(crate) fn fields(&self, what: &str, fields: &[&str]) -> Result<(), ProblemError> {
        let map = match self.value {
            Yaml::Hash(map) => map,
            Yaml::BadValue | Yaml::Null => return Ok(()),
            _ => return Err(self.error(format!("must be a mapping ({what})"))),
        };
        for key in map.keys() {
            let Some(key) = key.as_str() else {
                return Err(self.error(format!("has a key that is not a string: {key:?}")));
            };
            if !fields.contains(&key) {
                return Err(self.get(key).error(format!("unknown key of {what} (known: {})", fields.join(", "))));
            }
        }
        Ok(())
    }

    /// The items of a list (none when absent).
    pub(crate) fn items(&self) -> Result<Vec<Node<'a>>, ProblemError> {
        match self.value {
            Yaml::Array(items) => Ok(items
                .iter()
                .enumerate()
                .map(|(i, value)| Node { file: self.file, path: self.path.index(i), value })
                .collect()),
            Yaml::BadValue | Yaml::Null => Ok(Vec::new()),
            _ => Err(self.error("must be a list")),
        }
    }

    pub(crate) fn number(&self) -> Result<f64, ProblemError> {
        let v = match self.value {
            Yaml::Integer(i) => *i as f64,
            other => other.as_f64().ok_or_else(|| self.error("must be a number"))?,
        };
        if v.is_finite() { Ok(v) } else { Err(self.error(format!("must be finite, got {v}"))) }
    }

    pub(crate) fn numbers(&self) -> Result<Vec<f64>, ProblemError> {
        self.items()?.iter().map(Node::number).collect()
    }

    pub(crate) fn text(&self) -> Result<&'a str, ProblemError> {
        self.value.as_str().ok_or_else(|| self.error("must be a string"))
    }

    /// A string, empty when absent.
    pub(crate) fn text_or_empty(&self) -> Result<&'a str, ProblemError> {
        if self.is_absent() { Ok("") } else { self.text() }
    }

    pub(crate) fn texts(&self) -> Result<Vec<&'a str>, ProblemError> {
        self.items()?.iter().map(Node::text).collect()
    }

    /// `[v1, …, vn]` or `{k1: v1, …}` with the keys `names`.
    fn components<const N: usize>(&self, names: [&str; N]) -> Result<[f64; N], ProblemError> {
        let values = match self.value {
            Yaml::Hash(_) => {
                self.fields("a vector", &names)?;
                names.iter().map(|k| self.required(k)?.number()).collect::<Result<Vec<f64>, _>>()?
            }
            _ => self.numbers()?,
        };
        values
            .try_into()
            .map_err(|v: Vec<f64>| self.error(format!("must hold {N} numbers [{}], has {}", names.join(", "), v.len())))
    }

    /// A one-field message in its message form (`{key: value}`: the node at
    /// `key`) or its short form (the value itself: this node).
    pub(crate) fn one_field(&self, what: &str, key: &str) -> Result<Node<'a>, ProblemError> {
        match self.value {
            Yaml::Hash(_) => {
                self.fields(what, &[key])?;
                self.required(key)
            }
            _ => Ok(Node { file: self.file, path: self.path.clone(), value: self.value }),
        }
    }

    /// A point or vector: `[x, y, z]` or `{x, y, z}`.
    pub(crate) fn vector3(&self) -> Result<Vector3<f64>, ProblemError> {
        Ok(Vector3::from(self.components(["x", "y", "z"])?))
    }

    /// A unit quaternion: `[x, y, z, w]` or `{x, y, z, w}`, norm 1 within 1e-3.
    pub(crate) fn quaternion(&self) -> Result<UnitQuaternion<f64>, ProblemError> {
        let [x, y, z, w] = self.components(["x", "y", "z", "w"])?;
        let q = Quaternion::new(w, x, y, z);
        if (q.norm() - 1.0).abs() > 1e-3 {
            return Err(self.error(format!("must be a unit quaternion, has norm {:.4}", q.norm())));
        }
        Ok(UnitQuaternion::from_quaternion(q))
    }

    /// A `geometry_msgs/Pose`: `{position, orientation}`.
    pub(crate) fn pose(&self) -> Result<IsometryMatrix3<f64>, ProblemError> {
        self.fields("a pose", &["position", "orientation"])?;
        let position = self.required("position")?.vector3()?;
        let rotation = self.required("orientation")?.quaternion()?.to_rotation_matrix();
        Ok(IsometryMatrix3::from_parts(Translation3::from(position), rotation))
    }

    /// A `geometry_msgs/Transform`: `{translation, rotation}`.
    pub(crate) fn transform(&self) -> Result<IsometryMatrix3<f64>, ProblemError> {
        self.fields("a transform", &["translation", "rotation"])?;
        let translation = self.required("translation")?.vector3()?;
        let rotation = self.required("rotation")?.quaternion()?.to_rotation_matrix();
        Ok(IsometryMatrix3::from_parts(Translation3::from(translation), rotation))
    }

    /// A `std_msgs/Header`: its `frame_id` (empty when absent).
    pub(crate) fn header_frame(&self) -> Result<&'a str, ProblemError> {
        let header = self.get("header");
        header.fields("a header", &["seq", "stamp", "frame_id"])?;
        header.get("frame_id").text_or_empty()
    }
}

/// Reads one YAML document.
pub(crate) fn load(path: &Path) -> Result<(String, Yaml), ProblemError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| ProblemError::Io { path: path.into(), source })?;
    let doc = parse(&text, &file)?;
    Ok((file, doc))
}

/// Parses one YAML document read from `file`.
pub(crate) fn parse(text: &str, file: &str) -> Result<Yaml, ProblemError> {
    let mut docs = YamlLoader::load_from_str(text).map_err(|e| ProblemError::Invalid {
        file: file.to_string(),
        line: Some(e.marker().line() as u32),
        key: None,
        message: format!("malformed YAML: {}", e.info()),
    })?;
    if docs.len() > 1 {
        return Err(ProblemError::Invalid {
            file: file.to_string(),
            line: None,
            key: None,
            message: format!("{} YAML documents; expected one", docs.len()),
        });
    }
    docs.pop().filter(|d| !d.is_null()).ok_or_else(|| ProblemError::Invalid {
        file: file.to_string(),
        line: None,
        key: None,
        message: "empty YAML document".into(),
    })
}
