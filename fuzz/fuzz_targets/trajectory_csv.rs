//! Trajectory CSV → joint trajectory → its CSV read back (the same joint
//! names and values: what tandem writes, it reads) → constant-gain tracking
//! policy → one query at the start and one rollout step.
#![no_main]

use libfuzzer_sys::fuzz_target;
use tandem::control::{GainSchedule, TrackingPolicy, TrackingWeights};
use tandem::trajectory::JointTrajectory;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let Ok(reference) = JointTrajectory::from_csv_str(text, "<fuzz>") else { return };
    let written = reference.to_csv();
    let back = JointTrajectory::from_csv_str(&written, "<written>").unwrap_or_else(|e| panic!("{e}\n{written}"));
    assert_eq!(back.joints(), reference.joints());
    assert!(back.positions().eq(reference.positions()), "{written}");
    let Ok(policy) = TrackingPolicy::new(reference, TrackingWeights::default(), GainSchedule::Constant) else {
        return;
    };
    let start = policy.reference().position(0).to_vec();
    let mut ws = policy.workspace();
    let mut command = vec![0.0; start.len()];
    let _ = policy.query(&mut ws, &start, None, &mut command);
    let _ = policy.rollout(&start, 2);
});
