//! RRT-Connect + shortcutting + certification on the shipped problems,
//! one call per seed (cycling through 100 seeds); problem preparation (IK
//! for the grasp goal, collision models) is done once, outside the timing.

use criterion::{Criterion, criterion_group, criterion_main};
use std::hint::black_box;
use tandem::plan::{PlanStatus, ProblemPlanner};
use tandem::problem::Problem;

fn planning(c: &mut Criterion) {
    let mut group = c.benchmark_group("plan");
    group.sample_size(30);
    for name in ["panda_reach_obstacle", "panda_grasp_box"] {
        let problem = Problem::builtin(name).expect("builtin problem");
        let mut planner = ProblemPlanner::new(&problem, Some(0)).expect("planner");
        let mut seed = 0u64;
        group.bench_function(name, |b| {
            b.iter(|| {
                seed = (seed + 1) % 100;
                let report = planner.run(black_box(seed)).expect("plan");
                assert_eq!(report.result.status, PlanStatus::Solved);
                black_box(report.path.len())
            })
        });
    }
    group.finish();
}

criterion_group!(benches, planning);
criterion_main!(benches);
