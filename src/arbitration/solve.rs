//! Stage 7 of a tick: the command that meets every hard-constraint row.
//! The mode's closed form when it meets them all (it is then the optimum
//! of the convex problem); else a solver on the rows it violates — the
//! dense active-set solver for the QP modes, Clarabel for `Constrained`'s
//! cone and whenever the active set cannot finish — adding the rows each
//! solution violates, up to 6 rounds.

use super::command::{Diagnostics, TickStatus};
use super::safety::{Row, SafetyRows};
use super::settings::{ArbiterSettings, SolverBackend};
use super::workspace::{ObjectiveStage, SolveStage};
use tandem_solvers::conic::{ConicData, ConicError, SecondOrderCone};

impl SolveStage {
    /// Meets every row of `rows` starting from `objective`'s closed form
    /// (with `closed_form_first`; else the solver runs on every row at
    /// once), into `self.u`. Returns whether the solver ran.
    pub(crate) fn enforce(
        &mut self,
        rows: &SafetyRows,
        objective: &ObjectiveStage,
        settings: &ArbiterSettings,
        diagnostics: &mut Diagnostics,
    ) -> Result<bool, TickStatus> {
        self.u.copy_from_slice(&objective.u0);
        self.active.clear();
        self.solved_rows = 0;
        let mut solved = !settings.closed_form_first;
        if solved {
            self.active.extend(rows.rows());
            self.solve(rows, objective, settings.backend, diagnostics)?;
        }
        for _round in 0..6 {
            let before = self.active.len();
            for row in rows.rows() {
                if !self.active.contains(&row) && rows.slack(row, &self.u) < -violation_tolerance(rows, row) {
                    self.active.push(row);
                }
            }
            if self.active.len() == before {
                return Ok(solved);
            }
            self.solve(rows, objective, settings.backend, diagnostics)?;
            solved = true;
        }
        let worst = rows.rows().map(|r| rows.slack(r, &self.u)).fold(0.0f64, f64::min);
        if worst < -1e-6 { Err(TickStatus::SolverFailed) } else { Ok(solved) }
    }

    /// Solves the objective's problem with the active rows into `self.u`.
    fn solve(
        &mut self,
        rows: &SafetyRows,
        objective: &ObjectiveStage,
        backend: SolverBackend,
        diagnostics: &mut Diagnostics,
    ) -> Result<(), TickStatus> {
        let n = self.u.len();
        if self.active.len() > self.h.len() {
            // More rows than the solvers take: the most violated first.
            let u = &self.u;
            self.active.sort_by(|a, b| rows.slack(*a, u).total_cmp(&rows.slack(*b, u)));
            self.active.truncate(self.h.len());
        }
        let m = self.active.len();
        for (i, &row) in self.active.iter().enumerate() {
            self.h[i] = rows.row(row, &mut self.g[i * n..(i + 1) * n]);
        }
        let o = objective;
        let cone = o.conic.then(|| SecondOrderCone { l: &o.cone_l, c: &o.cone_c, radius: o.radius });
        let data = ConicData { p: &o.p, q: &o.q, g: &self.g[..m * n], h: &self.h[..m], cone };
        let result = match (cone.is_some(), backend) {
            (true, _) => self.socp.solve(&data),
            (false, SolverBackend::ActiveSet) => match self.dense.solve(&data) {
                Ok(solution) => Ok(solution),
                Err(_) => self.qp.solve(&data),
            },
            #[cfg(feature = "osqp")]
            (false, SolverBackend::Osqp) => self.osqp.solve(&data),
            (false, _) => self.qp.solve(&data),
        };
        match result {
            Ok(solution) if solution.x.iter().all(|x| x.is_finite()) => {
                self.u.copy_from_slice(solution.x);
                self.z[..m].copy_from_slice(solution.z);
                self.solved_rows = m;
                diagnostics.solver_iterations += solution.iterations;
                diagnostics.solves += 1;
                Ok(())
            }
            Ok(_) | Err(ConicError::Numerical | ConicError::MaxIterations | ConicError::Capacity { .. }) => {
                Err(TickStatus::SolverFailed)
            }
            Err(ConicError::Infeasible | ConicError::Unbounded) => Err(TickStatus::Infeasible),
        }
    }
}

/// How far below zero a row's slack may go before it counts as violated.
fn violation_tolerance(rows: &SafetyRows, row: Row) -> f64 {
    let h = match row {
        Row::Upper(j) => rows.hi[j],
        Row::Lower(j) => rows.lo[j],
        Row::Distance(_) => 0.0,
    };
    1e-9 * (1.0 + h.abs())
}
