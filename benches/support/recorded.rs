//! An episode's ticks as a benchmark replays them: the state, the
//! velocity that led to the next state and the operator's command, tick by
//! tick (so every arbiter under test sees the same inputs).

use tandem::sim::EpisodeRecord;

/// One recorded tick: state (rad), velocity (rad/s), operator command (m/s).
pub struct Recorded {
    pub q: Vec<f64>,
    pub velocity: Vec<f64>,
    pub command: [f64; 3],
}

/// The ticks of `record`, run at period `dt` (s).
pub fn recorded_ticks(record: &EpisodeRecord, dt: f64) -> Vec<Recorded> {
    (0..record.steps)
        .map(|t| Recorded {
            q: record.q[t].clone(),
            velocity: record.q[t].iter().zip(&record.q[t + 1]).map(|(a, b)| (b - a) / dt).collect(),
            command: record.human[t],
        })
        .collect()
}
