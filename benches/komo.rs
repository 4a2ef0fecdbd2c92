//! Trajectory optimization on the shipped problems at T = 20 and 50:
//! `optimize` times one cold solve from a fixed RRT-Connect path (planned
//! once, outside the timing); `solve_problem` times the whole pipeline
//! (IK, planning, optimization, validation between slices, and the
//! re-solve with collision rows between slices when needed).

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use tandem::komo::{Initialization, TrajectoryOptimizer, TrajectoryProblem, trajectory_solver_settings};
use tandem::pipeline::{SolveSettings, solve_problem};
use tandem::plan::plan_problem;
use tandem::problem::Problem;
use tandem_solvers::least_squares::Termination;

const PROBLEMS: [&str; 3] = ["panda_reach", "panda_reach_obstacle", "panda_grasp_box"];

fn optimize(c: &mut Criterion) {
    let mut group = c.benchmark_group("optimize");
    group.sample_size(20);
    for name in PROBLEMS {
        let problem = Problem::builtin(name).expect("builtin problem");
        let plan = plan_problem(&problem, Some(0)).expect("plan");
        for horizon in [20, 50] {
            let t = TrajectoryProblem::from_problem(&problem).and_then(|p| p.with_horizon(horizon)).expect("problem");
            let mut optimizer = TrajectoryOptimizer::new(t, trajectory_solver_settings());
            group.bench_function(format!("{name}/T{horizon}"), |b| {
                b.iter(|| {
                    let result = optimizer.solve(Initialization::Path(black_box(&plan.path))).expect("solve");
                    assert_eq!(result.report.termination, Termination::Converged);
                    black_box(result.report.cost)
                })
            });
        }
    }
    group.finish();
}

fn pipeline(c: &mut Criterion) {
    let mut group = c.benchmark_group("solve_problem");
    group.sample_size(10);
    for name in PROBLEMS {
        let problem = Problem::builtin(name).expect("builtin problem");
        for horizon in [20, 50] {
            let mut seed = 0;
            group.bench_function(format!("{name}/T{horizon}"), |b| {
                b.iter(|| {
                    seed = (seed + 1) % 20;
                    let options =
                        SolveSettings { seed: Some(seed), horizon: Some(horizon), ..SolveSettings::default() };
                    let s = solve_problem(&problem, &options).expect("solve");
                    assert!(s.converged(), "{name} T{horizon} seed {seed}: {}", s.status());
                    black_box(s.report.cost)
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, optimize, pipeline);
criterion_main!(benches);
