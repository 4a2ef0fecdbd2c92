//! A policy that only keeps away from obstacles: the minimal-assistance
//! robot policy of the dissertation's Fig. 4.2(c).

use crate::collision::{CollisionModel, CollisionWorkspace};
use crate::control::{ControlError, RobotPolicy, RobotPolicyWorkspace};
use std::sync::Arc;

/// `a = gain · Σ (influence − d) ∇d` over the pairs closer than
/// `influence` (m): a push away from everything near, zero elsewhere
/// (rad/s). Its metric is what the robot knows about obstacles alone.
#[derive(Debug, Clone)]
pub struct ObstacleRepulsion {
    model: Arc<CollisionModel>,
    /// Distance below which a pair pushes (m).
    pub influence: f64,
    /// Gain (1/s per m of intrusion).
    pub gain: f64,
}

struct RepulsionState {
    collision: CollisionWorkspace,
    gradient: Vec<f64>,
}

impl ObstacleRepulsion {
    /// A repulsion from every pair of `model` closer than `influence` (m).
    pub fn new(model: Arc<CollisionModel>, influence: f64, gain: f64) -> Self {
        ObstacleRepulsion { model, influence, gain }
    }
}

impl RobotPolicy for ObstacleRepulsion {
    fn dof(&self) -> usize {
        self.model.robot().nq()
    }

    fn new_workspace(&self) -> RobotPolicyWorkspace {
        RobotPolicyWorkspace::new(RepulsionState {
            collision: CollisionWorkspace::new(&self.model),
            gradient: vec![0.0; self.dof()],
        })
    }

    fn act(
        &self,
        state: &mut RobotPolicyWorkspace,
        q: &[f64],
        velocity: &[f64],
        action: &mut [f64],
    ) -> Result<(), ControlError> {
        self.probe(state, q, velocity, action)
    }

    fn probe(
        &self,
        state: &mut RobotPolicyWorkspace,
        q: &[f64],
        _: &[f64],
        action: &mut [f64],
    ) -> Result<(), ControlError> {
        let s = state.get_mut::<RepulsionState>().ok_or(ControlError::ForeignState)?;
        let n = self.dof();
        if action.len() != n {
            return Err(ControlError::WrongLength { what: "action", expected: n, got: action.len() });
        }
        action.fill(0.0);
        let pairs = self
            .model
            .distances(&mut s.collision, q, self.influence)
            .map_err(|_| ControlError::NonFinite { what: "q", index: 0, value: f64::NAN })?
            .len();
        for k in 0..pairs {
            let d = s.collision_distance(k);
            if self.model.distance_gradient(&s.collision, &d, &mut s.gradient).is_ok() {
                let push = self.gain * (self.influence - d.signed.distance);
                for (a, g) in action.iter_mut().zip(&s.gradient) {
                    *a += push * g;
                }
            }
        }
        Ok(())
    }

    fn reset(&self, _: &mut RobotPolicyWorkspace) {}
}

impl RepulsionState {
    fn collision_distance(&self, k: usize) -> crate::collision::PairDistance {
        self.collision.last_distances()[k]
    }
}
