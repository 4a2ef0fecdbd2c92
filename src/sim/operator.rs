//! Simulated operators (seed §5.5.2): policies that give the arbiter the
//! commands a person would, from what they see of the scene.

/// What an operator sees each tick.
#[derive(Debug, Clone, Copy)]
pub struct Observation<'a> {
    /// The configuration (rad or m).
    pub q: &'a [f64],
    /// Gripper position (m, world).
    pub gripper: [f64; 3],
    /// The true goal's grasp point (m, world): where the operator aims.
    pub goal: [f64; 3],
    /// Seconds since the episode started.
    pub time: f64,
}

/// A simulated operator: a 3-D linear velocity command (m/s, world axes)
/// for the gripper each tick.
pub trait Operator: Send {
    /// The command for this tick, written into `out`.
    fn command(&mut self, seen: &Observation<'_>, out: &mut [f64; 3]);
    /// The operator's name (`straightline`, …).
    fn name(&self) -> &'static str;
}

/// Heads straight for the goal at `speed`, slowing down over the last
/// `slow_down` metres (seed: "actions that point directly toward the object").
#[derive(Debug, Clone, Copy)]
pub struct Straightline {
    /// Cruise speed (m/s; default 0.1).
    pub speed: f64,
    /// Distance over which the speed ramps down to 0 at the goal (m; default 0.05).
    pub slow_down: f64,
}

impl Default for Straightline {
    fn default() -> Self {
        Straightline { speed: 0.1, slow_down: 0.05 }
    }
}

impl Operator for Straightline {
    fn command(&mut self, seen: &Observation<'_>, out: &mut [f64; 3]) {
        toward(seen.gripper, seen.goal, self.speed, self.slow_down, out);
    }

    fn name(&self) -> &'static str {
        "straightline"
    }
}

/// Reaches a pre-grasp point `height` above the goal, then descends
/// (seed: "actions to reach a pre-grasp position above the object and
/// descend to grab the object").
#[derive(Debug, Clone, Copy)]
pub struct Approach {
    /// Cruise speed (m/s; default 0.1).
    pub speed: f64,
    /// Height of the pre-grasp point above the grasp point (m; default 0.1).
    pub height: f64,
    /// Distance to the pre-grasp point at which the descent starts (m; default 0.01).
    pub switch_distance: f64,
    descending: bool,
}

impl Approach {
    /// An approach at `speed` (m/s) with the default height and switch distance.
    pub fn at_speed(speed: f64) -> Self {
        Approach { speed, ..Approach::default() }
    }
}

impl Default for Approach {
    fn default() -> Self {
        Approach { speed: 0.1, height: 0.1, switch_distance: 0.01, descending: false }
    }
}

impl Operator for Approach {
    fn command(&mut self, seen: &Observation<'_>, out: &mut [f64; 3]) {
        let above = [seen.goal[0], seen.goal[1], seen.goal[2] + self.height];
        if !self.descending && distance(seen.gripper, above) < self.switch_distance {
            self.descending = true;
        }
        let aim = if self.descending { seen.goal } else { above };
        let slow = if self.descending { 0.05 } else { 0.0 };
        toward(seen.gripper, aim, self.speed, slow, out);
    }

    fn name(&self) -> &'static str {
        "approach"
    }
}

/// `speed` toward `to`, ramped down linearly over the last `slow_down` m.
pub(crate) fn toward(from: [f64; 3], to: [f64; 3], speed: f64, slow_down: f64, out: &mut [f64; 3]) {
    let d = distance(from, to);
    if d < 1e-9 {
        *out = [0.0; 3];
        return;
    }
    let s = if slow_down > 0.0 { speed * (d / slow_down).min(1.0) } else { speed.min(d / 0.05 * speed) };
    for i in 0..3 {
        out[i] = s * (to[i] - from[i]) / d;
    }
}

pub(crate) fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}
