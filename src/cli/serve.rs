//! `tandem serve`: the browser teleoperation page.

use crate::arbitration::ArbitrationMode;
use crate::teleop::{ServeSettings, SessionSettings, TeleopSession, TeleopTask, serve};
use std::io::Write;
use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use std::sync::Arc;

/// Arguments of `tandem serve`.
#[derive(Debug, clap::Args)]
pub struct ServeArgs {
    /// The reach-and-grasp problem (a file or builtin:NAME; it needs a
    /// gripper and a grasp goal). Default: the built-in panda_grasp_box with
    /// the box placed by --seed, as in `tandem experiment reach-grasp`.
    pub problem: Option<PathBuf>,
    /// Port to listen on (0: any free port; the address is printed).
    #[arg(long, default_value_t = 8080)]
    pub port: u16,
    /// Point clouds added to the problem's scene (with a problem only).
    #[command(flatten)]
    pub clouds: super::PointCloudArgs,
    /// Address to listen on. The default serves this machine only; give
    /// 0.0.0.0 to let others on the network drive the arm.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: IpAddr,
    /// Control rate of the simulator and the arbiter (Hz, 1–1000): 30 is
    /// the dissertation's joystick rate (§4.4).
    #[arg(long, default_value_t = 30.0, value_parser = |s: &str| super::number_in(s, 1.0..=1000.0))]
    pub rate: f64,
    /// States sent to the page per second at most (1–240).
    #[arg(long, default_value_t = 60.0, value_parser = |s: &str| super::number_in(s, 1.0..=240.0))]
    pub state_rate: f64,
    /// The task a new page starts on: reach-grasp or planar.
    #[arg(long, default_value = "reach-grasp", value_parser = ["reach-grasp", "planar"])]
    pub task: String,
    /// Seed of the first task's placement (the page's "new task" button
    /// moves on to the next seed).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// The mode a new page starts in (any mode of `tandem arbitrate`; the
    /// page switches among them).
    #[arg(long, default_value = "sos")]
    pub mode: ArbitrationMode,
    /// A trained arbitration actor (`tandem learn arbitration`), offered as
    /// mode `learned` on tasks with as many goals as it was trained for.
    #[arg(long, value_name = "FILE")]
    pub arbiter: Option<PathBuf>,
    /// Largest gripper speed a command may ask for (m/s).
    #[arg(long, default_value_t = 0.25, value_parser = |s: &str| super::number_in(s, 0.001..=2.0))]
    pub max_speed: f64,
    /// Folder where each driven episode is saved as Parquet (the layout of
    /// the simulator's episodes, src/sim/record.rs).
    #[arg(long, default_value = "recordings")]
    pub record_dir: PathBuf,
    /// Keep no recordings.
    #[arg(long)]
    pub no_record: bool,
    /// Sessions (pages) open at once at most; one more is refused with
    /// HTTP 503 and the reason.
    #[arg(long, default_value_t = 64, value_parser = |s: &str| super::number_in(s, 1usize..=4096))]
    pub max_sessions: usize,
    /// A page that sends nothing for this long is closed (s; 1001 "going
    /// away"). The server pings every third of it; browsers answer by
    /// themselves.
    #[arg(long, default_value_t = 30.0, value_parser = |s: &str| super::number_in(s, 1.0..=3600.0))]
    pub idle_timeout: f64,
}

/// Serves until interrupted.
///
/// # Errors
/// A bad problem or actor file, or a port that cannot be bound.
pub fn run(args: &ServeArgs) -> Result<(), Box<dyn std::error::Error>> {
    if args.problem.is_none() && !args.clouds.point_clouds.is_empty() {
        return Err("--point-cloud needs a problem: the default one is re-sampled every episode".into());
    }
    let problem =
        args.problem.as_deref().map(|p| super::problem_args::load(p, &args.clouds)).transpose()?.map(Arc::new);
    let actor = match &args.arbiter {
        Some(path) => Some(Arc::new(crate::learn::ArbitrationActor::load(path)?) as _),
        None => None,
    };
    let task = TeleopTask::parse(&args.task).ok_or_else(|| format!("unknown task '{}'", args.task))?;
    if args.mode == ArbitrationMode::Learned && actor.is_none() {
        return Err("--mode learned needs --arbiter FILE".into());
    }
    let settings = ServeSettings {
        address: SocketAddr::new(args.host, args.port),
        session: SessionSettings {
            rate_hz: args.rate,
            max_speed: args.max_speed,
            mode: args.mode,
            problem,
            record_dir: (!args.no_record).then(|| args.record_dir.clone()),
            actor,
            ..SessionSettings::default()
        },
        state_rate_hz: args.state_rate.min(args.rate),
        task,
        seed: args.seed,
        max_sessions: args.max_sessions,
        idle_timeout: std::time::Duration::from_secs_f64(args.idle_timeout),
        ..ServeSettings::default()
    };
    // A problem the task cannot use, or a recording folder that cannot be
    // written, fails here, not in the first page or at the first save.
    TeleopSession::prepare(&settings.session, task, args.seed)?;
    let record = settings.session.record_dir.clone();
    if let Some(dir) = &record {
        crate::files::check_writable(&dir.join(".tandem-write-check"))
            .map_err(|e| format!("--record-dir: {e} (or give --no-record)"))?;
    }
    serve(settings, |address| {
        println!("tandem serve: open http://{address}/ in a browser (Ctrl-C stops)");
        match &record {
            Some(dir) => println!("driven episodes are saved to {}/", dir.display()),
            None => println!("driven episodes are not saved (--no-record)"),
        }
        let _ = std::io::stdout().flush();
    })?;
    Ok(())
}
