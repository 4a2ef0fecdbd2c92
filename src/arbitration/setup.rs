//! From a problem to an arbiter: one optimized reference and tracking
//! policy per goal (per graspable object for a grasp problem), and the
//! collision model the hard constraints use.

use super::{Arbiter, ArbiterGoal, ArbiterSettings, ArbitrationError};
use crate::control::{GainSchedule, TrackingPolicy, TrackingWeights};
use crate::pipeline::{ProblemSolution, SolveSettings, solve_problem};
use crate::problem::{Goal, Problem};
use crate::robot::KinematicsWorkspace;
use std::sync::Arc;

/// Which goals a problem yields.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GoalObjects {
    /// The problem's own goal only.
    #[default]
    Goal,
    /// For a grasp goal, every scene object with the goal's grasp frame
    /// (the problem retargeted to each, see
    /// [`Problem::retarget_grasp`]); otherwise the goal only.
    AllGraspable,
}

/// How [`problem_goals`] plans the references and builds the policies.
#[derive(Debug, Clone, PartialEq)]
pub struct GoalSettings {
    /// Planner seed (default: the problem's).
    pub seed: Option<u64>,
    /// Optimizer horizon (default: the problem's).
    pub horizon: Option<usize>,
    /// Weights of the tracking policies' cost.
    pub weights: TrackingWeights,
    /// Constant or time-varying gains.
    pub schedule: GainSchedule,
    /// Which goals the problem yields.
    pub objects: GoalObjects,
}

impl Default for GoalSettings {
    fn default() -> Self {
        GoalSettings {
            seed: None,
            horizon: None,
            weights: TrackingWeights::default(),
            schedule: GainSchedule::TimeVarying,
            objects: GoalObjects::AllGraspable,
        }
    }
}

/// A goal prepared from a problem: its (retargeted) problem, the optimized
/// reference, the tracking policy, and the gripper position at the end of
/// the reference (m, world), which the intent estimator uses.
#[derive(Debug, Clone)]
pub struct ProblemGoal {
    /// Its name.
    pub name: String,
    /// The goal's problem (retargeted for other objects).
    pub problem: Problem,
    /// The optimized reference.
    pub solution: ProblemSolution,
    /// Its LQR tracking policy.
    pub policy: Arc<TrackingPolicy>,
    /// A world point (m).
    pub position: [f64; 3],
}

impl ProblemGoal {
    /// The gripper's world pose at the end of the reference.
    ///
    /// # Errors
    /// No gripper frame.
    pub fn final_gripper_pose(&self) -> Result<nalgebra::IsometryMatrix3<f64>, ArbitrationError> {
        let robot = &self.problem.robot;
        let gripper = self.problem.robot_spec.gripper.as_deref().ok_or(ArbitrationError::NoGripper)?;
        let mut ws = KinematicsWorkspace::new(robot);
        robot.forward_kinematics(&mut ws, self.policy.reference().goal())?;
        Ok(robot.frame_pose(&ws, robot.frame_id(gripper)?))
    }

    /// The goal as the arbiter takes it.
    pub fn arbiter_goal(&self) -> ArbiterGoal {
        ArbiterGoal { name: self.name.clone(), position: self.position, policy: self.policy.clone() }
    }
}

/// Plans and optimizes a reference from the problem's start to each goal
/// (see [`GoalObjects`]) and turns each into a tracking policy.
///
/// # Errors
/// No gripper frame; a goal whose optimization does not converge (named
/// with its status); optimizer, planner or policy errors.
pub fn problem_goals(problem: &Problem, options: &GoalSettings) -> Result<Vec<ProblemGoal>, ArbitrationError> {
    let gripper = problem.robot_spec.gripper.as_deref().ok_or(ArbitrationError::NoGripper)?;
    let gripper = problem.robot.frame_id(gripper)?;
    let problems = match (&problem.goal, options.objects) {
        (Goal::Grasp { grasp, .. }, GoalObjects::AllGraspable) => problem
            .scene
            .objects()
            .iter()
            .filter(|o| o.grasps.iter().any(|g| &g.name == grasp))
            .map(|o| problem.retarget_grasp(&o.name).map(|p| (o.name.clone(), p)))
            .collect::<Result<Vec<_>, _>>()?,
        (Goal::Grasp { object, .. }, GoalObjects::Goal) => vec![(object.clone(), problem.clone())],
        _ => vec![(problem.name.clone(), problem.clone())],
    };
    let solve_options = SolveSettings { seed: options.seed, horizon: options.horizon, ..SolveSettings::default() };
    let mut ws = KinematicsWorkspace::new(&problem.robot);
    problems
        .into_iter()
        .map(|(name, goal_problem)| {
            let solution = solve_problem(&goal_problem, &solve_options)?;
            if !solution.converged() {
                return Err(ArbitrationError::GoalNotReached { goal: name, status: solution.status() });
            }
            let policy = solution.tracking_policy(&goal_problem.start, options.weights, options.schedule)?;
            let end = policy.reference().goal().to_vec();
            problem.robot.forward_kinematics(&mut ws, &end)?;
            let position = problem.robot.frame_position(&ws, gripper).into();
            Ok(ProblemGoal { name, problem: goal_problem, solution, policy: Arc::new(policy), position })
        })
        .collect()
}

impl Arbiter {
    /// An arbiter for `problem` with prepared `goals`: the gripper is the
    /// problem's, and the collision model allows the gripper's rigid body
    /// to touch the goal objects (grasp targets), as planning does.
    ///
    /// # Errors
    /// No gripper; collision model errors; as [`Arbiter::new`].
    pub fn for_problem(
        problem: &Problem,
        goals: &[ProblemGoal],
        settings: ArbiterSettings,
    ) -> Result<Arbiter, ArbitrationError> {
        let gripper = problem.robot_spec.gripper.as_deref().ok_or(ArbitrationError::NoGripper)?;
        let targets: Vec<&str> = goals
            .iter()
            .filter_map(|g| match &g.problem.goal {
                Goal::Grasp { object, .. } => Some(object.as_str()),
                _ => None,
            })
            .collect();
        let collision = Arc::new(problem.collision_model_grasping(&targets, 0.0)?);
        Arbiter::new(collision, gripper, goals.iter().map(ProblemGoal::arbiter_goal).collect(), settings)
    }
}
