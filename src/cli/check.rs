//! `tandem check`: validate a problem file and check a configuration for
//! collisions.

use super::kinematics::parse_values;
use super::{Outcome, ProblemArgs};
use crate::collision::{CollisionModel, CollisionWorkspace};
use crate::problem::{Goal, Problem, ProblemFamily};
use std::path::{Path, PathBuf};

/// Most family members `tandem check --samples` draws.
pub const MAX_CHECK_SAMPLES: u64 = 10_000;

/// Arguments of `tandem check`.
#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    #[command(flatten)]
    pub input: ProblemArgs,
    /// Configuration to check, one value per active joint (rad or m),
    /// comma-separated, within the joint limits. Default: the problem's start.
    #[arg(long, value_name = "V1,V2,...", allow_hyphen_values = true)]
    pub q: Option<String>,
    /// For a family file: how many members (ids 0 … N−1 of run seed 0) to
    /// draw and check, at most 10000.
    #[arg(long, value_name = "N", default_value_t = 3,
          value_parser = |s: &str| super::number_in(s, 0..=MAX_CHECK_SAMPLES))]
    pub samples: u64,
    /// Print exactly one JSON object: {"valid", "collision_free",
    /// "min_distance" (m, negative when penetrating), "closest_pair"
    /// [body, body], "problem", "joints" (the columns of "q"), "q",
    /// "pairs_checked", "colliding_pairs"
    /// [[body, body, distance], ...], "goal_collision_free" (joint goals,
    /// else null), "fast_path" (the sphere fast path's variant: baseline,
    /// avx2 or avx512, from TANDEM_SIMD or the CPU; null off it),
    /// "warnings" [what loading left out: SRDF entries and allowed-collision
    /// names the robot or scene lacks, as MoveIt ignores them]}; for a family file {"valid", "family", "base",
    /// "samples": [that object plus "id", "seed", "skipped_obstacles"]}.
    /// An invalid file or --q prints {"valid": false, "error": message}
    /// and exits with status 1.
    #[arg(long)]
    pub json: bool,
}

/// What a check found.
struct Report {
    problem: Problem,
    q: Vec<f64>,
    pairs_checked: usize,
    collision_free: bool,
    closest: Option<(String, String, f64)>,
    colliding: Vec<(String, String, f64)>,
    goal_free: Option<bool>,
    /// The sphere fast path's variant, when it applies.
    fast_path: Option<crate::collision::SimdLevel>,
}

fn check(args: &CheckArgs) -> Result<Report, Box<dyn std::error::Error>> {
    let problem = args.input.load()?;
    let q = match &args.q {
        Some(text) => {
            let q = parse_values(text)?;
            problem.robot.check_within_limits(&q).map_err(|e| format!("--q: {e}"))?;
            q
        }
        None => problem.start.clone(),
    };
    check_problem(problem, q, args.q.is_none())
}

/// The collision report of `problem` at `q` (and at its joint goal, when
/// `with_goal`).
fn check_problem(problem: Problem, q: Vec<f64>, with_goal: bool) -> Result<Report, Box<dyn std::error::Error>> {
    let model: CollisionModel = problem.collision_model()?;
    let mut ws = CollisionWorkspace::new(&model);
    let collision_free = model.collision_free(&mut ws, &q)?;
    let names = |pair: usize| {
        let (a, b) = model.pair_names(pair);
        (a.to_string(), b.to_string())
    };
    let closest = model.min_distance(&mut ws, &q)?.map(|d| {
        let (a, b) = names(d.pair);
        (a, b, d.signed.distance)
    });
    let mut colliding: Vec<(String, String, f64)> = Vec::new();
    for d in model.distances(&mut ws, &q, 0.0)? {
        let (a, b) = names(d.pair);
        // One line per body pair: its deepest object pair.
        match colliding.iter_mut().find(|(x, y, _)| *x == a && *y == b) {
            Some(entry) => entry.2 = entry.2.min(d.signed.distance),
            None => colliding.push((a, b, d.signed.distance)),
        }
    }
    let goal_free = match &problem.goal {
        Goal::Joints(g) if with_goal => Some(model.collision_free(&mut ws, g)?),
        _ => None,
    };
    let (pairs_checked, fast_path) = (model.pair_count(), model.simd());
    Ok(Report { pairs_checked, problem, q, collision_free, closest, colliding, goal_free, fast_path })
}

pub(super) fn run(args: &CheckArgs) -> Result<Outcome, Box<dyn std::error::Error>> {
    let result = match family_file(&args.input) {
        Some(path) => check_family(args, &path),
        None => check(args).map(|report| {
            if args.json {
                println!("{}", report_json(&report));
            } else {
                print_text(&report);
            }
            report.outcome()
        }),
    };
    result.inspect_err(|e| {
        if args.json {
            println!("{}", serde_json::json!({"valid": false, "error": e.to_string()}));
        }
    })
}

impl Report {
    /// Unsuccessful when the configuration or the joint goal collides.
    fn outcome(&self) -> Outcome {
        if self.collision_free && self.goal_free != Some(false) { Outcome::Success } else { Outcome::Unsuccessful }
    }
}

/// The path of a family file (a TOML file with a top-level `base` key),
/// if the problem argument names one.
fn family_file(input: &ProblemArgs) -> Option<PathBuf> {
    let path = input.problem.as_ref()?;
    let text = std::fs::read_to_string(path).ok()?;
    let table: toml::Table = toml::from_str(&text).ok()?;
    table.contains_key("base").then(|| path.clone())
}

/// Validates a family file and checks its first `--samples` members.
fn check_family(args: &CheckArgs, path: &Path) -> Result<Outcome, Box<dyn std::error::Error>> {
    if args.q.is_some() {
        return Err("--q does not apply to a family file (its members have their own starts)".into());
    }
    let family = ProblemFamily::from_file(path)?;
    let mut members = Vec::new();
    let mut outcome = Outcome::Success;
    for id in 0..args.samples {
        let sample = family.sample(0, id)?;
        let (skipped, seed) = (sample.skipped_obstacles, sample.seed);
        let start = sample.problem.start.clone();
        let report = check_problem(sample.problem, start, true)?;
        if report.outcome() == Outcome::Unsuccessful {
            outcome = Outcome::Unsuccessful;
        }
        members.push((id, seed, skipped, report));
    }
    if args.json {
        let samples: Vec<_> = members
            .iter()
            .map(|(id, seed, skipped, r)| {
                let mut v = report_json(r);
                v["id"] = serde_json::json!(id);
                v["seed"] = serde_json::json!(seed);
                v["skipped_obstacles"] = serde_json::json!(skipped);
                v
            })
            .collect();
        let out = serde_json::json!({
            "valid": true,
            "family": family.name,
            "base": family.base.origin,
            "samples": samples,
        });
        println!("{out}");
    } else {
        println!("family {} ({}): valid, base problem {}", family.name, path.display(), family.base.origin);
        if !family.description.is_empty() {
            println!("  {}", family.description);
        }
        for (id, seed, skipped, r) in &members {
            let obstacles: Vec<&str> = r.problem.scene.obstacles().iter().map(|o| o.name.as_str()).collect();
            let closest = r.closest.as_ref().map_or("-".to_string(), |(a, b, d)| format!("{d:.4} m ({a}, {b})"));
            println!(
                "  member {id} (seed {seed:#018x}): start collision-free {}, closest {closest}, obstacles [{}]{}",
                if r.collision_free { "yes" } else { "NO" },
                obstacles.join(", "),
                if *skipped > 0 { format!(", {skipped} obstacle(s) could not be placed") } else { String::new() }
            );
        }
    }
    Ok(outcome)
}

fn report_json(r: &Report) -> serde_json::Value {
    let (pair, distance) = match &r.closest {
        Some((a, b, d)) => (serde_json::json!([a, b]), serde_json::json!(d)),
        None => (serde_json::Value::Null, serde_json::Value::Null),
    };
    let colliding: Vec<_> = r.colliding.iter().map(|(a, b, d)| serde_json::json!([a, b, d])).collect();
    serde_json::json!({
        "valid": true,
        "collision_free": r.collision_free,
        "min_distance": distance,
        "closest_pair": pair,
        "problem": r.problem.name,
        "joints": r.problem.robot.joint_names(),
        "q": r.q,
        "pairs_checked": r.pairs_checked,
        "colliding_pairs": colliding,
        "goal_collision_free": r.goal_free,
        "fast_path": r.fast_path.map(|l| l.name()),
        "warnings": r.problem.warnings,
    })
}

fn print_text(r: &Report) {
    let p = &r.problem;
    println!("problem {} ({}): valid", p.name, p.origin);
    if !p.description.is_empty() {
        println!("  {}", p.description);
    }
    if !p.warnings.is_empty() {
        println!("warnings ({}; left out, as MoveIt does):", p.warnings.len());
        for w in &p.warnings {
            println!("  - {w}");
        }
    }
    println!("robot: {} active joints ({})", p.robot.nq(), p.robot.joint_names().join(", "));
    let obstacles: Vec<String> = p
        .scene
        .obstacles()
        .iter()
        .map(|o| match &o.shape {
            crate::scene::Shape::Points { points, radius } => {
                format!("{} ({} points, radius {radius} m)", o.name, points.len())
            }
            _ => o.name.clone(),
        })
        .collect();
    let objects: Vec<&str> = p.scene.objects().iter().map(|o| o.name.as_str()).collect();
    println!("scene: obstacles [{}], objects [{}]", obstacles.join(", "), objects.join(", "));
    let q: Vec<String> = r.q.iter().map(|v| format!("{v:.4}")).collect();
    println!("q = [{}]", q.join(", "));
    let fast =
        r.fast_path.map_or("general path (not all spheres)".to_string(), |l| format!("sphere fast path, {}", l.name()));
    println!(
        "{} object pairs checked (padding {} m; boolean checks on the {fast})",
        r.pairs_checked, p.robot_spec.padding
    );
    println!("collision-free: {}", if r.collision_free { "yes" } else { "NO" });
    if let Some((a, b, d)) = &r.closest {
        println!("minimum signed distance: {d:.4} m, between {a} and {b}");
    }
    for (a, b, d) in &r.colliding {
        println!("  collision: {a} and {b} penetrate by {:.4} m", -d);
    }
    if let Some(free) = r.goal_free {
        println!("goal configuration collision-free: {}", if free { "yes" } else { "NO" });
    }
}
