//! Objectives as data: (feature, time span, kind, scale, target, order),
//! built with a small builder or from a problem file's `[[optimizer.objectives]]`.

use super::KomoError;
use super::feature::{Feature, FrameRef};
use crate::problem::{Goal, ObjectiveKind, ObjectiveSpec, Problem, TimeRange};
use crate::robot::RobotModel;
use nalgebra::{IsometryMatrix3, Translation3};

/// When an objective applies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeSpan {
    /// Fractions of the duration, `0 ≤ start ≤ end ≤ 1`: slice `t` of `T`
    /// sits at `t/T`, so a fraction `f` maps to slice `round(f·T)` (at least 1).
    Fraction {
        /// First fraction of the horizon (0 = the first slice).
        start: f64,
        /// Last fraction (1 = the last slice).
        end: f64,
    },
    /// Slices `first ..= last` (1-based, `last ≤ T`).
    Slices {
        /// First slice (1-based, as q_1).
        first: usize,
        /// Last slice, inclusive.
        last: usize,
    },
}

impl TimeSpan {
    /// The whole motion.
    pub const ALL: TimeSpan = TimeSpan::Fraction { start: 0.0, end: 1.0 };
    /// The last slice only.
    pub const END: TimeSpan = TimeSpan::Fraction { start: 1.0, end: 1.0 };

    /// The slices `first ..= last` covered at horizon `horizon`.
    pub fn slices(&self, horizon: usize) -> (usize, usize) {
        let slice = |f: f64| ((f * horizon as f64).round() as usize).clamp(1, horizon);
        match *self {
            TimeSpan::Fraction { start, end } => (slice(start), slice(end)),
            TimeSpan::Slices { first, last } => (first, last),
        }
    }
}

/// One term of the optimization problem.
#[derive(Debug, Clone, PartialEq)]
pub struct Objective {
    /// A readable name for reports, e.g. `position_difference(panda_hand_tcp, box/center)`.
    pub name: String,
    /// What is measured.
    pub feature: Feature,
    /// Where in the motion.
    pub time: TimeSpan,
    /// Cost, equality or inequality.
    pub kind: ObjectiveKind,
    /// Multiplies the feature's rows (for sos: the weight's square root).
    pub scale: f64,
    /// Subtracted from the (differenced) feature; empty means zero.
    pub target: Vec<f64>,
    /// 0: the feature; 1: its velocity (`Δφ/τ`); 2: its acceleration (`Δ²φ/τ²`).
    pub order: usize,
}

impl Objective {
    /// An objective over the whole motion, scale 1, zero target, order 0.
    pub fn new(name: impl Into<String>, feature: Feature, kind: ObjectiveKind) -> Objective {
        Objective { name: name.into(), feature, time: TimeSpan::ALL, kind, scale: 1.0, target: Vec::new(), order: 0 }
    }

    /// Sum of squared joint accelerations (order 2) or velocities (order 1).
    pub fn control(order: usize) -> Objective {
        Objective::new("control", Feature::JointState, ObjectiveKind::SumOfSquares).order(order)
    }

    /// Applies over `time`.
    pub fn time(mut self, time: TimeSpan) -> Objective {
        self.time = time;
        self
    }

    /// Applies over fractions `start ..= end` of the duration.
    pub fn during(self, start: f64, end: f64) -> Objective {
        self.time(TimeSpan::Fraction { start, end })
    }

    /// Sets the weight of the objective's rows (> 0).
    pub fn scale(mut self, scale: f64) -> Objective {
        self.scale = scale;
        self
    }

    /// Sets the value the feature is driven to.
    pub fn target(mut self, target: impl Into<Vec<f64>>) -> Objective {
        self.target = target.into();
        self
    }

    /// Sets the order: 0 the feature, 1 its velocity, 2 its acceleration.
    pub fn order(mut self, order: usize) -> Objective {
        self.order = order;
        self
    }

    /// Checks the objective against a robot and horizon.
    ///
    /// # Errors
    /// [`KomoError::Objective`] naming what is wrong.
    pub(crate) fn validate(&self, robot: &RobotModel, horizon: usize, max_order: usize) -> Result<(), KomoError> {
        let fail = |message: String| Err(KomoError::Objective { name: self.name.clone(), message });
        let (first, last) = self.time.slices(horizon);
        if first == 0 || first > last || last > horizon {
            return fail(format!("slices {first}..={last} are not within 1..={horizon}"));
        }
        if self.order > max_order {
            return fail(format!("order {} exceeds the problem's order {max_order}", self.order));
        }
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return fail(format!("scale must be positive, got {}", self.scale));
        }
        let dim = self.feature.dim(robot);
        if !self.target.is_empty() && self.target.len() != dim {
            return fail(format!("target has {} values, the feature has {dim}", self.target.len()));
        }
        if self.target.iter().any(|t| !t.is_finite()) {
            return fail("target is not finite".into());
        }
        let margins: &[(&str, f64)] = match self.feature {
            Feature::Collision { margin, obstacle_margin } => {
                &[("margin", margin), ("obstacle_margin", obstacle_margin)]
            }
            Feature::JointLimits { margin } => &[("margin", margin)],
            _ => &[],
        };
        if let Some((key, m)) = margins.iter().find(|(_, m)| !(m.is_finite() && *m >= 0.0)) {
            return fail(format!("{key} must be finite and zero or positive, got {m}"));
        }
        let collision = matches!(self.feature, Feature::Collision { .. });
        if collision && (self.order != 0 || self.kind == ObjectiveKind::Equality) {
            return fail("collision is an order-0 inequality or sum-of-squares objective".into());
        }
        Ok(())
    }
}

/// Resolves a frame name of a problem file: a robot frame, `world`, a
/// scene object, or `object/grasp`.
fn frame_ref(problem: &Problem, name: &str) -> Result<FrameRef, String> {
    if name == "world" {
        return Ok(FrameRef::Fixed(IsometryMatrix3::identity()));
    }
    if let Ok(id) = problem.robot.frame_id(name) {
        return Ok(FrameRef::Robot(id));
    }
    if let Some(object) = problem.scene.object(name) {
        return Ok(FrameRef::Fixed(object.pose));
    }
    if let Some((object, grasp)) = name.split_once('/') {
        return problem.scene.grasp_pose(object, grasp).map(FrameRef::Fixed).map_err(|e| e.to_string());
    }
    Err(format!("unknown frame '{name}'"))
}

/// The objective a problem file's entry describes.
///
/// # Errors
/// [`KomoError::Objective`] for an entry the problem cannot resolve (e.g. a
/// joint-state target with no joint goal to default to).
pub fn objective_from_spec(problem: &Problem, spec: &ObjectiveSpec) -> Result<Objective, KomoError> {
    let name = if spec.frames.is_empty() {
        spec.feature.clone()
    } else {
        format!("{}({})", spec.feature, spec.frames.join(", "))
    };
    let fail = |message: String| KomoError::Objective { name: name.clone(), message };
    let frame = |k: usize| frame_ref(problem, &spec.frames[k]).map_err(&fail);
    let feature = match spec.feature.as_str() {
        "joint_state" | "control" => Feature::JointState,
        "joint_limits" => Feature::JointLimits { margin: spec.margin },
        "position" => Feature::Position { frame: frame(0)? },
        "position_difference" => Feature::PositionDifference { a: frame(0)?, b: frame(1)? },
        "scalar_product" => {
            Feature::ScalarProduct { a: frame(0)?, axis_a: spec.axes[0], b: frame(1)?, axis_b: spec.axes[1] }
        }
        "vector" => Feature::Vector { a: frame(0)?, axis: spec.axes[0], b: frame(1)? },
        "orientation_difference" => Feature::OrientationDifference { a: frame(0)?, b: frame(1)? },
        "collision" => {
            Feature::Collision { margin: spec.margin, obstacle_margin: spec.obstacle_margin.unwrap_or(spec.margin) }
        }
        other => return Err(fail(format!("unknown feature '{other}'"))),
    };
    let mut target = spec.target.clone().unwrap_or_default();
    if target.is_empty() && spec.feature == "joint_state" && spec.order == 0 {
        match &problem.goal {
            Goal::Joints(goal) => target = goal.clone(),
            _ => return Err(fail("a joint_state objective without target needs a joint goal".into())),
        }
    }
    if target.is_empty() && spec.feature == "position" {
        match &problem.goal {
            Goal::Pose { position, .. } => target = position.as_slice().to_vec(),
            _ => return Err(fail("a position objective without target needs a pose goal".into())),
        }
    }
    let TimeRange { start, end } = spec.time;
    Ok(Objective {
        name,
        feature,
        time: TimeSpan::Fraction { start, end },
        kind: spec.kind,
        scale: spec.scale,
        target,
        order: spec.order as usize,
    })
}

/// The objectives of a problem that lists none: minimal acceleration,
/// joint limits, collision avoidance with `margin` (m), and the goal at the
/// end of the motion, reached at rest.
///
/// # Errors
/// A grasp goal without a gripper frame, or an unknown object.
pub fn default_objectives(problem: &Problem, margin: f64) -> Result<Vec<Objective>, KomoError> {
    use ObjectiveKind::{Equality, Inequality};
    let mut objectives = vec![
        Objective::control(2),
        Objective::new("joint_limits", Feature::JointLimits { margin: 0.0 }, Inequality),
        Objective::new("collision", Feature::Collision { margin, obstacle_margin: margin }, Inequality),
    ];
    let gripper = || -> Result<FrameRef, KomoError> {
        let name = problem.robot_spec.gripper.as_deref().ok_or(KomoError::NoGripper)?;
        Ok(FrameRef::Robot(problem.robot.frame_id(name)?))
    };
    match &problem.goal {
        Goal::Joints(goal) => {
            objectives
                .push(Objective::new("goal", Feature::JointState, Equality).time(TimeSpan::END).target(goal.clone()));
        }
        Goal::Pose { frame, position, orientation, axis_alignment } => {
            let tcp = FrameRef::Robot(problem.robot.frame_id(frame)?);
            let at = Feature::Position { frame: tcp.clone() };
            objectives
                .push(Objective::new("goal position", at, Equality).time(TimeSpan::END).target(position.as_slice()));
            let world = FrameRef::Fixed(IsometryMatrix3::identity());
            if let Some(rotation) = orientation {
                let b = FrameRef::Fixed(IsometryMatrix3::from_parts(Translation3::identity(), *rotation));
                let f = Feature::OrientationDifference { a: tcp.clone(), b };
                objectives.push(Objective::new("goal orientation", f, Equality).time(TimeSpan::END));
            }
            if let Some((axis, direction)) = axis_alignment {
                let f = Feature::Vector { a: tcp, axis: *axis, b: world.clone() };
                let unit = direction.normalize();
                objectives.push(Objective::new("goal axis", f, Equality).time(TimeSpan::END).target(unit.as_slice()));
            }
        }
        Goal::Grasp { object, grasp } => {
            let pose = problem
                .scene
                .grasp_pose(object, grasp)
                .map_err(|e| KomoError::Objective { name: "grasp".into(), message: e.to_string() })?;
            let (a, b) = (gripper()?, FrameRef::Fixed(pose));
            let at = Feature::PositionDifference { a: a.clone(), b: b.clone() };
            objectives.push(Objective::new("grasp position", at, Equality).time(TimeSpan::END));
            let turn = Feature::OrientationDifference { a, b };
            objectives.push(Objective::new("grasp orientation", turn, Equality).time(TimeSpan::END));
        }
    }
    objectives.push(Objective::new("rest", Feature::JointState, Equality).time(TimeSpan::END).order(1));
    Ok(objectives)
}
