//! Traded control from predicted intent (the dissertation's chapter 7,
//! Table 7.3): short seeded runs. The full run is
//! `tandem experiment traded --episodes 100` (docs/experiments.md). Checks:
//! the same results per seed whatever the thread count; the commit rule;
//! Early never starts later than Late; the CLI's JSON.
#![cfg(all(feature = "learn", feature = "cli"))]

mod common;

use std::process::Command;
use tandem::experiments::traded::{
    GraspDirection, HandUser, PlanningMode, TradedExperimentSettings, TradedResults, TradedSettings, commit,
    run_traded_experiment, synthesize_reach,
};

fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool").install(f)
}

fn small(seed: u64) -> TradedExperimentSettings {
    TradedExperimentSettings {
        episodes: 2,
        seed,
        loop_settings: TradedSettings { planning_latency: Some(0.05), ..TradedSettings::default() },
        training_per_class: 9,
        curve_demonstrations: 6,
        ..TradedExperimentSettings::default()
    }
}

/// Everything but the measured wall-clock times.
fn reproducible(r: &TradedResults) -> String {
    let rows: Vec<_> = r
        .rows
        .iter()
        .map(|row| {
            let mut row = row.clone();
            row.planning_s = [0.0; 2];
            row
        })
        .collect();
    let picks: Vec<_> =
        r.runs.iter().flat_map(|(_, e)| e.iter().map(|e| (e.mode, e.episode_seconds, e.picks.clone()))).collect();
    format!("{rows:?}\n{picks:?}\n{:?}", r.curves)
}

#[test]
fn traded_experiment_is_deterministic_per_seed_and_thread_count() {
    let one = in_pool(1, || run_traded_experiment(&small(3), &|| {}).map_err(|e| e.to_string())).expect("run");
    let two = in_pool(2, || run_traded_experiment(&small(3), &|| {}).map_err(|e| e.to_string())).expect("run");
    assert_eq!(reproducible(&one), reproducible(&two));
    let other = in_pool(2, || run_traded_experiment(&small(4), &|| {}).map_err(|e| e.to_string())).expect("run");
    assert_ne!(reproducible(&one), reproducible(&other));
    assert_eq!(one.rows.len(), 9);
    for (_, episodes) in &one.runs {
        for mode in PlanningMode::ALL {
            let of_mode: Vec<_> = episodes.iter().filter(|e| e.mode == mode).collect();
            assert_eq!(of_mode.len(), 2);
            for e in of_mode {
                assert_eq!(e.picks.len(), 3);
                // Each object picked once, in the operator's order.
                let mut objects: Vec<usize> = e.picks.iter().map(|p| p.object).collect();
                objects.sort_unstable();
                assert_eq!(objects, [0, 1, 2]);
                for p in &e.picks {
                    assert!(p.solved, "{mode:?}: plan of {p:?} failed");
                    assert!(p.cycle_seconds >= p.demonstration_seconds);
                    assert!(p.cycle_seconds > p.time_until_execution);
                }
            }
        }
    }
}

#[test]
fn early_never_starts_later_than_late() {
    let r = run_traded_experiment(&small(5), &|| {}).expect("run");
    for (_, episodes) in &r.runs {
        let early: Vec<_> = episodes.iter().filter(|e| e.mode == PlanningMode::Early).collect();
        let late: Vec<_> = episodes.iter().filter(|e| e.mode == PlanningMode::Late).collect();
        for (e, l) in early.iter().zip(&late) {
            for (pe, pl) in e.picks.iter().zip(&l.picks) {
                assert_eq!(pe.grasped, pl.grasped, "same commit rule, same target");
                assert!(pe.time_until_execution <= pl.time_until_execution + 1e-12);
                assert!(pl.time_until_execution >= pl.demonstration_seconds);
            }
        }
    }
}

#[test]
fn commit_waits_for_consecutive_predictions_after_the_discard_window() {
    let settings = TradedSettings { commit_steps: 4, discard_steps: 3, ..TradedSettings::default() };
    let (a, b) = ((0, GraspDirection::Top), (1, GraspDirection::Side));
    // Frames 0..3 are discarded, even though they agree.
    let p = [a, a, a, b, b, a, a, a, a, b];
    assert_eq!(commit(&p, &settings), (8, a));
    // Never settles: the last frame's prediction at the end.
    let q = [a, a, a, a, b, a, b, a, b];
    assert_eq!(commit(&q, &settings), (8, b));
}

#[test]
fn demonstrations_differ_by_user_but_not_by_run() {
    let objects = TradedSettings::default().objects;
    let normal = synthesize_reach(&objects, 0, GraspDirection::Side, HandUser::Normal, 11);
    let noisy = synthesize_reach(&objects, 0, GraspDirection::Side, HandUser::Noisy, 11);
    assert_eq!(normal.samples, synthesize_reach(&objects, 0, GraspDirection::Side, HandUser::Normal, 11).samples);
    assert_ne!(normal.samples, noisy.samples);
    for s in &noisy.samples {
        let n: f64 = s.palm_normal.iter().map(|v| v * v).sum();
        assert!((n - 1.0).abs() < 1e-9);
    }
}

#[test]
fn cli_prints_table_7_3_as_json() {
    let out = Command::new(env!("CARGO_BIN_EXE_tandem"))
        .args(["experiment", "traded", "--episodes", "1", "--training", "3", "--planning-latency", "0.1", "--json"])
        .current_dir(common::repo())
        .output()
        .expect("run tandem");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    assert_eq!(json["episodes"], 1);
    let rows = json["results"].as_array().expect("results");
    assert_eq!(rows.len(), 9);
    for row in rows {
        for key in ["time_until_execution_s", "episode_s"] {
            assert_eq!(row[key].as_array().map(Vec::len), Some(2), "{key}");
        }
        let acc = row["goal_accuracy"].as_f64().expect("goal accuracy");
        assert!((0.0..=1.0).contains(&acc));
    }
    let bad = Command::new(env!("CARGO_BIN_EXE_tandem"))
        .args(["experiment", "traded", "--planning-latency=-1"])
        .output()
        .expect("run tandem");
    assert_eq!(bad.status.code(), Some(2), "a value out of range is a usage error");
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--planning-latency"));
    // A huge value is quoted as typed, not as 301 digits.
    let huge = Command::new(env!("CARGO_BIN_EXE_tandem"))
        .args(["experiment", "traded", "--planning-latency", "1e300"])
        .output()
        .expect("run tandem");
    let message = String::from_utf8_lossy(&huge.stderr);
    assert_eq!(huge.status.code(), Some(2));
    assert!(message.contains("1e300 is outside the allowed range [0, 3600]") && message.len() < 400, "{message}");
}
