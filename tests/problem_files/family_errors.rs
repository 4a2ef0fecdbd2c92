//! Bad family files: each error names the family file (or its base), the
//! line and the key.

use super::*;

fn family_text(body: &str) -> String {
    format!("base = \"{}\"\nname = \"fam\"\n\n{body}", shipped("panda_grasp_box.toml").display())
}

#[test]
fn family_fixture_is_valid_and_relative_base_works() {
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("f.toml"), family_text("[[objects]]\nname = \"box\"\nx = [0.4, 0.6]\n")).unwrap();
    ProblemFamily::from_file(dir.path().join("f.toml")).unwrap_or_else(|e| panic!("{e}"));
    // A relative base resolves against the family file's folder.
    let f = ProblemFamily::from_file(shipped("panda_grasp_family.toml")).unwrap();
    assert_eq!(f.base.origin, shipped("panda_grasp_box.toml").display().to_string());
}

#[test]
fn family_with_a_missing_base() {
    let text = "# a family\nname = \"fam\"\nbase = \"no_such_problem.toml\"\n";
    expect_family_error(text, "base", "base", "cannot read");
}

#[test]
fn family_base_with_an_error_names_the_base_file() {
    let dir = TempDir::new().unwrap();
    let base = problem(&[ROBOT, START, JOINT_GOAL, "[optimizer]\nhorizon = 1\n"]);
    std::fs::write(dir.path().join("base.toml"), &base).unwrap();
    std::fs::write(dir.path().join("fam.toml"), "base = \"base.toml\"\nname = \"fam\"\n").unwrap();
    let e = ProblemFamily::from_file(dir.path().join("fam.toml")).unwrap_err().to_string();
    let head = format!("{}:{}: optimizer.horizon: ", dir.path().join("base.toml").display(), line_of(&base, "horizon"));
    assert!(e.starts_with(&head), "expected `{head}…`, got `{e}`");
}

#[test]
fn family_unknown_object() {
    let text = family_text("[[objects]]\nname = \"cup\"\nx = [0.4, 0.6]\n");
    expect_family_error(&text, "cup", "objects[0].name", "the base problem has no object 'cup'");
}

#[test]
fn family_unknown_key() {
    let text = family_text("[start]\njitter = 0.1\nspread = 0.2\n");
    expect_family_error(&text, "spread", "start.spread", "unknown field `spread`");
}

#[test]
fn family_negative_jitter() {
    let text = family_text("[start]\njitter = -0.1\n");
    expect_family_error(&text, "jitter", "start.jitter", "must be between 0 and 10 rad, got -0.1");
}

#[test]
fn family_range_min_above_max() {
    let text = family_text("[[objects]]\nname = \"box\"\nx = [0.4, 0.6]\nyaw = [1.0, -1.0]\n");
    expect_family_error(&text, "yaw", "objects[0].yaw", "low ≤ high, got [1, -1]");
}

const OBSTACLES: &str = "[obstacles]\ncount = [0, 2]\nshapes = [\"box\", \"sphere\"]\nsize = [0.04, 0.1]\n\
                         region_min = [0.25, -0.6, 0.25]\nregion_max = [0.75, 0.6, 0.8]\n";

#[test]
fn family_obstacle_ranges() {
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("f.toml"), family_text(OBSTACLES)).unwrap();
    ProblemFamily::from_file(dir.path().join("f.toml")).unwrap_or_else(|e| panic!("{e}"));

    let text = family_text(&OBSTACLES.replace("[0, 2]", "[3, 2]"));
    expect_family_error(&text, "count", "obstacles.count", "min ≤ max ≤ 1000, got [3, 2]");
    let text = family_text(&OBSTACLES.replace("[0.04, 0.1]", "[0.1, 0.04]"));
    expect_family_error(&text, "size", "obstacles.size", "0 < low ≤ high ≤ 10 m, got [0.1, 0.04]");
    let text = family_text(&OBSTACLES.replace("[0.75, 0.6, 0.8]", "[0.75, 0.6, 0.2]"));
    expect_family_error(&text, "region_max", "obstacles.region_max[2]", "be ≥ region_min[2], got 0.2 < 0.25");
    let text = family_text(&OBSTACLES.replace("\"sphere\"", "\"mesh\""));
    expect_family_error(&text, "shapes", "obstacles.shapes[1]", "unknown shape 'mesh'");
    let text = family_text(&format!("{OBSTACLES}clearance = -0.01\n"));
    expect_family_error(&text, "clearance", "obstacles.clearance", "must be between 0 and 10 m, got -0.01");
}

/// A family's `[optimizer] obstacle_margin` changes the base problem's
/// collision objective and nothing else: the same draws for every (seed, id).
#[test]
fn a_family_obstacle_margin_keeps_the_tasks() {
    let text = std::fs::read_to_string(shipped("panda_grasp_family.toml")).unwrap();
    let text = format!("{text}\n[optimizer]\nobstacle_margin = 0.02\n");
    let clearance = ProblemFamily::from_str_with(&text, "clearance.toml", Some(&repo().join("problems"))).unwrap();
    let plain = family();
    for id in 0..40 {
        let (a, b) = (clearance.sample(5, id).unwrap().problem, plain.sample(5, id).unwrap().problem);
        assert_eq!(fingerprint(&a), fingerprint(&b), "sample {id}");
    }
    let margins = |f: &ProblemFamily| -> Vec<(f64, Option<f64>)> {
        let collision = f.base.optimizer.objectives.iter().filter(|o| o.feature == "collision");
        collision.map(|o| (o.margin, o.obstacle_margin)).collect()
    };
    assert_eq!(margins(&plain), [(0.005, None)]);
    assert_eq!(margins(&clearance), [(0.005, Some(0.02))]);
    // Everything else of the base problem is kept.
    let mut same = clearance.base.optimizer.clone();
    same.objectives.iter_mut().for_each(|o| o.obstacle_margin = None);
    assert_eq!(same, plain.base.optimizer);
}

#[test]
fn obstacle_margins_out_of_place_or_range() {
    let text = family_text("[optimizer]\nobstacle_margin = -0.02\n");
    expect_family_error(&text, "obstacle_margin", "optimizer.obstacle_margin", "must be between 0 and 10 m, got -0.02");
    let text = family_text("[optimizer]\nobstacle_margin = nan\n");
    expect_family_error(&text, "obstacle_margin", "optimizer.obstacle_margin", "got NaN");
    let text = family_text("[optimizer]\nmargin = 0.02\n");
    expect_family_error(&text, "margin", "optimizer.margin", "unknown field `margin`");
    // A base without a collision objective has nothing to set.
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("base.toml"), problem(&[ROBOT, START, JOINT_GOAL])).unwrap();
    let text = "base = \"base.toml\"\nname = \"fam\"\n\n[optimizer]\nobstacle_margin = 0.02\n";
    std::fs::write(dir.path().join("fam.toml"), text).unwrap();
    let e = ProblemFamily::from_file(dir.path().join("fam.toml")).unwrap_err().to_string();
    assert!(e.contains("optimizer.obstacle_margin: the base problem lists no collision objective"), "{e}");
    // In a problem file: collision objectives only, never negative.
    let limits = "[[optimizer.objectives]]\nfeature = \"joint_limits\"\nkind = \"ineq\"\nobstacle_margin = 0.02\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, limits]);
    expect_problem_error(&text, "obstacle_margin", "optimizer.objectives[0].obstacle_margin", "collision feature only");
    let collision = "[[optimizer.objectives]]\nfeature = \"collision\"\nkind = \"ineq\"\nobstacle_margin = -1.0\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, collision]);
    expect_problem_error(
        &text,
        "obstacle_margin",
        "optimizer.objectives[0].obstacle_margin",
        "zero or positive, got -1",
    );
}

/// Finite values far beyond any workspace are refused where they enter:
/// they used to pass and then panic in sampling (a range of ±1.7e308) or in
/// the collision solver (an obstacle of 1e300 m).
#[test]
fn family_values_beyond_any_workspace_are_refused() {
    let text =
        family_text(&OBSTACLES.replace("region_min = [0.25, -0.6, 0.25]", "region_min = [-1.7e308, -0.6, 0.25]"));
    expect_family_error(&text, "region_min", "obstacles.region_min[0]", "within ±1000 m");
    let text = family_text(&OBSTACLES.replace("[0.75, 0.6, 0.8]", "[1.7e308, 0.6, 0.8]"));
    // Out of range, not "smaller than region_min" (it printed "got 1e308 < 0.25").
    expect_family_error(&text, "region_max", "obstacles.region_max[0]", "must lie within ±1000 m, got 1.7e308");
    let text = family_text(&OBSTACLES.replace("[0.04, 0.1]", "[0.04, 1e300]"));
    expect_family_error(&text, "size", "obstacles.size", "≤ 10 m, got [0.04, 1e300]");
    let text = family_text("[[objects]]\nname = \"box\"\nx = [-1.7e308, 1.7e308]\n");
    expect_family_error(&text, "x =", "objects[0].x", "within ±1000");
}
