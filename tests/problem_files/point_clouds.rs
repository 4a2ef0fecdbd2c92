//! (d) Point clouds in problem files: `[[scene.point_clouds]]` reads the
//! file relative to the problem, places it by the sensor's pose, thins it
//! and grows the balls by the spacing; every bad value names its key.

use super::*;
use tandem::scene::Shape;

/// An ASCII PCD of `points` (x y z per line).
fn pcd(points: &[[f64; 3]]) -> String {
    let mut text = format!(
        "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH {n}\nHEIGHT 1\n\
         VIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA ascii\n",
        n = points.len()
    );
    for p in points {
        text.push_str(&format!("{} {} {}\n", p[0], p[1], p[2]));
    }
    text
}

#[test]
fn a_point_cloud_section_places_thins_and_inflates_the_points() {
    let dir = TempDir::new().unwrap();
    // Two points 4 mm apart (one cell of a 1 cm filter) and one far off.
    let points = [[0.0, 0.0, 1.0], [0.004, 0.0, 1.0], [0.5, 0.0, 1.0]];
    std::fs::create_dir(dir.path().join("clouds")).unwrap();
    std::fs::write(dir.path().join("clouds/camera.pcd"), pcd(&points)).unwrap();
    let section = "[[scene.point_clouds]]\nname = \"camera\"\nfile = \"clouds/camera.pcd\"\npoint_radius = 0.005\n\
                   spacing = 0.01\nposition = [0.2, 0.0, 0.3]\nrpy = [0.0, 0.0, 1.5707963267948966]\n\n\
                   [[scene.point_clouds]]\nfile = \"clouds/camera.pcd\"\npoint_radius = 0.002\n";
    let path = dir.path().join("p.toml");
    std::fs::write(&path, problem(&[ROBOT, START, JOINT_GOAL, section])).unwrap();
    let p = Problem::from_file(&path).unwrap();
    let camera = p.scene.obstacle("camera").unwrap();
    let Shape::Points { points: tree, radius } = &camera.shape else { panic!("{:?}", camera.shape) };
    assert_eq!(tree.len(), 2, "the filter keeps one of the two close points");
    assert!((radius - 0.015).abs() < 1e-15, "the balls grow by the spacing: {radius}");
    // The sensor frame turned a quarter about z, then moved.
    let far = tree.points().find(|(_, i)| *i == 1).map(|(q, _)| q).unwrap();
    let world = camera.pose * nalgebra::Point3::from(far);
    assert!((world - nalgebra::Point3::new(0.2, 0.5, 1.3)).norm() < 1e-6, "{world}");
    // The second cloud, unnamed, unthinned.
    let Shape::Points { points: tree, radius } = &p.scene.obstacle("point_cloud").unwrap().shape else { panic!() };
    assert_eq!((tree.len(), *radius), (3, 0.002));
}

#[test]
fn point_cloud_errors_name_their_key() {
    let cloud = |extra: &str| format!("[[scene.point_clouds]]\nfile = \"none.ply\"\npoint_radius = 0.01\n{extra}");
    let text = problem(&[ROBOT, START, JOINT_GOAL, &cloud("")]);
    expect_problem_error(&text, "none.ply", "scene.point_clouds[0].file", "none.ply");
    let text = problem(&[ROBOT, START, JOINT_GOAL, &cloud("")]).replace("0.01", "-0.01");
    expect_problem_error(&text, "-0.01", "scene.point_clouds[0].point_radius", "must be positive");
    let text = problem(&[ROBOT, START, JOINT_GOAL, &cloud("colour = \"red\"\n")]);
    expect_problem_error(&text, "colour", "scene.point_clouds[0].colour", "unknown field `colour`");
    let text = problem(&[ROBOT, START, JOINT_GOAL, &cloud("spacing = 0.0\n")]);
    expect_problem_error(&text, "spacing", "scene.point_clouds[0].spacing", "must be positive");
}
