//! Triangle meshes of collision geometry, loaded from STL and OBJ files here
//! and from COLLADA by [`TriMesh::from_collada_file`], which lives with its
//! reader in collada.rs.
//!
//! Meshes are kept exactly as loaded (scaled into the element frame) for the
//! collision layer, which turns them into convex hulls or sphere sets.
//!
//! ```no_run
//! use tandem::robot::TriMesh;
//! let mesh = TriMesh::from_stl_file("link0.stl".as_ref(), [1.0; 3]).unwrap();
//! println!("{} vertices, {} triangles", mesh.vertices.len(), mesh.triangles.len());
//! ```

use super::error::RobotError;
use nalgebra::Point3;
use std::path::Path;

/// An indexed triangle mesh, in metres, in the frame of its collision element.
#[derive(Debug, Clone, PartialEq)]
pub struct TriMesh {
    /// Vertices (m, element frame).
    pub vertices: Vec<Point3<f64>>,
    /// Vertex indices of each triangle, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Loads an ASCII or binary STL file, multiplying coordinates by `scale`.
    ///
    /// # Errors
    /// [`RobotError::Io`] when the file cannot be read, [`RobotError::InvalidMesh`]
    /// when it is not a valid STL or holds non-finite coordinates.
    pub fn from_stl_file(path: &Path, scale: [f64; 3]) -> Result<TriMesh, RobotError> {
        let mut file =
            std::fs::File::open(path).map_err(|source| RobotError::Io { path: path.to_path_buf(), source })?;
        let invalid = |message: String| RobotError::InvalidMesh { path: path.to_path_buf(), message };
        let stl = stl_io::read_stl(&mut file).map_err(|e| invalid(format!("not a valid STL file: {e}")))?;
        let vertices: Vec<Point3<f64>> = stl
            .vertices
            .iter()
            .map(|v| {
                Point3::new(f64::from(v.0[0]) * scale[0], f64::from(v.0[1]) * scale[1], f64::from(v.0[2]) * scale[2])
            })
            .collect();
        if let Some(bad) = vertices.iter().position(|v| !v.coords.iter().all(|c| c.is_finite())) {
            return Err(invalid(format!("vertex {bad} has a non-finite coordinate")));
        }
        if vertices.is_empty() {
            return Err(invalid("the mesh has no vertices".into()));
        }
        let to_u32 = |i: usize| u32::try_from(i).map_err(|_| invalid("more than 2^32 vertices".into()));
        let triangles = stl
            .faces
            .iter()
            .map(|f| Ok([to_u32(f.vertices[0])?, to_u32(f.vertices[1])?, to_u32(f.vertices[2])?]))
            .collect::<Result<Vec<_>, RobotError>>()?;
        Ok(TriMesh { vertices, triangles })
    }

    /// Loads a Wavefront OBJ file (`v` and `f` records; polygons are fanned
    /// into triangles), multiplying coordinates by `scale`.
    ///
    /// # Errors
    /// [`RobotError::Io`] when the file cannot be read, [`RobotError::InvalidMesh`]
    /// naming the line of a malformed record.
    pub fn from_obj_file(path: &Path, scale: [f64; 3]) -> Result<TriMesh, RobotError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| RobotError::Io { path: path.to_path_buf(), source })?;
        parse_obj(&text, scale).map_err(|message| RobotError::InvalidMesh { path: path.to_path_buf(), message })
    }

    /// Axis-aligned bounding box `(min, max)` of the vertices.
    pub fn aabb(&self) -> (Point3<f64>, Point3<f64>) {
        let mut lo = Point3::from([f64::INFINITY; 3]);
        let mut hi = Point3::from([f64::NEG_INFINITY; 3]);
        for v in &self.vertices {
            lo = lo.inf(v);
            hi = hi.sup(v);
        }
        (lo, hi)
    }
}

fn parse_obj(text: &str, scale: [f64; 3]) -> Result<TriMesh, String> {
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for (lineno, line) in text.lines().enumerate() {
        let mut fields = line.split_whitespace();
        let bad = |what: &str| format!("line {}: {what}: '{}'", lineno + 1, line.trim());
        match fields.next() {
            Some("v") => {
                let mut p = [0.0; 3];
                for (k, c) in p.iter_mut().enumerate() {
                    let v: f64 = fields
                        .next()
                        .and_then(|f| f.parse().ok())
                        .filter(|v: &f64| v.is_finite())
                        .ok_or_else(|| bad("a vertex needs three finite coordinates"))?;
                    *c = v * scale[k];
                }
                vertices.push(Point3::from(p));
            }
            Some("f") => {
                let idx = fields
                    .map(|f| obj_index(f, vertices.len()).ok_or_else(|| bad("bad vertex index")))
                    .collect::<Result<Vec<u32>, String>>()?;
                if idx.len() < 3 {
                    return Err(bad("a face needs at least three vertices"));
                }
                triangles.extend((1..idx.len() - 1).map(|k| [idx[0], idx[k], idx[k + 1]]));
            }
            _ => {}
        }
    }
    if vertices.is_empty() {
        return Err("the mesh has no vertices".into());
    }
    Ok(TriMesh { vertices, triangles })
}

/// OBJ face index (`7`, `7/1`, `7//3`, or negative, relative to the end) → 0-based.
fn obj_index(field: &str, count: usize) -> Option<u32> {
    let raw: i64 = field.split('/').next()?.parse().ok()?;
    let count = i64::try_from(count).ok()?;
    let idx = if raw < 0 { count + raw } else { raw - 1 };
    (0..count).contains(&idx).then(|| u32::try_from(idx).ok()).flatten()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_polygons_are_fanned_and_indices_checked() {
        let obj = "# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1/1 2/2 3/3 -1\n";
        let mesh = parse_obj(obj, [2.0, 1.0, 1.0]).unwrap();
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(mesh.vertices[1], Point3::new(2.0, 0.0, 0.0));
        let err = parse_obj("v 0 0 0\nf 1 2 3\n", [1.0; 3]).unwrap_err();
        assert!(err.contains("line 2"), "{err}");
        assert!(parse_obj("v 0 nan 0\n", [1.0; 3]).is_err());
    }
}
