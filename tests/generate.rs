//! `tandem generate`: determinism across thread counts and shardings, a
//! real run killed with SIGKILL and resumed, refusal of mismatched
//! parameters, and the dataset read back by pyarrow + Pinocchio
//! (python_ref/check_dataset.py).

mod common;

use common::{repo, run_python};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

const COUNT: &str = "12";
const CHUNK: &str = "3";
const PARTS: usize = 4;

fn family() -> String {
    repo().join("problems/panda_grasp_family.toml").display().to_string()
}

fn generate_command(out: &Path, extra: &[&str]) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_tandem"));
    cmd.args(["generate", "--family", &family(), "--count", COUNT, "--chunk-size", CHUNK, "-T", "20", "--seed", "3"])
        .arg("--out")
        .arg(out)
        .args(["--quiet"])
        .args(extra);
    cmd
}

fn generate(out: &Path, extra: &[&str]) -> Output {
    let output = generate_command(out, extra).output().expect("run tandem generate");
    assert!(output.status.success(), "tandem generate failed:\n{}", String::from_utf8_lossy(&output.stderr));
    output
}

/// Every file of the dataset (timings excluded: they are wall-clock times).
fn dataset_files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.is_file())
        .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
        .collect()
}

fn part_files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    dataset_files(dir).into_iter().filter(|(name, _)| name.starts_with("part-")).collect()
}

fn manifest(dir: &Path, name: &str) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join(name)).unwrap()).unwrap()
}

#[test]
fn dataset_is_identical_across_threads_shards_and_a_killed_run() {
    let tmp = tempfile::tempdir().unwrap();
    let (one, two, sharded, killed) =
        (tmp.path().join("one"), tmp.path().join("two"), tmp.path().join("sharded"), tmp.path().join("killed"));
    generate(&one, &["--threads", "1"]);
    let reference = dataset_files(&one);
    assert_eq!(part_files(&one).len(), PARTS);
    let m = manifest(&one, "_manifest.json");
    assert_eq!(m["samples"], 12);
    assert_eq!(m["accepted"].as_u64().unwrap() + m["rejected"].as_u64().unwrap(), 12);
    assert!(m["accepted"].as_u64().unwrap() >= 11, "acceptance below 11/12: {m}");
    assert_eq!(std::fs::read_dir(one.join("_timings")).unwrap().count(), PARTS);

    // Two threads: the same bytes.
    generate(&two, &["--threads", "2"]);
    assert_eq!(dataset_files(&two), reference, "thread count changed the dataset");

    // Two shards, then the unsharded command over their union: it only
    // writes the manifest, which equals the one-run manifest.
    generate(&sharded, &["--shard", "0/2"]);
    generate(&sharded, &["--shard", "1/2"]);
    assert_eq!(manifest(&sharded, "_manifest-shard-0-of-2.json")["ids"], serde_json::json!([0, 6]));
    let union = generate(&sharded, &[]);
    assert!(String::from_utf8_lossy(&union.stdout).contains("nothing to do"));
    let mut files = dataset_files(&sharded);
    files.retain(|name, _| !name.starts_with("_manifest-shard"));
    assert_eq!(files, reference, "shards do not add up to one run");

    // SIGKILL after the first part file lands, then the same command again.
    let mut child = generate_command(&killed, &["--threads", "1"]).spawn().unwrap();
    let began = Instant::now();
    while !killed.join("part-00000.parquet").exists() {
        assert!(began.elapsed() < Duration::from_secs(600), "no part file after 10 minutes");
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap(); // SIGKILL on Unix
    child.wait().unwrap();
    let survivors = part_files(&killed);
    assert!(survivors.len() < PARTS, "the run ended before the kill; the test proves nothing");
    for (name, bytes) in &survivors {
        assert_eq!(Some(bytes), reference.get(name), "{name} differs after the kill");
    }
    assert!(!killed.join("_manifest.json").exists());
    generate(&killed, &["--threads", "1"]);
    assert_eq!(dataset_files(&killed), reference, "the resumed run differs from the uninterrupted one");

    // pyarrow + Pinocchio read the dataset back and check it.
    let urdf = repo().join("problems/robots/panda/panda.urdf");
    let report = run_python("check_dataset.py", &[one.to_str().unwrap(), urdf.to_str().unwrap()], "");
    let report: serde_json::Value = serde_json::from_str(&report).unwrap();
    assert_eq!(report["rows"], m["accepted"]);
    assert!(report["worst"]["ee_pose"].as_f64().unwrap() < 1e-9, "{report}");
}

#[test]
fn resuming_with_other_parameters_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("d");
    let mut first = Command::new(env!("CARGO_BIN_EXE_tandem"));
    first.args(["generate", "--family", &family(), "--count", "1", "-T", "10", "--quiet", "--out"]).arg(&out);
    assert!(first.output().unwrap().status.success());
    let mut other = Command::new(env!("CARGO_BIN_EXE_tandem"));
    other.args(["generate", "--family", &family(), "--count", "1", "-T", "10", "--seed", "9", "--out"]).arg(&out);
    let output = other.output().unwrap();
    assert_eq!(output.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("seed = 0") && stderr.contains("asks 9"), "{stderr}");
}

/// `--initial-guess` is part of the dataset's identity: recorded, and a
/// resume asking another is refused by name; a dataset written before it
/// was recorded reads as `planned`.
#[test]
fn the_initial_guess_is_recorded_and_checked_on_resume() {
    let tmp = tempfile::tempdir().unwrap();
    let run = |out: &Path, extra: &[&str]| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_tandem"));
        cmd.args(["generate", "--family", &family(), "--count", "2", "-T", "10", "--quiet", "--out"]).arg(out);
        cmd.args(extra).output().unwrap()
    };
    let (straight, planned) = (tmp.path().join("straight"), tmp.path().join("planned"));
    assert!(run(&straight, &["--initial-guess", "straight"]).status.success());
    assert_eq!(manifest(&straight, "_dataset.json")["initial_guess"], "straight");
    assert!(run(&planned, &[]).status.success());
    assert_eq!(manifest(&planned, "_dataset.json")["initial_guess"], "planned");
    let output = run(&straight, &["--initial-guess", "planned"]);
    assert_eq!(output.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("initial_guess = \"straight\", this run asks \"planned\""), "{stderr}");
    // A dataset from before the key: it resumes as planned, and only so.
    let path = planned.join("_dataset.json");
    let mut older = manifest(&planned, "_dataset.json");
    older.as_object_mut().unwrap().remove("initial_guess");
    std::fs::write(&path, serde_json::to_string_pretty(&older).unwrap()).unwrap();
    assert!(run(&planned, &[]).status.success(), "the older dataset resumes");
    std::fs::write(&path, serde_json::to_string_pretty(&older).unwrap()).unwrap();
    let stderr = String::from_utf8_lossy(&run(&planned, &["--initial-guess", "straight"]).stderr).into_owned();
    assert!(stderr.contains("initial_guess = \"planned\", this run asks \"straight\""), "{stderr}");
    let output = run(&planned, &["--initial-guess", "sideways"]);
    assert_eq!(output.status.code(), Some(2), "a usage error");
    assert!(String::from_utf8_lossy(&output.stderr).contains("possible values: planned, straight"));
}

#[test]
fn bad_arguments_are_named() {
    let tmp = tempfile::tempdir().unwrap();
    let run = |args: &[&str]| {
        let output = Command::new(env!("CARGO_BIN_EXE_tandem")).arg("generate").args(args).output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        (output.status.code(), stderr)
    };
    let out = tmp.path().join("x").display().to_string();
    let fam = family();
    // Out-of-range sizes are usage errors (status 2) naming the option and its range.
    let usage = |args: &[&str], option: &str, range: &str| {
        let (code, stderr) = run(args);
        assert_eq!(code, Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(option) && stderr.contains(range), "{args:?}: {stderr}");
    };
    usage(&["--family", &fam, "--count", "0", "--out", &out], "--count", "[1, 100000000000]");
    // u64::MAX aborted out of memory, with --chunk-size too a panic.
    let huge = "18446744073709551615";
    usage(&["--family", &fam, "--count", huge, "--out", &out], "--count", "[1, 100000000000]");
    usage(&["--family", &fam, "--count", "5", "--chunk-size", huge, "--out", &out], "--chunk-size", "[1, 100000]");
    usage(&["--family", &fam, "--count", "5", "--out", &out, "--threads", "0"], "--threads", "[1, 1024]");
    // -T 100001 used 2 GB, bypassing the 100,000-slice limit of problem files.
    usage(&["--family", &fam, "--count", "5", "--out", &out, "-T", "100001"], "--horizon", "[2, 100000]");
    let (code, stderr) = run(&["--family", &fam, "--count", "5", "--out", &out, "--shard", "2/2"]);
    assert!(code == Some(2) && stderr.contains("0 ≤ I < M"), "{stderr}");
    let (code, stderr) = run(&["--family", "missing.toml", "--count", "5", "--out", &out]);
    assert!(code == Some(1) && stderr.contains("missing.toml"), "{stderr}");
    // Sizes whose product is out of bounds are errors of the settings (status 1).
    let (code, stderr) = run(&["--family", &fam, "--count", "100000000000", "--chunk-size", "1", "--out", &out]);
    assert!(code == Some(1) && stderr.contains("at most 1000000 part files"), "{stderr}");
    let (code, stderr) =
        run(&["--family", &fam, "--count", "100000", "--chunk-size", "100000", "-T", "100000", "--out", &out]);
    assert!(code == Some(1) && stderr.contains("slices per part file"), "{stderr}");
}

/// A dataset resumed after its robot's URDF changed was accepted and mixed
/// parts made with two robots: `_dataset.json` records a hash over every
/// file that shapes the robot, and a changed one is refused by name.
#[test]
fn resuming_after_the_robot_changed_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let copy = |from: &Path, to: &Path| {
        std::fs::create_dir_all(to.parent().unwrap()).unwrap();
        std::fs::copy(from, to).unwrap();
    };
    let problems = repo().join("problems");
    for file in
        ["panda_grasp_family.toml", "panda_grasp_box.toml", "robots/panda/panda.urdf", "robots/panda/joint_limits.yaml"]
    {
        copy(&problems.join(file), &tmp.path().join(file));
    }
    let family = tmp.path().join("panda_grasp_family.toml");
    let out = tmp.path().join("d");
    let run = || {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_tandem"));
        cmd.args(["generate", "--count", "1", "-T", "10", "--quiet", "--family"]).arg(&family).arg("--out").arg(&out);
        cmd.output().unwrap()
    };
    assert!(run().status.success());
    let recorded = manifest(&out, "_dataset.json")["robot_sha256"].as_str().unwrap().to_string();
    assert!(recorded.len() == 64 && recorded.chars().all(|c| c.is_ascii_hexdigit()), "{recorded}");
    assert!(run().status.success(), "the same robot resumes");
    // One joint's velocity limit changed.
    let urdf = tmp.path().join("robots/panda/panda.urdf");
    let text = std::fs::read_to_string(&urdf).unwrap();
    let changed = text.replacen("velocity=\"2.175", "velocity=\"2.0", 1);
    assert_ne!(text, changed);
    std::fs::write(&urdf, changed).unwrap();
    let output = run();
    assert_eq!(output.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("robot_sha256") && stderr.contains(&recorded), "{stderr}");
}
