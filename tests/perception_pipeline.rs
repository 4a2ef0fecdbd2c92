//! A short seeded run of the whole perception pipeline on the reach-and-
//! grasp table: objects of Table 7.1 at random upright poses, the Panda
//! reaching into view, a D435 across the table rendered by MuJoCo's rays
//! (not by the rasteriser the estimator and tracker use), the sensor
//! model, segmentation with the arm filtered out, labelling and poses by
//! ICP, *mesh_pose* by CPD, and the particle tracker for one second at
//! 10 Hz. Scores are ADD-S (eq. 7.4).
#![cfg(feature = "mujoco")]

use nalgebra::{IsometryMatrix3, Rotation3, Translation3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::perception::metrics::add_s;
use tandem::perception::{
    DepthCamera, DepthImage, DepthSensorSettings, EstimateSettings, EstimateWorkspace, ObjectLibrary, SegmentSettings,
    TrackSettings, Tracker, apply_sensor_model, catalog, detect, mesh_pose, segment_objects,
};
use tandem::point_cloud::CameraIntrinsics;
use tandem::problem::Problem;
use tandem::sim::PhysicsSettings;
use tandem::sim::mujoco::{GeomRole, PhysicsScene, RayCastCamera, RayCastFrame, SceneMesh};

/// Three objects at seeded upright poses 12 cm or more apart in the
/// region in front of the box.
fn placements(names: &[&str], seed: u64) -> Vec<IsometryMatrix3<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out: Vec<IsometryMatrix3<f64>> = vec![];
    while out.len() < names.len() {
        let (x, y) = (rng.random_range(0.45..0.7), rng.random_range(-0.3..-0.02));
        if out.iter().all(|p| (p.translation.x - x).hypot(p.translation.y - y) > 0.14) {
            let yaw = rng.random_range(0.0..std::f64::consts::TAU);
            out.push(IsometryMatrix3::from_parts(
                Translation3::new(x, y, 0.0),
                Rotation3::from_euler_angles(0.0, 0.0, yaw),
            ));
        }
    }
    out
}

#[test]
fn objects_are_found_labelled_and_tracked_on_the_table() {
    let problem = Problem::builtin("panda_grasp_box").unwrap();
    let library = ObjectLibrary::new(catalog()).unwrap();
    let cam = DepthCamera::looking_at(
        CameraIntrinsics::realsense_d435_640x480(),
        [1.15, -0.1, 0.6],
        [0.55, -0.12, 0.03],
        [0.0, 0.0, 1.0],
    )
    .unwrap();
    let q = [0.0, 0.5, 0.0, -1.6, 0.0, 2.1, 0.785];
    let collision = CollisionModel::builder(problem.robot.clone()).build().unwrap();
    let mut cws = CollisionWorkspace::new(&collision);
    let mut rays = RayCastCamera::new(cam, 4.0);
    let sensor = DepthSensorSettings::default();
    let estimate = EstimateSettings::for_table(0.0);
    let mut ews = EstimateWorkspace::default();
    let mut report = vec![];
    let trials: [&[&str]; 3] = [&["cube", "teapot", "cup"], &["sphere", "jug", "bowl"], &["lego_toy", "cup", "teapot"]];
    for (trial, names) in trials.iter().enumerate() {
        let poses = placements(names, 100 + trial as u64);
        let objects: Vec<_> = names.iter().map(|n| tandem::perception::objects::object(n).unwrap()).collect();
        let meshes: Vec<SceneMesh> = objects
            .iter()
            .zip(&poses)
            .map(|(o, p)| SceneMesh { name: o.name, mesh: &o.mesh, pose: *p, mass: o.mass_kg })
            .collect();
        let scene = PhysicsScene::with_meshes(&problem, 0.01, &PhysicsSettings::default(), &meshes).unwrap();
        let mut data = scene.data();
        scene.reset(&mut data, &q);
        data.forward();
        let mut frame = RayCastFrame::default();
        rays.render(&mut data, &mut frame);
        let mut image = DepthImage::default();
        apply_sensor_model(&cam, &frame.depth, &frame.cos_incidence, &sensor, 7 + trial as u64, &mut image).unwrap();
        let mut points = vec![];
        image.points(&cam, &mut points);
        let seg = SegmentSettings::for_table([-0.4, -0.8], [1.0, 0.8], 0.0);
        let (segments, _) = segment_objects(&points, Some((&collision, &mut cws, &q)), &seg).unwrap();
        // The problem's own box is object 0 of the scene; ours follow it.
        for s in &segments {
            let truth_of = |k: usize| frame.geom[k].map(|g| scene.role(g));
            let Some(GeomRole::Object(o)) = truth_of(s.pixels[s.pixels.len() / 2]) else { continue };
            if o == 0 {
                continue;
            }
            let (name, truth) = (names[o - 1], poses[o - 1]);
            let found = detect(s, &cam, &image, &library, &estimate, &mut ews).unwrap();
            let Some(found) = found else {
                report.push((name, None, f64::NAN, f64::NAN, f64::NAN));
                continue;
            };
            let label = library.object(found.object).name;
            if label != name {
                for k in 0..library.len() {
                    let d = tandem::perception::fit_object(s, &cam, &image, &library, k, &estimate, &mut ews).unwrap();
                    eprintln!(
                        "  {name} segment ({} points) as {}: fit {:.3}, explained {:.3}",
                        s.points.len(),
                        library.object(k).name,
                        d.fit,
                        d.explained
                    );
                }
            }
            let model = &library.surface(found.object).points()[..500];
            let truth_model = library.objects().position(|m| m.name == name).unwrap();
            let truth_points = &library.surface(truth_model).points()[..500];
            let icp_err = if label == name { add_s(model, &truth, &found.pose) } else { f64::INFINITY };
            let mesh = mesh_pose(s, &cam, &image, &library, found.object, &estimate, &mut ews).unwrap();
            let mesh_err = add_s(truth_points, &truth, &mesh.pose);
            let mut tracker =
                Tracker::new(library.object(found.object).mesh.clone(), &cam, found.pose, TrackSettings::default(), 3)
                    .unwrap();
            for f in 0..10 {
                let mut noisy = DepthImage::default();
                apply_sensor_model(
                    &cam,
                    &frame.depth,
                    &frame.cos_incidence,
                    &sensor,
                    1000 * trial as u64 + f,
                    &mut noisy,
                )
                .unwrap();
                tracker.update(&noisy).unwrap();
            }
            let track_err = add_s(truth_points, &truth, &tracker.estimate());
            report.push((name, Some(label), mesh_err, icp_err, track_err));
        }
    }
    for r in &report {
        eprintln!(
            "{:>9} as {:>9?}: ADD-S mesh (CPD) {:.4} m, ICP {:.4} m, particle 1 s {:.4} m",
            r.0, r.1, r.2, r.3, r.4
        );
    }
    assert_eq!(report.len(), 9, "every object seen in a segment of its own");
    let right = report.iter().filter(|r| r.1 == Some(r.0)).count();
    assert_eq!(right, 9, "{right} of 9 labelled right");
    assert!(report.iter().filter(|r| r.1 == Some(r.0)).all(|r| r.3 < 0.02 && r.4 < 0.02), "ICP and tracker under 2 cm");
}
