//! (c) Errors: every kind of bad problem file names the file, the line and
//! the key.

use super::*;

#[test]
fn the_error_fixture_is_valid() {
    let dir = TempDir::new().unwrap();
    let path = dir.path().join("good.toml");
    let grasp = "[goal]\ngrasp = \"box\"\n";
    for text in [problem(&[ROBOT, START, JOINT_GOAL]), problem(&[ROBOT, START, grasp, BOX])] {
        std::fs::write(&path, &text).unwrap();
        Problem::from_file(&path).unwrap_or_else(|e| panic!("{e}\n{text}"));
    }
    let p = Problem::from_file(&path).unwrap();
    // The first grasp frame is the default.
    assert_eq!(p.goal, Goal::Grasp { object: "box".into(), grasp: "top".into() });
}

#[test]
fn missing_file() {
    let e = Problem::from_file("/nonexistent/p.toml").unwrap_err().to_string();
    assert!(e.starts_with("cannot read /nonexistent/p.toml: "), "{e}");
}

#[test]
fn toml_syntax_error() {
    let text = problem(&[ROBOT, START, JOINT_GOAL, "[optimizer]\nhorizon = = 50\n"]);
    let dir = TempDir::new().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, &text).unwrap();
    let e = Problem::from_file(&path).unwrap_err().to_string();
    let head = format!("{}:{}: ", path.display(), line_of(&text, "horizon = = 50"));
    assert!(e.starts_with(&head), "expected `{head}…`, got `{e}`");
}

#[test]
fn unknown_key_at_top_level() {
    let text =
        problem(&[ROBOT, START, JOINT_GOAL]).replacen("name = \"bad\"\n", "name = \"bad\"\ncolour = \"red\"\n", 1);
    expect_problem_error(&text, "colour", "colour", "unknown field `colour`");
}

#[test]
fn unknown_key_in_a_grasp() {
    let text =
        problem(&[ROBOT, START, JOINT_GOAL, BOX]).replace("rpy = [3.141592653589793", "rpyy = [3.141592653589793");
    expect_problem_error(&text, "rpyy", "scene.objects[0].grasps[0].rpyy", "unknown field `rpyy`");
}

#[test]
fn unknown_key_in_robot() {
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace("gripper =", "end_effector =");
    expect_problem_error(&text, "end_effector", "robot.end_effector", "unknown field `end_effector`");
}

#[test]
fn unknown_key_in_an_obstacle() {
    let wall = "[[scene.obstacles]]\nname = \"wall\"\nshape = \"sphere\"\nradius = 0.1\n\n\
                [[scene.obstacles]]\nname = \"post\"\nshape = \"sphere\"\nradios = 0.1\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "radios", "scene.obstacles[1].radios", "unknown field `radios`");
}

#[test]
fn unknown_key_in_an_objective() {
    let objectives = "[[optimizer.objectives]]\nfeature = \"control\"\n\n\
                      [[optimizer.objectives]]\nfeature = \"collision\"\nkind = \"ineq\"\nweight = 2.0\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, objectives]);
    expect_problem_error(&text, "weight", "optimizer.objectives[1].weight", "unknown field `weight`");
}

#[test]
fn string_for_a_number() {
    let text = problem(&[ROBOT, START, JOINT_GOAL, "[optimizer]\nhorizon = \"fifty\"\n"]);
    expect_problem_error(&text, "fifty", "optimizer.horizon", "invalid type");
}

#[test]
fn two_element_position() {
    let wall = "[[scene.obstacles]]\nname = \"wall\"\nshape = \"sphere\"\nradius = 0.1\nposition = [0.5, 0.2]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "position = [0.5, 0.2]", "scene.obstacles[0].position", "3");
}

#[test]
fn negative_radius() {
    let wall = "[[scene.obstacles]]\nname = \"post\"\nshape = \"cylinder\"\nradius = -0.1\nlength = 0.5\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "radius = -0.1", "scene.obstacles[0].radius", "must be positive, got -0.1");
}

#[test]
fn zero_box_size() {
    let wall =
        "[[scene.obstacles]]\nname = \"wall\"\nshape = \"box\"\nsize = [\n    0.3,\n    0.0, # zero\n    0.5,\n]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "# zero", "scene.obstacles[0].size[1]", "must be positive, got 0");
}

#[test]
fn box_size_with_two_values() {
    let wall = "[[scene.obstacles]]\nname = \"wall\"\nshape = \"box\"\nsize = [0.3, 0.5]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "size", "scene.obstacles[0].size", "must hold 3 lengths, has 2");
}

#[test]
fn missing_shape_dimension() {
    let wall = "[[scene.obstacles]]\nname = \"ball\"\nshape = \"sphere\"\nposition = [0.5, 0.0, 0.5]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    // A missing key is reported at the header of its table.
    expect_problem_error(&text, "[[scene.obstacles]]", "scene.obstacles[0].radius", "a sphere needs `radius`");
}

#[test]
fn dimension_of_another_shape() {
    let wall = "[[scene.obstacles]]\nname = \"ball\"\nshape = \"sphere\"\nradius = 0.1\nlength = 0.2\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "length", "scene.obstacles[0].length", "does not apply to a sphere");
}

#[test]
fn table_with_zero_thickness() {
    let table = "[scene.table]\ntop = [0.3, 0.0, 0.0]\nsize = [1.4, 1.6]\nthickness = 0.0\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, table]);
    expect_problem_error(&text, "thickness", "scene.table.thickness", "must be positive");
}

#[test]
fn negative_padding() {
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace("gripper = \"panda_hand_tcp\"\n", "padding = -0.01\n");
    expect_problem_error(&text, "padding", "robot.padding", "must be zero or positive, got -0.01");
}

#[test]
fn start_outside_a_joint_limit() {
    let start = "[start]\nq = [\n    0.0,\n    -0.785,\n    0.0,\n    0.25,\n    0.0,\n    1.571,\n    0.785,\n]\n";
    let text = problem(&[ROBOT, start, JOINT_GOAL]);
    expect_problem_error(&text, "0.25,", "start.q[3]", "panda_joint4 = 0.25 is outside its limits [-3.0718, -0.0698]");
}

#[test]
fn goal_outside_a_joint_limit() {
    let goal = "[goal]\nq = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 3.0]\n";
    let text = problem(&[ROBOT, START, goal]);
    expect_problem_error(&text, "3.0]", "goal.q[6]", "panda_joint7 = 3 is outside its limits");
}

#[test]
fn wrong_number_of_start_values() {
    let start = "[start]\nq = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571]\n";
    let text = problem(&[ROBOT, start, JOINT_GOAL]);
    expect_problem_error(&text, "1.571]", "start.q", "has 6 values, the robot has 7 active joints (panda_joint1, ");
}

#[test]
fn horizon_of_one() {
    let text = problem(&[ROBOT, START, JOINT_GOAL, "[optimizer]\nduration = 3.0\nhorizon = 1\n"]);
    expect_problem_error(&text, "horizon", "optimizer.horizon", "must be between 2 and 100000, got 1");
}

#[test]
fn zero_planner_step() {
    let text = problem(&[ROBOT, START, JOINT_GOAL, "[planner]\nseed = 3\nstep = 0.0\n"]);
    expect_problem_error(&text, "step", "planner.step", "must be positive, got 0");
}

#[test]
fn more_out_of_range_values() {
    let pose_goal =
        "[goal]\nframe = \"panda_hand_tcp\"\nposition = [0.5, 0.0, 0.4]\naxis = \"z\"\ndirection = [0.0, 0.0, -1.0]\n";
    let table = "[scene.table]\ntop = [0.3, 0.0, 0.0]\nsize = [1.4, 1.6]\n";
    let settings = "[planner]\nmax_iterations = 10\n\n[optimizer]\norder = 2\nmax_iterations = 20\n";
    let objective = "[[optimizer.objectives]]\nfeature = \"scalar_product\"\nframes = [\"panda_hand_tcp\", \"world\"]\naxes = [\"z\", \"z\"]\nscale = 1.0\norder = 0\nmargin = 0.0\ntarget = [0.0]\n";
    let good = problem(&[ROBOT, START, pose_goal, table, settings, objective]);
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("good.toml"), &good).unwrap();
    Problem::from_file(dir.path().join("good.toml")).unwrap_or_else(|e| panic!("{e}"));
    let cases = [
        ("frame = \"panda_hand_tcp\"", "frame = \"hand\"", "goal.frame", "unknown frame 'hand'"),
        ("axis = \"z\"", "axis = \"w\"", "goal.axis", "must be x, y or z"),
        ("direction = [0.0, 0.0, -1.0]", "direction = [0.0, 0.0, 0.0]", "goal.direction", "non-zero finite vector"),
        ("direction = [0.0, 0.0, -1.0]", "# no direction", "goal", "`axis` and `direction` go together"),
        ("size = [1.4, 1.6]", "size = [0.0, 1.6]", "scene.table.size[0]", "must be positive, got 0"),
        ("max_iterations = 10", "max_iterations = 0", "planner.max_iterations", "must be at least 1"),
        ("order = 2", "order = 3", "optimizer.order", "must be 1 or 2, got 3"),
        ("max_iterations = 20", "max_iterations = 0", "optimizer.max_iterations", "must be at least 1"),
        (
            "axes = [\"z\", \"z\"]",
            "axes = [\"z\"]",
            "optimizer.objectives[0].axes",
            "scalar_product reads 2 axis name(s)",
        ),
        ("axes = [\"z\", \"z\"]", "axes = [\"z\", \"q\"]", "optimizer.objectives[0].axes[1]", "must be x, y or z"),
        ("scale = 1.0", "scale = 0.0", "optimizer.objectives[0].scale", "must be positive, got 0"),
        ("order = 0", "order = 3", "optimizer.objectives[0].order", "must be 0, 1 or 2, got 3"),
        ("margin = 0.0", "margin = -0.1", "optimizer.objectives[0].margin", "must be zero or positive, got -0.1"),
        ("target = [0.0]", "target = [nan]", "optimizer.objectives[0].target[0]", "must be finite, got NaN"),
        ("target = [0.0]", "target = [0.0, 1.0]", "optimizer.objectives[0].target", "has 1 value(s); the target has 2"),
        ("target = [0.0]", "target = [-1.0]", "optimizer.objectives[0].target", "with feature \"vector\""),
    ];
    for (from, to, key, message) in cases {
        assert_eq!(good.matches(from).count(), 1, "{from}");
        let text = good.replace(from, to);
        let marker = if key == "goal" { "[goal]" } else { to.lines().next().unwrap() };
        expect_problem_error(&text, marker, key, message);
    }
}

#[test]
fn objective_time_backwards() {
    let o = "[[optimizer.objectives]]\nfeature = \"joint_state\"\ntime = [0.8, 0.2]\nkind = \"eq\"\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(&text, "time", "optimizer.objectives[0].time", "0 ≤ start ≤ end ≤ 1, got [0.8, 0.2]");
}

#[test]
fn unknown_feature() {
    let o = "[[optimizer.objectives]]\nfeature = \"control\"\n\n[[optimizer.objectives]]\nfeature = \"speed\"\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(
        &text,
        "speed",
        "optimizer.objectives[1].feature",
        "unknown feature 'speed' (expected one of ",
    );
}

#[test]
fn targets_fit_their_feature() {
    let cases = [
        ("feature = \"joint_limits\"\nkind = \"ineq\"\ntarget = [0.0]\n", "feature joint_limits takes no target"),
        ("feature = \"joint_state\"\ntarget = [0.0, 0.0]\n", "has 7 value(s); the target has 2"),
        (
            "feature = \"vector\"\nframes = [\"panda_hand_tcp\", \"world\"]\naxes = [\"z\"]\ntarget = [0.0, -1.0]\n",
            "has 3 value(s)",
        ),
        (
            "feature = \"vector\"\nframes = [\"panda_hand_tcp\", \"world\"]\naxes = [\"z\", \"x\"]\n",
            "vector reads 1 axis name(s)",
        ),
    ];
    for (objective, message) in cases {
        let text = problem(&[ROBOT, START, JOINT_GOAL, &format!("[[optimizer.objectives]]\n{objective}")]);
        let line = objective.lines().last().unwrap();
        let key =
            if line.starts_with("axes") { "optimizer.objectives[0].axes" } else { "optimizer.objectives[0].target" };
        expect_problem_error(&text, line, key, message);
    }
}

#[test]
fn wrong_number_of_feature_frames() {
    let o = "[[optimizer.objectives]]\nfeature = \"position_difference\"\nframes = [\"panda_hand_tcp\"]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(&text, "frames", "optimizer.objectives[0].frames", "reads 2 frame(s), got 1");
}

#[test]
fn unknown_shape() {
    let wall = "[[scene.obstacles]]\nname = \"cone\"\nshape = \"cone\"\nradius = 0.1\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "shape", "scene.obstacles[0].shape", "unknown shape 'cone' (expected box, sphere, ");
}

#[test]
fn unknown_objective_kind() {
    let o = "[[optimizer.objectives]]\nfeature = \"collision\"\nkind = \"hard\"\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(
        &text,
        "kind = \"hard\"",
        "optimizer.objectives[0].kind",
        "unknown kind 'hard' (expected sos, eq or ineq)",
    );
}

#[test]
fn non_unit_quaternion() {
    let o = "[[scene.obstacles]]\nname = \"b\"\nshape = \"sphere\"\nradius = 0.1\nquaternion = [0.0, 0.0, 0.0, 2.0]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(&text, "quaternion", "scene.obstacles[0].quaternion", "unit quaternion [x, y, z, w]");
}

#[test]
fn unknown_gripper_frame() {
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace("\"panda_hand_tcp\"\n", "\"panda_hand_tpc\"\n");
    expect_problem_error(&text, "panda_hand_tpc", "robot.gripper", "panda_hand_tpc");
}

#[test]
fn grasp_of_a_missing_object() {
    let text = problem(&[ROBOT, START, "[goal]\ngrasp = \"cup\"\n", BOX]);
    expect_problem_error(&text, "cup", "goal.grasp", "the scene has no object 'cup'");
}

#[test]
fn missing_grasp_frame() {
    let text = problem(&[ROBOT, START, "[goal]\ngrasp = \"box\"\ngrasp_frame = \"side\"\n", BOX]);
    expect_problem_error(&text, "side", "goal.grasp_frame", "no grasp frame named 'side'");
}

#[test]
fn finger_pads_name_collision_elements() {
    let with = |keys: &str| {
        problem(&[ROBOT, START, JOINT_GOAL])
            .replace("gripper = \"panda_hand_tcp\"\n", &format!("gripper = \"panda_hand_tcp\"\n{keys}\n"))
    };
    Problem::from_str_with(&with("finger_pads = [\"panda_leftfinger_pad\", \"panda_rightfinger_pad\"]"), "ok", None)
        .unwrap();
    let text = with("finger_pads = [\"panda_leftfinger_pad\", \"panda_rightfinger_pda\"]");
    let message =
        "no collision element of the robot is named 'panda_rightfinger_pda' (did you mean panda_rightfinger_pad";
    expect_problem_error(&text, "finger_pads", "robot.finger_pads[1]", message);
    let text = with("finger_pads = [\"panda_leftfinger\"]");
    expect_problem_error(&text, "finger_pads", "robot.finger_pads[0]", "'panda_leftfinger' is a link");
    let text = format!(
        "{}\n[[scene.obstacles]]\nname = \"panda_leftfinger_pad\"\nshape = \"sphere\"\nradius = 0.05\nposition = [1.0, 1.0, 1.0]\n",
        with("finger_pads = [\"panda_leftfinger_pad\"]")
    );
    expect_problem_error(&text, "finger_pads", "robot.finger_pads[0]", "a name apart from the scene's obstacles");
    let text = with("max_grasp_depth = -0.01");
    expect_problem_error(&text, "max_grasp_depth", "robot.max_grasp_depth", "must be positive, got -0.01");
    let text = problem(&[ROBOT, START, JOINT_GOAL])
        .replace("gripper = \"panda_hand_tcp\"\n", "finger_pads = [\"panda_leftfinger_pad\"]\n");
    expect_problem_error(&text, "finger_pads", "robot.finger_pads[0]", "finger pads need `robot.gripper`");
}

#[test]
fn grasp_goal_without_a_gripper() {
    let text = problem(&[ROBOT, START, "[goal]\ngrasp = \"box\"\n", BOX]).replace("gripper = \"panda_hand_tcp\"\n", "");
    expect_problem_error(&text, "grasp = \"box\"", "goal.grasp", "a grasp goal needs `robot.gripper`");
}

#[test]
fn grasp_of_an_object_without_grasp_frames() {
    let ball = "[[scene.objects]]\nname = \"ball\"\nshape = \"sphere\"\nradius = 0.03\nposition = [0.5, 0.0, 0.03]\n";
    let text = problem(&[ROBOT, START, "[goal]\ngrasp = \"ball\"\n", ball]);
    expect_problem_error(&text, "grasp = ", "goal.grasp", "object 'ball' has no grasp frame");
}

#[test]
fn objective_frame_naming_nothing() {
    let o = "[[optimizer.objectives]]\nfeature = \"position_difference\"\nframes = [\n    \"panda_hand_tcp\",\n    \"box/bottom\",\n]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, BOX, o]);
    expect_problem_error(&text, "box/bottom", "optimizer.objectives[0].frames[1]", "'box/bottom' is neither");
}

#[test]
fn allowed_contact_naming_nothing() {
    let scene = "[scene]\nallowed_contacts = [[\"panda_link0\", \"table\"]]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, scene]);
    expect_problem_error(&text, "allowed", "scene.allowed_contacts[0][1]", "no link, obstacle or object named 'table'");
}

#[test]
fn duplicate_scene_names() {
    let table = "[scene.table]\ntop = [0.3, 0.0, 0.0]\nsize = [1.4, 1.6]\n\n\
                 [[scene.obstacles]]\nname = \"table\"\nshape = \"sphere\"\nradius = 0.1\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, table]);
    expect_problem_error(
        &text,
        "name = \"table\"",
        "scene.obstacles[0].name",
        "already has an obstacle or object named 'table'",
    );
}

#[test]
fn duplicate_grasp_names() {
    let text = problem(&[ROBOT, START, JOINT_GOAL, BOX]).replace(
        "    { name = \"top\", position = [0.0, 0.0, 0.06], rpy = [3.141592653589793, 0.0, 0.0] },\n",
        "    { name = \"top\", position = [0.0, 0.0, 0.06] },\n    { name = \"top\", position = [0.0, 0.0, -0.06] },\n",
    );
    expect_problem_error(&text, "-0.06", "scene.objects[0].grasps[1].name", "two grasp frames named 'top'");
}

#[test]
fn grasps_on_an_obstacle() {
    let wall =
        "[[scene.obstacles]]\nname = \"ball\"\nshape = \"sphere\"\nradius = 0.1\ngrasps = [{ name = \"top\" }]\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, wall]);
    expect_problem_error(&text, "grasps", "scene.obstacles[0].grasps", "make it an object");
}

#[test]
fn missing_urdf_file() {
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace(&urdf(), "/nonexistent/robot.urdf");
    expect_problem_error(&text, "nonexistent", "robot.urdf", "/nonexistent/robot.urdf");
}

#[test]
fn missing_mesh_file() {
    let o = "[[scene.obstacles]]\nname = \"m\"\nshape = \"mesh\"\nmesh = \"missing.stl\"\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(&text, "missing.stl", "scene.obstacles[0].mesh", "missing.stl");
}

#[test]
fn unknown_chain_tip() {
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace("panda_hand_tcp\"]", "panda_hand_tcpp\"]");
    expect_problem_error(&text, "chain", "robot.chain", "unknown frame 'panda_hand_tcpp' (did you mean panda_hand_tcp");
}

#[test]
fn unknown_active_joint() {
    let joints = "joints = [\"panda_joint1\", \"panda_joint2\", \"panda_joint3\", \"panda_joint4\", \"panda_joint5\", \"panda_joint6\", \"panda_joint77\"]";
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace("chain = [\"panda_link0\", \"panda_hand_tcp\"]", joints);
    expect_problem_error(&text, "joints", "robot.joints", "unknown joint 'panda_joint77'");
}

#[test]
fn bad_held_joints() {
    let base = problem(&[ROBOT, START, JOINT_GOAL]);
    let text = base.replace("panda_finger_joint1 = 0.04", "panda_finger_joint3 = 0.04");
    expect_problem_error(&text, "hold", "robot.hold.panda_finger_joint3", "unknown joint 'panda_finger_joint3'");
    let text = base.replace("panda_finger_joint1 = 0.04", "panda_finger_joint1 = 0.5");
    expect_problem_error(
        &text,
        "hold",
        "robot.hold.panda_finger_joint1",
        "held value 0.5 for joint 'panda_finger_joint1' is outside its limits [0, 0.04]",
    );
    let text = base.replace("{ panda_finger_joint1 = 0.04 }", "{ panda_finger_joint1 = 0.04, panda_joint1 = 0.5 }");
    expect_problem_error(&text, "hold", "robot.hold.panda_joint1", "joint 'panda_joint1' cannot be active");
}

#[test]
fn group_without_srdf() {
    let text = problem(&[ROBOT, START, JOINT_GOAL])
        .replace("chain = [\"panda_link0\", \"panda_hand_tcp\"]", "group = \"panda_arm\"");
    expect_problem_error(&text, "group", "robot.group", "a group needs `srdf`");
}

#[test]
fn joints_and_chain_both() {
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace(
        "hold =",
        "joints = [\"panda_joint1\", \"panda_joint2\", \"panda_joint3\", \"panda_joint4\", \"panda_joint5\", \"panda_joint6\", \"panda_joint7\"]\nhold =",
    );
    expect_problem_error(&text, "joints", "robot.joints", "give only one of `joints`, `chain` or `group`");
}

#[test]
fn rpy_and_quaternion_both() {
    let text = problem(&[ROBOT, START, JOINT_GOAL, BOX]).replace(
        "position = [0.5, 0.1, 0.06]\n",
        "position = [0.5, 0.1, 0.06]\nrpy = [0.0, 0.0, 0.1]\nquaternion = [0.0, 0.0, 0.0, 1.0]\n",
    );
    expect_problem_error(&text, "quaternion", "scene.objects[0].quaternion", "give rpy or quaternion, not both");
}

#[test]
fn two_goal_kinds() {
    let goal = "[goal]\nq = [0.5, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]\ngrasp = \"box\"\n";
    let text = problem(&[ROBOT, START, goal, BOX]);
    expect_problem_error(&text, "grasp = ", "goal.grasp", "give exactly one kind of goal");
}

#[test]
fn goal_key_of_another_goal_kind() {
    let goal = "[goal]\ngrasp = \"box\"\ndirection = [0.0, 0.0, -1.0]\n";
    let text = problem(&[ROBOT, START, goal, BOX]);
    expect_problem_error(&text, "direction", "goal.direction", "does not apply to a grasp goal");
    let goal = "[goal]\nq = [0.5, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785]\ngrasp_frame = \"top\"\n";
    let text = problem(&[ROBOT, START, goal, BOX]);
    expect_problem_error(&text, "grasp_frame", "goal.grasp_frame", "does not apply to a joint goal");
}

#[test]
fn pose_goal_without_position() {
    let goal = "[goal]\nframe = \"panda_hand_tcp\"\naxis = \"z\"\ndirection = [0.0, 0.0, -1.0]\n";
    let text = problem(&[ROBOT, START, goal]);
    expect_problem_error(&text, "[goal]", "goal", "a pose goal needs `position`");
}

#[test]
fn missing_required_keys() {
    // A missing key is reported at the table it is missing from.
    let text = problem(&[ROBOT, START, JOINT_GOAL]).replace("urdf = ", "# urdf = ");
    expect_problem_error(&text, "[robot]", "robot", "missing field `urdf`");
    let o = "[[scene.obstacles]]\nname = \"a\"\nradius = 0.1\n";
    let text = problem(&[ROBOT, START, JOINT_GOAL, o]);
    expect_problem_error(&text, "[[scene.obstacles]]", "scene.obstacles[0]", "missing field `shape`");
    let text = problem(&[ROBOT, START, JOINT_GOAL, BOX]).replace("{ name = \"top\", ", "{ ");
    expect_problem_error(&text, "position = [0.0, 0.0, 0.06]", "scene.objects[0].grasps[0]", "missing field `name`");
    // A missing top-level table has no line.
    let text = problem(&[ROBOT, START]);
    let dir = TempDir::new().unwrap();
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, &text).unwrap();
    let e = Problem::from_file(&path).unwrap_err().to_string();
    assert_eq!(e, format!("{}: missing field `goal`", path.display()));
}
