//! The server side of `tandem serve`, per control tick: one
//! [`TeleopSession::tick`] (the arbiter's tick, the simulator's step with
//! its collision check and the task's judge, then the link poses, beliefs
//! and metric ellipsoid the page draws), and the state's JSON. Groups:
//! * `teleop/session_tick/<task>`: sum-of-squares, the operator driving
//!   at 5 cm/s toward the first goal; the episode restarts (untimed)
//!   every 150 ticks or when it ends;
//! * `teleop/state_json/<task>`: serialising one state.
//!
//! End-to-end latency over a real WebSocket: `web/bench/latency.mjs`.

use criterion::Criterion;
use std::hint::black_box;
use std::time::{Duration, Instant};
use tandem::teleop::{SessionSettings, TeleopSession, TeleopTask};

fn session(task: TeleopTask) -> (TeleopSession, [f64; 3]) {
    let session = TeleopSession::prepare(&SessionSettings::default(), task, 0).expect("the task prepares");
    let goal = session.scene().goals[0].position;
    (session, goal)
}

fn toward(from: [f64; 3], to: [f64; 3]) -> [f64; 3] {
    let d: Vec<f64> = (0..3).map(|k| to[k] - from[k]).collect();
    let n = d.iter().map(|v| v * v).sum::<f64>().sqrt().max(1e-9);
    [0.05 * d[0] / n, 0.05 * d[1] / n, 0.05 * d[2] / n]
}

fn benches(c: &mut Criterion) {
    let mut group = c.benchmark_group("teleop");
    for task in TeleopTask::ALL {
        let (mut s, goal) = session(task);
        group.bench_function(format!("session_tick/{}", task.as_str()), |b| {
            b.iter_custom(|iters| {
                let mut spent = Duration::ZERO;
                for _ in 0..iters {
                    if s.outcome().is_some() || s.state().steps >= 150 {
                        s.restart(task, 0).expect("restart");
                    }
                    let now = Instant::now();
                    s.set_command(toward(s.state().gripper, goal), now);
                    black_box(s.tick(now).expect("tick"));
                    spent += now.elapsed();
                }
                spent
            })
        });
        let state = s.state().clone();
        group.bench_function(format!("state_json/{}", task.as_str()), |b| {
            b.iter(|| serde_json::to_string(black_box(&state)).expect("json"))
        });
    }
    group.finish();
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    benches(&mut c);
    c.final_summary();
}
