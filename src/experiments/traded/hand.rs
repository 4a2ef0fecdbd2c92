//! Synthesized hand-motion demonstrations (§7.5.6 of the dissertation): a
//! person reaches to grasp one of the objects on the table from the top or
//! from the side, as a hand tracker would see it at 180 Hz.
//!
//! The reaching model is minimum-jerk (Flash & Hogan) in position and in
//! orientation (a geodesic between the start and grasp orientations), with
//! trial-to-trial variability and a slow start:
//!
//! * rest before the reach starts: `U(0.3, 0.9)` s with 2 mm tremor;
//! * reach duration `U(1.2, 2.4)` s, then holding at the grasp `U(0.4, 1.2)` s
//!   (episodes of 2–4.5 s, the dissertation's 2–5 s);
//! * the path bows by a bump `64 τ³ (1 − τ)³` (zero velocity and acceleration
//!   at both ends) times a random via offset: lateral `N(0, 3 cm)`, up
//!   `U(3, 10) cm`;
//! * end-point scatter `N(0, 1 cm)` per axis, grasp orientation scatter
//!   `N(0, 0.1 rad)` about a random axis.
//!
//! Users ([`HandUser`]): *Normal* as above, *Noisy* adds `N(0, 1 cm)` to the
//! position and `N(0, 0.05 rad)` to the orientation at every step, *Biased*
//! adds one constant offset per episode (`U(−5, 5) cm` per axis,
//! `U(−0.15, 0.15) rad` about a random axis).
//!
//! Frames: world (the robot's table frame, z up, x away from the robot); the
//! hand frame has x along the fingers (*hand direction*) and z out of the
//! palm (*palm normal*).
//!
//! ```
//! use tandem::experiments::traded::{GraspDirection, HandUser, synthesize_reach};
//! let objects = [[0.5, -0.2, 0.06], [0.55, 0.0, 0.06], [0.5, 0.2, 0.06]];
//! let demo = synthesize_reach(&objects, 1, GraspDirection::Top, HandUser::Normal, 7);
//! assert!(demo.samples.len() > 300);
//! ```

use nalgebra::{Rotation3, Unit, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Tracker rate (Hz), the dissertation's 180 Hz.
pub const HAND_RATE: f64 = 180.0;

/// Where the hand starts (world, m): above the table edge in front of the
/// objects.
pub const HAND_REST: [f64; 3] = [0.25, 0.0, 0.25];

/// How the hand grasps the object.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
pub enum GraspDirection {
    /// From above: fingers forward and down, palm down.
    Top,
    /// From the side: fingers forward, palm facing sideways (toward −y).
    Side,
}

impl GraspDirection {
    /// Both directions, in class order.
    pub const ALL: [GraspDirection; 2] = [GraspDirection::Top, GraspDirection::Side];

    /// Class index (Top 0, Side 1).
    pub fn index(self) -> usize {
        self as usize
    }

    /// Name as in the tables.
    pub fn as_str(self) -> &'static str {
        match self {
            GraspDirection::Top => "top",
            GraspDirection::Side => "side",
        }
    }
}

/// The simulated demonstrator (§7.5.6 of the dissertation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
pub enum HandUser {
    /// The reaching model alone.
    Normal,
    /// Gaussian noise at every step.
    Noisy,
    /// A constant random offset per episode.
    Biased,
}

impl HandUser {
    /// The three users, in table order.
    pub const ALL: [HandUser; 3] = [HandUser::Normal, HandUser::Noisy, HandUser::Biased];

    /// Name as in the tables.
    pub fn as_str(self) -> &'static str {
        match self {
            HandUser::Normal => "Normal",
            HandUser::Noisy => "Noisy",
            HandUser::Biased => "Biased",
        }
    }
}

/// One tracker sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandSample {
    /// Time since the demonstration began (s).
    pub time: f64,
    /// Palm centre (world, m).
    pub position: [f64; 3],
    /// Unit vector along the fingers (world).
    pub direction: [f64; 3],
    /// Unit normal out of the palm (world).
    pub palm_normal: [f64; 3],
    /// Roll, pitch, yaw of the hand frame (rad, extrinsic x-y-z).
    pub rpy: [f64; 3],
}

/// A synthesized demonstration and its labels.
#[derive(Debug, Clone)]
pub struct Demonstration {
    /// Index of the object reached for.
    pub object: usize,
    /// How it is grasped.
    pub direction: GraspDirection,
    /// Samples at [`HAND_RATE`].
    pub samples: Vec<HandSample>,
}

/// The hand orientation grasping `direction` (hand frame in world).
pub fn grasp_orientation(direction: GraspDirection) -> Rotation3<f64> {
    let (fingers, palm) = match direction {
        // Fingers 60° below the horizontal, palm facing down and back.
        GraspDirection::Top => (Vector3::new(0.5, 0.0, -0.866), Vector3::new(-0.866, 0.0, -0.5)),
        GraspDirection::Side => (Vector3::new(1.0, 0.0, 0.0), Vector3::new(0.0, -1.0, 0.0)),
    };
    hand_frame(fingers, palm)
}

/// The hand at rest: fingers forward and 30° down, palm down.
fn rest_orientation() -> Rotation3<f64> {
    hand_frame(Vector3::new(0.866, 0.0, -0.5), Vector3::new(0.5, 0.0, 0.866).scale(-1.0))
}

fn hand_frame(fingers: Vector3<f64>, palm: Vector3<f64>) -> Rotation3<f64> {
    let x = fingers.normalize();
    let z = (palm - x * palm.dot(&x)).normalize();
    let y = z.cross(&x);
    Rotation3::from_basis_unchecked(&[x, y, z])
}

/// Where the palm ends for a grasp of an object centred at `object` (world, m).
pub fn grasp_position(object: [f64; 3], direction: GraspDirection) -> Vector3<f64> {
    let c = Vector3::from(object);
    match direction {
        GraspDirection::Top => c + Vector3::new(-0.04, 0.0, 0.12),
        GraspDirection::Side => c + Vector3::new(0.0, 0.07, 0.02),
    }
}

/// Minimum-jerk progress `10τ³ − 15τ⁴ + 6τ⁵` of `τ ∈ [0, 1]`.
pub fn minimum_jerk(tau: f64) -> f64 {
    let t = tau.clamp(0.0, 1.0);
    t * t * t * (10.0 - 15.0 * t + 6.0 * t * t)
}

/// A standard normal draw (Box–Muller).
fn gaussian(rng: &mut ChaCha8Rng) -> f64 {
    let u: f64 = rng.random_range(f64::EPSILON..1.0);
    let v: f64 = rng.random_range(0.0..1.0);
    (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
}

fn random_rotation(rng: &mut ChaCha8Rng, angle: f64) -> Rotation3<f64> {
    let axis = Vector3::new(gaussian(rng), gaussian(rng), gaussian(rng));
    match Unit::try_new(axis, 1e-9) {
        Some(axis) => Rotation3::from_axis_angle(&axis, angle),
        None => Rotation3::identity(),
    }
}

/// Synthesizes one demonstration of reaching for `objects[object]` (object
/// centres, world, m) with `direction` by `user`, seeded by `seed`.
/// An out-of-range `object` is clamped to the last one.
pub fn synthesize_reach(
    objects: &[[f64; 3]],
    object: usize,
    direction: GraspDirection,
    user: HandUser,
    seed: u64,
) -> Demonstration {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let object = object.min(objects.len().saturating_sub(1));
    let rest_time = rng.random_range(0.3..0.9);
    let reach_time = rng.random_range(1.2..2.4);
    let hold_time = rng.random_range(0.4..1.2);
    let start = Vector3::from(HAND_REST);
    let scatter = Vector3::new(gaussian(&mut rng), gaussian(&mut rng), gaussian(&mut rng)) * 0.01;
    let end = grasp_position(objects.get(object).copied().unwrap_or(HAND_REST), direction) + scatter;
    let via = Vector3::new(0.0, 0.03 * gaussian(&mut rng), rng.random_range(0.03..0.10));
    let r0 = rest_orientation();
    let scatter_angle = 0.1 * gaussian(&mut rng);
    let r1 = random_rotation(&mut rng, scatter_angle) * grasp_orientation(direction);
    let (bias_p, bias_r) = match user {
        HandUser::Biased => {
            let p = Vector3::new(
                rng.random_range(-0.05..0.05),
                rng.random_range(-0.05..0.05),
                rng.random_range(-0.05..0.05),
            );
            let angle = rng.random_range(-0.15..0.15);
            (p, random_rotation(&mut rng, angle))
        }
        _ => (Vector3::zeros(), Rotation3::identity()),
    };
    let total = rest_time + reach_time + hold_time;
    let steps = (total * HAND_RATE).round() as usize;
    let mut samples = Vec::with_capacity(steps);
    for k in 0..steps {
        let time = k as f64 / HAND_RATE;
        let tau = ((time - rest_time) / reach_time).clamp(0.0, 1.0);
        let s = minimum_jerk(tau);
        let bump = 64.0 * tau.powi(3) * (1.0 - tau).powi(3);
        let tremor = Vector3::new(gaussian(&mut rng), gaussian(&mut rng), gaussian(&mut rng)) * 0.002;
        let mut p = start + (end - start) * s + via * bump + tremor + bias_p;
        let mut r = bias_r * r0.slerp(&r1, s);
        if user == HandUser::Noisy {
            p += Vector3::new(gaussian(&mut rng), gaussian(&mut rng), gaussian(&mut rng)) * 0.01;
            let angle = 0.05 * gaussian(&mut rng);
            r = random_rotation(&mut rng, angle) * r;
        }
        samples.push(sample(time, p, r));
    }
    Demonstration { object, direction, samples }
}

fn sample(time: f64, p: Vector3<f64>, r: Rotation3<f64>) -> HandSample {
    let m = r.matrix();
    let (roll, pitch, yaw) = r.euler_angles();
    HandSample {
        time,
        position: [p.x, p.y, p.z],
        direction: [m[(0, 0)], m[(1, 0)], m[(2, 0)]],
        palm_normal: [m[(0, 2)], m[(1, 2)], m[(2, 2)]],
        rpy: [roll, pitch, yaw],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const OBJECTS: [[f64; 3]; 3] = [[0.5, -0.2, 0.06], [0.55, 0.0, 0.06], [0.5, 0.2, 0.06]];

    #[test]
    fn reach_ends_at_the_grasp_and_is_seeded() {
        for direction in GraspDirection::ALL {
            let a = synthesize_reach(&OBJECTS, 2, direction, HandUser::Normal, 3);
            let b = synthesize_reach(&OBJECTS, 2, direction, HandUser::Normal, 3);
            assert_eq!(a.samples, b.samples);
            let last = a.samples.last().map(|s| Vector3::from(s.position)).unwrap_or_default();
            assert!((last - grasp_position(OBJECTS[2], direction)).norm() < 0.05);
            let duration = a.samples.len() as f64 / HAND_RATE;
            assert!((1.9..=4.5).contains(&duration), "{duration}");
        }
    }

    #[test]
    fn minimum_jerk_is_smooth_at_the_ends() {
        assert_eq!(minimum_jerk(0.0), 0.0);
        assert_eq!(minimum_jerk(1.0), 1.0);
        assert!((minimum_jerk(0.5) - 0.5).abs() < 1e-12);
        assert!(minimum_jerk(1e-3) < 1e-8);
    }
}
