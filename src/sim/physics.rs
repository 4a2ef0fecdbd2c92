//! Settings of a physics episode (the MuJoCo backend, feature `mujoco`):
//! plain data, so that experiments and the command line can name them in
//! every build.
//!
//! A physics episode runs the arbiter exactly as the kinematic simulator
//! does, but the arm is a simulated robot: the arbiter's joint velocities
//! become position-servo targets integrated at the physics step, and the
//! arbiter sees the measured joint positions. When the gripper is in
//! position the fingers close, the arm lifts the object 10 cm and holds it
//! 1 s. *In position*: the operator stops (it believes it has reached the
//! grasp point, §5.5.2), or the kinematic judge agrees with the gripper
//! within 1 cm of the grasp point (the judge alone agrees as soon as the
//! pads' conservative spheres straddle the box, up to 2 cm above the grasp
//! point, where the real pads would hold a few millimetres of it).
//! **Success** = the object rose ≥ 5 cm and stayed ≥ 5 cm through the
//! hold, and it moved < 2 cm before the fingers closed (the dissertation's
//! "the object has not deviated from its initial position", §5.5.3).
//! Otherwise the reason is a collision (the robot touched an obstacle), a
//! push (the object moved ≥ 2 cm before closing), the kinematic judge's
//! reason when the fingers closed on nothing, a slip (the object did not
//! rise 5 cm) or a drop (it fell during the hold).

/// Physical parameters and the grasp sequence of a physics episode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhysicsSettings {
    /// Largest physics step (s; default 0.002, 500 Hz). The step used is
    /// the control period divided into whole steps no longer than this.
    pub max_timestep: f64,
    /// Density of the movable objects (kg/m³; default 500: the 6 × 6 × 12
    /// cm box weighs 216 g).
    pub object_density: f64,
    /// Sliding friction coefficient of every contact (default 1, MuJoCo's).
    pub friction: f64,
    /// How long the fingers close before the lift (s; default 0.5).
    pub close_time: f64,
    /// How far the arm lifts (m; default 0.10) ...
    pub lift_height: f64,
    /// ... at this speed (m/s; default 0.05).
    pub lift_speed: f64,
    /// How long the lifted object must stay up (s; default 1).
    pub hold_time: f64,
    /// The rise that counts as lifted (m; default 0.05).
    pub lifted: f64,
    /// The largest displacement of the object before the fingers close
    /// (m; default 0.02); more is a push (a collision).
    pub push_tolerance: f64,
}

impl Default for PhysicsSettings {
    fn default() -> Self {
        PhysicsSettings {
            max_timestep: 0.002,
            object_density: 500.0,
            friction: 1.0,
            close_time: 0.5,
            lift_height: 0.10,
            lift_speed: 0.05,
            hold_time: 1.0,
            lifted: 0.05,
            push_tolerance: 0.02,
        }
    }
}

impl PhysicsSettings {
    /// Checks every value is finite and positive, naming the first that is
    /// not.
    ///
    /// # Errors
    /// The field's name and value.
    pub fn validate(&self) -> Result<(), String> {
        let fields = [
            ("max_timestep", self.max_timestep),
            ("object_density", self.object_density),
            ("friction", self.friction),
            ("close_time", self.close_time),
            ("lift_height", self.lift_height),
            ("lift_speed", self.lift_speed),
            ("hold_time", self.hold_time),
            ("lifted", self.lifted),
            ("push_tolerance", self.push_tolerance),
        ];
        match fields.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
            Some((name, v)) => Err(format!("physics setting {name} = {v} must be finite and positive")),
            None => Ok(()),
        }
    }
}
