//! Problem-file TOML (relative paths from the working directory, the
//! shipped Panda path mapped to the embedded robot) → validated problem,
//! collision model and start check, trajectory problem with its objectives.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tandem::collision::CollisionWorkspace;
use tandem::komo::TrajectoryProblem;
use tandem::problem::Problem;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(problem) = Problem::from_str_with(text, "<fuzz>", None) else { return };
    if let Ok(model) = problem.collision_model() {
        let mut ws = CollisionWorkspace::new(&model);
        let _ = model.collision_free(&mut ws, &problem.start);
        let _ = model.min_distance(&mut ws, &problem.start);
    }
    let _ = problem.grasp_target();
    let _ = TrajectoryProblem::from_problem(&problem);
});
