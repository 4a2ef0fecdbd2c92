//! The self-filter: a camera that watches the arm sees the arm. Points on
//! the robot's own body (its links, and what it holds) at the measured
//! configuration are not obstacles; left in, every configuration would be
//! in collision with the cloud of itself.

use super::distance::signed_distance;
use super::model::CollisionModel;
use super::query::CollisionWorkspace;
use crate::robot::RobotError;
use crate::scene::Shape;
use nalgebra::{IsometryMatrix3, Point3};

impl CollisionModel {
    /// Removes from `points` (world frame, m) every point within `margin`
    /// (m) of the robot's own shapes — its links and attached objects,
    /// padded as the model pads them — placed at `q`, and returns how many
    /// it removed. The others keep their order.
    ///
    /// The margin covers what the measurement and the image disagree on:
    /// the sensor's noise and the arm's motion between the image and the
    /// joint state (a few centimetres; docs/point_clouds.md). A negative
    /// or NaN margin counts as 0. Bounding balls of the links and of each
    /// shape prune almost every point; the rest get an exact distance.
    ///
    /// # Errors
    /// A `q` of the wrong length or with non-finite values.
    pub fn remove_robot_points(
        &self,
        ws: &mut CollisionWorkspace,
        q: &[f64],
        margin: f64,
        points: &mut Vec<[f64; 3]>,
    ) -> Result<usize, RobotError> {
        let margin = margin.max(0.0);
        self.place(ws, q)?;
        let moving: Vec<usize> = (0..self.groups.len()).filter(|&g| self.groups[g].body.is_some()).collect();
        let point_shape = Shape::Sphere { radius: 0.0 };
        let before = points.len();
        points.retain(|p| {
            let at = Point3::from(*p);
            let on_robot = moving.iter().any(|&g| {
                let group = &self.groups[g];
                if (at - ws.centers[g]).norm() > group.radius + margin {
                    return false;
                }
                group.objects.clone().any(|i| {
                    let object = &self.objects[i];
                    let pose = &ws.poses[i];
                    if (at.coords - pose.translation.vector).norm() > object.radius + margin {
                        return false;
                    }
                    let d = signed_distance(
                        &point_shape,
                        &IsometryMatrix3::translation(p[0], p[1], p[2]),
                        &object.shape,
                        pose,
                    );
                    d.distance - object.padding < margin
                })
            });
            !on_robot
        });
        Ok(before - points.len())
    }
}
