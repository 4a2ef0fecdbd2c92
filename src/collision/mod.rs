//! Collision checking and signed distances between the robot and its scene.
//!
//! A [`CollisionModel`] compiles the robot's URDF collision elements (one
//! group per link, and per named surface such as a finger pad, see
//! [`CollisionModelBuilder::surface_groups`]; primitives as they are,
//! meshes as convex hulls), the
//! scene's obstacles and objects, and the list of pairs to check: every
//! robot link against every obstacle and free object, attached objects
//! against both, and self-collision pairs between links that are neither on
//! the same rigid body nor parent and child, minus the pairs an SRDF
//! disables and the contacts the scene allows. Queries run over a
//! per-thread [`CollisionWorkspace`] and allocate nothing.
//!
//! ```
//! use tandem::collision::{CollisionModel, CollisionWorkspace};
//! use tandem::scene::{Shape, Obstacle, Scene};
//! use tandem::robot::RobotModel;
//! use nalgebra::IsometryMatrix3;
//! use std::sync::Arc;
//! let panda = Arc::new(RobotModel::panda());
//! let mut scene = Scene::new();
//! scene.add_obstacle(Obstacle::new("ball", Shape::sphere(0.1), IsometryMatrix3::translation(0.5, 0.0, 0.4))).unwrap();
//! let model = CollisionModel::builder(panda.clone()).scene(&scene).build().unwrap();
//! let mut ws = CollisionWorkspace::new(&model);
//! let q = [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785];
//! assert!(model.collision_free(&mut ws, &q).unwrap());
//! let closest = model.min_distance(&mut ws, &q).unwrap().unwrap();
//! let mut gradient = [0.0; 7];
//! model.distance_gradient(&ws, &closest, &mut gradient).unwrap();
//! println!("{:?} at {:.3} m", model.pair_names(closest.pair), closest.signed.distance);
//! ```

mod distance;
mod exchange;
mod geometry;
mod model;
mod motion;
mod query;
mod self_filter;
mod spheres;

pub use distance::{SignedDistance, closer_than, signed_distance};
pub use geometry::ObjectSource;
pub use model::{CollisionModel, CollisionModelBuilder};
pub use motion::{MAX_MOTION_SAMPLES, MIN_CLEARANCE, MIN_RESOLUTION};
pub use query::{CollisionWorkspace, PairDistance};
pub use spheres::{LANES, SimdLevel, SnappedQuarterTurns};

use crate::robot::RobotError;
use crate::scene::ShapeError;
use thiserror::Error;

/// Errors building collision shapes and models.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum CollisionError {
    /// A shape that cannot be built (a bad dimension, a degenerate mesh
    /// hull), or a padding that is not finite and non-negative.
    #[error(transparent)]
    Shape(#[from] ShapeError),
    /// A link whose collision mesh tandem cannot read.
    #[error("link '{link}' has a collision mesh in a format tandem cannot read (use STL, OBJ or COLLADA)")]
    UnreadableMesh {
        /// The link's name.
        link: String,
    },
    /// A link's collision element that cannot become a collision shape
    /// (e.g. a flat mesh, whose convex hull has no volume).
    #[error("{urdf}: link '{link}', collision element {element}{}: {source}", mesh.as_ref().map(|p| format!(" (mesh {})", p.display())).unwrap_or_default())]
    LinkGeometry {
        /// The URDF (path or `<string>`) the element comes from.
        urdf: String,
        /// The link's name.
        link: String,
        /// Index of the `<collision>` element in the link (URDF order, from 0).
        element: usize,
        /// The mesh file, for mesh elements.
        mesh: Option<std::path::PathBuf>,
        #[source]
        /// Why the element cannot become a shape.
        source: Box<CollisionError>,
    },
    /// A name (link, obstacle, object) that matches nothing.
    #[error("no link, obstacle or object named '{name}'{}", crate::robot::did_you_mean(suggestions))]
    UnknownName {
        /// The name asked for.
        name: String,
        /// Close names that do exist, for "did you mean".
        suggestions: Vec<String>,
    },
    /// A surface group name that no robot collision element has.
    #[error("no robot collision element is named '{name}'{}", crate::robot::did_you_mean(suggestions))]
    UnknownSurface {
        /// The name asked for.
        name: String,
        /// Close names that do exist.
        suggestions: Vec<String>,
    },
    /// A surface group name (see
    /// [`CollisionModelBuilder::surface_groups`]) that is already a link's,
    /// an obstacle's or an object's.
    #[error("surface '{name}' has the name of a link, obstacle or object; name its collision elements apart")]
    SurfaceNameTaken {
        /// The surface's name.
        name: String,
    },
    /// A robot-side error (unknown frame, …).
    #[error(transparent)]
    Robot(#[from] RobotError),
}
