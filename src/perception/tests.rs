//! The camera, the rasteriser, the sensor model, CPD and ICP on shapes
//! whose answers are known in closed form.

use super::*;
use crate::point_cloud::CameraIntrinsics;
use nalgebra::{IsometryMatrix3, Matrix3, Point3, Rotation3, Translation3, Vector3};

/// A box of half extents `h` centred at the origin, outward
/// counter-clockwise triangles.
fn box_mesh(h: [f64; 3]) -> TriangleMesh {
    let v: Vec<[f64; 3]> = (0..8)
        .map(|i| {
            [
                if i & 1 == 0 { -h[0] } else { h[0] },
                if i & 2 == 0 { -h[1] } else { h[1] },
                if i & 4 == 0 { -h[2] } else { h[2] },
            ]
        })
        .collect();
    let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
    let mut t = vec![];
    for q in quads {
        t.push([q[0], q[1], q[2]]);
        t.push([q[0], q[2], q[3]]);
    }
    TriangleMesh::new(v, t, "box").unwrap()
}

fn small_camera() -> DepthCamera {
    let k = CameraIntrinsics { width: 80, height: 60, fx: 70.0, fy: 70.0, cx: 39.5, cy: 29.5, distortion: [0.0; 5] };
    DepthCamera::looking_at(k, [0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]).unwrap()
}

/// The ray-box distance along `dir` from `o` (slab method), `None` on a miss.
fn ray_box(o: Vector3<f64>, dir: Vector3<f64>, h: [f64; 3]) -> Option<f64> {
    let (mut lo, mut hi) = (0.0f64, f64::INFINITY);
    for i in 0..3 {
        let (a, b) = ((-h[i] - o[i]) / dir[i], (h[i] - o[i]) / dir[i]);
        lo = lo.max(a.min(b));
        hi = hi.min(a.max(b));
    }
    (lo <= hi).then_some(lo)
}

#[test]
fn looking_at_builds_an_optical_frame_that_sees_its_target_at_the_image_centre() {
    let cam = small_camera();
    let r = cam.pose.rotation.matrix();
    assert!((r.determinant() - 1.0).abs() < 1e-12);
    // Looking down −z from above, up +y: optical z is −z, y (image down) is −y.
    assert!((r.column(2) - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-12);
    assert!((r.column(1) - Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-12);
    let p = cam.unproject(39.5, 29.5, 1.0);
    assert!(p.iter().all(|c| c.abs() < 1e-12), "{p:?}");
    let k = CameraIntrinsics::realsense_d435_640x480();
    assert!(DepthCamera::looking_at(k, [0.0; 3], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0]).is_err());
    assert!(DepthCamera::looking_at(k, [0.0; 3], [0.0; 3], [0.0, 0.0, 1.0]).is_err());
    let mut distorted = k;
    distorted.distortion[0] = 0.1;
    assert!(DepthCamera::new(distorted, IsometryMatrix3::identity()).is_err());
}

#[test]
fn rasterised_depth_is_the_exact_ray_intersection() {
    let cam = small_camera();
    let h = [0.2, 0.14, 0.1];
    let mesh = box_mesh(h);
    let pose =
        IsometryMatrix3::from_parts(Translation3::new(0.02, -0.01, 0.1), Rotation3::from_euler_angles(0.3, -0.2, 0.7));
    let mut depth = vec![f32::NAN; 80 * 60];
    let mut ws = RenderWorkspace::default();
    render_mesh(&cam, &mesh, &pose, PixelWindow::full(&cam), &RenderSettings::default(), &mut ws, &mut depth);
    let (mut hits, mut worst) = (0, 0.0f64);
    let inv = pose.inverse() * cam.pose;
    for v in 0..60 {
        for u in 0..80 {
            let r = cam.ray(u as f64, v as f64);
            let o = inv * Point3::origin();
            let dir = inv.rotation * Vector3::from(r);
            let truth = ray_box(o.coords, dir, h);
            let got = depth[v * 80 + u];
            match truth {
                // The ray is (x, y, 1) in the optical frame: its parameter is the depth.
                Some(t) if got.is_finite() => {
                    worst = worst.max((f64::from(got) - t).abs());
                    hits += 1;
                }
                Some(t) => {
                    // A miss only on the outline, where rounding decides.
                    let near_edge = (0..3).filter(|&i| ((o[i] + t * dir[i]).abs() - h[i]).abs() < 1e-9).count() >= 2;
                    assert!(near_edge, "pixel ({u}, {v}) should see the box at {t}");
                }
                None => assert!(got.is_nan(), "pixel ({u}, {v}) sees {got} where the ray misses"),
            }
        }
    }
    assert!(hits > 700, "{hits}");
    // f32 storage: about 6e-8 at 1 m.
    assert!(worst < 2e-7, "worst depth error {worst:e} m");
}

#[test]
fn a_window_renders_what_the_full_image_has_there() {
    let cam = small_camera();
    let mesh = box_mesh([0.05, 0.05, 0.05]);
    let pose =
        IsometryMatrix3::from_parts(Translation3::new(0.03, 0.0, 0.0), Rotation3::from_euler_angles(0.1, 0.2, 0.3));
    let mut ws = RenderWorkspace::default();
    let mut full = vec![f32::NAN; 80 * 60];
    render_mesh(&cam, &mesh, &pose, PixelWindow::full(&cam), &RenderSettings::default(), &mut ws, &mut full);
    let window = PixelWindow { u0: 30, v0: 20, u1: 55, v1: 41 };
    let mut part = vec![f32::NAN; window.width() * window.height()];
    render_mesh(&cam, &mesh, &pose, window, &RenderSettings::default(), &mut ws, &mut part);
    for v in 20..41 {
        for u in 30..55 {
            let (a, b) = (full[v * 80 + u], part[(v - 20) * 25 + (u - 30)]);
            assert!(a == b || (a.is_nan() && b.is_nan()), "({u}, {v}): {a} vs {b}");
        }
    }
}

/// A flat wall at depth `z`, facing the camera (incidence 0).
fn wall(cam: &DepthCamera, z: f32) -> (DepthImage, Vec<f32>) {
    let (w, h) = cam.size();
    (DepthImage { width: w, height: h, depth: vec![z; w * h] }, vec![1.0; w * h])
}

#[test]
fn sensor_noise_follows_the_stereo_rms_formula_and_is_quantised() {
    let k = CameraIntrinsics::realsense_d435_640x480();
    let cam = DepthCamera::new(k, IsometryMatrix3::identity()).unwrap();
    let (ideal, cos) = wall(&cam, 1.0);
    let s = DepthSensorSettings::default();
    let mut out = DepthImage::empty(0, 0);
    apply_sensor_model(&cam, &ideal, &cos, &s, 7, &mut out).unwrap();
    let values: Vec<f64> = out.depth.iter().filter(|d| d.is_finite()).map(|&d| f64::from(d)).collect();
    // The left band: f·B/z = 19.25 px of each row.
    let band = (385.0f64 * 0.05).ceil() as usize;
    assert_eq!(values.len(), (640 - band) * 480);
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let sd = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    let expected = s.depth_rms(1.0, 385.0);
    assert!((expected - 0.08 / (385.0 * 0.05)).abs() < 1e-15);
    // 1 mm rounding adds 1/12 mm² of variance; 290K samples pin the sd to 0.2 %.
    let with_rounding = (expected * expected + 1e-6 / 12.0).sqrt();
    assert!((sd / with_rounding - 1.0).abs() < 0.01, "sd {sd} against {with_rounding}");
    assert!((mean - 1.0).abs() < 1e-4, "mean {mean}");
    assert!(values.iter().all(|v| ((v * 1000.0).round() - v * 1000.0).abs() < 1e-3));
    // The same seed, the same bytes; another seed, other noise.
    let mut again = DepthImage::empty(0, 0);
    apply_sensor_model(&cam, &ideal, &cos, &s, 7, &mut again).unwrap();
    assert!(out.depth.iter().zip(&again.depth).all(|(a, b)| a.to_bits() == b.to_bits()));
    apply_sensor_model(&cam, &ideal, &cos, &s, 8, &mut again).unwrap();
    assert!(out.depth.iter().zip(&again.depth).any(|(a, b)| a.to_bits() != b.to_bits()));
}

#[test]
fn a_near_box_casts_a_stereo_shadow_of_the_disparity_gap_on_the_wall() {
    let k = CameraIntrinsics { width: 200, height: 20, fx: 100.0, fy: 100.0, cx: 99.5, cy: 9.5, distortion: [0.0; 5] };
    let cam = DepthCamera::new(k, IsometryMatrix3::identity()).unwrap();
    let (mut ideal, cos) = wall(&cam, 2.0);
    // A box face at 0.5 m over columns 100..140.
    for v in 0..20 {
        for u in 100..140 {
            ideal.depth[v * 200 + u] = 0.5;
        }
    }
    let s = DepthSensorSettings { baseline: 0.05, ..DepthSensorSettings::ideal() };
    let mut out = DepthImage::empty(0, 0);
    apply_sensor_model(&cam, &ideal, &cos, &s, 1, &mut out).unwrap();
    for v in 0..20 {
        let row = &out.depth[v * 200..(v + 1) * 200];
        // Left band: d = f·B/z = 2.5 px on the wall (columns 0, 1, 2 land left of 0).
        assert!(row[..3].iter().all(|d| d.is_nan()) && row[3].is_finite(), "{:?}", &row[..5]);
        // The shadow left of the box: disparities 10 px (box) and 2.5 px
        // (wall), a gap of 7.5: columns 93..99 hidden (u − 2.5 ≥ 100 − 10 = 90 … ).
        let hidden: Vec<usize> = (3..100).filter(|&u| row[u].is_nan()).collect();
        assert_eq!(hidden, (93..100).collect::<Vec<_>>(), "row {v}");
        assert!(row[100..140].iter().all(|d| *d == 0.5) && row[140..].iter().all(|d| *d == 2.0));
    }
}

#[test]
fn grazing_surfaces_and_the_far_side_of_edges_go_missing() {
    let k =
        CameraIntrinsics { width: 100, height: 100, fx: 100.0, fy: 100.0, cx: 49.5, cy: 49.5, distortion: [0.0; 5] };
    let cam = DepthCamera::new(k, IsometryMatrix3::identity()).unwrap();
    let (mut ideal, mut cos) = wall(&cam, 1.0);
    // Left half grazing at 80° (halfway into the 70–85° ramp), right half at 60°.
    for (k, c) in cos.iter_mut().enumerate() {
        *c = if k % 100 < 50 { 80f32.to_radians().cos() } else { 60f32.to_radians().cos() };
    }
    let s = DepthSensorSettings { edge_dropout: 0.0, ..DepthSensorSettings::ideal() };
    let s = DepthSensorSettings { grazing_start_deg: 70.0, grazing_end_deg: 85.0, ..s };
    let mut out = DepthImage::empty(0, 0);
    apply_sensor_model(&cam, &ideal, &cos, &s, 3, &mut out).unwrap();
    let missing = |range: std::ops::Range<usize>| {
        (0..100 * 100).filter(|k| range.contains(&(k % 100)) && out.depth[*k].is_nan()).count() as f64 / 5000.0
    };
    // cos-linear ramp: (cos70 − cos80)/(cos70 − cos85) = 0.6696.
    let chance =
        (70f64.to_radians().cos() - 80f64.to_radians().cos()) / (70f64.to_radians().cos() - 85f64.to_radians().cos());
    assert!((missing(0..50) - chance).abs() < 0.03, "{} vs {chance}", missing(0..50));
    assert_eq!(missing(50..100), 0.0);
    // Edges: a near square; only the far side of its outline drops, at the chance given.
    cos.iter_mut().for_each(|c| *c = 1.0);
    for v in 30..70 {
        for u in 30..70 {
            ideal.depth[v * 100 + u] = 0.5;
        }
    }
    let s = DepthSensorSettings { edge_dropout: 1.0, ..DepthSensorSettings::ideal() };
    apply_sensor_model(&cam, &ideal, &cos, &s, 3, &mut out).unwrap();
    let dropped: Vec<usize> = (0..100 * 100).filter(|k| out.depth[*k].is_nan()).collect();
    assert_eq!(dropped.len(), 4 * 40, "the 160 wall pixels bordering the square");
    assert!(dropped.iter().all(|&k| ideal.depth[k] == 1.0));
}

#[test]
fn the_sensor_refuses_images_that_do_not_fit_the_camera() {
    let cam = small_camera();
    let (ideal, cos) = wall(&cam, 1.0);
    let mut out = DepthImage::empty(0, 0);
    let s = DepthSensorSettings::default();
    let small = DepthImage { width: 10, height: 10, depth: vec![1.0; 100] };
    let e = apply_sensor_model(&cam, &small, &cos, &s, 1, &mut out).unwrap_err();
    assert!(e.to_string().contains("10 × 10"), "{e}");
    let mut negative = ideal.clone();
    negative.depth[81] = -1.0;
    let e = apply_sensor_model(&cam, &negative, &cos, &s, 1, &mut out).unwrap_err();
    assert!(e.to_string().contains("pixel (1, 1)"), "{e}");
    assert!(apply_sensor_model(&cam, &ideal, &cos[1..], &s, 1, &mut out).is_err());
    let bad = DepthSensorSettings { grazing_start_deg: 88.0, grazing_end_deg: 80.0, ..s };
    assert!(apply_sensor_model(&cam, &ideal, &cos, &bad, 1, &mut out).is_err());
    let bad = DepthSensorSettings { baseline: f64::NAN, ..s };
    assert!(apply_sensor_model(&cam, &ideal, &cos, &bad, 1, &mut out).is_err());
}

/// Points on a box's faces on a grid of `step` (m), with outward normals.
fn box_surface(h: [f64; 3], step: f64) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let (mut p, mut n) = (vec![], vec![]);
    for axis in 0..3 {
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        let (na, nb) = ((2.0 * h[a] / step).round() as i32, (2.0 * h[b] / step).round() as i32);
        for side in [-1.0, 1.0] {
            for i in 0..=na {
                for j in 0..=nb {
                    let mut q = [0.0; 3];
                    q[axis] = side * h[axis];
                    q[a] = -h[a] + 2.0 * h[a] * f64::from(i) / f64::from(na);
                    q[b] = -h[b] + 2.0 * h[b] * f64::from(j) / f64::from(nb);
                    let mut m = [0.0; 3];
                    m[axis] = side;
                    p.push(q);
                    n.push(m);
                }
            }
        }
    }
    (p, n)
}

fn moved(points: &[[f64; 3]], pose: &IsometryMatrix3<f64>) -> Vec<[f64; 3]> {
    points.iter().map(|p| (pose * Point3::from(*p)).coords.into()).collect()
}

/// Translation (m) and rotation (rad) between two poses; the angle from
/// the rotation's skew and symmetric parts, exact near zero (acos of the
/// trace is not).
fn pose_error(a: &IsometryMatrix3<f64>, b: &IsometryMatrix3<f64>) -> (f64, f64) {
    let d = a.inverse() * b;
    let m = d.rotation.matrix();
    let sin = 0.5 * Vector3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)]).norm();
    let cos = 0.5 * (m.trace() - 1.0);
    (d.translation.vector.norm(), sin.atan2(cos))
}

#[test]
fn cpd_recovers_a_rigid_motion_of_an_asymmetric_set() {
    let (model, _) = box_surface([0.04, 0.025, 0.015], 0.01);
    let truth =
        IsometryMatrix3::from_parts(Translation3::new(0.5, -0.2, 0.8), Rotation3::from_euler_angles(0.2, -0.15, 0.5));
    let fixed = moved(&model, &truth);
    let settings = CpdSettings { outlier_weight: 0.0, tolerance: 1e-12, max_iterations: 500, ..CpdSettings::default() };
    let start = (Matrix3::identity(), Vector3::new(0.5, -0.2, 0.8), 1.0);
    let mut ws = CpdWorkspace::default();
    let r = rigid_cpd(&fixed, &model, start, &settings, &mut ws).unwrap();
    let found =
        IsometryMatrix3::from_parts(Translation3::from(r.translation), Rotation3::from_matrix_unchecked(r.rotation));
    let (dt, dr) = pose_error(&found, &truth);
    assert!(dt < 1e-6 && dr < 1e-5, "{dt:e} m, {dr:e} rad after {} iterations", r.iterations);
    assert_eq!(r.scale, 1.0);
    assert!(r.variance < 1e-8, "{}", r.variance);
    // With a scale estimated it finds 1.
    let scaled = CpdSettings { estimate_scale: true, ..settings };
    let r = rigid_cpd(&fixed, &model, start, &scaled, &mut ws).unwrap();
    assert!((r.scale - 1.0).abs() < 1e-6, "{}", r.scale);
}

#[test]
fn cpd_refuses_what_it_cannot_register() {
    let mut ws = CpdWorkspace::default();
    let start = (Matrix3::identity(), Vector3::zeros(), 1.0);
    let s = CpdSettings::default();
    assert!(rigid_cpd(&[], &[[0.0; 3]], start, &s, &mut ws).is_err());
    let e = rigid_cpd(&[[0.0, f64::NAN, 0.0]], &[[0.0; 3]], start, &s, &mut ws).unwrap_err();
    assert!(e.to_string().contains("fixed point 0"), "{e}");
    let bad = CpdSettings { outlier_weight: 1.0, ..s };
    assert!(rigid_cpd(&[[0.0; 3]], &[[0.0; 3]], start, &bad, &mut ws).is_err());
    assert!(
        rigid_cpd(&[[0.0; 3]], &[[0.0; 3]], (Matrix3::identity(), Vector3::zeros(), f64::NAN), &s, &mut ws).is_err()
    );
}

#[test]
fn icp_pulls_a_displaced_box_back_onto_its_model() {
    let h = [0.04, 0.025, 0.015];
    let (model, normals) = box_surface(h, 0.002);
    let surface = SurfaceModel::new(model, normals).unwrap();
    let (measured, _) = box_surface(h, 0.0037);
    let truth =
        IsometryMatrix3::from_parts(Translation3::new(0.4, 0.1, 0.75), Rotation3::from_euler_angles(0.1, 0.3, -0.4));
    let points = moved(&measured, &truth);
    let off = IsometryMatrix3::from_parts(
        Translation3::new(0.006, -0.004, 0.003),
        Rotation3::from_euler_angles(0.05, -0.04, 0.08),
    );
    let settings = IcpSettings::default();
    let r = point_to_plane_icp(&surface, &points, &(truth * off), &settings).unwrap();
    let (dt, dr) = pose_error(&r.pose, &truth);
    // The measured grid is not the model's: the faces' planes still pin the pose.
    assert!(dt < 1e-6 && dr < 1e-5, "{dt:e} m, {dr:e} rad, {} iterations", r.iterations);
    assert!(r.converged && r.paired_fraction == 1.0 && r.rmse < 1e-6, "{r:?}");
}

#[test]
fn icp_on_a_sphere_keeps_its_free_rotation_finite_and_refuses_bad_input() {
    // A sphere pins only its centre.
    let mut pts = vec![];
    let mut nrm = vec![];
    for i in 0..40 {
        for j in 0..20 {
            let (a, b) =
                (f64::from(i) * std::f64::consts::TAU / 40.0, (f64::from(j) + 0.5) * std::f64::consts::PI / 20.0);
            let n = [b.sin() * a.cos(), b.sin() * a.sin(), b.cos()];
            pts.push(n.map(|c| 0.035 * c));
            nrm.push(n);
        }
    }
    let surface = SurfaceModel::new(pts.clone(), nrm).unwrap();
    let truth = IsometryMatrix3::from_parts(Translation3::new(0.3, 0.0, 0.7), Rotation3::identity());
    let points = moved(&pts, &truth);
    let start = IsometryMatrix3::from_parts(
        Translation3::new(0.305, 0.003, 0.698),
        Rotation3::from_euler_angles(0.3, 0.0, 0.0),
    );
    let r = point_to_plane_icp(&surface, &points, &start, &IcpSettings::default()).unwrap();
    assert!((r.pose.translation.vector - truth.translation.vector).norm() < 1e-4, "{r:?}");
    assert!(r.pose.to_homogeneous().iter().all(|v| v.is_finite()));
    assert!(point_to_plane_icp(&surface, &[], &start, &IcpSettings::default()).is_err());
    assert!(point_to_plane_icp(&surface, &[[f64::NAN; 3]], &start, &IcpSettings::default()).is_err());
    let bad = IcpSettings { max_correspondence_distance: 0.0, ..IcpSettings::default() };
    assert!(point_to_plane_icp(&surface, &points, &start, &bad).is_err());
    assert!(SurfaceModel::new(vec![[0.0; 3]], vec![[0.0; 3]]).is_err());
}

#[test]
fn segmentation_finds_one_cluster_per_object_on_the_table() {
    let k = CameraIntrinsics::realsense_d435_640x480();
    let cam = DepthCamera::looking_at(k, [0.0, -0.5, 0.6], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]).unwrap();
    let (w, h) = cam.size();
    let mut depth = vec![f32::NAN; w * h];
    let mut ws = RenderWorkspace::default();
    let full = PixelWindow::full(&cam);
    // The table: a slab whose top is z = 0; two boxes resting on it, 6 cm apart.
    let table = box_mesh([0.5, 0.5, 0.02]);
    render_mesh(
        &cam,
        &table,
        &IsometryMatrix3::translation(0.0, 0.0, -0.02),
        full,
        &RenderSettings::default(),
        &mut ws,
        &mut depth,
    );
    let boxes = [
        IsometryMatrix3::from_parts(Translation3::new(-0.06, 0.0, 0.03), Rotation3::from_euler_angles(0.0, 0.0, 0.4)),
        IsometryMatrix3::from_parts(Translation3::new(0.08, 0.05, 0.025), Rotation3::from_euler_angles(0.0, 0.0, -0.2)),
    ];
    let sizes = [[0.03, 0.02, 0.03], [0.025, 0.025, 0.025]];
    for (pose, s) in boxes.iter().zip(sizes) {
        render_mesh(&cam, &box_mesh(s), pose, full, &RenderSettings::default(), &mut ws, &mut depth);
    }
    let image = DepthImage { width: w, height: h, depth };
    let mut points = vec![];
    image.points(&cam, &mut points);
    // A few stray points floating above the table: speckle.
    points.extend([([0.2, 0.2, 0.1], 0), ([0.2, 0.201, 0.1], 1), ([0.201, 0.2, 0.1], 2)]);
    let settings = SegmentSettings::for_table([-0.4, -0.4], [0.4, 0.4], 0.0);
    let (segments, report) = segment_objects(&points, None, &settings).unwrap();
    assert_eq!(segments.len(), 2, "{report:?}");
    // The speckle, and a lone pixel or two on a side face seen edge-on
    // (its pixels land more than a cell apart).
    assert!((3..=6).contains(&report.rejected), "{report:?}");
    for s in &segments {
        // Every point belongs to one box (inside it, grown by rounding).
        let owner: Vec<usize> = s
            .points
            .iter()
            .map(|p| {
                (0..2)
                    .find(|&b| {
                        let q = boxes[b].inverse() * Point3::from(*p);
                        (0..3).all(|i| q[i].abs() <= sizes[b][i] + 1e-6)
                    })
                    .expect("a point on neither box")
            })
            .collect();
        assert!(owner.iter().all(|&o| o == owner[0]));
        assert!(s.points.len() > 200, "{}", s.points.len());
        assert_eq!(s.points.len(), s.pixels.len());
        let c = s.centroid();
        assert!((c[0] - boxes[owner[0]].translation.x).abs() < 0.03);
    }
    // The same points, the same segments.
    let (again, _) = segment_objects(&points, None, &settings).unwrap();
    assert_eq!(again, segments);
    let bad = SegmentSettings { cluster_distance: 0.0, ..settings };
    assert!(segment_objects(&points, None, &bad).is_err());
}
