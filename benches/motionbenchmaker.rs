//! RRT-Connect on all 700 MotionBenchMaker Panda problems
//! (problems/motionbenchmaker) with the spherized Panda and its SRDF: solved
//! count and the median / mean / 95th percentile of planning time and of
//! planning + simplification (shortcutting and certification), one seed
//! per problem, in the layout of the reference table of the benchmark's
//! README. Problem loading and collision-model building are not timed.
//!
//!   cargo bench --bench motionbenchmaker [-- --time-limit SECONDS --seeds N --per-family N --plain]
//!
//! `--seeds N`: plans every problem with seeds 0 to N − 1 (default 1),
//! each (problem, seed) a run of its own in the figures: with one seed,
//! a family's problems all draw the same sample stream.
//!
//! `--per-family N`: only the first N problems of each family.
//!
//! `--plain`: plain RRT-Connect (step 0.5 rad, no balancing, no
//! dynamic-domain sampling), the planner before those were added.
//!
//! `--pointcloud SPACING`: every scene as a depth camera all around would
//! see it — its obstacles replaced by points `SPACING` m apart on their
//! surfaces (`Shape::surface_points`), balls of `SPACING / √2` (the
//! samples' covering radius, so the balls cover the surfaces) — and the
//! figures gain "build" (the point tree and the collision model, timed)
//! and "build + planning + simplification".
//!
//! `--clouds DIR [--point-radius R] [--filter SPACING] [--cull REACH] [--no-margin]`:
//! every scene's obstacles replaced by the points of `DIR/<family>/NNNN.ply`
//! (NNNN the problem's number, from 0001; problems without a file are left
//! out; benches/peers/vamp_pointcloud.py writes them, the points VAMP's
//! `evaluate_mbm.py --pointcloud` samples), each run the whole pipeline,
//! timed step by step: "filter" (`PointCloud::filtered`: points farther than
//! `REACH` from the robot's base, and outside the cube of half-side `REACH`
//! around it, dropped, as VAMP culls, default 1.19 m, 0 for none; then
//! tandem's minimum-distance filter at `SPACING`, default 0.02 m, 0 for
//! none), "build" (the point tree over the kept points, the scene and the
//! collision model), planning, simplification, and the sum. Points are
//! balls of `R` (default 0.0025 m, VAMP's) plus the filter's
//! `radius_margin` (= `SPACING`), so that the kept points stand for every
//! point of the file: a certified edge is certified against the whole file.
//! `--no-margin` leaves the margin out (balls of `R` at the kept points, as
//! VAMP treats its filtered cloud), for comparison only: edges are then
//! certified against the kept points, not against the file.
//!
//! `--set DIR --urdf FILE --srdf FILE --robot NAME`: another
//! MotionBenchMaker set instead of the vendored Panda one: every problem of
//! `DIR/<family>_<NAME>/{scene,request}NNNN.yaml` (VAMP ships such sets
//! for a UR5, a Baxter and a Fetch with their sphere URDFs; see
//! benches/peers/compare_vamp.sh). Problems that do not load count as
//! unsolved, with the reason.
//!
//! Writes target/peers/motionbenchmaker.json (motionbenchmaker_plain.json
//! with `--plain`, motionbenchmaker_pointcloud.json with `--pointcloud`,
//! motionbenchmaker_clouds.json with `--clouds`; `--out FILE` instead).

#[path = "support/mbm.rs"]
mod mbm;

use mbm::{Benchmark, CloudPipeline, FAMILIES, full_run, make_plain, median_mean, option, row, text};
use std::path::{Path, PathBuf};
use std::time::Instant;
use tandem::plan::{PlanStatus, ProblemPlanner, path_length};

/// The vendored Panda set (`per_family` problems of each family), or the
/// set `--set` names (all its problems).
fn benchmark(args: &[String], per_family: usize) -> (Benchmark, Vec<(String, usize)>, String) {
    let Some(set) = text(args, "--set") else {
        // Counted from the files, as for other sets: the cap alone would
        // read past the last problem forever.
        let benchmark = Benchmark::unpack();
        let counted = benchmark.families();
        let count = |f: &str| counted.iter().find(|(name, n)| name == f && *n > 0).expect("every family unpacked").1;
        let families = FAMILIES.iter().map(|f| (f.to_string(), count(f).min(per_family))).collect();
        return (benchmark, families, "Panda".into());
    };
    let need = |name: &str| text(args, name).unwrap_or_else(|| panic!("--set needs {name}"));
    let (urdf, srdf, robot) = (need("--urdf"), need("--srdf"), need("--robot"));
    let benchmark = Benchmark::from_set(Path::new(urdf), Path::new(srdf), Path::new(set), robot);
    let families = benchmark.families().into_iter().map(|(f, n)| (f, n.min(per_family))).collect();
    (benchmark, families, robot.to_string())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let plain = args.iter().any(|a| a == "--plain");
    let cloud_spacing = option(&args, "--pointcloud");
    let clouds = CloudPipeline::from_args(&args);
    assert!(cloud_spacing.is_none() || clouds.is_none(), "--pointcloud and --clouds exclude each other");
    let (mut builds, mut with_build, mut cloud_points) = (Vec::new(), Vec::new(), Vec::new());
    // With --clouds: filter times (s), simplification times (s), and the
    // points of each problem's file and of what the filter kept.
    let (mut filters, mut simplifications, mut file_points, mut kept_points) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    // `cargo test --all-targets` runs bench targets without `--bench`: a
    // smoke run of one problem per family then, not the whole benchmark.
    let per_family = if full_run() { option(&args, "--per-family").map_or(usize::MAX, |n| n as usize) } else { 1 };
    let time_limit = option(&args, "--time-limit").unwrap_or(10.0);
    let seeds = option(&args, "--seeds").unwrap_or(1.0).max(1.0) as u64;
    let (benchmark, families, robot) = benchmark(&args, per_family);
    let (mut planning, mut total, mut failed) = (Vec::new(), Vec::new(), Vec::new());
    // Joint-space length of the simplified paths (rad): what simplification buys.
    let mut lengths = Vec::new();
    // Extension rounds of the search: what the sampling strategy costs.
    let mut iterations = Vec::new();
    // Planning + simplification per family (s): where the tail lives.
    let mut by_family = Vec::new();
    let (mut runs, mut without_cloud) = (0, 0);
    for (family, count) in &families {
        let (family, first) = (family.as_str(), total.len());
        for k in 1..=*count {
            // The problem's file of points (read once, not timed).
            let cloud = match &clouds {
                Some(pipeline) => match pipeline.read(family, k) {
                    Some(cloud) => Some(cloud),
                    None => {
                        without_cloud += 1;
                        continue;
                    }
                },
                None => None,
            };
            if let Some(cloud) = &cloud {
                file_points.push(cloud.len() as f64);
            }
            for seed in 0..seeds {
                runs += 1;
                let mut problem = match benchmark.load(family, k) {
                    Ok(problem) => problem,
                    Err(e) => {
                        failed.push(format!("{family} {k} seed {seed}: does not load: {e}"));
                        continue;
                    }
                };
                problem.planner.time_limit = time_limit;
                let started = Instant::now();
                let mut filter = 0.0;
                if let Some(spacing) = cloud_spacing {
                    problem.scene =
                        problem.scene.sampled_as_points("camera", spacing, spacing / 2f64.sqrt()).expect("primitives");
                    if let Some(o) = problem.scene.obstacle("camera")
                        && let tandem::scene::Shape::Points { points, .. } = &o.shape
                    {
                        cloud_points.push(points.len() as f64);
                    }
                }
                if let (Some(pipeline), Some(cloud)) = (&clouds, &cloud) {
                    let kept = pipeline.filter(cloud);
                    filter = started.elapsed().as_secs_f64();
                    if seed == 0 {
                        kept_points.push(kept.len() as f64);
                    }
                    problem.scene = pipeline.scene(&problem.scene, &kept);
                }
                let mut planner = ProblemPlanner::new(&problem, Some(seed)).expect("planner");
                let build = started.elapsed().as_secs_f64() - filter;
                if plain {
                    make_plain(&mut planner);
                }
                let report = planner.run(seed).expect("plan");
                if report.result.status == PlanStatus::Solved && report.certified {
                    let (p, s) = (report.planning_time.as_secs_f64(), report.simplify_time.as_secs_f64());
                    planning.push(p);
                    total.push(p + s);
                    simplifications.push(s);
                    filters.push(filter);
                    builds.push(build);
                    with_build.push(filter + build + p + s);
                    lengths.push(path_length(&report.path));
                    iterations.push(report.result.iterations as f64);
                } else {
                    failed.push(format!("{family} {k} seed {seed}: {}", report.result.status.name()));
                }
            }
        }
        by_family.push((family, total[first..].to_vec()));
    }
    println!(
        "MotionBenchMaker, {robot}, spherized geometry, RRT-Connect ({seeds} seed(s) per problem, {time_limit} s limit):"
    );
    println!("| figure | median | mean | 95th pct |\n| --- | --- | --- | --- |");
    let p = row("planning time", &mut planning);
    let t = row("planning + simplification", &mut total);
    let point_cloud = cloud_spacing.map(|spacing| {
        let (points, _) = median_mean(&mut cloud_points);
        println!(
            "(scenes as point clouds: {spacing} m apart, balls of {:.4} m, {points:.0} points median)",
            spacing / 2f64.sqrt()
        );
        let b = row("build (tree + collision model)", &mut builds);
        let w = row("build + planning + simplification", &mut with_build);
        serde_json::json!({"spacing_m": spacing, "points_median": points, "build": b, "build_plan_simplify": w})
    });
    let pipeline = clouds.as_ref().map(|pipeline| {
        let f = row("filter", &mut filters);
        let b = row("build (tree + collision model)", &mut builds);
        let s = row("simplification", &mut simplifications);
        let w = row("filter + build + planning + simplification", &mut with_build);
        let ((file_median, file_mean), (kept_median, kept_mean)) =
            (median_mean(&mut file_points), median_mean(&mut kept_points));
        println!("(clouds of {file_median:.0} points median, {kept_median:.0} kept median; {})", pipeline.describe());
        serde_json::json!({"filter": f, "build": b, "simplification": s, "filter_build_plan_simplify": w,
            "points": {"original_median": file_median, "original_mean": file_mean,
                "filtered_median": kept_median, "filtered_mean": kept_mean},
            "settings": pipeline.settings_json(), "without_cloud": without_cloud})
    });
    let (its, mean_its) = median_mean(&mut iterations);
    println!("| RRT iterations | {its:.0} | {mean_its:.0} | |");
    println!("| solved | {} of {runs} | | |", planning.len());
    let mean_length = lengths.iter().sum::<f64>() / lengths.len().max(1) as f64;
    println!("mean path length after simplification: {mean_length:.4} rad");
    for f in &failed {
        println!("unsolved: {f}");
    }
    println!("planning + simplification by family:\n| family | median | mean | share of the total time |");
    println!("| --- | --- | --- | --- |");
    let all: f64 = total.iter().sum();
    for (family, mut times) in by_family {
        let share = times.iter().sum::<f64>() / all;
        let (median, mean) = median_mean(&mut times);
        println!("| {family} | {:.2} ms | {:.2} ms | {:.0} % |", median * 1e3, mean * 1e3, share * 100.0);
    }
    let mut out = serde_json::json!({"solved": planning.len(), "runs": runs, "planning": p, "total": t,
        "unsolved": failed, "time_limit_s": time_limit, "seeds": seeds, "mean_path_length_rad": mean_length,
        "iterations": {"median": its, "mean": mean_its}, "point_cloud": point_cloud});
    if let (Some(fields), Some(serde_json::Value::Object(extra))) = (out.as_object_mut(), pipeline) {
        fields.extend(extra);
    }
    if !full_run() {
        return;
    }
    let peers = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/peers");
    std::fs::create_dir_all(&peers).expect("target/peers");
    let name = match (plain, cloud_spacing.is_some(), clouds.is_some()) {
        (true, _, _) => "motionbenchmaker_plain.json",
        (false, true, _) => "motionbenchmaker_pointcloud.json",
        (false, false, true) => "motionbenchmaker_clouds.json",
        (false, false, false) => "motionbenchmaker.json",
    };
    let default = peers.join(name);
    std::fs::write(text(&args, "--out").map_or(default, PathBuf::from), out.to_string()).expect("write results");
}
