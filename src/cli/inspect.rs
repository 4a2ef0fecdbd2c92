//! `tandem inspect`: a readable account of a URDF.

use super::UrdfArgs;
use crate::robot::{Geometry, JointKind, RobotDescription};
use std::fmt::Write;

/// Arguments of `tandem inspect`.
#[derive(Debug, clap::Args)]
pub struct InspectArgs {
    #[command(flatten)]
    pub urdf: UrdfArgs,
}

pub(super) fn run(args: &InspectArgs) -> Result<(), Box<dyn std::error::Error>> {
    let desc = args.urdf.load()?;
    print!("{}", report(&desc));
    Ok(())
}

/// The full text of `tandem inspect`.
pub fn report(desc: &RobotDescription) -> String {
    let mut out = String::new();
    let movable = desc.joints().iter().filter(|j| j.kind.is_movable()).count();
    let _ = writeln!(
        out,
        "robot '{}' ({}): {} links, {} joints ({} movable, {} independent)",
        desc.name(),
        desc.source(),
        desc.links().len(),
        desc.joints().len(),
        movable,
        desc.independent_joints().len()
    );
    out.push_str("\nkinematic tree:\n");
    tree(desc, desc.links().iter().position(|l| l.name == desc.root_link()).unwrap_or(0), &mut out);
    out.push_str("\njoints:\n");
    for j in desc.joints() {
        let _ = write!(out, "  {:<28} {:<10}", j.name, j.kind.name());
        if let Some(axis) = j.kind.axis() {
            let _ = write!(out, " axis [{:.3} {:.3} {:.3}]", axis.x, axis.y, axis.z);
        }
        if j.kind.is_movable() {
            let l = &j.limits;
            let unit = if matches!(j.kind, JointKind::Prismatic { .. }) { "m" } else { "rad" };
            let _ = write!(
                out,
                " position [{}, {}] {unit}, velocity {} {unit}/s, effort {}",
                l.lower, l.upper, l.velocity, l.effort
            );
        }
        if let Some(m) = &j.mimic {
            let _ = write!(out, " mimics {} (x{} + {})", desc.joints()[m.joint].name, m.multiplier, m.offset);
        }
        out.push('\n');
    }
    out.push_str("\nframes (every link and joint is a frame):\n");
    let links: Vec<&str> = desc.links().iter().map(|l| l.name.as_str()).collect();
    let _ = writeln!(out, "  links:  {}", links.join(", "));
    let joints: Vec<&str> = desc.joints().iter().map(|j| j.name.as_str()).collect();
    let _ = writeln!(out, "  joints: {}", joints.join(", "));
    out.push_str("\ncollision geometry:\n");
    for l in desc.links() {
        if l.collisions.is_empty() {
            continue;
        }
        let shapes: Vec<String> = l.collisions.iter().map(|c| shape_summary(&c.geometry)).collect();
        let _ = writeln!(out, "  {:<28} {}", l.name, summarize(&shapes));
    }
    let problems = desc.lint();
    let count = if problems.is_empty() { "none".to_string() } else { problems.len().to_string() };
    let _ = writeln!(out, "\nproblems found: {count}");
    for p in problems {
        let _ = writeln!(out, "  - {p}");
    }
    out
}

/// Depth beyond which the tree is no longer indented further (its level is
/// printed instead), so a long chain prints in linear size.
const MAX_INDENT: usize = 32;

/// The kinematic tree below `root`, depth first (an explicit stack: a
/// 10,000-link chain would overflow the call stack).
fn tree(desc: &RobotDescription, root: usize, out: &mut String) {
    let children = desc.children();
    let indent = |depth: usize| {
        if depth <= MAX_INDENT { "  ".repeat(depth) } else { format!("{}[level {depth}] ", "  ".repeat(MAX_INDENT)) }
    };
    // (joint leading to the link, the link, the link line's depth)
    let mut pending = vec![(None, root, 1)];
    while let Some((joint, link, depth)) = pending.pop() {
        if let Some(j) = joint {
            let joint: &crate::robot::Joint = &desc.joints()[j];
            let _ = writeln!(out, "{}└─ {} ({})", indent(depth - 1), joint.name, joint.kind.name());
        }
        let _ = writeln!(out, "{}{}", indent(depth), desc.links()[link].name);
        for &j in children[link].iter().rev() {
            pending.push((Some(j), desc.joints()[j].child, depth + 2));
        }
    }
}

fn shape_summary(g: &Geometry) -> String {
    match g {
        Geometry::Box { half_extents: h } => {
            format!("box {:.3}x{:.3}x{:.3}", 2.0 * h.x, 2.0 * h.y, 2.0 * h.z)
        }
        Geometry::Cylinder { radius, length } => format!("cylinder r={radius:.3} l={length:.3}"),
        Geometry::Capsule { radius, length } => format!("capsule r={radius:.3} l={length:.3}"),
        Geometry::Sphere { radius } => format!("sphere r={radius:.3}"),
        Geometry::Mesh { path, mesh, .. } => format!(
            "mesh {} ({} vertices, {} triangles)",
            path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default(),
            mesh.vertices.len(),
            mesh.triangles.len()
        ),
        Geometry::UnreadableMesh { path, format, .. } => format!(
            "mesh {} (unreadable {format})",
            path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default()
        ),
    }
}

/// "sphere r=0.1 ×3, box …" — repeated shapes counted once.
fn summarize(shapes: &[String]) -> String {
    let mut parts: Vec<(String, usize)> = Vec::new();
    for s in shapes {
        match parts.iter_mut().find(|(p, _)| p == s) {
            Some((_, n)) => *n += 1,
            None => parts.push((s.clone(), 1)),
        }
    }
    if parts.len() > 4 {
        return format!("{} elements ({})", shapes.len(), kinds(shapes));
    }
    let text: Vec<String> = parts.into_iter().map(|(s, n)| if n > 1 { format!("{s} ×{n}") } else { s }).collect();
    text.join(", ")
}

fn kinds(shapes: &[String]) -> String {
    let mut kinds: Vec<&str> = shapes.iter().filter_map(|s| s.split(' ').next()).collect();
    kinds.sort_unstable();
    kinds.dedup();
    kinds.join(", ")
}
