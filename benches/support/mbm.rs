//! Shared by the MotionBenchMaker benches: the problem set, unpacking, and
//! the percentile table.

use nalgebra::IsometryMatrix3;
use std::path::{Path, PathBuf};
use std::process::Command;
use tandem::plan::ProblemPlanner;
use tandem::point_cloud::{FilterSettings, PointCloud};
use tandem::problem::Problem;
use tandem::scene::{Obstacle, Scene};

pub const FAMILIES: [&str; 7] =
    ["bookshelf_small", "bookshelf_tall", "bookshelf_thin", "box", "cage", "table_pick", "table_under_pick"];

/// The unpacked benchmark: the spherized Panda, its SRDF and the problems.
pub struct Benchmark {
    urdf: PathBuf,
    srdf: PathBuf,
    problems: PathBuf,
    /// The problem folders' suffix after the family (`_panda`).
    robot: String,
}

impl Benchmark {
    /// Unpacks `problems/motionbenchmaker/panda_problems.tar.bz2` (all 700
    /// problems, vendored) into a temporary folder.
    pub fn unpack() -> Benchmark {
        let mbm = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/motionbenchmaker");
        let dir = std::env::temp_dir().join("tandem_mbm");
        std::fs::create_dir_all(&dir).expect("temp dir");
        let tar = Command::new("tar").arg("xjf").arg(mbm.join("panda_problems.tar.bz2")).arg("-C").arg(&dir).status();
        assert!(tar.expect("run tar").success(), "cannot unpack the problems");
        Benchmark {
            urdf: mbm.join("panda_spherized.urdf"),
            srdf: mbm.join("panda.srdf"),
            problems: dir.join("problems"),
            robot: "panda".into(),
        }
    }

    /// Another MotionBenchMaker set: `problems` holds one folder per
    /// family, `<family>_<robot>/{scene,request}NNNN.yaml` (NNNN from 0001),
    /// for the robot of `urdf` and `srdf`.
    #[allow(dead_code)] // only the Panda bench takes other sets
    pub fn from_set(urdf: &Path, srdf: &Path, problems: &Path, robot: &str) -> Benchmark {
        let (urdf, srdf, problems) = (urdf.to_path_buf(), srdf.to_path_buf(), problems.to_path_buf());
        Benchmark { urdf, srdf, problems, robot: robot.into() }
    }

    /// The set's families and their number of problems, by name.
    #[allow(dead_code)] // only the Panda bench takes other sets
    pub fn families(&self) -> Vec<(String, usize)> {
        let suffix = format!("_{}", self.robot);
        let entries = std::fs::read_dir(&self.problems).expect("the problem folder");
        let mut families: Vec<(String, usize)> = entries
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter_map(|name| Some(name.strip_suffix(&suffix)?.to_string()))
            .map(|family| {
                let count = (1..).take_while(|&k| self.file(&family, "scene", k).exists()).count();
                (family, count)
            })
            .collect();
        families.sort();
        families
    }

    fn file(&self, family: &str, kind: &str, k: usize) -> PathBuf {
        self.problems.join(format!("{family}_{}", self.robot)).join(format!("{kind}{k:04}.yaml"))
    }

    /// Problem `k` (1-based) of `family`, or why it does not load.
    pub fn load(&self, family: &str, k: usize) -> Result<Problem, String> {
        let at = |kind: &str| self.file(family, kind, k);
        Problem::from_moveit(&self.urdf, &self.srdf, &at("scene"), &at("request")).map_err(|e| e.to_string())
    }

    /// Problem `k` (1-based) of `family`, which must load.
    #[allow(dead_code)] // the Panda bench takes other sets, which may not
    pub fn problem(&self, family: &str, k: usize) -> Problem {
        self.load(family, k).expect("valid problem")
    }
}

/// The number after `name` on the command line (`--seeds 3`), if any.
pub fn option(args: &[String], name: &str) -> Option<f64> {
    text(args, name).and_then(|v| v.parse().ok())
}

/// The word after `name` on the command line (`--set DIR`), if any.
pub fn text<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).map(String::as_str)
}

/// Whether this run is the full benchmark (`cargo bench`) rather than the
/// smoke run `cargo test --all-targets` makes of bench targets.
pub fn full_run() -> bool {
    std::env::args().any(|a| a == "--bench")
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

/// Prints a `| label | median | mean | p95 |` row (times in s, shown in ms)
/// and returns it as JSON.
pub fn row(label: &str, times: &mut [f64]) -> serde_json::Value {
    if times.is_empty() {
        println!("| {label} | – | – | – |");
        return serde_json::Value::Null;
    }
    times.sort_by(f64::total_cmp);
    let ms = |s: f64| s * 1e3;
    let (median, mean, p95) =
        (percentile(times, 0.5), times.iter().sum::<f64>() / times.len() as f64, percentile(times, 0.95));
    println!("| {label} | {:.2} ms | {:.2} ms | {:.2} ms |", ms(median), ms(mean), ms(p95));
    serde_json::json!({"median_ms": ms(median), "mean_ms": ms(mean), "p95_ms": ms(p95)})
}

/// `--plain`: RRT-Connect as before balancing, dynamic-domain sampling and
/// the root bias (step 0.5 rad, trees alternating, every sample used and
/// uniform), for comparison.
#[allow(dead_code)] // not every bench compares with the plain planner
pub fn make_plain(planner: &mut ProblemPlanner) {
    let settings = planner.search_settings_mut();
    settings.step = 0.5;
    settings.dynamic_domain = None;
    settings.root_bias = None;
    settings.balance = false;
}

/// Median and mean of `values` (sorted in place); NaN and 0 when empty.
#[allow(dead_code)] // not every bench reports it
pub fn median_mean(values: &mut [f64]) -> (f64, f64) {
    values.sort_by(f64::total_cmp);
    let median = values.get(values.len() / 2).copied().unwrap_or(f64::NAN);
    (median, values.iter().sum::<f64>() / values.len().max(1) as f64)
}

/// `--clouds DIR`: scenes from files of points, filtered and built as a
/// robot that sees its world would (see the motionbenchmaker bench).
#[allow(dead_code)] // only the Panda bench reads clouds
pub struct CloudPipeline {
    dir: PathBuf,
    /// Balls' radius as the sensor's points are (m), before the filter's margin.
    point_radius: f64,
    /// The crop, range window and minimum-distance filter.
    filter: FilterSettings,
    /// Whether the balls leave out the filter's margin (`--no-margin`).
    no_margin: bool,
}

#[allow(dead_code)] // only the Panda bench reads clouds
impl CloudPipeline {
    /// The pipeline `--clouds DIR [--point-radius R] [--filter SPACING]
    /// [--cull REACH] [--no-margin]` asks for, if any.
    pub fn from_args(args: &[String]) -> Option<CloudPipeline> {
        let dir = PathBuf::from(text(args, "--clouds")?);
        let point_radius = option(args, "--point-radius").unwrap_or(0.0025);
        let spacing = option(args, "--filter").unwrap_or(0.02);
        let reach = option(args, "--cull").unwrap_or(1.19);
        let cull = reach > 0.0;
        let filter = FilterSettings {
            crop: cull.then_some(([-reach; 3], [reach; 3])),
            sensor: [0.0; 3],
            range: cull.then_some((0.0, reach)),
            spacing,
        };
        filter.validate().expect("filter settings");
        assert!(point_radius.is_finite() && point_radius > 0.0, "--point-radius must be positive");
        Some(CloudPipeline { dir, point_radius, filter, no_margin: args.iter().any(|a| a == "--no-margin") })
    }

    /// The points of problem `k` of `family`, if its file is there.
    pub fn read(&self, family: &str, k: usize) -> Option<PointCloud> {
        let path = self.dir.join(family).join(format!("{k:04}.ply"));
        path.exists().then(|| PointCloud::read(&path).unwrap_or_else(|e| panic!("{e}")))
    }

    /// The points the filter keeps (the timed step "filter").
    pub fn filter(&self, cloud: &PointCloud) -> PointCloud {
        cloud.filtered(&self.filter).expect("validated settings").0
    }

    /// The balls' radius (m): the point radius plus, unless `--no-margin`,
    /// what the filter asks for the kept points to stand for the removed
    /// ones (its `radius_margin`, the spacing).
    pub fn radius(&self) -> f64 {
        self.point_radius + if self.no_margin { 0.0 } else { self.filter.spacing }
    }

    /// `scene` with its obstacles replaced by the balls at `kept` (objects
    /// kept; contacts allowed with an obstacle allowed with the cloud).
    pub fn scene(&self, scene: &Scene, kept: &PointCloud) -> Scene {
        let name = "camera";
        let cloud = Obstacle::point_cloud(name, kept, self.radius(), IsometryMatrix3::identity()).expect("radius");
        let mut out = Scene::new();
        out.add_obstacle(cloud).expect("the cloud");
        for object in scene.objects() {
            out.add_object(object.clone()).expect("an object of a valid scene");
        }
        for (a, b) in scene.allowed_contacts() {
            let named = |n: &String| if scene.obstacle(n).is_some() { name.to_string() } else { n.clone() };
            out.allow_contact(named(a), named(b));
        }
        out
    }

    /// One line saying the settings.
    pub fn describe(&self) -> String {
        let cull = self.filter.range.map_or("no cull".to_string(), |(_, r)| format!("culled beyond {r} m"));
        let margin = if self.no_margin { ", no margin: certified against the kept points only" } else { "" };
        format!("{cull}, minimum-distance filter at {} m, balls of {} m{margin}", self.filter.spacing, self.radius())
    }

    /// The settings, as JSON.
    pub fn settings_json(&self) -> serde_json::Value {
        serde_json::json!({"dir": self.dir.display().to_string(), "point_radius_m": self.point_radius,
            "filter_spacing_m": self.filter.spacing, "cull_m": self.filter.range.map(|(_, r)| r),
            "ball_radius_m": self.radius(), "margin": !self.no_margin})
    }
}
