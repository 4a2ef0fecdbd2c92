//! One cold trajectory optimization of a shipped problem, repeated, as the
//! `optimize` group of `benches/komo.rs` runs it (RRT-Connect path of seed
//! 0, planned once; `trajectory_solver_settings`): for profiling the
//! optimizer alone, e.g. instruction counts per solve with
//!
//! ```text
//! valgrind --tool=callgrind --toggle-collect='*TrajectoryOptimizer*solve*' \
//!     target/release/examples/komo_profile panda_grasp_box 50 3
//! ```
//!
//! Prints the solver's report and an FNV-1a hash of the trajectory's bits
//! (the same on every run: solves are deterministic).

use tandem::komo::{Initialization, TrajectoryOptimizer, TrajectoryProblem, trajectory_solver_settings};
use tandem::plan::plan_problem;
use tandem::problem::Problem;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("panda_grasp_box", String::as_str);
    let horizon: usize = args.get(2).map_or(Ok(50), |s| s.parse())?;
    let reps: usize = args.get(3).map_or(Ok(1), |s| s.parse())?;
    let problem = Problem::builtin(name)?;
    let plan = plan_problem(&problem, Some(0))?;
    let problem_t = TrajectoryProblem::from_problem(&problem)?.with_horizon(horizon)?;
    let mut optimizer = TrajectoryOptimizer::new(problem_t, trajectory_solver_settings());
    for _ in 0..reps {
        let result = optimizer.solve(Initialization::Path(&plan.path))?;
        let hash = result
            .trajectory
            .iter()
            .flatten()
            .fold(0xcbf2_9ce4_8422_2325u64, |h, v| (h ^ v.to_bits()).wrapping_mul(0x0100_0000_01b3));
        let r = &result.report;
        println!(
            "{name} T{horizon}: {} outer {} inner {} evaluations {} cost {:.9e} eq {:.2e} ineq {:.2e} {:.3} ms hash {hash:016x}",
            r.termination.as_str(),
            r.outer_iterations,
            r.inner_steps,
            r.evaluations,
            r.cost,
            r.equality_violation,
            r.inequality_violation,
            r.time.as_secs_f64() * 1e3,
        );
    }
    Ok(())
}
