//! The reach-and-grasp experiment's figures: success per operator and
//! method beside the dissertation's Table 5.1, and the first task's gripper
//! paths (Fig. 5.4).

use super::{Method, ReachGraspResults};
use crate::experiments::ExperimentError;
use crate::experiments::figures::{episode_path, outcome_legend};
use crate::figures::{Color, Marker, Panel, Series, render_grid, render_panels, share_y};
use crate::sim::{Arm, OperatorKind};

/// Table 5.1's success rates (%) of NoAssist, Constrained and SoS for the
/// operators of [`OperatorKind::TABLE_5_1`], right arm then left.
const TABLE_5_1_SUCCESS: [(Arm, [[f64; 7]; 3]); 2] = [
    (
        Arm::Right,
        [
            [34.0, 80.0, 62.0, 21.0, 82.0, 80.0, 81.0],
            [74.0, 91.0, 92.0, 88.0, 95.0, 89.0, 89.0],
            [98.0, 96.0, 84.0, 74.0, 98.0, 99.0, 98.0],
        ],
    ),
    (
        Arm::Left,
        [
            [37.0, 83.0, 56.0, 42.0, 82.0, 83.0, 85.0],
            [82.0, 86.0, 92.0, 95.0, 91.0, 87.0, 84.0],
            [98.0, 97.0, 86.0, 71.0, 97.0, 98.0, 99.0],
        ],
    ),
];

/// Success (%) per operator and method, one panel per arm: tandem's as
/// dots, the dissertation's (Table 5.1, its three methods) as rings in the
/// same colour, side by side in each operator's slot.
pub(super) fn success(r: &ReachGraspResults) -> Result<String, ExperimentError> {
    let s = &r.settings;
    let names: Vec<String> = s.operators.iter().map(OperatorKind::name).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let count = s.methods.len().max(1) as f64;
    let slot = |o: usize, m: usize| o as f64 + 0.7 * ((m as f64 + 0.5) / count - 0.5);
    let mut panels: Vec<Panel> = s
        .arms
        .iter()
        .map(|&arm| {
            let mut panel = Panel::new(&format!("{} arm, {} tasks", arm.as_str(), s.tasks), "operator", "success (%)")
                .categories(&names)
                .y_range((-4.0, 104.0));
            for (m, method) in s.methods.iter().enumerate() {
                let rates: Vec<(f64, f64)> = (0..s.operators.len())
                    .map(|o| {
                        let c = r.cell(arm, o, m);
                        let n = (c.success + c.failed + c.collision + c.timeout).max(1);
                        (slot(o, m), 100.0 * c.success as f64 / n as f64)
                    })
                    .collect();
                panel = panel.with(Series::points(method.name(), &rates, m));
                let published = TABLE_5_1_SUCCESS
                    .iter()
                    .find(|(a, _)| *a == arm)
                    .and_then(|(_, rows)| Method::ALL[..3].iter().position(|x| x == method).map(|k| rows[k]));
                if let Some(row) = published {
                    let rings: Vec<(f64, f64)> = (0..s.operators.len())
                        .filter_map(|o| {
                            let k = OperatorKind::TABLE_5_1.iter().position(|x| *x == s.operators[o])?;
                            Some((slot(o, m), row[k]))
                        })
                        .collect();
                    let label = format!("{} (dissertation)", method.name());
                    panel = panel.with(Series::markers(&label, &rings, m, Marker::Ring));
                }
            }
            panel
        })
        .collect();
    share_y(&mut panels);
    let title = match r.settings.simulator {
        super::Simulator::Kinematic => {
            "reach-and-grasp: success by operator and method (dots: tandem; rings: Table 5.1)"
        }
        super::Simulator::Mujoco(_) => {
            "reach-and-grasp in MuJoCo: box lifted, by operator and method (dots: tandem; rings: Table 5.1)"
        }
    };
    Ok(render_panels(title, &panels, 620, 380)?)
}

/// Fig. 5.4: the first task's gripper paths per operator, seen from above
/// and from the side, for NoAssist and the dissertation's two methods, with
/// the robot's reference, the box, and the gripper's approach axis along
/// the way (its projection: short arrows mean it points into the view).
pub(super) fn paths(r: &ReachGraspResults) -> Result<Option<String>, ExperimentError> {
    let s = &r.settings;
    let Some(&arm) = s.arms.first() else { return Ok(None) };
    let Some(task) = r.tasks.iter().find(|t| t.arm == arm && t.index == 0) else { return Ok(None) };
    let problem = &task.goal.problem;
    let robot = &problem.robot;
    let gripper = robot.frame_id(problem.robot_spec.gripper.as_deref().unwrap_or_default())?;
    let reference = task.goal.policy.reference();
    let planned = robot.frame_path(gripper, (0..reference.len()).map(|i| reference.position(i)))?;
    let corners: Vec<[f64; 3]> = problem.scene.object("box").map(|o| o.silhouette_points()).unwrap_or_default();
    let shown = [
        Method::NoAssist,
        s.methods.get(1).copied().unwrap_or(Method::NoAssist),
        s.methods.get(2).copied().unwrap_or(Method::NoAssist),
    ];
    let operators: Vec<(usize, &OperatorKind)> = s.operators.iter().enumerate().take(4).collect();
    let goal = task.goal.position;
    let view = |o: usize, op: &OperatorKind, (a, b): (usize, usize), y_label: &str| {
        let project = |p: &[f64; 3]| (p[a], p[b]);
        let title = if b == 1 { format!("{}: from above", op.name()) } else { format!("{}: from the side", op.name()) };
        let mut panel = Panel::new(&title, "x (m)", y_label)
            .with(Series::outline("box", &corners.iter().map(project).collect::<Vec<_>>()))
            .with(Series::dashed("reference", &planned.iter().map(project).collect::<Vec<_>>(), Color::Reference))
            .equal();
        let mut outcomes = vec![];
        for (k, method) in shown.iter().enumerate() {
            let Some(m) = s.methods.iter().position(|x| x == method) else { continue };
            let Some(e) = r.episodes.iter().find(|e| e.arm == arm && e.task == 0 && e.operator == o && e.method == m)
            else {
                continue;
            };
            let path: Vec<(f64, f64)> = e.path.iter().map(project).collect();
            panel = episode_path(panel, method.name(), &path, k, e.outcome);
            outcomes.push(e.outcome);
            // Eight arrows of 2 cm along the approach axis, evenly in time.
            let offset = e.path.len().saturating_sub(e.approach.len());
            let every = (e.approach.len() / 8).max(1);
            let (at, along): (Vec<_>, Vec<_>) = e
                .approach
                .iter()
                .enumerate()
                .step_by(every)
                .map(|(i, z)| (project(&e.path[offset + i]), (0.02 * z[a], 0.02 * z[b])))
                .unzip();
            panel = panel.with(Series::arrows(&at, &along, k));
        }
        let start: Vec<(f64, f64)> = planned.first().map(project).into_iter().collect();
        outcome_legend(panel, outcomes)
            .with(Series::markers("start", &start, Color::Reference, Marker::Dot))
            .with(Series::markers("grasp point", &[project(&goal)], Color::Reference, Marker::Ring))
    };
    let top: Vec<Panel> = operators.iter().map(|&(o, op)| view(o, op, (0, 1), "y (m)")).collect();
    let side: Vec<Panel> = operators.iter().map(|&(o, op)| view(o, op, (0, 2), "z (m)")).collect();
    let title =
        format!("reach-and-grasp, {} arm, task 0: gripper paths, approach axis as arrows (Fig. 5.4)", arm.as_str());
    Ok(Some(render_grid(&title, &[top, side], 380, 400)?))
}
