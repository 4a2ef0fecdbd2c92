//! Point clouds as a depth camera or a lidar gives them: the points
//! themselves, read from the files sensors and their drivers write.
//!
//! [`PointCloud::read`] takes PLY (ASCII, binary little- and big-endian;
//! the `vertex` element's `x`, `y`, `z` of any numeric type) and PCD
//! (PCL's format: `ascii`, `binary` and `binary_compressed`, fields `x`,
//! `y`, `z` as `F` 4 or 8 bytes), organised or not. Points with a NaN or
//! infinite coordinate — a depth camera's missing pixels in an organised
//! cloud — are dropped and counted ([`PointCloud::dropped`]). Every error
//! names the file and, where there is one, the header line or the point.
//!
//! The points are in the frame the file gives them in (the sensor's or the
//! robot's root frame: a file says nothing about it); placing them is the
//! caller's (see [`PointCloud::transformed`]). [`PointCloud::filtered`]
//! crops, range-limits and thins a cloud, and says how much the point
//! radius must grow for the thinned cloud to stand for the whole.
//! [`DepthProjection`] turns a depth camera's images into points.

mod depth;
mod filter;
mod octomap;
mod pcd;
mod ply;
mod tree;

pub use depth::{CameraIntrinsics, DepthProjection};
pub use filter::{FilterReport, FilterSettings};
pub use octomap::OCTOMAP_MAX_CELLS;
pub use tree::PointTree;

use std::path::Path;

/// Where a parser puts the points it reads, in file order (non-finite
/// ones included: the sink counts them).
pub(crate) trait PointSink {
    /// One point as the file gives it.
    fn push(&mut self, p: [f64; 3]);
    /// Room for `n` more points (a hint).
    fn reserve(&mut self, _n: usize) {}
}

impl PointSink for PointCloud {
    fn push(&mut self, p: [f64; 3]) {
        PointCloud::push(self, p);
    }

    fn reserve(&mut self, n: usize) {
        self.points.reserve(n.min(1 << 24));
    }
}

/// Parses the file at `path` (by its extension, else by its first bytes)
/// into `sink`.
fn read_into(path: &Path, sink: &mut impl PointSink) -> Result<(), PointCloudError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| PointCloudError::new(&file, None, format!("cannot read: {e}")))?;
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("ply") => ply::parse(&bytes, &file, sink),
        Some("pcd") => pcd::parse(&bytes, &file, sink),
        _ if bytes.starts_with(b"ply") => ply::parse(&bytes, &file, sink),
        _ if bytes.starts_with(b"# .PCD") || bytes.starts_with(b"VERSION") => pcd::parse(&bytes, &file, sink),
        _ => Err(PointCloudError::new(&file, None, "neither a PLY nor a PCD file (by extension or first bytes)")),
    }
}

/// A set of points (m), in one frame.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PointCloud {
    /// The points, in file order, the non-finite ones left out (m).
    pub points: Vec<[f64; 3]>,
    /// How many points of the file had a NaN or infinite coordinate.
    pub dropped: usize,
}

/// Why a point cloud file could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{file}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
pub struct PointCloudError {
    /// The file (as given).
    pub file: String,
    /// The header line at fault (1-based), when the fault is in the header
    /// or in an ASCII body.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl PointCloudError {
    pub(crate) fn new(file: &str, line: Option<usize>, message: impl Into<String>) -> PointCloudError {
        PointCloudError { file: file.to_string(), line, message: message.into() }
    }
}

impl PointCloud {
    /// Reads a `.ply` or `.pcd` file (by its extension, else by its first
    /// bytes: `ply` or a PCD header).
    ///
    /// # Errors
    /// The file unreadable, of another format, or malformed (naming the
    /// file and line or point).
    pub fn read(path: impl AsRef<Path>) -> Result<PointCloud, PointCloudError> {
        let mut cloud = PointCloud::default();
        read_into(path.as_ref(), &mut cloud)?;
        Ok(cloud)
    }

    /// Parses a PLY file's bytes, naming it `file` in errors.
    ///
    /// # Errors
    /// As [`Self::read`].
    pub fn from_ply(bytes: &[u8], file: &str) -> Result<PointCloud, PointCloudError> {
        let mut cloud = PointCloud::default();
        ply::parse(bytes, file, &mut cloud)?;
        Ok(cloud)
    }

    /// Parses a PCD file's bytes, naming it `file` in errors.
    ///
    /// # Errors
    /// As [`Self::read`].
    pub fn from_pcd(bytes: &[u8], file: &str) -> Result<PointCloud, PointCloudError> {
        let mut cloud = PointCloud::default();
        pcd::parse(bytes, file, &mut cloud)?;
        Ok(cloud)
    }

    /// The cloud from points given directly (m), non-finite ones dropped.
    pub fn from_points(points: impl IntoIterator<Item = [f64; 3]>) -> PointCloud {
        let mut cloud = PointCloud::default();
        for p in points {
            cloud.push(p);
        }
        cloud
    }

    /// The points moved by `pose` (the sensor's pose in the frame wanted).
    pub fn transformed(&self, pose: &nalgebra::IsometryMatrix3<f64>) -> PointCloud {
        let points = self
            .points
            .iter()
            .map(|p| {
                let q = pose * nalgebra::Point3::new(p[0], p[1], p[2]);
                [q.x, q.y, q.z]
            })
            .collect();
        PointCloud { points, dropped: self.dropped }
    }

    /// Adds a point, or counts it as dropped when a coordinate is not finite.
    pub(crate) fn push(&mut self, p: [f64; 3]) {
        if p.iter().all(|x| x.is_finite()) {
            self.points.push(p);
        } else {
            self.dropped += 1;
        }
    }

    /// Reads a `.ply` or `.pcd` file as [`Self::read`] does and filters it
    /// as [`Self::filtered`] does, point by point as they are parsed: only
    /// the file's bytes and the kept points are held, never the whole
    /// cloud (a 10-million-point cloud thinned to a few thousand points
    /// needs the file's size and a little more).
    ///
    /// # Errors
    /// As [`Self::read`] and [`FilterSettings::validate`].
    pub fn read_filtered(
        path: impl AsRef<Path>,
        settings: &FilterSettings,
    ) -> Result<(PointCloud, FilterReport), PointCloudError> {
        let mut filter = filter::Thinning::new(settings)?;
        read_into(path.as_ref(), &mut filter)?;
        Ok(filter.finish())
    }

    /// The number of points kept.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether no point was kept.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

/// A numeric scalar type of a binary point record, and its width in bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Scalar {
    pub(crate) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::I64 | Scalar::U64 | Scalar::F64 => 8,
        }
    }

    /// The value at the start of `b` (at least [`Self::size`] bytes).
    pub(crate) fn read(self, b: &[u8], little: bool) -> f64 {
        macro_rules! get {
            ($t:ty, $n:expr) => {{
                let raw: [u8; $n] = b[..$n].try_into().expect("width checked by the caller");
                if little { <$t>::from_le_bytes(raw) as f64 } else { <$t>::from_be_bytes(raw) as f64 }
            }};
        }
        match self {
            Scalar::I8 => f64::from(b[0] as i8),
            Scalar::U8 => f64::from(b[0]),
            Scalar::I16 => get!(i16, 2),
            Scalar::U16 => get!(u16, 2),
            Scalar::I32 => get!(i32, 4),
            Scalar::U32 => get!(u32, 4),
            Scalar::I64 => get!(i64, 8),
            Scalar::U64 => get!(u64, 8),
            Scalar::F32 => get!(f32, 4),
            Scalar::F64 => get!(f64, 8),
        }
    }
}

/// A header line: its number (1-based) and text.
pub(crate) type HeaderLine<'a> = (usize, &'a str);

/// The header's lines up to and including the one `last` accepts, and the
/// body's offset.
pub(crate) fn header_lines<'a>(
    bytes: &'a [u8],
    file: &str,
    last: impl Fn(&str) -> bool,
) -> Result<(Vec<HeaderLine<'a>>, usize), PointCloudError> {
    let mut lines = Vec::new();
    let mut at = 0;
    // A header is short: refuse to scan a body that never ends one.
    const LIMIT: usize = 1 << 20;
    while at < bytes.len().min(LIMIT) {
        let end = bytes[at..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |k| at + k);
        let text = std::str::from_utf8(&bytes[at..end])
            .map_err(|_| PointCloudError::new(file, Some(lines.len() + 1), "the header is not text"))?
            .trim_end_matches('\r');
        lines.push((lines.len() + 1, text));
        at = (end + 1).min(bytes.len());
        if last(text.trim()) {
            return Ok((lines, at));
        }
    }
    Err(PointCloudError::new(file, None, "the header does not end (no end_header / DATA line)"))
}

#[cfg(test)]
mod tests;
