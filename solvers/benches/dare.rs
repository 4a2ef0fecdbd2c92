//! DARE solve time with a reused workspace (the allocation-free path).
//!
//! `dare/n4_m2` and `dare/n30_m10`: seeded random stabilisable systems (A
//! scaled to spectral radius 1.2, Q = CᵀC + 1e-3·I, R = DᵀD + 0.1·I);
//! `dare/n14_m7`: the Panda's per-joint double integrator (dt = 0.01 s,
//! Q = diag(100·I, I), R = 0.1·I), which decouples into seven identical
//! joints; `dare/n14_m7_dense` solves it as one 14-state system
//! (`DareSettings::decouple = false`), and `dare/n14_m7_warm` /
//! `dare/n14_m7_dense_warm` start Newton from the `P` of a nearby problem
//! (position weights 1% apart, R 1% larger), as when a policy is rebuilt.
//! The exact matrices are written to
//! `<workspace>/target/peers/dare_cases.json`, which
//! `benches/peers/scipy_dare.py` times with `scipy.linalg.solve_discrete_are`
//! (`benches/peers/compare_dare.sh` runs both and prints the ratios).

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::path::PathBuf;
use tandem_solvers::riccati::{DareProblem, DareSettings, DareWorkspace, double_integrator, solve_dare};

struct Case {
    name: &'static str,
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    q: DMatrix<f64>,
    r: DMatrix<f64>,
}

fn random_case(name: &'static str, n: usize, m: usize, seed: u64) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut uniform = |r: usize, c: usize| DMatrix::from_fn(r, c, |_, _| rng.random_range(-1.0..1.0));
    let mut a = uniform(n, n);
    let rho = a.clone().complex_eigenvalues().iter().map(|z| z.norm()).fold(0.0, f64::max);
    a *= 1.2 / rho;
    let (b, c, d) = (uniform(n, m), uniform(n, n), uniform(m, m));
    let q = c.transpose() * c + DMatrix::identity(n, n) * 1e-3;
    let r = d.transpose() * d + DMatrix::identity(m, m) * 0.1;
    Case { name, a, b, q, r }
}

fn panda_double_integrator(name: &'static str, position: [f64; 7], control: f64) -> Case {
    let j = 7;
    let i = DMatrix::<f64>::identity(j, j);
    let (a, b) = double_integrator(j, 0.01);
    let q = DMatrix::from_diagonal(&nalgebra::DVector::from_fn(2 * j, |k, _| if k < j { position[k] } else { 1.0 }));
    Case { name, a, b, q, r: &i * control }
}

fn rows(m: &DMatrix<f64>) -> serde_json::Value {
    m.row_iter().map(|r| r.iter().copied().collect::<Vec<_>>()).collect()
}

/// Writes the cases for the scipy peer; a failure only loses the peer's input.
fn export(cases: &[Case]) {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/peers");
    let json: Vec<serde_json::Value> = cases
        .iter()
        .map(
            |c| serde_json::json!({"name": c.name, "a": rows(&c.a), "b": rows(&c.b), "q": rows(&c.q), "r": rows(&c.r)}),
        )
        .collect();
    let written = std::fs::create_dir_all(&dir)
        .and_then(|_| std::fs::write(dir.join("dare_cases.json"), serde_json::json!({ "cases": json }).to_string()));
    if let Err(e) = written {
        eprintln!("warning: could not write {}/dare_cases.json: {e}", dir.display());
    }
}

fn dare(c: &mut Criterion) {
    let panda = |name| panda_double_integrator(name, [100.0; 7], 0.1);
    let cases = [
        random_case("n4_m2", 4, 2, 4),
        panda("n14_m7"),
        panda("n14_m7_dense"),
        panda("n14_m7_warm"),
        panda("n14_m7_dense_warm"),
        random_case("n30_m10", 30, 10, 30),
    ];
    export(&cases);
    let nearby = panda_double_integrator("nearby", [101.0, 100.0, 99.5, 100.0, 100.0, 100.5, 100.0], 0.101);
    let nearby = solve_dare(&DareProblem::new(&nearby.a, &nearby.b, &nearby.q, &nearby.r), &DareSettings::default())
        .expect("nearby case is solvable")
        .p;
    let mut group = c.benchmark_group("dare");
    for case in &cases {
        let settings = DareSettings { decouple: !case.name.contains("dense"), ..DareSettings::default() };
        let warm = case.name.ends_with("warm").then_some(&nearby);
        let problem = DareProblem::new(&case.a, &case.b, &case.q, &case.r);
        let mut ws = DareWorkspace::new(case.a.nrows(), case.b.ncols());
        let solve = |ws: &mut DareWorkspace| match warm {
            Some(p0) => ws.solve_warm(black_box(&problem), &settings, p0),
            None => ws.solve(black_box(&problem), &settings),
        };
        let stats = solve(&mut ws).expect("benchmark case is solvable");
        eprintln!(
            "{}: {} doubling iterations, {} Newton steps, residual {:.1e}",
            case.name, stats.iterations, stats.refinement_steps, stats.residual
        );
        group.bench_function(case.name, |bench| bench.iter(|| black_box(solve(&mut ws).expect("solvable"))));
    }
    group.finish();
}

criterion_group!(benches, dare);
criterion_main!(benches);
