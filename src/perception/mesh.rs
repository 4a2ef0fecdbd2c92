//! Triangle meshes: an object's surface in its own frame (m).

use super::PerceptionError;

/// A triangle mesh: vertices (m, in the object's frame) and triangles as
/// vertex indices, counter-clockwise seen from outside (so that the right-
/// hand normal points out).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions (m).
    pub vertices: Vec<[f64; 3]>,
    /// Triangles: three indices into `vertices`, counter-clockwise from
    /// outside.
    pub triangles: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// The mesh from its parts, checked: finite vertices, indices in
    /// range, no triangle of repeated vertices; `origin` names it in errors.
    ///
    /// # Errors
    /// The first vertex or triangle at fault.
    pub fn new(
        vertices: Vec<[f64; 3]>,
        triangles: Vec<[u32; 3]>,
        origin: &str,
    ) -> Result<TriangleMesh, PerceptionError> {
        if let Some(i) = vertices.iter().position(|v| !v.iter().all(|c| c.is_finite())) {
            return Err(PerceptionError::new(origin, None, format!("vertex {i} is not finite: {:?}", vertices[i])));
        }
        for (i, t) in triangles.iter().enumerate() {
            if t.iter().any(|&k| k as usize >= vertices.len()) {
                return Err(PerceptionError::new(
                    origin,
                    None,
                    format!("triangle {i} {t:?} indexes past the {} vertices", vertices.len()),
                ));
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Err(PerceptionError::new(origin, None, format!("triangle {i} {t:?} repeats a vertex")));
            }
        }
        Ok(TriangleMesh { vertices, triangles })
    }
}
