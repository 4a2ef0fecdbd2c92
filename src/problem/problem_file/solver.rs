//! The `[planner]` and `[optimizer]` sections of a problem file: how the
//! problem is solved, as opposed to what it is (robot, scene, start, goal).

use super::check::{Check, axis_index};
use crate::problem::toml_source::KeyPath;
use crate::problem::{
    ObjectiveKind, ObjectiveSpec, OptimizerSettings, PlannerSettings, ProblemError, Source, TimeRange,
};
use crate::robot::RobotModel;
use crate::scene::Scene;
use crate::settings::readable;
use serde::Deserialize;

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawPlanner {
    seed: Option<u64>,
    step: Option<f64>,
    resolution: Option<f64>,
    clearance: Option<f64>,
    time_limit: Option<f64>,
    max_iterations: Option<usize>,
}

#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawOptimizer {
    horizon: Option<usize>,
    duration: Option<f64>,
    order: Option<u8>,
    max_iterations: Option<usize>,
    #[serde(default)]
    objectives: Vec<RawObjective>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObjective {
    feature: String,
    #[serde(default)]
    frames: Vec<String>,
    #[serde(default)]
    axes: Vec<String>,
    time: Option<[f64; 2]>,
    #[serde(default = "sos")]
    kind: String,
    #[serde(default = "one")]
    scale: f64,
    target: Option<Vec<f64>>,
    #[serde(default)]
    order: u8,
    #[serde(default)]
    margin: f64,
    obstacle_margin: Option<f64>,
}

fn sos() -> String {
    "sos".into()
}

fn one() -> f64 {
    1.0
}

/// Finest planner `resolution` of a problem file (rad): the motion
/// checks' floor ([`MIN_RESOLUTION`](crate::collision::MIN_RESOLUTION)).
pub const MIN_PLANNER_RESOLUTION: f64 = crate::collision::MIN_RESOLUTION;

/// Smallest non-zero planner `clearance` of a problem file (m); edges are
/// certified to keep half of it.
pub const MIN_PLANNER_CLEARANCE: f64 = 1e-5;

/// Fewest optimized configurations T of a trajectory.
pub const MIN_HORIZON: usize = 2;

/// Most optimized configurations T of a trajectory, from a problem file,
/// `tandem solve -T` or `tandem generate -T` alike.
pub const MAX_HORIZON: usize = crate::trajectory::MAX_WAYPOINTS - 1;

/// Largest planner `time_limit` of a problem file (s): one day.
pub const MAX_TIME_LIMIT: f64 = 86_400.0;

impl RawPlanner {
    pub(super) fn build(self, check: &Check, path: &KeyPath) -> Result<PlannerSettings, ProblemError> {
        let d = PlannerSettings::default();
        let pos = |key: &str, v: Option<f64>, default: f64| check.positive(&path.key(key), v.unwrap_or(default));
        let max_iterations = self.max_iterations.unwrap_or(d.max_iterations);
        if max_iterations == 0 {
            return Err(check.src.error(&path.key("max_iterations"), "must be at least 1"));
        }
        let at_least = |key: &str, v: f64, min: f64, unit: &str| {
            if v >= min {
                Ok(v)
            } else {
                Err(check.src.error(&path.key(key), format!("must be at least {min} {unit}, got {}", readable(v))))
            }
        };
        let resolution = pos("resolution", self.resolution, d.resolution)?;
        at_least("resolution", resolution, MIN_PLANNER_RESOLUTION, "rad")?;
        let clearance = check.non_negative(&path.key("clearance"), self.clearance.unwrap_or(d.clearance))?;
        if clearance != 0.0 {
            at_least("clearance", clearance, MIN_PLANNER_CLEARANCE, "m (or 0 for sampled edge checks)")?;
        }
        let time_limit = pos("time_limit", self.time_limit, d.time_limit)?;
        if time_limit > MAX_TIME_LIMIT {
            let msg = format!("must be at most {MAX_TIME_LIMIT} s (a day), got {}", readable(time_limit));
            return Err(check.src.error(&path.key("time_limit"), msg));
        }
        Ok(PlannerSettings {
            seed: self.seed.unwrap_or(d.seed),
            step: pos("step", self.step, d.step)?,
            resolution,
            clearance,
            time_limit,
            max_iterations,
            ..d
        })
    }
}

/// Features: name, frames read, axes read, and target length (`None`: no
/// target; `Some(0)`: one per active joint).
const FEATURES: [(&str, usize, usize, Option<usize>); 9] = [
    ("joint_state", 0, 0, Some(0)),
    ("joint_limits", 0, 0, None),
    ("position", 1, 0, Some(3)),
    ("position_difference", 2, 0, Some(3)),
    ("scalar_product", 2, 2, Some(1)),
    ("vector", 2, 1, Some(3)),
    ("orientation_difference", 2, 0, Some(3)),
    ("collision", 0, 0, None),
    ("control", 0, 0, Some(0)),
];

impl RawOptimizer {
    pub(super) fn build(
        self,
        check: &Check,
        path: &KeyPath,
        robot: &RobotModel,
        scene: &Scene,
    ) -> Result<OptimizerSettings, ProblemError> {
        let src = check.src;
        let d = OptimizerSettings::default();
        let horizon = self.horizon.unwrap_or(d.horizon);
        if !(MIN_HORIZON..=MAX_HORIZON).contains(&horizon) {
            let msg = format!("must be between {MIN_HORIZON} and {MAX_HORIZON}, got {horizon}");
            return Err(src.error(&path.key("horizon"), msg));
        }
        let order = self.order.unwrap_or(d.order);
        if !(1..=2).contains(&order) {
            return Err(src.error(&path.key("order"), format!("must be 1 or 2, got {order}")));
        }
        let mut objectives = Vec::new();
        for (i, o) in self.objectives.into_iter().enumerate() {
            objectives.push(o.build(check, &path.key("objectives").index(i), robot, scene)?);
        }
        let max_iterations = self.max_iterations.unwrap_or(d.max_iterations);
        if max_iterations == 0 {
            return Err(src.error(&path.key("max_iterations"), "must be at least 1"));
        }
        Ok(OptimizerSettings {
            horizon,
            duration: check.positive(&path.key("duration"), self.duration.unwrap_or(d.duration))?,
            order,
            max_iterations,
            objectives,
        })
    }
}

impl RawObjective {
    fn build(
        self,
        check: &Check,
        path: &KeyPath,
        robot: &RobotModel,
        scene: &Scene,
    ) -> Result<ObjectiveSpec, ProblemError> {
        let src = check.src;
        let names = FEATURES.map(|f| f.0).join(", ");
        let &(_, frame_count, axis_count, target_len) =
            FEATURES.iter().find(|f| f.0 == self.feature).ok_or_else(|| {
                src.error(&path.key("feature"), format!("unknown feature '{}' (expected one of {names})", self.feature))
            })?;
        if self.frames.len() != frame_count {
            let msg = format!("feature {} reads {frame_count} frame(s), got {}", self.feature, self.frames.len());
            return Err(src.error(&path.key("frames"), msg));
        }
        for (k, f) in self.frames.iter().enumerate() {
            if !frame_exists(robot, scene, f) {
                let msg =
                    format!("'{f}' is neither a robot frame, an object, nor an object's grasp frame (object/grasp)");
                return Err(src.error(&path.key("frames").index(k), msg));
            }
        }
        let axes = match (axis_count, self.axes.len()) {
            (0, 0) => Vec::new(),
            (0, _) => {
                return Err(src.error(&path.key("axes"), format!("does not apply to feature {}", self.feature)));
            }
            (wanted, got) if wanted != got => {
                let example = if wanted == 2 { "[\"z\", \"z\"]" } else { "[\"z\"]" };
                let msg = format!("{} reads {wanted} axis name(s), e.g. {example}; got {got}", self.feature);
                return Err(src.error(&path.key("axes"), msg));
            }
            _ => {
                let mut axes = Vec::new();
                for (k, a) in self.axes.iter().enumerate() {
                    let bad = || src.error(&path.key("axes").index(k), "must be x, y or z");
                    axes.push(axis_index(a).ok_or_else(bad)?);
                }
                axes
            }
        };
        let time = match self.time {
            None => TimeRange { start: 0.0, end: 1.0 },
            Some([a, b]) if (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b) && a <= b => {
                TimeRange { start: a, end: b }
            }
            Some([a, b]) => {
                return Err(src.error(
                    &path.key("time"),
                    format!("must be [start, end] with 0 ≤ start ≤ end ≤ 1, got [{a}, {b}]"),
                ));
            }
        };
        let kind = match self.kind.as_str() {
            "sos" => ObjectiveKind::SumOfSquares,
            "eq" => ObjectiveKind::Equality,
            "ineq" => ObjectiveKind::Inequality,
            other => {
                return Err(src.error(&path.key("kind"), format!("unknown kind '{other}' (expected sos, eq or ineq)")));
            }
        };
        if self.order > 2 {
            return Err(src.error(&path.key("order"), format!("must be 0, 1 or 2, got {}", self.order)));
        }
        if let Some(t) = &self.target {
            check.finite(&path.key("target"), t)?;
            self.check_target(src, &path.key("target"), t, target_len, robot.nq())?;
        }
        let obstacle_margin = match self.obstacle_margin {
            None => None,
            Some(_) if self.feature != "collision" => {
                return Err(src.error(&path.key("obstacle_margin"), "applies to the collision feature only"));
            }
            Some(m) => Some(check.non_negative(&path.key("obstacle_margin"), m)?),
        };
        Ok(ObjectiveSpec {
            feature: self.feature,
            frames: self.frames,
            axes,
            time,
            kind,
            scale: check.positive(&path.key("scale"), self.scale)?,
            target: self.target,
            order: self.order,
            margin: check.non_negative(&path.key("margin"), self.margin)?,
            obstacle_margin,
        })
    }
}

impl RawObjective {
    /// The target's length against the feature's dimension; a scalar
    /// product driven to ±1 has a zero gradient there, so it is refused
    /// in favour of `vector`.
    fn check_target(
        &self,
        src: &Source,
        path: &KeyPath,
        target: &[f64],
        len: Option<usize>,
        nq: usize,
    ) -> Result<(), ProblemError> {
        let feature = &self.feature;
        let Some(len) = len else {
            return Err(src.error(path, format!("feature {feature} takes no target")));
        };
        let len = if len == 0 { nq } else { len };
        let order = self.order;
        if target.len() != len {
            let msg = format!("feature {feature} (order {order}) has {len} value(s); the target has {}", target.len());
            return Err(src.error(path, msg));
        }
        if feature == "scalar_product" && order == 0 && (target[0].abs() - 1.0).abs() < 1e-6 {
            let msg = "a scalar product of ±1 has a zero gradient at its target, which stalls the optimizer: \
                       align the axis with feature \"vector\" instead (e.g. target [0, 0, -1] in the second frame)";
            return Err(src.error(path, msg));
        }
        Ok(())
    }
}

/// A robot frame, an object, or `object/grasp`.
fn frame_exists(robot: &RobotModel, scene: &Scene, name: &str) -> bool {
    name == "world"
        || robot.frame_id(name).is_ok()
        || scene.object(name).is_some()
        || name.split_once('/').is_some_and(|(o, g)| scene.grasp_pose(o, g).is_ok())
}
