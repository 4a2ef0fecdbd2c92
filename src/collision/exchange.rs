//! The "collision scene exchange" JSON: a collision model described for
//! the reference and peer tools (`python_ref/coal_reference.py`,
//! `benches/peers/run_coal.sh`), which rebuild the same geometry in coal.

use super::geometry::ObjectSource;
use super::model::CollisionModel;
use crate::scene::Shape;
use serde_json::{Value, json};
use std::path::Path;

impl CollisionModel {
    /// Describes this model for coal: the robot by its URDF file (the
    /// model's own collision elements, by link and index), obstacles and
    /// free objects by shape and world pose, every checked pair, and the
    /// `configurations` to evaluate. Attached objects and convex hulls are
    /// not expressible and yield `None`.
    pub fn to_exchange_json(&self, urdf: &Path, package_dirs: &[&Path], configurations: &[Vec<f64>]) -> Option<Value> {
        let robot = &self.robot;
        let description = robot.description();
        let values = robot.all_joint_values(&robot.neutral_configuration()).ok()?;
        let held: serde_json::Map<String, Value> = description
            .joints()
            .iter()
            .enumerate()
            .filter(|(_, j)| j.kind.is_movable() && !robot.joint_names().contains(&j.name))
            .map(|(i, j)| (j.name.clone(), json!(values[i])))
            .collect();
        let (mut robot_elements, mut others) = (Vec::new(), Vec::new());
        // Position of each object in robot_elements ++ obstacles.
        let mut slot = vec![0usize; self.objects.len()];
        for (i, o) in self.objects.iter().enumerate() {
            match o.source {
                ObjectSource::RobotLink { link, element } => {
                    slot[i] = robot_elements.len();
                    robot_elements.push(json!({"link": description.links()[link].name, "index": element}));
                }
                _ if self.groups[o.group].body.is_some() => return None,
                _ => {
                    slot[i] = usize::MAX - others.len();
                    others.push(shape_json(&self.groups[o.group].name, &o.shape, &o.local)?);
                }
            }
        }
        let n = robot_elements.len();
        let index = |k: usize| if k >= usize::MAX - others.len() { n + (usize::MAX - k) } else { k };
        let pairs: Vec<Value> =
            self.pairs.iter().map(|[a, b]| json!([index(slot[*a as usize]), index(slot[*b as usize])])).collect();
        Some(json!({
            "urdf": urdf,
            "package_dirs": package_dirs,
            "joints": robot.joint_names(),
            "held": held,
            "robot_elements": robot_elements,
            "obstacles": others,
            "pairs": pairs,
            "configurations": configurations,
        }))
    }
}

fn shape_json(name: &str, shape: &Shape, pose: &nalgebra::IsometryMatrix3<f64>) -> Option<Value> {
    let r = pose.rotation.matrix();
    let rotation: Vec<[f64; 3]> = (0..3).map(|i| [r[(i, 0)], r[(i, 1)], r[(i, 2)]]).collect();
    let mut v = json!({"name": name, "translation": pose.translation.vector.as_slice(), "rotation": rotation});
    let extra = match shape {
        Shape::Box { half_extents } => json!({"shape": "box", "half_extents": half_extents.as_slice()}),
        Shape::Sphere { radius } => json!({"shape": "sphere", "radius": radius}),
        Shape::Cylinder { radius, half_length } => {
            json!({"shape": "cylinder", "radius": radius, "length": 2.0 * half_length})
        }
        Shape::Capsule { radius, half_length } => {
            json!({"shape": "capsule", "radius": radius, "length": 2.0 * half_length})
        }
        Shape::Convex(_) | Shape::Points { .. } => return None,
    };
    v.as_object_mut()?.extend(extra.as_object()?.clone());
    Some(v)
}
