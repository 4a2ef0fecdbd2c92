//! The `tandem` command; see `tandem --help`.

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    restore_default_sigpipe();
    // Usage errors exit with clap's status 2 (tandem::cli::EXIT_USAGE).
    let cli = tandem::cli::Cli::parse();
    match tandem::cli::run(cli) {
        Ok(tandem::cli::Outcome::Success) => ExitCode::from(tandem::cli::EXIT_SUCCESS),
        Ok(tandem::cli::Outcome::Unsuccessful) => ExitCode::from(tandem::cli::EXIT_UNSUCCESSFUL),
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(tandem::cli::EXIT_ERROR)
        }
    }
}

/// Rust ignores SIGPIPE, so `println!` panics when stdout is a closed pipe
/// (`tandem inspect x.urdf | head`). Command-line tools should just stop.
fn restore_default_sigpipe() {
    #[cfg(unix)]
    // SAFETY: called first thing in main, before any thread exists; resetting
    // a signal disposition to its default has no other precondition.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}
