//! The arbiter: each mode against its closed form from the dissertation, KKT
//! conditions of constrained solutions, safe fallbacks, singularities,
//! separating pairs, no allocation per tick.

use nalgebra::{DMatrix, DVector};
use std::sync::Arc;
use tandem::arbitration::{
    Arbiter, ArbiterGoal, ArbiterSettings, ArbiterWorkspace, ArbitrationMode, HumanCommand, MetricSpace, TickInput,
    TickStatus,
};
use tandem::collision::CollisionModel;
use tandem::control::{ControlError, GainSchedule, RobotPolicy, RobotPolicyWorkspace, TrackingPolicy, TrackingWeights};
use tandem::robot::RobotModel;
use tandem::scene::{Obstacle, Scene, Shape};
use tandem::trajectory::JointTrajectory;

mod common;

#[global_allocator]
static GLOBAL: common::alloc::CountingAllocator = common::alloc::CountingAllocator;

const READY: [f64; 7] = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
const GOAL_A: [f64; 7] = [0.5, -0.3, -0.2, -2.0, 0.1, 1.9, 0.5];
const GOAL_B: [f64; 7] = [-0.5, -0.4, 0.2, -2.1, -0.1, 1.8, 1.0];
/// Off both references, away from limits and singularities.
const Q: [f64; 7] = [0.12, -0.6, 0.05, -2.2, 0.04, 1.7, 0.8];

fn tracking(goal: &[f64; 7]) -> Arc<TrackingPolicy> {
    let panda = RobotModel::panda();
    let reference = JointTrajectory::minimum_jerk(panda.joint_names().to_vec(), &READY, goal, 3.0, 0.05).unwrap();
    Arc::new(TrackingPolicy::new(reference, TrackingWeights::default(), GainSchedule::TimeVarying).unwrap())
}

fn goals() -> Vec<ArbiterGoal> {
    vec![
        ArbiterGoal { name: "a".into(), position: [0.5, 0.3, 0.2], policy: tracking(&GOAL_A) },
        ArbiterGoal { name: "b".into(), position: [0.5, -0.3, 0.2], policy: tracking(&GOAL_B) },
    ]
}

fn arbiter_with(scene: &Scene, settings: ArbiterSettings) -> Arbiter {
    let panda = Arc::new(RobotModel::panda());
    let model = Arc::new(CollisionModel::builder(panda).scene(scene).build().unwrap());
    Arbiter::new(model, "panda_hand_tcp", goals(), settings).unwrap()
}

/// No obstacle, no margin: no constraint binds for slow commands.
fn free_arbiter(settings: ArbiterSettings) -> Arbiter {
    let settings = ArbiterSettings {
        safety: tandem::arbitration::SafetySettings { margin: 0.0, ..Default::default() },
        ..settings
    };
    arbiter_with(&Scene::new(), settings)
}

fn dmat(column_major: &[f64], n: usize) -> DMatrix<f64> {
    DMatrix::from_column_slice(n, n, column_major)
}

/// The first `k` rows of the workspace's gripper Jacobian.
fn task_jacobian(ws: &ArbiterWorkspace, k: usize) -> DMatrix<f64> {
    ws.jacobian().rows(0, k).into_owned()
}

/// `(JᵀJ + μI)⁻¹Jᵀv` (damped least squares away from singularities).
fn dls(j: &DMatrix<f64>, v: &DVector<f64>) -> DVector<f64> {
    let n = j.ncols();
    let normal = j.transpose() * j + DMatrix::identity(n, n) * 1e-6;
    normal.cholesky().unwrap().solve(&(j.transpose() * v))
}

fn assert_close(got: &[f64], want: &DVector<f64>, what: &str) {
    let scale = want.amax().max(1e-12);
    let err = got.iter().zip(want.iter()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(err <= 1e-9 * scale, "{what}: error {err:e} (scale {scale:e})\n got {got:?}\nwant {:?}", want.as_slice());
}

/// The command's task dimension and the human command in joint space.
fn human(ws: &ArbiterWorkspace, command: &HumanCommand<'_>) -> (Option<DMatrix<f64>>, DVector<f64>) {
    match command {
        HumanCommand::Linear(v) | HumanCommand::Twist(v) => {
            let j = task_jacobian(ws, v.len());
            let h = dls(&j, &DVector::from_column_slice(v));
            (Some(j), h)
        }
        HumanCommand::Joint(v) => (None, DVector::from_column_slice(v)),
    }
}

/// `η`: the operator's speed over the shaped command's.
fn speed(j: &Option<DMatrix<f64>>, command: &[f64], h: &DVector<f64>, shaped: &DVector<f64>) -> f64 {
    match j {
        Some(j) => DVector::from_column_slice(command).norm() / (j * shaped).norm(),
        None => h.norm() / shaped.norm(),
    }
}

/// The closed form of `mode` from the dissertation, from what the workspace exposes.
fn closed_form(
    arbiter: &Arbiter,
    ws: &ArbiterWorkspace,
    mode: ArbitrationMode,
    command: &HumanCommand<'_>,
) -> DVector<f64> {
    let n = 7;
    let (j, h) = human(ws, command);
    let v = command.values();
    let b = ws.beliefs();
    let top = if b[0] >= b[1] { 0 } else { 1 };
    let s = arbiter.settings();
    match mode {
        // The learned mode's closed form is its policy's command (tests/learned_arbitration.rs).
        ArbitrationMode::DirectControl | ArbitrationMode::ObstacleAvoidance | ArbitrationMode::Learned => h,
        ArbitrationMode::LinearBlending(style) => {
            let alpha = s.modes.blending_alpha(style, b[top], 2);
            DVector::from_column_slice(ws.robot_action(top)) * alpha + h * (1.0 - alpha)
        }
        ArbitrationMode::NaturalGradient(MetricSpace::Task) if j.is_some() => {
            let j = j.unwrap();
            let f_inv = dmat(ws.task_metric().inverse(), 3);
            let lin = DVector::from_column_slice(&v[..3]);
            let shaped = &f_inv * &lin;
            let mut target = DVector::from_column_slice(v);
            target.rows_mut(0, 3).copy_from(&(shaped.clone() * (lin.norm() / shaped.norm())));
            dls(&j, &target)
        }
        ArbitrationMode::NaturalGradient(_) => {
            let shaped = dmat(ws.metric().inverse(), n) * &h;
            let eta = speed(&j, v, &h, &shaped);
            shaped * eta
        }
        ArbitrationMode::Constrained => {
            let w_inv = dmat(ws.metric().inverse(), n);
            let shaped = &w_inv * &h;
            let eta = speed(&j, v, &h, &shaped);
            let mean =
                (0..2).fold(DVector::zeros(n), |acc, g| acc + DVector::from_column_slice(ws.robot_action(g)) * b[g]);
            mean * s.modes.constrained_center + shaped * eta
        }
        ArbitrationMode::SumOfSquares => {
            // The dissertation's form: W⁻¹Jᵀ(JW⁻¹Jᵀ + εI)⁻¹ v_H (J = I for joint commands).
            let w_inv = dmat(ws.metric().inverse(), n);
            let eps = s.modes.sum_of_squares_epsilon;
            let j = j.unwrap_or_else(|| DMatrix::identity(n, n));
            let k = j.nrows();
            let inner = &j * &w_inv * j.transpose() + DMatrix::identity(k, k) * eps;
            let rhs = match command {
                HumanCommand::Joint(_) => h.clone(),
                _ => DVector::from_column_slice(v),
            };
            // With the preferred step c = κ ā_R: c + W⁻¹Jᵀ(JW⁻¹Jᵀ + εI)⁻¹(v − Jc).
            let mean =
                (0..2).fold(DVector::zeros(n), |acc, g| acc + DVector::from_column_slice(ws.robot_action(g)) * b[g]);
            let c = mean * s.modes.sum_of_squares_center;
            &c + &w_inv * j.transpose() * inner.cholesky().unwrap().solve(&(rhs - &j * &c))
        }
    }
}

#[test]
fn every_mode_reduces_to_its_closed_form() {
    let twist = [0.02, -0.01, 0.015, 0.05, -0.02, 0.03];
    let joint = [0.05, -0.03, 0.02, 0.04, -0.05, 0.03, 0.06];
    let commands = [HumanCommand::Linear(&twist[..3]), HumanCommand::Twist(&twist), HumanCommand::Joint(&joint)];
    for centre in [0.0, 0.5] {
        for mode in ArbitrationMode::ALL {
            let mut settings = ArbiterSettings { mode, ..ArbiterSettings::default() };
            settings.modes.constrained_center = centre;
            settings.modes.sum_of_squares_center = centre;
            let arbiter = free_arbiter(settings);
            let mut ws = arbiter.workspace();
            for (c, command) in commands.iter().enumerate() {
                for beliefs in [[0.7, 0.3], [0.2, 0.8], [0.5, 0.5]] {
                    let input = TickInput { q: &Q, velocity: None, command: *command, beliefs: Some(&beliefs) };
                    let out = arbiter.tick(&mut ws, &input);
                    let what = format!("{mode}, command {c}, beliefs {beliefs:?}, κ = {centre}");
                    assert_eq!(out.status, TickStatus::Nominal, "{what}: {:?}", out.diagnostics);
                    let qdot = out.qdot.to_vec();
                    assert_close(&qdot, &closed_form(&arbiter, &ws, mode, command), &what);
                }
            }
        }
    }
}

#[test]
fn metrics_are_repaired_and_shape_toward_the_reference() {
    let arbiter = free_arbiter(ArbiterSettings { mode: ArbitrationMode::SumOfSquares, ..ArbiterSettings::default() });
    let mut ws = arbiter.workspace();
    // On reference a, halfway: the metric is cheapest along the reference direction.
    let policy = tracking(&GOAL_A);
    let r = policy.reference();
    let q_mid: Vec<f64> = r.position(r.len() / 2).iter().map(|x| x + 0.01).collect();
    let input =
        TickInput { q: &q_mid, velocity: None, command: HumanCommand::Linear(&[0.0; 3]), beliefs: Some(&[1.0, 0.0]) };
    arbiter.tick(&mut ws, &input);
    let w = dmat(ws.metric().matrix(), 7);
    let eig = w.clone().symmetric_eigen();
    let (lo, hi) = eig.eigenvalues.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
    assert!(lo > 0.0 && (hi / lo) <= 20.0 + 1e-9, "eigenvalues {:?}", eig.eigenvalues);
    assert!((w.trace() - 7.0).abs() < 1e-9, "mean eigenvalue 1: trace {}", w.trace());
    assert!(((&w * dmat(ws.metric().inverse(), 7)) - DMatrix::identity(7, 7)).amax() < 1e-9);
    let tangent: DVector<f64> = (DVector::from_column_slice(r.position(r.len() / 2 + 1))
        - DVector::from_column_slice(r.position(r.len() / 2 - 1)))
    .normalize();
    let along = (tangent.transpose() * &w * &tangent)[0];
    assert!(along < 0.2 * hi, "the reference direction costs {along}, the largest eigenvalue is {hi}");
}

/// KKT: Pu + q + Gᵀz = 0, z ≥ 0, Gu ≤ h, z ⊙ (h − Gu) = 0 for the solver's
/// last problem, and every row of the tick met by the executed command.
fn assert_kkt(ws: &ArbiterWorkspace, qdot: &[f64], what: &str) {
    let solved = ws.last_solve().unwrap_or_else(|| panic!("{what}: the solver did not run"));
    assert!(!solved.conic);
    let n = 7;
    let m = solved.h.len();
    let u = DVector::from_column_slice(qdot);
    let p = DMatrix::from_column_slice(n, n, solved.p);
    let g = DMatrix::from_row_slice(m, n, solved.g);
    let z = DVector::from_column_slice(solved.z);
    let stationarity = (&p * &u + DVector::from_column_slice(solved.q) + g.transpose() * &z).amax();
    let scale = 1.0 + (&p * &u).amax();
    assert!(stationarity <= 1e-6 * scale, "{what}: stationarity {stationarity:e}");
    let slack = DVector::from_column_slice(solved.h) - &g * &u;
    for i in 0..m {
        assert!(slack[i] >= -1e-7, "{what}: row {i} violated by {}", -slack[i]);
        assert!(z[i] >= -1e-9, "{what}: negative multiplier {}", z[i]);
        assert!((z[i] * slack[i]).abs() <= 1e-6 * scale, "{what}: complementarity {}", z[i] * slack[i]);
    }
}

fn cluttered_scene() -> Scene {
    let mut scene = Scene::new();
    scene.add_obstacle(Obstacle::table("table", [0.3, 0.0, 0.0], [1.4, 1.6], 0.04)).unwrap();
    scene.allow_contact("panda_link0", "table");
    scene
}

/// The cluttered scene plus a 6 cm ball right under the gripper at `q`,
/// `gap` (m) from the closest robot part.
fn scene_with_ball_below(q: &[f64], gap: f64) -> Scene {
    let panda = Arc::new(RobotModel::panda());
    let mut kin = tandem::robot::KinematicsWorkspace::new(&panda);
    panda.forward_kinematics(&mut kin, q).unwrap();
    let p = panda.frame_pose(&kin, panda.frame_id("panda_hand_tcp").unwrap()).translation.vector;
    let mut z = p.z - 0.06 - gap;
    for _ in 0..20 {
        let mut scene = cluttered_scene();
        let ball = nalgebra::IsometryMatrix3::translation(p.x, p.y, z);
        scene.add_obstacle(Obstacle::new("ball", Shape::sphere(0.06), ball)).unwrap();
        let model = CollisionModel::builder(panda.clone()).scene(&scene).build().unwrap();
        let mut ws = tandem::collision::CollisionWorkspace::new(&model);
        let closest = model
            .distances(&mut ws, q, f64::INFINITY)
            .unwrap()
            .iter()
            .filter(|d| model.pair_names(d.pair).1 == "ball")
            .map(|d| d.signed.distance)
            .fold(f64::INFINITY, f64::min);
        if (closest - gap).abs() < 1e-4 {
            return scene;
        }
        z += closest - gap;
    }
    panic!("could not place the ball {gap} m under the gripper");
}

#[test]
fn constrained_solutions_satisfy_kkt_and_limits() {
    // Pushed into the table and into a joint limit, each QP mode must stop
    // at the boundary with valid multipliers.
    let scene = scene_with_ball_below(&Q, 0.02);
    let mut checked = 0;
    for mode in ArbitrationMode::ALL.into_iter().filter(|m| !m.is_conic()) {
        let arbiter = arbiter_with(&scene, ArbiterSettings { mode, ..ArbiterSettings::default() });
        let mut ws = arbiter.workspace();
        let low = Q;
        let down = [0.0, 0.0, -0.5];
        let near_limit = [2.85, -0.6, 0.05, -2.2, 0.04, 1.7, 0.8];
        let joint = [1.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        for (q, command) in [(&low, HumanCommand::Linear(&down)), (&near_limit, HumanCommand::Joint(&joint))] {
            let out = arbiter.tick(&mut ws, &TickInput { q, velocity: None, command, beliefs: Some(&[0.6, 0.4]) });
            let what = format!("{mode} at {q:?}");
            assert!(
                matches!(out.status, TickStatus::Constrained | TickStatus::StepShortened),
                "{what}: {:?}",
                out.status
            );
            let qdot = out.qdot.to_vec();
            if out.status == TickStatus::Constrained && ws.last_solve().is_some() {
                assert_kkt(&ws, &qdot, &what);
                checked += 1;
            }
            for (j, l) in arbiter.robot().limits().iter().enumerate() {
                let next = q[j] + qdot[j] / 15.0;
                assert!(next <= l.upper + 1e-12 && next >= l.lower - 1e-12, "{what}: joint {j} to {next}");
                assert!(qdot[j].abs() <= l.velocity + 1e-12, "{what}: joint {j} at {} rad/s", qdot[j]);
            }
        }
    }
    assert!(checked >= 8, "only {checked} solves checked");
}

#[test]
fn a_separating_pair_is_never_slowed() {
    // The hand 2 cm above the ball (inside a 3 cm margin): moving up is
    // executed exactly; moving down is stopped.
    let q = Q;
    let scene = scene_with_ball_below(&q, 0.02);
    let mut settings = ArbiterSettings::default();
    settings.safety.margin = 0.03;
    let arbiter = arbiter_with(&scene, settings);
    let mut ws = arbiter.workspace();
    let up = [0.0, 0.0, 0.1];
    let out =
        arbiter.tick(&mut ws, &TickInput { q: &q, velocity: None, command: HumanCommand::Linear(&up), beliefs: None });
    assert!(matches!(out.status, TickStatus::Nominal), "{:?} {:?}", out.status, out.diagnostics);
    let qdot = out.qdot.to_vec();
    let want = dls(&task_jacobian(&ws, 3), &DVector::from_column_slice(&up));
    assert_close(&qdot, &want, "moving away");
    let down = [0.0, 0.0, -0.1];
    let out = arbiter
        .tick(&mut ws, &TickInput { q: &q, velocity: None, command: HumanCommand::Linear(&down), beliefs: None });
    assert_eq!(out.status, TickStatus::Constrained);
    let qdot = out.qdot.to_vec();
    let vz = (task_jacobian(&ws, 3) * DVector::from_column_slice(&qdot))[2];
    assert!(vz > -0.1 * 0.5, "approach not slowed: {vz} m/s");
}

#[test]
fn bad_inputs_hold_and_the_next_tick_works() {
    let arbiter = free_arbiter(ArbiterSettings { mode: ArbitrationMode::Constrained, ..ArbiterSettings::default() });
    let mut ws = arbiter.workspace();
    let v = [0.05, 0.0, 0.0];
    let nan_q = [f64::NAN; 7];
    let cases: Vec<(TickInput<'_>, TickStatus)> = vec![
        (TickInput::new(&Q, HumanCommand::Linear(&[f64::NAN, 0.0, 0.0])), TickStatus::InvalidCommand),
        (TickInput::new(&Q, HumanCommand::Linear(&[0.1, f64::INFINITY, 0.0])), TickStatus::InvalidCommand),
        (TickInput::new(&Q, HumanCommand::Linear(&[0.1, 0.0])), TickStatus::InvalidCommand),
        (TickInput::new(&Q, HumanCommand::Joint(&[0.1; 6])), TickStatus::InvalidCommand),
        (TickInput::new(&nan_q, HumanCommand::Linear(&v)), TickStatus::InvalidState),
        (TickInput::new(&Q[..6], HumanCommand::Linear(&v)), TickStatus::InvalidState),
        (
            TickInput { velocity: Some(&[f64::NAN; 7]), ..TickInput::new(&Q, HumanCommand::Linear(&v)) },
            TickStatus::InvalidState,
        ),
        (
            TickInput { beliefs: Some(&[0.5, 0.6]), ..TickInput::new(&Q, HumanCommand::Linear(&v)) },
            TickStatus::InvalidBeliefs,
        ),
        (
            TickInput { beliefs: Some(&[1.0]), ..TickInput::new(&Q, HumanCommand::Linear(&v)) },
            TickStatus::InvalidBeliefs,
        ),
        (
            TickInput { beliefs: Some(&[-0.5, 1.5]), ..TickInput::new(&Q, HumanCommand::Linear(&v)) },
            TickStatus::InvalidBeliefs,
        ),
    ];
    for (input, status) in cases {
        let out = arbiter.tick(&mut ws, &input);
        assert_eq!(out.status, status, "{input:?}");
        assert!(out.qdot.iter().all(|x| *x == 0.0), "{status:?} must hold");
        let next = arbiter.tick(&mut ws, &TickInput::new(&Q, HumanCommand::Linear(&v)));
        assert_eq!(next.status, TickStatus::Nominal);
        assert!(next.qdot.iter().any(|x| *x != 0.0));
    }
    // Huge commands are clipped by the velocity limits, not passed on.
    let out = arbiter.tick(&mut ws, &TickInput::new(&Q, HumanCommand::Linear(&[1e300, 0.0, 0.0])));
    assert!(out.qdot.iter().zip(arbiter.robot().limits()).all(|(v, l)| v.abs() <= l.velocity + 1e-12));
}

/// A policy that fails on every query.
#[derive(Debug)]
struct Broken;

impl RobotPolicy for Broken {
    fn dof(&self) -> usize {
        7
    }
    fn new_workspace(&self) -> RobotPolicyWorkspace {
        RobotPolicyWorkspace::new(())
    }
    fn act(&self, _: &mut RobotPolicyWorkspace, _: &[f64], _: &[f64], _: &mut [f64]) -> Result<(), ControlError> {
        Err(ControlError::ForeignState)
    }
    fn probe(&self, _: &mut RobotPolicyWorkspace, _: &[f64], _: &[f64], _: &mut [f64]) -> Result<(), ControlError> {
        Err(ControlError::ForeignState)
    }
    fn reset(&self, _: &mut RobotPolicyWorkspace) {}
}

#[test]
fn a_failing_policy_drops_assistance_but_not_the_operator() {
    let panda = Arc::new(RobotModel::panda());
    let model = Arc::new(CollisionModel::builder(panda).build().unwrap());
    let goal = ArbiterGoal { name: "broken".into(), position: [0.5, 0.0, 0.3], policy: Arc::new(Broken) };
    let settings = ArbiterSettings { mode: ArbitrationMode::SumOfSquares, ..ArbiterSettings::default() };
    let arbiter = Arbiter::new(model, "panda_hand_tcp", vec![goal], settings).unwrap();
    let mut ws = arbiter.workspace();
    let v = [0.03, 0.0, 0.0];
    let out = arbiter.tick(&mut ws, &TickInput::new(&Q, HumanCommand::Linear(&v)));
    assert_eq!(out.status, TickStatus::PolicyFailed);
    let qdot = out.qdot.to_vec();
    let want = dls(&task_jacobian(&ws, 3), &DVector::from_column_slice(&v));
    assert_close(&qdot, &want, "direct control under a broken policy");
}

#[test]
fn near_a_singularity_the_arm_keeps_moving() {
    // Stretched straight up (joints 2 and 4 at 0 and −0.07 rad): the
    // gripper cannot move up, but sideways it can.
    let arbiter = free_arbiter(ArbiterSettings::default());
    let mut ws = arbiter.workspace();
    let q = [0.0, 0.0, 0.0, -0.07, 0.0, 3.0, 0.785];
    for v in [[0.0, 0.0, 0.1], [0.1, 0.0, 0.0], [0.07, 0.0, 0.07]] {
        let out = arbiter.tick(&mut ws, &TickInput::new(&q, HumanCommand::Linear(&v)));
        assert!(!out.status.is_hold(), "{v:?}: {:?}", out.status);
        let qdot = out.qdot.to_vec();
        let speed = qdot.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(speed.is_finite() && speed < 3.0, "{v:?}: joint speed {speed}");
        let moved = task_jacobian(&ws, 3) * DVector::from_column_slice(&qdot);
        if v[0] > 0.0 {
            assert!(moved[0] > 0.5 * v[0], "{v:?}: only {moved:?} m/s");
        }
    }
}

/// Ticks allocate nothing of their own; Clarabel's solve allocates one
/// small map per call in its internal timers (`clarabel::timers`, reset at
/// every solve), which only ticks where a constraint binds pay.
#[test]
fn ticks_do_not_allocate() {
    let scene = scene_with_ball_below(&Q, 0.02);
    let near_limit = [2.85, -0.6, 0.05, -2.2, 0.04, 1.7, 0.8];
    let (mut free_ticks, mut solves_seen) = (0, 0);
    for mode in ArbitrationMode::ALL {
        let arbiter = arbiter_with(&scene, ArbiterSettings { mode, ..ArbiterSettings::default() });
        let mut ws = arbiter.workspace();
        let inputs = [
            TickInput::new(&Q, HumanCommand::Linear(&[0.05, 0.0, 0.0])),
            TickInput::new(&Q, HumanCommand::Twist(&[0.05, 0.0, 0.0, 0.0, 0.1, 0.0])),
            TickInput::new(&Q, HumanCommand::Joint(&[0.1; 7])),
            TickInput::new(&Q, HumanCommand::Linear(&[f64::NAN, 0.0, 0.0])),
            TickInput::new(&Q, HumanCommand::Linear(&[0.0, 0.0, -0.5])),
            TickInput::new(&near_limit, HumanCommand::Joint(&[1.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])),
        ];
        // Warm-up: every code path once.
        for input in &inputs {
            arbiter.tick(&mut ws, input);
        }
        for _ in 0..20 {
            for input in &inputs {
                let before = common::alloc::allocations();
                let solves = arbiter.tick(&mut ws, input).diagnostics.solves as usize;
                let allocated = common::alloc::allocations() - before;
                // The active-set QP solver allocates nothing; Clarabel (the
                // cone of Constrained) at most once per solve (its timers).
                let allowed = if mode.is_conic() { solves } else { 0 };
                assert!(
                    allocated <= allowed,
                    "{mode}: {allocated} allocations in a tick of {solves} solves ({input:?})"
                );
                free_ticks += usize::from(solves == 0);
                solves_seen += solves;
            }
        }
    }
    assert!(free_ticks >= 400 && solves_seen >= 200, "{free_ticks} ticks without a solve, {solves_seen} solves");
}

/// With the OSQP backend, even ticks that solve allocate nothing.
#[cfg(feature = "osqp")]
#[test]
fn ticks_with_osqp_do_not_allocate() {
    let scene = scene_with_ball_below(&Q, 0.02);
    let settings = ArbiterSettings { backend: tandem::arbitration::SolverBackend::Osqp, ..ArbiterSettings::default() };
    let arbiter = arbiter_with(&scene, settings);
    let mut ws = arbiter.workspace();
    let input = TickInput::new(&Q, HumanCommand::Linear(&[0.0, 0.0, -0.5]));
    arbiter.tick(&mut ws, &input);
    let before = common::alloc::allocations();
    let mut solves = 0;
    for _ in 0..50 {
        solves += arbiter.tick(&mut ws, &input).diagnostics.solves;
    }
    assert!(solves >= 50);
    assert_eq!(common::alloc::allocations() - before, 0);
}

/// The QP modes give the same command with the active set, Clarabel and
/// OSQP (the solver forced on every tick), free and constrained.
#[cfg(feature = "osqp")]
#[test]
fn the_solver_backends_agree() {
    use tandem::arbitration::SolverBackend;
    let scene = scene_with_ball_below(&Q, 0.02);
    let near_limit = [2.85, -0.6, 0.05, -2.2, 0.04, 1.7, 0.8];
    let inputs = [
        TickInput::new(&Q, HumanCommand::Linear(&[0.05, 0.02, 0.0])),
        TickInput::new(&Q, HumanCommand::Linear(&[0.0, 0.0, -0.5])),
        TickInput::new(&Q, HumanCommand::Twist(&[0.05, 0.0, -0.3, 0.0, 0.1, 0.0])),
        TickInput::new(&near_limit, HumanCommand::Joint(&[1.5, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0])),
    ];
    let mut worst = 0.0f64;
    for mode in ArbitrationMode::ALL.into_iter().filter(|m| !m.is_conic()) {
        let mut runs = vec![];
        for backend in [SolverBackend::ActiveSet, SolverBackend::Clarabel, SolverBackend::Osqp] {
            let mut settings =
                ArbiterSettings { mode, backend, closed_form_first: false, ..ArbiterSettings::default() };
            settings.solver.tolerance = 1e-9;
            let arbiter = arbiter_with(&scene, settings);
            let mut ws = arbiter.workspace();
            runs.push(inputs.iter().map(|i| arbiter.tick(&mut ws, i).qdot.to_vec()).collect::<Vec<_>>());
        }
        for (name, run) in [("Clarabel", &runs[1]), ("OSQP", &runs[2])] {
            for (k, (a, b)) in runs[0].iter().zip(run).enumerate() {
                let err = a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
                worst = worst.max(err);
                assert!(err < 1e-6, "{mode}, input {k}: the active set and {name} differ by {err:e}");
            }
        }
    }
    eprintln!("largest difference from the active set (Clarabel, OSQP): {worst:e} rad/s");
}
