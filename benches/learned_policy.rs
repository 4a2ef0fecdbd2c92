//! Query time of the learned policy (target: under 5 µs, so the 36
//! queries of a metric fit in a tick): the network alone and the whole
//! query (forward kinematics, features, network, velocity), for the
//! default architecture (hidden 128, 128, 128) with random weights — the
//! time does not depend on the values — or for the policy file named by
//! `TANDEM_POLICY`.

use criterion::{Criterion, criterion_group, criterion_main};
use rand::{RngExt, SeedableRng};
use std::hint::black_box;
use std::sync::Arc;
use tandem::control::RobotPolicy;
use tandem::learn::features::input_width;
use tandem::learn::{FORMAT, FORMAT_VERSION, LearnedPolicy, PolicyMeta, PolicyNetwork};
use tandem::problem::Problem;

fn network(problem: &Problem) -> PolicyNetwork {
    if let Ok(path) = std::env::var("TANDEM_POLICY") {
        return PolicyNetwork::load(path.as_ref()).expect("TANDEM_POLICY names a policy file");
    }
    let meta = PolicyMeta {
        format: FORMAT.into(),
        version: FORMAT_VERSION,
        joints: problem.robot.joint_names().to_vec(),
        gripper: problem.robot_spec.gripper.clone().expect("a gripper"),
        static_obstacles: vec!["table".into()],
        obstacle_slots: 2,
        obstacle_frames: Vec::new(),
        hidden: vec![128, 128, 128],
        speed_scale: 0.5,
        time_step: 0.08,
        family: "bench".into(),
        seed: 0,
        epochs: 0,
        trajectories: 0,
        pairs: 0,
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    let d = input_width(7, 2, 0);
    let (mut weights, mut biases) = (vec![], vec![]);
    for (inputs, outputs) in meta.layer_shapes() {
        let bound = (6.0 / inputs as f64).sqrt() as f32;
        weights.push((0..inputs * outputs).map(|_| rng.random_range(-bound..bound)).collect());
        biases.push((0..outputs).map(|_| rng.random_range(-0.1..0.1)).collect());
    }
    PolicyNetwork::from_parts(meta, vec![0.0; d], vec![1.0; d], &weights, &biases).expect("consistent parts")
}

fn bench(c: &mut Criterion) {
    let problem = Problem::builtin("panda_grasp_box").expect("builtin problem");
    let network = Arc::new(network(&problem));
    let policy = LearnedPolicy::for_problem(network.clone(), &problem).expect("policy fits the Panda");
    let d = network.meta().input_width();
    let input: Vec<f32> = (0..d).map(|i| (i as f32 * 0.37).sin()).collect();
    let mut scratch = network.scratch();
    let mut raw = vec![0.0f32; 8];
    // Each compiled variant of the forward pass this CPU runs; the default
    // (the best, or TANDEM_SIMD's) is `network_forward`.
    for level in tandem::collision::SimdLevel::available() {
        let mut variant = (*network).clone();
        variant.set_simd(level);
        c.bench_function(&format!("learned_policy/network_forward_{}", level.name()), |b| {
            b.iter(|| {
                variant.forward(black_box(&input), &mut scratch, &mut raw);
                black_box(raw[0])
            })
        });
    }
    c.bench_function("learned_policy/network_forward", |b| {
        b.iter(|| {
            network.forward(black_box(&input), &mut scratch, &mut raw);
            black_box(raw[0])
        })
    });
    // The same network through candle (its CPU matmul), as trained.
    let reference = tandem::learn::CandleNetwork::new(&network).expect("candle layers");
    c.bench_function("learned_policy/network_forward_candle", |b| {
        b.iter(|| reference.forward(black_box(&input)).expect("a forward pass")[0])
    });
    let mut state = policy.new_workspace();
    let zero = [0.0; 7];
    let mut action = [0.0; 7];
    let mut q = problem.start.clone();
    let mut k = 0usize;
    c.bench_function("learned_policy/query", |b| {
        b.iter(|| {
            k += 1;
            q[k % 7] += if k.is_multiple_of(2) { 1e-4 } else { -1e-4 };
            policy.act(&mut state, black_box(&q), &zero, &mut action).expect("valid query");
            black_box(action[0])
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
