//! Learned arbitration (the dissertation's chapter 6): a policy that maps the
//! arbitration state `s_t = {x, a_H, a_1^R … a_G^R, b_1 … b_G}` (§6.4) to the
//! arbitrated gripper velocity, run inside [`Arbiter::tick`](super::Arbiter::tick) as
//! [`ArbitrationMode::Learned`](super::ArbitrationMode::Learned) under the
//! same hard constraints as every mode.
//!
//! The state is laid out by [`StateLayout`] in the task plane or space
//! (`task_dims` = 2 for the planar task's x–y, 3 for an arm), in
//! normalised units (positions over `length_scale`, velocities over
//! `speed_scale`):
//!
//! ```text
//! [ gripper position (d) | goal − gripper, per goal (G·d)
//! | distance to the nearest obstacle (1) and the unit direction toward it (d)
//! | robot action as gripper velocity J a_g^R, per goal (G·d) | beliefs (G) | operator's command (d) ]
//! ```
//!
//! The operator's command comes last: the dissertation's networks route
//! everything before it through a shared "head" and join the command after it.
//! [`Arbiter::observe`](super::Arbiter::observe) computes the state
//! without acting and [`Arbiter::act_observed`](super::Arbiter::act_observed)
//! executes a given command under the hard constraints — the two halves a
//! learner (DDPG, a Gymnasium environment) needs between them.
//!
//! ```
//! use tandem::arbitration::StateLayout;
//! let planar = StateLayout::planar(2);
//! assert_eq!(planar.width(), 17); // the dissertation's 17-dimensional input (§6.5)
//! assert_eq!(planar.human_offset(), 15);
//! ```

/// Where each part of the arbitration state sits, and its units.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StateLayout {
    /// Task dimensions `d` of positions, commands and actions: 2 (x, y of
    /// the world; a planar task) or 3.
    pub task_dims: usize,
    /// Number of goals `G`.
    pub goals: usize,
    /// Positions and distances are divided by this (m; default 0.1).
    pub length_scale: f64,
    /// Velocities are divided by this (m/s; default 0.05, the simulated
    /// users' speed).
    pub speed_scale: f64,
}

impl StateLayout {
    /// The planar task's layout with `goals` goals.
    pub fn planar(goals: usize) -> StateLayout {
        StateLayout { task_dims: 2, goals, length_scale: 0.1, speed_scale: 0.05 }
    }

    /// Width of the whole state.
    pub fn width(&self) -> usize {
        self.belief_offset() + self.goals + self.task_dims
    }

    /// Index of the distance to the nearest obstacle (the direction follows).
    pub fn obstacle_offset(&self) -> usize {
        self.task_dims * (1 + self.goals)
    }

    /// Index of the operator's command (the last `task_dims` values).
    pub fn human_offset(&self) -> usize {
        self.width() - self.task_dims
    }

    /// Index of goal `g`'s robot action.
    pub fn action_offset(&self, g: usize) -> usize {
        self.obstacle_offset() + 1 + self.task_dims * (1 + g)
    }

    /// Index of the beliefs.
    pub fn belief_offset(&self) -> usize {
        self.action_offset(self.goals)
    }

    /// Whether the layout is usable (`task_dims` 2 or 3, positive finite scales).
    pub fn is_valid(&self) -> bool {
        (2..=3).contains(&self.task_dims)
            && self.length_scale.is_finite()
            && self.length_scale > 0.0
            && self.speed_scale.is_finite()
            && self.speed_scale > 0.0
    }
}

/// An arbitration policy: the arbitrated gripper velocity from the
/// arbitration state. Implemented by the trained DDPG actor
/// (`tandem::learn::ArbitrationActor`); any `Send + Sync` policy can be
/// plugged into an [`Arbiter`](super::Arbiter) with
/// [`Arbiter::with_arbitration_policy`](super::Arbiter::with_arbitration_policy).
pub trait ArbitrationPolicy: Send + Sync + std::fmt::Debug {
    /// The state layout it reads.
    fn layout(&self) -> StateLayout;
    /// Scratch values [`ArbitrationPolicy::act`] needs.
    fn scratch_len(&self) -> usize;
    /// Writes the arbitrated command (`layout().task_dims` values,
    /// normalised: multiply by `speed_scale` for m/s) for the normalised
    /// `state`. Must not allocate: it runs every control tick.
    fn act(&self, state: &[f64], scratch: &mut [f32], command: &mut [f64]);
}
