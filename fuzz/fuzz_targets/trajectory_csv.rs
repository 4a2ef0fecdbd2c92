//! Trajectory CSV → table → joint reference → constant-gain tracking
//! policy → one query at the start and one rollout step.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tandem::control::{GainSchedule, JointTrajectory, TrackingPolicy, TrackingWeights};
use tandem::data::TrajectoryTable;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(table) = TrajectoryTable::from_csv_str(text, "<fuzz>") else { return };
    let _ = table.to_csv();
    let Ok(reference) = JointTrajectory::new(table.joints, table.time_step, &table.configurations) else { return };
    let Ok(policy) = TrackingPolicy::new(reference, TrackingWeights::default(), GainSchedule::Constant) else {
        return;
    };
    let start = policy.reference().position(0).to_vec();
    let mut ws = policy.workspace();
    let mut command = vec![0.0; start.len()];
    let _ = policy.query(&mut ws, &start, None, &mut command);
    let _ = policy.rollout(&start, 2);
});
