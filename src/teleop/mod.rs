//! Teleoperation from a browser (`tandem serve`): a person drives the arm
//! with a gamepad or the keyboard, and the [`Arbiter`](crate::arbitration::Arbiter)
//! blends their command with the robot's policies every control tick, as
//! the dissertation's user studies did with a joystick at 30 Hz (§4.4).
//!
//! The pieces, one per file:
//! - [`TeleopSession`]: one person's simulator — a task (the Panda's
//!   reach-and-grasp or the planar pick), its arbiter, the arm stepped by a
//!   [`LiveEpisode`](crate::sim::LiveEpisode), the latest command, and the
//!   recording of every driven episode (Parquet, the simulator's layout);
//!   an episode starts at the first command that is not zero, so a page
//!   left open is neither timed nor recorded;
//! - [`SceneView`] and [`StateView`]: what the page draws, as JSON;
//! - `serve` (feature `serve`): the axum web server, the page at `/`, the WebSocket at
//!   `/ws` (one session per connection), health and timing at `/stats`.
//!
//! The protocol (JSON text frames): the page sends
//! `{"type":"command","linear":[vx,vy,vz]}` (m/s, world axes; `null` is
//! read as NaN and makes the arbiter hold), `{"type":"mode","mode":"sos"}`
//! and `{"type":"reset","task":"planar","seed":3}`; the server sends
//! `hello`, `preparing`, `scene`, `state` (at most 60 per second),
//! `episode` (an episode ended: its outcome, its reason by name and in
//! words — `reason`, `reason_detail`, as in [`StateView`] — and where it was
//! saved; once per episode) and `error`. Between `preparing` and `scene`
//! a mode message is kept and applied (or refused with an `error`) when the
//! task is ready, and commands are dropped. Limits: [`ServeSettings`]
//! (sessions at once, request-head and idle timeouts).
//!
//! ```no_run
//! use tandem::teleop::{SessionSettings, TeleopSession, TeleopTask};
//! // Without a browser: one session stepped by hand.
//! let settings = SessionSettings::default();
//! let mut session = TeleopSession::prepare(&settings, TeleopTask::Planar, 0)?;
//! session.set_command([0.05, 0.0, 0.0], std::time::Instant::now());
//! let state = session.tick(std::time::Instant::now())?;
//! println!("gripper at {:?}, status {}", state.gripper, state.status);
//! # Ok::<(), tandem::teleop::TeleopError>(())
//! ```

mod protocol;
mod scene_view;
#[cfg(feature = "serve")]
mod server;
mod session;

pub use protocol::{ClientMessage, MAX_FRAME_BYTES, MAX_MESSAGE_BYTES, parse_client_message};
pub use scene_view::{SceneView, ShapeView, StateView};
#[cfg(feature = "serve")]
pub use server::{ServeSettings, Server, ServerStats, serve};
pub use session::{Recording, SessionSettings, TeleopSession, TeleopTask};

/// Errors of the teleoperation server and its sessions.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TeleopError {
    /// A task could not be prepared (its references, its arbiter).
    #[error("preparing the {task} task: {source}")]
    Prepare {
        /// The task.
        task: &'static str,
        /// Why.
        source: Box<crate::arbitration::ArbitrationError>,
    },
    /// The simulator's kinematics or collision queries failed.
    #[error(transparent)]
    Robot(#[from] crate::robot::RobotError),
    /// The learned arbitration actor could not be loaded.
    #[error(transparent)]
    Learn(#[from] crate::learn::LearnError),
    /// Binding the port or serving failed.
    #[error("the web server: {0}")]
    Io(#[from] std::io::Error),
    /// Writing an episode's recording failed.
    #[error(transparent)]
    Record(#[from] crate::files::FileError),
}
