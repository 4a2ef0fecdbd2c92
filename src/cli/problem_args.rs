//! Where a command's problem comes from: a problem file, a builtin, or
//! MoveIt inputs. Shared by `tandem check` and `tandem plan`.

use crate::problem::Problem;
use std::path::PathBuf;

/// A problem file, `builtin:NAME`, or MoveIt inputs.
#[derive(Debug, Clone, clap::Args)]
pub struct ProblemArgs {
    /// Problem file (TOML, format in problems/README.md), or `builtin:NAME`
    /// for a problem embedded in the binary (panda_reach,
    /// panda_reach_obstacle, panda_grasp_box). Omit it for MoveIt inputs
    /// (--urdf, --srdf, --scene, --request).
    #[arg(required_unless_present = "scene")]
    pub problem: Option<PathBuf>,
    #[command(flatten)]
    /// MoveIt inputs, instead of a problem file.
    pub moveit: MoveItArgs,
}

impl ProblemArgs {
    /// Loads the problem these arguments name.
    ///
    /// # Errors
    /// Any loading error, naming the file, key and line.
    pub fn load(&self) -> Result<Problem, Box<dyn std::error::Error>> {
        if let Some(problem) = self.moveit.load() {
            return Ok(problem?);
        }
        let path = self.problem.as_deref().ok_or("give a problem file, or --urdf --srdf --scene --request")?;
        match path.to_str().and_then(|p| p.strip_prefix("builtin:")) {
            Some(name) => Ok(Problem::builtin(name)?),
            None => Ok(Problem::from_file(path)?),
        }
    }
}

/// MoveIt inputs (the MotionBenchMaker format): robot URDF + SRDF, a
/// planning scene YAML and a motion plan request YAML.
#[derive(Debug, Clone, clap::Args)]
pub struct MoveItArgs {
    /// Robot URDF (with --srdf, --scene, --request).
    #[arg(long, requires_all = ["srdf", "scene", "request"], conflicts_with = "problem")]
    pub urdf: Option<PathBuf>,
    /// Robot SRDF: planning groups and disabled collision pairs.
    #[arg(long, requires = "urdf")]
    pub srdf: Option<PathBuf>,
    /// MoveIt planning scene YAML (collision objects: box, cylinder, sphere).
    #[arg(long, requires = "urdf")]
    pub scene: Option<PathBuf>,
    /// MoveIt motion plan request YAML (group, start state, joint goal).
    #[arg(long, requires = "urdf")]
    pub request: Option<PathBuf>,
}

impl MoveItArgs {
    /// The problem these inputs describe, when given.
    pub fn load(&self) -> Option<Result<Problem, crate::problem::ProblemError>> {
        match (&self.urdf, &self.srdf, &self.scene, &self.request) {
            (Some(u), Some(s), Some(sc), Some(r)) => Some(Problem::from_moveit(u, s, sc, r)),
            _ => None,
        }
    }
}
