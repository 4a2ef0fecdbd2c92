//! Newton (Hewer) steps on the DARE: the refinement after doubling and the
//! warm start, each solving one Stein equation by Smith doubling.

use super::{DareSettings, DareStats, DareWorkspace};
use crate::riccati::dense::{self, Op, gemm};

/// Doubling steps of the Smith iteration for the Newton correction (each
/// squares the closed loop, so 60 covers spectral radii up to 1 − 1e-16).
const MAX_SMITH_STEPS: usize = 60;

/// Newton steps a warm start may take before the cold solve takes over
/// (from a nearby stabilising `P` it needs one or two).
const MAX_WARM_STEPS: usize = 8;

impl DareWorkspace {
    /// Newton steps from the `P` in `p`; `None` unless they reach the
    /// residual tolerance with a certified Schur-stable closed loop (the
    /// caller then solves cold).
    pub(super) fn newton_from_p(&mut self, settings: &DareSettings) -> Option<DareStats> {
        let mut residual = self.gain_and_residual();
        if !residual.is_finite() {
            return None; // R + BᵀP₀B is not positive definite: no gain to start from
        }
        let steps;
        (residual, steps) = self.newton_steps(settings.refinement_threshold, MAX_WARM_STEPS, residual);
        if residual.is_nan() || residual > settings.residual_tolerance {
            return None;
        }
        self.closed_loop_into_mm();
        let rho = self.spectral_radius_bound(0);
        // ρ < 1 with a small residual: this P is the stabilising solution (it is unique).
        (rho < 1.0).then_some(DareStats {
            residual,
            iterations: 0,
            refinement_steps: steps,
            closed_loop_spectral_radius: rho,
        })
    }

    /// `mm ← A − BK` for the current `K`.
    fn closed_loop_into_mm(&mut self) {
        self.mm.copy_from(&self.a0);
        gemm(&mut self.mm, -1.0, Op::n(&self.b0), Op::n(&self.k), 1.0);
    }

    /// One Newton step `P ← P + X`, `X − SᵀXS = Res(P)`, `S = A − BK`;
    /// false when the Stein series does not converge (`S` not Schur-stable).
    fn newton_step(&mut self) -> bool {
        self.closed_loop_into_mm();
        if !self.stein() {
            return false;
        }
        self.p += &self.dh;
        dense::symmetrize(&mut self.p);
        true
    }

    /// The refinement after doubling: [`Self::newton_steps`] up to the
    /// settings' threshold and step count.
    pub(super) fn refine(&mut self, settings: &DareSettings, residual: f64) -> (f64, usize) {
        self.newton_steps(settings.refinement_threshold, settings.max_refinement_steps, residual)
    }

    /// Newton steps `P ← P + X`, `X − SᵀXS = Res(P)`, `S = A − BK`, at most
    /// `max_steps`, while the residual is above `threshold` and improving;
    /// returns the final residual and the steps attempted.
    fn newton_steps(&mut self, threshold: f64, max_steps: usize, mut residual: f64) -> (f64, usize) {
        let mut steps = 0;
        while residual > threshold && steps < max_steps {
            steps += 1;
            self.p_prev.copy_from(&self.p);
            self.k_prev.copy_from(&self.k);
            let terms = self.residual_terms;
            let next = if self.newton_step() { self.gain_and_residual() } else { f64::NAN };
            if next.is_nan() || next >= residual {
                // Stalled at rounding level (or diverging): keep the better answer.
                self.p.copy_from(&self.p_prev);
                self.k.copy_from(&self.k_prev);
                self.residual_terms = terms;
                break;
            }
            residual = next;
        }
        (residual, steps)
    }

    /// Solves `X − SᵀXS = res` into `dh` by Smith doubling: the series
    /// `X = Σ_i (Sᵀ)^i res S^i` summed in blocks of doubling length,
    /// `X ← X + MᵀXM`, `M ← M²`, starting from `X = res`, `M = S` (in `mm`);
    /// false when the series has not converged (or overflowed).
    fn stein(&mut self) -> bool {
        self.dh.copy_from(&self.res);
        for _ in 0..MAX_SMITH_STEPS {
            gemm(&mut self.t1, 1.0, Op::n(&self.dh), Op::n(&self.mm), 0.0);
            gemm(&mut self.w, 1.0, Op::t(&self.mm), Op::n(&self.t1), 0.0);
            self.dh += &self.w;
            let (step, sum) = (dense::frobenius(self.w.as_slice()), dense::frobenius(self.dh.as_slice()));
            if !sum.is_finite() {
                return false;
            }
            if step <= f64::EPSILON * sum {
                return true;
            }
            gemm(&mut self.m2, 1.0, Op::n(&self.mm), Op::n(&self.mm), 0.0);
            std::mem::swap(&mut self.mm, &mut self.m2);
        }
        false
    }
}
