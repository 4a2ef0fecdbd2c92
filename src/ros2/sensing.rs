//! What the node's camera topics carry, as points: `sensor_msgs/PointCloud2`
//! in any field layout (x, y, z as FLOAT32 or FLOAT64, either byte order,
//! organised or not) and depth `sensor_msgs/Image`s (REP 118: `32FC1` in
//! m, `16UC1` in mm) with their `CameraInfo` (pinhole or plumb_bob).
//! Invalid points — NaN or infinite coordinates, missing depth — are
//! dropped and counted; a message whose layout contradicts itself is
//! refused whole, with the reason.

use super::messages::{CameraInfo, Image, PointCloud2};
use crate::point_cloud::{CameraIntrinsics, DepthProjection, PointCloud};

/// Why a camera message was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct SensorError(pub String);

fn refuse<T>(message: String) -> Result<T, SensorError> {
    Err(SensorError(message))
}

/// Bytes a `PointField` datatype takes, for the types x, y and z may have.
fn float_size(datatype: u8) -> Option<usize> {
    match datatype {
        7 => Some(4),
        8 => Some(8),
        _ => None,
    }
}

fn read_f64(bytes: &[u8], size: usize, big: bool) -> f64 {
    match (size, big) {
        (4, false) => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
        (4, true) => f32::from_be_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
        (_, false) => f64::from_le_bytes(bytes[..8].try_into().unwrap_or([0; 8])),
        (_, true) => f64::from_be_bytes(bytes[..8].try_into().unwrap_or([0; 8])),
    }
}

/// Appends the points of `msg` (m, in its header's frame) to `out`,
/// row by row; points with a non-finite coordinate are counted in
/// `out.dropped`.
///
/// # Errors
/// No `x`, `y` or `z` field, or one that is not FLOAT32 / FLOAT64 or lies
/// outside a point; a row shorter than its points; fewer bytes than the
/// rows need.
pub fn cloud_points(msg: &PointCloud2, out: &mut PointCloud) -> Result<(), SensorError> {
    let (width, height) = (msg.width as usize, msg.height as usize);
    let (step, row_step) = (msg.point_step as usize, msg.row_step as usize);
    let mut axes = [(0usize, 0usize); 3];
    for (axis, name) in axes.iter_mut().zip(["x", "y", "z"]) {
        let Some(field) = msg.fields.iter().find(|f| f.name == name) else {
            let names: Vec<&str> = msg.fields.iter().map(|f| f.name.as_str()).collect();
            return refuse(format!("no field '{name}' (fields: {})", names.join(", ")));
        };
        let Some(size) = float_size(field.datatype) else {
            return refuse(format!(
                "field '{name}' has datatype {} (x, y and z must be FLOAT32 (7) or FLOAT64 (8))",
                field.datatype
            ));
        };
        if field.count == 0 {
            return refuse(format!("field '{name}' has count 0"));
        }
        if field.offset as usize + size > step {
            return refuse(format!(
                "field '{name}' at offset {} ({size} bytes) lies outside a point of point_step {step}",
                field.offset
            ));
        }
        *axis = (field.offset as usize, size);
    }
    if width == 0 || height == 0 {
        return Ok(());
    }
    if (width as u64) * (step as u64) > row_step as u64 {
        return refuse(format!("row_step {row_step} is shorter than width {width} × point_step {step}"));
    }
    let needed = (height as u64 - 1) * row_step as u64 + (width * step) as u64;
    if (msg.data.len() as u64) < needed {
        return refuse(format!(
            "{} bytes of data for {height} row(s) of {width} point(s) (row_step {row_step}, point_step {step}): {needed} needed",
            msg.data.len()
        ));
    }
    out.points.reserve(width * height);
    for row in 0..height {
        for col in 0..width {
            let at = row * row_step + col * step;
            let p = axes.map(|(offset, size)| read_f64(&msg.data[at + offset..], size, msg.is_bigendian));
            if p.iter().all(|x| x.is_finite()) {
                out.points.push(p);
            } else {
                out.dropped += 1;
            }
        }
    }
    Ok(())
}

/// The intrinsics `info` gives: K and plumb_bob D, or with `rectified`
/// (the image is `image_rect`) P's focal lengths and principal point and
/// no distortion.
///
/// # Errors
/// A size of 0 (an uncalibrated camera), binning or a region of interest
/// (not supported), a distortion model other than `plumb_bob` (or
/// `rational_polynomial` whose k4–k6 are 0, or none), focal lengths that
/// are not positive.
pub fn intrinsics(info: &CameraInfo, rectified: bool) -> Result<CameraIntrinsics, SensorError> {
    if info.width == 0 || info.height == 0 {
        return refuse(format!("camera info of an image of {} × {} pixels: not calibrated", info.width, info.height));
    }
    if info.binning_x > 1 || info.binning_y > 1 {
        return refuse(format!("binning {} × {} is not supported", info.binning_x, info.binning_y));
    }
    let roi = info.roi;
    if !(roi.width == 0 || roi.width == info.width) || !(roi.height == 0 || roi.height == info.height) {
        return refuse(format!("a region of interest ({} × {} pixels) is not supported", roi.width, roi.height));
    }
    let mut distortion = [0.0; 5];
    if !rectified {
        let d = &info.d;
        let zero_beyond = |n: usize| d.iter().skip(n).all(|x| *x == 0.0);
        match info.distortion_model.as_str() {
            "plumb_bob" | "rational_polynomial" if zero_beyond(5) => {
                for (slot, value) in distortion.iter_mut().zip(d) {
                    *slot = *value;
                }
            }
            "" | "none" if zero_beyond(0) => {}
            model => {
                return refuse(format!(
                    "distortion model '{model}' with d = {d:?} is not supported (plumb_bob, or none; or a rectified image)"
                ));
            }
        }
    }
    let (fx, fy, cx, cy) = match rectified {
        true => (info.p[0], info.p[5], info.p[2], info.p[6]),
        false => (info.k[0], info.k[4], info.k[2], info.k[5]),
    };
    let camera = CameraIntrinsics { width: info.width, height: info.height, fx, fy, cx, cy, distortion };
    camera.validate().map_err(|e| SensorError(format!("camera info: {}", e.message)))?;
    Ok(camera)
}

/// Appends the points of depth image `image` (m, in the camera's optical
/// frame) to `out`, every `stride`-th pixel of every `stride`-th row;
/// missing depths (NaN, ∞, ≤ 0; 0 in `16UC1`) counted in `out.dropped`.
/// `projection` is the camera's rays, rebuilt when `info` describes
/// another camera (the first time, or after a recalibration).
///
/// # Errors
/// An encoding other than `32FC1` or `16UC1` (`mono16`), rows shorter
/// than their pixels, fewer bytes than the rows need, camera info that
/// contradicts the image (another size) or that [`intrinsics`] refuses.
pub fn depth_points(
    image: &Image,
    info: &CameraInfo,
    rectified: bool,
    stride: usize,
    projection: &mut Option<DepthProjection>,
    out: &mut PointCloud,
) -> Result<(), SensorError> {
    let (bytes, millimetres) = match image.encoding.as_str() {
        "32FC1" => (4, false),
        "16UC1" | "mono16" => (2, true),
        other => return refuse(format!("depth encoding '{other}' (give 32FC1 in m or 16UC1 in mm, REP 118)")),
    };
    if (image.width, image.height) != (info.width, info.height) {
        return refuse(format!(
            "the image is {} × {} pixels, its camera info {} × {}",
            image.width, image.height, info.width, info.height
        ));
    }
    let (w, h, step) = (image.width as usize, image.height as usize, image.step as usize);
    if w == 0 || h == 0 {
        return Ok(()); // an empty frame: an empty cloud
    }
    let camera = intrinsics(info, rectified)?;
    if w * bytes > step {
        return refuse(format!("step {step} is shorter than width {w} × {bytes} bytes"));
    }
    let needed = (h - 1) * step + w * bytes;
    if image.data.len() < needed {
        return refuse(format!("{} bytes of data for {h} rows of step {step}: {needed} needed", image.data.len()));
    }
    if projection.as_ref().is_none_or(|p| *p.intrinsics() != camera) {
        *projection = Some(DepthProjection::new(camera).map_err(|e| SensorError(e.message))?);
    }
    let Some(projection) = projection.as_ref() else { return Ok(()) };
    let big = image.is_bigendian != 0;
    let data = &image.data;
    projection.points(
        |k| {
            let at = (k / w) * step + (k % w) * bytes;
            if millimetres {
                let raw = [data[at], data[at + 1]];
                let mm = if big { u16::from_be_bytes(raw) } else { u16::from_le_bytes(raw) };
                mm as f64 * 1e-3
            } else {
                read_f64(&data[at..], 4, big)
            }
        },
        stride,
        out,
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::messages::PointField;
    use super::*;

    fn field(name: &str, offset: u32, datatype: u8) -> PointField {
        PointField { name: name.into(), offset, datatype, count: 1 }
    }

    /// An organised 2 × 3 cloud laid out as a RealSense driver does it —
    /// x, y, z, rgb as FLOAT32 with padding, rows padded too — one point
    /// NaN, in either byte order; and the same points as FLOAT64 z-first.
    #[test]
    fn any_layout_reads_the_same_points() {
        let points: Vec<[f64; 3]> = (0..6)
            .map(|k| [0.5 + k as f64 * 0.125, -0.25 * k as f64, if k == 4 { f64::NAN } else { 1.0 + k as f64 }])
            .collect();
        for big in [false, true] {
            let step = 20usize;
            let row_step = 3 * step + 4;
            let mut data = vec![0u8; 2 * row_step];
            for (k, p) in points.iter().enumerate() {
                let at = (k / 3) * row_step + (k % 3) * step;
                for (axis, value) in p.iter().enumerate() {
                    let b = if big { (*value as f32).to_be_bytes() } else { (*value as f32).to_le_bytes() };
                    data[at + axis * 4..at + axis * 4 + 4].copy_from_slice(&b);
                }
            }
            let msg = PointCloud2 {
                height: 2,
                width: 3,
                fields: vec![field("x", 0, 7), field("y", 4, 7), field("z", 8, 7), field("rgb", 16, 7)],
                is_bigendian: big,
                point_step: step as u32,
                row_step: row_step as u32,
                data,
                ..PointCloud2::default()
            };
            let mut cloud = PointCloud::default();
            cloud_points(&msg, &mut cloud).unwrap();
            assert_eq!((cloud.len(), cloud.dropped), (5, 1));
            let expected: Vec<[f64; 3]> = points.iter().filter(|p| p[2].is_finite()).copied().collect();
            assert_eq!(cloud.points, expected);
        }
        // FLOAT64, z first, unorganised.
        let mut data = Vec::new();
        for p in points.iter().filter(|p| p[2].is_finite()) {
            for v in [p[2], p[0], p[1]] {
                data.extend_from_slice(&v.to_le_bytes());
            }
        }
        let msg = PointCloud2 {
            height: 1,
            width: 5,
            fields: vec![field("z", 0, 8), field("x", 8, 8), field("y", 16, 8)],
            point_step: 24,
            row_step: 120,
            data,
            ..PointCloud2::default()
        };
        let mut cloud = PointCloud::default();
        cloud_points(&msg, &mut cloud).unwrap();
        assert_eq!(cloud.len(), 5);
        assert_eq!(cloud.points[1], points[1]);
    }

    #[test]
    fn layouts_that_contradict_themselves_are_refused_with_the_reason() {
        let good = PointCloud2 {
            height: 1,
            width: 2,
            fields: vec![field("x", 0, 7), field("y", 4, 7), field("z", 8, 7)],
            point_step: 12,
            row_step: 24,
            data: vec![0; 24],
            ..PointCloud2::default()
        };
        let mut cloud = PointCloud::default();
        assert!(cloud_points(&good, &mut cloud).is_ok());
        for (bad, says) in [
            (PointCloud2 { fields: good.fields[..2].to_vec(), ..good.clone() }, "no field 'z' (fields: x, y)"),
            (
                PointCloud2 { fields: vec![field("x", 0, 7), field("y", 4, 7), field("z", 8, 4)], ..good.clone() },
                "datatype 4",
            ),
            (
                PointCloud2 { fields: vec![field("x", 0, 7), field("y", 4, 7), field("z", 10, 7)], ..good.clone() },
                "outside a point",
            ),
            (PointCloud2 { row_step: 20, ..good.clone() }, "row_step 20 is shorter"),
            (PointCloud2 { data: vec![0; 23], ..good.clone() }, "23 bytes of data"),
            (PointCloud2 { height: 2, ..good.clone() }, "24 bytes of data for 2 row(s)"),
        ] {
            let e = cloud_points(&bad, &mut cloud).unwrap_err().0;
            assert!(e.contains(says), "{e}");
        }
    }

    fn info(width: u32, height: u32) -> CameraInfo {
        let c = CameraIntrinsics::realsense_d435_640x480();
        CameraInfo {
            width,
            height,
            distortion_model: "plumb_bob".into(),
            d: vec![0.0; 5],
            k: [c.fx / 10.0, 0.0, 31.5, 0.0, c.fy / 10.0, 23.5, 0.0, 0.0, 1.0],
            p: [c.fx / 10.0, 0.0, 31.5, 0.0, 0.0, c.fy / 10.0, 23.5, 0.0, 0.0, 0.0, 1.0, 0.0],
            ..CameraInfo::default()
        }
    }

    /// A wall 1.2 m ahead seen in 32FC1 metres and in 16UC1 millimetres:
    /// the same points (to the millimetre), missing pixels dropped.
    #[test]
    fn depth_images_in_metres_and_millimetres_give_the_same_points() {
        let (w, h) = (64u32, 48u32);
        let camera = info(w, h);
        let mut metres = Vec::new();
        let mut millimetres = Vec::new();
        for k in 0..(w * h) {
            let z = if k % 7 == 0 { f32::NAN } else { 1.2 };
            metres.extend_from_slice(&z.to_le_bytes());
            millimetres.extend_from_slice(&(if z.is_nan() { 0u16 } else { 1200 }).to_le_bytes());
        }
        let float =
            Image { width: w, height: h, encoding: "32FC1".into(), step: 4 * w, data: metres, ..Image::default() };
        let int =
            Image { width: w, height: h, encoding: "16UC1".into(), step: 2 * w, data: millimetres, ..Image::default() };
        let mut projection = None;
        let (mut a, mut b) = (PointCloud::default(), PointCloud::default());
        depth_points(&float, &camera, false, 1, &mut projection, &mut a).unwrap();
        depth_points(&int, &camera, false, 1, &mut projection, &mut b).unwrap();
        assert_eq!((a.len(), a.dropped), (b.len(), b.dropped));
        assert_eq!(a.dropped, (w * h).div_ceil(7) as usize);
        for (p, q) in a.points.iter().zip(&b.points) {
            assert!((0..3).all(|i| (p[i] - q[i]).abs() < 1e-6), "{p:?} {q:?}");
        }
        // The centre pixel's point lies on the optical axis, 1.2 m out.
        assert!(a.points.iter().any(|p| (p[2] - 1.2).abs() < 1e-6 && p[0].abs() < 0.02 && p[1].abs() < 0.02));
        for (image, cam, says) in [
            (Image { encoding: "rgb8".into(), ..float.clone() }, camera.clone(), "depth encoding 'rgb8'"),
            (float.clone(), info(32, 48), "its camera info 32 × 48"),
            (Image { step: 100, ..float.clone() }, camera.clone(), "step 100 is shorter"),
            (Image { data: vec![0; 10], ..float.clone() }, camera.clone(), "10 bytes of data"),
            (float.clone(), CameraInfo { distortion_model: "equidistant".into(), ..camera.clone() }, "'equidistant'"),
            (float.clone(), CameraInfo { k: [0.0; 9], ..camera.clone() }, "focal lengths"),
            (float.clone(), CameraInfo { binning_x: 2, ..camera.clone() }, "binning"),
        ] {
            let e = depth_points(&image, &cam, false, 1, &mut projection, &mut a).unwrap_err().0;
            assert!(e.contains(says), "{e}");
        }
        // An empty frame is an empty cloud, not an error (nor a panic).
        let empty = Image { width: 0, height: 0, data: Vec::new(), ..float.clone() };
        let mut c = PointCloud::default();
        depth_points(&empty, &info(0, 0), false, 1, &mut projection, &mut c).unwrap();
        assert_eq!((c.len(), c.dropped), (0, 0));
    }
}
