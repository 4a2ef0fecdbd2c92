//! Collision meshes (STL, COLLADA) as tandem loads them against the same
//! meshes loaded by Pinocchio/coal through assimp: vertex bounds of every
//! mesh collision element, in its own frame, agree to 1e-6 m (assimp reads
//! coordinates as 32-bit floats).

mod common;

use common::{ErdRobots, run_python};
use tandem::robot::{Geometry, MeshSearchPath, RobotDescription};

fn compare(erd: &ErdRobots, robot: &str) -> (usize, f64) {
    let urdf = erd.urdf(robot);
    let desc = RobotDescription::from_urdf_file(&urdf, &MeshSearchPath::new([erd.package_dir.clone()])).unwrap();
    let request = serde_json::json!({"urdf": urdf, "package_dir": erd.package_dir});
    let reply: serde_json::Value =
        serde_json::from_str(&run_python("pin_reference.py", &["meshes"], &request.to_string())).unwrap();
    let objects = reply["objects"].as_array().unwrap();
    let mut worst = 0.0f64;
    for obj in objects {
        // Pinocchio names the k-th collision element of link L "L_k".
        let name = obj["name"].as_str().unwrap();
        let (link, k) = name.rsplit_once('_').unwrap();
        let element = &desc.link(link).unwrap_or_else(|| panic!("{robot}: no link {link}")).collisions
            [k.parse::<usize>().unwrap()];
        let Geometry::Mesh { mesh, .. } = &element.geometry else { panic!("{robot}: {name} is not a mesh here") };
        let (lo, hi) = mesh.aabb();
        for i in 0..3 {
            worst = common::worst(worst, (lo[i] - obj["min"][i].as_f64().unwrap()).abs());
            worst = common::worst(worst, (hi[i] - obj["max"][i].as_f64().unwrap()).abs());
        }
    }
    (objects.len(), worst)
}

#[test]
fn stl_and_collada_meshes_match_coal() {
    let erd = ErdRobots::load();
    for robot in ["panda", "ur10", "so100", "baxter", "tiago", "kinova", "hyq"] {
        let (count, worst) = compare(&erd, robot);
        println!("{robot}: {count} mesh elements, max |Δ bounds| = {worst:.2e} m");
        assert!(count > 0, "{robot}: no mesh compared");
        assert!(worst < 1e-6, "{robot}: mesh bounds differ by {worst:e} m");
    }
}
