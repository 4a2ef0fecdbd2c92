//! Shared helpers of the integration tests: the Python reference
//! environment and seeded random configurations.
#![allow(dead_code)]

pub mod alloc;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use tandem::collision::{CollisionModel, CollisionWorkspace};
use tandem::robot::RobotModel;

/// Repository root.
pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The reference Python: `$TANDEM_PYTHON`, else `python_ref/.venv/bin/python`.
///
/// Panics with instructions when it is missing: cross-checks never skip.
pub fn python() -> PathBuf {
    let p = std::env::var_os("TANDEM_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| repo().join("python_ref/.venv/bin/python"));
    assert!(
        p.is_file(),
        "the Python reference environment is missing ({}). Run `scripts/test.sh` \
         (it creates python_ref/.venv from python_ref/requirements.txt), or set TANDEM_PYTHON.",
        p.display()
    );
    p
}

/// Runs `python_ref/<script> <args>` with `stdin`, returns stdout; panics with stderr on failure.
pub fn run_python(script: &str, args: &[&str], stdin: &str) -> String {
    let mut child = Command::new(python())
        .arg(repo().join("python_ref").join(script))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start the reference Python");
    child.stdin.take().expect("stdin is piped").write_all(stdin.as_bytes()).expect("write request");
    let out = child.wait_with_output().expect("reference Python ran");
    assert!(out.status.success(), "python_ref/{script} {args:?} failed:\n{}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("utf-8 output")
}

/// The larger of two errors, NaN when either is: `f64::max` returns the
/// other operand for a NaN, so a NaN error folded with it vanished and a
/// NaN result passed every tolerance check.
pub fn worst(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() { f64::NAN } else { a.max(b) }
}

/// The largest absolute value, NaN when any is NaN (see [`worst`]).
pub fn max_abs(values: impl IntoIterator<Item = f64>) -> f64 {
    values.into_iter().map(f64::abs).fold(0.0, worst)
}

/// The vendored MotionBenchMaker files (`problems/motionbenchmaker/`,
/// provenance in its README).
pub fn mbm() -> PathBuf {
    repo().join("problems/motionbenchmaker")
}

/// Unpacks the MotionBenchMaker problems into `dir`; returns the
/// `problems` folder (one `<family>_panda` folder per family).
pub fn unpack_mbm(dir: &Path) -> PathBuf {
    let status = Command::new("tar")
        .arg("xjf")
        .arg(mbm().join("panda_problems.tar.bz2"))
        .arg("-C")
        .arg(dir)
        .status()
        .expect("run tar");
    assert!(status.success(), "tar failed to unpack the MotionBenchMaker problems");
    dir.join("problems")
}

/// Example-robot-data locations reported by the reference environment.
pub struct ErdRobots {
    pub package_dir: PathBuf,
    pub robots: serde_json::Map<String, serde_json::Value>,
}

impl ErdRobots {
    pub fn load() -> Self {
        let v: serde_json::Value = serde_json::from_str(&run_python("pin_reference.py", &["robots"], "")).unwrap();
        ErdRobots {
            package_dir: PathBuf::from(v["package_dir"].as_str().unwrap()),
            robots: v["robots"].as_object().unwrap().clone(),
        }
    }

    pub fn urdf(&self, name: &str) -> PathBuf {
        PathBuf::from(self.robots[name].as_str().unwrap())
    }
}

/// Reads a little-endian f64 file.
pub fn read_f64_file(path: &Path) -> Vec<f64> {
    let bytes = std::fs::read(path).unwrap();
    bytes.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect()
}

/// `count` seeded random configurations within the model's limits (±π for
/// unlimited joints).
pub fn random_configurations(model: &RobotModel, count: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|_| {
            model
                .limits()
                .iter()
                .map(|l| {
                    let (lo, hi) = if l.lower.is_finite() && l.upper.is_finite() {
                        (l.lower, l.upper)
                    } else {
                        (-std::f64::consts::PI, std::f64::consts::PI)
                    };
                    if hi > lo { rng.random_range(lo..=hi) } else { lo }
                })
                .collect()
        })
        .collect()
}

/// Asserts that `samples + 1` evenly spaced configurations of the
/// straight motion `q0 → q1` (ends included) each keep at least `keep`
/// (m) from everything, by `model`'s signed distances: the dense check of
/// a certified motion, on a path other than the one that certified it.
pub fn assert_motion_keeps(
    model: &CollisionModel,
    ws: &mut CollisionWorkspace,
    (q0, q1): (&[f64], &[f64]),
    keep: f64,
    samples: usize,
) {
    for k in 0..=samples {
        let t = k as f64 / samples as f64;
        let q: Vec<f64> = q0.iter().zip(q1).map(|(a, b)| a + (b - a) * t).collect();
        let d = model.min_distance(ws, &q).unwrap().unwrap().signed.distance;
        assert!(d >= keep, "certified motion {q0:?} -> {q1:?} comes {d} m close at t = {t}");
    }
}

/// `scene` as a depth camera all around it would see it: one obstacle,
/// `camera`, of balls of `radius` (m) at points `spacing` (m) apart on its
/// obstacles' surfaces ([`Scene::sampled_as_points`](tandem::scene::Scene::sampled_as_points)).
pub fn sampled_scene(scene: &tandem::scene::Scene, spacing: f64, radius: f64) -> tandem::scene::Scene {
    scene.sampled_as_points("camera", spacing, radius).unwrap()
}
