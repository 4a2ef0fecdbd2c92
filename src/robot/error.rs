//! Typed errors of robot loading and kinematics.
//!
//! Every variant names what was wrong and where: the URDF source (a file path
//! or `<string>`), the element and its line when known, and the offending
//! value, so a user can fix their file without reading tandem's source.

use std::path::PathBuf;
use thiserror::Error;

/// Where a problem was found in a URDF: the source and, when known, the line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SourceLocation {
    /// File path, or `<string>` for a URDF given as text.
    pub source: String,
    /// 1-based line of the element, when it could be located.
    pub line: Option<u32>,
}

impl std::fmt::Display for SourceLocation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{}", self.source, line),
            None => write!(f, "{}", self.source),
        }
    }
}

/// Errors loading a URDF, building a [`RobotModel`](super::RobotModel) or
/// querying its kinematics.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum RobotError {
    /// The URDF (or a mesh) file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        #[source]
        /// The underlying error.
        source: std::io::Error,
    },
    /// The text is not well-formed XML.
    #[error("{at}: malformed XML: {message}")]
    MalformedXml {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// What is wrong.
        message: String,
    },
    /// Well-formed XML that is not a valid URDF (missing attribute, bad number…).
    #[error("{at}: invalid URDF: {message}")]
    InvalidUrdf {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// What is wrong.
        message: String,
    },
    /// An SRDF that is malformed or names links or joints the robot lacks.
    #[error("{at}: invalid SRDF: {message}")]
    InvalidSrdf {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// What is wrong.
        message: String,
    },
    /// A joint `type` outside revolute, continuous, prismatic, fixed, floating,
    /// planar, spherical.
    #[error(
        "{at}: joint '{joint}' has unknown type '{joint_type}' (expected revolute, continuous, prismatic or fixed)"
    )]
    UnknownJointType {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// The joint's name.
        joint: String,
        /// The type as written.
        joint_type: String,
    },
    /// A valid URDF joint type that tandem does not model (floating, planar, spherical).
    #[error(
        "{at}: joint '{joint}' has type '{joint_type}', which tandem does not support (use revolute, continuous, prismatic or fixed)"
    )]
    UnsupportedJointType {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// The joint's name.
        joint: String,
        /// The type as written.
        joint_type: String,
    },
    /// A joint names a parent or child link that the URDF does not define.
    #[error("{at}: joint '{joint}' names {role} link '{link}', which is not defined")]
    MissingLink {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// The joint's name.
        joint: String,
        /// `parent` or `child`.
        role: &'static str,
        /// The link's name.
        link: String,
    },
    /// Two links, or two joints, share a name.
    #[error("{at}: duplicate {kind} name '{name}'")]
    DuplicateName {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// `link` or `joint`.
        kind: &'static str,
        /// The name used twice.
        name: String,
    },
    /// The joints do not form a tree: a link has two parents or a cycle exists.
    #[error("{at}: kinematic loop: {detail}")]
    KinematicLoop {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// What is wrong, in detail.
        detail: String,
    },
    /// More than one link has no parent joint.
    #[error("{at}: the URDF has {} root links ({}); a robot needs exactly one", roots.len(), roots.join(", "))]
    MultipleRoots {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// The links without a parent joint.
        roots: Vec<String>,
    },
    /// The URDF defines no link.
    #[error("{at}: the URDF defines no link")]
    NoLinks {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
    },
    /// A joint's lower position limit is above its upper limit.
    #[error("{at}: joint '{joint}' has lower limit {lower} above upper limit {upper}")]
    InvalidLimits {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// The joint's name.
        joint: String,
        /// Lower position limit (rad or m).
        lower: f64,
        /// Upper position limit (rad or m).
        upper: f64,
    },
    /// A number that must be finite (or non-negative) is not.
    #[error("{at}: {element} '{name}': {field} = {value} is not valid ({expected})")]
    InvalidValue {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// `link` or `joint`.
        element: &'static str,
        /// The link's or joint's name.
        name: String,
        /// The attribute (e.g. `mesh scale x`).
        field: &'static str,
        /// The offending value.
        value: f64,
        /// What it must be.
        expected: &'static str,
    },
    /// A revolute or prismatic joint with a zero axis.
    #[error("{at}: joint '{joint}' has a zero-length axis {axis:?}")]
    ZeroAxis {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// The joint's name.
        joint: String,
        /// The axis as written.
        axis: [f64; 3],
    },
    /// A mimic element names a joint that does not exist, or mimics form a cycle.
    #[error("{at}: joint '{joint}' mimics '{target}': {detail}")]
    InvalidMimic {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// The joint's name.
        joint: String,
        /// The joint it mimics.
        target: String,
        /// What is wrong, in detail.
        detail: String,
    },
    /// A mesh URI could not be resolved to an existing file.
    #[error("{at}: link '{link}': mesh '{uri}' not found (looked in: {})", searched.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "))]
    MeshNotFound {
        /// Where: the file (or `<string>`) and line.
        at: SourceLocation,
        /// The link's name.
        link: String,
        /// The mesh URI as written.
        uri: String,
        /// Every place looked in.
        searched: Vec<PathBuf>,
    },
    /// A mesh file exists but could not be parsed.
    #[error("mesh {path}: {message}")]
    InvalidMesh {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// No frame (link or joint) has this name.
    #[error("unknown frame '{name}'{}", did_you_mean(suggestions))]
    UnknownFrame {
        /// The name asked for.
        name: String,
        /// Close names that do exist, for "did you mean".
        suggestions: Vec<String>,
    },
    /// No joint has this name.
    #[error("unknown joint '{name}'{}", did_you_mean(suggestions))]
    UnknownJoint {
        /// The name asked for.
        name: String,
        /// Close names that do exist, for "did you mean".
        suggestions: Vec<String>,
    },
    /// A joint chosen as active cannot be: fixed, or driven by a mimic.
    #[error("joint '{joint}' cannot be active: {reason}")]
    NotActuable {
        /// The joint's name.
        joint: String,
        /// Why it cannot be.
        reason: String,
    },
    /// The requested root link is not an ancestor of the tip frame.
    #[error("link '{root}' is not an ancestor of frame '{tip}', so they do not define a chain")]
    NotAChain {
        /// The root link asked for.
        root: String,
        /// The tip frame asked for.
        tip: String,
    },
    /// A held (inactive) joint value is outside the joint's limits or not finite.
    #[error("held value {value} for joint '{joint}' is outside its limits [{lower}, {upper}]")]
    HeldValueOutOfRange {
        /// The joint's name.
        joint: String,
        /// The offending value.
        value: f64,
        /// Lower position limit (rad or m).
        lower: f64,
        /// Upper position limit (rad or m).
        upper: f64,
    },
    /// A configuration with the wrong number of values.
    #[error("expected {expected} joint values ({joints}), got {got}")]
    WrongDof {
        /// What it must be.
        expected: usize,
        /// Values given.
        got: usize,
        /// The active joints, comma-separated.
        joints: String,
    },
    /// A configuration containing NaN or an infinity.
    #[error("joint '{joint}' (index {index}) has non-finite value {value}")]
    NonFinite {
        /// The joint's name.
        joint: String,
        /// Its index in q.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// A configuration value outside its joint's position limits.
    #[error("joint '{joint}' (index {index}) = {value} is outside its limits [{lower}, {upper}]")]
    OutsideLimits {
        /// The joint's name.
        joint: String,
        /// Its index in q.
        index: usize,
        /// The offending value.
        value: f64,
        /// Lower position limit (rad or m).
        lower: f64,
        /// Upper position limit (rad or m).
        upper: f64,
    },
    /// A setting of a query (a motion check's resolution or clearance)
    /// outside its documented range, or one that would make the query
    /// unbounded.
    #[error(transparent)]
    InvalidSetting(#[from] crate::settings::InvalidSetting),
    /// A motion limit (velocity, acceleration, deceleration, jerk) that is
    /// not finite and positive.
    #[error("joint '{joint}': {what} = {value} must be finite and above 0")]
    InvalidLimit {
        /// The joint's name.
        joint: String,
        /// Which limit (`max_acceleration`, …).
        what: &'static str,
        /// The value given.
        value: f64,
    },
    /// An output buffer of the wrong shape (a programming error of the caller).
    #[error("output has {got} columns, the model has {expected} active joints")]
    OutputShape {
        /// What it must be.
        expected: usize,
        /// Values given.
        got: usize,
    },
}

pub(crate) fn did_you_mean(suggestions: &[String]) -> String {
    if suggestions.is_empty() { String::new() } else { format!(" (did you mean {}?)", suggestions.join(", ")) }
}

/// Up to three names closest to `name` by edit distance, for "did you mean".
pub(crate) fn suggest<'a>(name: &str, candidates: impl Iterator<Item = &'a str>) -> Vec<String> {
    let mut scored: Vec<(usize, &str)> = candidates
        .map(|c| (edit_distance(name, c), c))
        .filter(|(d, c)| *d <= (name.len().max(c.len()) / 2).max(2))
        .collect();
    scored.sort();
    scored.dedup_by(|a, b| a.1 == b.1);
    scored.into_iter().take(3).map(|(_, c)| c.to_string()).collect()
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let cur = row[j + 1];
            row[j + 1] = (prev + usize::from(ca != *cb)).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggestions_rank_close_names_first() {
        let names = ["panda_link7", "panda_link8", "panda_hand", "world"];
        let s = suggest("panda_lnk7", names.iter().copied());
        assert_eq!(s.first().map(String::as_str), Some("panda_link7"));
        assert!(suggest("zzzzzzzzzzzz", names.iter().copied()).is_empty());
    }
}
