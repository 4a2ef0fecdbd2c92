//! One full arbitration tick per mode on the Panda grasp scene
//! (`builtin:panda_grasp_box`: table, box; the reference optimized, an LQR
//! tracking policy): validation, intent, the robot action, the mode's
//! metric (36 policy queries for the Hessian metric), distances of the
//! pairs within reach, the solve, the certified step.
//!
//! The ticks replay an Approach-operator episode recorded under
//! SumOfSquares, so the policies' progress, the distances and the
//! constraints are those of a real run. Groups:
//! * `arbitration/tick/<mode>`: the default settings (closed form first,
//!   then the active-set QP solver; Clarabel for `Constrained`'s cone);
//!   `learned` runs an actor of the shape in §6.5 of the dissertation (head
//!   32-32-32-2, tail 16-16-16; weights drawn at random: the cost does not
//!   depend on them);
//! * `arbitration/solver/<mode>/<backend>`: the solver forced on every tick
//!   (`closed_form_first = false`) on every row: the active set, Clarabel
//!   and, with `--features osqp`, OSQP.
//!
//! After criterion, percentile tables (median, p99, max over 20 passes of
//! the episode) are printed for every mode and backend. With `TANDEM_EXPORT_QP=FILE` the
//! forced-solve DirectControl problems (objective, every constraint row)
//! are written as JSON for `benches/peers/compare_arbitration.sh`.

#[path = "support/recorded.rs"]
mod recorded;

use criterion::Criterion;
use recorded::{Recorded, recorded_ticks};
use std::hint::black_box;
use std::time::Instant;
use tandem::arbitration::{
    Arbiter, ArbiterSettings, ArbitrationMode, GoalSettings, HumanCommand, SolverBackend, StateLayout, TickInput,
    problem_goals,
};
use tandem::learn::{ARBITRATION_FORMAT, ARBITRATION_FORMAT_VERSION, ArbitrationActor, ArbitrationMeta};
use tandem::problem::Problem;
use tandem::sim::{Approach, Episode, EpisodeSettings, TaskJudge};

struct Setup {
    problem: Problem,
    goals: Vec<tandem::arbitration::ProblemGoal>,
    ticks: Vec<Recorded>,
}

fn setup() -> Setup {
    let problem = Problem::builtin("panda_grasp_box").expect("builtin problem");
    let goals = problem_goals(&problem, &GoalSettings::default()).expect("goal references");
    let settings = ArbiterSettings { mode: ArbitrationMode::SumOfSquares, ..ArbiterSettings::default() };
    let arbiter = Arbiter::for_problem(&problem, &goals, settings).expect("arbiter");
    let episode = Episode {
        arbiter: &arbiter,
        start: &problem.start,
        target: goals[0].position,
        true_goal: 0,
        settings: EpisodeSettings::default(),
    };
    let mut judge = TaskJudge::new(&goals[0]);
    let record = episode.run(&mut arbiter.workspace(), &mut Approach::default(), &mut judge).expect("episode");
    assert!(record.steps > 0, "the recorded episode has no ticks ({})", record.outcome.as_str());
    let dt = arbiter.settings().period;
    let ticks = recorded_ticks(&record, dt);
    eprintln!("recorded {} ticks ({})", ticks.len(), record.outcome.as_str());
    Setup { problem, goals, ticks }
}

fn arbiter(s: &Setup, mode: ArbitrationMode, backend: SolverBackend, closed_form_first: bool) -> Arbiter {
    let settings = ArbiterSettings { mode, backend, closed_form_first, ..ArbiterSettings::default() };
    Arbiter::for_problem(&s.problem, &s.goals, settings).expect("arbiter")
}

/// An arbiter in `ArbitrationMode::Learned` with an actor of the dissertation's shape.
fn learned_arbiter(s: &Setup) -> Arbiter {
    let meta = ArbitrationMeta {
        format: ARBITRATION_FORMAT.into(),
        version: ARBITRATION_FORMAT_VERSION,
        layout: StateLayout { task_dims: 3, goals: s.goals.len(), length_scale: 0.1, speed_scale: 0.1 },
        head: vec![32, 32, 32, 2],
        tail: vec![16, 16, 16],
        max_command: 2.0,
        reward: "combined".into(),
        seed: 0,
        episodes: 0,
    };
    let (head, tail) = meta.layer_shapes();
    let mut x = 0.5f32;
    let mut next = || {
        x = (x * 1.618_034 + 0.31).fract();
        (x - 0.5) * 0.5
    };
    let layers: Vec<(Vec<f32>, Vec<f32>)> =
        head.iter().chain(&tail).map(|(i, o)| ((0..i * o).map(|_| next()).collect(), vec![0.0; *o])).collect();
    let actor = ArbitrationActor::from_parts(meta, &layers).expect("actor");
    arbiter(s, ArbitrationMode::DirectControl, SolverBackend::default(), true)
        .with_arbitration_policy(std::sync::Arc::new(actor))
        .and_then(|a| a.with_settings(ArbiterSettings { mode: ArbitrationMode::Learned, ..*a.settings() }))
        .expect("learned arbiter")
}

/// Runs tick `k` of the recorded episode (resetting at its start).
fn tick(a: &Arbiter, ws: &mut tandem::arbitration::ArbiterWorkspace, s: &Setup, k: usize) -> usize {
    let r = &s.ticks[k % s.ticks.len()];
    if k.is_multiple_of(s.ticks.len()) {
        a.reset(ws);
    }
    let input =
        TickInput { q: &r.q, velocity: Some(&r.velocity), command: HumanCommand::Linear(&r.command), beliefs: None };
    let out = a.tick(ws, &input);
    black_box(out.qdot[0]);
    out.diagnostics.solves as usize
}

fn backends() -> Vec<(SolverBackend, &'static str)> {
    #[allow(unused_mut)]
    let mut b = vec![(SolverBackend::ActiveSet, "active-set"), (SolverBackend::Clarabel, "clarabel")];
    #[cfg(feature = "osqp")]
    b.push((SolverBackend::Osqp, "osqp"));
    b
}

fn criterion_groups(c: &mut Criterion, s: &Setup) {
    let mut group = c.benchmark_group("arbitration/tick");
    for mode in ArbitrationMode::ALL {
        let a = arbiter(s, mode, SolverBackend::default(), true);
        let mut ws = a.workspace();
        let mut k = 0;
        group.bench_function(mode.as_str(), |b| {
            b.iter(|| {
                k += 1;
                tick(&a, &mut ws, s, k)
            })
        });
    }
    let a = learned_arbiter(s);
    let mut ws = a.workspace();
    let mut k = 0;
    group.bench_function("learned", |b| {
        b.iter(|| {
            k += 1;
            tick(&a, &mut ws, s, k)
        })
    });
    group.finish();
    let mut group = c.benchmark_group("arbitration/solver");
    for mode in ArbitrationMode::ALL {
        for (backend, name) in backends() {
            if mode.is_conic() && backend != SolverBackend::Clarabel {
                continue;
            }
            let a = arbiter(s, mode, backend, false);
            let mut ws = a.workspace();
            let mut k = 0;
            group.bench_function(format!("{mode}/{name}"), |b| {
                b.iter(|| {
                    k += 1;
                    tick(&a, &mut ws, s, k)
                })
            });
        }
    }
    group.finish();
}

/// Median, p99 and max tick times over 20 passes of the episode.
fn percentile_table(s: &Setup) {
    for (backend, name) in backends() {
        println!(
            "\n{:<32} {:>10} {:>10} {:>10} {:>10}",
            format!("mode ({name})"),
            "median µs",
            "p99 µs",
            "max µs",
            "solves"
        );
        for mode in ArbitrationMode::ALL {
            percentile_row(s, mode, backend);
        }
    }
}

fn percentile_row(s: &Setup, mode: ArbitrationMode, backend: SolverBackend) {
    let a = arbiter(s, mode, backend, true);
    let mut ws = a.workspace();
    for k in 0..s.ticks.len() {
        tick(&a, &mut ws, s, k);
    }
    let mut times = Vec::with_capacity(20 * s.ticks.len());
    let mut solves = 0;
    for k in 0..20 * s.ticks.len() {
        let began = Instant::now();
        solves += tick(&a, &mut ws, s, k);
        times.push(began.elapsed().as_secs_f64() * 1e6);
    }
    let (median, p99, max) = tandem::sim::percentiles(&times);
    println!("{:<32} {median:>10.1} {p99:>10.1} {max:>10.1} {solves:>10}", mode.as_str());
}

/// The forced-solve DirectControl problems (every row) as JSON.
fn export(s: &Setup, path: &str) {
    let a = arbiter(s, ArbitrationMode::DirectControl, SolverBackend::Clarabel, false);
    let mut ws = a.workspace();
    let mut problems = vec![];
    for (k, r) in s.ticks.iter().enumerate() {
        if k == 0 {
            a.reset(&mut ws);
        }
        let input = TickInput {
            q: &r.q,
            velocity: Some(&r.velocity),
            command: HumanCommand::Linear(&r.command),
            beliefs: None,
        };
        let out = a.tick(&mut ws, &input);
        let (qdot, fraction) = (out.qdot.to_vec(), out.diagnostics.step_fraction);
        if let (Some(p), true) = (ws.last_solve(), fraction == 1.0) {
            problems.push(serde_json::json!({"p": p.p, "q": p.q, "g": p.g, "h": p.h, "u": qdot}));
        }
    }
    let json = serde_json::json!({"n": 7, "problems": problems});
    std::fs::write(path, json.to_string()).expect("write the exported problems");
    eprintln!("exported {} problems to {path}", problems.len());
}

fn main() {
    let s = setup();
    if let Ok(path) = std::env::var("TANDEM_EXPORT_QP") {
        export(&s, &path);
        return;
    }
    let mut c = Criterion::default().configure_from_args();
    criterion_groups(&mut c, &s);
    c.final_summary();
    percentile_table(&s);
}
