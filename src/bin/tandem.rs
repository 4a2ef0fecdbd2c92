//! The `tandem` command; see `tandem --help`.

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    restore_default_sigpipe();
    pin_thread_count();
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

/// candle (the network trainer) asks for the number of physical cores —
/// reading /proc/cpuinfo — on every matrix product unless
/// RAYON_NUM_THREADS is set; that made DDPG training several times slower.
/// Setting it to the cores this process may use changes nothing else
/// (rayon's default is the same number).
fn pin_thread_count() {
    if std::env::var_os("RAYON_NUM_THREADS").is_none() {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        // SAFETY: called in main before any thread exists, so no other
        // thread can read the environment concurrently.
        unsafe { std::env::set_var("RAYON_NUM_THREADS", cores.to_string()) };
    }
}
