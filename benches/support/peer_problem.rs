//! The trajectory problem as the peers (benches/peers/rai_komo.py,
//! casadi_komo.py, rai_generate.py) read it; shared by examples/komo_seeds.rs
//! and examples/family_export.rs (`#[path]` module).
//!
//! The keys: the optimizer's collision model in the collision scene exchange
//! format (URDF collision spheres by link and index, obstacles by shape and
//! world pose, every checked pair; no padding), the start, joint names and
//! limits, horizon, order, duration, time step, padding, and every objective
//! resolved (feature, frames — robot frames by name, fixed frames by world
//! pose —, axes, kind, scale, target, order, slices, margin).

use serde_json::{Map, Value, json};
use tandem::komo::{Feature, FrameRef, TrajectoryProblem};
use tandem::problem::{ObjectiveKind, Problem};

/// The keys above for `problem` posed as `tp` (its horizon may differ from
/// the problem file's).
pub fn problem_json(problem: &Problem, tp: &TrajectoryProblem) -> Result<Map<String, Value>, String> {
    let robot = tp.robot();
    let model = tp.collision_model().ok_or("the problem has no collision model")?;
    let urdf = problem.robot_spec.collision_urdf.as_ref().unwrap_or(&problem.robot_spec.urdf);
    let urdf = std::fs::canonicalize(urdf).map_err(|e| format!("robot URDF {}: {e}", urdf.display()))?;
    let exchange = model
        .to_exchange_json(&urdf, &[], &[])
        .ok_or("the collision model has shapes the exchange format cannot describe")?;
    let specs = &problem.optimizer.objectives;
    let mut objectives = Vec::new();
    for (index, objective) in tp.objectives().iter().enumerate() {
        let spec_frames = specs.get(index).map(|s| s.frames.as_slice()).unwrap_or(&[]);
        let frame = |k: usize, f: &FrameRef| match f {
            FrameRef::Robot(id) => json!({"robot": robot.frame_name(*id)}),
            FrameRef::Fixed(pose) => {
                let r = pose.rotation.matrix();
                json!({
                    "fixed": spec_frames.get(k).cloned().unwrap_or_else(|| format!("fixed{index}_{k}")),
                    "translation": pose.translation.vector.as_slice(),
                    "rotation": (0..3).map(|i| [r[(i, 0)], r[(i, 1)], r[(i, 2)]]).collect::<Vec<_>>(),
                })
            }
        };
        let (feature, frames, axes, margin) = match &objective.feature {
            Feature::JointState => ("joint_state", vec![], vec![], None),
            Feature::JointLimits { margin } => ("joint_limits", vec![], vec![], Some(*margin)),
            Feature::Position { frame: f } => ("position", vec![frame(0, f)], vec![], None),
            Feature::PositionDifference { a, b } => {
                ("position_difference", vec![frame(0, a), frame(1, b)], vec![], None)
            }
            Feature::ScalarProduct { a, axis_a, b, axis_b } => {
                ("scalar_product", vec![frame(0, a), frame(1, b)], vec![*axis_a, *axis_b], None)
            }
            Feature::Vector { a, axis, b } => ("vector", vec![frame(0, a), frame(1, b)], vec![*axis], None),
            Feature::OrientationDifference { a, b } => {
                ("orientation_difference", vec![frame(0, a), frame(1, b)], vec![], None)
            }
            Feature::Collision { margin, obstacle_margin } if margin == obstacle_margin => {
                ("collision", vec![], vec![], Some(*margin))
            }
            Feature::Collision { .. } => {
                return Err("the peers' collision feature has one margin, not an obstacle margin".into());
            }
        };
        let kind = match objective.kind {
            ObjectiveKind::SumOfSquares => "sos",
            ObjectiveKind::Equality => "eq",
            ObjectiveKind::Inequality => "ineq",
        };
        let (first, last) = objective.time.slices(tp.horizon());
        objectives.push(json!({
            "name": objective.name,
            "feature": feature,
            "frames": frames,
            "axes": axes,
            "kind": kind,
            "scale": objective.scale,
            "target": objective.target,
            "order": objective.order,
            "slices": [first, last],
            "margin": margin,
        }));
    }
    let limits = robot.limits();
    let out = json!({
        "problem": problem.name,
        "origin": problem.origin,
        "joints": robot.joint_names(),
        "joint_limits": limits.iter().map(|l| [l.lower, l.upper]).collect::<Vec<_>>(),
        "start": tp.start(),
        "horizon": tp.horizon(),
        "order": problem.optimizer.order,
        "duration": problem.optimizer.duration,
        "time_step": tp.time_step(),
        "padding": model.padding(),
        "objectives": objectives,
        "exchange": exchange,
    });
    match out {
        Value::Object(map) => Ok(map),
        _ => unreachable!("json! of an object literal"),
    }
}
