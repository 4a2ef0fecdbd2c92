//! Triangle meshes: an object's surface in its own frame (m), its Wavefront
//! OBJ files, and samples of its surface.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

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

    /// A mesh from Wavefront OBJ text; `origin` names it in errors.
    ///
    /// Reads `v x y z` (a fourth number or a colour after the three is
    /// ignored) and `f` with `i`, `i/t`, `i//n` or `i/t/n` references:
    /// 1-based, or negative for relative to the last vertex read (`-1`, the
    /// last); a polygon of more than three vertices is cut into a fan from
    /// its first vertex. `vn`, `vt`, `vp`, `o`, `g`, `s`, `usemtl`,
    /// `mtllib`, comments (`#` to the end of the line) and blank lines are
    /// skipped; any other statement is an error. A face may only name
    /// vertices read before it.
    ///
    /// # Errors
    /// The line (1-based) at fault: a bad or non-finite number, an index
    /// out of range or zero, a face of fewer than three vertices or one
    /// repeating a vertex, an unsupported statement; or a text without
    /// vertices or faces.
    pub fn parse_obj(text: &str, origin: &str) -> Result<TriangleMesh, PerceptionError> {
        let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
        let mut face: Vec<u32> = Vec::new();
        for (n, raw) in text.lines().enumerate() {
            let err = |message: String| PerceptionError::new(origin, Some(n + 1), message);
            let mut words = raw.split('#').next().unwrap_or("").split_whitespace();
            let Some(keyword) = words.next() else { continue };
            match keyword {
                "v" => {
                    let mut p = [0.0; 3];
                    for (k, c) in p.iter_mut().enumerate() {
                        let w = words.next().ok_or_else(|| err(format!("vertex of {k} coordinates, needs 3")))?;
                        *c = w
                            .parse::<f64>()
                            .ok()
                            .filter(|x| x.is_finite())
                            .ok_or_else(|| err(format!("bad number '{w}' (coordinate {} of a vertex)", k + 1)))?;
                    }
                    if vertices.len() >= u32::MAX as usize {
                        return Err(err("more vertices than a u32 index reaches".into()));
                    }
                    vertices.push(p);
                }
                "f" => {
                    face.clear();
                    for w in words {
                        face.push(vertex_index(w, vertices.len()).map_err(&err)?);
                    }
                    if face.len() < 3 {
                        return Err(err(format!("face of {} vertices, needs at least 3", face.len())));
                    }
                    for k in 1..face.len() - 1 {
                        let t = [face[0], face[k], face[k + 1]];
                        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                            return Err(err(format!("face repeats a vertex ({})", t[0].max(t[1]).max(t[2]) + 1)));
                        }
                        triangles.push(t);
                    }
                }
                "vn" | "vt" | "vp" | "o" | "g" | "s" | "usemtl" | "mtllib" => {}
                other => return Err(err(format!("unsupported OBJ statement '{other}'"))),
            }
        }
        if vertices.is_empty() {
            return Err(PerceptionError::new(origin, None, "no vertices (no 'v' line)"));
        }
        if triangles.is_empty() {
            return Err(PerceptionError::new(origin, None, "no faces (no 'f' line)"));
        }
        Ok(TriangleMesh { vertices, triangles })
    }

    /// A mesh from an OBJ file ([`parse_obj`](Self::parse_obj)).
    ///
    /// # Errors
    /// The file unreadable, or its line at fault; both name the file.
    pub fn read_obj(path: impl AsRef<Path>) -> Result<TriangleMesh, PerceptionError> {
        let name = path.as_ref().display().to_string();
        let text =
            std::fs::read_to_string(path.as_ref()).map_err(|e| PerceptionError::new(&name, None, e.to_string()))?;
        TriangleMesh::parse_obj(&text, &name)
    }

    /// The mesh as OBJ text: each line of `comment` as a `# ` line, then
    /// `v x y z` lines and 1-based `f a b c` lines.
    ///
    /// Coordinates are written rounded to 9 decimals (1 nm in metres),
    /// trailing zeros dropped, `-0` as `0`: a mesh read from such a text
    /// (of coordinates below 10⁶) is written back byte for byte, so
    /// read → write → read gives the same mesh exactly.
    pub fn to_obj(&self, comment: &str) -> String {
        let mut out = String::with_capacity(32 * self.vertices.len() + 20 * self.triangles.len());
        for line in comment.lines() {
            out.push('#');
            if !line.is_empty() {
                out.push(' ');
                out.push_str(line);
            }
            out.push('\n');
        }
        for v in &self.vertices {
            out.push('v');
            for c in v {
                let s = format!("{c:.9}");
                let s = s.trim_end_matches('0').trim_end_matches('.');
                out.push(' ');
                out.push_str(if s == "-0" { "0" } else { s });
            }
            out.push('\n');
        }
        for t in &self.triangles {
            let _ = writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
        }
        out
    }

    /// Total surface area (m²).
    pub fn area(&self) -> f64 {
        (0..self.triangles.len()).map(|i| 0.5 * self.cross(i).norm()).sum()
    }

    /// The axis-aligned bounding box: (minimum, maximum) corner (m);
    /// `([+∞; 3], [−∞; 3])` for a mesh without vertices.
    pub fn bounds(&self) -> ([f64; 3], [f64; 3]) {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for v in &self.vertices {
            for k in 0..3 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        (lo, hi)
    }

    /// Unit normal of triangle `i`, outward for a counter-clockwise
    /// triangle; zero for a triangle of no area.
    ///
    /// # Panics
    /// `i` past the triangles.
    pub fn triangle_normal(&self, i: usize) -> [f64; 3] {
        let n = self.cross(i);
        let norm = n.norm();
        if norm > 0.0 { (n / norm).into() } else { [0.0; 3] }
    }

    /// Unit normal at each vertex: the area-weighted mean of its triangles'
    /// normals; zero for a vertex of no triangle (or of no area).
    pub fn vertex_normals(&self) -> Vec<[f64; 3]> {
        let mut sum = vec![Vector3::zeros(); self.vertices.len()];
        for (i, t) in self.triangles.iter().enumerate() {
            let n = self.cross(i); // twice the area times the unit normal
            for &k in t {
                sum[k as usize] += n;
            }
        }
        sum.iter().map(|n| if n.norm() > 0.0 { n.normalize().into() } else { [0.0; 3] }).collect()
    }

    /// Whether the mesh is watertight and consistently oriented: every edge
    /// is shared by exactly two triangles, which run along it in opposite
    /// directions. False for a mesh without triangles.
    pub fn is_closed(&self) -> bool {
        let mut directed: HashMap<(u32, u32), u32> = HashMap::with_capacity(3 * self.triangles.len());
        for t in &self.triangles {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *directed.entry((a, b)).or_default() += 1;
            }
        }
        !self.triangles.is_empty() && directed.iter().all(|(&(a, b), &n)| n == 1 && directed.get(&(b, a)) == Some(&1))
    }

    /// The volume enclosed (m³), by the divergence theorem about the
    /// frame's origin: positive for a closed, outward-oriented mesh (and
    /// then independent of the origin); for overlapping closed parts, the
    /// sum of their volumes.
    pub fn signed_volume(&self) -> f64 {
        let v = |k: u32| Vector3::from(self.vertices[k as usize]);
        self.triangles.iter().map(|t| v(t[0]).dot(&v(t[1]).cross(&v(t[2])))).sum::<f64>() / 6.0
    }

    /// `count` points uniformly distributed over the surface (each triangle
    /// chosen with probability proportional to its area, then a uniform
    /// point in it), the same for the same `seed` (ChaCha8); none for a
    /// mesh of no area.
    pub fn sample_surface(&self, count: usize, seed: u64) -> Vec<[f64; 3]> {
        self.samples(count, seed).into_iter().map(|(p, _)| p).collect()
    }

    /// As [`sample_surface`](Self::sample_surface) (the same points for the
    /// same seed), each with the unit normal of its triangle.
    pub fn sample_surface_with_normals(&self, count: usize, seed: u64) -> Vec<([f64; 3], [f64; 3])> {
        self.samples(count, seed).into_iter().map(|(p, i)| (p, self.triangle_normal(i))).collect()
    }

    /// Surface samples with the triangle each lies in.
    fn samples(&self, count: usize, seed: u64) -> Vec<([f64; 3], usize)> {
        let mut total = 0.0;
        let cumulative: Vec<f64> = (0..self.triangles.len())
            .map(|i| {
                total += self.cross(i).norm();
                total
            })
            .collect();
        if count == 0 || total <= 0.0 || !total.is_finite() {
            return Vec::new();
        }
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..count)
            .map(|_| {
                let r = rng.random::<f64>() * total;
                let i = cumulative.partition_point(|&c| c <= r).min(cumulative.len() - 1);
                let (mut u, mut v) = (rng.random::<f64>(), rng.random::<f64>());
                if u + v > 1.0 {
                    (u, v) = (1.0 - u, 1.0 - v);
                }
                let [a, b, c] = self.corners(i);
                ((a + (b - a) * u + (c - a) * v).into(), i)
            })
            .collect()
    }

    fn corners(&self, i: usize) -> [Vector3<f64>; 3] {
        self.triangles[i].map(|k| Vector3::from(self.vertices[k as usize]))
    }

    /// (b − a) × (c − a) of triangle `i`: twice its area along its normal.
    fn cross(&self, i: usize) -> Vector3<f64> {
        let [a, b, c] = self.corners(i);
        (b - a).cross(&(c - a))
    }
}

/// The 0-based vertex of an OBJ face reference (`i`, `i/t`, `i//n`,
/// `i/t/n`) when `count` vertices have been read.
fn vertex_index(word: &str, count: usize) -> Result<u32, String> {
    let mut parts = word.split('/');
    let first = parts.next().unwrap_or("");
    let bad = || format!("bad vertex reference '{word}'");
    if parts.clone().count() > 2 || parts.any(|p| !p.is_empty() && p.parse::<i64>().is_err()) {
        return Err(bad());
    }
    let i: i64 = first.parse().map_err(|_| bad())?;
    let k = match i {
        0 => return Err(format!("vertex index 0 in '{word}' (OBJ indices start at 1)")),
        i if i > 0 => i - 1,
        i => count as i64 + i,
    };
    if k < 0 || k >= count as i64 {
        return Err(format!("vertex index {i} out of range: {count} vertices read so far"));
    }
    Ok(k as u32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A box `[0, s]`, outward counter-clockwise quads as OBJ text.
    fn box_obj(s: [f64; 3]) -> String {
        let mut text = String::new();
        for i in 0..8 {
            let c = |bit: usize, k: usize| if i & bit == 0 { 0.0 } else { s[k] };
            text += &format!("v {} {} {}\n", c(1, 0), c(2, 1), c(4, 2));
        }
        text + "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n"
    }

    /// Distance from `p` to triangle `abc` (closest point by projection,
    /// else the nearest edge).
    fn distance_to_triangle(p: Vector3<f64>, [a, b, c]: [Vector3<f64>; 3]) -> f64 {
        let n = (b - a).cross(&(c - a)).normalize();
        let q = p - n * n.dot(&(p - a));
        let inside = [(a, b), (b, c), (c, a)].iter().all(|&(u, v)| (v - u).cross(&(q - u)).dot(&n) >= 0.0);
        if inside {
            return (p - q).norm();
        }
        let segment = |u: Vector3<f64>, v: Vector3<f64>| {
            let t = ((p - u).dot(&(v - u)) / (v - u).norm_squared()).clamp(0.0, 1.0);
            (p - (u + (v - u) * t)).norm()
        };
        segment(a, b).min(segment(b, c)).min(segment(c, a))
    }

    #[test]
    fn parse_obj_reads_each_face_form_negative_indices_and_fans() {
        let head = "# a comment\n\nmtllib a.mtl\no thing\ng part\ns 1\nusemtl red\nvn 0 0 1\nvt 0.5 0.5\n\
                    v 0 0 0 1.0\nv 1 0 0 0.5 0.5 0.5\nv 1 1 0\nv 0 1 0 # inline comment\n";
        for face in
            ["f 1 2 3", "f 1/1 2/2 3/3", "f 1//1 2//1 3//1", "f 1/1/1 2/2/1 3/3/1", "f -4 -3 -2", "f -4/1 2//1 -2/3/1"]
        {
            let m = TriangleMesh::parse_obj(&format!("{head}{face}\n"), "t.obj").unwrap();
            assert_eq!(m.vertices.len(), 4, "{face}");
            assert_eq!(m.triangles, vec![[0, 1, 2]], "{face}");
        }
        let fan = TriangleMesh::parse_obj(&format!("{head}v 0.5 1.5 0\nf 1 2 3 5 4\n"), "t").unwrap();
        assert_eq!(fan.triangles, vec![[0, 1, 2], [0, 2, 4], [0, 4, 3]]);
        assert!((fan.area() - 1.25).abs() < 1e-15);
    }

    #[test]
    fn parse_obj_errors_name_the_origin_and_the_line() {
        let v = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        let cases = [
            (format!("{v}v 1 x 0\nf 1 2 3\n"), Some(4), "bad number 'x'"),
            (format!("{v}v 1 2\n"), Some(4), "needs 3"),
            (format!("{v}v 1 nan 0\n"), Some(4), "bad number 'nan'"),
            (format!("{v}\nf 1 2 4\n"), Some(5), "out of range"),
            (format!("{v}f 1 2 -4\n"), Some(4), "out of range"),
            (format!("{v}f 0 1 2\n"), Some(4), "index 0"),
            (format!("{v}f 1 2\n"), Some(4), "at least 3"),
            (format!("{v}f 1 2 1\n"), Some(4), "repeats"),
            (format!("{v}f 1/a 2 3\n"), Some(4), "bad vertex reference"),
            (format!("{v}curv 0 1 2\n"), Some(4), "unsupported"),
            (v.to_string(), None, "no faces"),
            ("# nothing\n".to_string(), None, "no vertices"),
        ];
        for (text, line, message) in cases {
            let e = TriangleMesh::parse_obj(&text, "cup.obj").unwrap_err();
            assert_eq!(e.line, line, "{e}");
            assert!(e.message.contains(message), "{e}");
            let prefix = line.map_or("cup.obj: ".to_string(), |l| format!("cup.obj:{l}: "));
            assert!(e.to_string().starts_with(&prefix), "{e}");
        }
    }

    #[test]
    fn obj_files_round_trip_and_read_errors_name_the_file() {
        let mut m = TriangleMesh::parse_obj(&box_obj([0.05, 0.02, 0.01]), "box").unwrap();
        m.vertices[3] = [0.1234567891234, -1e-12, -7.000000000499];
        let text = m.to_obj("a box\n\nsecond line");
        assert!(text.starts_with("# a box\n#\n# second line\nv 0 0 0\n"), "{text}");
        assert!(text.contains("v 0.123456789 0 -7\n"), "{text}");
        let back = TriangleMesh::parse_obj(&text, "text").unwrap();
        assert_eq!(back.triangles, m.triangles);
        for (a, b) in back.vertices.iter().zip(&m.vertices) {
            assert!((0..3).all(|k| (a[k] - b[k]).abs() <= 5e-10), "{a:?} {b:?}");
        }
        assert_eq!(back.to_obj("a box\n\nsecond line"), text);
        let path = std::env::temp_dir().join(format!("tandem-mesh-{}.obj", std::process::id()));
        std::fs::write(&path, &text).unwrap();
        assert_eq!(TriangleMesh::read_obj(&path).unwrap(), back);
        std::fs::write(&path, "v 0 0 0\nf 1 1 1\n").unwrap();
        let e = TriangleMesh::read_obj(&path).unwrap_err();
        assert_eq!((e.origin.as_str(), e.line), (path.display().to_string().as_str(), Some(2)));
        std::fs::remove_file(&path).unwrap();
        let e = TriangleMesh::read_obj(&path).unwrap_err();
        assert!(e.to_string().starts_with(&path.display().to_string()), "{e}");
    }

    #[test]
    fn a_box_has_its_area_volume_bounds_normals_and_is_closed() {
        let m = TriangleMesh::parse_obj(&box_obj([1.0, 1.0, 2.0]), "box").unwrap();
        assert!((m.area() - 10.0).abs() < 1e-12 && (m.signed_volume() - 2.0).abs() < 1e-12);
        assert_eq!(m.bounds(), ([0.0; 3], [1.0, 1.0, 2.0]));
        assert!(m.is_closed());
        for i in 0..m.triangles.len() {
            let n = Vector3::from(m.triangle_normal(i));
            let centre = m.corners(i).iter().sum::<Vector3<f64>>() / 3.0 - Vector3::new(0.5, 0.5, 1.0);
            assert!((n.norm() - 1.0).abs() < 1e-12 && n.dot(&centre) > 0.0, "{i}: outward");
        }
        let mut open = m.clone();
        open.triangles.pop();
        let mut flipped = m.clone();
        flipped.triangles[0].swap(1, 2);
        assert!(!open.is_closed() && !flipped.is_closed() && !TriangleMesh::default().is_closed());
        // A regular octahedron: every vertex's normal points away from the centre.
        let oct = TriangleMesh::parse_obj(
            "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n\
             f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n",
            "octahedron",
        )
        .unwrap();
        assert!(oct.is_closed() && (oct.signed_volume() - 4.0 / 3.0).abs() < 1e-12);
        for (v, n) in oct.vertices.iter().zip(oct.vertex_normals()) {
            assert!((0..3).all(|k| (v[k] - n[k]).abs() < 1e-12), "{v:?} {n:?}");
        }
    }

    #[test]
    fn surface_samples_are_deterministic_on_the_surface_and_area_weighted() {
        let m = TriangleMesh::parse_obj(&box_obj([1.0, 1.0, 2.0]), "box").unwrap();
        let n = 20_000;
        let a = m.sample_surface(n, 7);
        assert_eq!(a.len(), n);
        assert_eq!(a, m.sample_surface(n, 7));
        assert_ne!(a, m.sample_surface(n, 8));
        let with_normals = m.sample_surface_with_normals(n, 7);
        assert!(with_normals.iter().zip(&a).all(|((p, _), q)| p == q));
        // On the surface: as near as rounding to some triangle, whose
        // normal is the one returned.
        for (p, normal) in with_normals.iter().take(2000) {
            let p = Vector3::from(*p);
            let (d, i) = (0..m.triangles.len())
                .map(|i| (distance_to_triangle(p, m.corners(i)), i))
                .fold((f64::INFINITY, 0), |best, x| if x.0 < best.0 { x } else { best });
            assert!(d < 1e-12, "{p:?} {d}");
            assert_eq!(*normal, m.triangle_normal(i));
        }
        // Faces x = 0, x = 1, y = 0, y = 1 (area 2 of 10) and z = 0, z = 2 (area 1).
        let mut counts = [0usize; 6];
        for p in &a {
            let face = (0..3)
                .flat_map(|k| [(k, 0.0), (k, [1.0, 1.0, 2.0][k])])
                .position(|(k, c)| (p[k] - c).abs() < 1e-12)
                .unwrap();
            counts[face] += 1;
        }
        for (face, &count) in counts.iter().enumerate() {
            let p = if face < 4 { 0.2 } else { 0.1 };
            let sigma = (n as f64 * p * (1.0 - p)).sqrt();
            assert!((count as f64 - n as f64 * p).abs() < 3.0 * sigma, "face {face}: {count} of {n}");
        }
        assert!(m.sample_surface(0, 1).is_empty() && TriangleMesh::default().sample_surface(5, 1).is_empty());
    }
}
