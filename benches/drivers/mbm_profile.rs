//! MotionBenchMaker problems planned and simplified as
//! `benches/motionbenchmaker.rs` does (seed 0), for profiling:
//!
//! ```text
//! mbm_profile --band 0.25 0.75          # names of the problems whose total
//!                                       # time lies in that percentile band
//! valgrind --tool=callgrind --toggle-collect='*ProblemPlanner*run*' \
//!     target/release/examples/mbm_profile box:3 cage:17 ...
//! ```
//!
//! Given problems (`family:k`), prints an FNV-1a hash of the simplified
//! paths' bits and their mean length: changes that keep every verdict
//! keep the hash.

#[path = "../support/mbm.rs"]
#[allow(dead_code)]
mod mbm;

use mbm::{Benchmark, FAMILIES};
use tandem::plan::{ProblemPlanner, path_length};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let benchmark = Benchmark::unpack();
    if args.first().map(String::as_str) == Some("--band") {
        let band = |i: usize| -> Result<f64, Box<dyn std::error::Error>> {
            Ok(args.get(i).ok_or("--band needs two fractions, e.g. --band 0.25 0.75")?.parse()?)
        };
        let (lo, hi) = (band(1)?, band(2)?);
        let mut times = Vec::new();
        for family in FAMILIES {
            for k in 1..=100 {
                let mut planner = ProblemPlanner::new(&benchmark.problem(family, k), Some(0))?;
                let report = planner.run(0)?;
                if report.certified {
                    times.push(((report.planning_time + report.simplify_time).as_secs_f64(), format!("{family}:{k}")));
                }
            }
        }
        times.sort_by(|a, b| a.0.total_cmp(&b.0));
        let at = |p: f64| (p * (times.len() - 1) as f64).round() as usize;
        let names: Vec<&str> = times[at(lo)..=at(hi)].iter().map(|t| t.1.as_str()).collect();
        println!("{}", names.join(" "));
        return Ok(());
    }
    // Prepared first, so that a profile toggled on `run` sees planning only.
    let mut planners = Vec::new();
    for name in &args {
        let (family, k) = name.split_once(':').ok_or("family:k")?;
        planners.push(ProblemPlanner::new(&benchmark.problem(family, k.parse()?), Some(0))?);
    }
    let (mut hash, mut length, mut solved) = (0xcbf2_9ce4_8422_2325u64, 0.0, 0);
    let reps: usize = std::env::var("MBM_REPS").map_or(Ok(1), |v| v.parse())?;
    let began = std::time::Instant::now();
    for _ in 1..reps {
        for planner in &mut planners {
            planner.run(0)?;
        }
    }
    for planner in &mut planners {
        let report = planner.run(0)?;
        if report.certified {
            solved += 1;
            length += path_length(&report.path);
        }
        hash = report.path.iter().flatten().fold(hash, |h, v| (h ^ v.to_bits()).wrapping_mul(0x0100_0000_01b3));
    }
    let per_run = began.elapsed().as_secs_f64() * 1e3 / (reps * planners.len()) as f64;
    println!(
        "{solved} of {} certified, mean length {:.4} rad, hash {hash:016x}, {per_run:.3} ms per run",
        args.len(),
        length / solved as f64
    );
    Ok(())
}
