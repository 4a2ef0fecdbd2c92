//! The robot's surroundings as geometry: collision shapes ([`Shape`]),
//! static obstacles, a table, and graspable objects with named grasp
//! frames, each with a pose in the world (the URDF root frame). Objects can
//! be attached to a robot frame (grasped) and detached again. This is the
//! ground the collision checker stands on; problems (a scene, a robot and a
//! task) are [`crate::problem`]'s.
//!
//! ```
//! use tandem::scene::{Obstacle, Scene, SceneObject, Shape};
//! use nalgebra::IsometryMatrix3;
//! let mut scene = Scene::new();
//! scene.add_obstacle(Obstacle::table("table", [0.5, 0.0, 0.3], [0.8, 1.0], 0.04)).unwrap();
//! let mut box_ = SceneObject::new("box", Shape::cuboid([0.06, 0.06, 0.12]), IsometryMatrix3::translation(0.5, 0.0, 0.36));
//! box_.add_grasp("top", IsometryMatrix3::translation(0.0, 0.0, 0.03));
//! scene.add_object(box_).unwrap();
//! let grasp = scene.grasp_pose("box", "top").unwrap();
//! assert!((grasp.translation.z - 0.39).abs() < 1e-12);
//! ```

mod shape;

pub use shape::{ConvexHull, Shape, ShapeError};

use crate::point_cloud::PointCloud;
use crate::robot::suggest_names;
use nalgebra::{IsometryMatrix3, Rotation3, Vector3};
use thiserror::Error;

/// A fixed obstacle.
#[derive(Debug, Clone)]
pub struct Obstacle {
    /// Unique name in the scene.
    pub name: String,
    /// Its shape, in its own frame.
    pub shape: Shape,
    /// Pose of the shape frame in the world.
    pub pose: IsometryMatrix3<f64>,
}

/// `shape`'s silhouette points at `pose`, as arrays (world, m).
fn world_points(shape: &Shape, pose: &IsometryMatrix3<f64>) -> Vec<[f64; 3]> {
    shape.silhouette_points().iter().map(|p| (pose * p).coords.into()).collect()
}

impl Obstacle {
    /// Its shape's [`Shape::silhouette_points`] at its pose (world, m).
    pub fn silhouette_points(&self) -> Vec<[f64; 3]> {
        world_points(&self.shape, &self.pose)
    }

    /// An obstacle of `shape` at `pose`.
    pub fn new(name: impl Into<String>, shape: Shape, pose: IsometryMatrix3<f64>) -> Obstacle {
        Obstacle { name: name.into(), shape, pose }
    }

    /// Balls of `radius` (m) at the points of `cloud` (in the sensor's
    /// frame), the sensor at `pose` (world): what a depth camera saw, as an
    /// obstacle.
    ///
    /// # Errors
    /// A radius that is not finite and positive.
    pub fn point_cloud(
        name: impl Into<String>,
        cloud: &PointCloud,
        radius: f64,
        pose: IsometryMatrix3<f64>,
    ) -> Result<Obstacle, ShapeError> {
        Ok(Obstacle::new(name, Shape::points(&cloud.points, radius)?, pose))
    }

    /// A table top: a horizontal slab of `size` (x, y) and `thickness` (m)
    /// whose upper surface is centred on `top_center` (world, m).
    pub fn table(name: impl Into<String>, top_center: [f64; 3], size: [f64; 2], thickness: f64) -> Obstacle {
        let [x, y, z] = top_center;
        Obstacle::new(
            name,
            Shape::cuboid([size[0], size[1], thickness]),
            IsometryMatrix3::translation(x, y, z - thickness / 2.0),
        )
    }
}

/// A named frame on an object where a gripper frame should go to grasp it.
#[derive(Debug, Clone)]
pub struct GraspFrame {
    /// Unique name in the scene.
    pub name: String,
    /// Pose of the grasp frame in the object frame.
    pub pose: IsometryMatrix3<f64>,
}

/// Where an object is held: a robot frame and the object's pose in it.
#[derive(Debug, Clone)]
pub struct Attachment {
    /// Name of the robot frame (link or joint) holding the object.
    pub frame: String,
    /// Pose of the object frame in that robot frame.
    pub pose: IsometryMatrix3<f64>,
}

/// A movable object: lies in the world until attached to the robot.
#[derive(Debug, Clone)]
pub struct SceneObject {
    /// Unique name in the scene.
    pub name: String,
    /// Its shape, in its own frame.
    pub shape: Shape,
    /// World pose while not attached (the last pose before attachment otherwise).
    pub pose: IsometryMatrix3<f64>,
    /// Where a gripper may hold it.
    pub grasps: Vec<GraspFrame>,
    /// The robot frame holding it, when grasped.
    pub attachment: Option<Attachment>,
}

impl SceneObject {
    /// A free object of `shape` at world `pose`, with no grasp frame yet.
    pub fn new(name: impl Into<String>, shape: Shape, pose: IsometryMatrix3<f64>) -> SceneObject {
        SceneObject { name: name.into(), shape, pose, grasps: Vec::new(), attachment: None }
    }

    /// Adds a grasp frame at `pose` in the object frame.
    pub fn add_grasp(&mut self, name: impl Into<String>, pose: IsometryMatrix3<f64>) {
        self.grasps.push(GraspFrame { name: name.into(), pose });
    }

    /// Its shape's [`Shape::silhouette_points`] at its pose (world, m).
    pub fn silhouette_points(&self) -> Vec<[f64; 3]> {
        world_points(&self.shape, &self.pose)
    }
}

/// Errors editing a scene.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum SceneError {
    /// Two obstacles or objects share a name.
    #[error("the scene already has an obstacle or object named '{0}'")]
    DuplicateName(String),
    /// No object (or obstacle) of this name.
    #[error("the scene has no {kind} named '{name}'{}", crate::robot::did_you_mean(suggestions))]
    Unknown {
        /// `object` or `grasp frame`.
        kind: &'static str,
        /// Unique name in the scene.
        name: String,
        /// Close names that do exist, for "did you mean".
        suggestions: Vec<String>,
    },
    /// A shape with a bad dimension.
    #[error("'{name}': {source}")]
    Shape {
        /// Unique name in the scene.
        name: String,
        #[source]
        /// What is wrong with the shape.
        source: Box<ShapeError>,
    },
    /// A pose with NaN or infinite entries.
    #[error("'{0}' has a non-finite pose")]
    NonFinitePose(String),
    /// A movable object whose shape is a point cloud (objects are grasped
    /// and carried: they must be convex).
    #[error("'{0}' is a point cloud: only obstacles may be point clouds")]
    PointCloudObject(String),
    /// An obstacle [`Scene::sampled_as_points`] cannot sample (a hull or a
    /// cloud).
    #[error("obstacle '{name}' is a {kind}: only primitives are sampled into points")]
    NotSampled {
        /// The obstacle's name.
        name: String,
        /// Its shape's kind.
        kind: &'static str,
    },
    /// Attaching an object that is already attached, or detaching a free one.
    #[error("object '{name}' is {state}")]
    AttachmentState {
        /// Unique name in the scene.
        name: String,
        /// Its state, as the error states it.
        state: &'static str,
    },
}

/// Obstacles and objects around the robot; see the module example.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    obstacles: Vec<Obstacle>,
    objects: Vec<SceneObject>,
    /// Pairs of names (robot links, obstacles, objects) allowed to touch.
    allowed: Vec<(String, String)>,
}

fn finite_pose(pose: &IsometryMatrix3<f64>) -> bool {
    pose.rotation.matrix().iter().chain(pose.translation.vector.iter()).all(|v| v.is_finite())
}

impl Scene {
    /// An empty scene.
    pub fn new() -> Scene {
        Scene::default()
    }

    /// Adds a fixed obstacle.
    ///
    /// # Errors
    /// A duplicate name, a bad shape or a non-finite pose.
    pub fn add_obstacle(&mut self, obstacle: Obstacle) -> Result<(), SceneError> {
        self.check_new(&obstacle.name, &obstacle.shape, &obstacle.pose)?;
        self.obstacles.push(obstacle);
        Ok(())
    }

    /// Adds a movable object.
    ///
    /// # Errors
    /// As [`add_obstacle`](Self::add_obstacle); grasp poses must be finite
    /// too, and the shape convex (not [`Shape::Points`]).
    pub fn add_object(&mut self, object: SceneObject) -> Result<(), SceneError> {
        self.check_new(&object.name, &object.shape, &object.pose)?;
        if !object.shape.is_convex() {
            return Err(SceneError::PointCloudObject(object.name));
        }
        if object.grasps.iter().any(|g| !finite_pose(&g.pose)) {
            return Err(SceneError::NonFinitePose(object.name));
        }
        self.objects.push(object);
        Ok(())
    }

    fn check_new(&self, name: &str, shape: &Shape, pose: &IsometryMatrix3<f64>) -> Result<(), SceneError> {
        if self.obstacle(name).is_some() || self.object(name).is_some() {
            return Err(SceneError::DuplicateName(name.to_string()));
        }
        shape.validate().map_err(|source| SceneError::Shape { name: name.to_string(), source: Box::new(source) })?;
        if !finite_pose(pose) {
            return Err(SceneError::NonFinitePose(name.to_string()));
        }
        Ok(())
    }

    /// The scene as a depth camera all around it would see it: its
    /// obstacles replaced by one obstacle `name` of balls of `radius` (m)
    /// at points `spacing` (m) apart on their surfaces
    /// ([`Shape::surface_points`]: every surface point lies within
    /// `spacing / √2` of one, so balls at least that wide cover the
    /// surfaces). Objects stay as they are; contacts allowed with an
    /// obstacle are allowed with the cloud.
    ///
    /// # Errors
    /// An obstacle that is a hull or a cloud, a spacing or a radius that is
    /// not finite and positive.
    pub fn sampled_as_points(&self, name: &str, spacing: f64, radius: f64) -> Result<Scene, SceneError> {
        if !(spacing.is_finite() && spacing > 0.0) {
            let source = Box::new(ShapeError::InvalidShape { what: "point spacing", value: spacing });
            return Err(SceneError::Shape { name: name.to_string(), source });
        }
        let mut points = Vec::new();
        for o in &self.obstacles {
            let unsampled = || SceneError::NotSampled { name: o.name.clone(), kind: o.shape.kind_name() };
            let surface = o.shape.surface_points(spacing).ok_or_else(unsampled)?;
            points.extend(surface.iter().map(|p| -> [f64; 3] { (o.pose * p).coords.into() }));
        }
        let shape = Shape::points(&points, radius)
            .map_err(|e| SceneError::Shape { name: name.to_string(), source: Box::new(e) })?;
        let mut scene = Scene::new();
        scene.add_obstacle(Obstacle::new(name, shape, IsometryMatrix3::identity()))?;
        for object in &self.objects {
            scene.add_object(object.clone())?;
        }
        for (a, b) in &self.allowed {
            let named = |n: &String| if self.obstacle(n).is_some() { name.to_string() } else { n.clone() };
            scene.allow_contact(named(a), named(b));
        }
        Ok(scene)
    }

    /// Lets `a` and `b` (robot link, obstacle or object names) touch: the
    /// pair is left out of collision checking.
    pub fn allow_contact(&mut self, a: impl Into<String>, b: impl Into<String>) {
        self.allowed.push((a.into(), b.into()));
    }

    /// Whether `a` and `b` were allowed to touch (in either order).
    pub fn is_contact_allowed(&self, a: &str, b: &str) -> bool {
        self.allowed.iter().any(|(x, y)| (x == a && y == b) || (x == b && y == a))
    }

    /// The allowed pairs, as given.
    pub fn allowed_contacts(&self) -> &[(String, String)] {
        &self.allowed
    }

    /// The fixed obstacles, in insertion order.
    pub fn obstacles(&self) -> &[Obstacle] {
        &self.obstacles
    }

    /// The movable objects, in insertion order.
    pub fn objects(&self) -> &[SceneObject] {
        &self.objects
    }

    /// The obstacle named `name`.
    pub fn obstacle(&self, name: &str) -> Option<&Obstacle> {
        self.obstacles.iter().find(|o| o.name == name)
    }

    /// The object named `name`.
    pub fn object(&self, name: &str) -> Option<&SceneObject> {
        self.objects.iter().find(|o| o.name == name)
    }

    /// The movable objects, to move in place (poses stay the caller's to
    /// keep finite).
    pub(crate) fn objects_mut(&mut self) -> &mut [SceneObject] {
        &mut self.objects
    }

    fn object_mut(&mut self, name: &str) -> Result<&mut SceneObject, SceneError> {
        let suggestions = suggest_names(name, self.objects.iter().map(|o| o.name.as_str()));
        self.objects.iter_mut().find(|o| o.name == name).ok_or_else(|| SceneError::Unknown {
            kind: "object",
            name: name.to_string(),
            suggestions,
        })
    }

    /// Moves a free object to world `pose` (its grasp frames move with it).
    ///
    /// # Errors
    /// Unknown object, an attached object, a non-finite pose.
    pub fn set_object_pose(&mut self, object: &str, pose: IsometryMatrix3<f64>) -> Result<(), SceneError> {
        if !finite_pose(&pose) {
            return Err(SceneError::NonFinitePose(object.to_string()));
        }
        let obj = self.object_mut(object)?;
        if obj.attachment.is_some() {
            return Err(SceneError::AttachmentState { name: object.to_string(), state: "attached" });
        }
        obj.pose = pose;
        Ok(())
    }

    /// Turns grasp frame `grasp` of `object` by π about its own z (approach)
    /// axis: the same grasp for a parallel-jaw gripper, with the fingers
    /// swapped, reached with the wrist turned the other way.
    ///
    /// # Errors
    /// Unknown object or grasp name.
    pub fn flip_grasp(&mut self, object: &str, grasp: &str) -> Result<(), SceneError> {
        let obj = self.object_mut(object)?;
        let suggestions = suggest_names(grasp, obj.grasps.iter().map(|g| g.name.as_str()));
        let g = obj.grasps.iter_mut().find(|g| g.name == grasp).ok_or_else(|| SceneError::Unknown {
            kind: "grasp frame",
            name: grasp.to_string(),
            suggestions,
        })?;
        g.pose.rotation *= Rotation3::from_axis_angle(&Vector3::z_axis(), std::f64::consts::PI);
        Ok(())
    }

    /// World pose of grasp frame `grasp` of a free object.
    ///
    /// # Errors
    /// Unknown object or grasp name.
    pub fn grasp_pose(&self, object: &str, grasp: &str) -> Result<IsometryMatrix3<f64>, SceneError> {
        let unknown = |kind, name: &str, names: Vec<&str>| SceneError::Unknown {
            kind,
            name: name.to_string(),
            suggestions: suggest_names(name, names.into_iter()),
        };
        let obj = self
            .object(object)
            .ok_or_else(|| unknown("object", object, self.objects.iter().map(|o| o.name.as_str()).collect()))?;
        let g = obj
            .grasps
            .iter()
            .find(|g| g.name == grasp)
            .ok_or_else(|| unknown("grasp frame", grasp, obj.grasps.iter().map(|g| g.name.as_str()).collect()))?;
        Ok(obj.pose * g.pose)
    }

    /// Attaches `object` to robot frame `frame`, held at `pose_in_frame`
    /// (the object frame in the robot frame). Collision checking then moves
    /// it with that frame; rebuild the [`CollisionModel`](crate::collision::CollisionModel).
    ///
    /// # Errors
    /// Unknown object, an object already attached, a non-finite pose.
    pub fn attach(
        &mut self,
        object: &str,
        frame: impl Into<String>,
        pose_in_frame: IsometryMatrix3<f64>,
    ) -> Result<(), SceneError> {
        if !finite_pose(&pose_in_frame) {
            return Err(SceneError::NonFinitePose(object.to_string()));
        }
        let obj = self.object_mut(object)?;
        if obj.attachment.is_some() {
            return Err(SceneError::AttachmentState { name: object.to_string(), state: "already attached" });
        }
        obj.attachment = Some(Attachment { frame: frame.into(), pose: pose_in_frame });
        Ok(())
    }

    /// Releases `object` at world pose `pose`.
    ///
    /// # Errors
    /// Unknown object, an object not attached, a non-finite pose.
    pub fn detach(&mut self, object: &str, pose: IsometryMatrix3<f64>) -> Result<(), SceneError> {
        if !finite_pose(&pose) {
            return Err(SceneError::NonFinitePose(object.to_string()));
        }
        let obj = self.object_mut(object)?;
        if obj.attachment.take().is_none() {
            return Err(SceneError::AttachmentState { name: object.to_string(), state: "not attached" });
        }
        obj.pose = pose;
        Ok(())
    }
}
