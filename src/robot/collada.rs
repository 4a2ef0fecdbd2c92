//! A minimal COLLADA (`.dae`) reader for collision meshes: triangles,
//! polylists and polygons of every geometry instanced in the visual scene,
//! with node transforms (matrix, translate, rotate, scale) and the asset's
//! unit applied. Materials, normals and texture coordinates are ignored, and
//! so is `<up_axis>`, as Pinocchio/coal (through assimp) and ROS tools do:
//! the tests compare every mesh of example-robot-data's Baxter, TIAGo,
//! Kinova and HyQ with coal's.

use super::error::RobotError;
use super::mesh::TriMesh;
use nalgebra::{Matrix4, Point3, Rotation3, Unit, Vector3};
use std::collections::HashMap;
use std::path::Path;

type Doc<'a> = roxmltree::Document<'a>;
type Node<'a, 'i> = roxmltree::Node<'a, 'i>;

// Here, not in mesh.rs, so the mesh type does not import its COLLADA reader.
impl TriMesh {
    /// Loads the triangles of a COLLADA (`.dae`) file's visual scene, with
    /// its node transforms and unit, multiplying coordinates by `scale`.
    pub fn from_collada_file(path: &Path, scale: [f64; 3]) -> Result<TriMesh, RobotError> {
        let text =
            std::fs::read_to_string(path).map_err(|source| RobotError::Io { path: path.to_path_buf(), source })?;
        parse_collada(&text, scale).map_err(|message| RobotError::InvalidMesh { path: path.to_path_buf(), message })
    }
}

/// Parses COLLADA text into one triangle mesh, in metres, scaled by `scale`.
fn parse_collada(text: &str, scale: [f64; 3]) -> Result<TriMesh, String> {
    let doc = Doc::parse(text).map_err(|e| format!("malformed XML: {e}"))?;
    let root = doc.root_element();
    if root.tag_name().name() != "COLLADA" {
        return Err(format!("the root element is <{}>, expected <COLLADA>", root.tag_name().name()));
    }
    let unit = child(root, "asset")
        .and_then(|a| child(a, "unit"))
        .and_then(|u| u.attribute("meter"))
        .map_or(Ok(1.0), |m| m.trim().parse::<f64>().map_err(|_| format!("unit meter='{m}' is not a number")))?;
    let geometries: HashMap<&str, Node> =
        doc.descendants().filter(|n| is(n, "geometry")).filter_map(|n| Some((n.attribute("id")?, n))).collect();
    let mut mesh = TriMesh { vertices: Vec::new(), triangles: Vec::new() };
    let scene =
        root.descendants().find(|n| is(n, "instance_visual_scene")).and_then(|i| i.attribute("url")).and_then(|url| {
            doc.descendants().find(|n| is(n, "visual_scene") && n.attribute("id") == url.strip_prefix('#'))
        });
    let to_metres = Matrix4::new_nonuniform_scaling(&Vector3::new(scale[0] * unit, scale[1] * unit, scale[2] * unit));
    match scene {
        Some(scene) => {
            for node in scene.children().filter(|n| is(n, "node")) {
                add_node(node, &to_metres, &geometries, &mut mesh)?;
            }
        }
        None => {
            for g in geometries.values() {
                add_geometry(*g, &to_metres, &mut mesh)?;
            }
        }
    }
    if mesh.triangles.is_empty() {
        return Err("no triangles found in the visual scene".into());
    }
    Ok(without_unused_vertices(mesh))
}

/// Drops vertices no triangle uses: exporters often share one position
/// array between several partial meshes, and a collision hull or bound
/// must see only the surface that is there.
fn without_unused_vertices(mesh: TriMesh) -> TriMesh {
    let mut remap = vec![u32::MAX; mesh.vertices.len()];
    let mut vertices = Vec::new();
    let triangles = mesh
        .triangles
        .iter()
        .map(|t| {
            t.map(|i| {
                let slot = &mut remap[i as usize];
                if *slot == u32::MAX {
                    *slot = vertices.len() as u32;
                    vertices.push(mesh.vertices[i as usize]);
                }
                *slot
            })
        })
        .collect();
    TriMesh { vertices, triangles }
}

fn is(n: &Node, tag: &str) -> bool {
    n.is_element() && n.tag_name().name() == tag
}

fn child<'a, 'i>(n: Node<'a, 'i>, tag: &str) -> Option<Node<'a, 'i>> {
    n.children().find(|c| is(c, tag))
}

fn numbers(n: &Node) -> Result<Vec<f64>, String> {
    n.text()
        .unwrap_or_default()
        .split_whitespace()
        .map(|s| s.parse::<f64>().map_err(|_| format!("<{}>: '{s}' is not a number", n.tag_name().name())))
        .collect()
}

/// A node's transform (its children applied in document order) composed onto `parent`.
fn add_node(
    node: Node,
    parent: &Matrix4<f64>,
    geometries: &HashMap<&str, Node>,
    mesh: &mut TriMesh,
) -> Result<(), String> {
    let mut m = *parent;
    for t in node.children().filter(roxmltree::Node::is_element) {
        let v = || numbers(&t);
        match t.tag_name().name() {
            "matrix" => {
                let v = v()?;
                if v.len() != 16 {
                    return Err("<matrix> needs 16 numbers".into());
                }
                m *= Matrix4::from_row_slice(&v);
            }
            "translate" => match v()?.as_slice() {
                [x, y, z] => m *= Matrix4::new_translation(&Vector3::new(*x, *y, *z)),
                _ => return Err("<translate> needs 3 numbers".into()),
            },
            "rotate" => match v()?.as_slice() {
                [x, y, z, deg] => {
                    let axis = Unit::try_new(Vector3::new(*x, *y, *z), 1e-12).ok_or("<rotate> has a zero axis")?;
                    m *= Rotation3::from_axis_angle(&axis, deg.to_radians()).to_homogeneous();
                }
                _ => return Err("<rotate> needs 4 numbers".into()),
            },
            "scale" => match v()?.as_slice() {
                [x, y, z] => m *= Matrix4::new_nonuniform_scaling(&Vector3::new(*x, *y, *z)),
                _ => return Err("<scale> needs 3 numbers".into()),
            },
            _ => {}
        }
    }
    for item in node.children().filter(roxmltree::Node::is_element) {
        match item.tag_name().name() {
            "instance_geometry" => {
                let url = item.attribute("url").unwrap_or_default().trim_start_matches('#');
                let g =
                    geometries.get(url).ok_or_else(|| format!("instance_geometry names unknown geometry '{url}'"))?;
                add_geometry(*g, &m, mesh)?;
            }
            "node" => add_node(item, &m, geometries, mesh)?,
            _ => {}
        }
    }
    Ok(())
}

/// Appends the triangles of one `<geometry>`, transformed by `m`.
fn add_geometry(geometry: Node, m: &Matrix4<f64>, mesh: &mut TriMesh) -> Result<(), String> {
    let Some(gmesh) = child(geometry, "mesh") else { return Ok(()) };
    let source_points = |id: &str| -> Result<Vec<Point3<f64>>, String> {
        let src = gmesh
            .children()
            .find(|c| is(c, "source") && c.attribute("id") == Some(id))
            .ok_or_else(|| format!("no <source id='{id}'>"))?;
        let values = numbers(&child(src, "float_array").ok_or("a <source> without <float_array>")?)?;
        let stride = child(src, "technique_common")
            .and_then(|t| child(t, "accessor"))
            .and_then(|a| a.attribute("stride"))
            .and_then(|s| s.parse::<usize>().ok())
            .unwrap_or(3)
            .max(3);
        Ok(values.chunks_exact(stride).map(|c| m.transform_point(&Point3::new(c[0], c[1], c[2]))).collect())
    };
    let vertices = child(gmesh, "vertices").ok_or("a <mesh> without <vertices>")?;
    let position = vertices
        .children()
        .find(|c| is(c, "input") && c.attribute("semantic") == Some("POSITION"))
        .and_then(|i| i.attribute("source"))
        .ok_or("<vertices> without a POSITION input")?;
    let points = source_points(position.trim_start_matches('#'))?;
    let base = mesh.vertices.len();
    let count = points.len();
    mesh.vertices.extend(points);
    for prim in gmesh.children().filter(|c| matches!(c.tag_name().name(), "triangles" | "polylist" | "polygons")) {
        add_primitive(prim, base, count, mesh)?;
    }
    Ok(())
}

/// Fans each polygon of a `<triangles>`, `<polylist>` or `<polygons>` into triangles.
fn add_primitive(prim: Node, base: usize, count: usize, mesh: &mut TriMesh) -> Result<(), String> {
    let inputs: Vec<Node> = prim.children().filter(|c| is(c, "input")).collect();
    let offset_of = |i: &Node| i.attribute("offset").and_then(|o| o.parse::<usize>().ok()).unwrap_or(0);
    let stride = inputs.iter().map(offset_of).max().map_or(1, |m| m + 1);
    let vertex_offset = inputs
        .iter()
        .find(|i| i.attribute("semantic") == Some("VERTEX"))
        .map(offset_of)
        .ok_or("a primitive without a VERTEX input")?;
    let index = |raw: f64| -> Result<u32, String> {
        let i = raw as usize;
        if raw < 0.0 || raw.fract() != 0.0 || i >= count {
            return Err(format!("vertex index {raw} out of range (0..{count})"));
        }
        u32::try_from(base + i).map_err(|_| "more than 2^32 vertices".to_string())
    };
    let mut polygon = |corners: &[f64]| -> Result<(), String> {
        let ids: Vec<u32> = corners.chunks_exact(stride).map(|c| index(c[vertex_offset])).collect::<Result<_, _>>()?;
        if ids.len() >= 3 {
            mesh.triangles.extend((1..ids.len() - 1).map(|k| [ids[0], ids[k], ids[k + 1]]));
        }
        Ok(())
    };
    match prim.tag_name().name() {
        "polygons" => {
            for p in prim.children().filter(|c| is(c, "p")) {
                polygon(&numbers(&p)?)?;
            }
        }
        name => {
            let p = child(prim, "p").map(|p| numbers(&p)).transpose()?.unwrap_or_default();
            let sizes: Vec<usize> = if name == "polylist" {
                numbers(&child(prim, "vcount").ok_or("<polylist> without <vcount>")?)?
                    .iter()
                    .map(|v| *v as usize)
                    .collect()
            } else {
                vec![3; p.len() / (3 * stride)]
            };
            let mut at = 0;
            for size in sizes {
                let end = at + size * stride;
                polygon(p.get(at..end).ok_or("<p> is shorter than its polygon counts")?)?;
                at = end;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const DOC: &str = r##"<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit meter="0.01"/><up_axis>Z_UP</up_axis></asset>
  <library_geometries><geometry id="g"><mesh>
    <source id="pos"><float_array count="15">0 0 0 1 0 0 1 1 0 0 1 0 9 9 9</float_array>
      <technique_common><accessor source="#pos-array" count="5" stride="3"/></technique_common></source>
    <vertices id="v"><input semantic="POSITION" source="#pos"/></vertices>
    <polylist count="1"><input semantic="VERTEX" source="#v" offset="0"/><input semantic="NORMAL" source="#n" offset="1"/>
      <vcount>4</vcount><p>0 0 1 0 2 0 3 0</p></polylist>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s"><node><translate>0 0 5</translate><rotate>0 0 1 90</rotate>
    <instance_geometry url="#g"/></node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>"##;

    #[test]
    fn polylist_with_node_transform_and_unit() {
        let mesh = parse_collada(DOC, [2.0, 1.0, 1.0]).unwrap();
        // The quad fans into two triangles; the unused vertex (9 9 9) is dropped.
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(mesh.vertices.len(), 4);
        // (1, 0, 0) → rotate 90° about z → (0, 1, 0) → +5 z → ×0.01 m, x scaled by 2.
        let p = mesh.vertices[1];
        assert!((p - Point3::new(0.0, 0.01, 0.05)).norm() < 1e-12, "{p}");
        let p = mesh.vertices[3];
        assert!((p - Point3::new(-0.02, 0.0, 0.05)).norm() < 1e-12, "{p}");
    }

    #[test]
    fn malformed_documents_are_errors() {
        assert!(parse_collada("<model/>", [1.0; 3]).unwrap_err().contains("<COLLADA>"));
        let bad_index = DOC.replace("<p>0 0 1 0 2 0 3 0</p>", "<p>0 0 1 0 2 0 7 0</p>");
        assert!(parse_collada(&bad_index, [1.0; 3]).unwrap_err().contains("out of range"));
        let bad_number = DOC.replace("<translate>0 0 5</translate>", "<translate>0 x 5</translate>");
        assert!(parse_collada(&bad_number, [1.0; 3]).unwrap_err().contains("'x'"));
    }
}
