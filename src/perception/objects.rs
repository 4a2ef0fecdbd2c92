//! The seven objects of Table 7.1 of the dissertation — cube, sphere, lego
//! toy, teapot, cup, jug, bowl — as the perception pipeline knows them: a
//! mesh, a mass, a symmetry and grasp frames for the Franka Panda.
//!
//! **Meshes.** Each is an OBJ file of `problems/objects/` (metres), embedded
//! in the library and read by [`catalog`] and [`object`]. The files are made
//! by the generator of `objects/generate.rs` (compiled in tests only); a
//! test checks every committed file against it byte for byte, and
//! `TANDEM_WRITE_OBJECTS=1 cargo test --lib perception::objects` rewrites
//! them. Every mesh is closed and outward-oriented
//! ([`TriangleMesh::is_closed`]): the cup, jug and bowl as thin-walled
//! solids (outer wall, rounded rim, inner wall, inner bottom), open at the
//! top so that a camera looking in sees their inside; handles, the teapot's
//! spout and handle as closed parts of their own overlapping the body (their
//! capped ends hidden in the wall or body).
//!
//! **Frames.** An object's frame has its origin at the centre of its base,
//! z up, so that the object rests on the plane z = 0; the axis of the
//! bodies of revolution is z, a handle lies on −x (jug, teapot) or +x (cup),
//! the jug's lip and the teapot's spout on +x.
//!
//! **Grasp frames** follow tandem's gripper convention (`problems/README.md`,
//! `panda_grasp_box.toml`): the frame the gripper frame (`panda_hand_tcp`,
//! the fingertips' centre) goes to, its z the approach direction, its y the
//! axis the fingers close along, x = y × z. Each object has a top grasp
//! (z pointing down, `rpy = [π, 0, yaw]`) whose origin lies at most
//! [`GRASP_DEPTH`] below the object's top (the Panda's fingers reach
//! 27.7 mm past its palm) across less than the gripper's 80 mm opening;
//! the containers are gripped by their wall at the rim, and cup, jug and
//! teapot also have a side grasp of their handle (approach horizontal,
//! fingers closing across the handle).
//!
//! **Masses** are the mesh's volume times a density: solid beech wood
//! (700 kg/m³) for the cube and sphere; ceramic (stoneware, 2400 kg/m³)
//! over the modelled walls of the cup, jug and bowl, and over a 4 mm shell
//! of the teapot's surface (its mesh is the solid outer envelope); the lego
//! toy is hollow like the real brick, whose 2.32 g scaled by 2.5³ it weighs.

use std::f64::consts::{FRAC_PI_2, PI};

use nalgebra::{IsometryMatrix3, Matrix3, Rotation3, Translation3, Vector3};

use super::mesh::TriangleMesh;

#[cfg(test)]
mod generate;

/// The objects of Table 7.1, in its order.
pub const OBJECT_NAMES: [&str; 7] = ["cube", "sphere", "lego_toy", "teapot", "cup", "jug", "bowl"];

/// An object's rotational symmetry, which a pose estimate cannot resolve.
///
/// Registration starts from several initial hypotheses related by the
/// symmetry (and may stop at any of them), and the pose error is ADD (the
/// mean distance of corresponding model points) for [`Symmetry::None`],
/// ADD-S (the mean distance to the nearest model point) otherwise.
/// Rotations are about the object's centre: the middle of its mesh's
/// bounds for `Cube` and `Sphere`, the z axis through the frame's origin
/// for `RevolutionZ`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Symmetry {
    /// None modelled (the lego toy's half turn about z included).
    None,
    /// The cube's 24 rotations.
    Cube,
    /// Any rotation about the object's z axis.
    RevolutionZ,
    /// Any rotation about the centre.
    Sphere,
}

/// An object of the catalog.
#[derive(Debug, Clone)]
pub struct ObjectModel {
    /// Its name, one of [`OBJECT_NAMES`].
    pub name: &'static str,
    /// Its surface in the object frame (m).
    pub mesh: TriangleMesh,
    /// Mass (kg); see the [module documentation](self) for the densities.
    pub mass_kg: f64,
    /// Its symmetry.
    pub symmetry: Symmetry,
    /// Grasp frames in the object frame, the top grasp first.
    pub grasps: Vec<IsometryMatrix3<f64>>,
    /// The OBJ file of its mesh, relative to the repository's root.
    pub file: &'static str,
    /// Where the mesh comes from, and its licence.
    pub source: &'static str,
}

/// The seven objects of Table 7.1, in its order ([`OBJECT_NAMES`]).
pub fn catalog() -> Vec<ObjectModel> {
    OBJECT_NAMES.iter().filter_map(|name| object(name)).collect()
}

/// The object named `name` (one of [`OBJECT_NAMES`]), `None` for another.
pub fn object(name: &str) -> Option<ObjectModel> {
    macro_rules! obj {
        ($name:literal) => {
            (
                $name,
                include_str!(concat!("../../problems/objects/", $name, ".obj")),
                concat!("problems/objects/", $name, ".obj"),
            )
        };
    }
    let ((name, text, file), mass_kg, symmetry, grasps) = match name {
        "cube" => (obj!("cube"), CUBE_MASS, Symmetry::Cube, cube_grasps()),
        "sphere" => (obj!("sphere"), SPHERE_MASS, Symmetry::Sphere, sphere_grasps()),
        "lego_toy" => (obj!("lego_toy"), LEGO_MASS, Symmetry::None, lego_grasps()),
        "teapot" => (obj!("teapot"), TEAPOT_MASS, Symmetry::None, teapot_grasps()),
        "cup" => (obj!("cup"), CUP_MASS, Symmetry::None, cup_grasps()),
        "jug" => (obj!("jug"), JUG_MASS, Symmetry::None, jug_grasps()),
        "bowl" => (obj!("bowl"), BOWL_MASS, Symmetry::RevolutionZ, bowl_grasps()),
        _ => return None,
    };
    let source = source(name);
    let mesh = TriangleMesh::parse_obj(text, file).expect("the embedded OBJ files parse (tested)");
    Some(ObjectModel { name, mesh, mass_kg, symmetry, grasps, file, source })
}

/// How far below an object's top a top grasp's origin (the fingertips'
/// centre) lies (m): well within the Panda's 27.7 mm reach past its palm.
pub const GRASP_DEPTH: f64 = 0.012;

const GENERATED: &str = "generated by tandem (src/perception/objects/generate.rs), MIT OR Apache-2.0";
const TEAPOT_SOURCE: &str = "Newell's teapot (1975), public domain: its 32 Bezier patches tessellated by tandem \
     (src/perception/objects/generate.rs), lid gap bridged, handle and spout capped";

/// Where object `name`'s mesh comes from, and its licence.
fn source(name: &str) -> &'static str {
    if name == "teapot" { TEAPOT_SOURCE } else { GENERATED }
}

// Masses (kg): volume × density, see the module documentation.
const CUBE_MASS: f64 = 0.0875;
const SPHERE_MASS: f64 = 0.126;
const LEGO_MASS: f64 = 0.0363;
const TEAPOT_MASS: f64 = 0.337;
const CUP_MASS: f64 = 0.267;
const JUG_MASS: f64 = 0.722;
const BOWL_MASS: f64 = 0.425;

// Geometry (m).
const CUBE_EDGE: f64 = 0.05;
const SPHERE_RADIUS: f64 = 0.035;
/// The lego toy's body (without studs): a 2 × 4 brick scaled 2.5×.
const LEGO_BODY: [f64; 3] = [0.08, 0.04, 0.024];
/// Distance between stud centres, stud radius and height.
const LEGO_STUD: [f64; 3] = [0.02, 0.006, 0.004];
/// Cup: outer radius, height, wall, bottom thickness.
const CUP: [f64; 4] = [0.04, 0.09, 0.004, 0.005];
/// Cup handle: lower and upper end heights, reach out from the wall.
const CUP_HANDLE: [f64; 3] = [0.024, 0.074, 0.034];
/// Jug: height, wall, bottom thickness.
const JUG: [f64; 3] = [0.18, 0.004, 0.006];
/// The jug's outer radius (m) at heights (m), before its lip.
const JUG_PROFILE: [[f64; 2]; 6] =
    [[0.0, 0.052], [0.04, 0.058], [0.08, 0.06], [0.12, 0.055], [0.15, 0.05], [0.18, 0.053]];
/// Jug handle: lower and upper end heights, reach out from the wall.
const JUG_HANDLE: [f64; 3] = [0.06, 0.15, 0.045];
/// Bowl: rim radius, height, wall, radius of the flat of its base outside
/// and inside.
const BOWL: [f64; 5] = [0.08, 0.05, 0.005, 0.04, 0.035];
/// The teapot: metres per unit of Newell's data across, and the stretch of
/// its heights (the classic data is the real Melitta teapot squashed by 1.3).
const TEAPOT_SCALE: f64 = 3.0 / 128.0;
const TEAPOT_STRETCH: f64 = 1.3;

/// The jug's outer radius at height `z` (m), before its lip: a cubic
/// Hermite spline through [`JUG_PROFILE`] (slopes from the neighbours).
fn jug_radius(z: f64) -> f64 {
    let p = &JUG_PROFILE;
    let k = p.iter().rposition(|q| q[0] <= z).unwrap_or(0).min(p.len() - 2);
    let slope = |i: usize| {
        let (a, b) = (p[i.saturating_sub(1)], p[(i + 1).min(p.len() - 1)]);
        (b[1] - a[1]) / (b[0] - a[0])
    };
    let h = p[k + 1][0] - p[k][0];
    let t = ((z - p[k][0]) / h).clamp(0.0, 1.0);
    let (t2, t3) = (t * t, t * t * t);
    (2.0 * t3 - 3.0 * t2 + 1.0) * p[k][1]
        + (t3 - 2.0 * t2 + t) * h * slope(k)
        + (-2.0 * t3 + 3.0 * t2) * p[k + 1][1]
        + (t3 - t2) * h * slope(k + 1)
}

/// A point of the bowl's outer (or inner) wall profile (r, z) at `phi`
/// (0 at the base, π/2 at the rim): a quarter ellipse from the flat of the
/// base up to the rim, the inner one a wall's thickness inside.
fn bowl_wall(phi: f64, inner: bool) -> [f64; 2] {
    let [radius, height, wall, foot, inner_foot] = BOWL;
    let top = height - wall / 2.0;
    if inner {
        let r = inner_foot + (radius - wall - inner_foot) * phi.sin();
        [r, wall + (top - wall) * (1.0 - phi.cos())]
    } else {
        [foot + (radius - foot) * phi.sin(), top * (1.0 - phi.cos())]
    }
}

/// The bowl wall's radius at height `z` on the outer (or inner) wall.
fn bowl_radius_at(z: f64, inner: bool) -> f64 {
    let [_, height, wall, ..] = BOWL;
    let top = height - wall / 2.0;
    let cos = if inner { 1.0 - (z - wall) / (top - wall) } else { 1.0 - z / top };
    bowl_wall(cos.clamp(-1.0, 1.0).acos(), inner)[0]
}

/// A handle's centre line: a cubic Bézier curve in the xz-plane, (x, z)
/// control points, leaving the wall and coming back to it horizontally
/// (each end in the middle of the wall, at `x` of sign `side`).
fn handle_curve(ends: [[f64; 2]; 2], reach: f64, side: f64) -> [[f64; 2]; 4] {
    let [a, b] = ends;
    [a, [a[0] + side * reach, a[1]], [b[0] + side * reach, b[1]], b]
}

fn cup_handle() -> [[f64; 2]; 4] {
    let [radius, _, wall, _] = CUP;
    let [low, high, reach] = CUP_HANDLE;
    let x = radius - wall / 2.0;
    handle_curve([[x, high], [x, low]], reach, 1.0)
}

fn jug_handle() -> [[f64; 2]; 4] {
    let [_, wall, _] = JUG;
    let [low, high, reach] = JUG_HANDLE;
    let end = |z: f64| [-(jug_radius(z) - wall / 2.0), z];
    handle_curve([end(high), end(low)], reach, -1.0)
}

/// The middle of a handle's centre line (its farthest point from the wall).
fn handle_middle(c: &[[f64; 2]; 4]) -> [f64; 3] {
    let m = |k: usize| (c[0][k] + 3.0 * c[1][k] + 3.0 * c[2][k] + c[3][k]) / 8.0;
    [m(0), 0.0, m(1)]
}

/// A top grasp at `p`: approach straight down, fingers closing along the
/// horizontal direction at angle `closing` from x (`rpy = [π, 0, closing + π/2]`).
fn top_grasp(p: [f64; 3], closing: f64) -> IsometryMatrix3<f64> {
    IsometryMatrix3::from_parts(
        Translation3::new(p[0], p[1], p[2]),
        Rotation3::from_euler_angles(PI, 0.0, closing + FRAC_PI_2),
    )
}

/// A grasp at `p` approaching along `approach`, fingers closing along
/// `closing` (orthogonal unit vectors).
fn side_grasp(p: [f64; 3], approach: [f64; 3], closing: [f64; 3]) -> IsometryMatrix3<f64> {
    let (z, y) = (Vector3::from(approach), Vector3::from(closing));
    let rotation = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[y.cross(&z), y, z]));
    IsometryMatrix3::from_parts(Translation3::new(p[0], p[1], p[2]), rotation)
}

/// Top grasps, the fingers closing along x, then along y.
fn cube_grasps() -> Vec<IsometryMatrix3<f64>> {
    let p = [0.0, 0.0, CUBE_EDGE - GRASP_DEPTH];
    vec![top_grasp(p, 0.0), top_grasp(p, FRAC_PI_2)]
}

/// A top grasp 20 mm below the top, where the sphere is 63 mm across.
fn sphere_grasps() -> Vec<IsometryMatrix3<f64>> {
    vec![top_grasp([0.0, 0.0, 2.0 * SPHERE_RADIUS - 0.02], 0.0)]
}

/// A top grasp across the brick's 40 mm width.
fn lego_grasps() -> Vec<IsometryMatrix3<f64>> {
    vec![top_grasp([0.0, 0.0, LEGO_BODY[2] + LEGO_STUD[2] - GRASP_DEPTH], FRAC_PI_2)]
}

/// A top grasp of the lid's knob (7 mm below its top); a side grasp of
/// the handle's outer bar, approaching along +x.
fn teapot_grasps() -> Vec<IsometryMatrix3<f64>> {
    let (s, h) = (TEAPOT_SCALE, TEAPOT_SCALE * TEAPOT_STRETCH);
    vec![
        top_grasp([0.0, 0.0, 3.15 * h - 0.007], 0.0),
        side_grasp([-2.85 * s, 0.0, 1.8 * h], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ]
}

/// Top grasps of the wall at the rim on +y and on −x, the fingers closing
/// across the wall; a side grasp of the handle, approaching along −x.
fn cup_grasps() -> Vec<IsometryMatrix3<f64>> {
    let [radius, height, wall, _] = CUP;
    let r = radius - wall / 2.0;
    vec![
        top_grasp([0.0, r, height - GRASP_DEPTH], FRAC_PI_2),
        top_grasp([-r, 0.0, height - GRASP_DEPTH], PI),
        side_grasp(handle_middle(&cup_handle()), [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ]
}

/// A top grasp of the wall at the rim on +y; a side grasp of the handle,
/// approaching along +x.
fn jug_grasps() -> Vec<IsometryMatrix3<f64>> {
    let [height, wall, _] = JUG;
    let z = height - GRASP_DEPTH;
    vec![
        top_grasp([0.0, jug_radius(z) - wall / 2.0, z], FRAC_PI_2),
        side_grasp(handle_middle(&jug_handle()), [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
    ]
}

/// A top grasp of the wall at the rim on +x.
fn bowl_grasps() -> Vec<IsometryMatrix3<f64>> {
    let z = BOWL[1] - GRASP_DEPTH;
    let r = (bowl_radius_at(z, false) + bowl_radius_at(z, true)) / 2.0;
    vec![top_grasp([r, 0.0, z], 0.0)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    /// The OBJ text of object `name` as the generator makes it.
    fn generated_obj(name: &str) -> String {
        let header = format!(
            "{name}: {}\nmetres; object frame: origin at the centre of the base, z up\n\
             made by src/perception/objects/generate.rs (TANDEM_WRITE_OBJECTS=1 cargo test --lib perception::objects)",
            source(name)
        );
        generate::generate(name).to_obj(&header)
    }

    fn repo_file(file: &str) -> std::path::PathBuf {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(file)
    }

    #[test]
    fn committed_files_match_the_generator() {
        let write = std::env::var("TANDEM_WRITE_OBJECTS").is_ok_and(|v| v == "1");
        for name in OBJECT_NAMES {
            let (text, file) = (generated_obj(name), format!("problems/objects/{name}.obj"));
            if write {
                std::fs::write(repo_file(&file), &text).unwrap();
                continue;
            }
            let committed = std::fs::read_to_string(repo_file(&file)).unwrap();
            assert!(committed == text, "{file} differs from the generator: TANDEM_WRITE_OBJECTS=1");
            let model = object(name).unwrap();
            assert_eq!(model.file, file);
            assert_eq!(model.mesh, TriangleMesh::parse_obj(&text, &file).unwrap(), "{name}");
        }
        assert!(!write, "files written: run again without TANDEM_WRITE_OBJECTS to check them");
    }

    #[test]
    fn the_readme_describes_every_file_with_its_triangles_and_mass() {
        let readme = std::fs::read_to_string(repo_file("problems/objects/README.md")).unwrap();
        for model in catalog() {
            let file = model.file.rsplit('/').next().unwrap();
            let row =
                readme.lines().find(|l| l.starts_with(&format!("| `{file}` |"))).unwrap_or_else(|| panic!("{file}"));
            let cells: Vec<&str> = row.split('|').map(str::trim).collect();
            assert_eq!(cells[3], model.mesh.triangles.len().to_string(), "{file}");
            assert!(cells[4].starts_with(&format!("{} kg", model.mass_kg)), "{file}: {}", cells[4]);
            assert!(cells[5].starts_with(model.source.split(':').next().unwrap()), "{file}: {}", cells[5]);
        }
    }

    #[test]
    fn the_catalog_holds_the_seven_objects_in_table_order() {
        let names: Vec<_> = catalog().iter().map(|m| m.name).collect();
        assert_eq!(names, OBJECT_NAMES);
        assert!(object("teacup").is_none());
        assert_eq!(object("bowl").unwrap().symmetry, Symmetry::RevolutionZ);
    }

    /// (lower, upper) bounds of each object, as documented (m).
    fn documented_bounds(name: &str) -> ([f64; 3], [f64; 3]) {
        match name {
            "cube" => ([-0.025, -0.025, 0.0], [0.025, 0.025, 0.05]),
            "sphere" => ([-0.035, -0.035, 0.0], [0.035, 0.035, 0.07]),
            "lego_toy" => ([-0.04, -0.02, 0.0], [0.04, 0.02, 0.028]),
            "teapot" => ([-0.0703, -0.0469, 0.0], [0.0804, 0.0469, 0.096]),
            "cup" => ([-0.04, -0.04, 0.0], [0.0675, 0.04, 0.09]),
            "jug" => ([-0.092, -0.0601, 0.0], [0.0698, 0.0601, 0.18]),
            "bowl" => ([-0.08, -0.08, 0.0], [0.08, 0.08, 0.05]),
            _ => unreachable!(),
        }
    }

    #[test]
    fn every_object_is_closed_of_positive_volume_within_its_bounds_and_size() {
        for model in catalog() {
            let m = &model.mesh;
            let name = model.name;
            assert!(m.is_closed(), "{name} is not watertight and consistently oriented");
            assert!(m.signed_volume() > 0.0, "{name}");
            assert!((500..=6000).contains(&m.triangles.len()), "{name}: {} triangles", m.triangles.len());
            let (lo, hi) = m.bounds();
            let (want_lo, want_hi) = documented_bounds(name);
            for k in 0..3 {
                assert!(
                    (lo[k] - want_lo[k]).abs() < 1e-3 && (hi[k] - want_hi[k]).abs() < 1e-3,
                    "{name}: {lo:?} {hi:?}"
                );
            }
            assert_eq!(lo[2], 0.0, "{name} rests on z = 0");
            assert!(model.mass_kg > 0.01 && model.mass_kg < 1.5, "{name}: {} kg", model.mass_kg);
        }
    }

    #[test]
    fn cube_sphere_and_lego_have_their_analytic_volume_and_area() {
        let cube = object("cube").unwrap().mesh;
        assert!((cube.signed_volume() - CUBE_EDGE.powi(3)).abs() < 1e-12);
        assert!((cube.area() - 6.0 * CUBE_EDGE.powi(2)).abs() < 1e-12);
        let sphere = object("sphere").unwrap().mesh;
        let r = SPHERE_RADIUS;
        assert!((sphere.signed_volume() / (4.0 / 3.0 * PI * r.powi(3)) - 1.0).abs() < 0.02);
        assert!((sphere.area() / (4.0 * PI * r * r) - 1.0).abs() < 0.02);
        for v in &sphere.vertices {
            assert!(((v[0].powi(2) + v[1].powi(2) + (v[2] - r).powi(2)).sqrt() - r).abs() < 1e-9);
        }
        // The body and eight studs, 16-gons.
        let lego = object("lego_toy").unwrap().mesh;
        let [_, stud_r, stud_h] = LEGO_STUD;
        let stud_area = 8.0 * stud_r * stud_r * (PI / 8.0).sin();
        let volume = LEGO_BODY.iter().product::<f64>() + 8.0 * stud_area * stud_h;
        // Exact but for the files' rounding to 1 nm.
        assert!((lego.signed_volume() - volume).abs() < 1e-11, "{}", lego.signed_volume());
        let [x, y, z] = LEGO_BODY;
        let walls = 8.0 * 16.0 * 2.0 * stud_r * (PI / 16.0).sin() * stud_h;
        assert!((lego.area() - 2.0 * (x * y + x * z + y * z) - walls).abs() < 1e-9, "{}", lego.area());
    }

    #[test]
    fn masses_are_the_documented_densities_times_the_volumes() {
        let volume = |name: &str| object(name).unwrap().mesh.signed_volume();
        let expected = [
            ("cube", 700.0 * volume("cube")),
            ("sphere", 700.0 * 4.0 / 3.0 * PI * SPHERE_RADIUS.powi(3)),
            ("lego_toy", 0.00232 * 2.5f64.powi(3)),
            ("teapot", 2400.0 * 0.004 * object("teapot").unwrap().mesh.area()),
            ("cup", 2400.0 * volume("cup")),
            ("jug", 2400.0 * volume("jug")),
            ("bowl", 2400.0 * volume("bowl")),
        ];
        let wrong: Vec<String> = expected
            .iter()
            .filter(|(name, mass)| (object(name).unwrap().mass_kg / mass - 1.0).abs() > 0.01)
            .map(|(name, mass)| format!("{name}: {} kg, expected {mass:.4}", object(name).unwrap().mass_kg))
            .collect();
        assert!(wrong.is_empty(), "{wrong:?}");
    }

    #[test]
    fn containers_are_open_and_hollow() {
        // Nothing near the axis above the inner bottom: a camera looking
        // down into the cup, jug or bowl sees the inside.
        for (name, bottom, radius) in [("cup", CUP[3], CUP[0]), ("jug", JUG[2], 0.05), ("bowl", BOWL[2], BOWL[4])] {
            let m = object(name).unwrap().mesh;
            for v in &m.vertices {
                if v[0].hypot(v[1]) < radius - 0.006 {
                    assert!(v[2] <= bottom + 1e-9, "{name}: {v:?}");
                }
            }
        }
        // Handles stay out of the inside.
        for (name, inner) in [("cup", CUP[0] - CUP[2]), ("jug", 0.0)] {
            let m = object(name).unwrap().mesh;
            for v in &m.vertices {
                let inner = if name == "jug" { jug_radius(v[2]) - JUG[1] } else { inner };
                let r = v[0].hypot(v[1]);
                assert!(
                    r >= inner - 1e-9 || r < 1e-12 || (v[2] - CUP[3].max(JUG[2])).abs() < 0.002 || r < inner - 0.003
                );
            }
        }
    }

    /// The object's extent between the fingers of `grasp`: twice the
    /// largest |y| of surface points in the fingers' way (|x| < 1 cm,
    /// |z| < 5 mm in the grasp frame) within 5 cm of the frame's origin,
    /// with the least y; and the grasp's depth (`grasp_depth` of
    /// `problem::grasp`: the object's extent above the origin against z).
    fn opening(m: &TriangleMesh, grasp: &IsometryMatrix3<f64>) -> (f64, f64, f64) {
        let inverse = grasp.inverse();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in m.sample_surface(40_000, 3) {
            let q = inverse * Point3::from(p);
            if q.x.abs() < 0.01 && q.z.abs() < 0.005 && q.y.abs() < 0.05 {
                lo = lo.min(q.y);
                hi = hi.max(q.y);
            }
        }
        let up = -(grasp.rotation * Vector3::z());
        let depth = m.vertices.iter().map(|v| Vector3::from(*v).dot(&up)).fold(f64::NEG_INFINITY, f64::max)
            - grasp.translation.vector.dot(&up);
        (2.0 * lo.abs().max(hi.abs()), lo, depth)
    }

    #[test]
    fn every_grasp_fits_the_panda_gripper() {
        for model in catalog() {
            let name = model.name;
            let top = &model.grasps[0];
            assert!((top.rotation * Vector3::z()).dot(&-Vector3::z()) > 1.0 - 1e-12, "{name}: top grasp first");
            for (i, g) in model.grasps.iter().enumerate() {
                let r = g.rotation.matrix();
                assert!(
                    (r.determinant() - 1.0).abs() < 1e-12 && (r.transpose() * r - Matrix3::identity()).norm() < 1e-12
                );
                let (width, lo, depth) = opening(&model.mesh, g);
                println!("{name} grasp {i}: opening {:.1} mm, depth {:.1} mm", width * 1e3, depth * 1e3);
                assert!(width < 0.074, "{name} grasp {i}: {width} m between the fingers");
                assert!(lo < -0.001 && lo > -width / 2.0 - 1e-12, "{name} grasp {i}: object on both sides");
                assert!(depth > 0.002 && depth < 0.0277, "{name} grasp {i}: {depth} m deep");
            }
        }
    }
}
