//! Live cross-check of the DARE solver against scipy
//! (python_ref/scipy_reference.py, `scipy.linalg.solve_discrete_are`): 60
//! seeded random stabilisable systems with n = 1 … 30 and m = 1 … n (eight of
//! them with a cross term N), plus the Panda's per-joint double integrator
//! (n = 14, m = 7). P and K agree to 2e-10 in relative Frobenius norm
//! (about 100 times the largest error seen, 2.1e-12; NaN fails), for the
//! default solve (the Panda's decouples into its joints), the dense one
//! (`decouple = false`) and a warm start from 1.05·P.
//!
//! The reference Python is `$TANDEM_PYTHON`, else
//! `<workspace>/python_ref/.venv/bin/python`; when it is missing the test
//! fails and says to run `scripts/test.sh` (cross-checks never skip).

use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::io::Write;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use tandem_solvers::riccati::{DareProblem, DareSettings, DareWorkspace, double_integrator};

const TOLERANCE: f64 = 2e-10;

/// The larger of two values, NaN when either is (`f64::max` drops a NaN).
fn worst(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() { f64::NAN } else { a.max(b) }
}
const RANDOM_SYSTEMS: usize = 60;
/// Every `CROSS_EVERY`-th random system gets a cross term.
const CROSS_EVERY: usize = 7;

struct Case {
    label: String,
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    q: DMatrix<f64>,
    r: DMatrix<f64>,
    n: Option<DMatrix<f64>>,
}

fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).parent().expect("solvers/ has a parent").to_path_buf()
}

fn python() -> PathBuf {
    let p = std::env::var_os("TANDEM_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("python_ref/.venv/bin/python"));
    assert!(
        p.is_file(),
        "the Python reference environment is missing ({}). Run `scripts/test.sh` \
         (it creates python_ref/.venv from python_ref/requirements.txt), or set TANDEM_PYTHON.",
        p.display()
    );
    p
}

/// Runs python_ref/scipy_reference.py on `request`, returns its JSON answer.
fn scipy(request: &serde_json::Value) -> serde_json::Value {
    let script = workspace_root().join("python_ref/scipy_reference.py");
    let mut child = Command::new(python())
        .arg(&script)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start the reference Python");
    child.stdin.take().expect("stdin is piped").write_all(request.to_string().as_bytes()).expect("write request");
    let out = child.wait_with_output().expect("reference Python ran");
    assert!(out.status.success(), "{} failed:\n{}", script.display(), String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("JSON answer")
}

fn rows(m: &DMatrix<f64>) -> serde_json::Value {
    m.row_iter().map(|r| r.iter().copied().collect::<Vec<_>>()).collect()
}

fn from_rows(v: &serde_json::Value) -> DMatrix<f64> {
    let rows: Vec<Vec<f64>> = serde_json::from_value(v.clone()).expect("matrix as rows");
    DMatrix::from_fn(rows.len(), rows[0].len(), |i, j| rows[i][j])
}

fn uniform(rng: &mut ChaCha8Rng, r: usize, c: usize) -> DMatrix<f64> {
    DMatrix::from_fn(r, c, |_, _| rng.random_range(-1.0..1.0))
}

fn spectral_radius(a: &DMatrix<f64>) -> f64 {
    a.clone().complex_eigenvalues().iter().map(|z| z.norm()).fold(0.0, f64::max)
}

/// A random stabilisable, detectable system: A scaled to a spectral radius
/// in [0.5, 1.5] (generic B of full column rank makes it controllable),
/// Q = CᵀC + 1e-3·I, R = DᵀD + 0.1·I; with a cross term, the joint weight
/// [[Q, N], [Nᵀ, R]] = EᵀE + 1e-3·I is positive definite.
fn random_case(rng: &mut ChaCha8Rng, index: usize) -> Case {
    let n = 1 + index % 30;
    let m = rng.random_range(1..=n);
    let mut a = uniform(rng, n, n);
    let rho = spectral_radius(&a);
    a *= rng.random_range(0.5..1.5) / rho;
    let b = uniform(rng, n, m);
    let (q, r, cross) = if index % CROSS_EVERY == CROSS_EVERY - 1 {
        let e = uniform(rng, n + m, n + m);
        let joint = e.transpose() * e + DMatrix::identity(n + m, n + m) * 1e-3;
        let q = joint.view((0, 0), (n, n)).into_owned();
        (q, joint.view((n, n), (m, m)).into_owned(), Some(joint.view((0, n), (n, m)).into_owned()))
    } else {
        let outputs = rng.random_range(1..=n);
        let c = uniform(rng, outputs, n);
        let d = uniform(rng, m, m);
        (c.transpose() * c + DMatrix::identity(n, n) * 1e-3, d.transpose() * d + DMatrix::identity(m, m) * 0.1, None)
    };
    let label = format!("random #{index} (n = {n}, m = {m}{})", if cross.is_some() { ", with N" } else { "" });
    Case { label, a, b, q, r, n: cross }
}

/// Seven joints, x = [q, q̇], u = q̈, dt = 0.01 s, Q = diag(100·I, I), R = 0.1·I.
fn panda_double_integrator() -> Case {
    let j = 7;
    let i = DMatrix::<f64>::identity(j, j);
    let (a, b) = double_integrator(j, 0.01);
    let q = DMatrix::from_diagonal(&nalgebra::DVector::from_fn(2 * j, |k, _| if k < j { 100.0 } else { 1.0 }));
    Case { label: "Panda double integrator (n = 14, m = 7)".into(), a, b, q, r: &i * 0.1, n: None }
}

fn relative(x: &DMatrix<f64>, reference: &DMatrix<f64>) -> f64 {
    (x - reference).norm() / reference.norm()
}

#[test]
fn dare_agrees_with_scipy() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x5EED_DA4E);
    let mut cases: Vec<Case> = (0..RANDOM_SYSTEMS).map(|i| random_case(&mut rng, i)).collect();
    cases.push(panda_double_integrator());
    let problems: Vec<serde_json::Value> = cases
        .iter()
        .map(|c| {
            let n = c.n.as_ref().map(rows);
            serde_json::json!({"a": rows(&c.a), "b": rows(&c.b), "q": rows(&c.q), "r": rows(&c.r), "n": n})
        })
        .collect();
    let answer = scipy(&serde_json::json!({ "problems": problems }));
    let solutions = answer["solutions"].as_array().expect("solutions");
    assert_eq!(solutions.len(), cases.len());

    let settings = DareSettings::default();
    let mut ws = DareWorkspace::new(1, 1);
    let (mut worst_p, mut worst_k, mut worst_residual, mut max_iterations) = (0.0f64, 0.0f64, 0.0f64, 0);
    for (case, reference) in cases.iter().zip(solutions) {
        let mut problem = DareProblem::new(&case.a, &case.b, &case.q, &case.r);
        if let Some(n) = &case.n {
            problem = problem.with_cross_term(n);
        }
        let (p_ref, k_ref) = (from_rows(&reference["p"]), from_rows(&reference["k"]));
        let dense = DareSettings { decouple: false, ..settings.clone() };
        ws.solve(&problem, &dense).unwrap_or_else(|e| panic!("{} (dense): {e}", case.label));
        let guess = ws.p() * 1.05;
        for (path, stats) in [("dense", None), ("warm", Some(ws.solve_warm(&problem, &settings, &guess)))] {
            if let Some(stats) = stats {
                stats.unwrap_or_else(|e| panic!("{} ({path}): {e}", case.label));
            }
            let (p_err, k_err) = (relative(ws.p(), &p_ref), relative(ws.k(), &k_ref));
            assert!(p_err < TOLERANCE && k_err < TOLERANCE, "{} ({path}): P error {p_err:e}, K {k_err:e}", case.label);
        }
        let stats = ws.solve(&problem, &settings).unwrap_or_else(|e| panic!("{}: {e}", case.label));
        let (p_err, k_err) = (relative(ws.p(), &p_ref), relative(ws.k(), &k_ref));
        assert!(p_err < TOLERANCE && k_err < TOLERANCE, "{}: P error {p_err:e}, K error {k_err:e}", case.label);
        assert!(stats.closed_loop_spectral_radius < 1.0, "{}", case.label);
        // The bound is an upper estimate, tight to a few per cent.
        let exact = spectral_radius(&(&case.a - &case.b * ws.k()));
        let rho = stats.closed_loop_spectral_radius;
        assert!(rho >= exact * (1.0 - 1e-9) && rho <= exact * 1.1 + 1e-12, "{}: ρ {rho} vs {exact}", case.label);
        worst_p = worst(worst_p, p_err);
        worst_k = worst(worst_k, k_err);
        worst_residual = worst(worst_residual, stats.residual);
        max_iterations = max_iterations.max(stats.iterations);
    }
    println!(
        "{} systems vs scipy {}: max relative error P {worst_p:.2e}, K {worst_k:.2e}; \
         max residual {worst_residual:.2e}; max doubling iterations {max_iterations}",
        cases.len(),
        answer["scipy_version"].as_str().unwrap_or("?")
    );
}
