//! Inverse kinematics: damped least squares on the frame Jacobian, joint
//! limits by clamping, seeded random restarts, solutions verified
//! collision-free.

use crate::collision::{CollisionModel, CollisionWorkspace};
use crate::robot::{FrameId, KinematicsWorkspace, ReferenceFrame, RobotError, RobotModel};
use nalgebra::{Matrix6, Matrix6xX, Rotation3, Vector3, Vector6};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use thiserror::Error;

/// Where a frame should go.
#[derive(Debug, Clone, PartialEq)]
pub struct IkTarget {
    /// The robot frame to place.
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
    /// Damped least-squares iterations per attempt, at most; an attempt
    /// whose error shrinks by less than 10 % over 10 iterations is given up.
    pub iterations: usize,
    /// Position tolerance (m).
    pub position_tolerance: f64,
    /// Orientation tolerance (rad).
    pub angle_tolerance: f64,
    /// Damping λ of (J Jᵀ + λ² I).
    pub damping: f64,
    /// Seed of the random restarts.
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
#[non_exhaustive]
pub enum IkError {
    /// No attempt converged; the best one missed by this much.
    #[error(
        "no joint configuration within limits reaches the target (best attempt: {position_error:.2e} m, {angle_error:.2e} rad off after {attempts} attempts)"
    )]
    Unreachable {
        /// Smallest position error reached (m).
        position_error: f64,
        /// Its orientation error (rad).
        angle_error: f64,
        /// Restarts tried.
        attempts: usize,
    },
    /// Every converged solution collides.
    #[error("{solutions} configurations reach the target but all collide (first: {first_pair})")]
    InCollision {
        /// Solutions found, all colliding.
        solutions: usize,
        /// The colliding pair of the first.
        first_pair: String,
    },
    #[error(transparent)]
    /// A robot-side error (unknown frame, bad configuration).
    Robot(#[from] RobotError),
}

/// The frame's position error and orientation error (zero when the target
/// sets no orientation) at `q`, and its world-aligned Jacobian into `jac`
/// (orientation rows zeroed when they do not count).
fn error(
    robot: &RobotModel,
    ws: &mut KinematicsWorkspace,
    jac: &mut Matrix6xX<f64>,
    t: &IkTarget,
    q: &[f64],
) -> Result<(Vector3<f64>, Vector3<f64>), RobotError> {
    robot.forward_kinematics(ws, q)?;
    let pose = robot.frame_jacobian(ws, t.frame, ReferenceFrame::WorldAligned, jac)?;
    let ep = t.position - pose.translation.vector;
    let er = match (&t.orientation, &t.axis_alignment) {
        (Some(r), _) => crate::robot::rotation_log(&(r * pose.rotation.inverse())),
        (None, Some((axis, dir))) => pose.rotation.matrix().column(*axis).cross(dir),
        (None, None) => {
            jac.fixed_rows_mut::<3>(3).fill(0.0);
            Vector3::zeros()
        }
    };
    Ok((ep, er))
}

/// Iterations between stall checks of a descent, and the least fraction
/// by which its error must shrink over them to go on.
const STALL_WINDOW: usize = 10;
const STALL_PROGRESS: f64 = 0.1;

/// One damped least-squares descent from `q`; returns the final position
/// and angle errors. A descent whose error stops shrinking (stuck against
/// joint limits, in a local minimum) is given up early: the restarts find
/// solutions faster than the remaining iterations would.
fn descend(
    robot: &RobotModel,
    ws: &mut KinematicsWorkspace,
    jac: &mut Matrix6xX<f64>,
    t: &IkTarget,
    q: &mut [f64],
    s: &IkSettings,
) -> Result<(f64, f64), RobotError> {
    let mut errs = (f64::INFINITY, f64::INFINITY);
    let mut checkpoint = f64::INFINITY;
    for iteration in 0..s.iterations {
        let (ep, er) = error(robot, ws, jac, t, q)?;
        errs = (ep.norm(), er.norm());
        if errs.0 < s.position_tolerance && errs.1 < s.angle_tolerance {
            break;
        }
        if iteration % STALL_WINDOW == 0 {
            let total = errs.0 + errs.1;
            if total > (1.0 - STALL_PROGRESS) * checkpoint {
                break;
            }
            checkpoint = total;
        }
        // Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e, on the stack.
        let e = Vector6::new(ep.x, ep.y, ep.z, er.x, er.y, er.z);
        // J Jᵀ column by column: a dynamic-size product would go through a
        // general matrix multiply that allocates its packing buffers.
        let mut jjt = Matrix6::identity() * (s.damping * s.damping);
        for column in jac.column_iter() {
            let c = Vector6::from_iterator(column.iter().copied());
            jjt += c * c.transpose();
        }
        let Some(y) = jjt.cholesky().map(|c| c.solve(&e)) else { break };
        for ((k, v), l) in q.iter_mut().enumerate().zip(robot.limits()) {
            *v = (*v + jac.column(k).dot(&y)).clamp(l.lower, l.upper);
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
    let (mut kinematics, mut jac) = (KinematicsWorkspace::new(&robot), Matrix6xX::zeros(robot.nq()));
    for attempt in 0..settings.restarts.max(1) {
        let mut q: Vec<f64> = if attempt == 0 {
            seed_q.to_vec()
        } else {
            robot.limits().iter().map(|l| rng.random_range(l.lower..=l.upper)).collect()
        };
        let errs = descend(&robot, &mut kinematics, &mut jac, target, &mut q, settings)?;
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
