//! The learning reward of the arbitration environment: the dissertation's
//! Algorithm 5 (agreement with the user at decision points, with the true
//! goal's sub-policy elsewhere, at the user's speed) plus the environment
//! reward.

use crate::arbitration::StateLayout;
use crate::arbitration::decision::{DecisionSettings, planar_modality, spatial_modality};

/// Which reward trains the arbiter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RewardKind {
    /// `r_agree + r_env` (Algorithm 5).
    Combined,
    /// `r_env` only (the dissertation's comparison).
    Environment,
}

impl RewardKind {
    /// `combined` or `environment`.
    pub fn as_str(&self) -> &'static str {
        match self {
            RewardKind::Combined => "combined",
            RewardKind::Environment => "environment",
        }
    }
}

/// Algorithm 5: the reward of taking `action` (units of the user speed) in
/// `state` (of `layout`) when the user meant goal `true_goal`, given the
/// step's environment reward. At a decision point (the sub-policies' von
/// Mises mixture multimodal) the agreement term is `−‖â_H − û‖²`, else
/// `−‖â_{g*} − û‖²` (hats: unit directions, as the dissertation normalises the
/// actions); both minus the speed difference `|‖a_H‖ − ‖u‖|` (units of the
/// user speed).
pub fn reward(
    layout: &StateLayout,
    state: &[f64],
    action: &[f64],
    true_goal: usize,
    env_reward: f64,
    kind: RewardKind,
    decision: &DecisionSettings,
) -> f64 {
    if kind == RewardKind::Environment {
        return env_reward;
    }
    let d = layout.task_dims.min(3);
    let vector = |at: usize| {
        let mut v = [0.0; 3];
        v[..d].copy_from_slice(&state[at..at + d]);
        v
    };
    let human = vector(layout.human_offset());
    let goals = layout.goals.min(8);
    let mut actions = [[0.0; 3]; 8];
    for (g, a) in actions.iter_mut().enumerate().take(goals) {
        // In m/s for the mixture's speed floor.
        *a = vector(layout.action_offset(g)).map(|x| x * layout.speed_scale);
    }
    let beliefs = &state[layout.belief_offset()..layout.belief_offset() + goals];
    let multimodal = if d == 2 {
        let planar: [[f64; 2]; 8] = actions.map(|a| [a[0], a[1]]);
        planar_modality(&planar[..goals], beliefs, decision).multimodal
    } else {
        spatial_modality(&actions[..goals], beliefs, decision).multimodal
    };
    let mut u = [0.0; 3];
    u[..d].copy_from_slice(&action[..d]);
    let toward = if multimodal { human } else { vector(layout.action_offset(true_goal.min(goals.saturating_sub(1)))) };
    let unit = |v: [f64; 3]| {
        let n = norm(v);
        if n > 1e-9 { v.map(|x| x / n) } else { [0.0; 3] }
    };
    let (a, b) = (unit(toward), unit(u));
    let agree = -(0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>();
    let speed = -(norm(human) - norm(u)).abs();
    agree + speed + env_reward
}

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}
