use super::*;

const POINTS: [[f64; 3]; 3] = [[0.5, -0.25, 1.0], [1.5, 2.0, -3.0], [0.125, 0.0, 4.0]];

#[test]
fn ascii_ply_with_faces_comments_and_a_missing_point() {
    let text = "ply\nformat ascii 1.0\ncomment from a depth camera\nelement vertex 4\nproperty float x\n\
                property float y\nproperty float z\nproperty uchar red\nelement face 1\n\
                property list uchar int vertex_indices\nend_header\n0.5 -0.25 1 255\n1.5 2 -3 0\nnan 0 1 3\n\
                0.125 0 4 7\n3 0 1 2\n";
    let cloud = PointCloud::from_ply(text.as_bytes(), "cam.ply").unwrap();
    assert_eq!(cloud.points, POINTS);
    assert_eq!(cloud.dropped, 1);
}

/// A binary PLY: an element with a list before the vertices (read past),
/// the vertices' coordinates as `ty` among other properties.
fn binary_ply(little: bool, double: bool) -> Vec<u8> {
    let (kind, ty) =
        (if little { "binary_little_endian" } else { "binary_big_endian" }, if double { "double" } else { "float" });
    let mut b = format!(
        "ply\nformat {kind} 1.0\nelement camera 1\nproperty list uchar ushort ids\nelement vertex 3\n\
         property uchar label\nproperty {ty} x\nproperty {ty} y\nproperty {ty} z\nend_header\n"
    )
    .into_bytes();
    let u16b = |v: u16| if little { v.to_le_bytes() } else { v.to_be_bytes() };
    b.push(2);
    b.extend(u16b(7));
    b.extend(u16b(9));
    for (k, p) in POINTS.iter().enumerate() {
        b.push(k as u8);
        for x in p {
            match (double, little) {
                (true, true) => b.extend(x.to_le_bytes()),
                (true, false) => b.extend(x.to_be_bytes()),
                (false, true) => b.extend((*x as f32).to_le_bytes()),
                (false, false) => b.extend((*x as f32).to_be_bytes()),
            }
        }
    }
    b
}

#[test]
fn binary_ply_both_byte_orders_floats_and_doubles() {
    for little in [true, false] {
        for double in [true, false] {
            let cloud = PointCloud::from_ply(&binary_ply(little, double), "b.ply").unwrap();
            assert_eq!(cloud.points, POINTS, "little {little}, double {double}");
        }
    }
    // Cut inside the last vertex: the element and record are named.
    let full = binary_ply(true, false);
    let e = PointCloud::from_ply(&full[..full.len() - 2], "cut.ply").unwrap_err().to_string();
    assert_eq!(e, "cut.ply: element vertex ends in its record 2 of 3");
}

#[test]
fn bad_ply_headers_name_the_line() {
    for (text, says) in [
        ("plx\nformat ascii 1.0\nend_header\n", "f.ply:1: a PLY file starts with the line `ply`"),
        ("ply\nformat ascii 2.0\nend_header\n", "f.ply:2: PLY version 2.0"),
        ("ply\nformat zip 1.0\nend_header\n", "f.ply:2: unknown PLY format 'zip'"),
        (
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n",
            "f.ply:3: the vertex element has no property z",
        ),
        (
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty real x\nend_header\n",
            "f.ply:4: property x: unknown type 'real'",
        ),
        ("ply\nformat ascii 1.0\nelement vertex 1\n", "f.ply: the header does not end"),
        (
            "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n",
            "f.ply: element vertex ends after 1 of 2",
        ),
        (
            "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 two 3\n",
            "f.ply:8: 'two' is not a number",
        ),
    ] {
        let e = PointCloud::from_ply(text.as_bytes(), "f.ply").unwrap_err().to_string();
        assert!(e.starts_with(says), "{text:?}: {e}");
    }
}

fn pcd_header(data: &str, fields: &str, sizes: &str, types: &str, points: usize) -> String {
    format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {fields}\nSIZE {sizes}\nTYPE {types}\n\
         COUNT {}\nWIDTH {points}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {points}\nDATA {data}\n",
        fields.split(' ').map(|_| "1").collect::<Vec<_>>().join(" ")
    )
}

#[test]
fn ascii_and_binary_pcd_with_an_rgb_field_and_a_missing_point() {
    let mut text = pcd_header("ascii", "x y z rgb", "4 4 4 4", "F F F U", 4);
    text += "0.5 -0.25 1 4278190080\n1.5 2 -3 0\nnan nan nan 0\n0.125 0 4 1\n";
    let cloud = PointCloud::from_pcd(text.as_bytes(), "a.pcd").unwrap();
    assert_eq!((cloud.points.as_slice(), cloud.dropped), (&POINTS[..], 1));

    let mut b = pcd_header("binary", "rgb x y z", "4 8 8 8", "U F F F", 3).into_bytes();
    for p in POINTS {
        b.extend(7u32.to_le_bytes());
        p.iter().for_each(|x| b.extend(x.to_le_bytes()));
    }
    assert_eq!(PointCloud::from_pcd(&b, "b.pcd").unwrap().points, POINTS);
    let e = PointCloud::from_pcd(&b[..b.len() - 1], "b.pcd").unwrap_err().to_string();
    assert!(e.contains("3 points of 28 need 84"), "{e}");
}

/// LZF as literal runs only (a valid stream liblzf decompresses).
fn lzf_literals(raw: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    for chunk in raw.chunks(32) {
        out.push((chunk.len() - 1) as u8);
        out.extend_from_slice(chunk);
    }
    out
}

#[test]
fn binary_compressed_pcd_and_lzf_back_references() {
    // Column-major: every x, then every y, then every z.
    let mut raw = Vec::new();
    for axis in 0..3 {
        POINTS.iter().for_each(|p| raw.extend((p[axis] as f32).to_le_bytes()));
    }
    let compressed = lzf_literals(&raw);
    let mut b = pcd_header("binary_compressed", "x y z", "4 4 4", "F F F", 3).into_bytes();
    b.extend((compressed.len() as u32).to_le_bytes());
    b.extend((raw.len() as u32).to_le_bytes());
    b.extend(&compressed);
    assert_eq!(PointCloud::from_pcd(&b, "c.pcd").unwrap().points, POINTS);
    // "abc" then a reference 3 back, 6 long: "abcabcabc".
    assert_eq!(pcd::lzf_for_tests(&[2, b'a', b'b', b'c', 4 << 5, 2], 9).unwrap(), b"abcabcabc");
    assert!(pcd::lzf_for_tests(&[4 << 5, 9], 6).unwrap_err().contains("before the start"));
    assert!(pcd::lzf_for_tests(&[2, b'a', b'b', b'c'], 4).unwrap_err().contains("3 bytes, 4 announced"));
}

#[test]
fn bad_pcd_headers_and_bodies_are_named() {
    for (text, says) in [
        (pcd_header("zip", "x y z", "4 4 4", "F F F", 1), "f.pcd:11: DATA 'zip'"),
        (pcd_header("ascii", "x y", "4 4", "F F", 1), "f.pcd: no field z"),
        (pcd_header("ascii", "x y z", "4 4", "F F F", 1), "f.pcd: FIELDS has 3 names, SIZE 2"),
        (pcd_header("ascii", "x y z", "4 4 4", "F F Q", 1), "f.pcd:5: TYPE 'Q'"),
        (pcd_header("ascii", "x y z", "4 4 4", "U F F", 1), "f.pcd: field x is not a float"),
        (pcd_header("ascii", "x y z", "4 4 4", "F F F", 2) + "1 2 3\n", "f.pcd: the body ends after 1 of 2"),
        (pcd_header("ascii", "x y z", "4 4 4", "F F F", 1) + "1 2\n", "f.pcd:12: 2 values, the fields have 3"),
        (String::from("VERSION 0.7\nFIELDS x y z\nDATA ascii\n"), "f.pcd: FIELDS has 3 names, SIZE 0"),
    ] {
        let e = PointCloud::from_pcd(text.as_bytes(), "f.pcd").unwrap_err().to_string();
        assert!(e.starts_with(says), "{text:?}: {e}");
    }
}

#[test]
fn files_are_read_by_extension_or_first_bytes_and_placed_by_a_pose() {
    let dir = tempfile::tempdir().unwrap();
    let ply = dir.path().join("cloud.ply");
    std::fs::write(&ply, binary_ply(true, true)).unwrap();
    let unnamed = dir.path().join("cloud.bin");
    std::fs::write(&unnamed, binary_ply(false, false)).unwrap();
    assert_eq!(PointCloud::read(&ply).unwrap().points, POINTS);
    assert_eq!(PointCloud::read(&unnamed).unwrap().points, POINTS);
    let other = dir.path().join("notes.txt");
    std::fs::write(&other, "hello").unwrap();
    assert!(PointCloud::read(&other).unwrap_err().to_string().contains("neither a PLY nor a PCD"));
    assert!(PointCloud::read(dir.path().join("absent.ply")).unwrap_err().to_string().contains("cannot read"));
    // A sensor 1 m up, turned half a turn about z.
    let pose = nalgebra::IsometryMatrix3::from_parts(
        nalgebra::Translation3::new(0.0, 0.0, 1.0),
        nalgebra::Rotation3::from_axis_angle(&nalgebra::Vector3::z_axis(), std::f64::consts::PI),
    );
    let moved = PointCloud::from_points(POINTS).transformed(&pose);
    for (a, b) in moved.points.iter().zip(POINTS) {
        assert!((a[0] + b[0]).abs() < 1e-15 && (a[1] + b[1]).abs() < 1e-15 && (a[2] - b[2] - 1.0).abs() < 1e-15);
    }
    assert_eq!(PointCloud::from_points([[f64::NAN, 0.0, 0.0], [0.0; 3]]).dropped, 1);
}

/// Random points in a 1 m cube, some repeated (ties) and a flat patch
/// (a degenerate box side), from a fixed seed.
fn scattered(n: usize, seed: u64) -> Vec<[f64; 3]> {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut points: Vec<[f64; 3]> = (0..n).map(|_| [rng.random(), rng.random(), rng.random()]).collect();
    points.extend_from_within(..n / 10);
    points.extend((0..n / 10).map(|_| [rng.random(), rng.random(), 0.5]));
    points
}

fn brute_nearest(points: &[[f64; 3]], p: &[f64; 3]) -> (f64, usize) {
    let d2 = |q: &[f64; 3]| (0..3).map(|i| (q[i] - p[i]).powi(2)).sum::<f64>();
    // First of the nearest, as the tree's ties may name another: compare distances.
    points.iter().enumerate().map(|(i, q)| (d2(q), i)).fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a })
}

#[test]
fn tree_answers_as_brute_force_does() {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    for n in [0, 1, 5, 8, 9, 100, 2000] {
        let points = scattered(n, n as u64);
        let tree = PointTree::new(&points);
        assert_eq!(tree.len(), points.len());
        for _ in 0..300 {
            let p: [f64; 3] = std::array::from_fn(|_| rng.random_range(-0.5..1.5));
            let cap: f64 = rng.random_range(0.0..0.6);
            let (d2, _) = brute_nearest(&points, &p);
            match tree.nearest(&p, f64::INFINITY) {
                Some((t2, i)) => {
                    assert_eq!(t2, d2);
                    let (q, input) = tree.point(i);
                    assert_eq!(q, points[input]);
                    assert_eq!((0..3).map(|k| (q[k] - p[k]).powi(2)).sum::<f64>(), d2);
                }
                None => assert!(points.is_empty()),
            }
            assert_eq!(tree.nearest(&p, cap).map(|(t2, _)| t2), (d2 < cap * cap).then_some(d2));
            assert_eq!(tree.any_closer(&p, cap), d2 < cap * cap, "n {n}, p {p:?}, cap {cap}");
            // A ball of radius 0.1 about p, distances to its surface.
            let ball = |q: [f64; 3]| (0..3).map(|k| (q[k] - p[k]).powi(2)).sum::<f64>().sqrt() - 0.1;
            let near = tree.nearest_to(&p, 0.1, cap, ball).map(|(d, _)| d);
            let expected = (d2.sqrt() - 0.1 < cap).then_some(d2.sqrt() - 0.1);
            assert_eq!(near.is_some(), expected.is_some());
            if let (Some(a), Some(b)) = (near, expected) {
                assert!((a - b).abs() < 1e-15, "{a} vs {b}");
            }
            let mut seen = 0;
            tree.any_near(&p, 0.1, cap, |_| {
                seen += 1;
                false
            });
            let within = points.iter().filter(|q| ball(**q) <= cap).count();
            assert_eq!(seen, within);
        }
        if !points.is_empty() {
            let (lo, hi) = tree.bounds().unwrap();
            assert!(points.iter().all(|q| (0..3).all(|k| lo[k] <= q[k] && q[k] <= hi[k])));
        }
    }
}

#[test]
fn tree_is_never_free_at_nan_and_skips_non_finite_points() {
    let tree = PointTree::new(&[[0.0, 0.0, 0.0], [f64::NAN, 0.0, 0.0], [1.0, f64::INFINITY, 0.0], [5.0, 5.0, 5.0]]);
    assert_eq!(tree.len(), 2);
    let nan = [f64::NAN, 0.0, 0.0];
    assert!(tree.any_closer(&nan, 0.01));
    assert!(tree.nearest(&nan, 1.0).unwrap().0.is_nan());
    assert!(tree.nearest_to(&nan, 0.1, 1.0, |_| 0.0).unwrap().0.is_nan());
    // Tree order names the input's index.
    let (d2, k) = tree.nearest(&[4.0, 5.0, 5.0], f64::INFINITY).unwrap();
    assert_eq!((d2, tree.point(k)), (1.0, ([5.0, 5.0, 5.0], 3)));
    // Same points, same tree.
    let points = scattered(500, 3);
    let (a, b) = (PointTree::new(&points), PointTree::new(&points));
    assert!(a.points().zip(b.points()).all(|(x, y)| x == y));
    assert!(PointTree::new(&[]).nearest(&[0.0; 3], f64::INFINITY).is_none());
}
