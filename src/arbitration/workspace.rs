//! The per-control-loop [`ArbiterWorkspace`], grouped by the stage of a
//! tick that fills it (as Pinocchio documents its `Data`): everything a
//! tick writes is allocated here once, by [`Arbiter::workspace`], so that a
//! tick allocates nothing. The stages run in the order of the fields:
//!
//! 1. [`InputStage`]: the inputs validated, kinematics at `q`;
//! 2. [`IntentStage`]: the beliefs over goals;
//! 3. [`RobotStage`]: each goal policy's action at `q`;
//! 4. [`MetricStage`]: the mode's metric from the policies' curvature;
//! 5. [`ObjectiveStage`]: the mode's problem and its closed form;
//! 6. [`SafetyRows`]: the hard-constraint rows;
//! 7. [`SolveStage`]: the command that meets every row;
//! 8. [`CertifyStage`]: the step checked against the exact geometry, the
//!    command out.
//!
//! [`LearnedStage`] serves the learned mode and [`Arbiter::observe`].

use super::arbiter::{Arbiter, MAX_SOLVER_ROWS};
use super::command::Diagnostics;
use super::intent::IntentEstimator;
use super::learned::StateLayout;
use super::metric::{Metric, MetricWorkspace};
use super::modes::ArbitrationMode;
use super::motion::MotionStage;
use super::safety::{Row, SafetyRows};
use crate::control::RobotPolicyWorkspace;
use crate::robot::KinematicsWorkspace;
use nalgebra::Matrix6xX;
use tandem_solvers::conic::{ActiveSetSolver, ConicSolverPool};

/// Per-control-loop state of an [`Arbiter`]: one group of buffers per stage
/// of a tick (see the [module](self)), the policies' states and the
/// solvers, allocated once.
pub struct ArbiterWorkspace {
    /// The mode the next ticks run ([`ArbiterWorkspace::set_mode`]).
    pub(crate) mode: ArbitrationMode,
    /// Stage 1.
    pub(crate) input: InputStage,
    /// Stage 2.
    pub(crate) intent: IntentStage,
    /// Stage 3.
    pub(crate) robot: RobotStage,
    /// Stage 4.
    pub(crate) metric: MetricStage,
    /// Stage 5.
    pub(crate) objective: ObjectiveStage,
    /// Stage 6.
    pub(crate) rows: SafetyRows,
    /// Stage 7.
    pub(crate) solve: SolveStage,
    /// Stage 8.
    pub(crate) certify: CertifyStage,
    /// The learned mode and the observe / act split.
    pub(crate) learned: LearnedStage,
    /// The executed command sequence and the braking step (motion limits).
    pub(crate) motion: MotionStage,
    /// What every stage reports, reset at the start of each tick.
    pub(crate) diagnostics: Diagnostics,
}

/// Stage 1, inputs: the tick's velocity (validated) and the kinematics at
/// its configuration. Filled by `Arbiter::prepare`.
pub struct InputStage {
    /// Forward kinematics at `q`.
    pub(crate) kin: KinematicsWorkspace,
    /// The gripper Jacobian at `q` (6 × n, world-aligned, linear rows first).
    pub(crate) jac: Matrix6xX<f64>,
    /// The gripper position at `q` (m, world).
    pub(crate) gripper_position: [f64; 3],
    /// The joint velocity given with the state (rad/s; zero when none).
    pub(crate) velocity: Vec<f64>,
}

/// Stage 2, intent: the goal posterior. Filled by `Arbiter::update_beliefs`.
pub struct IntentStage {
    /// The estimator of the beliefs from the gripper path.
    pub(crate) estimator: IntentEstimator,
    /// The beliefs of this tick (estimated, or given with the input).
    pub(crate) beliefs: Vec<f64>,
}

/// Stage 3, robot actions: each goal policy at `q`. Filled by
/// `Arbiter::robot_actions`.
pub struct RobotStage {
    /// Each goal policy's state (its progress along its reference).
    pub(crate) states: Vec<RobotPolicyWorkspace>,
    /// The actions, goal-major (`goals × n`, rad/s).
    pub(crate) actions: Vec<f64>,
}

/// Stage 4, metric: the Hessian or Fisher metric of the mode, per goal and
/// mixed by belief. Filled by `Arbiter::compute_metric`.
pub struct MetricStage {
    /// Kinematics and Jacobian at the task metric's probe configurations.
    pub(crate) probe_kin: KinematicsWorkspace,
    /// The gripper Jacobian at a probe configuration.
    pub(crate) probe_jac: Matrix6xX<f64>,
    /// Scratch of the joint-space metrics (n joints).
    pub(crate) scratch: MetricWorkspace,
    /// Scratch of the task-space metric (3 dimensions).
    pub(crate) task_scratch: MetricWorkspace,
    /// One goal's raw (unrepaired) metric.
    pub(crate) raw: Vec<f64>,
    /// One goal's repaired joint-space metric.
    pub(crate) goal_joint: Metric,
    /// The joint-space metric of the tick (the mixture over goals).
    pub(crate) joint: Metric,
    /// One goal's repaired task-space metric.
    pub(crate) goal_task: Metric,
    /// The 3 × 3 task-space metric of the tick.
    pub(crate) task: Metric,
}

/// Stage 5, objective: the mode's problem `min ½uᵀPu + qᵀu` (plus, for
/// `Constrained`, the trust-region cone) and its unconstrained minimiser.
/// Filled by `Arbiter::objective`.
pub struct ObjectiveStage {
    /// The operator's command in joint space (rad/s).
    pub(crate) human: Vec<f64>,
    /// The operator's command as used (capped), `max(n, 6)` values.
    pub(crate) command: Vec<f64>,
    /// The task Jacobian rows in use (row-major `k × n`).
    pub(crate) jk: Vec<f64>,
    /// The task target (`k` values).
    pub(crate) task: [f64; 6],
    /// A joint-space target (`n` values; `max(n, 6)` allocated).
    pub(crate) target: Vec<f64>,
    /// `P` (n × n, column-major).
    pub(crate) p: Vec<f64>,
    /// `q`.
    pub(crate) q: Vec<f64>,
    /// The unconstrained minimiser (the mode's closed form, rad/s).
    pub(crate) u0: Vec<f64>,
    /// A Cholesky factor (n × n).
    pub(crate) chol: Vec<f64>,
    /// One column of scratch (n).
    pub(crate) column: Vec<f64>,
    /// The cone `‖L(u) − c‖ ≤ radius` of `Constrained`: `L` (n × n) …
    pub(crate) cone_l: Vec<f64>,
    /// … `c` …
    pub(crate) cone_c: Vec<f64>,
    /// … and the radius.
    pub(crate) radius: f64,
    /// Whether the problem has the cone.
    pub(crate) conic: bool,
    /// Whether damped least squares slowed a direction losing rank (a task
    /// command near a singularity).
    pub(crate) damped: bool,
}

/// Stage 7, solve: the command that meets every row — the closed form when
/// it does, else a solver on the rows it violates. Filled by
/// `SolveStage::enforce`.
pub struct SolveStage {
    /// The rows handed to the solver.
    pub(crate) active: Vec<Row>,
    /// Their `G` (row-major `m × n`), `h` and the solver's multipliers `z`.
    pub(crate) g: Vec<f64>,
    /// `h` of the active rows.
    pub(crate) h: Vec<f64>,
    /// The multipliers of the last solve.
    pub(crate) z: Vec<f64>,
    /// Rows of the last solve (0 when the closed form was feasible).
    pub(crate) solved_rows: usize,
    /// Clarabel for the QP modes …
    pub(crate) qp: ConicSolverPool,
    /// … the dense active-set solver …
    pub(crate) dense: ActiveSetSolver,
    /// … Clarabel with the cone …
    pub(crate) socp: ConicSolverPool,
    /// … and OSQP.
    #[cfg(feature = "osqp")]
    pub(crate) osqp: tandem_solvers::conic::OsqpSolver,
    /// The command (rad/s).
    pub(crate) u: Vec<f64>,
}

/// Stage 8, certification and the command out. Filled by `Arbiter::certify`
/// and `emit`.
pub struct CertifyStage {
    /// The configuration a step reaches (`q + f·u·dt`), and the step's
    /// joint displacement while the rows are built.
    pub(crate) step: Vec<f64>,
    /// The joint velocity executed (rad/s; zero on a hold).
    pub(crate) qdot: Vec<f64>,
}

/// The learned mode's arbitration state and the observe / act split.
/// Filled by `Arbiter::fill_state`.
pub struct LearnedStage {
    /// The arbitration state (see [`StateLayout`]).
    pub(crate) state: Vec<f64>,
    /// Scratch of the learned policy.
    pub(crate) scratch: Vec<f32>,
    /// Whether the last call was a successful [`Arbiter::observe`].
    pub(crate) observed: bool,
}

impl Arbiter {
    /// A workspace for one control loop (allocates; ticks do not).
    pub fn workspace(&self) -> ArbiterWorkspace {
        let n = self.robot.nq();
        let k = self.goals.len();
        let positions: Vec<[f64; 3]> = self.goals.iter().map(|g| g.position).collect();
        let max_rows = 2 * n + MAX_SOLVER_ROWS;
        let solver = &self.settings.solver;
        let layout = StateLayout { task_dims: 3, goals: k, length_scale: 1.0, speed_scale: 1.0 };
        ArbiterWorkspace {
            mode: self.settings.mode,
            input: InputStage {
                kin: KinematicsWorkspace::new(&self.robot),
                jac: Matrix6xX::zeros(n),
                gripper_position: [0.0; 3],
                velocity: vec![0.0; n],
            },
            intent: IntentStage {
                estimator: IntentEstimator::new(&positions, self.settings.intent),
                beliefs: vec![if k == 0 { 0.0 } else { 1.0 / k as f64 }; k],
            },
            robot: RobotStage {
                states: self.goals.iter().map(|g| g.policy.new_workspace()).collect(),
                actions: vec![0.0; k * n],
            },
            metric: MetricStage {
                probe_kin: KinematicsWorkspace::new(&self.robot),
                probe_jac: Matrix6xX::zeros(n),
                scratch: MetricWorkspace::new(n),
                task_scratch: MetricWorkspace::new(3),
                // n × n joint metrics and 3 × 3 task metrics, also on arms
                // of fewer than three joints.
                raw: vec![0.0; (n * n).max(9)],
                goal_joint: Metric::identity(n),
                joint: Metric::identity(n),
                goal_task: Metric::identity(3),
                task: Metric::identity(3),
            },
            objective: ObjectiveStage {
                human: vec![0.0; n],
                command: vec![0.0; n.max(6)],
                jk: vec![0.0; 6 * n.max(1)],
                task: [0.0; 6],
                target: vec![0.0; n.max(6)],
                p: vec![0.0; n * n],
                q: vec![0.0; n],
                u0: vec![0.0; n],
                chol: vec![0.0; n * n],
                column: vec![0.0; n],
                cone_l: vec![0.0; n * n],
                cone_c: vec![0.0; n],
                radius: 0.0,
                conic: false,
                damped: false,
            },
            rows: self.safety_rows(),
            solve: SolveStage {
                active: Vec::with_capacity(max_rows + self.settings.safety.max_distance_rows),
                g: vec![0.0; max_rows * n],
                h: vec![0.0; max_rows],
                z: vec![0.0; max_rows],
                solved_rows: 0,
                qp: ConicSolverPool::new(n, max_rows, None, solver),
                dense: ActiveSetSolver::new(n, max_rows, solver),
                socp: ConicSolverPool::new(n, max_rows, Some(n), solver),
                #[cfg(feature = "osqp")]
                osqp: tandem_solvers::conic::OsqpSolver::new(n, max_rows, solver),
                u: vec![0.0; n],
            },
            certify: CertifyStage { step: vec![0.0; n], qdot: vec![0.0; n] },
            motion: MotionStage::new(n),
            learned: LearnedStage {
                state: vec![0.0; layout.width()],
                scratch: vec![0.0; self.learned.as_ref().map_or(0, |p| p.scratch_len())],
                observed: false,
            },
            diagnostics: Diagnostics::default(),
        }
    }
}

impl Arbiter {
    /// The hard-constraint rows' scratch for this arbiter's collision
    /// model (allocates): what a workspace of an arbiter of the same goals
    /// takes in [`ArbiterWorkspace::swap_safety_rows`] when the model
    /// changes. Build it off the control loop's thread.
    pub fn safety_rows(&self) -> SafetyRows {
        SafetyRows::new(self.robot.nq(), self.settings.safety.max_distance_rows, &self.collision)
    }
}

impl ArbiterWorkspace {
    /// Exchanges this workspace's hard-constraint rows with `rows` (made by
    /// [`Arbiter::safety_rows`] for the arbiter the next ticks use, one
    /// from [`Arbiter::with_collision_model`]): the old rows come back in
    /// `rows`, to be dropped off the loop's thread. Everything else — the
    /// beliefs, the policies' states, the motion, the mode — carries over.
    /// Allocates nothing.
    ///
    /// # Panics
    /// Rows of an arm with another joint count.
    pub fn swap_safety_rows(&mut self, rows: &mut SafetyRows) {
        assert_eq!(self.rows.joints(), rows.joints(), "safety rows of different arms");
        std::mem::swap(&mut self.rows, rows);
    }

    /// Takes over the arm `from` has been commanding: the next tick
    /// continues `from`'s executed command sequence (its last velocity and
    /// acceleration) within the motion limits, instead of starting from
    /// rest. For a new arbiter mid-motion (new goals, a lift after the
    /// approach): without it the first command would be bounded relative
    /// to zero velocity, a jump the arm would see.
    ///
    /// # Panics
    /// Workspaces of arms with different joint counts.
    pub fn continue_motion(&mut self, from: &ArbiterWorkspace) {
        assert_eq!(self.motion.velocity.len(), from.motion.velocity.len(), "workspaces of different arms");
        self.motion.velocity.copy_from_slice(&from.motion.velocity);
        self.motion.acceleration.copy_from_slice(&from.motion.acceleration);
    }

    /// The mode the next ticks run.
    pub fn mode(&self) -> ArbitrationMode {
        self.mode
    }

    /// Switches the mode from the next tick on.
    pub fn set_mode(&mut self, mode: ArbitrationMode) {
        self.mode = mode;
    }

    /// Beliefs over the goals after the last tick.
    pub fn beliefs(&self) -> &[f64] {
        &self.intent.beliefs
    }

    /// Goal `g`'s robot action at the last tick (rad/s).
    pub fn robot_action(&self, g: usize) -> &[f64] {
        let n = self.solve.u.len();
        &self.robot.actions[g * n..(g + 1) * n]
    }

    /// The joint-space metric of the last tick (the Hessian metric `W` for
    /// `Constrained` and `SumOfSquares`, the Fisher metric `F` for
    /// `NaturalGradient(Joint)`; the identity otherwise).
    pub fn metric(&self) -> &Metric {
        &self.metric.joint
    }

    /// The 3 × 3 task-space Fisher metric of the last
    /// `NaturalGradient(Task)` tick.
    pub fn task_metric(&self) -> &Metric {
        &self.metric.task
    }

    /// The gripper Jacobian of the last tick (6 × n, world-aligned, linear rows first).
    pub fn jacobian(&self) -> &Matrix6xX<f64> {
        &self.input.jac
    }

    /// The gripper position of the last tick (m, world).
    pub fn gripper_position(&self) -> [f64; 3] {
        self.input.gripper_position
    }

    /// The operator's command mapped to joint space at the last tick (rad/s).
    pub fn human_joint_command(&self) -> &[f64] {
        &self.objective.human
    }

    /// The last problem the solver solved this tick, with its multipliers
    /// (for KKT checks); `None` when the closed form met every constraint.
    pub fn last_solve(&self) -> Option<SolvedProblem<'_>> {
        let (n, m) = (self.solve.u.len(), self.solve.solved_rows);
        (m > 0).then(|| SolvedProblem {
            p: &self.objective.p,
            q: &self.objective.q,
            g: &self.solve.g[..m * n],
            h: &self.solve.h[..m],
            z: &self.solve.z[..m],
            conic: self.objective.conic,
        })
    }

    /// The mode's unconstrained solution at the last tick (rad/s).
    pub fn closed_form(&self) -> &[f64] {
        &self.objective.u0
    }
}

/// A solved problem `min ½uᵀPu + qᵀu s.t. Gu ≤ h` (plus the trust-region
/// cone when `conic`) and the solver's multipliers `z` of the rows.
#[derive(Debug, Clone, Copy)]
pub struct SolvedProblem<'w> {
    /// `P` (n × n, column-major) and `q`.
    pub p: &'w [f64],
    /// `q` of the objective.
    pub q: &'w [f64],
    /// `G` (m × n, row-major) and `h`.
    pub g: &'w [f64],
    /// `h` of the rows.
    pub h: &'w [f64],
    /// The solver's multipliers of the rows (≥ 0).
    pub z: &'w [f64],
    /// Whether the trust-region cone was part of it.
    pub conic: bool,
}
