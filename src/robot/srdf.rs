//! SRDF (MoveIt's semantic robot description): planning groups, named
//! group states and the link pairs whose collisions are disabled.
//!
//! Parsed with line numbers, and checked against a [`RobotDescription`] so a
//! misspelt link or joint is an error naming the SRDF line.
//!
//! ```
//! use tandem::robot::Srdf;
//! let srdf = Srdf::from_srdf_str(r#"<robot name="arm">
//!   <group name="arm"><chain base_link="base" tip_link="tool"/></group>
//!   <group_state name="home" group="arm"><joint name="j1" value="0.5"/></group_state>
//!   <disable_collisions link1="base" link2="link1" reason="Adjacent"/>
//! </robot>"#).unwrap();
//! assert_eq!(srdf.disabled_pairs.len(), 1);
//! assert_eq!(srdf.group_state("home").unwrap().values[0].1, 0.5);
//! ```

use super::error::{RobotError, SourceLocation};
use super::model::JointSelection;
use super::{RobotDescription, error::suggest};
use std::path::Path;

/// A planning group: chains, joints, links and subgroups, as written.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Group {
    /// Name, as in the SRDF.
    pub name: String,
    /// `(base_link, tip_link)` of each `<chain>`.
    pub chains: Vec<(String, String)>,
    /// Joints listed by `<joint>`.
    pub joints: Vec<String>,
    /// Links listed by `<link>`.
    pub links: Vec<String>,
    /// Groups listed by `<group>`.
    pub subgroups: Vec<String>,
    /// 1-based line in the source file, when known.
    pub line: Option<u32>,
}

/// A named configuration of a group (rad or m per joint).
#[derive(Debug, Clone, PartialEq)]
pub struct GroupState {
    /// Name, as in the SRDF.
    pub name: String,
    /// The group it configures.
    pub group: String,
    /// Joint values (rad or m) by joint name.
    pub values: Vec<(String, f64)>,
    /// 1-based line in the source file, when known.
    pub line: Option<u32>,
}

/// A pair of links never checked against each other.
#[derive(Debug, Clone, PartialEq)]
pub struct DisabledPair {
    /// One link.
    pub link1: String,
    /// The other link.
    pub link2: String,
    /// MoveIt's reason (`Adjacent`, `Never`, `Default`, …).
    pub reason: String,
    /// 1-based line in the source file, when known.
    pub line: Option<u32>,
}

/// A joint between a frame outside the robot and one of its links (MoveIt
/// places the robot's root in the planning frame with one).
#[derive(Debug, Clone, PartialEq)]
pub struct VirtualJoint {
    /// Name, as in the SRDF.
    pub name: String,
    /// `fixed`, `floating` or `planar`.
    pub kind: String,
    /// The frame outside the robot (e.g. `world`): MoveIt's planning frame.
    pub parent_frame: String,
    /// The robot link it places (the URDF root).
    pub child_link: String,
    /// 1-based line in the source file, when known.
    pub line: Option<u32>,
}

/// The parsed SRDF.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Srdf {
    /// Name, as in the SRDF.
    pub name: String,
    /// The file it was read from (or `<string>`).
    pub source: String,
    /// Planning groups.
    pub groups: Vec<Group>,
    /// Named group configurations.
    pub group_states: Vec<GroupState>,
    /// Link pairs never checked for collisions.
    pub disabled_pairs: Vec<DisabledPair>,
    /// Joints placing the robot in an outer frame.
    pub virtual_joints: Vec<VirtualJoint>,
}

impl Srdf {
    /// Reads and parses an SRDF file.
    pub fn from_srdf_file(path: impl AsRef<Path>) -> Result<Srdf, RobotError> {
        let path = path.as_ref();
        let text =
            std::fs::read_to_string(path).map_err(|source| RobotError::Io { path: path.to_path_buf(), source })?;
        parse(&text, &path.display().to_string())
    }

    /// Parses SRDF text.
    pub fn from_srdf_str(text: &str) -> Result<Srdf, RobotError> {
        parse(text, "<string>")
    }

    /// The group with this name.
    pub fn group(&self, name: &str) -> Option<&Group> {
        self.groups.iter().find(|g| g.name == name)
    }

    /// The group state with this name.
    pub fn group_state(&self, name: &str) -> Option<&GroupState> {
        self.group_states.iter().find(|g| g.name == name)
    }

    /// True when collisions between `a` and `b` are disabled (either order).
    pub fn is_disabled(&self, a: &str, b: &str) -> bool {
        self.disabled_pairs.iter().any(|p| (p.link1 == a && p.link2 == b) || (p.link1 == b && p.link2 == a))
    }

    /// The active joints of a group with a single chain, as a selection.
    pub fn joint_selection(&self, group: &str) -> Result<JointSelection, RobotError> {
        let g = self.group(group).ok_or_else(|| self.invalid(None, format!("no group named '{group}'")))?;
        match (g.chains.as_slice(), g.joints.is_empty()) {
            ([(base, tip)], true) => Ok(JointSelection::Chain { root: base.clone(), tip: tip.clone() }),
            ([], false) => Ok(JointSelection::Names(g.joints.clone())),
            _ => Err(self.invalid(g.line, format!("group '{group}' must be one chain or a list of joints"))),
        }
    }

    /// Checks that every link and joint named exists in `robot`.
    pub fn check_against(&self, robot: &RobotDescription) -> Result<(), RobotError> {
        let link = |name: &str, line| {
            robot.link(name).map(|_| ()).ok_or_else(|| {
                let close = suggest(name, robot.links().iter().map(|l| l.name.as_str()));
                self.invalid(line, format!("link '{name}' is not in robot '{}'{}", robot.name(), hint(&close)))
            })
        };
        let joint = |name: &str, line| {
            robot.joint(name).map(|_| ()).ok_or_else(|| {
                let close = suggest(name, robot.joints().iter().map(|j| j.name.as_str()));
                self.invalid(line, format!("joint '{name}' is not in robot '{}'{}", robot.name(), hint(&close)))
            })
        };
        for g in &self.groups {
            for (base, tip) in &g.chains {
                link(base, g.line)?;
                link(tip, g.line)?;
            }
            g.links.iter().try_for_each(|l| link(l, g.line))?;
            g.joints.iter().try_for_each(|j| joint(j, g.line))?;
        }
        for s in &self.group_states {
            s.values.iter().try_for_each(|(j, _)| joint(j, s.line))?;
        }
        for p in &self.disabled_pairs {
            link(&p.link1, p.line)?;
            link(&p.link2, p.line)?;
        }
        for v in &self.virtual_joints {
            link(&v.child_link, v.line)?;
        }
        Ok(())
    }

    fn invalid(&self, line: Option<u32>, message: String) -> RobotError {
        RobotError::InvalidSrdf { at: SourceLocation { source: self.source.clone(), line }, message }
    }
}

fn hint(close: &[String]) -> String {
    if close.is_empty() { String::new() } else { format!(" (did you mean {}?)", close.join(", ")) }
}

fn parse(text: &str, source: &str) -> Result<Srdf, RobotError> {
    let at = |line: u32| SourceLocation { source: source.to_string(), line: Some(line) };
    let doc = roxmltree::Document::parse(text)
        .map_err(|e| RobotError::MalformedXml { at: at(e.pos().row), message: e.to_string() })?;
    let index = super::xml_checks::LineIndex::new(text);
    let line = |n: &roxmltree::Node| index.line(n);
    let attr = |n: &roxmltree::Node, key: &str| -> Result<String, RobotError> {
        n.attribute(key).map(str::to_string).ok_or_else(|| RobotError::InvalidSrdf {
            at: at(line(n)),
            message: format!("<{}> needs a {key} attribute", n.tag_name().name()),
        })
    };
    let root = doc.root_element();
    let mut srdf = Srdf {
        name: root.attribute("name").unwrap_or_default().to_string(),
        source: source.to_string(),
        ..Default::default()
    };
    for node in root.children().filter(roxmltree::Node::is_element) {
        match node.tag_name().name() {
            "group" => {
                let mut g = Group { name: attr(&node, "name")?, line: Some(line(&node)), ..Default::default() };
                for c in node.children().filter(roxmltree::Node::is_element) {
                    match c.tag_name().name() {
                        "chain" => g.chains.push((attr(&c, "base_link")?, attr(&c, "tip_link")?)),
                        "joint" => g.joints.push(attr(&c, "name")?),
                        "link" => g.links.push(attr(&c, "name")?),
                        "group" => g.subgroups.push(attr(&c, "name")?),
                        _ => {}
                    }
                }
                srdf.groups.push(g);
            }
            "group_state" => {
                let mut values = Vec::new();
                for j in node.children().filter(|c| c.has_tag_name("joint")) {
                    let raw = attr(&j, "value")?;
                    let value = raw.trim().parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
                        RobotError::InvalidSrdf {
                            at: at(line(&j)),
                            message: format!("joint value '{raw}' is not a finite number"),
                        }
                    })?;
                    values.push((attr(&j, "name")?, value));
                }
                srdf.group_states.push(GroupState {
                    name: attr(&node, "name")?,
                    group: attr(&node, "group")?,
                    values,
                    line: Some(line(&node)),
                });
            }
            "virtual_joint" => srdf.virtual_joints.push(VirtualJoint {
                name: attr(&node, "name")?,
                kind: attr(&node, "type")?,
                parent_frame: attr(&node, "parent_frame")?,
                child_link: attr(&node, "child_link")?,
                line: Some(line(&node)),
            }),
            "disable_collisions" => srdf.disabled_pairs.push(DisabledPair {
                link1: attr(&node, "link1")?,
                link2: attr(&node, "link2")?,
                reason: node.attribute("reason").unwrap_or_default().to_string(),
                line: Some(line(&node)),
            }),
            _ => {}
        }
    }
    Ok(srdf)
}
