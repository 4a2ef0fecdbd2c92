//! The node's eyes: a `PointCloud2` or depth `Image` topic becomes the
//! scene's point cloud while the node runs, without the control loop ever
//! touching a camera's bytes.
//!
//! A worker thread owns the camera's readers. For each new message it
//! reads the points ([`super::sensing`]), places them by the sensor's pose,
//! crops them to the workspace and the sensor's range, thins them
//! (minimum-distance filter), removes the arm's own body at the latest
//! measured configuration (the self-filter), builds the collision model of
//! the scene with the cloud and the arbiter's hard-constraint rows for it,
//! and hands both to the loop, which swaps them in between two ticks
//! ([`ControlLoop::swap_collision`](super::ControlLoop::swap_collision):
//! no allocation, the beliefs and the motion carry over). The old model
//! goes back to the worker to be freed there.
//!
//! Goals re-planned from poses while a cloud is in the scene are planned
//! around it, and their arbiter keeps it.

use super::messages::{CameraInfo, Image, PointCloud2};
use super::sensing::{cloud_points, depth_points};
use crate::arbitration::{Arbiter, SafetyRows};
use crate::collision::CollisionWorkspace;
use crate::point_cloud::{DepthProjection, FilterSettings, PointCloud};
use crate::problem::moveit_yaml::Node;
use crate::problem::{Problem, ProblemError};
use crate::scene::Obstacle;
use nalgebra::{IsometryMatrix3, Rotation3, Translation3};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, SyncSender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// What the node does when the point cloud in the scene is older than
/// [`CameraSettings::max_age`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StaleCloud {
    /// Holds the arm (status [`POINT_CLOUD_STALE`](super::POINT_CLOUD_STALE))
    /// until a new cloud arrives: the arm does not move past what it has
    /// not seen lately. Also before the first cloud.
    Hold,
    /// Keeps the last cloud as the scene and goes on.
    Keep,
}

/// The camera input of the node (`tandem ros2 --config`): where the
/// points come from and how they become obstacles.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraSettings {
    /// `sensor_msgs/PointCloud2` topic (key `point_cloud_topic`); `None`: off.
    pub point_cloud_topic: Option<String>,
    /// Depth `sensor_msgs/Image` topic (`depth_image_topic`; 32FC1 m or
    /// 16UC1 mm); `None`: off. Not together with a point cloud topic.
    pub depth_image_topic: Option<String>,
    /// The depth camera's `sensor_msgs/CameraInfo` (`camera_info_topic`).
    pub camera_info_topic: String,
    /// The depth image is rectified (`depth_image_rectified`): P's
    /// intrinsics, no distortion; else K and plumb_bob D.
    pub depth_rectified: bool,
    /// Every n-th pixel of every n-th row (`depth_image_stride`, 1–16).
    pub depth_stride: usize,
    /// Pose in the robot's root frame of the frame the points are given in
    /// (`sensor_position` m, `sensor_rpy` rad, roll-pitch-yaw about fixed
    /// x, y, z): for a depth image its optical frame (z forward, x right, y
    /// down); identity by default (points already in the root frame).
    pub sensor_pose: IsometryMatrix3<f64>,
    /// Radius of every point's ball (m, `point_radius`; 0.0001–0.5,
    /// default 0.01): at least the sensor's noise.
    pub point_radius: f64,
    /// The minimum-distance filter's spacing (m, `point_cloud_spacing`;
    /// 0–0.2, default 0.01): the balls grow by it (docs/point_clouds.md).
    pub spacing: f64,
    /// Distances from the sensor kept (m, `point_cloud_range: [near,
    /// far]`; default 0.05 to 10).
    pub range: (f64, f64),
    /// Root-frame box the points are cropped to (`workspace_min`,
    /// `workspace_max`, m); `None`: no crop.
    pub workspace: Option<([f64; 3], [f64; 3])>,
    /// Points this close to the arm's own shapes at the measured
    /// configuration are removed (m, `self_filter_margin`; default 0.015):
    /// the arm's motion between image and joint state, and the sensor's
    /// noise. Below `point_radius + point_cloud_spacing`, the clearance the
    /// arm keeps from every point: a larger margin would filter the points
    /// of an obstacle the arm has come close to as the arm's own, and the
    /// arm would creep into it cloud by cloud.
    pub self_filter_margin: f64,
    /// A cloud older than this is stale (s, `point_cloud_max_age`;
    /// 0.01–60, default 0.5), counted from its arrival.
    pub max_age: f64,
    /// What a stale cloud does (`point_cloud_stale`: `hold`, the default,
    /// or `keep`).
    pub stale: StaleCloud,
}

impl Default for CameraSettings {
    fn default() -> Self {
        CameraSettings {
            point_cloud_topic: None,
            depth_image_topic: None,
            camera_info_topic: "/camera/depth/camera_info".into(),
            depth_rectified: false,
            depth_stride: 1,
            sensor_pose: IsometryMatrix3::identity(),
            point_radius: 0.01,
            spacing: 0.01,
            range: (0.05, 10.0),
            workspace: None,
            self_filter_margin: 0.015,
            max_age: 0.5,
            stale: StaleCloud::Hold,
        }
    }
}

/// The settings file's keys for the camera.
pub(super) const CAMERA_KEYS: [&str; 15] = [
    "point_cloud_topic",
    "depth_image_topic",
    "camera_info_topic",
    "depth_image_rectified",
    "depth_image_stride",
    "sensor_position",
    "sensor_rpy",
    "point_radius",
    "point_cloud_spacing",
    "point_cloud_range",
    "workspace_min",
    "workspace_max",
    "self_filter_margin",
    "point_cloud_max_age",
    "point_cloud_stale",
];

impl CameraSettings {
    /// Whether a camera topic is configured.
    pub fn enabled(&self) -> bool {
        self.point_cloud_topic.is_some() || self.depth_image_topic.is_some()
    }

    /// The cloud's age (s) past which the loop holds; `None` when it never does.
    pub fn hold_after(&self) -> Option<f64> {
        (self.enabled() && self.stale == StaleCloud::Hold).then_some(self.max_age)
    }

    /// Reads the camera's keys of the node's parameters.
    pub(super) fn read(
        params: &Node<'_>,
        topic: impl Fn(&Node<'_>) -> Result<String, ProblemError>,
    ) -> Result<CameraSettings, ProblemError> {
        let mut s = CameraSettings::default();
        let present = |key: &str| Some(params.get(key)).filter(|n| !n.is_absent());
        if let Some(n) = present("point_cloud_topic") {
            s.point_cloud_topic = Some(topic(&n)?);
        }
        if let Some(n) = present("depth_image_topic") {
            if s.point_cloud_topic.is_some() {
                return Err(n.error("give point_cloud_topic or depth_image_topic, not both"));
            }
            s.depth_image_topic = Some(topic(&n)?);
        }
        if let Some(n) = present("camera_info_topic") {
            s.camera_info_topic = topic(&n)?;
        }
        if let Some(n) = present("depth_image_rectified") {
            s.depth_rectified = n.value.as_bool().ok_or_else(|| n.error("must be true or false"))?;
        }
        let number = |key: &str, range: std::ops::RangeInclusive<f64>, into: &mut f64| -> Result<(), ProblemError> {
            let Some(n) = present(key) else { return Ok(()) };
            let v = n.number()?;
            if !range.contains(&v) {
                return Err(n.error(format!("{v} is outside [{}, {}]", range.start(), range.end())));
            }
            *into = v;
            Ok(())
        };
        let mut stride = s.depth_stride as f64;
        number("depth_image_stride", 1.0..=16.0, &mut stride)?;
        if stride.fract() != 0.0 {
            return Err(params.get("depth_image_stride").error(format!("must be a whole number, got {stride}")));
        }
        s.depth_stride = stride as usize;
        number("point_radius", 1e-4..=0.5, &mut s.point_radius)?;
        number("point_cloud_spacing", 0.0..=0.2, &mut s.spacing)?;
        number("self_filter_margin", 0.0..=0.5, &mut s.self_filter_margin)?;
        if s.self_filter_margin >= s.point_radius + s.spacing {
            let n = params.get("self_filter_margin");
            let n = if n.is_absent() { params.get("point_radius") } else { n };
            return Err(n.error(format!(
                "self_filter_margin {} must be below point_radius + point_cloud_spacing = {} (the clearance the arm \
                 keeps from every point): points of an obstacle the arm comes that close to would be filtered as \
                 the arm's own",
                s.self_filter_margin,
                s.point_radius + s.spacing
            )));
        }
        number("point_cloud_max_age", 0.01..=60.0, &mut s.max_age)?;
        let triple = |key: &str| -> Result<Option<[f64; 3]>, ProblemError> {
            let Some(n) = present(key) else { return Ok(None) };
            let v = n.numbers()?;
            <[f64; 3]>::try_from(v.as_slice())
                .map(Some)
                .map_err(|_| n.error(format!("must be 3 numbers, got {}", v.len())))
        };
        let position = triple("sensor_position")?.unwrap_or([0.0; 3]);
        let [roll, pitch, yaw] = triple("sensor_rpy")?.unwrap_or([0.0; 3]);
        s.sensor_pose = IsometryMatrix3::from_parts(
            Translation3::new(position[0], position[1], position[2]),
            Rotation3::from_euler_angles(roll, pitch, yaw),
        );
        if let Some(n) = present("point_cloud_range") {
            let v = n.numbers()?;
            match v.as_slice() {
                [near, far] if 0.0 <= *near && near < far => s.range = (*near, *far),
                _ => return Err(n.error(format!("must be [near, far] with 0 ≤ near < far (m), got {v:?}"))),
            }
        }
        match (triple("workspace_min")?, triple("workspace_max")?) {
            (None, None) => {}
            (Some(lo), Some(hi)) if (0..3).all(|k| lo[k] < hi[k]) => s.workspace = Some((lo, hi)),
            (Some(lo), Some(hi)) => {
                return Err(params.get("workspace_min").error(format!("{lo:?} is not below workspace_max {hi:?}")));
            }
            _ => return Err(params.get("workspace_min").error("give workspace_min and workspace_max together")),
        }
        if let Some(n) = present("point_cloud_stale") {
            s.stale = match n.text()? {
                "hold" => StaleCloud::Hold,
                "keep" => StaleCloud::Keep,
                other => return Err(n.error(format!("'{other}' is not hold or keep"))),
            };
        }
        Ok(s)
    }

    fn filter(&self) -> FilterSettings {
        let t = self.sensor_pose.translation.vector;
        FilterSettings { crop: self.workspace, sensor: [t.x, t.y, t.z], range: Some(self.range), spacing: self.spacing }
    }
}

/// The scene a new cloud joins: what the goals were planned in, shared by
/// the camera worker and the goal preparation (each locks it briefly, the
/// control loop never).
pub struct SceneState {
    /// The problem of the current goals (objects where their poses put
    /// them), without the cloud.
    pub problem: Problem,
    /// The objects the goals grasp (contacts with them allowed).
    pub targets: Vec<String>,
    /// The current goals' arbiter, with the loop's settings.
    pub arbiter: Arbiter,
    /// Counts the goal updates: a cloud built for older goals is dropped.
    pub generation: u64,
    /// The latest cloud obstacle and when it arrived.
    pub cloud: Option<(Obstacle, Instant)>,
}

/// A new collision model for the loop: its arbiter, the rows it needs and
/// what the filter did.
pub struct CloudUpdate {
    /// The current goals against the scene with the new cloud.
    pub arbiter: Arbiter,
    /// The hard-constraint rows for it (see [`SafetyRows`]).
    pub rows: SafetyRows,
    /// The goal update it was built for ([`SceneState::generation`]).
    pub generation: u64,
    /// When the cloud arrived.
    pub arrived: Instant,
    /// What became of the points.
    pub report: CloudReport,
}

/// What became of one message's points.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CloudReport {
    /// Points in the message (valid ones).
    pub points: usize,
    /// Invalid points (NaN, ∞, missing depth).
    pub invalid: usize,
    /// Cropped or out of range.
    pub cropped: usize,
    /// Removed by the minimum-distance filter.
    pub thinned: usize,
    /// On the arm itself (self-filter).
    pub on_robot: usize,
    /// Kept as obstacles.
    pub kept: usize,
    /// From arrival to the update ready (ms).
    pub build_ms: f64,
}

/// A message the worker could not use, for the loop to log.
pub type CloudRefusal = String;

/// The camera worker's readers.
pub enum CameraReaders {
    /// PointCloud2.
    Cloud(Box<ros2_client::Subscription<PointCloud2>>),
    /// Depth image and camera info.
    Depth(Box<(ros2_client::Subscription<Image>, ros2_client::Subscription<CameraInfo>)>),
}

/// The latest sample of `reader` (older ones skipped); unreadable ones counted.
fn latest<M: 'static + serde::de::DeserializeOwned>(
    reader: &ros2_client::Subscription<M>,
    unreadable: &mut u64,
) -> Option<M> {
    let mut last = None;
    for _ in 0..64 {
        match reader.take() {
            Ok(Some((msg, _))) => last = Some(msg),
            Ok(None) => break,
            Err(_) => *unreadable += 1,
        }
    }
    last
}

/// The loop's end of the camera worker. Dropping it stops the worker.
pub struct CameraLink {
    /// New collision models, or why a message was refused.
    pub updates: Receiver<Result<CloudUpdate, CloudRefusal>>,
    /// What the loop swapped out, to be freed by the worker (bounded and
    /// preallocated: the loop's `try_send` neither blocks nor allocates).
    pub freed: SyncSender<(Arbiter, SafetyRows)>,
    /// The scene shared with the goal preparation.
    pub scene: Arc<Mutex<SceneState>>,
    measured: Arc<Mutex<Option<Vec<f64>>>>,
    stop: Arc<AtomicBool>,
}

impl CameraLink {
    /// Starts the worker on `readers`, for the scene `scene`.
    ///
    /// # Errors
    /// The thread could not be started.
    pub fn start(readers: CameraReaders, settings: CameraSettings, scene: SceneState) -> std::io::Result<CameraLink> {
        // Bounded both ways, so that nothing the loop touches allocates: one
        // update waits for the loop (the worker blocks until it is taken),
        // and the worker drains what comes back every few milliseconds.
        let (updates_tx, updates) = std::sync::mpsc::sync_channel(1);
        let (freed, freed_rx) = std::sync::mpsc::sync_channel(8);
        let scene = Arc::new(Mutex::new(scene));
        let measured = Arc::new(Mutex::new(None));
        let stop = Arc::new(AtomicBool::new(false));
        let (s, m, f) = (scene.clone(), measured.clone(), stop.clone());
        std::thread::Builder::new()
            .name("ros2-camera".into())
            .spawn(move || run_camera(readers, settings, s, m, updates_tx, freed_rx, &f))?;
        Ok(CameraLink { updates, freed, scene, measured, stop })
    }

    /// Shares the loop's measured configuration with the worker (for the
    /// self-filter). Never blocks: skipped while the worker reads it; no
    /// allocation after the first.
    pub fn measured(&self, q: &[f64]) {
        if let Ok(mut shared) = self.measured.try_lock() {
            match shared.as_mut() {
                Some(v) if v.len() == q.len() => v.copy_from_slice(q),
                _ => *shared = Some(q.to_vec()),
            }
        }
    }
}

impl Drop for CameraLink {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
    }
}

/// Runs the camera worker until `stop`: reads `readers`, sends updates
/// (or refusals) to the loop, frees what the loop sends back on `freed`.
/// `measured` is the loop's latest valid joint state (`None` until there
/// is one: without it the arm cannot be filtered out, and clouds wait).
fn run_camera(
    readers: CameraReaders,
    settings: CameraSettings,
    scene: Arc<Mutex<SceneState>>,
    measured: Arc<Mutex<Option<Vec<f64>>>>,
    updates: SyncSender<Result<CloudUpdate, CloudRefusal>>,
    freed: Receiver<(Arbiter, SafetyRows)>,
    stop: &AtomicBool,
) {
    let mut projection: Option<DepthProjection> = None;
    let mut info: Option<CameraInfo> = None;
    let mut unreadable = 0u64;
    let mut pending: Option<(PointCloud, Instant)> = None;
    let filter = settings.filter();
    while !stop.load(Ordering::Relaxed) {
        while freed.try_recv().is_ok() {}
        let mut cloud = PointCloud::default();
        let read = match &readers {
            CameraReaders::Cloud(reader) => latest(reader, &mut unreadable).map(|msg| cloud_points(&msg, &mut cloud)),
            CameraReaders::Depth(depth) => {
                let (images, infos) = &**depth;
                if let Some(i) = latest(infos, &mut unreadable) {
                    info = Some(i);
                }
                match (latest(images, &mut unreadable), &info) {
                    (Some(image), Some(info)) => Some(depth_points(
                        &image,
                        info,
                        settings.depth_rectified,
                        settings.depth_stride,
                        &mut projection,
                        &mut cloud,
                    )),
                    (Some(_), None) => Some(Err(super::sensing::SensorError(format!(
                        "a depth image, but no camera info on {} yet",
                        settings.camera_info_topic
                    )))),
                    (None, _) => None,
                }
            }
        };
        match read {
            Some(Ok(())) => pending = Some((cloud, Instant::now())),
            Some(Err(e)) => {
                let topic = settings.point_cloud_topic.as_deref().or(settings.depth_image_topic.as_deref());
                if updates.send(Err(format!("{}: {e}", topic.unwrap_or_default()))).is_err() {
                    return;
                }
            }
            None => {}
        }
        let q = measured.lock().ok().and_then(|m| m.clone());
        let (Some(q), true) = (q, pending.is_some()) else {
            std::thread::sleep(Duration::from_millis(2));
            continue;
        };
        let Some((points, arrived)) = pending.take() else { continue };
        let result = build_update(points, arrived, &q, &settings, &filter, &scene);
        if updates.send(result).is_err() {
            return;
        }
    }
}

/// One cloud (sensor frame) to a collision model and rows for the loop.
fn build_update(
    points: PointCloud,
    arrived: Instant,
    q: &[f64],
    settings: &CameraSettings,
    filter: &FilterSettings,
    scene: &Mutex<SceneState>,
) -> Result<CloudUpdate, CloudRefusal> {
    let mut report = CloudReport { points: points.len(), invalid: points.dropped, ..CloudReport::default() };
    let placed = points.transformed(&settings.sensor_pose);
    let (mut kept, filtered) = placed.filtered(filter).map_err(|e| e.to_string())?;
    report.cropped = filtered.cropped + filtered.out_of_range;
    report.thinned = filtered.thinned;
    let (mut problem, targets, base, generation) = {
        let state = scene.lock().map_err(|_| "the scene's lock is poisoned".to_string())?;
        (state.problem.clone(), state.targets.clone(), state.arbiter.collision_model().clone(), state.generation)
    };
    let mut ws = CollisionWorkspace::new(&base);
    report.on_robot = base
        .remove_robot_points(&mut ws, q, settings.self_filter_margin, &mut kept.points)
        .map_err(|e| e.to_string())?;
    report.kept = kept.len();
    let radius = settings.point_radius + filtered.radius_margin;
    let obstacle =
        Obstacle::point_cloud("point_cloud", &kept, radius, IsometryMatrix3::identity()).map_err(|e| e.to_string())?;
    if !kept.is_empty() {
        problem.scene.add_obstacle(obstacle.clone()).map_err(|e| e.to_string())?;
    }
    let names: Vec<&str> = targets.iter().map(String::as_str).collect();
    let model = Arc::new(problem.collision_model_grasping(&names, 0.0).map_err(|e| e.to_string())?);
    let mut state = scene.lock().map_err(|_| "the scene's lock is poisoned".to_string())?;
    if state.generation != generation {
        return Err("the goals changed while the cloud was built: it waits for the next".into());
    }
    let arbiter = state.arbiter.with_collision_model(model).map_err(|e| e.to_string())?;
    state.cloud = (!kept.is_empty()).then_some((obstacle, arrived));
    drop(state);
    let rows = arbiter.safety_rows();
    report.build_ms = arrived.elapsed().as_secs_f64() * 1e3;
    Ok(CloudUpdate { arbiter, rows, generation, arrived, report })
}
