//! High-accuracy adaptive integration of initial value problems `y' = f(t, y)`, used for
//! a-posteriori checks (re-integrating the pure Suslov equations with a computed control).
//!
//! The stepping is Verner's "most efficient" 9(8) pair with its 9th-order interpolant
//! (`RKV989e`, 16 + 10 stages) from the `differential-equations` crate (0.7); output at the
//! requested times uses that interpolant. DOP853 from the same crate was tried first and
//! rejected: at `rtol = atol = 1e-12` its dense output was off by `2.6e-8` on the harmonic
//! oscillator (test `harmonic_oscillator_to_1e_10`), whereas RKV989e meets `1e-10`
//! everywhere. This module adds: a plain slice-based closure API, validated options, output
//! exactly at the requested times (including the end point), and errors instead of panics
//! or silent garbage for step-size collapse, exhausted step budgets and non-finite values.
//!
//! # Notation
//! `n` is the state dimension; `y` is stored as one `Vec<f64>` of length `n` per output time.

use std::cell::Cell;

use differential_equations::control::ControlFlag;
use differential_equations::error::Error as DeError;
use differential_equations::interpolate::Interpolation;
use differential_equations::prelude::{ExplicitRungeKutta, IVP};
use differential_equations::solout::Solout;
use differential_equations::solution::Solution;
use serde::Serialize;

/// Tolerances and limits of [`integrate`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct IvpOptions {
    /// Relative tolerance per component (default: 1e-12).
    pub rtol: f64,
    /// Absolute tolerance per component (default: 1e-12).
    pub atol: f64,
    /// Maximum number of step attempts, accepted or rejected (default: 1_000_000).
    pub max_steps: usize,
    /// Maximum step size (default: infinity). Set it below the width of sharp features of
    /// `f` (e.g. a sigmoid of width `w`) so that the first steps cannot jump over them.
    pub h_max: f64,
}

impl Default for IvpOptions {
    fn default() -> Self {
        Self {
            rtol: 1e-12,
            atol: 1e-12,
            max_steps: 1_000_000,
            h_max: f64::INFINITY,
        }
    }
}

impl IvpOptions {
    /// Checks `rtol`, `atol` in `(0, 1)` (`rtol >= 1e-15`), `max_steps > 0`, `h_max > 0`.
    pub fn validate(&self) -> Result<(), IvpError> {
        let ok = self.rtol >= 1e-15
            && self.rtol < 1.0
            && self.atol > 0.0
            && self.atol < 1.0
            && self.max_steps > 0
            && self.h_max > 0.0;
        if ok {
            Ok(())
        } else {
            Err(IvpError::InvalidInput {
                what: format!(
                    "options need 1e-15 <= rtol < 1, 0 < atol < 1, max_steps > 0, h_max > 0; got {self:?}"
                ),
            })
        }
    }
}

/// Work counters of one integration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct IvpStats {
    /// Evaluations of `f`.
    pub rhs_evals: usize,
    /// Accepted steps.
    pub accepted_steps: usize,
    /// Rejected steps.
    pub rejected_steps: usize,
}

/// Values at the requested output times.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IvpSolution {
    /// The output times, as requested.
    pub t: Vec<f64>,
    /// `y[k]` is the state (length `n`) at `t[k]`.
    pub y: Vec<Vec<f64>>,
    /// Work counters.
    pub stats: IvpStats,
}

/// Failures of [`integrate`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum IvpError {
    /// Invalid arguments (message gives the expected range and the value).
    #[error("invalid IVP input: {what}")]
    InvalidInput {
        /// What is wrong.
        what: String,
    },
    /// The step size collapsed (singularity or blow-up ahead).
    #[error("step size underflow at t = {t}: the solution is probably singular near t")]
    StepSizeUnderflow {
        /// Last time reached.
        t: f64,
    },
    /// The step budget was exhausted.
    #[error("max_steps = {max_steps} exhausted at t = {t}")]
    MaxSteps {
        /// Last time reached.
        t: f64,
        /// The budget.
        max_steps: usize,
    },
    /// `f` returned, or the state became, non-finite.
    #[error("non-finite value (f or y) at t = {t}")]
    NonFinite {
        /// Time of the first non-finite evaluation.
        t: f64,
    },
    /// Repeated step rejections (stiffness or a discontinuity).
    #[error("too many consecutive step rejections at t = {t} (stiff or discontinuous f?)")]
    Stiffness {
        /// Last time reached.
        t: f64,
    },
}

/// Records the state at the requested times from the dense output of each accepted step.
struct OutputAt<'a> {
    times: &'a [f64],
    next: usize,
    /// Tolerance for "this requested time is the (rounded) end of the last step".
    end_slack: f64,
    values: Vec<Vec<f64>>,
    failure: Option<IvpError>,
}

/// The [`Solout`] handed to the solver; it borrows the state so it can be read afterwards.
struct Recorder<'s, 'a>(&'s mut OutputAt<'a>);

impl Solout<f64, Vec<f64>> for Recorder<'_, '_> {
    fn solout<I>(
        &mut self,
        t_curr: f64,
        t_prev: f64,
        y_curr: &Vec<f64>,
        _y_prev: &Vec<f64>,
        interpolator: &mut I,
        _solution: &mut Solution<f64, Vec<f64>>,
    ) -> ControlFlag<f64, Vec<f64>>
    where
        I: Interpolation<f64, Vec<f64>> + ?Sized,
    {
        if !y_curr.iter().all(|v| v.is_finite()) {
            self.0.failure = Some(IvpError::NonFinite { t: t_curr });
            return ControlFlag::Terminate;
        }
        if self.0.values.is_empty() && self.0.next == 0 && t_curr == t_prev {
            // Initial call (t_curr = t_prev = t0): output requested times equal to t0.
            while self.0.next < self.0.times.len() && self.0.times[self.0.next] == t_curr {
                self.0.values.push(y_curr.clone());
                self.0.next += 1;
            }
            return ControlFlag::Continue;
        }
        if t_curr <= t_prev {
            self.0.failure = Some(IvpError::StepSizeUnderflow { t: t_curr });
            return ControlFlag::Terminate;
        }
        while self.0.next < self.0.times.len() {
            let t = self.0.times[self.0.next];
            let y = if t >= t_curr - self.0.end_slack && t <= t_curr + self.0.end_slack {
                y_curr.clone()
            } else if t < t_curr {
                match interpolator.interpolate(t) {
                    Ok(y) => y,
                    Err(_) => {
                        self.0.failure = Some(IvpError::InvalidInput {
                            what: format!("dense output failed at t = {t}"),
                        });
                        return ControlFlag::Terminate;
                    }
                }
            } else {
                break;
            };
            self.0.values.push(y);
            self.0.next += 1;
        }
        ControlFlag::Continue
    }
}

/// Integrates `y' = f(t, y)`, `y(t0) = y0`, over `[t0, t1]` (`t1 > t0`) with RKV989e and
/// returns `y` at the requested times `t_out` (non-decreasing, inside `[t0, t1]`).
///
/// `f(t, y, dydt)` writes `dydt` (length `n = y0.len()`). Errors instead of panicking on bad
/// input, step-size collapse, an exhausted step budget or non-finite values.
pub fn integrate<F>(
    f: F,
    (t0, t1): (f64, f64),
    y0: &[f64],
    t_out: &[f64],
    options: &IvpOptions,
) -> Result<IvpSolution, IvpError>
where
    F: Fn(f64, &[f64], &mut [f64]),
{
    options.validate()?;
    let n = y0.len();
    if !(t0.is_finite() && t1.is_finite() && t1 > t0) {
        return Err(IvpError::InvalidInput {
            what: format!("need finite t0 < t1; got t0 = {t0}, t1 = {t1}"),
        });
    }
    if n == 0 || !y0.iter().all(|v| v.is_finite()) {
        return Err(IvpError::InvalidInput {
            what: format!("y0 must be non-empty and finite; got {y0:?}"),
        });
    }
    if t_out
        .windows(2)
        .any(|w| w[0].partial_cmp(&w[1]).is_none_or(|o| o.is_gt()))
        || t_out.iter().any(|t| !(t0..=t1).contains(t))
    {
        return Err(IvpError::InvalidInput {
            what: format!("output times must be non-decreasing and inside [{t0}, {t1}]"),
        });
    }
    let first_non_finite: Cell<Option<f64>> = Cell::new(None);
    let rhs = |t: f64, y: &Vec<f64>, dydt: &mut Vec<f64>| {
        f(t, y, dydt);
        if first_non_finite.get().is_none() && !dydt.iter().all(|v| v.is_finite()) {
            first_non_finite.set(Some(t));
        }
    };
    let mut output = OutputAt {
        times: t_out,
        next: 0,
        end_slack: 16.0 * f64::EPSILON * t0.abs().max(t1.abs()).max(1.0),
        values: Vec::with_capacity(t_out.len()),
        failure: None,
    };
    let method = ExplicitRungeKutta::rkv989e()
        .rtol(options.rtol)
        .atol(options.atol)
        .max_steps(options.max_steps)
        .h_max(options.h_max);
    let result = IVP::ode_from_fn(rhs, t0, t1, y0.to_vec())
        .method(method)
        .solout(Recorder(&mut output))
        .solve();
    if let Some(t) = first_non_finite.get() {
        return Err(IvpError::NonFinite { t });
    }
    if let Some(failure) = output.failure {
        return Err(failure);
    }
    let solution = result.map_err(|e| match e {
        DeError::StepSize { t, .. } => IvpError::StepSizeUnderflow { t },
        DeError::MaxSteps { t, .. } => IvpError::MaxSteps {
            t,
            max_steps: options.max_steps,
        },
        DeError::Stiffness { t, .. } => IvpError::Stiffness { t },
        other => IvpError::InvalidInput {
            what: format!("{other:?}"),
        },
    })?;
    if output.values.len() != t_out.len() {
        return Err(IvpError::InvalidInput {
            what: format!(
                "internal: {} of {} output times produced (integration ended early?)",
                output.values.len(),
                t_out.len()
            ),
        });
    }
    Ok(IvpSolution {
        t: t_out.to_vec(),
        y: output.values,
        stats: IvpStats {
            rhs_evals: solution.evals.function,
            accepted_steps: solution.steps.accepted,
            rejected_steps: solution.steps.rejected,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(t0: f64, t1: f64, m: usize) -> Vec<f64> {
        (0..=m)
            .map(|k| {
                if k == m {
                    t1
                } else {
                    t0 + (t1 - t0) * k as f64 / m as f64
                }
            })
            .collect()
    }

    #[test]
    fn harmonic_oscillator_to_1e_10() {
        let t_out = grid(0.0, 20.0, 137);
        let sol = integrate(
            |_t, y, dy| {
                dy[0] = y[1];
                dy[1] = -y[0];
            },
            (0.0, 20.0),
            &[1.0, 0.0],
            &t_out,
            &IvpOptions::default(),
        )
        .unwrap();
        assert_eq!(sol.t.len(), t_out.len());
        for (t, y) in sol.t.iter().zip(&sol.y) {
            assert!((y[0] - t.cos()).abs() < 1e-10, "t = {t}: {y:?}");
            assert!((y[1] + t.sin()).abs() < 1e-10, "t = {t}: {y:?}");
        }
        assert_eq!(sol.y[0], vec![1.0, 0.0]);
        assert!(sol.stats.accepted_steps > 10 && sol.stats.rhs_evals > sol.stats.accepted_steps);
    }

    #[test]
    fn nonlinear_problem_with_exact_solution() {
        // y' = -2 t y^2, y(0) = 1: y = 1/(1 + t^2). Also a logistic component.
        // z' = z (1 - z), z(0) = 0.1: z = 1/(1 + 9 e^{-t}).
        let t_out = grid(0.0, 7.5, 50);
        let sol = integrate(
            |t, y, dy| {
                dy[0] = -2.0 * t * y[0] * y[0];
                dy[1] = y[1] * (1.0 - y[1]);
            },
            (0.0, 7.5),
            &[1.0, 0.1],
            &t_out,
            &IvpOptions::default(),
        )
        .unwrap();
        for (t, y) in sol.t.iter().zip(&sol.y) {
            assert!((y[0] - 1.0 / (1.0 + t * t)).abs() < 1e-10, "t = {t}");
            assert!(
                (y[1] - 1.0 / (1.0 + 9.0 * (-t).exp())).abs() < 1e-10,
                "t = {t}"
            );
        }
    }

    #[test]
    fn output_exactly_at_end_of_odd_intervals() {
        // End points that are not representable sums: every requested time is returned.
        for (t0, t1) in [(0.1, 0.7), (1.3, 2.9), (0.0, 1e-3), (3.0, 10.0 / 3.0)] {
            let t_out = [t0, (t0 + t1) / 2.0, t1];
            let sol = integrate(
                |_t, y, dy| dy[0] = -y[0],
                (t0, t1),
                &[1.0],
                &t_out,
                &IvpOptions::default(),
            )
            .unwrap();
            for (t, y) in sol.t.iter().zip(&sol.y) {
                assert!((y[0] - (-(t - t0)).exp()).abs() < 1e-12, "t = {t}");
            }
        }
    }

    #[test]
    fn blow_up_is_an_error() {
        // y' = y^2, y(0) = 1: y = 1/(1 - t) blows up at t = 1.
        let err = integrate(
            |_t, y, dy| dy[0] = y[0] * y[0],
            (0.0, 2.0),
            &[1.0],
            &[0.5, 2.0],
            &IvpOptions::default(),
        )
        .unwrap_err();
        let t = match err {
            IvpError::StepSizeUnderflow { t }
            | IvpError::MaxSteps { t, .. }
            | IvpError::NonFinite { t }
            | IvpError::Stiffness { t } => t,
            IvpError::InvalidInput { .. } => panic!("wrong error: {err}"),
        };
        assert!((t - 1.0).abs() < 1e-3, "{err}");
    }

    #[test]
    fn nan_rhs_and_bad_input_are_errors() {
        let err = integrate(
            |t, _y, dy| dy[0] = if t > 0.5 { f64::NAN } else { 1.0 },
            (0.0, 1.0),
            &[0.0],
            &[1.0],
            &IvpOptions::default(),
        )
        .unwrap_err();
        assert!(matches!(err, IvpError::NonFinite { t } if t > 0.5), "{err}");
        let f = |_t: f64, _y: &[f64], dy: &mut [f64]| dy[0] = 0.0;
        let o = IvpOptions::default();
        assert!(integrate(f, (1.0, 0.0), &[0.0], &[], &o).is_err());
        assert!(integrate(f, (0.0, 1.0), &[], &[], &o).is_err());
        assert!(integrate(f, (0.0, 1.0), &[0.0], &[0.5, 0.2], &o).is_err());
        assert!(integrate(f, (0.0, 1.0), &[0.0], &[1.5], &o).is_err());
        let bad = IvpOptions { rtol: 0.0, ..o };
        assert!(matches!(
            integrate(f, (0.0, 1.0), &[0.0], &[1.0], &bad),
            Err(IvpError::InvalidInput { .. })
        ));
    }
}
