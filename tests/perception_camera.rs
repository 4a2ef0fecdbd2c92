//! The depth camera in MuJoCo (ray casting) against tandem's own
//! rasteriser and closed-form intersections: two independent ways to the
//! same depth image.
#![cfg(feature = "mujoco")]

use mujoco_rs::prelude::*;
use nalgebra::{IsometryMatrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use std::sync::Arc;
use tandem::perception::{DepthCamera, PixelWindow, RenderSettings, RenderWorkspace, TriangleMesh, render_mesh};
use tandem::point_cloud::CameraIntrinsics;
use tandem::sim::mujoco::{RayCastCamera, RayCastFrame};

/// An L-shaped prism (concave: its notch is inside its convex hull), 12
/// cm × 8 cm × 5 cm tall, outward counter-clockwise triangles.
fn l_prism() -> TriangleMesh {
    let outline = [[0.0, 0.0], [0.12, 0.0], [0.12, 0.03], [0.04, 0.03], [0.04, 0.08], [0.0, 0.08]];
    let n = outline.len() as u32;
    let mut v = vec![];
    for z in [0.0, 0.05] {
        for p in outline {
            v.push([p[0], p[1], z]);
        }
    }
    // Caps: the outline is counter-clockwise from above; fan it from the
    // reflex-free corner 0 is not valid for an L, so two convex pieces.
    let top = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]];
    let mut t: Vec<[u32; 3]> = vec![];
    for [a, b, c] in top {
        t.push([a + n, b + n, c + n]);
        t.push([a, c, b]);
    }
    for i in 0..n {
        let j = (i + 1) % n;
        t.push([i, j, j + n]);
        t.push([i, j + n, i + n]);
    }
    TriangleMesh::new(v, t, "L prism").unwrap()
}

fn pose7(p: &IsometryMatrix3<f64>) -> String {
    let q = UnitQuaternion::from_rotation_matrix(&p.rotation);
    let t = p.translation.vector;
    format!(r#"pos="{} {} {}" quat="{} {} {} {}""#, t.x, t.y, t.z, q.w, q.i, q.j, q.k)
}

#[test]
fn ray_cast_depth_matches_the_rasteriser_and_closed_forms() {
    let mesh = l_prism();
    let mesh_pose =
        IsometryMatrix3::from_parts(Translation3::new(-0.05, 0.02, 0.0), Rotation3::from_euler_angles(0.0, 0.0, 0.6));
    let sphere = (Vector3::new(0.12, -0.06, 0.04), 0.04);
    let vertices: Vec<String> = mesh.vertices.iter().map(|v| format!("{} {} {}", v[0], v[1], v[2])).collect();
    let faces: Vec<String> = mesh.triangles.iter().map(|t| format!("{} {} {}", t[0], t[1], t[2])).collect();
    let xml = format!(
        r#"<mujoco><asset><mesh name="l" vertex="{}" face="{}"/></asset><worldbody>
        <geom name="floor" type="box" size="0.3 0.3 0.01" pos="0 0 -0.01"/>
        <geom name="l" type="mesh" mesh="l" {}/>
        <geom name="ball" type="sphere" size="{}" pos="{} {} {}"/>
        </worldbody></mujoco>"#,
        vertices.join(" "),
        faces.join(" "),
        pose7(&mesh_pose),
        sphere.1,
        sphere.0.x,
        sphere.0.y,
        sphere.0.z
    );
    let model = Arc::new(MjModel::from_xml_string(&xml).expect("MuJoCo compiles the scene"));
    let mut data = MjData::new(model.clone());
    data.forward();
    let k =
        CameraIntrinsics { width: 160, height: 120, fx: 150.0, fy: 150.0, cx: 79.5, cy: 59.5, distortion: [0.0; 5] };
    let cam = DepthCamera::looking_at(k, [0.02, 0.0, 0.45], [0.01, 0.05, 0.0], [0.0, 1.0, 0.0]).unwrap();
    let mut rays = RayCastCamera::new(cam, 3.0);
    let mut frame = RayCastFrame::default();
    rays.render(&mut data, &mut frame);

    let id = |name: &str| model.name_to_id(MjtObjBase::mjOBJ_GEOM, name).unwrap();
    let (floor, l, ball) = (id("floor"), id("l"), id("ball"));
    let mut raster = vec![f32::NAN; 160 * 120];
    let mut ws = RenderWorkspace::default();
    render_mesh(&cam, &mesh, &mesh_pose, PixelWindow::full(&cam), &RenderSettings::default(), &mut ws, &mut raster);

    let (mut worst_mesh, mut worst_ball, mut worst_floor) = (0.0f64, 0.0f64, 0.0f64);
    let (mut mesh_pixels, mut disagree, mut notch) = (0, 0, 0);
    for v in 0..120 {
        for u in 0..160 {
            let k = v * 160 + u;
            let d = f64::from(frame.depth.depth[k]);
            let ray = cam.pose.rotation * Vector3::from(cam.ray(u as f64, v as f64));
            let eye = cam.pose.translation.vector;
            match frame.geom[k] {
                Some(g) if g == l => {
                    mesh_pixels += 1;
                    if raster[k].is_finite() {
                        worst_mesh = worst_mesh.max((d - f64::from(raster[k])).abs());
                    } else {
                        disagree += 1;
                    }
                }
                Some(g) if g == ball => {
                    // |eye + t·ray − c| = r, the nearer root.
                    let oc = eye - sphere.0;
                    let (a, b, c) = (ray.norm_squared(), oc.dot(&ray), oc.norm_squared() - sphere.1 * sphere.1);
                    let t = (-b - (b * b - a * c).sqrt()) / a;
                    worst_ball = worst_ball.max((d - t).abs());
                    assert!(raster[k].is_nan() || f64::from(raster[k]) > d - 1e-6, "the mesh in front of the ball");
                }
                Some(g) if g == floor => {
                    // The floor's top, z = 0.
                    worst_floor = worst_floor.max((d - (-eye.z / ray.z)).abs());
                    // A floor point in the L's notch: the ray went down
                    // through the L's convex hull, between its walls.
                    let p = mesh_pose.inverse() * Point3::from(eye + d * ray);
                    if (0.045..0.115).contains(&p.x) && (0.035..0.075).contains(&p.y) {
                        notch += 1;
                    }
                    if raster[k].is_finite() {
                        disagree += 1;
                    }
                }
                Some(g) => panic!("pixel ({u}, {v}) sees geom {g}"),
                None => assert!(raster[k].is_nan() && d.is_nan()),
            }
            if frame.geom[k].is_some() {
                let c = frame.cos_incidence[k];
                assert!(c.is_finite() && (0.0..=1.0 + 1e-6).contains(&c), "{c}");
            }
        }
    }
    eprintln!(
        "mesh {mesh_pixels} px, worst {worst_mesh:e} m; ball {worst_ball:e} m; floor {worst_floor:e} m; outline disagreements {disagree}; notch floor {notch} px"
    );
    assert!(mesh_pixels > 500, "{mesh_pixels}");
    // f32 depth: ~6e-8 m at 0.7 m.
    assert!(worst_mesh < 1e-6 && worst_ball < 1e-6 && worst_floor < 1e-6);
    // Only the outline may disagree on which surface a pixel sees.
    assert!(disagree * 50 < mesh_pixels, "{disagree} of {mesh_pixels}");
    // Rays meet the mesh's triangles, not its convex hull (which MuJoCo
    // collides with): the floor is seen inside the notch.
    assert!(notch > 20, "{notch} floor pixels in the notch");
}

/// The reach-and-grasp world (Panda, table, box) with a mesh beside the
/// box, seen by a D435 across the table with the arm reaching into view:
/// the mesh body sits where the rasteriser puts it, and segmentation finds
/// the box and the mesh, the arm's points removed, each segment's pixels
/// the ground truth's.
#[test]
fn the_camera_sees_the_objects_and_segmentation_separates_them_from_the_arm() {
    use tandem::collision::{CollisionModel, CollisionWorkspace};
    use tandem::perception::{DepthImage, DepthSensorSettings, SegmentSettings, apply_sensor_model, segment_objects};
    use tandem::problem::Problem;
    use tandem::sim::PhysicsSettings;
    use tandem::sim::mujoco::{GeomRole, PhysicsScene, SceneMesh};

    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let mesh = l_prism();
    let pose =
        IsometryMatrix3::from_parts(Translation3::new(0.55, -0.15, 0.0), Rotation3::from_euler_angles(0.0, 0.0, 0.3));
    let extra = [SceneMesh { name: "l", mesh: &mesh, pose, mass: 0.2 }];
    let scene = PhysicsScene::with_meshes(&problem, 0.01, &PhysicsSettings::default(), &extra).unwrap();
    assert_eq!(scene.object_names(), ["box", "l"]);
    let mut data = scene.data();
    // The arm reaching forward over the table, in the camera's view.
    let q = [0.0, 0.5, 0.0, -1.6, 0.0, 2.1, 0.785];
    scene.reset(&mut data, &q);
    data.forward();
    let cam = DepthCamera::looking_at(
        CameraIntrinsics::realsense_d435_640x480(),
        [1.15, 0.0, 0.55],
        [0.5, 0.0, 0.05],
        [0.0, 0.0, 1.0],
    )
    .unwrap();
    let mut rays = RayCastCamera::new(cam, 4.0);
    let mut frame = RayCastFrame::default();
    rays.render(&mut data, &mut frame);
    let role = |k: usize| frame.geom[k].map(|g| scene.role(g));
    let count = |r: GeomRole| (0..frame.geom.len()).filter(|&k| role(k) == Some(r)).count();
    let (robot_px, box_px, l_px) = (count(GeomRole::Robot), count(GeomRole::Object(0)), count(GeomRole::Object(1)));
    eprintln!("robot {robot_px} px, box {box_px} px, L {l_px} px, table {} px", count(GeomRole::Obstacle));
    assert!(robot_px > 2000 && box_px > 500 && l_px > 500);

    // The mesh body where the rasteriser draws the mesh at its pose.
    let mut raster = vec![f32::NAN; 640 * 480];
    render_mesh(
        &cam,
        &mesh,
        &pose,
        PixelWindow::full(&cam),
        &RenderSettings::default(),
        &mut RenderWorkspace::default(),
        &mut raster,
    );
    let worst = (0..raster.len())
        .filter(|&k| role(k) == Some(GeomRole::Object(1)) && raster[k].is_finite())
        .map(|k| (frame.depth.depth[k] - raster[k]).abs())
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-6, "{worst:e} m");

    // Through the sensor model, then segmentation with the arm filtered out.
    let mut seen = DepthImage::default();
    let settings = DepthSensorSettings::default();
    apply_sensor_model(&cam, &frame.depth, &frame.cos_incidence, &settings, 5, &mut seen).unwrap();
    let mut points = vec![];
    seen.points(&cam, &mut points);
    let collision = CollisionModel::builder(problem.robot.clone()).build().unwrap();
    let mut ws = CollisionWorkspace::new(&collision);
    let seg = SegmentSettings::for_table([-0.4, -0.8], [1.0, 0.8], 0.0);
    let (segments, report) = segment_objects(&points, Some((&collision, &mut ws, &q)), &seg).unwrap();
    eprintln!(
        "{} segments of {:?} points; {report:?}",
        segments.len(),
        segments.iter().map(|s| s.points.len()).collect::<Vec<_>>()
    );
    assert!(report.robot > 1000, "{report:?}");
    assert_eq!(segments.len(), 2);
    for (s, object) in segments.iter().zip([0, 1]) {
        let own = s.pixels.iter().filter(|&&k| role(k) == Some(GeomRole::Object(object))).count();
        assert!(own * 100 >= s.pixels.len() * 98, "segment {object}: {own} of {} pixels its own", s.pixels.len());
    }
}
