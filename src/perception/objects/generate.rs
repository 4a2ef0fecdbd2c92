//! The generator of the objects' meshes, `problems/objects/NAME.obj`
//! (tests only: the library reads the files). Bodies of revolution from
//! profile curves (r, z) walked counter-clockwise around the solid's
//! cross-section, so that their triangles face out; handles as tubes swept
//! along a Bézier curve, capped; boxes as grids; the sphere an icosphere;
//! the teapot from Newell's Bézier patches. Parts are welded (vertices
//! within 0.1 nm merged) into one mesh.

use std::collections::HashMap;
use std::f64::consts::{PI, TAU};

use super::{
    BOWL, CUBE_EDGE, CUP, JUG, LEGO_BODY, LEGO_STUD, SPHERE_RADIUS, TEAPOT_SCALE, TEAPOT_STRETCH, bowl_wall,
    cup_handle, jug_handle, jug_radius,
};
use crate::perception::mesh::TriangleMesh;

type P = [f64; 3];

/// The handles' cross-sections (m): half their thickness in the handle's
/// plane, half their width across it (along y).
const CUP_HANDLE_SECTION: [f64; 2] = [0.004, 0.006];
const JUG_HANDLE_SECTION: [f64; 2] = [0.005, 0.008];

/// The mesh of object `name`.
///
/// # Panics
/// An unknown name.
pub(super) fn generate(name: &str) -> TriangleMesh {
    let mut parts = Parts::default();
    match name {
        "cube" => cube(&mut parts),
        "sphere" => sphere(&mut parts),
        "lego_toy" => lego(&mut parts),
        "teapot" => teapot(&mut parts),
        "cup" => cup(&mut parts),
        "jug" => jug(&mut parts),
        "bowl" => bowl(&mut parts),
        _ => panic!("no generator for object '{name}'"),
    }
    parts.weld();
    if name == "teapot" {
        parts.orient();
    }
    TriangleMesh::new(parts.v, parts.t, name).unwrap()
}

/// A mesh under construction, in parts that [`Parts::weld`] keeps apart.
#[derive(Default)]
struct Parts {
    v: Vec<P>,
    t: Vec<[u32; 3]>,
    /// The part of each vertex.
    part_of: Vec<u32>,
    part: u32,
}

impl Parts {
    fn vertex(&mut self, p: P) -> u32 {
        self.v.push(p);
        self.part_of.push(self.part);
        (self.v.len() - 1) as u32
    }

    /// Vertices made from now on belong to a new part (a handle, a spout),
    /// welded to none of the parts before even where they touch.
    fn next_part(&mut self) {
        self.part += 1;
    }

    /// Triangle `abc` (counter-clockwise from outside), unless it repeats a
    /// vertex.
    fn triangle(&mut self, a: u32, b: u32, c: u32) {
        if a != b && b != c && a != c {
            self.t.push([a, b, c]);
        }
    }

    /// Quad `abcd` (counter-clockwise from outside) as two triangles.
    fn quad(&mut self, a: u32, b: u32, c: u32, d: u32) {
        self.triangle(a, b, c);
        self.triangle(a, c, d);
    }

    /// Vertices of a part within 0.1 nm merged (the first kept), triangles
    /// that then repeat a vertex dropped.
    fn weld(&mut self) {
        const TOLERANCE: f64 = 1e-10;
        let cell = |p: &P, part: u32| {
            let [x, y, z] = p.map(|c| (c / 1e-6).floor() as i64);
            [x, y, z, part as i64]
        };
        let mut grid: HashMap<[i64; 4], Vec<u32>> = HashMap::new();
        let mut kept: Vec<P> = Vec::new();
        let mut map = Vec::with_capacity(self.v.len());
        for (p, &part) in self.v.iter().zip(&self.part_of) {
            let key = cell(p, part);
            let near = |q: &P| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>() < TOLERANCE * TOLERANCE;
            let mut found = None;
            for d in 0..27 {
                let k = [key[0] + d % 3 - 1, key[1] + d / 3 % 3 - 1, key[2] + d / 9 - 1, key[3]];
                if let Some(i) = grid.get(&k).and_then(|list| list.iter().find(|&&i| near(&kept[i as usize]))) {
                    found = Some(*i);
                    break;
                }
            }
            let i = found.unwrap_or_else(|| {
                kept.push(*p);
                let i = (kept.len() - 1) as u32;
                grid.entry(key).or_default().push(i);
                i
            });
            map.push(i);
        }
        let triangles = std::mem::take(&mut self.t);
        self.v = kept;
        self.part_of.clear();
        for t in triangles {
            self.triangle(map[t[0] as usize], map[t[1] as usize], map[t[2] as usize]);
        }
    }

    /// Each connected part's triangles turned to agree with their
    /// neighbours' orientation, then the whole part turned outward
    /// (positive volume): for parts whose patches run either way.
    fn orient(&mut self) {
        let mut by_edge: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
        for (i, t) in self.t.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                by_edge.entry((a.min(b), a.max(b))).or_default().push(i);
            }
        }
        let mut seen = vec![false; self.t.len()];
        for start in 0..self.t.len() {
            if seen[start] {
                continue;
            }
            seen[start] = true;
            let (mut part, mut queue) = (vec![start], vec![start]);
            while let Some(i) = queue.pop() {
                let t = self.t[i];
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    for &j in &by_edge[&(a.min(b), a.max(b))] {
                        if seen[j] {
                            continue;
                        }
                        let u = self.t[j];
                        if (0..3).any(|m| (u[m], u[(m + 1) % 3]) == (a, b)) {
                            self.t[j].swap(1, 2);
                        }
                        seen[j] = true;
                        part.push(j);
                        queue.push(j);
                    }
                }
            }
            let volume: f64 = part
                .iter()
                .map(|&i| {
                    let [a, b, c] = self.t[i].map(|k| nalgebra::Vector3::from(self.v[k as usize]));
                    a.dot(&b.cross(&c))
                })
                .sum();
            if volume < 0.0 {
                for &i in &part {
                    self.t[i].swap(1, 2);
                }
            }
        }
    }
}

fn linspace(a: f64, b: f64, n: usize) -> Vec<f64> {
    (0..=n).map(|i| if i == n { b } else { a + (b - a) * i as f64 / n as f64 }).collect()
}

/// The surface of the box spanned by the grid lines `c` (x, y and z
/// coordinates, increasing), each face a grid; without its top face when
/// `top` is false.
fn box_grid(p: &mut Parts, c: [&[f64]; 3], top: bool) {
    for axis in 0..3 {
        for high in [false, true] {
            if axis == 2 && high && !top {
                continue;
            }
            // (u, v) with u × v along the outward normal.
            let (u, v) = if high { ((axis + 1) % 3, (axis + 2) % 3) } else { ((axis + 2) % 3, (axis + 1) % 3) };
            let level = if high { c[axis][c[axis].len() - 1] } else { c[axis][0] };
            let mut id = vec![vec![0; c[v].len()]; c[u].len()];
            for (i, &cu) in c[u].iter().enumerate() {
                for (j, &cv) in c[v].iter().enumerate() {
                    let mut q = [0.0; 3];
                    (q[axis], q[u], q[v]) = (level, cu, cv);
                    id[i][j] = p.vertex(q);
                }
            }
            for i in 0..c[u].len() - 1 {
                for j in 0..c[v].len() - 1 {
                    p.quad(id[i][j], id[i + 1][j], id[i + 1][j + 1], id[i][j + 1]);
                }
            }
        }
    }
}

/// The surface swept by turning `profile` ((r, z) points) about z in
/// `segments` steps, the point at angle θ, radius r and height z placed at
/// `place(θ, r, z)`; a profile point on the axis (r = 0) is one vertex,
/// `place(0, 0, z)`.
fn revolve(p: &mut Parts, profile: &[[f64; 2]], segments: usize, place: &dyn Fn(f64, f64, f64) -> P) {
    let rings: Vec<Vec<u32>> = profile
        .iter()
        .map(|&[r, z]| {
            if r == 0.0 {
                vec![p.vertex(place(0.0, 0.0, z)); segments]
            } else {
                (0..segments).map(|j| p.vertex(place(TAU * j as f64 / segments as f64, r, z))).collect()
            }
        })
        .collect();
    for w in rings.windows(2) {
        for j in 0..segments {
            let k = (j + 1) % segments;
            p.quad(w[0][j], w[0][k], w[1][k], w[1][j]);
        }
    }
}

fn around_z(theta: f64, r: f64, z: f64) -> P {
    [r * theta.cos(), r * theta.sin(), z]
}

/// A closed tube along the planar Bézier curve `c` ((x, z) control points,
/// in the xz-plane) of elliptic section (half thickness in the plane, half
/// width along y), `rings` steps along, `sides` around, its ends capped.
fn tube(p: &mut Parts, c: &[[f64; 2]; 4], rings: usize, sides: usize, [a, b]: [f64; 2]) {
    let bezier = |t: f64, k: usize| {
        let s = 1.0 - t;
        s * s * s * c[0][k] + 3.0 * t * s * s * c[1][k] + 3.0 * t * t * s * c[2][k] + t * t * t * c[3][k]
    };
    let slope = |t: f64, k: usize| {
        let s = 1.0 - t;
        s * s * (c[1][k] - c[0][k]) + 2.0 * t * s * (c[2][k] - c[1][k]) + t * t * (c[3][k] - c[2][k])
    };
    let mut ids = Vec::new();
    let mut centres = Vec::new();
    for i in 0..=rings {
        let t = i as f64 / rings as f64;
        let (x, z) = (bezier(t, 0), bezier(t, 1));
        let (tx, tz) = (slope(t, 0), slope(t, 1));
        let norm = tx.hypot(tz);
        // Tangent T, binormal B = y, normal N = B × T: (T, N, B) right-handed.
        let (nx, nz) = (tz / norm, -tx / norm);
        centres.push([x, 0.0, z]);
        let ring: Vec<u32> = (0..sides)
            .map(|j| {
                let phi = TAU * j as f64 / sides as f64;
                let (cn, sb) = (a * phi.cos(), b * phi.sin());
                p.vertex([x + cn * nx, sb, z + cn * nz])
            })
            .collect();
        ids.push(ring);
    }
    for w in ids.windows(2) {
        for j in 0..sides {
            let k = (j + 1) % sides;
            p.quad(w[0][j], w[0][k], w[1][k], w[1][j]);
        }
    }
    let (start, end) = (p.vertex(centres[0]), p.vertex(centres[rings]));
    for j in 0..sides {
        let k = (j + 1) % sides;
        p.triangle(start, ids[0][k], ids[0][j]);
        p.triangle(end, ids[rings][j], ids[rings][k]);
    }
}

/// The 5 cm cube, each face an 8 × 8 grid.
fn cube(p: &mut Parts) {
    let (xy, z) = (linspace(-CUBE_EDGE / 2.0, CUBE_EDGE / 2.0, 8), linspace(0.0, CUBE_EDGE, 8));
    box_grid(p, [&xy, &xy, &z], true);
}

/// An icosphere: the icosahedron's faces split in four three times (1280
/// triangles), vertices on the sphere.
fn sphere(p: &mut Parts) {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut v: Vec<P> = vec![
        [-1.0, g, 0.0],
        [1.0, g, 0.0],
        [-1.0, -g, 0.0],
        [1.0, -g, 0.0],
        [0.0, -1.0, g],
        [0.0, 1.0, g],
        [0.0, -1.0, -g],
        [0.0, 1.0, -g],
        [g, 0.0, -1.0],
        [g, 0.0, 1.0],
        [-g, 0.0, -1.0],
        [-g, 0.0, 1.0],
    ];
    let mut faces: Vec<[usize; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let unit = |q: P| {
        let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt();
        q.map(|c| c / n)
    };
    v.iter_mut().for_each(|q| *q = unit(*q));
    for _ in 0..3 {
        let mut middle: HashMap<(usize, usize), usize> = HashMap::new();
        let mut split = |a: usize, b: usize, v: &mut Vec<P>| {
            *middle.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(unit([0, 1, 2].map(|k| v[a][k] + v[b][k])));
                v.len() - 1
            })
        };
        faces = faces
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (split(a, b, &mut v), split(b, c, &mut v), split(c, a, &mut v));
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    let r = SPHERE_RADIUS;
    let ids: Vec<u32> = v.iter().map(|q| p.vertex([r * q[0], r * q[1], r * (q[2] + 1.0)])).collect();
    for [a, b, c] in faces {
        // Outward: the normal along the face's centre (from the sphere's).
        let (qa, qb, qc) = (v[a], v[b], v[c]);
        let e1 = [0, 1, 2].map(|k| qb[k] - qa[k]);
        let e2 = [0, 1, 2].map(|k| qc[k] - qa[k]);
        let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        if (0..3).map(|k| n[k] * (qa[k] + qb[k] + qc[k])).sum::<f64>() > 0.0 {
            p.triangle(ids[a], ids[b], ids[c]);
        } else {
            p.triangle(ids[a], ids[c], ids[b]);
        }
    }
}

/// A 2 × 4 brick: a box whose top is eight 20 mm cells, each an annulus
/// around a stud (a 16-sided cylinder), the box's side grid lines meeting
/// the cells' edges.
fn lego(p: &mut Parts) {
    let [lx, ly, lz] = LEGO_BODY;
    let [pitch, radius, height] = LEGO_STUD;
    let half = pitch / 2.0;
    let centres = |n: usize| (0..n).map(|i| (i as f64 - (n as f64 - 1.0) / 2.0) * pitch).collect::<Vec<_>>();
    let (cx, cy) = (centres((lx / pitch).round() as usize), centres((ly / pitch).round() as usize));
    // 16 rays from a cell's centre: the stud's rim and the cell's square edge.
    let rays: Vec<(f64, f64)> = (0..16).map(|k| (TAU * k as f64 / 16.0).sin_cos()).collect();
    let on_edges = |c: &[f64]| {
        let mut lines: Vec<f64> = c
            .iter()
            .flat_map(|&m| [-1.0, -(PI / 8.0).tan(), 0.0, (PI / 8.0).tan(), 1.0].map(|f| m + f * half))
            .collect();
        lines.sort_by(f64::total_cmp);
        lines.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        lines
    };
    box_grid(p, [&on_edges(&cx), &on_edges(&cy), &linspace(0.0, lz, 3)], false);
    for &x in &cx {
        for &y in &cy {
            let mut square = Vec::new();
            let mut rim = Vec::new();
            for &(s, c) in &rays {
                let m = s.abs().max(c.abs());
                square.push(p.vertex([x + half * c / m, y + half * s / m, lz]));
                rim.push(p.vertex([x + radius * c, y + radius * s, lz]));
            }
            for k in 0..16 {
                let j = (k + 1) % 16;
                p.quad(square[k], square[j], rim[j], rim[k]);
            }
            let stud = [[radius, lz], [radius, lz + height], [0.0, lz + height]];
            revolve(p, &stud, 16, &|t, r, z| [x + r * t.cos(), y + r * t.sin(), z]);
        }
    }
}

/// The rim's half circle from (r, z) over to (r − w, z): `n` − 1 inner points.
fn rim(profile: &mut Vec<[f64; 2]>, r: f64, z: f64, w: f64, n: usize) {
    for k in 1..n {
        let a = PI * k as f64 / n as f64;
        profile.push([r - w / 2.0 + w / 2.0 * a.cos(), z + w / 2.0 * a.sin()]);
    }
}

/// A mug: outer bottom, outer wall, rounded rim, inner wall, inner bottom
/// turned about z in 40 steps; the handle a tube on +x.
fn cup(p: &mut Parts) {
    let [r, h, w, b] = CUP;
    let top = h - w / 2.0;
    let mut profile = vec![[0.0, 0.0]];
    profile.extend((1..=3).map(|k| [r * k as f64 / 3.0, 0.0]));
    profile.extend(linspace(0.0, top, 6).into_iter().skip(1).map(|z| [r, z]));
    rim(&mut profile, r, top, w, 6);
    profile.extend(linspace(top, b, 6).into_iter().map(|z| [r - w, z]));
    profile.extend((0..3).rev().map(|k| [(r - w) * k as f64 / 3.0, b]));
    revolve(p, &profile, 40, &around_z);
    p.next_part();
    tube(p, &cup_handle(), 24, 12, CUP_HANDLE_SECTION);
}

/// A pitcher: a bellied wall of revolution ([`jug_radius`]) pulled out
/// into a lip on +x near the top, the handle a tube on −x.
fn jug(p: &mut Parts) {
    let [h, w, b] = JUG;
    let top = h - w / 2.0;
    let mut profile = vec![[0.0, 0.0]];
    profile.extend((1..=3).map(|k| [jug_radius(0.0) * k as f64 / 3.0, 0.0]));
    profile.extend(linspace(0.0, top, 12).into_iter().skip(1).map(|z| [jug_radius(z), z]));
    rim(&mut profile, jug_radius(top), top, w, 6);
    profile.extend(linspace(top, b, 12).into_iter().map(|z| [jug_radius(z) - w, z]));
    profile.extend((0..3).rev().map(|k| [(jug_radius(b) - w) * k as f64 / 3.0, b]));
    // The lip: up to 18 mm out at the rim, over the top 50 mm, within
    // about ±40° of +x.
    let lip = |theta: f64, r: f64, z: f64| {
        let rise = ((z - 0.13) / (h - 0.13)).max(0.0);
        around_z(theta, r + 0.018 * rise * rise * theta.cos().max(0.0).powi(6), z)
    };
    revolve(p, &profile, 40, &lip);
    p.next_part();
    tube(p, &jug_handle(), 24, 12, JUG_HANDLE_SECTION);
}

/// A bowl: a flat base turning up into a quarter-elliptic wall
/// ([`bowl_wall`]), rounded rim, inner wall and inner bottom, in 48 steps.
fn bowl(p: &mut Parts) {
    let [r, h, w, foot, inner_foot] = BOWL;
    let top = h - w / 2.0;
    let steps = 10;
    let phi = |k: usize| std::f64::consts::FRAC_PI_2 * k as f64 / steps as f64;
    let mut profile = vec![[0.0, 0.0], [foot / 2.0, 0.0]];
    profile.extend((0..=steps).map(|k| bowl_wall(phi(k), false)));
    rim(&mut profile, r, top, w, 6);
    profile.extend((0..=steps).rev().map(|k| bowl_wall(phi(k), true)));
    profile.extend([[inner_foot / 2.0, w], [0.0, w]]);
    revolve(p, &profile, 48, &around_z);
}

/// Newell's teapot (1975, public domain): 10 bicubic Bézier patches of 16
/// control points (indices into [`TEAPOT_POINTS`]), each mirrored into
/// four quadrants (rim, body, lid, bottom) or across y = 0 (handle,
/// spout) — the 32 patches — and its number of divisions along v (8
/// around u); Newell's units, z up.
const TEAPOT_PATCHES: [([usize; 16], bool, usize); 10] = [
    ([102, 103, 104, 105, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15], true, 4), // rim
    ([12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27], true, 8), // body
    ([24, 25, 26, 27, 29, 30, 31, 32, 33, 34, 35, 36, 37, 38, 39, 40], true, 6),
    ([96, 96, 96, 96, 97, 98, 99, 100, 101, 101, 101, 101, 0, 1, 2, 3], true, 4), // lid
    ([0, 1, 2, 3, 106, 107, 108, 109, 110, 111, 112, 113, 114, 115, 116, 117], true, 6),
    ([118, 118, 118, 118, 124, 122, 119, 121, 123, 126, 125, 120, 40, 39, 38, 37], true, 6), // bottom
    ([41, 42, 43, 44, 45, 46, 47, 48, 49, 50, 51, 52, 53, 54, 55, 56], false, 8),            // handle
    ([53, 54, 55, 56, 57, 58, 59, 60, 61, 62, 63, 64, 28, 65, 66, 67], false, 8),
    ([68, 69, 70, 71, 72, 73, 74, 75, 76, 77, 78, 79, 80, 81, 82, 83], false, 8), // spout
    ([80, 81, 82, 83, 84, 85, 86, 87, 88, 89, 90, 91, 92, 93, 94, 95], false, 8),
];

/// The control points of Newell's teapot.
#[rustfmt::skip]
const TEAPOT_POINTS: [P; 127] = [
    [0.2, 0.0, 2.7], [0.2, -0.112, 2.7], [0.112, -0.2, 2.7], [0.0, -0.2, 2.7],
    [1.3375, 0.0, 2.53125], [1.3375, -0.749, 2.53125], [0.749, -1.3375, 2.53125], [0.0, -1.3375, 2.53125],
    [1.4375, 0.0, 2.53125], [1.4375, -0.805, 2.53125], [0.805, -1.4375, 2.53125], [0.0, -1.4375, 2.53125],
    [1.5, 0.0, 2.4], [1.5, -0.84, 2.4], [0.84, -1.5, 2.4], [0.0, -1.5, 2.4],
    [1.75, 0.0, 1.875], [1.75, -0.98, 1.875], [0.98, -1.75, 1.875], [0.0, -1.75, 1.875],
    [2.0, 0.0, 1.35], [2.0, -1.12, 1.35], [1.12, -2.0, 1.35], [0.0, -2.0, 1.35],
    [2.0, 0.0, 0.9], [2.0, -1.12, 0.9], [1.12, -2.0, 0.9], [0.0, -2.0, 0.9],
    [-2.0, 0.0, 0.9],
    [2.0, 0.0, 0.45], [2.0, -1.12, 0.45], [1.12, -2.0, 0.45], [0.0, -2.0, 0.45],
    [1.5, 0.0, 0.225], [1.5, -0.84, 0.225], [0.84, -1.5, 0.225], [0.0, -1.5, 0.225],
    [1.5, 0.0, 0.15], [1.5, -0.84, 0.15], [0.84, -1.5, 0.15], [0.0, -1.5, 0.15],
    [-1.6, 0.0, 2.025], [-1.6, -0.3, 2.025], [-1.5, -0.3, 2.25], [-1.5, 0.0, 2.25],
    [-2.3, 0.0, 2.025], [-2.3, -0.3, 2.025], [-2.5, -0.3, 2.25], [-2.5, 0.0, 2.25],
    [-2.7, 0.0, 2.025], [-2.7, -0.3, 2.025], [-3.0, -0.3, 2.25], [-3.0, 0.0, 2.25],
    [-2.7, 0.0, 1.8], [-2.7, -0.3, 1.8], [-3.0, -0.3, 1.8], [-3.0, 0.0, 1.8],
    [-2.7, 0.0, 1.575], [-2.7, -0.3, 1.575], [-3.0, -0.3, 1.35], [-3.0, 0.0, 1.35],
    [-2.5, 0.0, 1.125], [-2.5, -0.3, 1.125], [-2.65, -0.3, 0.9375], [-2.65, 0.0, 0.9375],
    [-2.0, -0.3, 0.9], [-1.9, -0.3, 0.6], [-1.9, 0.0, 0.6],
    [1.7, 0.0, 1.425], [1.7, -0.66, 1.425], [1.7, -0.66, 0.6], [1.7, 0.0, 0.6],
    [2.6, 0.0, 1.425], [2.6, -0.66, 1.425], [3.1, -0.66, 0.825], [3.1, 0.0, 0.825],
    [2.3, 0.0, 2.1], [2.3, -0.25, 2.1], [2.4, -0.25, 2.025], [2.4, 0.0, 2.025],
    [2.7, 0.0, 2.4], [2.7, -0.25, 2.4], [3.3, -0.25, 2.4], [3.3, 0.0, 2.4],
    [2.8, 0.0, 2.475], [2.8, -0.25, 2.475], [3.525, -0.25, 2.49375], [3.525, 0.0, 2.49375],
    [2.9, 0.0, 2.475], [2.9, -0.15, 2.475], [3.45, -0.15, 2.5125], [3.45, 0.0, 2.5125],
    [2.8, 0.0, 2.4], [2.8, -0.15, 2.4], [3.2, -0.15, 2.4], [3.2, 0.0, 2.4],
    [0.0, 0.0, 3.15], [0.8, 0.0, 3.15], [0.8, -0.45, 3.15], [0.45, -0.8, 3.15], [0.0, -0.8, 3.15],
    [0.0, 0.0, 2.85],
    [1.4, 0.0, 2.4], [1.4, -0.784, 2.4], [0.784, -1.4, 2.4], [0.0, -1.4, 2.4],
    [0.4, 0.0, 2.55], [0.4, -0.224, 2.55], [0.224, -0.4, 2.55], [0.0, -0.4, 2.55],
    [1.3, 0.0, 2.55], [1.3, -0.728, 2.55], [0.728, -1.3, 2.55], [0.0, -1.3, 2.55],
    [1.3, 0.0, 2.4], [1.3, -0.728, 2.4], [0.728, -1.3, 2.4], [0.0, -1.3, 2.4],
    [0.0, 0.0, 0.0], [1.425, -0.798, 0.0], [1.5, 0.0, 0.075], [1.425, 0.0, 0.0], [0.798, -1.425, 0.0],
    [0.0, -1.5, 0.075], [0.0, -1.425, 0.0], [1.5, -0.84, 0.075], [0.84, -1.5, 0.075],
];

/// Newell's teapot, closed: its 32 patches, the gap between the lid's edge
/// and the rim bridged by a flat ring, the ends of the handle and spout
/// capped by fans; x and y scaled by [`TEAPOT_SCALE`], z by
/// [`TEAPOT_STRETCH`] more, the base on z = 0. Body, handle and spout are
/// three closed parts, overlapping, not welded together (the handle's lower
/// end passes through a vertex of the body, Newell's point 28). Patches run
/// either way: [`Parts::orient`] turns them outward.
fn teapot(p: &mut Parts) {
    let point = |k: usize| TEAPOT_POINTS[k];
    // (control points, in four quadrants, divisions along v, part: body, handle, spout)
    let mut patches: Vec<([P; 16], bool, usize, u32)> = TEAPOT_PATCHES
        .iter()
        .enumerate()
        .map(|(i, (ids, four, nv))| (ids.map(point), *four, *nv, [0, 0, 0, 0, 0, 0, 1, 1, 2, 2][i]))
        .collect();
    // Rows of control points joined by a ruled patch (a row to a point: a cap).
    let ruled = |from: [P; 4], to: [P; 4]| -> [P; 16] {
        std::array::from_fn(|i| match (i / 4, i % 4) {
            (0, col) => from[col],
            (3, col) => to[col],
            (row, col) => [0, 1, 2].map(|k| from[col][k] + (to[col][k] - from[col][k]) * row as f64 / 3.0),
        })
    };
    let row = |ids: [usize; 4]| ids.map(point);
    patches.push((ruled(row([114, 115, 116, 117]), row([102, 103, 104, 105])), true, 1, 0));
    for (ends, part) in [([41, 42, 43, 44], 1), ([28, 65, 66, 67], 1), ([68, 69, 70, 71], 2), ([92, 93, 94, 95], 2)] {
        let loop_ = row(ends);
        let (a, d) = (loop_[0], loop_[3]);
        let centre = [0, 1, 2].map(|k| (a[k] + d[k]) / 2.0);
        patches.push((ruled(loop_, [centre; 4]), false, 1, part));
    }
    patches.sort_by_key(|patch| patch.3);
    let (s, h) = (TEAPOT_SCALE, TEAPOT_SCALE * TEAPOT_STRETCH);
    for (control, four, nv, part) in patches {
        while p.part < part {
            p.next_part();
        }
        let mirrors: &[[f64; 2]] =
            if four { &[[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]] } else { &[[1.0, 1.0], [1.0, -1.0]] };
        for m in mirrors {
            bezier_patch(p, &control.map(|q| [m[0] * q[0] * s, m[1] * q[1] * s, q[2] * h]), 8, nv);
        }
    }
}

/// A bicubic Bézier patch (control points row by row; u along a row, v
/// across rows) as a grid of `nu` × `nv` quads.
fn bezier_patch(p: &mut Parts, control: &[P; 16], nu: usize, nv: usize) {
    let curve = |q: [P; 4], t: f64| -> P {
        let s = 1.0 - t;
        let w = [s * s * s, 3.0 * t * s * s, 3.0 * t * t * s, t * t * t];
        [0, 1, 2].map(|k| w[0] * q[0][k] + w[1] * q[1][k] + w[2] * q[2][k] + w[3] * q[3][k])
    };
    let mut id = vec![vec![0u32; nv + 1]; nu + 1];
    for (i, column) in id.iter_mut().enumerate() {
        let u = i as f64 / nu as f64;
        let rows: [P; 4] = std::array::from_fn(|r| curve([0, 1, 2, 3].map(|c| control[4 * r + c]), u));
        for (j, slot) in column.iter_mut().enumerate() {
            *slot = p.vertex(curve(rows, j as f64 / nv as f64));
        }
    }
    for i in 0..nu {
        for j in 0..nv {
            p.quad(id[i][j], id[i + 1][j], id[i + 1][j + 1], id[i][j + 1]);
        }
    }
}
