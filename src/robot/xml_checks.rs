//! Checks on the raw XML of a URDF, before urdf-rs sees it, so that every
//! structural mistake is reported with its line: the root element, joint
//! types, required attributes and child elements, and every numeric
//! attribute (count and syntax).
//!
//! urdf-rs reports such problems without a position; catching them here
//! turns "missing field `parent`" into "robot.urdf:42: joint 'elbow' has no
//! `<parent link=…>` element".

use super::error::{RobotError, SourceLocation};
use std::collections::HashMap;

/// Element lines found by roxmltree, keyed by (tag, name).
pub(crate) struct Lines(HashMap<(&'static str, String), u32>);

impl Lines {
    pub(crate) fn get(&self, tag: &'static str, name: &str) -> Option<u32> {
        self.0.get(&(tag, name.to_string())).copied()
    }
}

/// Line numbers of byte offsets in one text, by binary search over the
/// line starts: roxmltree's `text_pos_at` scans from the start each time,
/// which made loading a 10,000-link URDF quadratic (20 s).
pub(crate) struct LineIndex(Vec<usize>);

impl LineIndex {
    pub(crate) fn new(text: &str) -> LineIndex {
        LineIndex(text.bytes().enumerate().filter(|(_, b)| *b == b'\n').map(|(i, _)| i).collect())
    }

    /// The 1-based line of the node's start.
    pub(crate) fn line(&self, node: &roxmltree::Node) -> u32 {
        let offset = node.range().start;
        // Newlines before the offset, plus one.
        (self.0.partition_point(|&nl| nl < offset) + 1) as u32
    }
}

/// The text with every `<visual>` and `<material>` element blanked out
/// (newlines kept): tandem never uses them, and urdf-rs rejects some that
/// urdfdom accepts (e.g. `<texture/>` without a filename).
pub(crate) fn without_visuals(text: &str, doc: &roxmltree::Document) -> String {
    let mut out = text.to_string();
    let appearance = |n: &roxmltree::Node| {
        n.has_tag_name("visual") || (n.has_tag_name("material") && n.parent().is_some_and(|p| p.has_tag_name("robot")))
    };
    for node in doc.descendants().filter(appearance) {
        let range = node.range();
        let blank: String = text[range.clone()].chars().map(|c| if c == '\n' { '\n' } else { ' ' }).collect();
        out.replace_range(range, &blank);
    }
    out
}

/// Checks what urdf-rs would reject without a line: the root element and joint types.
pub(crate) fn prevalidate(doc: &roxmltree::Document, source: &str) -> Result<Lines, RobotError> {
    let index = LineIndex::new(doc.input_text());
    let line_of = |n: &roxmltree::Node| index.line(n);
    let root = doc.root_element();
    if root.tag_name().name() != "robot" {
        return Err(RobotError::InvalidUrdf {
            at: SourceLocation { source: source.to_string(), line: Some(line_of(&root)) },
            message: format!("the root element is <{}>, expected <robot>", root.tag_name().name()),
        });
    }
    let mut lines = HashMap::new();
    for node in root.children().filter(roxmltree::Node::is_element) {
        let tag = match node.tag_name().name() {
            "link" => "link",
            "joint" => "joint",
            _ => continue,
        };
        let line = line_of(&node);
        let at = SourceLocation { source: source.to_string(), line: Some(line) };
        let name = node
            .attribute("name")
            .ok_or_else(|| RobotError::InvalidUrdf {
                at: at.clone(),
                message: format!("a <{tag}> has no name attribute"),
            })?
            .to_string();
        if tag == "joint" {
            check_joint_type(&node, &name, line, source)?;
            check_joint_children(&node, &name, &at)?;
        }
        check_numbers(doc, &node, tag, &name, source)?;
        lines.entry((tag, name)).or_insert(line);
    }
    Ok(Lines(lines))
}

fn check_joint_type(node: &roxmltree::Node, name: &str, line: u32, source: &str) -> Result<(), RobotError> {
    let ty = node.attribute("type").unwrap_or_default();
    let at = SourceLocation { source: source.to_string(), line: Some(line) };
    match ty {
        "revolute" | "continuous" | "prismatic" | "fixed" => Ok(()),
        "floating" | "planar" | "spherical" => {
            Err(RobotError::UnsupportedJointType { at, joint: name.to_string(), joint_type: ty.to_string() })
        }
        _ => Err(RobotError::UnknownJointType { at, joint: name.to_string(), joint_type: ty.to_string() }),
    }
}

/// A joint needs `<parent link>` and `<child link>`; revolute and prismatic
/// joints need `<limit>` (URDF 1.0/1.1, as urdfdom demands).
fn check_joint_children(node: &roxmltree::Node, name: &str, at: &SourceLocation) -> Result<(), RobotError> {
    let child = |tag: &str| node.children().find(|c| c.has_tag_name(tag));
    for role in ["parent", "child"] {
        if child(role).and_then(|c| c.attribute("link")).is_none() {
            return Err(RobotError::InvalidUrdf {
                at: at.clone(),
                message: format!("joint '{name}' has no <{role} link=\"…\"/> element"),
            });
        }
    }
    let ty = node.attribute("type").unwrap_or_default();
    if matches!(ty, "revolute" | "prismatic") && child("limit").is_none() {
        return Err(RobotError::InvalidUrdf {
            at: at.clone(),
            message: format!("joint '{name}' is {ty} but has no <limit lower upper velocity effort/> element"),
        });
    }
    Ok(())
}

/// Numeric attributes of URDF elements: (element, attribute, number of values).
const NUMERIC: &[(&str, &str, usize)] = &[
    ("origin", "xyz", 3),
    ("origin", "rpy", 3),
    ("axis", "xyz", 3),
    ("limit", "lower", 1),
    ("limit", "upper", 1),
    ("limit", "velocity", 1),
    ("limit", "effort", 1),
    ("box", "size", 3),
    ("sphere", "radius", 1),
    ("cylinder", "radius", 1),
    ("cylinder", "length", 1),
    ("capsule", "radius", 1),
    ("capsule", "length", 1),
    ("mesh", "scale", 3),
    ("mimic", "multiplier", 1),
    ("mimic", "offset", 1),
];

/// Every numeric attribute below a link or joint parses, with the right count.
fn check_numbers(
    doc: &roxmltree::Document,
    element: &roxmltree::Node,
    tag: &str,
    name: &str,
    source: &str,
) -> Result<(), RobotError> {
    for node in element.descendants().filter(roxmltree::Node::is_element) {
        // Visuals are blanked before parsing; their numbers do not matter.
        if node.ancestors().any(|a| a.has_tag_name("visual")) {
            continue;
        }
        for &(el, attr, count) in NUMERIC.iter().filter(|(el, _, _)| node.has_tag_name(*el)) {
            let Some(text) = node.attribute(attr) else { continue };
            let values: Vec<&str> = text.split_whitespace().collect();
            let parsed = values.iter().all(|v| v.parse::<f64>().is_ok());
            if values.len() != count || !parsed {
                let expected = if count == 1 { "a number".to_string() } else { format!("{count} numbers") };
                return Err(RobotError::InvalidUrdf {
                    at: SourceLocation {
                        source: source.to_string(),
                        line: Some(doc.text_pos_at(node.range().start).row),
                    },
                    message: format!("{tag} '{name}': <{el} {attr}=\"{text}\"> must be {expected}"),
                });
            }
        }
    }
    Ok(())
}
