//! tandem's ROS 2 messages against an independent serializer: each message
//! type (the camera's PointCloud2, Image and CameraInfo too), drawn at random 40 times (empty arrays and strings, non-ASCII
//! names, subnormal, huge and negative-zero numbers included), encodes to
//! the same bytes as PyPI `rosbags` writes from the same values
//! (python_ref/ros2_reference.py), and both decode back to the values.

mod common;

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use serde::de::DeserializeOwned;
use tandem::ros2::messages::*;

fn number(rng: &mut ChaCha8Rng) -> f64 {
    match rng.random_range(0..8) {
        0 => 0.0,
        1 => -0.0,
        2 => 5e-324,
        3 => rng.random_range(-1e300..1e300),
        _ => rng.random_range(-10.0..10.0),
    }
}

fn numbers(rng: &mut ChaCha8Rng) -> Vec<f64> {
    let n = if rng.random_range(0..4) == 0 { 0 } else { rng.random_range(1..9) };
    (0..n).map(|_| number(rng)).collect()
}

fn text(rng: &mut ChaCha8Rng) -> String {
    let pieces = ["", "panda_joint1", "world", "é", "base_link", "x y", "ツール"];
    (0..rng.random_range(0..3)).map(|_| pieces[rng.random_range(0..pieces.len())]).collect()
}

fn texts(rng: &mut ChaCha8Rng) -> Vec<String> {
    (0..rng.random_range(0..5)).map(|_| text(rng)).collect()
}

fn header(rng: &mut ChaCha8Rng) -> Header {
    Header { stamp: Time { sec: rng.random(), nanosec: rng.random_range(0..1_000_000_000) }, frame_id: text(rng) }
}

fn vector(rng: &mut ChaCha8Rng) -> Vector3 {
    Vector3 { x: number(rng), y: number(rng), z: number(rng) }
}

/// One drawn message of each type, as (ROS type name, payload, JSON values,
/// a check that decoding `payload` gives the message back).
type Drawn = (&'static str, Vec<u8>, serde_json::Value, Box<dyn Fn(&[u8]) -> bool>);

fn drawn<M: Serialize + DeserializeOwned + PartialEq + 'static>(name: &'static str, message: M) -> Drawn {
    let payload = encode(&message).unwrap();
    let json = serde_json::to_value(&message).unwrap();
    let check = move |bytes: &[u8]| decode::<M>(bytes).is_ok_and(|m| m == message);
    (name, payload, json, Box::new(check))
}

fn draw(rng: &mut ChaCha8Rng) -> Vec<Drawn> {
    let point = JointTrajectoryPoint {
        positions: numbers(rng),
        velocities: numbers(rng),
        accelerations: numbers(rng),
        effort: numbers(rng),
        time_from_start: Duration { sec: rng.random(), nanosec: rng.random_range(0..1_000_000_000) },
    };
    let points = (0..rng.random_range(0..3)).map(|_| point.clone()).collect();
    let dims = (0..rng.random_range(0..3))
        .map(|_| MultiArrayDimension { label: text(rng), size: rng.random(), stride: rng.random() })
        .collect();
    let poses = (0..rng.random_range(0..3))
        .map(|_| Pose {
            position: Point { x: number(rng), y: number(rng), z: number(rng) },
            orientation: Quaternion { x: number(rng), y: number(rng), z: number(rng), w: number(rng) },
        })
        .collect();
    vec![
        drawn(
            "geometry_msgs/msg/TwistStamped",
            TwistStamped { header: header(rng), twist: Twist { linear: vector(rng), angular: vector(rng) } },
        ),
        drawn(
            "control_msgs/msg/JointJog",
            JointJog {
                header: header(rng),
                joint_names: texts(rng),
                displacements: numbers(rng),
                velocities: numbers(rng),
                duration: number(rng),
            },
        ),
        drawn(
            "sensor_msgs/msg/JointState",
            JointState {
                header: header(rng),
                name: texts(rng),
                position: numbers(rng),
                velocity: numbers(rng),
                effort: numbers(rng),
            },
        ),
        drawn(
            "trajectory_msgs/msg/JointTrajectory",
            JointTrajectory { header: header(rng), joint_names: texts(rng), points },
        ),
        drawn(
            "std_msgs/msg/Float64MultiArray",
            Float64MultiArray { layout: MultiArrayLayout { dim: dims, data_offset: rng.random() }, data: numbers(rng) },
        ),
        drawn("std_msgs/msg/Int8", Int8 { data: rng.random() }),
        drawn("std_msgs/msg/String", StringMessage { data: text(rng) }),
        drawn("geometry_msgs/msg/PoseArray", PoseArray { header: header(rng), poses }),
        drawn(
            "sensor_msgs/msg/PointCloud2",
            PointCloud2 {
                header: header(rng),
                height: rng.random(),
                width: rng.random(),
                fields: (0..rng.random_range(0..4))
                    .map(|_| PointField {
                        name: text(rng),
                        offset: rng.random(),
                        datatype: rng.random(),
                        count: rng.random(),
                    })
                    .collect(),
                is_bigendian: rng.random(),
                point_step: rng.random(),
                row_step: rng.random(),
                data: bytes(rng),
                is_dense: rng.random(),
            },
        ),
        drawn(
            "sensor_msgs/msg/Image",
            Image {
                header: header(rng),
                height: rng.random(),
                width: rng.random(),
                encoding: text(rng),
                is_bigendian: rng.random(),
                step: rng.random(),
                data: bytes(rng),
            },
        ),
        drawn(
            "sensor_msgs/msg/CameraInfo",
            CameraInfo {
                header: header(rng),
                height: rng.random(),
                width: rng.random(),
                distortion_model: text(rng),
                d: numbers(rng),
                k: std::array::from_fn(|_| number(rng)),
                r: std::array::from_fn(|_| number(rng)),
                p: std::array::from_fn(|_| number(rng)),
                binning_x: rng.random(),
                binning_y: rng.random(),
                roi: RegionOfInterest {
                    x_offset: rng.random(),
                    y_offset: rng.random(),
                    height: rng.random(),
                    width: rng.random(),
                    do_rectify: rng.random(),
                },
            },
        ),
    ]
}

/// Bytes of a point cloud's or an image's data: none, a few, or an odd
/// count past a CDR alignment.
fn bytes(rng: &mut ChaCha8Rng) -> Vec<u8> {
    let n = [0, 1, 7, 12, 61][rng.random_range(0..5)];
    (0..n).map(|_| rng.random()).collect()
}

#[test]
fn every_message_encodes_as_rosbags_does() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let messages: Vec<Drawn> = (0..40).flat_map(|_| draw(&mut rng)).collect();
    let request: Vec<serde_json::Value> =
        messages.iter().map(|(name, _, json, _)| serde_json::json!({"type": name, "value": json})).collect();
    let reply = common::run_python("ros2_reference.py", &[], &serde_json::to_string(&request).unwrap());
    let lines: Vec<&str> = reply.lines().collect();
    assert_eq!(lines.len(), messages.len());
    for ((name, payload, json, decodes), hex) in messages.iter().zip(lines) {
        let theirs: Vec<u8> =
            (0..hex.len()).step_by(2).map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap()).collect();
        assert_eq!(payload, &theirs, "{name} {json}");
        assert!(decodes(&theirs), "{name}: rosbags' bytes do not decode to the message {json}");
    }
}

#[test]
fn payloads_that_are_not_plain_cdr_are_refused() {
    assert!(matches!(decode::<Int8>(&[0x00, 0x01]), Err(MessageError::Encapsulation(_))));
    // XCDR2 (0x0007) is not plain CDR.
    assert!(matches!(decode::<Int8>(&[0x00, 0x07, 0, 0, 1]), Err(MessageError::Encapsulation(_))));
    assert!(matches!(decode::<JointState>(&[0x00, 0x01, 0, 0, 9, 0, 0, 0]), Err(MessageError::Cdr(_))));
    // Big-endian payloads read too.
    assert_eq!(decode::<Int8>(&[0x00, 0x00, 0, 0, 0xfd]).unwrap(), Int8 { data: -3 });
}
