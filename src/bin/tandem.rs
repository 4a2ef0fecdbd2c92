//! The `tandem` command; see `tandem --help`.

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = tandem::cli::Cli::parse();
    match tandem::cli::run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
