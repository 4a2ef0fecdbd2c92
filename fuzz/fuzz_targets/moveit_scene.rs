//! MoveIt planning scene YAML → scene for the MotionBenchMaker Panda (its
//! SRDF names the planning frame), collision model, check at the ready pose.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::sync::{Arc, LazyLock};
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::problem::moveit_scene_from_str;
use tandem::robot::{MeshSearchPath, RobotDescription, RobotModel, Srdf};

struct Panda {
    description: Arc<RobotDescription>,
    srdf: Srdf,
    arm: Arc<RobotModel>,
}

static PANDA: LazyLock<Panda> = LazyLock::new(|| {
    let urdf = include_str!("../../problems/motionbenchmaker/panda_spherized.urdf");
    let description = Arc::new(RobotDescription::from_urdf_str(urdf, &MeshSearchPath::default()).unwrap());
    let srdf = Srdf::from_srdf_str(include_str!("../../problems/motionbenchmaker/panda.srdf")).unwrap();
    let selection = srdf.joint_selection("panda_arm").unwrap();
    let arm = Arc::new(RobotModel::builder(description.clone()).selection(selection).build().unwrap());
    Panda { description, srdf, arm }
});

const READY: [f64; 7] = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let panda = &*PANDA;
    let Ok(read) = moveit_scene_from_str(text, "<fuzz>", &panda.description, Some(&panda.srdf)) else { return };
    let scene = read.scene;
    let Ok(model) = CollisionModel::builder(panda.arm.clone()).scene(&scene).srdf(&panda.srdf).build() else {
        return;
    };
    let mut ws = CollisionWorkspace::new(&model);
    let _ = model.collision_free(&mut ws, &READY);
    let _ = model.min_distance(&mut ws, &READY);
});
