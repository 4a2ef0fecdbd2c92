//! `tandem fk`: pose and Jacobian of one frame.

use super::UrdfArgs;
use crate::robot::{KinematicsWorkspace, ReferenceFrame, RobotModel};
use nalgebra::Matrix6xX;
use std::sync::Arc;

/// Arguments of `tandem fk`.
#[derive(Debug, clap::Args)]
pub struct FkArgs {
    #[command(flatten)]
    pub urdf: UrdfArgs,
    /// Name of a link or joint frame.
    #[arg(long)]
    pub frame: String,
    /// Joint values, comma-separated, one per active joint (rad or m).
    #[arg(long, value_name = "V1,V2,...", allow_hyphen_values = true)]
    pub q: String,
    /// Active joints, comma-separated, in the order of --q. Default: all
    /// movable joints not driven by a mimic, in URDF order. Other joints sit
    /// at 0 (or mid-range when 0 is outside their limits).
    #[arg(long, value_name = "J1,J2,...")]
    pub joints: Option<String>,
    /// Express the Jacobian in the frame's own axes instead of world axes.
    #[arg(long)]
    pub local: bool,
    /// Print exactly one JSON object: frame, joints, translation, rotation
    /// (row-major 3×3), jacobian (6 rows of n).
    #[arg(long)]
    pub json: bool,
}

/// Parses `"0.1, -2,3e-1"` into numbers, naming the first bad entry.
pub fn parse_values(text: &str) -> Result<Vec<f64>, String> {
    if text.trim().is_empty() {
        return Ok(Vec::new());
    }
    text.split(',')
        .enumerate()
        .map(|(i, s)| {
            s.trim().parse::<f64>().map_err(|_| format!("--q value {} ('{}') is not a number", i + 1, s.trim()))
        })
        .collect()
}

pub(super) fn run(args: &FkArgs) -> Result<(), Box<dyn std::error::Error>> {
    let desc = Arc::new(args.urdf.load()?);
    let mut builder = RobotModel::builder(desc);
    if let Some(joints) = &args.joints {
        builder = builder.active_joints(joints.split(',').map(str::trim).filter(|s| !s.is_empty()));
    }
    let model = builder.build()?;
    let frame = model.frame_id(&args.frame)?;
    let q = parse_values(&args.q)?;
    let mut ws = KinematicsWorkspace::new(&model);
    model.forward_kinematics(&mut ws, &q)?;
    let reference = if args.local { ReferenceFrame::Local } else { ReferenceFrame::WorldAligned };
    let mut jac = Matrix6xX::zeros(model.nq());
    let pose = model.frame_jacobian(&ws, frame, reference, &mut jac)?;
    let rot = pose.rotation.matrix();
    let rows = |m: &dyn Fn(usize, usize) -> f64, r: usize, c: usize| -> Vec<Vec<f64>> {
        (0..r).map(|i| (0..c).map(|k| m(i, k)).collect()).collect()
    };
    let rotation = rows(&|i, k| rot[(i, k)], 3, 3);
    let jacobian = rows(&|i, k| jac[(i, k)], 6, model.nq());
    let t = pose.translation.vector;
    if args.json {
        let out = serde_json::json!({
            "frame": args.frame,
            "joints": model.joint_names(),
            "translation": [t.x, t.y, t.z],
            "rotation": rotation,
            "jacobian": jacobian,
        });
        println!("{out}");
        return Ok(());
    }
    println!("frame {} of {} at q = {:?}", args.frame, model.description().name(), q);
    println!("joints: {}", model.joint_names().join(", "));
    println!("translation (m): [{:.6}, {:.6}, {:.6}]", t.x, t.y, t.z);
    let (r, p, y) = pose.rotation.euler_angles();
    println!("rotation (fixed-axis roll, pitch, yaw, rad): [{r:.6}, {p:.6}, {y:.6}]");
    for row in &rotation {
        println!("  [{:>10.6} {:>10.6} {:>10.6}]", row[0], row[1], row[2]);
    }
    let label = if args.local { "local" } else { "world-aligned" };
    println!("jacobian ({label}, 6x{}; rows vx vy vz wx wy wz):", model.nq());
    for (name, row) in ["vx", "vy", "vz", "wx", "wy", "wz"].iter().zip(&jacobian) {
        let cells: Vec<String> = row.iter().map(|v| format!("{v:>9.5}")).collect();
        println!("  {name} {}", cells.join(" "));
    }
    Ok(())
}
