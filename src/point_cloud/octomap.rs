//! OctoMap's binary octree stream (`octomap_msgs/Octomap` with `binary:
//! true` and `id: OcTree`, the `data` of a MoveIt planning scene's
//! `world.octomap`; the part of a `.bt` file after its `data` line) as
//! the centres of its occupied cells.
//!
//! The stream is the tree depth first from the root, two bytes a node:
//! two bits per child (children 0–3 in the first byte, 4–7 in the second),
//! child `i`'s value `(bits >> 2i) & 3` of the 16 bits: 0 unknown, 1 free,
//! 2 occupied, 3 an inner node, whose own two bytes follow after those of
//! its earlier siblings' subtrees (OctoMap's `writeBinaryNode`). Child `i` lies on the +x side of its parent's centre
//! when bit 0 of `i` is set, +y for bit 1, +z for bit 2. The tree is 16
//! levels deep; a leaf at depth 16 is one cell of `resolution`, a leaf
//! higher up (a pruned block) is `2^(16 − depth)` cells on a side, which
//! are all returned, so every point stands for one cell.

use super::{PointCloud, PointCloudError};

/// Levels of an OctoMap tree (its keys are 16 bits).
const TREE_DEPTH: u32 = 16;
/// Cells returned at most: a pruned block near the root would be billions.
pub const OCTOMAP_MAX_CELLS: u64 = 20_000_000;

impl PointCloud {
    /// The centres (m, in the octree's frame) of the occupied cells of an
    /// OctoMap binary stream of cell size `resolution` (m): balls of
    /// `resolution × √3 / 2` around them cover the cells.
    ///
    /// # Errors
    /// A resolution that is not finite and positive, a stream that ends
    /// inside a node or goes on after the tree, a tree deeper than 16
    /// levels, or more than [`OCTOMAP_MAX_CELLS`] occupied cells; each names
    /// `file` and the byte.
    pub fn from_octomap_binary(data: &[u8], resolution: f64, file: &str) -> Result<PointCloud, PointCloudError> {
        let err = |m: String| PointCloudError::new(file, None, m);
        if !(resolution.is_finite() && resolution > 0.0) {
            return Err(err(format!("the octomap's resolution must be finite and positive, got {resolution}")));
        }
        let mut cloud = PointCloud::default();
        if data.is_empty() {
            return Ok(cloud);
        }
        // Inner nodes still to read, in stream order: (min key corner, depth).
        let mut stack: Vec<([u32; 3], u32)> = vec![([0; 3], 0)];
        let mut at = 0usize;
        let mut cells = 0u64;
        let half = f64::from(1u32 << (TREE_DEPTH - 1));
        while let Some((corner, depth)) = stack.pop() {
            if depth >= TREE_DEPTH {
                return Err(err(format!("byte {at}: an inner node at depth {depth}, below the tree's 16 levels")));
            }
            let Some(bytes) = data.get(at..at + 2) else {
                return Err(err(format!("the data ends at byte {} inside a node (2 bytes each)", data.len())));
            };
            at += 2;
            let bits = u16::from(bytes[0]) | (u16::from(bytes[1]) << 8);
            let size = 1u32 << (TREE_DEPTH - depth - 1); // a child's side, in cells
            let child_corner = |i: u32| [0, 1, 2].map(|k| corner[k] + if i >> k & 1 == 1 { size } else { 0 });
            let mut inner = Vec::new();
            for i in 0..8u32 {
                match (bits >> (2 * i)) & 0b11 {
                    0b11 => inner.push((child_corner(i), depth + 1)),
                    0b10 => {
                        cells += u64::from(size).pow(3);
                        if cells > OCTOMAP_MAX_CELLS {
                            return Err(err(format!(
                                "byte {at}: more than {OCTOMAP_MAX_CELLS} occupied cells of {resolution} m (a block of {size}³ cells)"
                            )));
                        }
                        let c = child_corner(i);
                        for x in 0..size {
                            for y in 0..size {
                                for z in 0..size {
                                    let key = [c[0] + x, c[1] + y, c[2] + z];
                                    cloud.points.push(key.map(|k| (f64::from(k) + 0.5 - half) * resolution));
                                }
                            }
                        }
                    }
                    _ => {} // unknown or free
                }
            }
            // The first child's subtree comes first in the stream.
            stack.extend(inner.into_iter().rev());
        }
        if at != data.len() {
            return Err(err(format!("{} bytes after the tree, which ends at byte {at}", data.len() - at)));
        }
        Ok(cloud)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tree of one occupied cell at the key space's centre corner: the
    /// path of child 7 (+x +y +z) then child 0 fifteen times.
    #[test]
    fn one_cell_sits_where_its_key_puts_it() {
        let mut data = vec![0b0000_0000, 0b1100_0000]; // root: child 7 inner
        for _ in 0..14 {
            data.extend([0b0000_0011, 0]); // child 0 inner
        }
        data.extend([0b0000_0010, 0]); // depth 15: child 0 occupied
        let cloud = PointCloud::from_octomap_binary(&data, 0.1, "t").unwrap();
        assert_eq!(cloud.points.len(), 1);
        for c in cloud.points[0] {
            assert!((c - 0.05).abs() < 1e-12, "{:?}", cloud.points[0]);
        }
    }

    #[test]
    fn broken_streams_are_refused_with_the_byte() {
        let e = PointCloud::from_octomap_binary(&[0b11, 0], 0.1, "t").unwrap_err().to_string();
        assert!(e.contains("ends at byte 2"), "{e}");
        let e = PointCloud::from_octomap_binary(&[0, 0, 1], 0.1, "t").unwrap_err().to_string();
        assert!(e.contains("1 bytes after the tree"), "{e}");
        let e = PointCloud::from_octomap_binary(&[0b10, 0], 0.1, "t").unwrap_err().to_string();
        assert!(e.contains("more than"), "{e}");
        assert!(PointCloud::from_octomap_binary(&[0, 0], f64::NAN, "t").is_err());
        assert!(PointCloud::from_octomap_binary(&[], 0.1, "t").unwrap().is_empty());
    }
}
