//! A globalized SQP method for the equality-constrained NLP of a [`Transcription`]: a direct
//! method that seeks a *minimum* from a rough start, where [`super::kkt::newton`] (full steps)
//! only converges from nearby and the indirect BVP solver finds any extremal its Newton steps
//! reach.
//!
//! # Method (as IPOPT's for problems without bounds)
//!
//! Iteration `k` at `(v, y)`:
//!
//! 1. **Inertia correction.** The KKT matrix `[[H + δ I, Aᵀ], [A, −δ_c I]]`
//!    (`H = ∇²ℒ(v, y)`) is factorized with `δ` = the current damping (0 at first, item 4);
//!    when its inertia is not `(n_var, n_con, 0)` (the reduced Hessian is not positive
//!    definite on the null space of `A`) `δ` grows from [`SqpOptions::first_regularization`]
//!    (or a third of the last one used) by a factor of 8 until it is; zero eigenvalues (`A`
//!    loses rank) first switch on `δ_c = 1e-8`. The step then minimizes a convex quadratic
//!    model on the linearized constraints. The factorization's inertia is not proven here
//!    ([`super::inertia::LbltFactor::factorize_unproven`]): the line search guards the step.
//! 2. **Step.** `[[H + δ I, Aᵀ], [A, −δ_c I]] [d; y⁺] = −[∇J; c]`.
//! 3. **Filter line search** (Wächter & Biegler 2006): a trial point is accepted when no
//!    earlier pair `(‖c‖₁, J)` of the filter dominates it and it reduces either `‖c‖₁` or `J`
//!    enough (Armijo's condition on `J` when the point is nearly feasible and `d` descends);
//!    backtracking by halves, and when the full step is rejected a second-order correction
//!    (the same matrix, the constraint right-hand side `c(v) + c(v + d)`) is tried first,
//!    against the Maratos effect.
//! 4. `v ← v + α d`, `y ← y + α (y⁺ − y)`. A short step (`α < 1/4`) raises the damping `δ` of
//!    the next iteration tenfold (a Levenberg–Marquardt term: the model is poor that far); a
//!    full step lowers it tenfold.
//! 5. When the filter blocks every step (the line search reaches
//!    [`SqpOptions::min_step`]), a feasibility restoration: least-norm Gauss–Newton steps on
//!    `c(v) = 0` alone until `‖c‖₁` has fallen tenfold, then a fresh filter (at most
//!    ten times).
//!
//! It stops when the relative stationarity and the feasibility are both below
//! [`SqpOptions::tolerance`], and with a reason when the line search and restoration fail,
//! the regularization runs away, or the iteration limit is reached.

use super::inertia::{Inertia, InertiaError, LbltFactor};
use super::kkt::{least_squares_multipliers, KktMatrix, KktPoint, KktResidual};
use super::problem::OcpProblem;
use super::transcription::Transcription;

/// Options of [`sqp`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SqpOptions {
    /// Stop when the relative stationarity and the feasibility are both below this.
    pub tolerance: f64,
    /// Iteration limit.
    pub max_iterations: usize,
    /// The first nonzero inertia correction `δ`.
    pub first_regularization: f64,
    /// The largest `δ` tried before giving up.
    pub max_regularization: f64,
    /// The smallest step length of the line search.
    pub min_step: f64,
}

impl Default for SqpOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-8,
            max_iterations: 200,
            first_regularization: 1e-4,
            max_regularization: 1e20,
            min_step: 1e-12,
        }
    }
}

/// What the iterations did.
#[derive(Debug, Clone, PartialEq)]
pub struct SqpReport {
    /// Iterations (steps taken).
    pub iterations: usize,
    /// The residual at the returned point.
    pub residual: KktResidual,
    /// The objective at the returned point.
    pub objective: f64,
    /// Iterations whose matrix needed an inertia correction `δ > 0`.
    pub regularized: usize,
    /// The largest `δ` used.
    pub largest_regularization: f64,
    /// Steps taken with the second-order correction.
    pub corrections: usize,
    /// The smallest accepted step length.
    pub smallest_step: f64,
    /// Feasibility restorations (the filter blocked every step).
    pub restorations: usize,
    /// Every iteration that took a step, in order.
    pub history: Vec<SqpIterate>,
}

/// One iteration of [`sqp`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SqpIterate {
    /// The objective before the step.
    pub objective: f64,
    /// The relative stationarity before the step.
    pub stationarity: f64,
    /// The feasibility before the step.
    pub feasibility: f64,
    /// The inertia correction used.
    pub regularization: f64,
    /// The accepted step length.
    pub step: f64,
    /// Whether the step was the second-order correction.
    pub corrected: bool,
}

/// Why [`sqp`] stopped without a KKT point.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SqpError {
    /// The KKT pattern could not be analysed or a matrix factorized.
    #[error("the KKT matrix: {0}")]
    Factorization(#[from] InertiaError),
    /// No inertia correction up to the limit gave the inertia of a minimum.
    #[error(
        "iteration {iteration}: no inertia correction up to {delta:.1e} makes the reduced \
         Hessian positive definite (inertia {inertia})"
    )]
    Regularization {
        /// The iteration.
        iteration: usize,
        /// The last `δ` tried.
        delta: f64,
        /// The inertia with it.
        inertia: Inertia,
    },
    /// The start is not a point where the problem is defined.
    #[error("the objective, constraints or derivatives are not finite at the start")]
    NonFiniteStart,
    /// The filter rejected every step down to the smallest step length, and a feasibility
    /// restoration did not help (or the restorations were used up).
    #[error(
        "iteration {iteration}: the line search found no step the filter accepts down to step \
         {step:.1e}, and no feasibility restoration helped (stationarity {stationarity:.2e}, \
         feasibility {feasibility:.2e})"
    )]
    LineSearch {
        /// The iteration.
        iteration: usize,
        /// The smallest step tried.
        step: f64,
        /// The relative stationarity there.
        stationarity: f64,
        /// The feasibility there.
        feasibility: f64,
    },
    /// The iteration limit.
    #[error(
        "no convergence in {iterations} iterations (stationarity {stationarity:.2e}, \
         feasibility {feasibility:.2e})"
    )]
    NotConverged {
        /// Iterations done.
        iterations: usize,
        /// The relative stationarity reached.
        stationarity: f64,
        /// The feasibility reached.
        feasibility: f64,
    },
}

/// The filter's margins and the switching and Armijo constants (IPOPT's defaults).
const GAMMA_THETA: f64 = 1e-5;
const GAMMA_PHI: f64 = 1e-5;
const S_THETA: f64 = 1.1;
const S_PHI: f64 = 2.3;
const ETA_PHI: f64 = 1e-4;

/// The regularization `δ_c` of the constraint block when the KKT matrix has zero eigenvalues.
const CONSTRAINT_REGULARIZATION: f64 = 1e-8;

fn norm_inf(x: &[f64]) -> f64 {
    x.iter().fold(0.0_f64, |m, v| m.max(v.abs()))
}

fn norm_1(x: &[f64]) -> f64 {
    x.iter().map(|v| v.abs()).sum()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Restorations allowed in one run of [`sqp`].
const MAX_RESTORATIONS: usize = 10;

/// Gauss–Newton steps of one restoration.
const RESTORATION_STEPS: usize = 20;

/// A restoration ends when it has reduced `‖c‖₁` by this factor.
const RESTORATION_REDUCTION: f64 = 0.1;

/// Least-norm Gauss–Newton steps `A d = −c` (backtracking on `‖c‖₁`) from `v` until `‖c‖₁`
/// falls by [`RESTORATION_REDUCTION`] (or below `1e-10`); `None` when it does not.
fn restore<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    kkt: &KktMatrix,
    v: &[f64],
) -> Option<Vec<f64>> {
    let nv = tr.n_var();
    let positions: Vec<_> = tr
        .lagrangian_hessian(v, &vec![0.0; tr.n_con()])
        .into_iter()
        .map(|(r, c, _)| (r, c, 0.0))
        .collect();
    let mut v = v.to_vec();
    let mut c = tr.constraints(&v);
    let theta_0 = norm_1(&c);
    let done = |theta: f64| theta <= RESTORATION_REDUCTION * theta_0 || theta <= 1e-10;
    for _ in 0..RESTORATION_STEPS {
        let theta = norm_1(&c);
        if done(theta) {
            return Some(v);
        }
        let values = kkt.values_regularized(&vec![1.0; nv], &positions, &tr.jacobian(&v), 0.0);
        let factor = kkt.factorize_unproven(&values).ok()?;
        let mut rhs = vec![0.0; nv];
        rhs.extend(c.iter().map(|x| -x));
        factor.solve_in_place(&mut rhs).ok()?;
        let mut alpha = 1.0;
        loop {
            let trial: Vec<f64> = v.iter().zip(&rhs).map(|(x, d)| x + alpha * d).collect();
            let c_trial = tr.constraints(&trial);
            let th = norm_1(&c_trial);
            if th.is_finite() && th <= (1.0 - 1e-4 * alpha) * theta {
                v = trial;
                c = c_trial;
                break;
            }
            alpha *= 0.5;
            if alpha < 1e-8 {
                return None;
            }
        }
    }
    done(norm_1(&c)).then_some(v)
}

/// Minimize the transcription's objective subject to its constraints from the primal point
/// `v0` (see the module docs). Returns the KKT point and what the iterations did.
pub fn sqp<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    v0: Vec<f64>,
    opts: &SqpOptions,
) -> Result<(KktPoint, SqpReport), SqpError> {
    let (nv, nc) = (tr.n_var(), tr.n_con());
    if v0.len() != nv {
        return Err(SqpError::Factorization(InertiaError::LengthMismatch {
            what: "start point",
            expected: nv,
            got: v0.len(),
        }));
    }
    if !tr.objective(&v0).is_finite() || !tr.constraints(&v0).iter().all(|c| c.is_finite()) {
        return Err(SqpError::NonFiniteStart);
    }
    let kkt = KktMatrix::regularizable(tr).map_err(|e| match e {
        super::kkt::KktError::Pattern(p) => SqpError::Factorization(p),
        _ => SqpError::NonFiniteStart,
    })?;
    let y0 = least_squares_multipliers(tr, &kkt, &v0).unwrap_or_else(|_| vec![0.0; nc]);
    let mut pt = KktPoint { v: v0, y: y0 };
    let target = Inertia {
        positive: nv,
        negative: nc,
        zero: 0,
    };
    let mut report = SqpReport {
        iterations: 0,
        residual: KktResidual {
            stationarity: f64::NAN,
            gradient_scale: f64::NAN,
            feasibility: f64::NAN,
        },
        objective: f64::NAN,
        regularized: 0,
        largest_regularization: 0.0,
        corrections: 0,
        smallest_step: 1.0,
        restorations: 0,
        history: Vec::new(),
    };
    let mut filter: Vec<(f64, f64)> = Vec::new();
    let mut theta_start: Option<f64> = None;
    let mut last_delta = 0.0_f64;
    let mut damping = 0.0_f64;
    loop {
        let g = tr.gradient(&pt.v);
        let a = tr.jacobian(&pt.v);
        let c = tr.constraints(&pt.v);
        let mut r = g.clone();
        for &(row, col, val) in &a {
            r[col] += val * pt.y[row];
        }
        let res = KktResidual {
            stationarity: norm_inf(&r),
            gradient_scale: norm_inf(&g),
            feasibility: norm_inf(&c),
        };
        report.residual = res;
        report.objective = tr.objective(&pt.v);
        if !(res.stationarity.is_finite() && res.feasibility.is_finite()) {
            return Err(SqpError::NonFiniteStart);
        }
        if res.relative_stationarity() <= opts.tolerance && res.feasibility <= opts.tolerance {
            return Ok((pt, report));
        }
        if report.iterations == opts.max_iterations {
            return Err(SqpError::NotConverged {
                iterations: report.iterations,
                stationarity: res.relative_stationarity(),
                feasibility: res.feasibility,
            });
        }
        let h = tr.lagrangian_hessian(&pt.v, &pt.y);
        // 1. Inertia correction, from the damping the last line search asked for.
        let mut delta = damping;
        let mut delta_c = 0.0;
        let factor: LbltFactor = loop {
            let values = kkt.values_regularized(&vec![delta; nv], &h, &a, delta_c);
            // A factorization refused as unreliable (tiny pivots: nearly singular) or broken
            // down at a zero pivot (singular) counts as a wrong inertia with zero
            // eigenvalues: the correction is raised.
            let (inertia, factor) = match kkt.factorize_unproven(&values) {
                Ok(f) => (f.inertia(), Some(f)),
                Err(InertiaError::Unreliable { .. } | InertiaError::Breakdown { .. }) => (
                    Inertia {
                        positive: 0,
                        negative: 0,
                        zero: nv + nc,
                    },
                    None,
                ),
                Err(e) => return Err(e.into()),
            };
            if let Some(f) = factor.filter(|_| inertia == target) {
                break f;
            }
            // Zero eigenvalues: the constraint Jacobian may have lost rank; regularize its
            // block once (IPOPT's δ_c), then go on raising δ_w.
            if inertia.zero > 0 && delta_c == 0.0 {
                delta_c = CONSTRAINT_REGULARIZATION;
                continue;
            }
            delta = if delta == damping && delta > 0.0 {
                delta * 8.0
            } else if delta == 0.0 {
                if last_delta == 0.0 {
                    opts.first_regularization
                } else {
                    (last_delta / 3.0).max(opts.first_regularization * 1e-4)
                }
            } else {
                delta * 8.0
            };
            if delta > opts.max_regularization {
                return Err(SqpError::Regularization {
                    iteration: report.iterations,
                    delta,
                    inertia,
                });
            }
        };
        if delta > 0.0 {
            report.regularized += 1;
            report.largest_regularization = report.largest_regularization.max(delta);
        }
        last_delta = delta;
        // 2. The step and the new multipliers.
        let mut rhs: Vec<f64> = g.iter().chain(&c).map(|x| -x).collect();
        factor.solve_in_place(&mut rhs)?;
        if !rhs.iter().all(|x| x.is_finite()) {
            return Err(SqpError::Regularization {
                iteration: report.iterations,
                delta,
                inertia: factor.inertia(),
            });
        }
        let (d, y_new) = rhs.split_at(nv);
        // 3. Filter line search (Wächter & Biegler 2006, as IPOPT's).
        let theta = norm_1(&c);
        let phi = report.objective;
        let theta_0 = *theta_start.get_or_insert(theta.max(1.0));
        let (theta_max, theta_min) = (1e4 * theta_0, 1e-4 * theta_0);
        let gd = dot(&g, d);
        let switching = |alpha: f64| gd < 0.0 && alpha * (-gd).powf(S_PHI) > theta.powf(S_THETA);
        // Some(f-type) when the trial at step `alpha` is accepted.
        let verdict = |alpha: f64, v: &[f64], filter: &[(f64, f64)]| -> Option<bool> {
            let th = norm_1(&tr.constraints(v));
            let ph = tr.objective(v);
            if !(th.is_finite() && ph.is_finite()) || th > theta_max {
                return None;
            }
            if filter.iter().any(|&(tj, pj)| th >= tj && ph >= pj) {
                return None;
            }
            if theta <= theta_min && switching(alpha) {
                (ph <= phi + ETA_PHI * alpha * gd).then_some(true)
            } else {
                (th <= (1.0 - GAMMA_THETA) * theta || ph <= phi - GAMMA_PHI * theta)
                    .then_some(false)
            }
        };
        let trial = |step: &[f64], alpha: f64| -> Vec<f64> {
            pt.v.iter().zip(step).map(|(x, s)| x + alpha * s).collect()
        };
        let mut alpha = 1.0;
        let mut accepted: Option<(Vec<f64>, f64, bool, bool)> = None;
        let full = trial(d, 1.0);
        if let Some(f_type) = verdict(1.0, &full, &filter) {
            accepted = Some((full, 1.0, false, f_type));
        } else {
            // Second-order correction of the full step.
            let c_full = tr.constraints(&full);
            if c_full.iter().all(|x| x.is_finite()) && norm_1(&c_full) >= theta {
                let mut soc: Vec<f64> = g
                    .iter()
                    .map(|x| -x)
                    .chain(c.iter().zip(&c_full).map(|(a, b)| -(a + b)))
                    .collect();
                if factor.solve_in_place(&mut soc).is_ok() && soc.iter().all(|x| x.is_finite()) {
                    let corrected = trial(&soc[..nv], 1.0);
                    if let Some(f_type) = verdict(1.0, &corrected, &filter) {
                        report.corrections += 1;
                        accepted = Some((corrected, 1.0, true, f_type));
                    }
                }
            }
            while accepted.is_none() {
                alpha *= 0.5;
                if alpha < opts.min_step {
                    break;
                }
                let v = trial(d, alpha);
                if let Some(f_type) = verdict(alpha, &v, &filter) {
                    accepted = Some((v, alpha, false, f_type));
                }
            }
        }
        let Some((v, alpha, corrected, f_type)) = accepted else {
            // 5. Feasibility restoration: the filter blocks every step. Move toward the
            // constraints alone (least-norm Gauss–Newton steps), then start a fresh filter.
            let restored = (report.restorations < MAX_RESTORATIONS)
                .then(|| restore(tr, &kkt, &pt.v))
                .flatten();
            let Some(v) = restored else {
                return Err(SqpError::LineSearch {
                    iteration: report.iterations,
                    step: alpha,
                    stationarity: res.relative_stationarity(),
                    feasibility: res.feasibility,
                });
            };
            pt.y = least_squares_multipliers(tr, &kkt, &v).unwrap_or_else(|_| vec![0.0; nc]);
            pt.v = v;
            filter.clear();
            theta_start = None;
            damping = 0.0;
            report.restorations += 1;
            report.iterations += 1;
            continue;
        };
        if !f_type {
            filter.push(((1.0 - GAMMA_THETA) * theta, phi - GAMMA_PHI * theta));
        }
        report.history.push(SqpIterate {
            objective: report.objective,
            stationarity: res.relative_stationarity(),
            feasibility: res.feasibility,
            regularization: delta,
            step: alpha,
            corrected,
        });
        // 4. Update.
        pt.v = v;
        for (yi, yn) in pt.y.iter_mut().zip(y_new) {
            *yi += alpha * (yn - *yi);
        }
        // Short steps: the quadratic model is poor so far from the point; damp the next
        // step (a Levenberg–Marquardt term on top of the inertia correction). Full steps
        // take the damping back.
        if alpha < 0.25 {
            damping = (damping * 10.0).max(delta).max(opts.first_regularization);
        } else if alpha == 1.0 {
            damping /= 10.0;
            if damping < opts.first_regularization * 1e-4 {
                damping = 0.0;
            }
        }
        report.smallest_step = report.smallest_step.min(alpha);
        report.iterations += 1;
    }
}
