//! tandem's registration against independent implementations on the same
//! points: rigid CPD against `pycpd`, point-to-plane ICP against
//! `small_gicp` (python_ref/registration_reference.py).
//!
//! The measured points are what a RealSense-like camera sees of a Table
//! 7.1 object: its mesh rasterised at a known pose, the D435 sensor model
//! applied (shadows, dropouts, noise, 1 mm steps), the pixels turned back
//! into world points.

mod common;

#[global_allocator]
static GLOBAL: common::alloc::CountingAllocator = common::alloc::CountingAllocator;

use common::run_python;
use nalgebra::{IsometryMatrix3, Matrix3, Matrix4, Rotation3, Translation3, Vector3};
use serde_json::{Value, json};
use tandem::perception::metrics::add_s;
use tandem::perception::{
    CpdSettings, CpdWorkspace, DepthCamera, DepthImage, DepthSensorSettings, IcpSettings, PixelWindow, RenderSettings,
    RenderWorkspace, SurfaceModel, apply_sensor_model, objects, point_to_plane_icp, render_mesh, rigid_cpd,
};
use tandem::point_cloud::CameraIntrinsics;

/// The camera of the perception experiment's table: a D435 at 640 × 480,
/// 0.6 m above and 0.45 m in front of the object, looking at it.
fn camera() -> DepthCamera {
    DepthCamera::looking_at(
        CameraIntrinsics::realsense_d435_640x480(),
        [0.05, -0.45, 0.6],
        [0.0, 0.0, 0.04],
        [0.0, 0.0, 1.0],
    )
    .unwrap()
}

/// What the camera measures of `name` at `pose`: world points, every
/// `stride`-th one kept.
fn measured(
    name: &str,
    pose: &IsometryMatrix3<f64>,
    stride: usize,
    sensor: &DepthSensorSettings,
    seed: u64,
) -> Vec<[f64; 3]> {
    let cam = camera();
    let object = objects::object(name).unwrap();
    let (w, h) = cam.size();
    let mut ideal = DepthImage::empty(w, h);
    let mut ws = RenderWorkspace::default();
    render_mesh(
        &cam,
        &object.mesh,
        pose,
        PixelWindow::full(&cam),
        &RenderSettings::default(),
        &mut ws,
        &mut ideal.depth,
    );
    // Incidence from the image itself is not needed here: a cosine of 1
    // keeps grazing dropouts out, the rest of the model stays.
    let cos: Vec<f32> = ideal.depth.iter().map(|d| if d.is_finite() { 1.0 } else { f32::NAN }).collect();
    let mut seen = DepthImage::default();
    apply_sensor_model(&cam, &ideal, &cos, sensor, seed, &mut seen).unwrap();
    let mut points = vec![];
    seen.points(&cam, &mut points);
    points.into_iter().step_by(stride).map(|(p, _)| p).collect()
}

fn pose_at(x: f64, y: f64, yaw: f64) -> IsometryMatrix3<f64> {
    IsometryMatrix3::from_parts(Translation3::new(x, y, 0.0), Rotation3::from_euler_angles(0.0, 0.0, yaw))
}

fn matrix3(v: &Value) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| v[i][j].as_f64().unwrap())
}

fn vector3(v: &Value) -> Vector3<f64> {
    Vector3::new(v[0].as_f64().unwrap(), v[1].as_f64().unwrap(), v[2].as_f64().unwrap())
}

fn isometry(v: &Value) -> IsometryMatrix3<f64> {
    let m = Matrix4::from_fn(|i, j| v[i][j].as_f64().unwrap());
    let r = Rotation3::from_matrix(&m.fixed_view::<3, 3>(0, 0).into_owned());
    IsometryMatrix3::from_parts(Translation3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]), r)
}

fn homogeneous(p: &IsometryMatrix3<f64>) -> Vec<Vec<f64>> {
    let m = p.to_homogeneous();
    (0..4).map(|i| (0..4).map(|j| m[(i, j)]).collect()).collect()
}

/// Translation (m) and rotation (rad) from `a` to `b`, exact near zero.
fn pose_error(a: &IsometryMatrix3<f64>, b: &IsometryMatrix3<f64>) -> (f64, f64) {
    let d = a.inverse() * b;
    let m = d.rotation.matrix();
    let sin = 0.5 * Vector3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)]).norm();
    (d.translation.vector.norm(), sin.atan2(0.5 * (m.trace() - 1.0)))
}

/// Rigid CPD, the same EM iterations from the same start: the transforms
/// agree to rounding. pycpd always estimates the scale, so tandem does too
/// here. Seen: 3.6e-15 in rotation, 1.5e-16 m in translation, 2.6e-15 in
/// scale, 4.7e-14 relative in σ² (tolerances about 100× those).
#[test]
fn rigid_cpd_takes_the_same_steps_as_pycpd() {
    let mut worst = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for (i, name) in ["lego_toy", "teapot", "cup", "cube"].into_iter().enumerate() {
        let truth = pose_at(0.02 * i as f64, -0.01, 0.4 + 0.3 * i as f64);
        let fixed = measured(name, &truth, 1, &DepthSensorSettings::default(), 11 + i as u64);
        let fixed: Vec<[f64; 3]> = {
            let stride = (fixed.len() / 250).max(1);
            fixed.into_iter().step_by(stride).collect()
        };
        let moving = objects::object(name).unwrap().mesh.sample_surface(200, 5 + i as u64);
        // Start 15° off in yaw, 1 cm off in place (pycpd takes only starts
        // whose rotation is positive semi-definite: yaw within ±90°).
        let yaw = 0.4 + 0.3 * i as f64;
        let start = pose_at(0.02 * i as f64 + 0.01, -0.01, yaw + 0.26);
        let (r0, t0) = (*start.rotation.matrix(), start.translation.vector);
        // σ² from the moved model (pycpd takes it from the unmoved one
        // unless given): both start from the same.
        let sigma2 = {
            let moved: Vec<Vector3<f64>> = moving.iter().map(|y| r0 * Vector3::from(*y) + t0).collect();
            let sum: f64 =
                fixed.iter().map(|x| moved.iter().map(|y| (Vector3::from(*x) - y).norm_squared()).sum::<f64>()).sum();
            sum / (3 * fixed.len() * moving.len()) as f64
        };
        let settings = CpdSettings {
            outlier_weight: 0.1,
            max_iterations: 40,
            tolerance: 0.0,
            estimate_scale: true,
            initial_variance: Some(sigma2),
        };
        let mut ws = CpdWorkspace::default();
        let ours = rigid_cpd(&fixed, &moving, (r0, t0, 1.0), &settings, &mut ws).unwrap();
        let request = json!({
            "method": "cpd", "fixed": fixed, "moving": moving,
            "rotation": (0..3).map(|i| (0..3).map(|j| r0[(i, j)]).collect::<Vec<_>>()).collect::<Vec<_>>(),
            "translation": [t0.x, t0.y, t0.z], "scale": 1.0, "w": 0.1, "max_iterations": 40, "tolerance": 0.0, "sigma2": sigma2,
        });
        let peer: Value =
            serde_json::from_str(&run_python("registration_reference.py", &[], &request.to_string())).unwrap();
        assert_eq!(peer["iterations"].as_u64(), Some(40));
        let dr = (ours.rotation - matrix3(&peer["rotation"])).abs().max();
        let dt = (ours.translation - vector3(&peer["translation"])).abs().max();
        let ds = (ours.scale - peer["scale"].as_f64().unwrap()).abs();
        let dv = (ours.variance / peer["variance"].as_f64().unwrap() - 1.0).abs();
        eprintln!(
            "{name}: {} × {} points, ΔR {dr:e}, Δt {dt:e} m, Δs {ds:e}, Δσ²/σ² {dv:e}; pycpd {:.1} ms",
            fixed.len(),
            moving.len(),
            peer["seconds"].as_f64().unwrap() * 1e3
        );
        assert!(ours.iterations == 40 && ours.rotation.iter().all(|v| v.is_finite()));
        worst = (worst.0.max(dr), worst.1.max(dt), worst.2.max(ds), worst.3.max(dv));
    }
    assert!(worst.0 < 5e-13 && worst.1 < 5e-14 && worst.2 < 5e-13 && worst.3 < 5e-12, "{worst:?}");
}

/// Point-to-plane ICP to convergence from the same start (6 mm and 4° off),
/// pairing the same planes (the model's normals as small_gicp estimates
/// them), on a perfect depth image: the two answers agree by ADD-S within
/// 1 mm and both lie within 3 mm of the truth.
#[test]
fn point_to_plane_icp_converges_where_small_gicp_does() {
    let mut worst = (0.0f64, 0.0f64);
    for (i, name) in ["lego_toy", "teapot", "cup", "jug", "bowl"].into_iter().enumerate() {
        let truth = pose_at(-0.02 + 0.01 * i as f64, 0.01, 1.1 * i as f64);
        let points = measured(name, &truth, 2, &DepthSensorSettings::ideal(), 21 + i as u64);
        let model = objects::object(name).unwrap().mesh.sample_surface(8000, 7 + i as u64);
        let start = truth * pose_at(0.006, -0.004, 0.07);
        let request = json!({
            "method": "icp", "model": model, "points": points, "pose": homogeneous(&start),
            "max_correspondence_distance": 0.02, "max_iterations": 100, "neighbors": 20,
        });
        let peer: Value =
            serde_json::from_str(&run_python("registration_reference.py", &[], &request.to_string())).unwrap();
        let normals: Vec<[f64; 3]> = peer["normals"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| [n[0].as_f64().unwrap(), n[1].as_f64().unwrap(), n[2].as_f64().unwrap()])
            .collect();
        let surface = SurfaceModel::new(model.clone(), normals).unwrap();
        let settings = IcpSettings {
            max_iterations: 100,
            translation_tolerance: 1e-12,
            rotation_tolerance: 1e-12,
            ..IcpSettings::default()
        };
        let ours = point_to_plane_icp(&surface, &points, &start, &settings).unwrap();
        let theirs = isometry(&peer["pose"]);
        let (dt, dr) = pose_error(&ours.pose, &theirs);
        // ADD-S between the two answers and to the truth: a bowl's turn
        // about its axis, and a cup's with its handle hidden, are free.
        let between = add_s(&model, &theirs, &ours.pose);
        let (to_truth, theirs_to_truth) = (add_s(&model, &truth, &ours.pose), add_s(&model, &truth, &theirs));
        eprintln!(
            "{name}: {} points; tandem − small_gicp ADD-S {between:.2e} m (pose {dt:.1e} m, {dr:.1e} rad; {} and {} iterations, small_gicp {:.2} ms); ADD-S to truth tandem {to_truth:.2e} m, small_gicp {theirs_to_truth:.2e} m",
            points.len(),
            ours.iterations,
            peer["iterations"],
            peer["seconds"].as_f64().unwrap() * 1e3
        );
        assert!(ours.converged, "{name}: {ours:?}");
        assert!(to_truth < 3e-3, "{name}: {to_truth} m from the truth");
        assert!(theirs_to_truth < 3e-3, "{name}: small_gicp {theirs_to_truth} m from the truth");
        // The bowl slides on itself (a smooth surface of revolution seen
        // from one side): the two optimisers stop millimetres apart there
        // (seen 2.4 mm), both near the truth.
        if name != "bowl" {
            worst = (worst.0.max(between), worst.1.max(to_truth));
        }
    }
    // Seen 4.2e-4 m (the cup): not rounding but where two optimisers of a
    // piecewise objective (pairs change as the pose moves) come to rest.
    assert!(worst.0 < 1e-3, "{worst:?}");
}

/// After its first frame the particle tracker allocates nothing, nor does
/// the sensor model writing into a reused image; the tracker holds a cup
/// it is given 6 mm and 4° off within 5 mm by ADD-S after a second.
#[test]
fn a_tracker_frame_allocates_nothing_and_holds_a_still_object() {
    use tandem::perception::{TrackSettings, Tracker};
    let cam = camera();
    let truth = pose_at(0.01, 0.0, 0.8);
    let cup = objects::object("cup").unwrap();
    let (w, h) = cam.size();
    let mut ideal = DepthImage::empty(w, h);
    let mut ws = RenderWorkspace::default();
    render_mesh(
        &cam,
        &cup.mesh,
        &truth,
        PixelWindow::full(&cam),
        &RenderSettings::default(),
        &mut ws,
        &mut ideal.depth,
    );
    let cos: Vec<f32> = ideal.depth.iter().map(|d| if d.is_finite() { 1.0 } else { f32::NAN }).collect();
    let sensor = DepthSensorSettings::default();
    let mut image = DepthImage::default();
    apply_sensor_model(&cam, &ideal, &cos, &sensor, 1, &mut image).unwrap();
    let start = truth * pose_at(0.006, -0.004, 0.07);
    let mut tracker = Tracker::new(cup.mesh.clone(), &cam, start, TrackSettings::default(), 9).unwrap();
    tracker.update(&image).unwrap();
    let before = common::alloc::allocations();
    for f in 0..9 {
        apply_sensor_model(&cam, &ideal, &cos, &sensor, 2 + f, &mut image).unwrap();
        tracker.update(&image).unwrap();
    }
    let allocated = common::alloc::allocations() - before;
    assert_eq!(allocated, 0, "{allocated} allocations in 9 frames");
    let samples = cup.mesh.sample_surface(500, 3);
    let (before, after) = (add_s(&samples, &truth, &start), add_s(&samples, &truth, &tracker.estimate()));
    eprintln!("cup: ADD-S {before:.4} m at the start, {after:.4} m after 10 frames");
    assert!(after < 0.005 && after.is_finite(), "{after}");
    // A wrong-sized image is refused.
    assert!(tracker.update(&DepthImage::empty(10, 10)).is_err());
}
