//! The limits of a joint's motion beyond its position: velocity,
//! acceleration, deceleration and jerk, with where each came from.
//!
//! A real arm's controller refuses a command sequence that breaks them:
//! libfranka aborts with a reflex (`joint_motion_generator_*_discontinuity`),
//! ros2_control's limiters clamp silently. The arbiter keeps them as hard
//! constraints of its tick (see `arbitration::motion`); here is only what
//! they are. A [`RobotModel`](super::RobotModel) holds one
//! [`JointMotionLimits`] per active joint: the URDF's velocity limit, the
//! embedded Panda's published Franka table, a MoveIt / ros2_control
//! `joint_limits.yaml` (read by `problem::joint_limits`), or the documented
//! defaults ([`JointMotionLimits::default_for`]).

/// Where one limit of a joint came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LimitSource {
    /// The URDF's `<limit velocity>`.
    Urdf,
    /// A table built into tandem: `"franka_panda"` (libfranka 0.9's
    /// `rate_limiting.h`, the Panda) or `"franka_fr3"` (libfranka's current
    /// table, the Franka Research 3).
    Builtin(&'static str),
    /// A `joint_limits.yaml` (its path as given).
    File(String),
    /// tandem's default for a joint that no source limits (see
    /// [`JointMotionLimits::default_for`]).
    Default,
}

impl std::fmt::Display for LimitSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LimitSource::Urdf => write!(f, "URDF"),
            LimitSource::Builtin(name) => write!(f, "builtin:{name}"),
            LimitSource::File(path) => write!(f, "{path}"),
            LimitSource::Default => write!(f, "default"),
        }
    }
}

/// A velocity limit that depends on the joint's position, as the Franka
/// Research 3 publishes it: upwards `min(cap, max(0, −offset +
/// √(gain·(upper − q))))`, downwards `max(−cap, min(0, offset −
/// √(gain·(q − lower))))` (rad/s; `q` in rad). It slows a joint near its
/// position limits so that it can stop in time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionVelocityLimit {
    /// The largest speed anywhere (rad/s).
    pub cap: f64,
    /// Speed taken off the square root (rad/s).
    pub offset: f64,
    /// Gain under the root (rad/s² — twice a deceleration).
    pub gain: f64,
    /// Position where upward motion must have stopped (rad).
    pub upper: f64,
    /// Position where downward motion must have stopped (rad).
    pub lower: f64,
}

impl PositionVelocityLimit {
    /// The range `[down, up]` of velocities allowed at `q` (rad/s;
    /// `down ≤ 0 ≤ up`).
    pub fn at(&self, q: f64) -> (f64, f64) {
        let up = (-self.offset + (self.gain * (self.upper - q)).max(0.0).sqrt()).clamp(0.0, self.cap);
        let down = (self.offset - (self.gain * (q - self.lower)).max(0.0).sqrt()).clamp(-self.cap, 0.0);
        (down, up)
    }
}

/// The motion limits of one joint (rad/s, rad/s², rad/s³; m for a
/// prismatic joint). Every value is finite and positive.
#[derive(Debug, Clone, PartialEq)]
pub struct JointMotionLimits {
    /// Speed limit `|q̇| ≤ velocity`.
    pub velocity: f64,
    /// Limit on speeding up: `|q̈| ≤ acceleration` while `|q̇|` grows.
    pub acceleration: f64,
    /// Limit on slowing down: `|q̈| ≤ deceleration` while `|q̇|` shrinks.
    pub deceleration: f64,
    /// `|q⃛| ≤ jerk`.
    pub jerk: f64,
    /// A position-dependent velocity limit on top of `velocity` (the FR3's).
    pub velocity_profile: Option<PositionVelocityLimit>,
    /// Where `velocity`, `acceleration`, `deceleration` and `jerk` came from.
    pub sources: [LimitSource; 4],
}

/// What a `joint_limits.yaml` or a table says of one joint; `None` keeps
/// what the joint has.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MotionLimitOverride {
    /// `max_velocity` (rad/s or m/s).
    pub velocity: Option<f64>,
    /// `max_acceleration`.
    pub acceleration: Option<f64>,
    /// `max_deceleration` (when absent, a given acceleration limit applies
    /// to slowing down too, as ros2_control does).
    pub deceleration: Option<f64>,
    /// `max_jerk`.
    pub jerk: Option<f64>,
}

/// The Panda's published joint limits: libfranka 0.9's `rate_limiting.h`
/// (`kMaxJointVelocity`, `kMaxJointAcceleration`, `kMaxJointJerk`, without
/// its `kLimitEps` = 1e-3 margin, which the arbiter's own tolerance keeps).
pub const FRANKA_PANDA: [[f64; 3]; 7] = [
    [2.1750, 15.0, 7500.0],
    [2.1750, 7.5, 3750.0],
    [2.1750, 10.0, 5000.0],
    [2.1750, 12.5, 6250.0],
    [2.6100, 15.0, 7500.0],
    [2.6100, 20.0, 10000.0],
    [2.6100, 20.0, 10000.0],
];

/// The Franka Research 3's: libfranka's current `rate_limiting.h` (10
/// rad/s², 5,000 rad/s³ on every joint) and its position-dependent velocity
/// limits (`computeUpperLimitsJointVelocity`, `…Lower…`): per joint `cap,
/// offset, gain, upper, lower` of [`PositionVelocityLimit`].
pub const FRANKA_FR3: [[f64; 5]; 7] = [
    [2.62, 0.30, 12.0, 2.75010, -2.75010],
    [2.62, 0.20, 5.17, 1.79180, -1.79180],
    [2.62, 0.20, 7.00, 2.90650, -2.90650],
    [2.62, 0.30, 8.00, -0.1458, -3.04810],
    [5.26, 0.35, 34.0, 2.81010, -2.81010],
    [4.18, 0.35, 11.0, 4.52050, 0.54092],
    [5.26, 0.35, 34.0, 3.01960, -3.01960],
];

/// The built-in tables by name: `franka_panda` and `franka_fr3`, for the
/// joints `panda_joint1` … `panda_joint7` (franka_description names the
/// FR3's `fr3_joint1` …; both are accepted).
pub fn builtin_limits(name: &str, joint: &str) -> Option<(MotionLimitOverride, Option<PositionVelocityLimit>)> {
    let index = ["panda_joint", "fr3_joint"]
        .iter()
        .find_map(|p| joint.strip_prefix(p))
        .and_then(|k| k.parse::<usize>().ok())
        .filter(|k| (1..=7).contains(k))?
        - 1;
    match name {
        "franka_panda" => {
            let [v, a, j] = FRANKA_PANDA[index];
            let set =
                MotionLimitOverride { velocity: Some(v), acceleration: Some(a), deceleration: Some(a), jerk: Some(j) };
            Some((set, None))
        }
        "franka_fr3" => {
            let [cap, offset, gain, upper, lower] = FRANKA_FR3[index];
            let set = MotionLimitOverride {
                velocity: Some(cap),
                acceleration: Some(10.0),
                deceleration: Some(10.0),
                jerk: Some(5000.0),
            };
            Some((set, Some(PositionVelocityLimit { cap, offset, gain, upper, lower })))
        }
        _ => None,
    }
}

/// The names [`builtin_limits`] knows.
pub const BUILTIN_LIMITS: [&str; 2] = ["franka_panda", "franka_fr3"];

impl JointMotionLimits {
    /// tandem's defaults for a joint with URDF velocity limit `velocity`
    /// (rad/s or m/s; a missing, zero or non-finite one reads as 2): full
    /// speed within 0.2 s (`acceleration = deceleration = 5·velocity`
    /// per s) and full acceleration within 20 ms (`jerk = 50·acceleration`
    /// per s). The Panda's published table is about 7·velocity and
    /// 500·acceleration: the defaults are gentler than a Panda.
    pub fn default_for(velocity: f64) -> JointMotionLimits {
        let (v, source) = if velocity.is_finite() && velocity > 0.0 {
            (velocity, LimitSource::Urdf)
        } else {
            (2.0, LimitSource::Default)
        };
        JointMotionLimits {
            velocity: v,
            acceleration: 5.0 * v,
            deceleration: 5.0 * v,
            jerk: 250.0 * v,
            velocity_profile: None,
            sources: [source, LimitSource::Default, LimitSource::Default, LimitSource::Default],
        }
    }

    /// Applies `set` (and a position-dependent velocity limit), recording
    /// `source` for each value it gives. A given acceleration without a
    /// deceleration limits both.
    pub fn apply(&mut self, set: &MotionLimitOverride, profile: Option<PositionVelocityLimit>, source: &LimitSource) {
        let fields = [set.velocity, set.acceleration, set.deceleration.or(set.acceleration), set.jerk];
        let values = [&mut self.velocity, &mut self.acceleration, &mut self.deceleration, &mut self.jerk];
        for ((value, given), src) in values.into_iter().zip(fields).zip(&mut self.sources) {
            if let Some(x) = given {
                *value = x;
                *src = source.clone();
            }
        }
        if profile.is_some() {
            self.velocity_profile = profile;
        }
    }

    /// The velocity range allowed at position `q`, scaled by `scale`
    /// (rad/s; `down ≤ 0 ≤ up`).
    pub fn velocity_range(&self, q: f64, scale: f64) -> (f64, f64) {
        let v = self.velocity * scale;
        match &self.velocity_profile {
            Some(p) => {
                let (down, up) = p.at(q);
                ((down * scale).max(-v), (up * scale).min(v))
            }
            None => (-v, v),
        }
    }
}
