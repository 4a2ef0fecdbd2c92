//! The perception pipeline's stages on the grasp table with all seven
//! Table 7.1 objects and the Panda reaching into view, seen by a D435
//! across the table (640 × 480): what each stage costs, whether seven
//! objects track at 10 Hz on one core, and the registration problems
//! written for the side-by-side peers (pycpd, small_gicp).
//!
//!   cargo bench --features mujoco --bench perception [-- --quick --json FILE --cases FILE]
//!
//! Figures (ms; median, p90 and max over the runs):
//! * **camera**: one 640 × 480 frame by MuJoCo's rays; the sensor model;
//! * **segment**: table crop, the self-filter at the arm's configuration,
//!   cell clustering;
//! * **detect**: one segment labelled among the seven objects (ICP from
//!   every hypothesis of every object, each scored against the image);
//! * **mesh_pose**: rigid CPD of the labelled object from its hypotheses;
//! * **icp**: one point-to-plane ICP from 6 mm and 4° off;
//! * **track**: one frame of seven particle trackers (100 particles each),
//!   the figure against the dissertation's "seven objects per core at 10
//!   Hz" (a frame must take under 100 ms).
//!
//! Under `cargo test --all-targets` (no `--bench` argument) a smoke run:
//! the first segments only, one run each, one tracking frame.
//!
//! `--cases FILE` writes, per object, one CPD and one ICP problem (the
//! points, the start, the settings) for benches/peers/compare_registration.sh.

use nalgebra::{IsometryMatrix3, Rotation3, Translation3};
use serde_json::json;
use std::time::Instant;
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::perception::{
    CpdSettings, CpdWorkspace, DepthCamera, DepthImage, DepthSensorSettings, EstimateSettings, EstimateWorkspace,
    IcpSettings, ObjectLibrary, SegmentSettings, SurfaceModel, TrackSettings, Tracker, apply_sensor_model, catalog,
    detect, mesh_pose, point_to_plane_icp, rigid_cpd, segment_objects,
};
use tandem::point_cloud::CameraIntrinsics;
use tandem::problem::Problem;
use tandem::sim::PhysicsSettings;
use tandem::sim::mujoco::{GeomRole, PhysicsScene, RayCastCamera, RayCastFrame, SceneMesh};

/// Where the seven objects stand (x, y, yaw), clear of the problem's box
/// at (0.5, 0.1) and of each other.
const LAYOUT: [(&str, f64, f64, f64); 7] = [
    ("cube", 0.40, -0.02, 0.3),
    ("sphere", 0.62, -0.02, 0.0),
    ("lego_toy", 0.75, 0.18, 1.1),
    ("teapot", 0.68, -0.22, 2.0),
    ("cup", 0.40, -0.22, -0.7),
    ("jug", 0.66, -0.47, 0.9),
    ("bowl", 0.40, -0.47, 0.0),
];

fn stats(mut t: Vec<f64>) -> (f64, f64, f64) {
    t.sort_by(f64::total_cmp);
    let at = |q: f64| t[((t.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.9), *t.last().unwrap())
}

fn time_ms(runs: usize, mut f: impl FnMut()) -> (f64, f64, f64) {
    f();
    stats(
        (0..runs)
            .map(|_| {
                let start = Instant::now();
                f();
                start.elapsed().as_secs_f64() * 1e3
            })
            .collect(),
    )
}

fn text(args: &[String], name: &str) -> Option<String> {
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1).cloned())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    // Under `cargo test --all-targets` (no `--bench`): a smoke run, one
    // object, one run of each stage, one tracking frame.
    let smoke = !args.iter().any(|a| a == "--bench");
    let quick = smoke || args.iter().any(|a| a == "--quick");
    let runs = if smoke {
        1
    } else if quick {
        3
    } else {
        30
    };
    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let library = ObjectLibrary::new(catalog()).unwrap();
    let objects: Vec<_> = LAYOUT.iter().map(|(n, ..)| tandem::perception::objects::object(n).unwrap()).collect();
    let poses: Vec<IsometryMatrix3<f64>> = LAYOUT
        .iter()
        .map(|&(_, x, y, yaw)| {
            IsometryMatrix3::from_parts(Translation3::new(x, y, 0.0), Rotation3::from_euler_angles(0.0, 0.0, yaw))
        })
        .collect();
    let meshes: Vec<SceneMesh> = objects
        .iter()
        .zip(&poses)
        .map(|(o, p)| SceneMesh { name: o.name, mesh: &o.mesh, pose: *p, mass: o.mass_kg })
        .collect();
    let scene = PhysicsScene::with_meshes(&problem, 0.01, &PhysicsSettings::default(), &meshes).unwrap();
    let mut data = scene.data();
    let q = [0.0, 0.5, 0.0, -1.6, 0.0, 2.1, 0.785];
    scene.reset(&mut data, &q);
    data.forward();
    let cam = DepthCamera::looking_at(
        CameraIntrinsics::realsense_d435_640x480(),
        [1.2, -0.15, 0.65],
        [0.55, -0.15, 0.03],
        [0.0, 0.0, 1.0],
    )
    .unwrap();
    let mut rays = RayCastCamera::new(cam, 4.0);
    let mut frame = RayCastFrame::default();
    let camera = time_ms(runs, || rays.render(&mut data, &mut frame));
    let sensor = DepthSensorSettings::default();
    let mut image = DepthImage::default();
    let mut seed = 0;
    let noise = time_ms(runs, || {
        seed += 1;
        apply_sensor_model(&cam, &frame.depth, &frame.cos_incidence, &sensor, seed, &mut image).unwrap();
    });
    let mut points = vec![];
    image.points(&cam, &mut points);
    let collision = CollisionModel::builder(problem.robot.clone()).build().unwrap();
    let mut cws = CollisionWorkspace::new(&collision);
    let seg = SegmentSettings::for_table([-0.4, -0.8], [1.0, 0.8], 0.0);
    let mut segments = vec![];
    let segment = time_ms(runs, || {
        segments = segment_objects(&points, Some((&collision, &mut cws, &q)), &seg).unwrap().0;
    });
    let settings = EstimateSettings::for_table(0.0);
    let mut ews = EstimateWorkspace::default();
    let (mut detect_t, mut mesh_t, mut icp_t) = (vec![], vec![], vec![]);
    let mut trackers = vec![];
    let mut cases = vec![];
    let mut labels = vec![];
    for s in segments.iter().take(if smoke { 2 } else { usize::MAX }) {
        let Some(GeomRole::Object(o)) = frame.geom[s.pixels[s.pixels.len() / 2]].map(|g| scene.role(g)) else {
            continue;
        };
        if o == 0 {
            continue;
        }
        let (name, truth) = (LAYOUT[o - 1].0, poses[o - 1]);
        let k = library.objects().position(|m| m.name == name).unwrap();
        let mut found = None;
        detect_t
            .push(time_ms(runs.min(5), || found = detect(s, &cam, &image, &library, &settings, &mut ews).unwrap()).0);
        labels.push((name, found.map(|d| library.object(d.object).name)));
        mesh_t.push(
            time_ms(runs.min(5), || {
                std::hint::black_box(mesh_pose(s, &cam, &image, &library, k, &settings, &mut ews).unwrap());
            })
            .0,
        );
        let start = truth
            * IsometryMatrix3::from_parts(
                Translation3::new(0.006, -0.004, 0.0),
                Rotation3::from_euler_angles(0.0, 0.0, 0.07),
            );
        let icp = IcpSettings::default();
        icp_t.push(
            time_ms(runs, || {
                std::hint::black_box(point_to_plane_icp(library.surface(k), &s.points, &start, &icp).unwrap());
            })
            .0,
        );
        trackers.push(
            Tracker::new(library.object(k).mesh.clone(), &cam, start, TrackSettings::default(), o as u64).unwrap(),
        );
        // The peers' problems: CPD of 200 model samples onto 300 segment
        // points from 15° and 1 cm off; ICP of the segment onto 8,000
        // samples (small_gicp's normals, as the cross-check test does).
        let stride = s.points.len().div_ceil(300);
        let fixed: Vec<[f64; 3]> = s.points.iter().step_by(stride).copied().collect();
        let moving = library.object(k).mesh.sample_surface(200, 5);
        let cpd_start = truth
            * IsometryMatrix3::from_parts(
                Translation3::new(0.01, 0.0, 0.0),
                Rotation3::from_euler_angles(0.0, 0.0, 0.26),
            );
        let cpd = CpdSettings { max_iterations: 40, tolerance: 0.0, estimate_scale: true, ..CpdSettings::default() };
        let (r0, t0) = (*cpd_start.rotation.matrix(), cpd_start.translation.vector);
        let mut cpd_ws = CpdWorkspace::default();
        let cpd_ms = time_ms(runs.min(10), || {
            std::hint::black_box(rigid_cpd(&fixed, &moving, (r0, t0, 1.0), &cpd, &mut cpd_ws).unwrap());
        })
        .0;
        let model = library.object(k).mesh.sample_surface_with_normals(8000, 7);
        let (mp, mn): (Vec<[f64; 3]>, Vec<[f64; 3]>) = model.into_iter().unzip();
        let surface = SurfaceModel::new(mp.clone(), mn).unwrap();
        let icp_ms = time_ms(runs, || {
            std::hint::black_box(point_to_plane_icp(&surface, &s.points, &start, &icp).unwrap());
        })
        .0;
        cases.push(json!({
            "object": name,
            "cpd": {"fixed": fixed, "moving": moving,
                    "rotation": (0..3).map(|i| (0..3).map(|j| r0[(i, j)]).collect::<Vec<_>>()).collect::<Vec<_>>(),
                    "translation": [t0.x, t0.y, t0.z], "scale": 1.0, "w": 0.1, "max_iterations": 40, "tolerance": 0.0,
                    "tandem_ms": cpd_ms},
            "icp": {"model": mp, "points": s.points, "pose": (0..4).map(|i| (0..4).map(|j| start.to_homogeneous()[(i, j)]).collect::<Vec<_>>()).collect::<Vec<_>>(),
                    "max_correspondence_distance": 0.02, "max_iterations": 50, "tolerance": 1e-8, "neighbors": 20,
                    "tandem_ms": icp_ms},
        }));
    }
    let frames = if smoke {
        1
    } else if quick {
        3
    } else {
        50
    };
    let mut track_t = vec![];
    for f in 0..frames {
        apply_sensor_model(&cam, &frame.depth, &frame.cos_incidence, &sensor, 1000 + f, &mut image).unwrap();
        let start = Instant::now();
        for t in &mut trackers {
            t.update(&image).unwrap();
        }
        track_t.push(start.elapsed().as_secs_f64() * 1e3);
    }
    let track = stats(track_t);
    let med = |v: &[f64]| stats(v.to_vec());
    println!(
        "perception on the grasp table, 7 objects, the Panda in view, D435 640 × 480 ({} segments)",
        segments.len()
    );
    println!("{:<44} {:>9} {:>9} {:>9}", "stage (ms)", "median", "p90", "max");
    let row = |name: &str, s: (f64, f64, f64)| println!("{name:<44} {:>9.2} {:>9.2} {:>9.2}", s.0, s.1, s.2);
    row("camera: MuJoCo rays, one frame", camera);
    row("sensor model, one frame", noise);
    row("segmentation (crop, self-filter, clusters)", segment);
    row("detect: one segment among 7 objects", med(&detect_t));
    row("mesh_pose: CPD from the hypotheses", med(&mesh_t));
    row("ICP from 6 mm / 4° off", med(&icp_t));
    row(&format!("track: one frame of {} trackers", trackers.len()), track);
    println!("labels: {labels:?}");
    println!("seven objects at 10 Hz need a frame under 100 ms: median {:.1} ms, max {:.1} ms", track.0, track.2);
    if let Some(path) = text(&args, "--cases") {
        std::fs::write(&path, serde_json::to_string(&cases).unwrap()).expect("write --cases FILE");
    }
    if let Some(path) = text(&args, "--json") {
        let s = |s: (f64, f64, f64)| json!({"median_ms": s.0, "p90_ms": s.1, "max_ms": s.2});
        let out = json!({
            "camera": s(camera), "sensor": s(noise), "segment": s(segment), "detect": s(med(&detect_t)),
            "mesh_pose": s(med(&mesh_t)), "icp": s(med(&icp_t)), "track_frame": s(track), "trackers": trackers.len(),
        });
        std::fs::write(path, serde_json::to_string_pretty(&out).unwrap()).expect("write --json FILE");
    }
}
