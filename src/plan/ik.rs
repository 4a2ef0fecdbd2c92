//! Inverse kinematics: damped least squares on the frame Jacobian, joint
//! limits by clamping, seeded random restarts, solutions verified
//! collision-free.

use crate::collision::{CollisionModel, CollisionWorkspace};
use crate::robot::{FrameId, KinematicsWorkspace, ReferenceFrame, RobotError, RobotModel};
use nalgebra::{DMatrix, DVector, Matrix6xX, Rotation3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use thiserror::Error;

/// Where a frame should go.
#[derive(Debug, Clone, PartialEq)]
pub struct IkTarget {
    pub frame: FrameId,
    /// Frame origin position (world, m).
    pub position: Vector3<f64>,
    /// Full orientation (world), when required.
    pub orientation: Option<Rotation3<f64>>,
    /// Frame axis (0 = x, 1 = y, 2 = z) to point along a world direction.
    pub axis_alignment: Option<(usize, Vector3<f64>)>,
}

/// Settings of [`solve_ik`].
#[derive(Debug, Clone, PartialEq)]
pub struct IkSettings {
    /// Attempts: the first from the given seed configuration, then random.
    pub restarts: usize,
    /// Damped least-squares iterations per attempt.
    pub iterations: usize,
    /// Position tolerance (m).
    pub position_tolerance: f64,
    /// Orientation tolerance (rad).
    pub angle_tolerance: f64,
    /// Damping λ of (J Jᵀ + λ² I).
    pub damping: f64,
    pub seed: u64,
}

impl Default for IkSettings {
    fn default() -> Self {
        IkSettings {
            restarts: 50,
            iterations: 150,
            position_tolerance: 1e-5,
            angle_tolerance: 1e-4,
            damping: 1e-3,
            seed: 0,
        }
    }
}

/// Why inverse kinematics failed.
#[derive(Debug, Error)]
pub enum IkError {
    /// No attempt converged; the best one missed by this much.
    #[error(
        "no joint configuration within limits reaches the target (best attempt: {position_error:.2e} m, {angle_error:.2e} rad off after {attempts} attempts)"
    )]
    Unreachable { position_error: f64, angle_error: f64, attempts: usize },
    /// Every converged solution collides.
    #[error("{solutions} configurations reach the target but all collide (first: {first_pair})")]
    InCollision { solutions: usize, first_pair: String },
    #[error(transparent)]
    Robot(#[from] RobotError),
}

/// The 6-vector error (position; orientation) of the frame at `q` and the
/// number of rows that matter (3 for position only).
fn error(
    robot: &RobotModel,
    ws: &mut KinematicsWorkspace,
    jac: &mut Matrix6xX<f64>,
    t: &IkTarget,
    q: &[f64],
) -> Result<(DVector<f64>, DMatrix<f64>), RobotError> {
    robot.forward_kinematics(ws, q)?;
    let pose = robot.frame_jacobian(ws, t.frame, ReferenceFrame::WorldAligned, jac)?;
    let ep = t.position - pose.translation.vector;
    let er = match (&t.orientation, &t.axis_alignment) {
        (Some(r), _) => Some(crate::robot::rotation_log(&(r * pose.rotation.inverse()))),
        (None, Some((axis, dir))) => Some(pose.rotation.matrix().column(*axis).cross(dir)),
        (None, None) => None,
    };
    let rows = if er.is_some() { 6 } else { 3 };
    let e = DVector::from_iterator(rows, ep.iter().chain(er.iter().flat_map(|v| v.iter())).copied());
    let j = DMatrix::from_fn(rows, robot.nq(), |r, c| jac[(r, c)]);
    Ok((e, j))
}

/// One damped least-squares descent from `q`; returns the final position
/// and angle errors.
fn descend(robot: &RobotModel, t: &IkTarget, q: &mut [f64], s: &IkSettings) -> Result<(f64, f64), RobotError> {
    let mut ws = KinematicsWorkspace::new(robot);
    let mut jac = Matrix6xX::zeros(robot.nq());
    let mut errs = (f64::INFINITY, f64::INFINITY);
    for _ in 0..s.iterations {
        let (e, j) = error(robot, &mut ws, &mut jac, t, q)?;
        errs = (e.rows(0, 3).norm(), if e.len() > 3 { e.rows(3, 3).norm() } else { 0.0 });
        if errs.0 < s.position_tolerance && errs.1 < s.angle_tolerance {
            break;
        }
        let jjt = &j * j.transpose() + DMatrix::identity(e.len(), e.len()) * (s.damping * s.damping);
        let Some(step) = jjt.cholesky().map(|c| j.transpose() * c.solve(&e)) else { break };
        for ((v, d), l) in q.iter_mut().zip(step.iter()).zip(robot.limits()) {
            *v = (*v + d).clamp(l.lower, l.upper);
        }
    }
    Ok(errs)
}

/// Up to `count` distinct collision-free configurations placing the target
/// frame as asked, the first attempt starting from `seed_q`.
///
/// # Errors
/// [`IkError::Unreachable`] when no attempt converges,
/// [`IkError::InCollision`] when every converged one collides.
pub fn solve_ik(
    collision: &CollisionModel,
    ws: &mut CollisionWorkspace,
    target: &IkTarget,
    seed_q: &[f64],
    count: usize,
    settings: &IkSettings,
) -> Result<Vec<Vec<f64>>, IkError> {
    let robot = collision.robot().clone();
    robot.check_configuration(seed_q)?;
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    let (mut found, mut colliding, mut best) = (Vec::<Vec<f64>>::new(), None, (f64::INFINITY, f64::INFINITY));
    let mut colliding_count = 0;
    for attempt in 0..settings.restarts.max(1) {
        let mut q: Vec<f64> = if attempt == 0 {
            seed_q.to_vec()
        } else {
            robot.limits().iter().map(|l| rng.random_range(l.lower..=l.upper)).collect()
        };
        let errs = descend(&robot, target, &mut q, settings)?;
        if errs.0 + errs.1 < best.0 + best.1 {
            best = errs;
        }
        if errs.0 >= settings.position_tolerance || errs.1 >= settings.angle_tolerance {
            continue;
        }
        if found.iter().any(|f| f.iter().zip(&q).all(|(a, b)| (a - b).abs() < 1e-3)) {
            continue;
        }
        if collision.collision_free(ws, &q)? {
            found.push(q);
            if found.len() >= count {
                break;
            }
        } else {
            colliding_count += 1;
            if colliding.is_none() {
                let d = collision.min_distance(ws, &q)?.map(|d| collision.pair_names(d.pair));
                colliding = d.map(|(a, b)| format!("{a} and {b}"));
            }
        }
    }
    if !found.is_empty() {
        return Ok(found);
    }
    match colliding {
        Some(first_pair) => Err(IkError::InCollision { solutions: colliding_count, first_pair }),
        None => Err(IkError::Unreachable {
            position_error: best.0,
            angle_error: best.1,
            attempts: settings.restarts.max(1),
        }),
    }
}
