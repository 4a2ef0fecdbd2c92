//! The learned robot policy: training on a tiny generated dataset
//! (deterministic per seed, whatever the thread count), the file format and
//! its errors, queries (allocation-free, the same as the training graph),
//! the policy inside the arbiter, and the CLI.

#[path = "../common/mod.rs"]
mod common;
mod rollouts;

#[global_allocator]
static GLOBAL: common::alloc::CountingAllocator = common::alloc::CountingAllocator;

use common::alloc::allocations;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Arc, OnceLock};
use tandem::arbitration::{Arbiter, ArbiterGoal, ArbiterSettings, ArbitrationMode, HumanCommand, TickInput};
use tandem::control::RobotPolicy;
use tandem::data::{GenerateSettings, Progress, generate};
use tandem::learn::evaluate::{RolloutSettings, Task};
use tandem::learn::{
    Demonstrations, FORMAT_VERSION, LearnError, LearnSettings, LearnedPolicy, PolicyNetwork, TrainSettings, train_on,
};
use tandem::problem::ProblemFamily;

fn family_path() -> PathBuf {
    common::repo().join("problems/panda_grasp_family.toml")
}

fn family() -> ProblemFamily {
    ProblemFamily::from_file(family_path()).unwrap()
}

/// 24 grasp trajectories (seed 3), generated once per test binary.
fn tiny_dataset() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let settings = GenerateSettings { count: 24, seed: 3, chunk_size: 12, ..GenerateSettings::default() };
        let summary = generate(&family_path(), dir.path(), &settings, &Progress::quiet()).unwrap();
        assert!(summary.manifest.accepted >= 20, "{} of 24 accepted", summary.manifest.accepted);
        dir
    })
    .path()
}

fn tiny_options(seed: u64) -> LearnSettings {
    LearnSettings {
        train: TrainSettings { epochs: 4, seed, hidden: vec![24, 24], batch: 128, ..TrainSettings::default() },
        validation: 0.2,
        ..LearnSettings::default()
    }
}

fn tiny_policy(seed: u64) -> PolicyNetwork {
    let demos = Demonstrations::read(tiny_dataset()).unwrap();
    train_on(&demos, &family(), &tiny_options(seed), None).unwrap().0
}

#[test]
fn training_is_deterministic_per_seed_and_learns() {
    let demos = Demonstrations::read(tiny_dataset()).unwrap();
    assert!(demos.items.len() >= 20);
    let lengths: Vec<usize> = demos.items.iter().map(|d| d.states.len()).collect();
    assert!(lengths.iter().all(|n| *n == 51), "q_0 … q_50 per trajectory: {lengths:?}");
    let (a, report) = train_on(&demos, &family(), &tiny_options(7), None).unwrap();
    let b = tiny_policy(7);
    let c = tiny_policy(8);
    assert_eq!(a.to_bytes().unwrap(), b.to_bytes().unwrap(), "same seed, same bytes");
    assert_ne!(a.to_bytes().unwrap(), c.to_bytes().unwrap(), "another seed, other weights");
    // The split is by sample id: every pair of a trajectory on one side.
    // One perturbed state per demonstrated state in the training split
    // (the default augmentation), none in validation.
    assert_eq!(report.train_pairs, 2 * 51 * report.train_trajectories);
    assert_eq!(report.validation_pairs, 51 * report.validation_trajectories);
    assert!(report.validation_trajectories > 0 && report.train_trajectories > report.validation_trajectories);
    let (first, last) = (report.losses[0], report.losses[report.losses.len() - 1]);
    assert!(last.train < 0.7 * first.train, "training loss {} -> {}", first.train, last.train);
    assert!(last.validation.is_finite() && last.validation < first.validation);
    let meta = a.meta();
    assert_eq!(meta.static_obstacles, vec!["table".to_string()]);
    assert_eq!(meta.joints.len(), 7);
    assert!((meta.time_step - 0.08).abs() < 1e-12, "4 s over 50 slices");
}

/// Keeps (possibly changed: shape, bytes) or drops (None) a named tensor.
type TensorEdit = dyn Fn(&str, Vec<usize>, Vec<u8>) -> Option<(Vec<usize>, Vec<u8>)>;

#[test]
fn files_round_trip_and_bad_files_are_named() {
    let network = tiny_policy(1);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("policy.safetensors");
    network.save(&path).unwrap();
    let loaded = PolicyNetwork::load(&path).unwrap();
    assert_eq!(loaded, network);
    // A robot policy given where an arbitration actor goes says what it is
    // (it said "missing field `layout`").
    let e = tandem::learn::ArbitrationActor::load(&path).unwrap_err().to_string();
    assert!(e.contains("this file is a learned robot policy (`tandem learn policy`"), "{e}");
    assert!(e.contains("not a tandem arbitration actor"), "{e}");

    let bad = |bytes: &[u8]| {
        let p = dir.path().join("bad.safetensors");
        std::fs::write(&p, bytes).unwrap();
        PolicyNetwork::load(&p).unwrap_err()
    };
    assert!(matches!(bad(b"not a tensor file"), LearnError::NotSafetensors { .. }));
    assert!(matches!(PolicyNetwork::load(&dir.path().join("missing.safetensors")), Err(LearnError::Io { .. })));
    // Tensors without tandem's metadata.
    let plain = safetensors::serialize(
        [("x", safetensors::tensor::TensorView::new(safetensors::Dtype::F32, vec![1], &[0u8; 4]).unwrap())],
        None,
    )
    .unwrap();
    let e = bad(&plain);
    assert!(matches!(&e, LearnError::Metadata { message, .. } if message.contains("not a tandem policy")), "{e}");

    // Edit the file: drop a tensor, change a shape, poison a value, bump the version.
    let bytes = std::fs::read(&path).unwrap();
    let file = safetensors::SafeTensors::deserialize(&bytes).unwrap();
    let (_, header) = safetensors::SafeTensors::read_metadata(&bytes).unwrap();
    let meta = header.metadata().clone().unwrap();
    let rebuild = |edit: &TensorEdit, meta_text: &str| {
        let mut owned = Vec::new();
        for name in file.names() {
            let view = file.tensor(name).unwrap();
            if let Some((shape, data)) = edit(name, view.shape().to_vec(), view.data().to_vec()) {
                owned.push((name.to_string(), shape, data));
            }
        }
        let views: Vec<_> = owned
            .iter()
            .map(|(n, s, d)| {
                (n.clone(), safetensors::tensor::TensorView::new(safetensors::Dtype::F32, s.clone(), d).unwrap())
            })
            .collect();
        let info = std::collections::HashMap::from([("tandem".to_string(), meta_text.to_string())]);
        safetensors::serialize(views, Some(info)).unwrap()
    };
    let text = meta["tandem"].clone();
    let keep = |_: &str, s: Vec<usize>, d: Vec<u8>| Some((s, d));
    assert_eq!(PolicyNetwork::from_bytes(&rebuild(&keep, &text), &path).unwrap(), network);
    let e = bad(&rebuild(&|n, s, d| (n != "layers.1.bias").then_some((s, d)), &text));
    assert!(matches!(&e, LearnError::MissingTensor { name, .. } if name == "layers.1.bias"), "{e}");
    let e = bad(&rebuild(
        &|n, s, d| if n == "input_std" { Some((vec![s[0] - 1], d[4..].to_vec())) } else { Some((s, d)) },
        &text,
    ));
    assert!(matches!(&e, LearnError::TensorShape { name, .. } if name == "input_std"), "{e}");
    let e = bad(&rebuild(
        &|n, s, mut d| {
            if n == "layers.0.weight" {
                d[..4].copy_from_slice(&f32::NAN.to_le_bytes());
            }
            Some((s, d))
        },
        &text,
    ));
    assert!(matches!(&e, LearnError::NonFinite { name, .. } if name == "layers.0.weight"), "{e}");
    let e = bad(&rebuild(&keep, &text.replace(&format!("\"version\":{FORMAT_VERSION}"), "\"version\":99")));
    assert!(matches!(&e, LearnError::Metadata { message, .. } if message.contains("version 99")), "{e}");
    let e = bad(&rebuild(&keep, &text.replace("\"hidden\":[24,24]", "\"hidden\":[24,25]")));
    assert!(matches!(&e, LearnError::TensorShape { name, .. } if name.starts_with("layers.1")), "{e}");

    // A policy for another robot.
    let planar = tandem::problem::Problem::from_file(common::repo().join("problems/planar_pick.toml")).unwrap();
    let e = LearnedPolicy::for_problem(Arc::new(network), &planar).unwrap_err();
    assert!(matches!(&e, LearnError::Mismatch { what, .. } if what == "active joints"), "{e}");
}

#[test]
fn dataset_errors_name_the_folder() {
    let empty = tempfile::tempdir().unwrap();
    let e = Demonstrations::read(empty.path()).unwrap_err();
    assert!(e.to_string().contains("no part-*.parquet"), "{e}");
    std::fs::write(empty.path().join("part-00000.parquet"), b"garbage").unwrap();
    let e = Demonstrations::read(empty.path()).unwrap_err();
    assert!(matches!(&e, LearnError::Dataset { path, .. } if path.ends_with("part-00000.parquet")), "{e}");
    assert!(matches!(Demonstrations::read(&empty.path().join("nope")), Err(LearnError::Io { .. })));
}

/// Every compiled variant of the hand-written forward pass (portable, AVX2,
/// AVX-512 where the CPU has them) equals candle's forward pass — the
/// training graph — to 1e-5 on random inputs, for a trained network, the
/// default architecture with random weights, and odd widths around the
/// kernels' blocks; and runs without allocating. Observed: at most 1.6e-6
/// relative (f32 sums in another order), against the bound of 1e-5.
#[test]
fn every_forward_variant_matches_candle() {
    use rand::{RngExt, SeedableRng};
    use tandem::collision::SimdLevel;
    use tandem::learn::{CandleNetwork, PolicyMeta};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let trained = tiny_policy(3);
    let random = |hidden: Vec<usize>, rng: &mut rand_chacha::ChaCha8Rng| {
        let meta = PolicyMeta { hidden, ..trained.meta().clone() };
        let d = meta.input_width();
        let (mut weights, mut biases) = (vec![], vec![]);
        for (inputs, outputs) in meta.layer_shapes() {
            let bound = (6.0 / inputs as f64).sqrt() as f32;
            weights.push((0..inputs * outputs).map(|_| rng.random_range(-bound..bound)).collect::<Vec<f32>>());
            biases.push((0..outputs).map(|_| rng.random_range(-0.1f32..0.1)).collect::<Vec<f32>>());
        }
        let mean = (0..d).map(|_| rng.random_range(-1.0f32..1.0)).collect();
        let std = (0..d).map(|_| rng.random_range(0.1f32..2.0)).collect();
        PolicyNetwork::from_parts(meta, mean, std, &weights, &biases).unwrap()
    };
    let networks = [trained.clone(), random(vec![128, 128, 128], &mut rng), random(vec![37, 9, 17], &mut rng)];
    for mut network in networks {
        let d = network.meta().input_width();
        let n = network.meta().dof() + 1;
        // Inputs within three standard deviations of the normalisation's mean.
        let (mean, std) = network.normalisation();
        let inputs: Vec<f32> =
            (0..200 * d).map(|i| mean[i % d] + std[i % d] * rng.random_range(-3.0f32..3.0)).collect();
        let expected = CandleNetwork::new(&network).unwrap().forward(&inputs).unwrap();
        assert_eq!(expected.len(), 200 * n);
        for level in SimdLevel::available() {
            assert_eq!(network.set_simd(level), level);
            let mut scratch = network.scratch();
            let mut out = vec![0.0f32; n];
            let before = allocations();
            let mut worst = 0.0f32;
            for (row, want) in inputs.chunks_exact(d).zip(expected.chunks_exact(n)) {
                network.forward(row, &mut scratch, &mut out);
                for (got, want) in out.iter().zip(want) {
                    assert!(got.is_finite(), "{level:?}");
                    worst = worst.max((got - want).abs() / (1.0 + want.abs()));
                }
            }
            assert_eq!(allocations() - before, 0, "{level:?} forward passes allocate");
            assert!(worst <= 1e-5, "{level:?} {:?}: off by {worst:e}", network.meta().hidden);
        }
    }
}

#[test]
fn queries_allocate_nothing_and_feed_the_arbiter() {
    let network = Arc::new(tiny_policy(2));
    let family = family();
    let problem = family.sample(11, 0).unwrap().problem;
    let policy = Arc::new(LearnedPolicy::for_problem(network.clone(), &problem).unwrap());
    let mut state = policy.new_workspace();
    let (zero, mut act, mut probe) = (vec![0.0; 7], vec![0.0; 7], vec![0.0; 7]);
    policy.act(&mut state, &problem.start, &zero, &mut act).unwrap();
    let mut q = problem.start.clone();
    let before = allocations();
    for k in 0..100 {
        q.copy_from_slice(&problem.start);
        q[k % 7] += 1e-3 * k as f64;
        policy.act(&mut state, &q, &zero, &mut act).unwrap();
        policy.probe(&mut state, &q, &zero, &mut probe).unwrap();
        assert_eq!(act, probe, "the policy has no memory: act and probe agree");
    }
    assert_eq!(allocations() - before, 0, "learned policy queries allocate");
    assert!(act.iter().all(|v| v.is_finite()));
    let speed = act.iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!(speed < 10.0, "{speed} rad/s");
    // Bad inputs are errors, not panics.
    assert!(policy.act(&mut state, &[0.0; 3], &zero, &mut act).is_err());
    assert!(policy.act(&mut state, &[f64::NAN; 7], &zero, &mut act).is_err());

    // The arbiter queries it (actions and the 36-query metric) in the
    // modes that use a metric.
    let task = Task::new(problem.clone(), RolloutSettings::default().max_tilt).unwrap();
    let target = problem.grasp_target().unwrap().translation.vector;
    for mode in [ArbitrationMode::Constrained, ArbitrationMode::SumOfSquares] {
        let goal = ArbiterGoal { name: "box".into(), position: target.into(), policy: policy.clone() };
        let settings = ArbiterSettings { mode, ..ArbiterSettings::default() };
        let arbiter = Arbiter::new(task.collision_model().clone(), task.gripper_name(), vec![goal], settings).unwrap();
        let mut ws = arbiter.workspace();
        let command = [0.05, 0.0, -0.05];
        let input =
            TickInput { q: &problem.start, velocity: None, command: HumanCommand::Linear(&command), beliefs: None };
        let out = arbiter.tick(&mut ws, &input);
        assert!(out.qdot.iter().all(|v| v.is_finite()), "{mode:?}: {:?}", out.status);
        assert!(!matches!(out.status, tandem::arbitration::TickStatus::PolicyFailed), "{mode:?}: {:?}", out.status);
    }
}

/// Training killed with SIGKILL after a checkpoint and started again with
/// the same command ends with the same weights, bit for bit, as a run never
/// stopped; the checkpoint is gone afterwards, and a checkpoint of other
/// settings is refused by name.
/// Mean relative squared error of `network`'s slopes against the tracking
/// policy's on `pairs`' perturbed rows: `Σ‖s_net − s‖² / Σ‖s‖²`.
fn slope_error(network: &PolicyNetwork, pairs: &tandem::learn::Pairs) -> f64 {
    let (d, n) = (pairs.input_width, pairs.dof);
    let mut scratch = network.scratch();
    let mut velocity = |r: usize| {
        let (mut out, mut v) = (vec![0.0f32; n + 1], vec![0.0; n]);
        network.forward(&pairs.inputs[r * d..(r + 1) * d], &mut scratch, &mut out);
        network.velocity_from_outputs(&out, &mut v);
        v
    };
    let (mut error, mut norm) = (0.0, 0.0);
    for (k, [perturbed, demonstrated]) in pairs.slope_rows.iter().enumerate() {
        let (a, b) = (velocity(*perturbed), velocity(*demonstrated));
        let inverse = f64::from(pairs.slope_inverse_lengths[k]);
        for j in 0..n {
            let target = f64::from(pairs.slopes[k * n + j]);
            error += ((a[j] - b[j]) * inverse - target).powi(2);
            norm += target * target;
        }
    }
    error / norm
}

/// Sobolev training: with the slope term, the network's action changes
/// around held-out demonstrations follow the LQR tracking policy's closer
/// than with the dissertation's loss alone, and its actions stay as good.
#[test]
fn slope_training_follows_the_tracking_policys_slopes() {
    let demos = Demonstrations::read(tiny_dataset()).unwrap();
    let train = |slope_weight: f64| {
        let mut options = tiny_options(5);
        options.train.epochs = 12;
        options.train.slope_weight = slope_weight;
        train_on(&demos, &family(), &options, None).unwrap()
    };
    let ((plain, plain_report), (sobolev, sobolev_report)) = (train(0.0), train(1.0));
    let meta = sobolev.meta();
    let base = &family().base;
    let static_obstacles = meta.static_obstacles.clone();
    let view = tandem::learn::InputView {
        gripper: &meta.gripper,
        static_obstacles: &static_obstacles,
        slots: meta.obstacle_slots,
        frames: &meta.obstacle_frames,
    };
    let around = tandem::learn::Augmentation { per_state: 2, seed: 99, ..Default::default() };
    let held_out = demos.pairs(&base.robot, &view, &around, |id| tandem::learn::in_validation(id, 0.2)).unwrap();
    assert!(held_out.slope_rows.len() > 300, "{} held-out slopes", held_out.slope_rows.len());
    let (plain_error, sobolev_error) = (slope_error(&plain, &held_out), slope_error(&sobolev, &held_out));
    assert!(plain_error.is_finite() && sobolev_error.is_finite());
    assert!(sobolev_error < 0.8 * plain_error, "slope error {sobolev_error} with the term, {plain_error} without");
    let validation = |r: &tandem::learn::TrainReport| r.losses.last().unwrap().validation;
    assert!(
        validation(&sobolev_report) < 1.5 * validation(&plain_report),
        "validation loss {} with the slope term, {} without",
        validation(&sobolev_report),
        validation(&plain_report)
    );
    eprintln!(
        "held-out slope error {sobolev_error:.3} (term) vs {plain_error:.3}; validation {:.4} vs {:.4}",
        validation(&sobolev_report),
        validation(&plain_report)
    );
}

#[test]
fn training_killed_and_resumed_gives_the_same_weights() {
    let dir = tempfile::tempdir().unwrap();
    let data = tiny_dataset().to_str().unwrap().to_string();
    let command = |out: &Path, epochs: &str| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_tandem"));
        cmd.args(["learn", "policy", "--data", &data, "--epochs", epochs, "--hidden", "32,32", "--batch", "16"])
            .args(["--quiet", "--out"])
            .arg(out)
            .current_dir(common::repo());
        cmd
    };
    let whole = dir.path().join("whole.safetensors");
    let output = command(&whole, "40").arg("--no-checkpoint").output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));

    let killed = dir.path().join("killed.safetensors");
    let checkpoint = killed.with_extension("checkpoint");
    let mut child = command(&killed, "40").spawn().unwrap();
    let began = std::time::Instant::now();
    while !checkpoint.exists() {
        assert!(began.elapsed().as_secs() < 120, "no checkpoint within 2 minutes");
        assert!(child.try_wait().unwrap().is_none(), "training ended before its first checkpoint was seen");
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL on Unix
    child.wait().unwrap();
    assert!(!killed.exists(), "the run ended before the kill; the test proves nothing");
    assert!(checkpoint.exists());
    // Another number of epochs is another run: its checkpoint is refused.
    let output = command(&killed, "41").output().unwrap();
    assert_eq!(output.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("training checkpoint") && stderr.contains("other data or settings"), "{stderr}");
    let output = command(&killed, "40").output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    assert_eq!(std::fs::read(&killed).unwrap(), std::fs::read(&whole).unwrap(), "resumed weights differ");
    assert!(!checkpoint.exists(), "the checkpoint outlived the run");
    let losses = |path: &Path| -> serde_json::Value {
        serde_json::from_slice::<serde_json::Value>(&std::fs::read(path.with_extension("json")).unwrap()).unwrap()
            ["losses"]
            .clone()
    };
    assert_eq!(losses(&killed), losses(&whole), "the report keeps every epoch's losses");
}

#[test]
fn cli_trains_the_same_bytes_on_one_or_two_threads_and_runs_the_experiment() {
    let dir = tempfile::tempdir().unwrap();
    let data = tiny_dataset().to_str().unwrap().to_string();
    let train = |threads: &str, out: &Path| {
        let output = Command::new(env!("CARGO_BIN_EXE_tandem"))
            .args(["learn", "policy", "--data", &data, "--epochs", "2", "--hidden", "16,16", "--quiet", "--out"])
            .arg(out)
            .env("RAYON_NUM_THREADS", threads)
            .current_dir(common::repo())
            .output()
            .unwrap();
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        std::fs::read(out).unwrap()
    };
    let one = train("1", &dir.path().join("one.safetensors"));
    let two = train("2", &dir.path().join("two.safetensors"));
    assert_eq!(one, two, "the weights do not depend on the thread count");
    assert!(dir.path().join("one.json").exists() && dir.path().join("one.svg").exists());

    let output = Command::new(env!("CARGO_BIN_EXE_tandem"))
        .args(["experiment", "policy", "--tasks", "3", "--arbitration-tasks", "1", "--json", "--data", &data])
        .arg("--policy")
        .arg(dir.path().join("one.safetensors"))
        .arg("--out")
        .arg(dir.path().join("experiment"))
        .current_dir(common::repo())
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(json["tasks"], 3);
    let results = json["results"].as_array().unwrap();
    assert_eq!(results.len(), 2);
    for (r, name) in results.iter().zip(["learned", "lqr"]) {
        assert_eq!(r["policy"], name);
        let sum: f64 =
            ["success", "collision", "timeout", "no_reference", "failed"].iter().map(|k| r[*k].as_f64().unwrap()).sum();
        assert!((sum - 1.0).abs() < 1e-12, "{r}");
    }
    assert_eq!(
        json["training"]["samples"].as_u64().unwrap() as usize,
        json["training"]["pairs"].as_u64().unwrap() as usize / (2 * 51)
    );
    assert!(json["training"]["seconds"].as_f64().unwrap() > 0.0);
    for (policy, r) in ["learned", "lqr"].iter().zip(results) {
        let failures = &json["failures"][policy];
        let by_reason: u64 = failures["reasons"].as_object().unwrap().values().map(|v| v.as_u64().unwrap()).sum();
        assert_eq!(by_reason, 3, "{failures}");
        let collisions = (r["collision"].as_f64().unwrap() * 3.0).round() as u64;
        let by_phase: u64 =
            failures["collision_phases"].as_object().unwrap().values().map(|v| v.as_u64().unwrap()).sum();
        assert_eq!(by_phase, collisions, "{failures}");
    }
    // rollouts.csv: every rollout, task by task, agreeing with the rates,
    // the breakdown and the paired counts of the JSON.
    let csv = std::fs::read_to_string(dir.path().join("experiment").join("rollouts.csv")).unwrap();
    // Read as RFC 4180 says, as a user's CSV reader would (pair names may be quoted).
    let records = tandem::files::csv::records(&csv).unwrap();
    let header = ["task", "policy", "outcome", "reason", "phase", "link", "body", "steps", "clamped", "distance_m"];
    assert_eq!(records[0].fields, header);
    let rows: Vec<Vec<&str>> = records[1..].iter().map(|r| r.fields.iter().map(String::as_str).collect()).collect();
    assert_eq!(rows.len(), 6, "3 tasks × 2 policies:\n{csv}");
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row.len(), 10, "{row:?}");
        assert_eq!((row[0], row[1]), (["0", "1", "2"][i / 2], ["learned", "lqr"][i % 2]), "{row:?}");
        let collided = row[2] == "collision";
        assert_eq!(collided, !row[4].is_empty() && !row[5].is_empty() && !row[6].is_empty(), "{row:?}");
        assert!(row[7].parse::<usize>().is_ok() && row[8].parse::<usize>().is_ok(), "{row:?}");
        if row[2] != "no_policy" {
            assert!(row[9].parse::<f64>().unwrap().is_finite(), "{row:?}");
        }
    }
    for (policy, r) in ["learned", "lqr"].iter().zip(results) {
        for (outcome, key) in [("success", "success"), ("collision", "collision"), ("no_policy", "no_reference")] {
            let n = rows.iter().filter(|row| row[1] == *policy && row[2] == outcome).count();
            assert_eq!(n as f64 / 3.0, r[key].as_f64().unwrap(), "{policy} {outcome}");
        }
        for (reason, n) in json["failures"][policy]["reasons"].as_object().unwrap() {
            let reason = if reason == "no_policy" { "" } else { reason.as_str() };
            let counted = rows.iter().filter(|row| row[1] == *policy && row[3] == reason).count();
            assert_eq!(Some(counted as u64), n.as_u64(), "{policy} {reason}");
        }
    }
    let succeeded = |task: &str, policy: &str| rows.iter().any(|r| r[0] == task && r[1] == policy && r[2] == "success");
    let mut paired = [0u64; 4];
    for task in ["0", "1", "2"] {
        paired[match (succeeded(task, "learned"), succeeded(task, "lqr")) {
            (true, true) => 0,
            (true, false) => 1,
            (false, true) => 2,
            (false, false) => 3,
        }] += 1;
    }
    let reported: Vec<u64> =
        ["both", "learned_only", "lqr_only", "neither"].iter().map(|k| json["paired"][*k].as_u64().unwrap()).collect();
    assert_eq!(reported, paired, "{}", json["paired"]);
    assert_eq!(json["arbitration"].as_array().unwrap().len(), 4);
    for figure in ["joint_histograms.svg", "success_by_distance.svg"] {
        let svg = std::fs::read_to_string(dir.path().join("experiment").join(figure)).unwrap();
        assert!(svg.contains("<svg"), "{figure}");
    }
    let bad = Command::new(env!("CARGO_BIN_EXE_tandem"))
        .args(["experiment", "policy", "--tasks", "1", "--data", &data, "--policy", "Cargo.toml", "--out"])
        .arg(dir.path().join("bad"))
        .current_dir(common::repo())
        .output()
        .unwrap();
    assert!(!bad.status.success());
    let stderr = String::from_utf8_lossy(&bad.stderr);
    assert!(stderr.contains("Cargo.toml") && stderr.contains("safetensors"), "{stderr}");

    // Without --policy: the shipped policy; DAgger needs the data.
    let shipped = |extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_tandem"))
            .args(["experiment", "policy", "--tasks", "3", "--arbitration-tasks", "0", "--no-lqr", "--json"])
            .args(extra)
            .arg("--out")
            .arg(dir.path().join("shipped"))
            .current_dir(common::repo())
            .output()
            .unwrap()
    };
    let output = shipped(&[]);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let json: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(json["policy"], "shipped");
    assert_eq!(json["results"].as_array().unwrap().len(), 1);
    assert!(json["paired"].is_null(), "no LQR policy to pair with: {}", json["paired"]);
    let csv = std::fs::read_to_string(dir.path().join("shipped").join("rollouts.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 3, "{csv}");
    assert!(csv.lines().skip(1).all(|l| l.split(',').nth(1) == Some("learned")), "{csv}");
    // Its training figures come from the provenance.
    let provenance: serde_json::Value = serde_json::from_str(tandem::learn::SHIPPED_POLICY_PROVENANCE).unwrap();
    for (key, recorded) in [("samples", "trajectories"), ("pairs", "pairs"), ("seconds", "seconds")] {
        assert_eq!(json["training"][key], provenance["training"][recorded], "{key}");
    }
    // The training split of the 100K dataset, as the network's file says.
    let trained_on = tandem::learn::shipped_policy().unwrap().meta().trajectories as u64;
    assert_eq!(json["training"]["samples"].as_u64(), Some(trained_on));
    assert!(trained_on > 80_000, "{trained_on}");
    let output = shipped(&["--rounds", "1"]);
    assert_eq!(output.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("--rounds") && stderr.contains("--data"), "{stderr}");
}

/// Obstacle frames: each slot also holds the obstacle's centre relative
/// to each frame's origin, computed here from the robot's own forward
/// kinematics; a policy trained with them keeps them in its file, queries
/// without allocating, and DAgger-style continuation keeps its input. A
/// frame the robot lacks and too many frames are refused by name.
#[test]
fn obstacle_frames_place_each_obstacle_relative_to_the_links() {
    let family = family();
    let demos = Demonstrations::read(tiny_dataset()).unwrap();
    let robot = &family.base.robot;
    let frames = vec!["panda_link4".to_string(), "panda_link5".to_string()];
    let static_obstacles: Vec<String> = family.base.scene.obstacles().iter().map(|o| o.name.clone()).collect();
    let view = |frames: &'static [String]| tandem::learn::InputView {
        gripper: "panda_hand_tcp",
        static_obstacles: static_obstacles.clone().leak(),
        slots: 2,
        frames,
    };
    let none = tandem::learn::Augmentation::default();
    let plain = demos.pairs(robot, &view(&[]), &none, |_| true).unwrap();
    let wide = demos.pairs(robot, &view(frames.clone().leak()), &none, |_| true).unwrap();
    assert_eq!(wide.input_width, plain.input_width + 2 * 6);
    assert_eq!(wide.len(), plain.len());
    let d = &demos.items[0];
    let goal = d.goal(&static_obstacles, 2);
    assert!(!goal.obstacles.is_empty(), "the first demonstration has a random obstacle");
    let mut ws = tandem::robot::KinematicsWorkspace::new(robot);
    let last = d.states.len() - 1;
    for (row, q) in [(0, &d.states[0]), (last, &d.states[last])] {
        robot.forward_kinematics(&mut ws, q).unwrap();
        let (p, w) = (&plain.inputs[row * plain.input_width..], &wide.inputs[row * wide.input_width..]);
        let base = plain.input_width - 2 * 7;
        assert_eq!(p[..base], w[..base], "the values before the slots do not change");
        for (k, obstacle) in goal.obstacles.iter().enumerate() {
            let slot = &w[base + 13 * k..base + 13 * (k + 1)];
            assert_eq!(slot[..7], p[base + 7 * k..base + 7 * (k + 1)], "slot {k}'s first values");
            for (f, name) in frames.iter().enumerate() {
                let origin = robot.frame_pose(&ws, robot.frame_id(name).unwrap()).translation.vector;
                for i in 0..3 {
                    let expected = obstacle.center[i] - origin[i];
                    let got = f64::from(slot[7 + 3 * f + i]);
                    assert!((got - expected).abs() < 1e-6, "row {row} slot {k} {name}[{i}]: {got} vs {expected}");
                }
            }
        }
    }

    let options = LearnSettings { obstacle_frames: frames.clone(), ..tiny_options(4) };
    let (network, _) = train_on(&demos, &family, &options, None).unwrap();
    assert_eq!(network.meta().obstacle_frames, frames);
    assert_eq!(network.meta().input_width(), wide.input_width);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frames.safetensors");
    network.save(&path).unwrap();
    let loaded = Arc::new(PolicyNetwork::load(&path).unwrap());
    assert_eq!(loaded.meta().obstacle_frames, frames);
    let problem = family.sample(11, 0).unwrap().problem;
    let policy = LearnedPolicy::for_problem(loaded.clone(), &problem).unwrap();
    let mut state = policy.new_workspace();
    let (zero, mut act) = (vec![0.0; 7], vec![0.0; 7]);
    policy.act(&mut state, &problem.start, &zero, &mut act).unwrap();
    let before = allocations();
    policy.act(&mut state, &problem.start, &zero, &mut act).unwrap();
    assert_eq!(allocations() - before, 0, "a query with obstacle frames allocates");
    assert!(act.iter().all(|v| v.is_finite()));
    // Continuing from it (as DAgger does) needs its input.
    let continued = train_on(&demos, &family, &options, Some(&loaded));
    assert!(continued.is_ok(), "{:?}", continued.err());
    let other = train_on(&demos, &family, &tiny_options(4), Some(&loaded)).unwrap_err().to_string();
    assert!(other.contains("obstacle slots and frames") && other.contains("panda_link4"), "{other}");

    let unknown = LearnSettings { obstacle_frames: vec!["panda_link44".into()], ..tiny_options(4) };
    let error = train_on(&demos, &family, &unknown, None).unwrap_err().to_string();
    assert!(error.contains("obstacle frame") && error.contains("panda_link44"), "{error}");
    let many = LearnSettings { obstacle_frames: vec!["panda_link4".into(); 9], ..tiny_options(4) };
    let error = train_on(&demos, &family, &many, None).unwrap_err().to_string();
    assert!(error.contains("obstacle_frames") && error.contains("at most 8"), "{error}");
}
