//! `tandem check`: validate a problem file and check a configuration for
//! collisions.

use super::ProblemArgs;
use super::kinematics::parse_values;
use crate::collision::{CollisionModel, CollisionWorkspace};
use crate::scene::{Goal, Problem};

/// Arguments of `tandem check`.
#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    #[command(flatten)]
    pub input: ProblemArgs,
    /// Configuration to check, one value per active joint (rad or m),
    /// comma-separated. Default: the problem's start.
    #[arg(long, value_name = "V1,V2,...", allow_hyphen_values = true)]
    pub q: Option<String>,
    /// Print exactly one JSON object: {"valid", "collision_free",
    /// "min_distance" (m, negative when penetrating), "closest_pair"
    /// [body, body], "problem", "q", "pairs_checked", "colliding_pairs"
    /// [[body, body, distance], ...]}. An invalid file prints
    /// {"valid": false, "error": message} and exits with status 1.
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
}

fn check(args: &CheckArgs) -> Result<Report, Box<dyn std::error::Error>> {
    let problem = args.input.load()?;
    let q = match &args.q {
        Some(text) => parse_values(text)?,
        None => problem.start.clone(),
    };
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
        Goal::Joints(g) if args.q.is_none() => Some(model.collision_free(&mut ws, g)?),
        _ => None,
    };
    Ok(Report { pairs_checked: model.pair_count(), problem, q, collision_free, closest, colliding, goal_free })
}

pub(super) fn run(args: &CheckArgs) -> Result<(), Box<dyn std::error::Error>> {
    let report = match check(args) {
        Ok(r) => r,
        Err(e) if args.json => {
            println!("{}", serde_json::json!({"valid": false, "error": e.to_string()}));
            return Err(e);
        }
        Err(e) => return Err(e),
    };
    if args.json {
        print_json(&report);
    } else {
        print_text(&report);
    }
    Ok(())
}

fn print_json(r: &Report) {
    let (pair, distance) = match &r.closest {
        Some((a, b, d)) => (serde_json::json!([a, b]), serde_json::json!(d)),
        None => (serde_json::Value::Null, serde_json::Value::Null),
    };
    let colliding: Vec<_> = r.colliding.iter().map(|(a, b, d)| serde_json::json!([a, b, d])).collect();
    let out = serde_json::json!({
        "valid": true,
        "collision_free": r.collision_free,
        "min_distance": distance,
        "closest_pair": pair,
        "problem": r.problem.name,
        "q": r.q,
        "pairs_checked": r.pairs_checked,
        "colliding_pairs": colliding,
    });
    println!("{out}");
}

fn print_text(r: &Report) {
    let p = &r.problem;
    println!("problem {} ({}): valid", p.name, p.origin);
    if !p.description.is_empty() {
        println!("  {}", p.description);
    }
    println!("robot: {} active joints ({})", p.robot.nq(), p.robot.joint_names().join(", "));
    let obstacles: Vec<&str> = p.scene.obstacles().iter().map(|o| o.name.as_str()).collect();
    let objects: Vec<&str> = p.scene.objects().iter().map(|o| o.name.as_str()).collect();
    println!("scene: obstacles [{}], objects [{}]", obstacles.join(", "), objects.join(", "));
    let q: Vec<String> = r.q.iter().map(|v| format!("{v:.4}")).collect();
    println!("q = [{}]", q.join(", "));
    println!("{} object pairs checked (padding {} m)", r.pairs_checked, p.robot_spec.padding);
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
