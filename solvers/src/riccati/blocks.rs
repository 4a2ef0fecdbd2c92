//! Decoupled subsystems. When the states and inputs split into groups that
//! no entry of `A`, `B`, `Q`, `R` or `N` connects, the stabilising `P` and
//! the gain `K` are block diagonal in the same grouping, and the DARE is a
//! set of independent smaller ones: a per-joint model (the Panda's double
//! integrator is seven systems of 2 states and 1 input) costs a few tiny
//! solves instead of one with 14 states. Groups whose matrices are
//! identical (the same model and weights on every joint) are solved once.

use super::dare::DareWorkspace;
use super::{DareSettings, DareStats, RiccatiError};
use nalgebra::DMatrix;

/// The grouping of the last split and one workspace per group; every
/// buffer keeps its capacity, so splitting the same structure again
/// allocates nothing.
#[derive(Debug, Clone, Default)]
pub(super) struct Blocks {
    /// Union-find parents over the `n` states, then the `m` inputs.
    parent: Vec<usize>,
    /// Group of each state, then of each input.
    group: Vec<usize>,
    /// States, then inputs, listed group after group (ascending within one).
    states: Vec<usize>,
    inputs: Vec<usize>,
    /// Group `g` owns `states[state_start[g]..state_start[g + 1]]`, likewise inputs.
    state_start: Vec<usize>,
    input_start: Vec<usize>,
    /// The first group with matrices identical to `g`'s (`g` itself if none).
    source: Vec<usize>,
    stats: Vec<DareStats>,
    parts: Vec<DareWorkspace>,
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

fn union(parent: &mut [usize], i: usize, j: usize) {
    let (ri, rj) = (find(parent, i), find(parent, j));
    if ri != rj {
        parent[ri.max(rj)] = ri.min(rj);
    }
}

/// `dst[r, c] = src[rows[r], cols[c]]`.
fn gather(dst: &mut DMatrix<f64>, src: &DMatrix<f64>, rows: &[usize], cols: &[usize]) {
    for (c, &j) in cols.iter().enumerate() {
        for (r, &i) in rows.iter().enumerate() {
            dst[(r, c)] = src[(i, j)];
        }
    }
}

/// `dst[rows[r], cols[c]] = src[r, c]`.
fn scatter(dst: &mut DMatrix<f64>, src: &DMatrix<f64>, rows: &[usize], cols: &[usize]) {
    for (c, &j) in cols.iter().enumerate() {
        for (r, &i) in rows.iter().enumerate() {
            dst[(i, j)] = src[(r, c)];
        }
    }
}

impl Blocks {
    /// Groups the states and inputs of `a`, `b`, `q`, `r` (and the cross
    /// weight); true when there are at least two groups and each has a
    /// state and an input (otherwise the dense solve is the one to run).
    pub(super) fn split(
        &mut self,
        a: &DMatrix<f64>,
        b: &DMatrix<f64>,
        q: &DMatrix<f64>,
        r: &DMatrix<f64>,
        cross: Option<&DMatrix<f64>>,
    ) -> bool {
        let (n, m) = (a.nrows(), b.ncols());
        if n < 2 || m < 2 {
            return false;
        }
        self.parent.clear();
        self.parent.extend(0..n + m);
        let p = &mut self.parent[..];
        // Column-major slices: column j of an n-row matrix is [j·n, (j + 1)·n).
        let (a, q, b, r) = (a.as_slice(), q.as_slice(), b.as_slice(), r.as_slice());
        for (j, (ac, qc)) in a.chunks_exact(n).zip(q.chunks_exact(n)).enumerate() {
            for (i, (x, y)) in ac.iter().zip(qc).enumerate() {
                if (*x != 0.0 || *y != 0.0) && i != j {
                    union(p, i, j);
                }
            }
        }
        for (u, bc) in b.chunks_exact(n).enumerate() {
            let nc = cross.map(|c| &c.as_slice()[u * n..(u + 1) * n]);
            for (i, x) in bc.iter().enumerate() {
                if *x != 0.0 || nc.is_some_and(|c| c[i] != 0.0) {
                    union(p, i, n + u);
                }
            }
            for (v, x) in r[u * m..u * m + u].iter().enumerate() {
                if *x != 0.0 {
                    union(p, n + v, n + u);
                }
            }
        }
        // Number the groups in the order of their first state or input.
        self.group.clear();
        self.group.resize(n + m, usize::MAX);
        let mut groups = 0;
        for x in 0..n + m {
            let root = find(&mut self.parent, x);
            if self.group[root] == usize::MAX {
                self.group[root] = groups;
                groups += 1;
            }
            self.group[x] = self.group[root];
        }
        if groups < 2 {
            return false;
        }
        self.states.clear();
        self.inputs.clear();
        self.state_start.clear();
        self.input_start.clear();
        for g in 0..groups {
            self.state_start.push(self.states.len());
            self.input_start.push(self.inputs.len());
            self.states.extend((0..n).filter(|&i| self.group[i] == g));
            self.inputs.extend((0..m).filter(|&u| self.group[n + u] == g));
            let (has_state, has_input) =
                (self.states.len() > self.state_start[g], self.inputs.len() > self.input_start[g]);
            if !(has_state && has_input) {
                return false; // states no input reaches, or an input that acts on nothing
            }
        }
        self.state_start.push(n);
        self.input_start.push(m);
        true
    }

    /// Solves every group of the last [`split`](Self::split) of `full`'s
    /// loaded problem, then assembles `P`, `K` and the statistics in `full`.
    /// With `warm`, `full.p` holds the starting `P` and each group starts
    /// from its diagonal block.
    pub(super) fn solve(
        &mut self,
        full: &mut DareWorkspace,
        settings: &DareSettings,
        warm: bool,
    ) -> Result<DareStats, RiccatiError> {
        let groups = self.state_start.len() - 1;
        self.source.clear();
        self.stats.clear();
        for g in 0..groups {
            let states = &self.states[self.state_start[g]..self.state_start[g + 1]];
            let inputs = &self.inputs[self.input_start[g]..self.input_start[g + 1]];
            let (ns, ni) = (states.len(), inputs.len());
            if self.parts.len() <= g {
                self.parts.push(DareWorkspace::new(ns, ni));
            }
            let part = &mut self.parts[g];
            part.resize(ns, ni);
            gather(&mut part.a0, &full.a0, states, states);
            gather(&mut part.b0, &full.b0, states, inputs);
            gather(&mut part.q0, &full.q0, states, states);
            gather(&mut part.r0, &full.r0, inputs, inputs);
            part.has_cross = full.has_cross;
            if full.has_cross {
                gather(&mut part.n0, &full.n0, states, inputs);
            }
            if warm {
                gather(&mut part.p, &full.p, states, states);
            }
            let twin = (0..g).find(|&h| self.source[h] == h && self.parts[h].same_problem(&self.parts[g]));
            match twin {
                Some(h) => {
                    self.source.push(h);
                    self.stats.push(self.stats[h]);
                }
                None => {
                    self.source.push(g);
                    self.stats.push(self.parts[g].solve_loaded(settings, warm)?);
                }
            }
        }
        full.p.fill(0.0);
        full.k.fill(0.0);
        let mut terms = [0.0; 4];
        let mut stats =
            DareStats { residual: 0.0, iterations: 0, refinement_steps: 0, closed_loop_spectral_radius: 0.0 };
        for g in 0..groups {
            let states = &self.states[self.state_start[g]..self.state_start[g + 1]];
            let inputs = &self.inputs[self.input_start[g]..self.input_start[g + 1]];
            let part = &self.parts[self.source[g]];
            scatter(&mut full.p, &part.p, states, states);
            scatter(&mut full.k, &part.k, inputs, states);
            // Block-diagonal matrices add their blocks' squared Frobenius norms.
            for (t, v) in terms.iter_mut().zip(part.residual_terms) {
                *t += v * v;
            }
            let s = &self.stats[g];
            stats.iterations = stats.iterations.max(s.iterations);
            stats.refinement_steps = stats.refinement_steps.max(s.refinement_steps);
            stats.closed_loop_spectral_radius = stats.closed_loop_spectral_radius.max(s.closed_loop_spectral_radius);
        }
        let [res, apa, p, q] = terms.map(f64::sqrt);
        stats.residual = if res == 0.0 { 0.0 } else { res / (apa + p + q) };
        Ok(stats)
    }
}
