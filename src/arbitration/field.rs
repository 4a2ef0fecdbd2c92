//! Metric fields over a planar workspace (the dissertation's Fig. 4.2): the
//! ellipses of `F⁻¹` that show where and how the robot policy reshapes the
//! operator's command.

use super::{Arbiter, ArbitrationMode, HumanCommand, MetricSpace, TickInput};

/// The inverse metric at one point: the first two joints' values and the
/// 2 × 2 block of `F⁻¹` (column-major) there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldSample {
    /// Values of the first two joints (rad or m).
    pub at: [f64; 2],
    /// The 2 × 2 block of the inverse metric, column-major.
    pub inverse: [f64; 4],
}

/// The joint-space Fisher metric (`NaturalGradient(Joint)`) of `arbiter` on
/// a `grid × grid` lattice over the limits of the first two joints (inset
/// by 5 %), the other joints at `rest`, with the beliefs `beliefs(point)`.
/// Each point is queried by a fresh episode (policies' progress reset),
/// as a field of arms placed there.
pub fn metric_field(
    arbiter: &Arbiter,
    rest: &[f64],
    grid: usize,
    beliefs: impl Fn([f64; 2]) -> Vec<f64>,
) -> Vec<FieldSample> {
    let limits = arbiter.robot().limits();
    let n = rest.len();
    let span = |j: usize| {
        let (lo, hi) = (limits[j].lower, limits[j].upper);
        let inset = 0.05 * (hi - lo);
        (lo + inset, hi - inset)
    };
    let (x, y) = (span(0), span(1));
    let mut ws = arbiter.workspace();
    ws.set_mode(ArbitrationMode::NaturalGradient(MetricSpace::Joint));
    let mut q = rest.to_vec();
    let zero = vec![0.0; n];
    let mut out = Vec::with_capacity(grid * grid);
    for i in 0..grid {
        for k in 0..grid {
            let at = [lerp(x, i, grid), lerp(y, k, grid)];
            q[0] = at[0];
            q[1] = at[1];
            let b = beliefs(at);
            arbiter.reset(&mut ws);
            let input = TickInput { q: &q, velocity: None, command: HumanCommand::Joint(&zero), beliefs: Some(&b) };
            arbiter.tick(&mut ws, &input);
            let m = ws.metric().inverse();
            out.push(FieldSample { at, inverse: [m[0], m[1], m[n], m[n + 1]] });
        }
    }
    out
}

fn lerp((lo, hi): (f64, f64), i: usize, count: usize) -> f64 {
    if count < 2 { 0.5 * (lo + hi) } else { lo + (hi - lo) * i as f64 / (count - 1) as f64 }
}
