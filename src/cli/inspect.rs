//! `tandem inspect`: a readable account of a URDF (and of an SRDF for it:
//! its planning groups' active joints, and the entries naming what the
//! URDF lacks, which MoveIt and tandem ignore).

use super::UrdfArgs;
use crate::collision::CollisionModel;
use crate::problem::{JointLimitsFile, apply_joint_limits};
use crate::robot::{Geometry, JointKind, RobotDescription, RobotModel, Srdf};
use std::fmt::Write;
use std::path::PathBuf;
use std::sync::Arc;

/// Arguments of `tandem inspect`.
#[derive(Debug, clap::Args)]
pub struct InspectArgs {
    #[command(flatten)]
    pub urdf: UrdfArgs,
    /// The robot's SRDF: list its planning groups with the joints each
    /// moves (MoveIt groups: chains, joints, links, subgroups), and warn
    /// about entries naming links, joints or groups the URDF lacks (left
    /// out on loading, as MoveIt does).
    #[arg(long, value_name = "FILE")]
    pub srdf: Option<PathBuf>,
    /// The joints' acceleration, deceleration and jerk limits: a MoveIt /
    /// ros2_control `joint_limits.yaml`, or `builtin:franka_panda` /
    /// `builtin:franka_fr3`. The report's "motion limits" say which limit
    /// came from where (URDF, this file, the built-in table, tandem's
    /// defaults).
    #[arg(long, value_name = "FILE")]
    pub joint_limits: Option<String>,
}

pub(super) fn run(args: &InspectArgs) -> Result<(), Box<dyn std::error::Error>> {
    let desc = args.urdf.load()?;
    print!("{}", report(&desc));
    let mut model = RobotModel::builder(Arc::new(desc.clone())).build()?;
    if let Some(limits) = &args.joint_limits {
        apply_joint_limits(&mut model, limits, |f| JointLimitsFile::read(f))
            .map_err(|e| format!("--joint-limits: {e}"))?;
    }
    print!("{}", motion_limits_report(&model));
    if let Some(path) = &args.srdf {
        let srdf = Srdf::from_srdf_file(path)?;
        print!("{}", srdf_report(Arc::new(desc), srdf));
    }
    Ok(())
}

/// The SRDF part of `tandem inspect`: warnings, then each group's joints.
pub fn srdf_report(desc: Arc<RobotDescription>, mut srdf: Srdf) -> String {
    let mut out = String::new();
    let warnings = srdf.reconcile(&desc);
    let _ = writeln!(
        out,
        "
SRDF {}: {} groups, {} group states, {} disabled pairs",
        srdf.source,
        srdf.groups.len(),
        srdf.group_states.len(),
        srdf.disabled_pairs.len()
    );
    let count = if warnings.is_empty() { "none".to_string() } else { warnings.len().to_string() };
    let _ = writeln!(out, "SRDF warnings (entries left out, as MoveIt does): {count}");
    for w in &warnings {
        let _ = writeln!(out, "  - {w}");
    }
    out.push_str("planning groups:\n");
    for g in &srdf.groups {
        let joints = srdf
            .joint_selection(&g.name)
            .map_err(|e| e.to_string())
            .and_then(|s| RobotModel::builder(desc.clone()).selection(s).build().map_err(|e| e.to_string()));
        let _ = match joints {
            Ok(m) => writeln!(out, "  {:<20} {} joints: {}", g.name, m.nq(), m.joint_names().join(", ")),
            Err(e) => writeln!(out, "  {:<20} unusable: {e}", g.name),
        };
    }
    out
}

/// The motion limits of `model`'s active joints, each with its source.
pub fn motion_limits_report(model: &RobotModel) -> String {
    let mut out =
        String::from("\nmotion limits (per s: velocity, acceleration, deceleration, jerk; where each came from):\n");
    for (j, (name, l)) in model.joint_names().iter().zip(model.motion_limits()).enumerate() {
        let unit = model.joint_unit(j).unwrap_or("rad");
        let [v, a, d, k] = &l.sources;
        let _ = write!(
            out,
            "  {name:<28} {} {unit}/s ({v}), {} {unit}/s² ({a}), {} {unit}/s² ({d}), {} {unit}/s³ ({k})",
            l.velocity, l.acceleration, l.deceleration, l.jerk
        );
        if let Some(p) = &l.velocity_profile {
            let _ = write!(
                out,
                ", velocity by position: cap {} offset {} gain {} stop at [{}, {}]",
                p.cap, p.offset, p.gain, p.lower, p.upper
            );
        }
        out.push('\n');
    }
    out
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
    fast_path_report(desc, &mut out);
    let problems = desc.lint();
    let count = if problems.is_empty() { "none".to_string() } else { problems.len().to_string() };
    let _ = writeln!(out, "\nproblems found: {count}");
    for p in problems {
        let _ = writeln!(out, "  - {p}");
    }
    out
}

/// Whether the robot's collision geometry takes the sphere fast path
/// (boolean checks and motion certification in lanes), and if not, which
/// links keep it off and what would put it on.
fn fast_path_report(desc: &RobotDescription, out: &mut String) {
    let off: Vec<&str> = desc
        .links()
        .iter()
        .filter(|l| l.collisions.iter().any(|c| !matches!(c.geometry, Geometry::Sphere { .. })))
        .map(|l| l.name.as_str())
        .collect();
    let with_geometry = desc.links().iter().filter(|l| !l.collisions.is_empty()).count();
    out.push_str("\ncollision fast path:\n");
    if off.is_empty() && with_geometry > 0 {
        out.push_str(
            "  every collision element is a sphere: checks and motion certification take the sphere fast path\n  \
             (revolute and prismatic joints, any number of chains), against sphere, capsule, box and\n  \
             cylinder obstacles (a scene with a mesh obstacle uses the general path)\n",
        );
        compiled_fast_path(desc, out);
        return;
    }
    let _ = writeln!(
        out,
        "  general path (exact convex distances): {} of {with_geometry} links with geometry have non-sphere \
         elements ({})",
        off.len(),
        off.join(", ")
    );
    out.push_str(
        "  what would take the fast path: a sphere model of the robot, every <collision> a <sphere>, as a second\n  \
         URDF (problem file `robot.collision_urdf`, or as --urdf for MoveIt inputs), e.g. the spherized URDFs of\n  \
         MotionBenchMaker and VAMP, or one fitted with foam (github.com/CoMMALab/foam)\n",
    );
}

/// Robots with more links than this are not compiled for the report (a
/// model's self pairs grow with the square of its links).
const MOST_LINKS_COMPILED: usize = 256;

/// What the compiled fast path makes of the robot alone (every movable
/// joint active, no obstacles): the joint frames it takes as exact quarter
/// turns, and whether plain checks run first in single precision.
fn compiled_fast_path(desc: &RobotDescription, out: &mut String) {
    if desc.links().len() > MOST_LINKS_COMPILED {
        let _ = writeln!(out, "  (not compiled for this report: more than {MOST_LINKS_COMPILED} links)");
        return;
    }
    let robot = RobotModel::builder(Arc::new(desc.clone())).build();
    let Some(model) = robot.ok().and_then(|r| CollisionModel::builder(Arc::new(r)).build().ok()) else { return };
    if let Some(snapped) = model.snapped_quarter_turns().filter(|s| s.frames > 0) {
        let _ = writeln!(
            out,
            "  {} joint frames within 1e-9 of a quarter turn are taken as exact ones (every sphere within {:.1e} m \
             of the exact model)",
            snapped.frames, snapped.error
        );
    }
    let _ = match model.single_precision_band() {
        Some(band) => writeln!(
            out,
            "  plain checks run first in single precision and defer to f64 within {band:.1e} m of a threshold (the \
             robot alone; a scene's extent widens the band)"
        ),
        None => writeln!(out, "  plain checks run in f64 (the single-precision bound would be too wide)"),
    };
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
