//! Path post-processing: shortcutting and resampling to a fixed number of
//! waypoints (the optimizer's horizon).

use super::EdgeCheck;
use crate::collision::{CollisionModel, CollisionWorkspace};
use crate::robot::RobotError;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Euclidean distance between two configurations (rad or m).
pub(super) fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt()
}

/// Smallest gain (fraction of the path's length) a random shortcut must
/// bring to be checked: each check validates a long motion, and the many
/// tiny gains cost most of the time for little (MotionBenchMaker: 0.4 %
/// longer paths than checking every gain, in a third of the time).
pub const MIN_GAIN: f64 = 0.005;

/// Joint-space length of a path (rad, sum of Euclidean segment lengths).
pub fn path_length(path: &[Vec<f64>]) -> f64 {
    path.windows(2).map(|w| distance(&w[0], &w[1])).sum()
}

/// Shortens a collision-free path: first greedily (from each waypoint, jump
/// to the farthest one reachable in a straight line), then `attempts`
/// random shortcuts between points on two random segments, each kept only
/// if its straight motion passes `edge`. Shortcuts that would shorten the
/// path by less than [`MIN_GAIN`] of its length are not checked. Seeded.
///
/// # Errors
/// Configurations of the wrong length or non-finite values.
pub fn shortcut(
    model: &CollisionModel,
    ws: &mut CollisionWorkspace,
    path: &[Vec<f64>],
    edge: EdgeCheck,
    attempts: usize,
    seed: u64,
) -> Result<Vec<Vec<f64>>, RobotError> {
    let mut out = greedy(model, ws, path, edge)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // The shortcut's ends, reused by every attempt (copied only when kept).
    let dim = path.first().map_or(0, Vec::len);
    let (mut a, mut b) = (vec![0.0; dim], vec![0.0; dim]);
    for _ in 0..attempts {
        if out.len() < 3 {
            break;
        }
        let i = rng.random_range(0..out.len() - 1);
        let j = rng.random_range(0..out.len() - 1);
        let (i, j) = (i.min(j), i.max(j));
        if j <= i {
            continue;
        }
        // Points inside segments i and j.
        let (s, t) = (rng.random_range(0.0..1.0), rng.random_range(0.0..1.0));
        lerp_into(&mut a, &out[i], &out[i + 1], s);
        lerp_into(&mut b, &out[j], &out[j + 1], t);
        let old = distance(&a, &out[i + 1]) + path_length(&out[i + 1..=j]) + distance(&out[j], &b);
        if distance(&a, &b) < old - MIN_GAIN * path_length(&out) && edge.is_free(model, ws, &a, &b)? {
            out.splice(i + 1..=j, [a.clone(), b.clone()]);
            out.dedup_by(|x, y| distance(x, y) < 1e-12);
        }
    }
    Ok(out)
}

fn greedy(
    model: &CollisionModel,
    ws: &mut CollisionWorkspace,
    path: &[Vec<f64>],
    edge: EdgeCheck,
) -> Result<Vec<Vec<f64>>, RobotError> {
    let Some(first) = path.first() else { return Ok(Vec::new()) };
    let mut out = vec![first.clone()];
    let mut i = 0;
    while i + 1 < path.len() {
        let mut j = path.len() - 1;
        while j > i + 1 && !edge.is_free(model, ws, &path[i], &path[j])? {
            j -= 1;
        }
        out.push(path[j].clone());
        i = j;
    }
    Ok(out)
}

/// `a + t (b − a)`.
fn lerp(a: &[f64], b: &[f64], t: f64) -> Vec<f64> {
    let mut out = vec![0.0; a.len()];
    lerp_into(&mut out, a, b, t);
    out
}

/// `a + t (b − a)` into `out` (of the same length).
fn lerp_into(out: &mut [f64], a: &[f64], b: &[f64], t: f64) {
    for ((o, x), y) in out.iter_mut().zip(a).zip(b) {
        *o = x + (y - x) * t;
    }
}

/// `count` (≥ 2) waypoints evenly spaced by joint-space arc length along
/// `path`, first and last included. Every new point lies on a segment of
/// the path, so a collision-free path stays collision-free.
pub fn resample(path: &[Vec<f64>], count: usize) -> Vec<Vec<f64>> {
    let count = count.max(2);
    let Some(first) = path.first() else { return Vec::new() };
    let total = path_length(path);
    if path.len() == 1 || total == 0.0 {
        return vec![first.clone(); count];
    }
    let mut out = Vec::with_capacity(count);
    let (mut seg, mut walked) = (0usize, 0.0);
    for k in 0..count {
        let target = total * k as f64 / (count - 1) as f64;
        while seg + 2 < path.len() && walked + distance(&path[seg], &path[seg + 1]) < target {
            walked += distance(&path[seg], &path[seg + 1]);
            seg += 1;
        }
        let len = distance(&path[seg], &path[seg + 1]);
        let t = if len > 0.0 { ((target - walked) / len).clamp(0.0, 1.0) } else { 0.0 };
        out.push(lerp(&path[seg], &path[seg + 1], t));
    }
    // The ends exactly, not up to rounding.
    out[count - 1].clone_from(&path[path.len() - 1]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resampling_keeps_ends_and_spacing() {
        let path = vec![vec![0.0, 0.0], vec![1.0, 0.0], vec![1.0, 3.0]];
        let r = resample(&path, 5);
        assert_eq!(r.len(), 5);
        assert_eq!(r[0], vec![0.0, 0.0]);
        assert_eq!(r[4], vec![1.0, 3.0]);
        assert!((r[1][0] - 1.0).abs() < 1e-12 && r[1][1].abs() < 1e-12);
        assert!((path_length(&r) - 4.0).abs() < 1e-12);
    }
}
