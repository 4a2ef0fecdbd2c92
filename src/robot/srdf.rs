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

/// An SRDF entry [`Srdf::reconcile`] dropped because it names a link,
/// joint or group the robot lacks.
#[derive(Debug, Clone, PartialEq)]
pub struct SrdfWarning {
    /// The SRDF file and line of the entry.
    pub at: SourceLocation,
    /// What was unknown and what was dropped.
    pub message: String,
}

impl std::fmt::Display for SrdfWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.at, self.message)
    }
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

    /// The joints a group moves, as MoveIt defines a group: the union of
    /// its chains, joints, links (each standing for the joint above it) and
    /// subgroups, recursively. A group of one chain is a
    /// [`JointSelection::Chain`]; anything else (several chains, both arms
    /// of a dual-arm robot, a torso joint plus an arm chain, joint lists
    /// naming fixed joints) a [`JointSelection::Union`] of the chains,
    /// joints and links of the group and its subgroups, whose joints the
    /// model orders depth first down the kinematic tree, as MoveIt does.
    ///
    /// # Errors
    /// No group of that name, a subgroup naming no group, a group that
    /// contains itself (through subgroups), a group with no members.
    pub fn joint_selection(&self, group: &str) -> Result<JointSelection, RobotError> {
        let g = self.group(group).ok_or_else(|| self.invalid(None, format!("no group named '{group}'")))?;
        if let ([(base, tip)], true, true, true) =
            (g.chains.as_slice(), g.joints.is_empty(), g.links.is_empty(), g.subgroups.is_empty())
        {
            return Ok(JointSelection::Chain { root: base.clone(), tip: tip.clone() });
        }
        let (mut chains, mut joints, mut links) = (Vec::new(), Vec::new(), Vec::new());
        self.collect_members(g, &mut vec![g.name.as_str()], &mut chains, &mut joints, &mut links)?;
        if chains.is_empty() && joints.is_empty() && links.is_empty() {
            return Err(self.invalid(g.line, format!("group '{group}' has no chains, joints or links")));
        }
        Ok(JointSelection::Union { chains, joints, links })
    }

    /// Adds `g`'s members and its subgroups' (depth first) to the lists;
    /// `path` holds the groups being expanded, to refuse cycles.
    fn collect_members<'a>(
        &'a self,
        g: &'a Group,
        path: &mut Vec<&'a str>,
        chains: &mut Vec<(String, String)>,
        joints: &mut Vec<String>,
        links: &mut Vec<String>,
    ) -> Result<(), RobotError> {
        chains.extend(g.chains.iter().cloned());
        joints.extend(g.joints.iter().cloned());
        links.extend(g.links.iter().cloned());
        for name in &g.subgroups {
            let sub = self.group(name).ok_or_else(|| {
                let close = suggest(name, self.groups.iter().map(|g| g.name.as_str()));
                self.invalid(
                    g.line,
                    format!("group '{}' names subgroup '{name}', which is no group{}", g.name, hint(&close)),
                )
            })?;
            if path.contains(&sub.name.as_str()) {
                let cycle = format!("{} -> {}", path.join(" -> "), sub.name);
                return Err(self.invalid(g.line, format!("groups contain themselves: {cycle}")));
            }
            path.push(&sub.name);
            self.collect_members(sub, path, chains, joints, links)?;
            path.pop();
        }
        Ok(())
    }

    /// Checks that every link, joint and group named exists: the first name
    /// [`Srdf::reconcile`] would warn about, as an error.
    ///
    /// # Errors
    /// [`RobotError::InvalidSrdf`] naming the SRDF line and the unknown name.
    pub fn check_against(&self, robot: &RobotDescription) -> Result<(), RobotError> {
        match self.clone().reconcile(robot).into_iter().next() {
            Some(w) => Err(RobotError::InvalidSrdf { at: w.at, message: w.message }),
            None => Ok(()),
        }
    }

    /// Drops every entry naming a link, joint or group that `robot` (or this
    /// SRDF) lacks, as MoveIt's srdfdom does ("Link … is not known to
    /// URDF"), and returns one warning per entry dropped: a disabled pair,
    /// a group's chain, joint, link or subgroup, a group state's joint
    /// value or a whole group state of an unknown group, a virtual joint.
    /// A robot description shared by several robots (one SRDF for a family
    /// of arms, a gripper left out of the URDF) then loads.
    pub fn reconcile(&mut self, robot: &RobotDescription) -> Vec<SrdfWarning> {
        let mut warnings = Vec::new();
        let source = self.source.clone();
        let mut warn = |line: Option<u32>, message: String| {
            warnings.push(SrdfWarning { at: SourceLocation { source: source.clone(), line }, message });
        };
        let unknown_link = |name: &str| {
            robot.link(name).is_none().then(|| {
                let close = suggest(name, robot.links().iter().map(|l| l.name.as_str()));
                format!("link '{name}' is not in robot '{}'{}", robot.name(), hint(&close))
            })
        };
        let unknown_joint = |name: &str| {
            robot.joint(name).is_none().then(|| {
                let close = suggest(name, robot.joints().iter().map(|j| j.name.as_str()));
                format!("joint '{name}' is not in robot '{}'{}", robot.name(), hint(&close))
            })
        };
        let group_names: Vec<String> = self.groups.iter().map(|g| g.name.clone()).collect();
        for g in &mut self.groups {
            let (name, line) = (g.name.clone(), g.line);
            g.chains.retain(|(base, tip)| match unknown_link(base).or_else(|| unknown_link(tip)) {
                Some(m) => {
                    warn(line, format!("{m}; chain {base} -> {tip} left out of group '{name}'"));
                    false
                }
                None => true,
            });
            g.joints.retain(|j| keep(unknown_joint(j), |m| warn(line, format!("{m}; left out of group '{name}'"))));
            g.links.retain(|l| keep(unknown_link(l), |m| warn(line, format!("{m}; left out of group '{name}'"))));
            g.subgroups.retain(|s| {
                let message = (!group_names.contains(s)).then(|| {
                    let close = suggest(s, group_names.iter().map(String::as_str));
                    format!("subgroup '{s}' is no group of this SRDF{}", hint(&close))
                });
                keep(message, |m| warn(line, format!("{m}; left out of group '{name}'")))
            });
        }
        self.group_states.retain_mut(|s| {
            if !group_names.contains(&s.group) {
                warn(
                    s.line,
                    format!("group state '{}' is for group '{}', which this SRDF lacks; ignored", s.name, s.group),
                );
                return false;
            }
            let (name, line) = (s.name.clone(), s.line);
            s.values.retain(|(j, _)| {
                keep(unknown_joint(j), |m| warn(line, format!("{m}; left out of group state '{name}'")))
            });
            true
        });
        self.disabled_pairs.retain(|p| {
            let message = unknown_link(&p.link1).or_else(|| unknown_link(&p.link2));
            keep(message, |m| warn(p.line, format!("{m}; disable_collisions {} / {} ignored", p.link1, p.link2)))
        });
        self.virtual_joints.retain(|v| {
            keep(unknown_link(&v.child_link), |m| warn(v.line, format!("{m}; virtual joint '{}' ignored", v.name)))
        });
        warnings
    }

    fn invalid(&self, line: Option<u32>, message: String) -> RobotError {
        RobotError::InvalidSrdf { at: SourceLocation { source: self.source.clone(), line }, message }
    }
}

/// True when `problem` is `None`; otherwise reports it and returns false
/// (a `retain` predicate that warns about what it drops).
fn keep(problem: Option<String>, report: impl FnOnce(String)) -> bool {
    match problem {
        Some(message) => {
            report(message);
            false
        }
        None => true,
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
