//! The node on DDS: topics and QoS, the fixed-rate loop, the `mode`
//! parameter. `ros2-client` (pure Rust over RustDDS) speaks the RTPS wire
//! protocol rclcpp and rclpy nodes use, so the node runs beside
//! `ros2_control` and a robot driver without a ROS installation.
//!
//! QoS, chosen so that the node matches what standard nodes offer:
//!
//! | topic | direction | reliability | history | why |
//! | --- | --- | --- | --- | --- |
//! | `joint_topic` | in | best effort | keep last 1 | matches reliable and best-effort publishers (`joint_state_broadcaster` is reliable, drivers often best effort); only the latest state matters |
//! | twist, joint commands | in | best effort | keep last 10 | matches any publisher (Servo's own reader is the system default, reliable); the latest of a tick's commands is used |
//! | `mode_topic` | in | reliable | keep last 1 | a mode switch must not be lost; one name read per tick |
//! | `goals_topic` | in | reliable | keep last 1 | only the latest poses matter, and they must arrive |
//! | `point_cloud_topic`, `depth_image_topic`, `camera_info_topic` | in | best effort | keep last 1 | matches camera drivers (sensor-data QoS); only the latest frame matters; read by the camera worker, never the loop |
//! | `command_out_topic` | out | reliable | keep last 1 | the controllers subscribe reliably (system default); a reliable writer matches both kinds of reader |
//! | status, beliefs, diagnostics | out | reliable | keep last 10 | readable by `ros2 topic echo` with its defaults |
//!
//! Every topic is volatile: nothing old is worth delivering to a late joiner.

use super::camera::{CameraLink, CameraReaders, SceneState};
use super::control::{ControlLoop, DIAGNOSTICS};
use super::goals::{GoalPoses, GoalPreparer};
use super::log::{Echo, LogKind, NodeLog};
use super::messages::{
    CameraInfo, Duration as RosDuration, Float64MultiArray, Header, Image, Int8, JointJog, JointState, JointTrajectory,
    JointTrajectoryPoint, MultiArrayDimension, MultiArrayLayout, PoseArray, StringMessage, TwistStamped,
};
use super::robot_description::MAX_ROBOT_DESCRIPTION_BYTES;
use super::settings::{CommandOut, NodeSettings};
use super::ticker::Ticker;
use crate::arbitration::ArbitrationMode;
use ros2_client::{
    Context, ContextOptions, MessageTypeName, Name, NodeName, NodeOptions, ParameterValue, QosProfile,
    qos::{History, WhenFull},
};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Why the node could not start.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum NodeError {
    /// A node or topic name ROS 2 does not accept.
    #[error("{what} '{name}' is not a valid ROS 2 name: {reason}")]
    Name {
        /// Which setting.
        what: &'static str,
        /// The name.
        name: String,
        /// Why.
        reason: String,
    },
    /// A camera topic without the problem to put its points in (no goal
    /// preparer given).
    #[error("a camera topic needs the problem's scene: run the node with goals from poses enabled")]
    CameraWithoutScene,
    /// The DDS participant, a topic, a reader or a writer could not be made.
    #[error("DDS: {0}")]
    Dds(String),
    /// One of the node's own threads (the log, the watchdog) could not be started.
    #[error("cannot start the {what} thread: {source}")]
    Thread {
        /// Which thread.
        what: &'static str,
        /// Why.
        source: std::io::Error,
    },
    /// The robot on `robot_description_topic` is not the problem's robot,
    /// or none was published in time.
    #[error("the robot on {topic} is not the problem's robot: {reason}")]
    RobotDescription {
        /// The topic.
        topic: String,
        /// What differs (the joint, the limit, the pose), or that nothing
        /// arrived; at most [`REASON_BYTES`] (the URDF's own text, echoed
        /// by an XML error, is cut).
        reason: String,
    },
    /// The URDF on `robot_description_topic` is larger than
    /// [`MAX_ROBOT_DESCRIPTION_BYTES`]: refused unread (a 60 MB one took
    /// 7 s and 611 MB to parse).
    #[error("the robot description on {topic} is {bytes} bytes, more than the limit of {limit} bytes: refused")]
    RobotDescriptionTooLarge {
        /// The topic.
        topic: String,
        /// Its size (bytes).
        bytes: usize,
        /// The limit (bytes).
        limit: usize,
    },
}

/// Longest reason of a [`NodeError::RobotDescription`] (bytes).
pub const REASON_BYTES: usize = 512;

fn bounded_reason(mut reason: String) -> String {
    if reason.len() > REASON_BYTES {
        let mut end = REASON_BYTES;
        while !reason.is_char_boundary(end) {
            end -= 1;
        }
        let total = reason.len();
        reason.truncate(end);
        reason.push_str(&format!("… ({total} bytes)"));
    }
    reason
}

/// What a run of the node did.
#[derive(Debug, Clone, Default)]
pub struct NodeReport {
    /// Ticks run.
    pub ticks: u64,
    /// Ticks that started more than half a period late.
    pub late_ticks: u64,
    /// Commands published (none before the first joint state).
    pub published: u64,
    /// Messages that could not be read (wrong type on a topic, malformed CDR).
    pub unreadable: u64,
    /// The tick's own time (µs): median, 99th percentile (both within
    /// [`QUANTILE_ERROR`](crate::control::timing::QUANTILE_ERROR)), largest.
    pub tick_us: [f64; 3],
    /// Log lines dropped because stderr was not read fast enough.
    pub dropped_log_lines: u64,
    /// Log lines suppressed by the rate limit (one line per kind per second).
    pub suppressed_log_lines: u64,
    /// Stalls of the loop the watchdog reported.
    pub stalls: u64,
    /// The longest stall (s past the deadline; 0 without one).
    pub longest_stall_s: f64,
    /// Mode names read from the mode topic (one a tick at most).
    pub mode_messages: u64,
    /// PoseArrays dropped as equal to the goals' poses.
    pub poses_unchanged: u64,
    /// Goal preparations started (re-plans).
    pub replans: u64,
    /// Point clouds swapped into the scene.
    pub point_clouds: u64,
    /// Camera messages refused (bad layout, no camera info, …).
    pub point_clouds_refused: u64,
    /// Stopped (SIGINT, SIGTERM) before the loop started, e.g. while
    /// waiting for the robot description: no tick ran.
    pub stopped_before_start: bool,
}

/// `~/name` resolved against the node (`/ns/node/name`), other names as given.
fn resolve(topic: &str, settings: &NodeSettings, what: &'static str) -> Result<Name, NodeError> {
    let full = match topic.strip_prefix("~/") {
        Some(rest) => {
            let ns = settings.namespace.trim_end_matches('/');
            format!("{ns}/{}/{rest}", settings.node_name)
        }
        None => topic.to_string(),
    };
    Name::parse(&full).map_err(|e| NodeError::Name { what, name: topic.to_string(), reason: format!("{e:?}") })
}

fn dds<E: std::fmt::Debug>(what: &str) -> impl FnOnce(E) -> NodeError + '_ {
    move |e| NodeError::Dds(format!("{what}: {e:?}"))
}

/// Runs the node until `stop` is set (or `duration` has passed): reads
/// the inputs, ticks at the settings' rate, publishes. `ready` is called
/// once every topic exists. With `preparer`, poses on the goals topic
/// re-plan the goals (on a thread of their own, one preparation at a
/// time). What the node says goes to stderr through [`NodeLog`], never
/// from the loop's thread. A stop before the loop starts (while waiting
/// for the robot description, say) returns a report with
/// `stopped_before_start`.
///
/// # Errors
/// A name ROS 2 refuses, DDS failing to create an entity, a thread that
/// cannot be started, a robot description that is not the problem's
/// robot, larger than [`MAX_ROBOT_DESCRIPTION_BYTES`] or not published in time.
pub fn run_node(
    control: &mut ControlLoop,
    settings: &NodeSettings,
    stop: &AtomicBool,
    duration: Option<Duration>,
    preparer: Option<GoalPreparer>,
    ready: impl FnOnce(),
) -> Result<NodeReport, NodeError> {
    // Everything the node says from here on goes through the log: a
    // stderr nobody reads must not stop it, in any phase.
    let log = NodeLog::stderr().map_err(|source| NodeError::Thread { what: "log", source })?;
    let context = Context::with_options(ContextOptions::new().domain_id(settings.domain_id))
        .map_err(dds("cannot join the DDS domain"))?;
    let node_name = NodeName::new(&settings.namespace, &settings.node_name).map_err(|e| NodeError::Name {
        what: "node_name",
        name: settings.node_name.clone(),
        reason: format!("{e:?}"),
    })?;
    // The mode parameter: validated where it enters, applied by the loop.
    let pending_mode: Arc<Mutex<Option<ArbitrationMode>>> = Arc::new(Mutex::new(None));
    let learned_ok = control.arbiter().arbitration_policy().is_some();
    let parse_mode = move |value: &ParameterValue| -> Result<ArbitrationMode, String> {
        let ParameterValue::String(name) = value else { return Err("mode is a string".into()) };
        // The caller's name is echoed back bounded.
        let mode: ArbitrationMode =
            name.parse().map_err(|_| format!("mode '{}': {}", Echo(name), super::control::ModeRefusal::Unknown))?;
        if mode == ArbitrationMode::Learned && !learned_ok {
            return Err("mode learned needs an arbitration actor (--arbiter)".into());
        }
        Ok(mode)
    };
    let apply = Arc::clone(&pending_mode);
    let options = NodeOptions::new()
        .enable_rosout(false)
        .start_parameter_services(true)
        .declare_parameter("mode", ParameterValue::String(control.mode().as_str().into()))
        .parameter_validator(Box::new(
            move |name, value| if name == "mode" { parse_mode(value).map(|_| ()) } else { Ok(()) },
        ))
        .parameter_set_action(Box::new(move |name, value| {
            if name == "mode" {
                let mode = parse_mode(value)?;
                if let Ok(mut pending) = apply.lock() {
                    *pending = Some(mode);
                }
            }
            Ok(())
        }));
    let mut node = context.new_node(node_name, options).map_err(dds("cannot create the node"))?;

    let latest = |depth| QosProfile::subscription_default().history(History::KeepLast { depth });
    let reliable = |depth| {
        QosProfile::publisher_default().reliability_reliable(WhenFull::DEFAULT).history(History::KeepLast { depth })
    };
    macro_rules! topic {
        ($setting:ident, $package:literal, $type:literal, $qos:expr) => {{
            let name = resolve(&settings.$setting, settings, stringify!($setting))?;
            node.create_topic(&name, MessageTypeName::new($package, $type), &$qos)
                .map_err(dds(concat!("cannot create the topic ", stringify!($setting))))?
        }};
    }
    let joint_states = topic!(joint_topic, "sensor_msgs", "JointState", latest(1));
    let twists = topic!(cartesian_command_in_topic, "geometry_msgs", "TwistStamped", latest(10));
    let jogs = topic!(joint_command_in_topic, "control_msgs", "JointJog", latest(10));
    let modes = topic!(mode_topic, "std_msgs", "String", reliable(1));
    let poses_topic = topic!(goals_topic, "geometry_msgs", "PoseArray", reliable(1));
    let (out_package, out_type) = match settings.command_out {
        CommandOut::Trajectory => ("trajectory_msgs", "JointTrajectory"),
        CommandOut::Positions | CommandOut::Velocities => ("std_msgs", "Float64MultiArray"),
    };
    let out_name = resolve(&settings.command_out_topic, settings, "command_out_topic")?;
    let command_out = node
        .create_topic(&out_name, MessageTypeName::new(out_package, out_type), &reliable(1))
        .map_err(dds("cannot create the topic command_out_topic"))?;
    let status = topic!(status_topic, "std_msgs", "Int8", reliable(10));
    let beliefs = topic!(beliefs_topic, "std_msgs", "Float64MultiArray", reliable(10));
    let diagnostics = topic!(diagnostics_topic, "std_msgs", "Float64MultiArray", reliable(10));

    let state_in = node.create_subscription::<JointState>(&joint_states, None).map_err(dds("joint_topic reader"))?;
    let twist_in = node.create_subscription::<TwistStamped>(&twists, None).map_err(dds("twist reader"))?;
    let jog_in = node.create_subscription::<JointJog>(&jogs, None).map_err(dds("joint command reader"))?;
    let mode_in = node.create_subscription::<StringMessage>(&modes, None).map_err(dds("mode reader"))?;
    let goals_in = node.create_subscription::<PoseArray>(&poses_topic, None).map_err(dds("goals reader"))?;
    let status_out = node.create_publisher::<Int8>(&status, None).map_err(dds("status writer"))?;
    let beliefs_out = node.create_publisher::<Float64MultiArray>(&beliefs, None).map_err(dds("beliefs writer"))?;
    let diagnostics_out =
        node.create_publisher::<Float64MultiArray>(&diagnostics, None).map_err(dds("diagnostics writer"))?;
    let trajectory_out = match settings.command_out {
        CommandOut::Trajectory => {
            Some(node.create_publisher::<JointTrajectory>(&command_out, None).map_err(dds("command writer"))?)
        }
        _ => None,
    };
    let array_out = match settings.command_out {
        CommandOut::Trajectory => None,
        _ => Some(node.create_publisher::<Float64MultiArray>(&command_out, None).map_err(dds("command writer"))?),
    };
    if settings.robot_description_timeout > 0.0 {
        let name = resolve(&settings.robot_description_topic, settings, "robot_description_topic")?;
        // MoveIt's QoS for the description: reliable, transient-local, so a
        // description published before the node started still arrives.
        let qos = reliable(1).durability(ros2_client::qos::Durability::TransientLocal);
        let topic = node
            .create_topic(&name, MessageTypeName::new("std_msgs", "String"), &qos)
            .map_err(dds("cannot create the topic robot_description_topic"))?;
        let reader =
            node.create_subscription::<StringMessage>(&topic, None).map_err(dds("robot description reader"))?;
        let waited = Instant::now();
        log.sender().send(format_args!(
            "waiting up to {} s for the robot description on {}",
            settings.robot_description_timeout, settings.robot_description_topic
        ));
        let urdf = loop {
            if let Ok(Some((msg, _))) = reader.take() {
                break msg.data;
            }
            // A stop is a stop in every phase: exit 0 with the report.
            if stop.load(Ordering::Relaxed) {
                return Ok(stopped_before_start(log));
            }
            if waited.elapsed().as_secs_f64() > settings.robot_description_timeout {
                return Err(NodeError::RobotDescription {
                    topic: settings.robot_description_topic.clone(),
                    reason: format!("nothing was published within {} s", settings.robot_description_timeout),
                });
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        if urdf.len() > MAX_ROBOT_DESCRIPTION_BYTES {
            return Err(NodeError::RobotDescriptionTooLarge {
                topic: settings.robot_description_topic.clone(),
                bytes: urdf.len(),
                limit: MAX_ROBOT_DESCRIPTION_BYTES,
            });
        }
        let arbiter = control.arbiter();
        super::robot_description::check_robot_description(arbiter.robot(), arbiter.gripper_frame(), &urdf).map_err(
            |reason| NodeError::RobotDescription {
                topic: settings.robot_description_topic.clone(),
                reason: bounded_reason(reason),
            },
        )?;
    }
    if stop.load(Ordering::Relaxed) {
        return Ok(stopped_before_start(log));
    }
    // Discovery, parameter services: on a thread of their own.
    let spinner = node.spinner().map_err(dds("cannot start the node's spinner"))?;
    std::thread::Builder::new()
        .name("ros2-spinner".into())
        .spawn(move || futures::executor::block_on(spinner.spin()))
        .map_err(dds("cannot start the spinner thread"))?;

    // The camera: its readers go to a worker thread of their own.
    let camera = &settings.camera;
    let readers = match (&camera.point_cloud_topic, &camera.depth_image_topic) {
        (Some(topic), _) => {
            let name = resolve(topic, settings, "point_cloud_topic")?;
            let t = node
                .create_topic(&name, MessageTypeName::new("sensor_msgs", "PointCloud2"), &latest(1))
                .map_err(dds("cannot create the topic point_cloud_topic"))?;
            Some(CameraReaders::Cloud(Box::new(node.create_subscription(&t, None).map_err(dds("point cloud reader"))?)))
        }
        (None, Some(topic)) => {
            let name = resolve(topic, settings, "depth_image_topic")?;
            let t = node
                .create_topic(&name, MessageTypeName::new("sensor_msgs", "Image"), &latest(1))
                .map_err(dds("cannot create the topic depth_image_topic"))?;
            let images = node.create_subscription::<Image>(&t, None).map_err(dds("depth image reader"))?;
            let name = resolve(&camera.camera_info_topic, settings, "camera_info_topic")?;
            let t = node
                .create_topic(&name, MessageTypeName::new("sensor_msgs", "CameraInfo"), &latest(1))
                .map_err(dds("cannot create the topic camera_info_topic"))?;
            let infos = node.create_subscription::<CameraInfo>(&t, None).map_err(dds("camera info reader"))?;
            Some(CameraReaders::Depth(Box::new((images, infos))))
        }
        (None, None) => None,
    };
    let loop_settings = *control.arbiter().settings();
    let camera_link = match readers {
        None => None,
        Some(readers) => {
            let preparer = preparer.as_ref().ok_or(NodeError::CameraWithoutScene)?;
            let arbiter = control.arbiter().with_settings(loop_settings).map_err(|e| NodeError::Dds(e.to_string()))?;
            let scene = SceneState {
                problem: preparer.problem().clone(),
                targets: preparer.graspable(),
                arbiter,
                generation: 0,
                cloud: None,
            };
            let link = CameraLink::start(readers, camera.clone(), scene)
                .map_err(|source| NodeError::Thread { what: "camera", source })?;
            Some(link)
        }
    };
    let shared_scene = camera_link.as_ref().map(|c| c.scene.clone());

    let joints: Vec<String> = control.arbiter().robot().joint_names().to_vec();
    let goals = control.arbiter().goals().len() as u32;
    // The messages, allocated once and refilled every tick.
    let mut trajectory = JointTrajectory {
        header: Header::default(),
        joint_names: joints.clone(),
        points: vec![JointTrajectoryPoint {
            time_from_start: to_duration(settings.period()),
            ..JointTrajectoryPoint::default()
        }],
    };
    let flat = |label: &str, size: u32| MultiArrayLayout {
        dim: vec![MultiArrayDimension { label: label.into(), size, stride: size }],
        data_offset: 0,
    };
    let mut array = Float64MultiArray { layout: flat("joints", joints.len() as u32), data: Vec::new() };
    let mut belief_msg = Float64MultiArray { layout: flat("goals", goals), data: Vec::new() };
    let mut diagnostics_msg =
        Float64MultiArray { layout: flat(&DIAGNOSTICS.join(","), DIAGNOSTICS.len() as u32), data: Vec::new() };

    // Goal preparation: the latest poses and the measured configuration go
    // to a thread that plans, optimizes and builds the new arbiter.
    let (to_preparer, requests) = std::sync::mpsc::channel::<(PoseArray, Vec<f64>)>();
    type Prepared = (crate::arbitration::Arbiter, f64, u64, Option<Instant>);
    let (prepared_tx, prepared) = std::sync::mpsc::channel::<Result<Prepared, String>>();
    let preparing = preparer.is_some();
    let poses_now = preparer.as_ref().map(GoalPreparer::problem_poses);
    if let Some(preparer) = preparer {
        std::thread::Builder::new()
            .name("ros2-goals".into())
            .spawn(move || {
                // One request at a time: the loop sends the next only
                // when this one's result is back (GoalPoses).
                let mut generation = 0;
                while let Ok(request) = requests.recv() {
                    let began = Instant::now();
                    // With a camera: planned around its latest cloud, and
                    // the scene's goals are these from now on.
                    let cloud = shared_scene.as_ref().and_then(|s| s.lock().ok().and_then(|s| s.cloud.clone()));
                    let result = preparer
                        .prepare_around(&request.0, &request.1, cloud.as_ref().map(|(o, _)| o))
                        .and_then(|(arbiter, problem)| {
                            generation += 1;
                            if let Some(scene) = &shared_scene {
                                let mut scene = scene.lock().map_err(|_| "the scene's lock is poisoned".to_string())?;
                                scene.arbiter = arbiter.with_settings(loop_settings).map_err(|e| e.to_string())?;
                                scene.problem = problem;
                                scene.generation = generation;
                            }
                            Ok((arbiter, began.elapsed().as_secs_f64(), generation, cloud.map(|(_, at)| at)))
                        });
                    if prepared_tx.send(result).is_err() {
                        break;
                    }
                }
            })
            .map_err(dds("cannot start the goal preparation thread"))?;
    } else {
        // Poses sent then fail, and the log says goals from poses are off.
        drop(requests);
    }
    let mut goal_poses =
        GoalPoses::new(control.arbiter().robot().description().root_link(), poses_now.unwrap_or_default());

    ready();
    let mut report = NodeReport::default();
    let period = Duration::from_secs_f64(settings.period());
    let began = Instant::now();
    let mut deadline = began;
    let mut ticker =
        Ticker::new(log, period, began).map_err(|source| NodeError::Thread { what: "watchdog", source })?;
    while !stop.load(Ordering::Relaxed) && duration.is_none_or(|d| began.elapsed() < d) {
        let now = Instant::now();
        if now < deadline {
            std::thread::sleep(deadline - now);
        }
        let now = Instant::now();
        if now > deadline + period / 2 {
            control.count_late();
            report.late_ticks += 1;
        }
        // The next deadline on the grid; a loop that fell behind by more
        // than a period starts a new grid rather than ticking in a burst.
        deadline = if now > deadline + period { now + period } else { deadline + period };

        // Drain the readers: the latest of each kind counts.
        drain(&state_in, &mut report.unreadable, |msg| control.joint_state(&msg, now));
        drain(&twist_in, &mut report.unreadable, |msg| control.twist(&msg, now));
        drain(&jog_in, &mut report.unreadable, |msg| control.joint_jog(&msg, now));
        // One mode name a tick, as documented: a flood cannot keep the
        // loop reading (keep-last-1 leaves the newest for the next tick).
        match mode_in.take() {
            Ok(Some((msg, _))) => {
                report.mode_messages += 1;
                if let Some(mode) = ticker.mode_name(control, &msg.data, now) {
                    let _ = node.set_parameter("mode", ParameterValue::String(mode.as_str().into()));
                }
            }
            Ok(None) => {}
            Err(_) => report.unreadable += 1,
        }
        drain(&goals_in, &mut report.unreadable, |msg| {
            goal_poses.arrived(msg);
        });
        // Poses wait for a valid joint state: the references start there.
        if let Some(q) = control.measured()
            && let Some(poses) = goal_poses.start()
            && to_preparer.send((poses, q.to_vec())).is_err()
        {
            goal_poses.finished(false);
            if preparing {
                ticker.log(
                    LogKind::GoalsRefused,
                    now,
                    format_args!("the goal preparation thread has stopped; the goals stay as they are"),
                );
            } else {
                ticker.log(LogKind::GoalsRefused, now, format_args!("goals from poses are not enabled"));
            }
        }
        if let Ok(result) = prepared.try_recv() {
            let accepted = result.and_then(|(arbiter, seconds, generation, cloud_at)| {
                control.replace_arbiter(&arbiter)?;
                control.accept_goals(generation, cloud_at);
                Ok(seconds)
            });
            match accepted {
                Ok(seconds) => {
                    goal_poses.finished(true);
                    ticker.log(
                        LogKind::Goals,
                        now,
                        format_args!("goals re-planned for the new poses in {:.0} ms", seconds * 1e3),
                    );
                }
                Err(e) => {
                    goal_poses.finished(false);
                    ticker.log(LogKind::GoalsRefused, now, format_args!("poses refused, the goals are unchanged: {e}"));
                }
            }
        }
        if let Some(camera) = &camera_link {
            if let Some(q) = control.measured() {
                camera.measured(q);
            }
            match camera.updates.try_recv() {
                Ok(Ok(mut update)) => {
                    let swapped = control.swap_collision(
                        &mut update.arbiter,
                        &mut update.rows,
                        update.generation,
                        update.arrived,
                    );
                    if swapped {
                        report.point_clouds += 1;
                        let r = update.report;
                        ticker.log(
                            LogKind::PointCloud,
                            now,
                            format_args!(
                                "point cloud: {} points kept of {} ({} invalid, {} cropped, {} thinned, {} on the arm), \
                                 in the scene {:.1} ms after arrival",
                                r.kept,
                                r.points + r.invalid,
                                r.invalid,
                                r.cropped,
                                r.thinned,
                                r.on_robot,
                                r.build_ms
                            ),
                        );
                    }
                    // The old model (or the unused new one) is freed by the
                    // worker; never waited for (a full queue, which the
                    // worker's draining makes rare, frees it here).
                    let _ = camera.freed.try_send((update.arbiter, update.rows));
                }
                Ok(Err(reason)) => {
                    report.point_clouds_refused += 1;
                    ticker.log(LogKind::PointCloudRefused, now, format_args!("camera message refused: {reason}"));
                }
                Err(_) => {}
            }
        }
        if let Some(mode) = pending_mode.try_lock().ok().and_then(|mut p| p.take())
            && mode != control.mode()
            && control.switch_mode(mode).is_ok()
        {
            ticker.log(LogKind::Mode, now, format_args!("mode {mode} (parameter)"));
        }

        let has_state = control.has_state();
        let out = control.tick(now);
        report.ticks += 1;
        ticker.ticked(out, &joints, deadline, Instant::now());
        if has_state {
            match (&trajectory_out, &array_out) {
                (Some(writer), _) => {
                    let point = &mut trajectory.points[0];
                    fill(&mut point.positions, settings.publish_joint_positions.then_some(&out.positions[..]));
                    fill(&mut point.velocities, settings.publish_joint_velocities.then_some(&out.qdot[..]));
                    fill(
                        &mut point.accelerations,
                        settings.publish_joint_accelerations.then_some(&out.accelerations[..]),
                    );
                    let _ = writer.publish(trajectory.clone());
                }
                (None, Some(writer)) => {
                    let values = if settings.command_out == CommandOut::Positions { &out.positions } else { &out.qdot };
                    fill(&mut array.data, Some(values));
                    let _ = writer.publish(array.clone());
                }
                (None, None) => {}
            }
            report.published += 1;
        }
        let _ = status_out.publish(Int8 { data: out.code });
        fill(&mut diagnostics_msg.data, Some(&out.diagnostics));
        let _ = diagnostics_out.publish(diagnostics_msg.clone());
        fill(&mut belief_msg.data, Some(control.beliefs()));
        let _ = beliefs_out.publish(belief_msg.clone());
    }
    // A last hold, so that a controller does not keep executing the last velocity.
    if let (Some(writer), true) = (&array_out, settings.command_out == CommandOut::Velocities) {
        fill(&mut array.data, None);
        array.data.resize(joints.len(), 0.0);
        let _ = writer.publish(array.clone());
    }
    let book = ticker.finish();
    report.tick_us = book.tick_us;
    report.dropped_log_lines = book.log.dropped;
    report.suppressed_log_lines = book.log.suppressed;
    report.stalls = book.stalls.count;
    report.longest_stall_s = book.stalls.longest_s;
    report.poses_unchanged = goal_poses.unchanged;
    report.replans = goal_poses.started;
    Ok(report)
}

/// The report of a node stopped before its loop started, its log's last
/// lines written (for a moment: stderr may not be read).
fn stopped_before_start(log: NodeLog) -> NodeReport {
    let counts = log.finish(Duration::from_millis(200));
    NodeReport {
        stopped_before_start: true,
        tick_us: [f64::NAN; 3],
        dropped_log_lines: counts.dropped,
        suppressed_log_lines: counts.suppressed,
        ..NodeReport::default()
    }
}

/// `into` = `values` (cleared when `None`), reusing its allocation.
fn fill(into: &mut Vec<f64>, values: Option<&[f64]>) {
    into.clear();
    if let Some(v) = values {
        into.extend_from_slice(v);
    }
}

fn to_duration(seconds: f64) -> RosDuration {
    let whole = seconds.floor();
    RosDuration { sec: whole as i32, nanosec: ((seconds - whole) * 1e9).round() as u32 }
}

/// Samples taken from one reader in one tick at most: a reader's history
/// holds fewer (keep last 10), so this only bounds a tick that samples
/// keep arriving into while it reads.
const DRAIN_LIMIT: usize = 256;

/// Takes the samples waiting in `reader` (up to [`DRAIN_LIMIT`]), oldest
/// first, handing each to `take`; samples that do not decode are counted in
/// `unreadable`.
fn drain<M: 'static + serde::de::DeserializeOwned>(
    reader: &ros2_client::Subscription<M>,
    unreadable: &mut u64,
    mut take: impl FnMut(M),
) {
    for _ in 0..DRAIN_LIMIT {
        match reader.take() {
            Ok(Some((msg, _))) => take(msg),
            Ok(None) => break,
            Err(_) => *unreadable += 1,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reason quoting a hostile URDF is cut at a character boundary, its
    /// length said; a short one is kept whole.
    #[test]
    fn robot_description_reasons_are_bounded() {
        assert_eq!(bounded_reason("joint panda_joint1 differs".into()), "joint panda_joint1 differs");
        let long = bounded_reason(format!("not XML: unexpected tag {}", "é".repeat(5_000)));
        assert!(long.len() <= REASON_BYTES + 20 && long.ends_with("… (10024 bytes)"), "{long}");
    }
}
