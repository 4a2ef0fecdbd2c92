//! The interface the arbiter queries: a goal-conditioned robot policy
//! `π_R(q)` answering at any configuration, with a per-caller workspace.

use super::{ControlError, PolicyWorkspace, TrackingPolicy};
use std::any::Any;
use std::fmt;

/// Per-caller workspace of a [`RobotPolicy`] (progress along a reference,
/// scratch buffers, …), made once by [`RobotPolicy::new_workspace`] and
/// reused every tick; it holds the policy's own workspace type.
pub struct RobotPolicyWorkspace(Box<dyn Any + Send>);

impl RobotPolicyWorkspace {
    /// Wraps a policy's own workspace type.
    pub fn new<T: Any + Send>(workspace: T) -> Self {
        RobotPolicyWorkspace(Box::new(workspace))
    }

    /// The policy's own workspace, if it has type `T`.
    pub fn get_mut<T: Any>(&mut self) -> Option<&mut T> {
        self.0.downcast_mut()
    }
}

impl fmt::Debug for RobotPolicyWorkspace {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("RobotPolicyWorkspace")
    }
}

/// A robot policy conditioned on one goal: the joint velocity (rad/s or m/s)
/// it commands at any configuration. Implemented by [`TrackingPolicy`]; a
/// learned policy can stand in its place. Queries allocate nothing.
pub trait RobotPolicy: Send + Sync + fmt::Debug {
    /// Number of joints.
    fn dof(&self) -> usize;

    /// A fresh per-caller workspace.
    fn new_workspace(&self) -> RobotPolicyWorkspace;

    /// The action at `q` with current joint velocity `velocity`, written to
    /// `action`; advances the state (e.g. progress along a reference).
    ///
    /// # Errors
    /// Wrong lengths or non-finite inputs, a state made by another policy type.
    fn act(
        &self,
        state: &mut RobotPolicyWorkspace,
        q: &[f64],
        velocity: &[f64],
        action: &mut [f64],
    ) -> Result<(), ControlError>;

    /// The action at `q` *without* advancing the state: a probe near the
    /// last [`RobotPolicy::act`] configuration, for finite differences.
    ///
    /// # Errors
    /// As [`RobotPolicy::act`].
    fn probe(
        &self,
        state: &mut RobotPolicyWorkspace,
        q: &[f64],
        velocity: &[f64],
        action: &mut [f64],
    ) -> Result<(), ControlError>;

    /// Forgets what the state learned (a new episode).
    fn reset(&self, state: &mut RobotPolicyWorkspace);
}

impl TrackingPolicy {
    fn tracking_state<'s>(&self, state: &'s mut RobotPolicyWorkspace) -> Result<&'s mut PolicyWorkspace, ControlError> {
        state.get_mut::<PolicyWorkspace>().ok_or(ControlError::ForeignState)
    }
}

impl RobotPolicy for TrackingPolicy {
    fn dof(&self) -> usize {
        self.reference().dof()
    }

    fn new_workspace(&self) -> RobotPolicyWorkspace {
        RobotPolicyWorkspace::new(self.workspace())
    }

    fn act(
        &self,
        state: &mut RobotPolicyWorkspace,
        q: &[f64],
        velocity: &[f64],
        action: &mut [f64],
    ) -> Result<(), ControlError> {
        let ws = self.tracking_state(state)?;
        self.query(ws, q, Some(velocity), action).map(|_| ())
    }

    fn probe(
        &self,
        state: &mut RobotPolicyWorkspace,
        q: &[f64],
        velocity: &[f64],
        action: &mut [f64],
    ) -> Result<(), ControlError> {
        let ws = self.tracking_state(state)?;
        TrackingPolicy::probe(self, ws, q, Some(velocity), action).map(|_| ())
    }

    fn reset(&self, state: &mut RobotPolicyWorkspace) {
        if let Ok(ws) = self.tracking_state(state) {
            ws.reset();
        }
    }
}
