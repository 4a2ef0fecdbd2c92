//! Table 5.1 with MuJoCo under the arm (`--physics mujoco`): each task's
//! world compiled once, every operator × method episode run by
//! [`PhysicsEpisode`](crate::sim::mujoco::PhysicsEpisode), and the
//! kinematic judge's verdict at the moment the fingers closed kept beside
//! the physical outcome, so the two can be compared episode by episode.

use super::{EpisodeSummary, ReachGraspResults};
#[cfg(not(feature = "mujoco"))]
use crate::experiments::ExperimentError;
use crate::sim::{Outcome, PhysicsSettings};
use std::collections::BTreeMap;
use std::fmt::Write;

/// Which simulator moves the arm.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Simulator {
    /// tandem's kinematic simulator: the arm goes where the arbiter says;
    /// success is the grasp judge's.
    #[default]
    Kinematic,
    /// MuJoCo physics (feature `mujoco`): success is the box lifted.
    Mujoco(PhysicsSettings),
}

impl Simulator {
    /// `kinematic` or `mujoco`.
    pub fn name(&self) -> &'static str {
        match self {
            Simulator::Kinematic => "kinematic",
            Simulator::Mujoco(_) => "mujoco",
        }
    }
}

/// What a physics episode adds to its summary (empty in the kinematic
/// simulator).
#[derive(Debug, Clone, Default)]
pub struct PhysicsOutcome {
    /// The kinematic judge's verdict when the fingers began to close
    /// (`None`: they never closed).
    pub kinematic: Option<crate::sim::Reason>,
    /// Physics steps run.
    pub steps: usize,
    /// Wall-clock time in MuJoCo's steps (s).
    pub seconds: f64,
}

/// Physics steps and the seconds in them, summed over `episodes`.
pub(super) fn physics_totals(episodes: &[super::EpisodeSummary]) -> (usize, f64) {
    episodes.iter().fold((0, 0.0), |(n, t), e| (n + e.physics.steps, t + e.physics.seconds))
}

#[cfg(feature = "mujoco")]
pub(super) use runner::Runner;

#[cfg(feature = "mujoco")]
mod runner {
    use super::PhysicsOutcome;
    use crate::arbitration::{Arbiter, ArbiterWorkspace};
    use crate::experiments::ExperimentError;
    use crate::sim::mujoco::{PhysicsEpisode, PhysicsScene, PhysicsWorkspace, lift_arbiter};
    use crate::sim::{Episode, EpisodeRecord, Operator, PhysicsSettings, Task, TaskJudge};

    /// One task's world in MuJoCo and the per-thread state to run it.
    pub(in crate::experiments::reach_grasp) struct Runner {
        scene: PhysicsScene,
        lift: Arbiter,
        workspace: PhysicsWorkspace,
        settings: PhysicsSettings,
    }

    impl Runner {
        pub(in crate::experiments::reach_grasp) fn new(
            task: &Task,
            arbiter: &Arbiter,
            settings: &PhysicsSettings,
        ) -> Result<Runner, ExperimentError> {
            let problem = &task.goal.problem;
            let scene = PhysicsScene::new(problem, arbiter.settings().period, settings)
                .map_err(|e| ExperimentError::Physics(e.to_string()))?;
            let lift = lift_arbiter(arbiter)?;
            let workspace = PhysicsWorkspace::new(&scene, &lift);
            Ok(Runner { scene, lift, workspace, settings: *settings })
        }

        /// Runs `episode` with physics; the object is the task's box.
        pub(in crate::experiments::reach_grasp) fn run(
            &mut self,
            episode: &Episode<'_>,
            ws: &mut ArbiterWorkspace,
            operator: &mut dyn Operator,
            judge: &mut TaskJudge,
        ) -> Result<(EpisodeRecord, PhysicsOutcome), ExperimentError> {
            let object = self.scene.object_names().iter().position(|n| n == "box").unwrap_or(0);
            let physical = PhysicsEpisode {
                scene: &self.scene,
                arbiter: episode.arbiter,
                lift: &self.lift,
                start: episode.start,
                target: episode.target,
                true_goal: episode.true_goal,
                object,
                settings: episode.settings,
                physics: self.settings,
            };
            let r = physical
                .run(ws, &mut self.workspace, operator, judge)
                .map_err(|e| ExperimentError::Physics(e.to_string()))?;
            Ok((
                r.record,
                PhysicsOutcome { kinematic: r.kinematic, steps: r.physics_steps, seconds: r.physics_seconds },
            ))
        }
    }
}

/// Without the `mujoco` feature there is nothing to run physics with.
#[cfg(not(feature = "mujoco"))]
pub(super) enum Runner {}

#[cfg(not(feature = "mujoco"))]
impl Runner {
    pub(super) fn new(
        _: &crate::sim::Task,
        _: &crate::arbitration::Arbiter,
        _: &PhysicsSettings,
    ) -> Result<Runner, ExperimentError> {
        Err(ExperimentError::Physics(
            "this tandem was built without MuJoCo: build with `--features mujoco` (see docs/physics.md)".into(),
        ))
    }

    pub(super) fn run(
        &mut self,
        _: &crate::sim::Episode<'_>,
        _: &mut crate::arbitration::ArbiterWorkspace,
        _: &mut dyn crate::sim::Operator,
        _: &mut crate::sim::TaskJudge,
    ) -> Result<(crate::sim::EpisodeRecord, PhysicsOutcome), ExperimentError> {
        match *self {}
    }
}

/// How the kinematic judge's verdict (at the moment the fingers closed)
/// and physics agree, over some episodes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Agreement {
    /// Both say success.
    pub both: usize,
    /// The kinematic judge says success, physics did not lift the box:
    /// by physical reason.
    pub kinematic_only: BTreeMap<&'static str, usize>,
    /// Physics lifted the box where the kinematic judge said no: by the
    /// judge's reason.
    pub physics_only: BTreeMap<&'static str, usize>,
    /// Neither.
    pub neither: usize,
    /// The fingers never closed (collision, push or timeout on the way).
    pub never_closed: usize,
}

impl Agreement {
    /// Over `episodes`.
    pub fn of<'a>(episodes: impl Iterator<Item = &'a EpisodeSummary>) -> Agreement {
        let mut a = Agreement::default();
        for e in episodes {
            let physics = e.outcome == Outcome::Success;
            match &e.physics.kinematic {
                None => a.never_closed += 1,
                Some(k) => match (k.outcome() == Outcome::Success, physics) {
                    (true, true) => a.both += 1,
                    (true, false) => *a.kinematic_only.entry(e.reason.as_str()).or_default() += 1,
                    (false, true) => *a.physics_only.entry(k.as_str()).or_default() += 1,
                    (false, false) => a.neither += 1,
                },
            }
        }
        a
    }

    /// As JSON.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "both": self.both, "kinematic_only": self.kinematic_only, "physics_only": self.physics_only,
            "neither": self.neither, "never_closed": self.never_closed,
        })
    }
}

/// The physics block under the table: where the kinematic judge and
/// physics disagree, per method, and the simulation's throughput.
pub(super) fn table(r: &ReachGraspResults) -> String {
    let s = &r.settings;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "\nsucc: the box lifted >= 5 cm and held 1 s, moved < 2 cm before the fingers closed (MuJoCo)\n\
         kinematic judge at the moment the fingers closed vs physics, all operators and arms:"
    );
    let list = |m: &BTreeMap<&str, usize>| {
        if m.is_empty() {
            "0".to_string()
        } else {
            m.iter().map(|(k, n)| format!("{k} {n}")).collect::<Vec<_>>().join(", ")
        }
    };
    for (m, method) in s.methods.iter().enumerate() {
        let a = Agreement::of(r.episodes.iter().filter(|e| e.method == m));
        let _ = writeln!(
            out,
            "  {:<24}both succeed {}, judge only: {}; physics only: {}; neither {}; never closed {}",
            method.name(),
            a.both,
            list(&a.kinematic_only),
            list(&a.physics_only),
            a.neither,
            a.never_closed
        );
    }
    let (steps, seconds) = physics_totals(&r.episodes);
    let _ = writeln!(
        out,
        "physics: {} steps, {:.0} steps/s in MuJoCo's step, {:.1} episodes/s on the wall clock",
        steps,
        steps as f64 / seconds.max(1e-9),
        r.episodes.len() as f64 / r.wall_seconds.max(1e-9)
    );
    out
}
