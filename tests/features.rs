//! A control loop that embeds tandem builds only what it uses: with
//! `default-features = false` the library's dependency tree holds none of
//! the command line's, the dataset writers' or the network trainer's
//! crates, nor the web server's (it held them all).

use std::process::Command;

/// Packages in the normal dependency tree of the library with `features`.
fn dependencies(features: &[&str]) -> Vec<String> {
    let mut cmd = Command::new(env!("CARGO"));
    cmd.args(["tree", "--offline", "-p", "tandem", "-e", "normal", "--prefix", "none", "--format", "{p}"])
        .args(features)
        .current_dir(env!("CARGO_MANIFEST_DIR"));
    let out = cmd.output().expect("run cargo tree");
    assert!(out.status.success(), "cargo tree failed: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .map(str::to_string)
        .collect()
}

const CLI_AND_DATA: [&str; 12] = [
    "clap",
    "indicatif",
    "parquet",
    "arrow-array",
    "arrow-schema",
    "rayon",
    "sha2",
    "plotters",
    "candle-core",
    "candle-nn",
    "axum",
    "tokio",
];

#[test]
fn the_library_without_default_features_leaves_out_cli_and_data_crates() {
    let lean = dependencies(&["--no-default-features"]);
    assert!(lean.iter().any(|p| p == "nalgebra") && lean.iter().any(|p| p == "parry3d-f64"), "{lean:?}");
    for name in CLI_AND_DATA {
        assert!(!lean.iter().any(|p| p == name), "{name} is built without the cli and data features: {lean:?}");
    }
    // Querying a trained policy needs only its file format.
    assert!(lean.iter().any(|p| p == "safetensors"), "{lean:?}");
    // The defaults keep the command line, datasets and training.
    let full = dependencies(&[]);
    for name in ["clap", "parquet", "rayon", "plotters", "candle-core", "candle-nn", "axum", "tokio"] {
        assert!(full.iter().any(|p| p == name), "{name} missing from the default build");
    }
}

#[test]
fn the_learn_feature_alone_brings_the_trainer_but_not_the_command_line() {
    let learn = dependencies(&["--no-default-features", "--features", "learn"]);
    for name in ["candle-core", "candle-nn", "parquet", "rayon"] {
        assert!(learn.iter().any(|p| p == name), "{name} missing with --features learn: {learn:?}");
    }
    assert!(!learn.iter().any(|p| p == "clap"), "clap is built with --features learn alone");
}
