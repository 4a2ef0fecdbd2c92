//! `tandem learn policy`: train a goal-conditioned policy network on a
//! dataset folder.

use crate::experiments::policy::train_and_save;
use crate::learn::{LearnSettings, TrainSettings};
use crate::problem::ProblemFamily;
use std::path::PathBuf;

/// Arguments of `tandem learn`.
#[derive(Debug, clap::Args)]
pub struct LearnArgs {
    #[command(subcommand)]
    pub what: LearnCommand,
}

/// What `tandem learn` trains.
#[derive(Debug, clap::Subcommand)]
pub enum LearnCommand {
    /// Train the robot policy network (§3.3.3 of the dissertation) on a
    /// dataset folder written by `tandem generate`: input gripper position,
    /// goal relative to it, goal rotation (6-D), q (the dissertation's), the
    /// gripper rotation and the goal in the gripper frame, and the family's
    /// random obstacles; output the unit joint velocity and its norm, trained
    /// on the weighted sum of their mean squared errors. Besides the
    /// demonstrated states it trains on perturbed ones labelled by each
    /// demonstration's LQR tracking policy (--augment, --noise), so the
    /// network learns how to get back to a motion. Deterministic per --seed
    /// whatever the thread count (RAYON_NUM_THREADS). Writes
    /// the network (safetensors), a report (JSON: losses per epoch, time,
    /// pairs) and the loss curves (SVG) beside it.
    ///
    /// Example:
    ///   tandem generate --family problems/panda_grasp_family.toml --count 2000 --out grasps/
    ///   tandem learn policy --data grasps/ --epochs 30 --out policy.safetensors
    #[command(verbatim_doc_comment)]
    Policy(LearnPolicyArgs),
    /// Train a learned arbiter (the dissertation's chapter 6) with DDPG on the
    /// planar task of §6.5: the gripper behind a pole, two cylinders near the
    /// far edge, a simulated user (straight, noisy-0.5, noisy-1.0, biased,
    /// drawn per episode) heading for one of them. The actor sees the
    /// gripper, the goals, the distance to the nearest obstacle, every
    /// sub-policy's action and belief and the user's command (17 values)
    /// and outputs the arbitrated x–y velocity, executed under the hard
    /// constraints. --reward combined adds Algorithm 5's agreement term —
    /// follow the user at decision points (the sub-policies' von Mises
    /// mixture multimodal), the user's goal's sub-policy elsewhere, at the
    /// user's speed — to the environment reward (−10 obstacle, −2 border,
    /// +10 goal); --reward environment uses the latter alone. Rewards are
    /// labelled in hindsight, once the user's goal is known. Deterministic
    /// per --seed. Writes the actor (safetensors; load it with
    /// `--mode learned --arbiter FILE` or ArbitrationActor::load), the
    /// training log (.json) and curves (.svg).
    ///
    /// Example:
    ///   tandem learn arbitration --episodes 300 --reward combined --out arbiter.safetensors
    #[command(verbatim_doc_comment)]
    Arbitration(super::learned_arbitration::LearnArbitrationArgs),
}

/// Arguments of `tandem learn policy`.
#[derive(Debug, clap::Args)]
pub struct LearnPolicyArgs {
    /// Dataset folder (part-*.parquet).
    #[arg(long, value_name = "DIR")]
    pub data: PathBuf,
    /// The family the dataset was generated from (robot, gripper, static obstacles).
    #[arg(long, default_value = "problems/panda_grasp_family.toml", value_name = "FAMILY.toml")]
    pub family: PathBuf,
    /// Passes over the training pairs.
    #[arg(long, default_value_t = 30, value_parser = |s: &str| super::number_in(s, 1usize..=100_000))]
    pub epochs: usize,
    /// Seed of the initial weights and the minibatch order.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Hidden layer widths: 1 to 16 layers of 1 to 4096 units.
    #[arg(long, value_delimiter = ',', default_value = "128,128,128", num_args = 1..=crate::learn::MAX_HIDDEN_LAYERS,
          value_parser = |s: &str| super::number_in(s, 1usize..=crate::learn::MAX_HIDDEN_WIDTH))]
    pub hidden: Vec<usize>,
    /// Robot frames besides the gripper that each obstacle is also placed
    /// relative to in the input (at most 8; e.g. `panda_link4,panda_link5`,
    /// the ends of the Panda's forearm). None by default.
    #[arg(long, value_delimiter = ',', value_name = "FRAME")]
    pub obstacle_frames: Vec<String>,
    /// Pairs per minibatch.
    #[arg(long, default_value_t = 512, value_parser = |s: &str| super::number_in(s, 1usize..=1_000_000))]
    pub batch: usize,
    /// Initial learning rate (cosine decay to 1 % of it), 1e-8 to 1.
    #[arg(long, default_value_t = 2e-3, value_parser = |s: &str| super::number_in(s, 1e-8..=1.0))]
    pub learning_rate: f64,
    /// Weight of the slope loss, 0 to 100: the network's action change
    /// from each demonstrated state to its perturbed copies (--augment)
    /// matched to the LQR tracking policy's, relative to its mean square
    /// (Sobolev training; 0: the dissertation's loss).
    #[arg(long, default_value_t = 0.0, value_parser = |s: &str| super::number_in(s, 0.0..=100.0))]
    pub slope_weight: f64,
    /// Share of sample ids held out for validation.
    #[arg(long, default_value_t = 0.1, value_parser = |s: &str| super::number_in(s, 0.0..=0.9))]
    pub validation: f64,
    /// Perturbed states per demonstrated state, labelled by the
    /// demonstration's LQR tracking policy (0: the demonstrations alone, as in
    /// the dissertation).
    #[arg(long, default_value_t = 1, value_parser = |s: &str| super::number_in(s, 0usize..=100))]
    pub augment: usize,
    /// Range of the perturbations' standard deviation per joint (rad),
    /// drawn log-uniformly.
    #[arg(long, value_delimiter = ',', num_args = 2, default_values_t = [0.005, 0.05],
          value_parser = |s: &str| super::number_in(s, 1e-6..=1.0))]
    pub noise: Vec<f64>,
    /// The network file to write (safetensors); the report goes to FILE
    /// with extension .json, the loss curves to .svg.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Where the optimisation state is saved after every epoch (default:
    /// --out with extension .checkpoint). A run stopped and started again
    /// with the same arguments goes on from its last finished epoch and
    /// ends with the same weights as one never stopped; a checkpoint of
    /// other data or settings is refused. Removed when training ends.
    #[arg(long, value_name = "FILE")]
    pub checkpoint: Option<PathBuf>,
    /// Keep no checkpoint.
    #[arg(long, conflicts_with = "checkpoint")]
    pub no_checkpoint: bool,
    /// Print the report as one JSON object.
    #[arg(long)]
    pub json: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

pub(super) fn run(args: &LearnArgs) -> Result<(), Box<dyn std::error::Error>> {
    match &args.what {
        LearnCommand::Policy(a) => run_policy(a),
        LearnCommand::Arbitration(a) => super::learned_arbitration::learn_arbitration(a),
    }
}

fn run_policy(args: &LearnPolicyArgs) -> Result<(), Box<dyn std::error::Error>> {
    let family = ProblemFamily::from_file(&args.family)?;
    let options = LearnSettings {
        train: TrainSettings {
            epochs: args.epochs,
            seed: args.seed,
            hidden: args.hidden.clone(),
            batch: args.batch,
            learning_rate: args.learning_rate,
            slope_weight: args.slope_weight,
            progress: !args.quiet && !args.json,
            checkpoint: (!args.no_checkpoint)
                .then(|| args.checkpoint.clone().unwrap_or_else(|| args.out.with_extension("checkpoint"))),
            ..TrainSettings::default()
        },
        validation: args.validation,
        obstacle_frames: args.obstacle_frames.clone(),
        augment: crate::learn::Augmentation {
            per_state: args.augment,
            noise: (args.noise[0], args.noise[1]),
            ..crate::learn::Augmentation::default()
        },
        ..LearnSettings::default()
    };
    // Before the dataset is read (it may take minutes): 17 layers named here.
    options
        .train
        .validate()
        .map_err(|e| crate::settings::InvalidSetting { field: format!("--{}", e.field.replace('_', "-")), ..e })?;
    let (_, report) = train_and_save(&args.data, &family, &options, &args.out)?;
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
        return Ok(());
    }
    println!(
        "trained on {} trajectories ({} pairs), validated on {} ({} pairs), in {:.1} s",
        report.trajectories, report.pairs, report.validation_trajectories, report.validation_pairs, report.seconds
    );
    println!("final loss: train {:.5}, validation {:.5}", report.final_train_loss, report.final_validation_loss);
    println!(
        "wrote {}, {} and {}",
        args.out.display(),
        args.out.with_extension("json").display(),
        args.out.with_extension("svg").display()
    );
    Ok(())
}
