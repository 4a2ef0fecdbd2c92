//! Compiling a [`RobotDescription`] into a [`RobotModel`]: choosing the
//! active joints (by name, chain or union), fixing the held ones, and
//! folding every constant joint into the placements of the moving bodies.

use super::{Body, Frame, FrameKind, JointSelection, Motion, RobotModel, default_value, resolve_value};
use crate::robot::description::RobotDescription;
use crate::robot::error::{RobotError, suggest};
use crate::robot::motion_limits::{JointMotionLimits, LimitSource, builtin_limits};
use crate::robot::placement::Placement;
use nalgebra::IsometryMatrix3;
use std::collections::HashMap;
use std::sync::Arc;

impl RobotModel {
    pub(super) fn compile(
        description: Arc<RobotDescription>,
        selection: &JointSelection,
        held: &[(String, f64)],
    ) -> Result<RobotModel, RobotError> {
        let active = select_joints(&description, selection)?;
        let held_values = held_joint_values(&description, &active, held)?;
        let mut compiler = Compiler::new(&description, &active, &held_values);
        compiler.walk(description.root_index());
        let (bodies, link_places) = (compiler.bodies, compiler.link_places);
        let frames = make_frames(&description, &link_places);
        let mut frame_lookup = HashMap::new();
        for (i, f) in frames.iter().enumerate().rev() {
            frame_lookup.insert(f.name.clone(), i);
        }
        let joints = description.joints();
        let joint_names: Vec<String> = active.iter().map(|&j| joints[j].name.clone()).collect();
        let mut motion: Vec<JointMotionLimits> =
            active.iter().map(|&j| JointMotionLimits::default_for(joints[j].limits.velocity)).collect();
        // The embedded Panda is a Panda: Franka's published limits.
        if description.source() == RobotDescription::panda_source() {
            for (limits, name) in motion.iter_mut().zip(&joint_names) {
                if let Some((set, profile)) = builtin_limits("franka_panda", name) {
                    limits.apply(&set, profile, &LimitSource::Builtin("franka_panda"));
                }
            }
        }
        Ok(RobotModel {
            joint_names,
            motion,
            limits: active.iter().map(|&j| joints[j].limits).collect(),
            active,
            held_values,
            bodies,
            frames,
            frame_lookup,
            description,
        })
    }
}

fn unknown_joint(desc: &RobotDescription, name: &str) -> RobotError {
    RobotError::UnknownJoint {
        name: name.to_string(),
        suggestions: suggest(name, desc.joints().iter().map(|j| j.name.as_str())),
    }
}

fn select_joints(desc: &RobotDescription, selection: &JointSelection) -> Result<Vec<usize>, RobotError> {
    let joints = desc.joints();
    let independent = |j: usize| joints[j].kind.is_movable() && joints[j].mimic.is_none();
    match selection {
        JointSelection::Independent => Ok((0..joints.len()).filter(|&j| independent(j)).collect()),
        JointSelection::Names(names) => {
            let mut out = Vec::with_capacity(names.len());
            for name in names {
                let j = desc.joint_index(name).ok_or_else(|| unknown_joint(desc, name))?;
                let reason = if !joints[j].kind.is_movable() {
                    Some("it is a fixed joint".to_string())
                } else {
                    joints[j].mimic.as_ref().map(|m| format!("it mimics '{}'", joints[m.joint].name))
                };
                if let Some(reason) = reason {
                    return Err(RobotError::NotActuable { joint: name.clone(), reason });
                }
                if out.contains(&j) {
                    return Err(RobotError::NotActuable { joint: name.clone(), reason: "it is listed twice".into() });
                }
                out.push(j);
            }
            Ok(out)
        }
        JointSelection::Chain { root, tip } => chain_joints(desc, root, tip),
        JointSelection::Union { chains, joints: names, links } => union_joints(desc, chains, names, links),
    }
}

/// The independent movable joints of a MoveIt group's members, first
/// appearance first (see [`JointSelection::Union`]).
fn union_joints(
    desc: &RobotDescription,
    chains: &[(String, String)],
    names: &[String],
    links: &[String],
) -> Result<Vec<usize>, RobotError> {
    let joints = desc.joints();
    let independent = |j: usize| joints[j].kind.is_movable() && joints[j].mimic.is_none();
    let mut listed = Vec::new();
    for (root, tip) in chains {
        listed.extend(chain_joints(desc, root, tip)?);
    }
    for name in names {
        listed.push(desc.joint_index(name).ok_or_else(|| unknown_joint(desc, name))?);
    }
    for name in links {
        let link = desc.link_index(name).ok_or_else(|| RobotError::UnknownFrame {
            name: name.clone(),
            suggestions: suggest(name, desc.links().iter().map(|l| l.name.as_str())),
        })?;
        listed.extend(desc.links()[link].parent_joint);
    }
    // Depth-first tree order, as MoveIt orders a group's joints.
    let rank = tree_order(desc);
    let mut out: Vec<usize> = listed.into_iter().filter(|&j| independent(j)).collect();
    out.sort_by_key(|&j| rank[j]);
    out.dedup();
    Ok(out)
}

/// Each joint's position in a depth-first walk of the tree from the root
/// (children in URDF order).
fn tree_order(desc: &RobotDescription) -> Vec<usize> {
    let children = desc.children();
    let mut rank = vec![0; desc.joints().len()];
    let mut stack: Vec<usize> = children[desc.root_index()].iter().rev().copied().collect();
    let mut next = 0;
    while let Some(j) = stack.pop() {
        rank[j] = next;
        next += 1;
        stack.extend(children[desc.joints()[j].child].iter().rev());
    }
    rank
}

/// The independent movable joints from link `root` down to frame `tip`, root first.
fn chain_joints(desc: &RobotDescription, root: &str, tip: &str) -> Result<Vec<usize>, RobotError> {
    let joints = desc.joints();
    let independent = |j: usize| joints[j].kind.is_movable() && joints[j].mimic.is_none();
    let tip_link = frame_link(desc, tip)?;
    let root_link = desc.link_index(root).ok_or_else(|| RobotError::UnknownFrame {
        name: root.to_string(),
        suggestions: suggest(root, desc.links().iter().map(|l| l.name.as_str())),
    })?;
    let path = desc.joints_to_root(tip_link);
    let start = if root_link == desc.root_index() {
        0
    } else {
        path.iter()
            .position(|&j| joints[j].parent == root_link)
            .ok_or_else(|| RobotError::NotAChain { root: root.to_string(), tip: tip.to_string() })?
    };
    Ok(path[start..].iter().copied().filter(|&j| independent(j)).collect())
}

/// The link a frame name belongs to (a link, or a joint's child link).
fn frame_link(desc: &RobotDescription, name: &str) -> Result<usize, RobotError> {
    desc.link_index(name).or_else(|| desc.joint_index(name).map(|j| desc.joints()[j].child)).ok_or_else(|| {
        RobotError::UnknownFrame {
            name: name.to_string(),
            suggestions: suggest(
                name,
                desc.links().iter().map(|l| l.name.as_str()).chain(desc.joints().iter().map(|j| j.name.as_str())),
            ),
        }
    })
}

fn held_joint_values(
    desc: &RobotDescription,
    active: &[usize],
    held: &[(String, f64)],
) -> Result<Vec<f64>, RobotError> {
    let joints = desc.joints();
    let mut values: Vec<f64> = joints.iter().map(|j| default_value(&j.limits)).collect();
    for (name, value) in held {
        let j = desc.joint_index(name).ok_or_else(|| unknown_joint(desc, name))?;
        let joint = &joints[j];
        if active.contains(&j) || !joint.kind.is_movable() || joint.mimic.is_some() {
            return Err(RobotError::NotActuable {
                joint: name.clone(),
                reason: "only inactive, independent movable joints can be held".into(),
            });
        }
        if !value.is_finite() || !joint.limits.contains(*value) {
            return Err(RobotError::HeldValueOutOfRange {
                joint: name.clone(),
                value: *value,
                lower: joint.limits.lower,
                upper: joint.limits.upper,
            });
        }
        values[j] = *value;
    }
    for &j in active {
        values[j] = 0.0;
    }
    Ok(values)
}

/// Depth-first walk that folds constant joints into placements.
struct Compiler<'a> {
    desc: &'a RobotDescription,
    children: Vec<Vec<usize>>,
    /// Active column of each description joint, if active.
    column: Vec<Option<usize>>,
    held_values: &'a [f64],
    bodies: Vec<Body>,
    /// (body, placement in body) of each link.
    link_places: Vec<(usize, IsometryMatrix3<f64>)>,
}

impl<'a> Compiler<'a> {
    fn new(desc: &'a RobotDescription, active: &[usize], held_values: &'a [f64]) -> Self {
        let mut column = vec![None; desc.joints().len()];
        for (k, &j) in active.iter().enumerate() {
            column[j] = Some(k);
        }
        Compiler {
            desc,
            children: desc.children(),
            column,
            held_values,
            bodies: vec![Body {
                parent: 0,
                placement: Placement::new(&IsometryMatrix3::identity()),
                motion: Motion::RevoluteZ,
                column: 0,
                multiplier: 0.0,
                offset: 0.0,
            }],
            link_places: vec![(0, IsometryMatrix3::identity()); desc.links().len()],
        }
    }

    /// The active column driving joint `j` (through mimics) with the combined
    /// multiplier and offset, or `None` when the joint does not move.
    fn driver(&self, j: usize) -> Option<(usize, f64, f64)> {
        let joints = self.desc.joints();
        let (mut multiplier, mut offset, mut at) = (1.0, 0.0, j);
        loop {
            joints[at].kind.is_movable().then_some(())?;
            match &joints[at].mimic {
                None => return self.column[at].map(|c| (c, multiplier, offset)),
                Some(m) => {
                    offset += multiplier * m.offset;
                    multiplier *= m.multiplier;
                    at = m.joint;
                }
            }
        }
    }

    /// Places every link under `root` and pushes a body for each moving
    /// joint, depth first with children in URDF order (so a parent body
    /// always comes before its children). An explicit stack, not
    /// recursion: a chain of any length fits (a 10,000-link chain
    /// overflowed the call stack).
    fn walk(&mut self, root: usize) {
        self.link_places[root] = (0, IsometryMatrix3::identity());
        // Joints still to visit, with the body and placement of their parent link.
        let mut pending: Vec<(usize, usize, IsometryMatrix3<f64>)> = Vec::new();
        let push_children = |pending: &mut Vec<_>, link: usize, body: usize, place: IsometryMatrix3<f64>| {
            pending.extend(self.children[link].iter().rev().map(|&j| (j, body, place)));
        };
        push_children(&mut pending, root, 0, IsometryMatrix3::identity());
        while let Some((j, body, place)) = pending.pop() {
            let joint = &self.desc.joints()[j];
            let at_joint = place * joint.origin;
            let (child_body, child_place) = match (self.driver(j), Motion::new(&joint.kind)) {
                (Some((column, multiplier, offset)), Some(motion)) => {
                    self.bodies.push(Body {
                        parent: body,
                        placement: Placement::new(&at_joint),
                        motion,
                        column,
                        multiplier,
                        offset,
                    });
                    (self.bodies.len() - 1, IsometryMatrix3::identity())
                }
                (_, motion) => {
                    let value = resolve_value(self.desc.joints(), self.held_values, j);
                    let moved = motion.map_or(IsometryMatrix3::identity(), |m| m.displacement(value));
                    (body, at_joint * moved)
                }
            };
            self.link_places[joint.child] = (child_body, child_place);
            push_children(&mut pending, joint.child, child_body, child_place);
        }
    }
}

fn make_frames(desc: &RobotDescription, link_places: &[(usize, IsometryMatrix3<f64>)]) -> Vec<Frame> {
    let links = desc.links().iter().enumerate().map(|(i, l)| Frame {
        name: l.name.clone(),
        kind: FrameKind::Link,
        element: i,
        body: link_places[i].0,
        placement: Placement::new(&link_places[i].1),
    });
    let joints = desc.joints().iter().enumerate().map(|(i, j)| Frame {
        name: j.name.clone(),
        kind: FrameKind::Joint,
        element: i,
        body: link_places[j.child].0,
        placement: Placement::new(&link_places[j.child].1),
    });
    links.chain(joints).collect()
}
