//! The planner's settings, one type for the search and for the problem
//! files' `[planner]` table: what RRT-Connect
//! ([`rrt_connect`](crate::plan::rrt_connect)) samples and how, how it
//! checks edges, and its budgets.
//!
//! ```
//! use tandem::problem::{PlannerSettings, RootBias};
//! // One sample in ten aims near the other tree's roots by default:
//! assert_eq!(PlannerSettings::default().root_bias, Some(RootBias { probability: 0.1, spread: 3.0 }));
//! // Plain RRT-Connect: uniform samples, every one used, trees alternating,
//! // edges sampled every 5 mrad.
//! let plain = PlannerSettings {
//!     dynamic_domain: None,
//!     root_bias: None,
//!     balance: false,
//!     clearance: 0.0,
//!     ..PlannerSettings::default()
//! };
//! assert!(plain.validate().is_ok());
//! ```

use crate::settings::{InvalidSetting, check};

/// Settings of RRT-Connect: sampling ([`DynamicDomain`], [`RootBias`],
/// balancing), the edge check, the budgets and the seed.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannerSettings {
    /// Seed of the sampler: the same seed gives the same path.
    pub seed: u64,
    /// Largest joint-space step of one extension (rad, Euclidean norm).
    pub step: f64,
    /// Sampled edge checks (`clearance` 0): the largest joint move between
    /// checked configurations (rad or m).
    pub resolution: f64,
    /// Certified edge checks (m): every configuration of an edge keeps at
    /// least `clearance / 2` from everything; 0 switches to `resolution`.
    /// A problem's planner searches on shapes padded by it and certifies
    /// the path ([`ProblemPlanner`](crate::plan::ProblemPlanner)).
    pub clearance: f64,
    /// Wall-clock budget (s).
    pub time_limit: f64,
    /// Budget of extension rounds.
    pub max_iterations: usize,
    /// Dynamic-domain sampling; `None`: every sample is used.
    pub dynamic_domain: Option<DynamicDomain>,
    /// Samples drawn near the other tree's roots; `None`: every sample is
    /// uniform over the joint limits.
    pub root_bias: Option<RootBias>,
    /// Always grow the smaller tree (else the trees alternate): a goal in
    /// a pocket gets the samples it needs to find its way out.
    pub balance: bool,
}

impl Default for PlannerSettings {
    fn default() -> Self {
        PlannerSettings {
            seed: 0,
            step: 1.0,
            resolution: 0.005,
            clearance: 0.001,
            time_limit: 1.0,
            max_iterations: 100_000,
            dynamic_domain: Some(DynamicDomain::default()),
            root_bias: Some(RootBias::default()),
            balance: true,
        }
    }
}

impl PlannerSettings {
    /// Checks the search's settings: a positive, finite step; a time limit
    /// of at least 0; a dynamic domain with a positive radius, a
    /// non-negative smallest radius and a rate in `[0, 1)`; a root bias
    /// with a chance in `[0, 1)` and a finite, non-negative spread. (The
    /// edge check's resolution or clearance is checked by the check
    /// itself.) A step of 0 would let a tree's connection add the same
    /// node forever within one round.
    ///
    /// # Errors
    /// The first setting out of range.
    pub fn validate(&self) -> Result<(), InvalidSetting> {
        check("step", self.step, self.step.is_finite() && self.step > 0.0, "finite and above 0 (rad or m)")?;
        check("time_limit", self.time_limit, self.time_limit >= 0.0, "at least 0 s")?;
        if let Some(d) = &self.dynamic_domain {
            check("dynamic_domain.radius", d.radius, d.radius > 0.0, "above 0 (rad or m)")?;
            check("dynamic_domain.min_radius", d.min_radius, d.min_radius >= 0.0, "at least 0 (rad or m)")?;
            check("dynamic_domain.rate", d.rate, (0.0..1.0).contains(&d.rate), "in [0, 1)")?;
        }
        if let Some(b) = &self.root_bias {
            let p = b.probability;
            check("root_bias.probability", p, (0.0..1.0).contains(&p), "in [0, 1)")?;
            let spread = b.spread;
            check("root_bias.spread", spread, spread.is_finite() && spread >= 0.0, "finite and at least 0 (rad or m)")?;
        }
        Ok(())
    }
}

/// Dynamic-domain sampling (Yershova et al. 2005, with the adaptive radius
/// of Jaillet et al. 2005): a node whose extension was blocked only takes
/// samples within a radius of it, so samples stop being spent pushing
/// boundary nodes into obstacles and go where the tree can grow. This is
/// what keeps narrow-passage problems (cages, shelves) from the long tail.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DynamicDomain {
    /// Radius a node gets at its first blocked extension (rad or m,
    /// Euclidean) on a robot of [`REFERENCE_JOINTS`](Self::REFERENCE_JOINTS)
    /// joints; a search over `n` joints uses [`radius_for(n)`](Self::radius_for),
    /// this times √(n / 7).
    pub radius: f64,
    /// Smallest radius a node shrinks to.
    pub min_radius: f64,
    /// Relative growth after an extension that advanced, and shrink after
    /// one that was blocked.
    pub rate: f64,
    /// Samples in a row a tree may reject before it takes one whatever its
    /// distance. In many dimensions a small tree whose every node is
    /// blocked (a start or goal in a pocket) would otherwise almost never
    /// accept a uniform sample again.
    pub max_rejections: u32,
}

impl Default for DynamicDomain {
    fn default() -> Self {
        DynamicDomain { radius: 4.0, min_radius: 1.0, rate: 1e-4, max_rejections: 16 }
    }
}

impl DynamicDomain {
    /// Joints of the arm [`radius`](Self::radius) is given for (the Panda's,
    /// on which the default was tuned).
    pub const REFERENCE_JOINTS: usize = 7;

    /// The first radius (rad or m) of a search over `joints` joints:
    /// [`radius`](Self::radius) × √(joints / 7). Distances between random
    /// configurations grow with the square root of the number of joints,
    /// so a fixed radius would reject ever more samples as joints are
    /// added. On the Baxter's two arms (14 joints; `shelf`, 30 problems ×
    /// 3 seeds) the radius of 5.66 rather than 4 took 16 % fewer
    /// instructions at the median; on 6 and 8 joints (UR5, TIAGo) the
    /// change stayed within 4 % either way (docs/notes/planning.md).
    pub fn radius_for(&self, joints: usize) -> f64 {
        self.radius * (joints as f64 / Self::REFERENCE_JOINTS as f64).sqrt()
    }
}

/// Samples drawn near the other tree's roots: with probability
/// [`probability`](Self::probability), a drawn sample is one of the
/// other tree's roots (the start, or a goal) moved by up to
/// [`spread`](Self::spread) in each joint, and the tree extends towards
/// it whatever its dynamic domain says. The domain rejects uniform draws
/// and never these, so they take a larger share of the extension rounds
/// than `probability` where it rejects many (with the default 0.1: 15 %
/// of the rounds of the Panda's `cage`, 22 % of the UR5's `cage` of
/// VAMP's set). A goal deep in a pocket (a grasp
/// in a cage, 1 cm from the bars) lets almost no random step out: from
/// MotionBenchMaker's Panda `cage` goals, 1 % of 1 rad steps in uniform
/// directions are free, 5 % of 0.5 rad ones, while the direction towards
/// the start, roughly where the arm must go, is free for 0.5 rad from 8 of
/// 12 goals. A spread keeps the sample from pointing the same blocked
/// way again. This is goal biasing (LaValle 1998) towards the other tree's
/// roots rather than its newest node; RRT-Connect already extends each
/// tree towards the other's new nodes.
///
/// Measured (docs/notes/planning.md, 2026-11-28): the Panda's 699 solved
/// MotionBenchMaker problems take 9.3 % fewer instructions (seed 0), its
/// planning mean / median went from 2.01–2.07 to 1.86–1.89 and the
/// TIAGo's median from 1.8× to 1.4× the Panda's; the Baxter's median
/// stayed where it was and its mean rose (dual-arm `cage`). A spread of 2 rad did as well on the
/// Panda and better on the TIAGo, but raised the Baxter's median 3.6 %;
/// a chance of 0.05 or 0.2 did worse on the Panda. It slows the UR5's
/// `cage` of VAMP's MotionBenchMaker set (median rounds 626 without it,
/// 1,480 with it), and no variant measured spared that family.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RootBias {
    /// Chance that a drawn sample is near a root (0 to 1; below 1,
    /// or a search could aim at the same blocked root forever).
    pub probability: f64,
    /// Largest move (rad or m) in each joint from the root, uniform,
    /// clamped to the joint limits.
    pub spread: f64,
}

impl Default for RootBias {
    fn default() -> Self {
        RootBias { probability: 0.1, spread: 3.0 }
    }
}
