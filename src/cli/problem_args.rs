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
    #[command(flatten)]
    /// Point clouds added to the problem's scene.
    pub clouds: PointCloudArgs,
}

impl ProblemArgs {
    /// Loads the problem these arguments name.
    ///
    /// # Errors
    /// Any loading error, naming the file, key and line.
    pub fn load(&self) -> Result<Problem, Box<dyn std::error::Error>> {
        if let Some(problem) = self.moveit.load() {
            let mut problem = problem?;
            self.clouds.add_to(&mut problem.scene)?;
            return Ok(problem);
        }
        let path = self.problem.as_deref().ok_or("give a problem file, or --urdf --srdf --scene --request")?;
        load(path, &self.clouds)
    }
}

/// The problem file or `builtin:NAME` at `path`, with `clouds` added to
/// its scene.
///
/// # Errors
/// Any loading error, naming the file, key and line.
pub(super) fn load(path: &std::path::Path, clouds: &PointCloudArgs) -> Result<Problem, Box<dyn std::error::Error>> {
    let mut problem = match path.to_str().and_then(|p| p.strip_prefix("builtin:")) {
        Some(name) => Problem::builtin(name)?,
        None => Problem::from_file(path)?,
    };
    clouds.add_to(&mut problem.scene)?;
    Ok(problem)
}

/// `--point-cloud FILE` (repeatable) and `--point-radius M`: what a depth
/// camera saw, as obstacles beside the problem's own.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct PointCloudArgs {
    /// A point cloud (PLY or PCD; points in the robot's root frame, m)
    /// whose points become obstacles: balls of --point-radius, named after
    /// the file. Repeatable; with or without the problem's own obstacles.
    #[arg(long = "point-cloud", value_name = "FILE")]
    pub point_clouds: Vec<PathBuf>,
    /// Radius of every point's ball (m): at least the sensor's noise, and
    /// the spacing of the points if the check is to cover the surfaces
    /// between them (see docs/point_clouds.md).
    #[arg(long, value_name = "M", default_value_t = 0.01, value_parser = |s: &str| super::number_in(s, 1e-6..=1.0))]
    pub point_radius: f64,
}

impl PointCloudArgs {
    /// Adds each cloud to `scene` as an obstacle named after its file
    /// (its stem, made unique).
    ///
    /// # Errors
    /// A file that cannot be read (naming it and the line or point).
    pub fn add_to(&self, scene: &mut crate::scene::Scene) -> Result<(), Box<dyn std::error::Error>> {
        for path in &self.point_clouds {
            let cloud = crate::point_cloud::PointCloud::read(path)?;
            let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("point_cloud").to_string();
            let taken = |n: &str| scene.obstacle(n).is_some() || scene.object(n).is_some();
            let name = (1..).map(|k| if k == 1 { stem.clone() } else { format!("{stem}_{k}") }).find(|n| !taken(n));
            let name = name.unwrap_or(stem);
            let identity = nalgebra::IsometryMatrix3::identity();
            scene.add_obstacle(crate::scene::Obstacle::point_cloud(name, &cloud, self.point_radius, identity)?)?;
        }
        Ok(())
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
