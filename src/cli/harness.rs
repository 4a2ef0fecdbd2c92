//! Running an experiment from the command line: the harness runs it
//! (threads, output folder), then its JSON, or its table and the files it
//! wrote, are printed. Every `tandem experiment` subcommand ends here.

use crate::data::Progress;
use crate::experiments::HarnessSettings;
use std::path::PathBuf;

/// Runs `experiment` in the harness (`threads`, `out`; quiet with `json`),
/// then prints its JSON, or its table and the files it wrote.
pub(super) fn run_in_harness<E: crate::experiments::Experiment>(
    experiment: &E,
    threads: Option<usize>,
    json: bool,
    out: Option<PathBuf>,
) -> Result<(), Box<dyn std::error::Error>> {
    let progress = if json { Progress::quiet() } else { Progress::auto() };
    let report = crate::experiments::run(experiment, &HarnessSettings { threads, progress, out })?;
    if json {
        println!("{}", report.json);
        return Ok(());
    }
    print!("{}", report.table);
    if !report.written.is_empty() {
        let files: Vec<String> = report.written.iter().map(|p| p.display().to_string()).collect();
        println!("wrote {}", files.join(", "));
    }
    Ok(())
}
