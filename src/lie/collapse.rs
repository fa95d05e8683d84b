//! Controls whose `ξ` nearly vanishes: an upper bound on the infimum of the cost, and why the
//! smooth optimality system cannot reach it.
//!
//! # The argument
//!
//! When the constraint value vanishes (`⟨Ω, ξ⟩ = 0`, every model with
//! [`Problem::conserves_energy`]), Suslov's equations
//! `𝕀Ω̇ = ad*_Ω 𝕀Ω + λξ` with λ chosen to keep `⟨Ω, ξ⟩ = 0` depend on `ξ` only through
//! its direction: `ξ → σ(t) ξ` with any positive scalar `σ` leaves `λξ`, hence the motion,
//! unchanged (λ scales by `1/σ`, and `⟨Ω, ξ̇⟩` only sees `σ⟨Ω, ξ̇⟩` on the constraint).
//! Conversely every smooth path `Ω_p(t)` on the energy level set is a motion: with
//! `ξ̃ = 𝕀Ω̇_p − ad*_{Ω_p} 𝕀Ω_p` (the paper's singular control, section 5.1),
//! `⟨Ω_p, ξ̃⟩ = dT/dt = 0`, so `ξ = σ ξ̃/|ξ̃|` keeps the constraint and drives exactly
//! `Ω_p` wherever `ξ̃ ≠ 0`.
//!
//! The cost `C(Ω, Ω̇, ξ, ξ̇)` is continuous at `ξ = ξ̇ = 0` (for the paper's weights,
//! `α/4 (|ξ|² − 1)² + β/2 |ξ̇|² → α/4`). So **any** motion from `Ω_a` to `Ω_b` on the level set
//! — the projected segment, the projected desired path, the motion of a computed solution or
//! of the direct start's minimum —
//! is reached by the admissible controls `ξ_ε = ε ξ̂` (ξ̂ its unit control direction), whose
//! cost tends, as `ε → 0`, to the cost of the motion alone with the control terms at `ξ = 0`:
//! for the paper's cost `(α/4 + δ) T + γ/2 ∫|Ω − Ω_d|² + η/2 ∫|Ω̇|²`. The infimum of the cost
//! over admissible controls is at most that, whatever `β`.
//!
//! Consequences, measured on the paper's own problem (the η = 0.01 case, free `b`): along the
//! projected segment `Ω_a → Ω_b` in `b − a = 0.157` such a control costs `J ≈ 0.86` (checked
//! independently: `scipy`'s `solve_ivp` of Suslov's equations with `ξ_ε`, `ε = 10⁻³`, reaches
//! `Ω_b` to `1.4e-8`), against `J = 2.666` at the paper's `b = 9.84`. The extremals the
//! homotopy computes are local minima among controls with `|ξ|` away from 0 (the second-order
//! certificate certifies exactly that); the problem's infimum can lie lower, approached with
//! `|ξ| → 0`, where the optimality system (which divides by `⟨ξ, 𝕀⁻¹ξ⟩`) is singular. When
//! the time weight is the only term of `C` that does not vanish with the motion's speed
//! (`η = 0`), `J → 0` as `b → a`: a free-time problem then has no optimal `b` at all.
//! This is why the homotopy's branches collapse (`|ξ| → 0`, [`super::solve`](mod@super::solve)): the cost
//! decreases toward this regime.
//!
//! # What is computed
//!
//! [`along_path`], [`along_segment`], [`along_desired`], [`along_solution`] and
//! [`along_samples`] (a motion through samples, e.g. the direct start's minimum) evaluate one
//! control `ξ_ε` ([`COLLAPSE_EPS`]) at given weights: its cost by composite 5-point
//! Gauss–Legendre quadrature (globally adaptive from [`PANELS`] equal panels: each panel's
//! rule compared with that on its halves, the worst panel split until the differences sum to
//! [`QUADRATURE_RTOL`]; that sum is the reported quadrature error), and its motion
//! re-integrated from the motion's own states (the generated `suslov_omega_dot` driven by
//! `ξ_ε`, in windows of about one radian of rotation as the solution checks do): a control whose re-integration departs from its
//! motion by more than [`REINTEGRATION_TOL`] (relative) is refused, not reported.
//! [`best_span`] scans the terminal time for the projected segment (free-time problems).

use serde::Serialize;

use crate::echo::Cost;
use crate::ivp::{integrate, IvpOptions};
use crate::model::Model;

use super::checks::{GAUSS5, REINTEGRATION_WINDOW_ANGLE};
use std::sync::Arc;

use super::path::{projected_segment, Path, PathError, Projected, Sampled};
use super::problem::{with_buffer, Problem};
use super::solve::LieSolution;

/// `|ξ|` of the controls evaluated: their cost is within `O(ε²)` of the limit `ε → 0` (the
/// `ε²` terms grow like `1/(b − a)` on short horizons, so ε is small; the motion, and so the
/// re-integration, does not depend on it: λ scales like `1/ε`, λξ not at all).
pub const COLLAPSE_EPS: f64 = 1e-6;

/// Equal panels the adaptive composite Gauss–Legendre rule starts from; the panel with the
/// largest error estimate is then split until the estimates sum to [`QUADRATURE_RTOL`].
pub const PANELS: usize = 64;

/// Cap on the panels of the quadrature.
pub const MAX_PANELS: usize = 8192;

/// Relative error (of `1 + |J|`) of the quadrature at which the splitting ends: the sum of
/// the panels' estimates (each the difference of the rule on the panel and on its halves).
pub const QUADRATURE_RTOL: f64 = 1e-10;

/// Largest relative departure `max |Ω_ivp − Ω_motion| / max |Ω|` of a control's re-integrated
/// motion from the motion it was built for.
pub const REINTEGRATION_TOL: f64 = 1e-6;

/// The spans of [`best_span`], as powers of two times the problem's `b_p − a`.
pub const SPAN_EXPONENTS: std::ops::RangeInclusive<i32> = -16..=3;

/// Which motion a collapsed control follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Motion {
    /// The radial projection onto the level set of the segment `Ω_a → Ω_b`.
    ProjectedSegment,
    /// The desired path projected onto the level set (when it joins `Ω_a` to `Ω_b`).
    DesiredPath,
    /// The motion of a computed solution (its `ξ` scaled to `ε ξ/|ξ|`).
    Solution,
    /// The motion of the direct start's minimum of the transcribed problem
    /// ([`super::direct`]): the spline through its `Ω` at the collocation points, projected
    /// onto the level set.
    DirectMinimum,
    /// The motion of the relaxed problem's minimum ([`super::relaxed`]: the limit `ξ → 0`,
    /// a torque `τ ⟂ Ω` as the control), through its `Ω` at the collocation points.
    RelaxedMinimum,
}

impl Motion {
    /// Words for messages.
    pub fn describe(self) -> &'static str {
        match self {
            Motion::ProjectedSegment => "the projected segment from Omega_a to Omega_b",
            Motion::DesiredPath => "the projected desired path",
            Motion::Solution => "the computed solution's motion",
            Motion::DirectMinimum => "the motion of the direct method's minimum",
            Motion::RelaxedMinimum => "the motion of the relaxed problem's minimum (xi -> 0)",
        }
    }
}

/// One admissible control `ξ = ε ξ̂` along a motion, at given weights.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CollapsedControl {
    /// The motion it drives.
    pub motion: Motion,
    /// `b − a`.
    pub span: f64,
    /// `|ξ|`.
    pub eps: f64,
    /// Its cost `∫ C dt` (the time weight's `δ (b − a)` included).
    pub cost: f64,
    /// The quadrature's error estimate: over its panels, the sum of `|rule on the halves −
    /// rule on the panel|` ([`PANELS`], [`QUADRATURE_RTOL`]).
    pub quadrature_error: f64,
    /// `max |Ω_ivp − Ω_motion| / max |Ω|` of the windowed re-integration.
    pub reintegration_error: f64,
}

/// Why no collapsed control was evaluated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CollapseError {
    /// The model's constraint has a nonzero value: scaling `ξ` changes the motion.
    #[error("the constraint value is not zero: scaling xi changes the motion")]
    ConstraintValue,
    /// The motion's control direction is undefined (`ξ̃ = 0`, or `ξ = 0` on a solution).
    #[error("the motion's control direction is undefined at t = {t} (xi~ or xi vanishes)")]
    SingularDirection {
        /// Where.
        t: f64,
    },
    /// The motion is not available (a path that cannot be built, e.g. opposite end points).
    #[error("no such motion: {0}")]
    Path(#[from] PathError),
    /// The desired path does not join `Ω_a` to `Ω_b` over the span.
    #[error("the desired path does not join Omega_a to Omega_b over [a, a + {span}]")]
    DesiredMissesEnds {
        /// `b − a`.
        span: f64,
    },
    /// The re-integrated motion departs from the motion.
    #[error("{}", reintegration_message(*error))]
    Reintegration {
        /// The departure (NaN when the integration failed).
        error: f64,
    },
}

/// [`CollapseError::Reintegration`]'s message: the departure, or that the integration failed.
fn reintegration_message(error: f64) -> String {
    if error.is_finite() {
        format!(
            "the re-integration departs from the motion by {error:e} (relative; allowed \
             {REINTEGRATION_TOL:e})"
        )
    } else {
        "the re-integration of the motion failed (its ODE solver stopped or its state \
         overflowed), so the motion could not be checked"
            .to_string()
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// `z = [Ω, ξ, ξ̇]` of the control of size `ε` (second argument) at time `t` (first), or the
/// time where its direction is undefined.
type Control<'a> = dyn Fn(f64, f64, &mut [f64]) -> Result<(), CollapseError> + 'a;

/// `∫ C dt` of `control` over `[t0, t0 + span]` by globally adaptive composite 5-point
/// Gauss–Legendre quadrature, and its error estimate.
///
/// Each panel carries the rule on itself and on its two halves; their difference is the
/// panel's error estimate (an over-estimate of the halves' error, by about `2^10` where the
/// integrand is smooth). Starting from [`PANELS`] equal panels, the panel with the largest
/// estimate is split (its halves become panels, 20 evaluations) until the estimates sum to at
/// most [`QUADRATURE_RTOL`] `· (1 + |J|)` or [`MAX_PANELS`] panels are in use. Unlike uniform
/// doubling, this spends its evaluations where the integrand needs them: the paper's desired
/// path turns within a width of 0.01 at `b_d`, and the long spans of the free-time scan cross
/// it while most of each span is smooth (the measured cost: `bench/README.md`).
fn cost_on<M: Model>(
    params: &[f64],
    desired: &dyn Path,
    (t0, span): (f64, f64),
    eps: f64,
    control: &Control<'_>,
) -> Result<(f64, f64), CollapseError> {
    /// One panel `[left, left + width]`: the rule on each half.
    #[derive(Clone, Copy)]
    struct Panel {
        left: f64,
        width: f64,
        halves: [f64; 2],
        error: f64,
    }
    /// A max-heap key: the panel's error estimate, ties broken by its index (deterministic).
    #[derive(PartialEq)]
    struct Key(f64, usize);
    impl Eq for Key {}
    impl PartialOrd for Key {
        fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
            Some(self.cmp(other))
        }
    }
    impl Ord for Key {
        fn cmp(&self, other: &Self) -> std::cmp::Ordering {
            self.0.total_cmp(&other.0).then(other.1.cmp(&self.1))
        }
    }
    let n = M::DIM;
    let mut z = vec![0.0; M::KAPPA.start];
    let mut od = vec![0.0; n];
    let (mut l_z, mut l_d) = (vec![0.0; M::KAPPA.start], vec![0.0; n]);
    let mut rule = |left: f64, width: f64| -> Result<f64, CollapseError> {
        let mut sum = 0.0;
        for (node, weight) in GAUSS5 {
            let t = left + node * width;
            control(t, eps, &mut z)?;
            desired.value_into(t, &mut od);
            let c = M::direct_cost(&z, params, &od, &mut l_z, &mut l_d);
            if !c.is_finite() {
                return Err(CollapseError::SingularDirection { t });
            }
            sum += weight * width * c;
        }
        Ok(sum)
    };
    fn panel(
        rule: &mut impl FnMut(f64, f64) -> Result<f64, CollapseError>,
        left: f64,
        width: f64,
        whole: f64,
    ) -> Result<Panel, CollapseError> {
        let halves = [
            rule(left, width / 2.0)?,
            rule(left + width / 2.0, width / 2.0)?,
        ];
        Ok(Panel {
            left,
            width,
            halves,
            error: (halves[0] + halves[1] - whole).abs(),
        })
    }
    let h = span / PANELS as f64;
    let mut panels = Vec::with_capacity(4 * PANELS);
    for k in 0..PANELS {
        // The last panel ends exactly at t0 + span.
        let left = t0 + k as f64 * h;
        let width = if k + 1 == PANELS { t0 + span - left } else { h };
        let whole = rule(left, width)?;
        panels.push(panel(&mut rule, left, width, whole)?);
    }
    let mut heap: std::collections::BinaryHeap<Key> = panels
        .iter()
        .enumerate()
        .map(|(i, p)| Key(p.error, i))
        .collect();
    let exact_sums = |panels: &[Panel]| -> (f64, f64) {
        panels.iter().fold((0.0, 0.0), |(v, e), p| {
            (v + p.halves[0] + p.halves[1], e + p.error)
        })
    };
    let (mut value, mut error) = exact_sums(&panels);
    while panels.len() < MAX_PANELS {
        if error <= QUADRATURE_RTOL * (1.0 + value.abs()) {
            // The running sums drift by rounding: confirm on the exact ones.
            (value, error) = exact_sums(&panels);
            if error <= QUADRATURE_RTOL * (1.0 + value.abs()) {
                break;
            }
        }
        let Some(Key(_, i)) = heap.pop() else { break };
        let p = panels[i];
        let half = p.width / 2.0;
        let first = panel(&mut rule, p.left, half, p.halves[0])?;
        let second = panel(&mut rule, p.left + half, half, p.halves[1])?;
        value += first.halves[0] + first.halves[1] + second.halves[0] + second.halves[1]
            - p.halves[0]
            - p.halves[1];
        error += first.error + second.error - p.error;
        panels[i] = first;
        heap.push(Key(first.error, i));
        heap.push(Key(second.error, panels.len()));
        panels.push(second);
    }
    // Summed in time order, so the value does not depend on the order of the splits.
    panels.sort_by(|a, b| a.left.total_cmp(&b.left));
    Ok(exact_sums(&panels))
}

/// The windowed re-integration of `control`'s motion: the IVP of the generated
/// `suslov_omega_dot` driven by its `ξ, ξ̇`, restarted from the motion at each window's start
/// (about [`REINTEGRATION_WINDOW_ANGLE`] of rotation per window), compared at 8 points of
/// each window. Returns `max |Ω_ivp − Ω_motion| / max |Ω|`.
fn reintegrate<M: Model>(
    params: &[f64],
    (t0, span): (f64, f64),
    eps: f64,
    control: &Control<'_>,
) -> Result<f64, CollapseError> {
    let mut z = vec![0.0; M::KAPPA.start];
    // The rotation: ∫|Ω| dt on a coarse grid, for the window count.
    let mut omega_max: f64 = 0.0;
    let mut angle = 0.0;
    let coarse = 256;
    for k in 0..=coarse {
        control(t0 + span * k as f64 / coarse as f64, eps, &mut z)?;
        let size = norm(&z[M::OMEGA]);
        omega_max = omega_max.max(size);
        angle += size * span / coarse as f64;
    }
    let windows = ((angle / REINTEGRATION_WINDOW_ANGLE).ceil() as usize).clamp(1, 4096);
    let options = IvpOptions {
        rtol: 1e-11,
        atol: 1e-12 * omega_max.max(1.0),
        ..IvpOptions::default()
    };
    let rhs = |t: f64, om: &[f64], out: &mut [f64]| {
        with_buffer(M::KAPPA.start, |x| {
            if control(t, eps, x).is_err() {
                out.iter_mut().for_each(|v| *v = f64::NAN);
                return;
            }
            x[M::OMEGA].copy_from_slice(om);
            M::suslov_omega_dot(x, params, out);
        });
    };
    let width = span / windows as f64;
    let mut worst: f64 = 0.0;
    for w in 0..windows {
        let (a, b) = (t0 + w as f64 * width, t0 + (w + 1) as f64 * width);
        let times: Vec<f64> = (1..=8).map(|k| a + (b - a) * k as f64 / 8.0).collect();
        control(a, eps, &mut z)?;
        let start = z[M::OMEGA].to_vec();
        let sol = integrate(rhs, (a, b), &start, &times, &options)
            .map_err(|_| CollapseError::Reintegration { error: f64::NAN })?;
        for (t, om) in times.iter().zip(&sol.y) {
            control(*t, eps, &mut z)?;
            let d: Vec<f64> = om.iter().zip(&z[M::OMEGA]).map(|(p, q)| p - q).collect();
            worst = worst.max(norm(&d) / omega_max);
        }
    }
    Ok(worst)
}

/// Whether a control's motion is re-integrated ([`reintegrate`]) or only its cost computed
/// (the scan of [`best_span`], whose cheapest control is then re-integrated).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Check {
    Reintegrate,
    CostOnly,
}

/// Cost, quadrature error and re-integration of one control.
fn evaluate<M: Model>(
    params: &[f64],
    desired: &dyn Path,
    (t0, span): (f64, f64),
    motion: Motion,
    check: Check,
    control: &Control<'_>,
) -> Result<CollapsedControl, CollapseError> {
    let eps = COLLAPSE_EPS;
    let (cost, quadrature_error) = cost_on::<M>(params, desired, (t0, span), eps, control)?;
    let error = match check {
        Check::Reintegrate => {
            let error = reintegrate::<M>(params, (t0, span), eps, control)?;
            if error.is_nan() || error > REINTEGRATION_TOL {
                return Err(CollapseError::Reintegration { error });
            }
            error
        }
        Check::CostOnly => f64::NAN,
    };
    Ok(CollapsedControl {
        motion,
        span,
        eps,
        cost,
        quadrature_error,
        reintegration_error: error,
    })
}

/// The control `ξ = ε ξ̃/|ξ̃|` that drives `path` (on the level set) over `[a, a + span]`, at
/// the constants `params` (the problem's `Ω_d`).
pub fn along_path<M: Model>(
    problem: &Problem<M>,
    params: &[f64],
    path: &dyn Path,
    span: f64,
    motion: Motion,
) -> Result<CollapsedControl, CollapseError> {
    path_control(problem, params, path, span, motion, Check::Reintegrate)
}

fn path_control<M: Model>(
    problem: &Problem<M>,
    params: &[f64],
    path: &dyn Path,
    span: f64,
    motion: Motion,
    check: Check,
) -> Result<CollapsedControl, CollapseError> {
    if !crate::model::constraint_value_vanishes::<M>(params) {
        return Err(CollapseError::ConstraintValue);
    }
    let control = |t: f64, eps: f64, z: &mut [f64]| control_at::<M>(path, params, t, eps, z);
    evaluate::<M>(
        params,
        &*problem.desired,
        (problem.t0, span),
        motion,
        check,
        &control,
    )
}

/// `[Ω, ξ, ξ̇]` of the control `ξ = ε ξ̃/|ξ̃|` along `path` at `t`, into the first
/// `M::XIDOT.end` entries of `z` (the state layout).
fn control_at<M: Model>(
    path: &dyn Path,
    params: &[f64],
    t: f64,
    eps: f64,
    z: &mut [f64],
) -> Result<(), CollapseError> {
    let n = M::DIM;
    with_buffer(6 * n, |buf| {
        let (jet, xi) = buf.split_at_mut(4 * n);
        path.jet_into(t, jet);
        // The path's jet [Ω, Ω̇, Ω̈, Ω⃛]; the singular control takes its first three blocks
        // and gives [ξ_p, ξ̇_p], the z-blocks XI and XIDOT.
        M::singular_control(&jet[..3 * n], params, xi);
        if !xi.iter().all(|v| v.is_finite()) {
            return Err(CollapseError::SingularDirection { t });
        }
        z[M::OMEGA].copy_from_slice(&jet[..n]);
        for (zk, v) in z[M::XI.start..M::XIDOT.end].iter_mut().zip(xi.iter()) {
            *zk = eps * v;
        }
        Ok(())
    })
}

/// The motion through `Ω(times[k]) = omegas[k]`: the natural cubic spline through the
/// samples, projected onto the level set.
fn samples_path<M: Model>(
    problem: &Problem<M>,
    times: &[f64],
    omegas: &[Vec<f64>],
) -> Result<Projected, CollapseError> {
    let spline = Sampled::new(times, omegas)?;
    Ok(Projected::new(Arc::new(spline), problem.level_set())?)
}

/// The control of [`along_samples`] (the motion through `Ω(times[k]) = omegas[k]`, projected
/// onto the level set, driven by `ξ = ε ξ̃/|ξ̃|`, [`COLLAPSE_EPS`]) at the times `at`: one row
/// `[Ω, ξ, ξ̇]` (the state layout's first `M::XIDOT.end` entries) per time.
pub fn samples_control<M: Model>(
    problem: &Problem<M>,
    times: &[f64],
    omegas: &[Vec<f64>],
    at: &[f64],
) -> Result<Vec<Vec<f64>>, CollapseError> {
    let path = samples_path(problem, times, omegas)?;
    at.iter()
        .map(|&t| {
            let mut z = vec![0.0; M::XIDOT.end];
            control_at::<M>(&path, problem.params(), t, COLLAPSE_EPS, &mut z)?;
            Ok(z)
        })
        .collect()
}

/// [`along_path`] on the motion through `Ω(times[k]) = omegas[k]` (rows of `n`), e.g. the
/// direct start's minimum: the natural cubic spline through the samples, projected onto the
/// level set. `times` run from `a` to `a + span`.
pub fn along_samples<M: Model>(
    problem: &Problem<M>,
    params: &[f64],
    times: &[f64],
    omegas: &[Vec<f64>],
    motion: Motion,
) -> Result<CollapsedControl, CollapseError> {
    let path = samples_path(problem, times, omegas)?;
    let span = times.last().copied().unwrap_or(problem.t0) - problem.t0;
    along_path(problem, params, &path, span, motion)
}

/// What the relaxed problem ([`super::relaxed`]) gave.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "status", rename_all = "snake_case")]
pub enum RelaxedOutcome {
    /// Its minimum on two meshes, and the admissible control along the finer one's motion
    /// (in [`CollapseEvidence::controls`], motion [`Motion::RelaxedMinimum`]).
    Computed {
        /// The intervals of the two meshes.
        intervals: [usize; 2],
        /// The discrete minima on them.
        costs: [f64; 2],
        /// Their spans `b − a` (the problem's, or the minima's for a free terminal time).
        spans: [f64; 2],
        /// The SQP's iterations on each.
        iterations: [usize; 2],
        /// The finer minimum's collocation times (the motion of its control; not written to
        /// the summary).
        #[serde(skip)]
        times: Vec<f64>,
        /// Its `Ω` at those times, one row each.
        #[serde(skip)]
        omegas: Vec<Vec<f64>>,
    },
    /// A free terminal time without a cost term in `Ω̇`: the relaxed cost falls with the
    /// span, there is no relaxed minimum over `b` ([`super::relaxed::RelaxedError::FreeTimeWithoutRate`]).
    FallsWithSpan,
    /// No minimum was computed (e.g. a cost without an `Ω̇` term: the relaxed problem is
    /// degenerate), or its control could not be evaluated.
    Failed {
        /// Why.
        reason: String,
    },
}

/// The relaxed minimum of `problem` ([`super::relaxed::relaxed_minimum`]) and the
/// admissible control `ξ = ε τ̂` along its finer motion ([`along_samples`], re-integrated).
pub fn along_relaxed<M: Model>(problem: &Problem<M>) -> (RelaxedOutcome, Option<CollapsedControl>) {
    along_relaxed_from(problem, &[problem.terminal.initial() - problem.t0])
}

/// [`along_relaxed`] with a free terminal time's relaxed minimum started from each span of
/// `spans` (the relaxed cost need not be convex in the span); the cheapest control is kept,
/// with its minimum's outcome. For a fixed terminal time one minimum is computed, at `b`.
pub fn along_relaxed_from<M: Model>(
    problem: &Problem<M>,
    spans: &[f64],
) -> (RelaxedOutcome, Option<CollapsedControl>) {
    let free = matches!(problem.terminal, super::problem::TerminalTime::Free { .. });
    let fixed_span = [problem.terminal.initial() - problem.t0];
    let spans = if free && !spans.is_empty() {
        spans
    } else {
        &fixed_span
    };
    let cost =
        |f: &(RelaxedOutcome, Option<CollapsedControl>)| f.1.map_or(f64::INFINITY, |c| c.cost);
    let mut best = relaxed_once(problem, spans[0]);
    for &span in &spans[1..] {
        let found = relaxed_once(problem, span);
        if cost(&found) < cost(&best) {
            best = found;
        }
    }
    best
}

fn relaxed_once<M: Model>(
    problem: &Problem<M>,
    span: f64,
) -> (RelaxedOutcome, Option<CollapsedControl>) {
    let relaxed = match super::relaxed::relaxed_minimum_from(problem, span) {
        Ok(r) => r,
        Err(super::relaxed::RelaxedError::FreeTimeWithoutRate) => {
            return (RelaxedOutcome::FallsWithSpan, None);
        }
        Err(e) => {
            let reason = e.to_string();
            return (RelaxedOutcome::Failed { reason }, None);
        }
    };
    let (coarse, fine) = (&relaxed.coarse, &relaxed.fine);
    // The motion joins the exact end points: the SQP meets them only to its tolerance, and
    // without a term in Ω̇ its end layers are steep (corpus problem spiral-129: the spline's
    // Ω(b) missed Ω_b by 7.4e-6 relative before the ends were pinned).
    let mut omegas = fine.omegas.clone();
    if let Some(first) = omegas.first_mut() {
        first.copy_from_slice(&problem.omega_a);
    }
    if let Some(last) = omegas.last_mut() {
        last.copy_from_slice(&problem.omega_b);
    }
    match along_samples(
        problem,
        problem.params(),
        &fine.times,
        &omegas,
        Motion::RelaxedMinimum,
    ) {
        Ok(control) => (
            RelaxedOutcome::Computed {
                intervals: [coarse.intervals, fine.intervals],
                costs: [coarse.cost, fine.cost],
                spans: [coarse.span, fine.span],
                iterations: [coarse.report.iterations, fine.report.iterations],
                times: fine.times.clone(),
                omegas,
            },
            Some(control),
        ),
        Err(e) => {
            let reason = format!("the control along the relaxed minimum: {e}");
            (RelaxedOutcome::Failed { reason }, None)
        }
    }
}

/// [`along_path`] on the projected segment `Ω_a → Ω_b` over `[a, a + span]`.
pub fn along_segment<M: Model>(
    problem: &Problem<M>,
    params: &[f64],
    span: f64,
) -> Result<CollapsedControl, CollapseError> {
    segment_control(problem, params, span, Check::Reintegrate)
}

fn segment_control<M: Model>(
    problem: &Problem<M>,
    params: &[f64],
    span: f64,
    check: Check,
) -> Result<CollapsedControl, CollapseError> {
    let set = problem.level_set();
    let path = projected_segment(
        &set,
        &problem.omega_a,
        &problem.omega_b,
        problem.t0,
        problem.t0 + span,
        super::problem::ENERGY_REL_TOL,
    )?;
    path_control(
        problem,
        params,
        &path,
        span,
        Motion::ProjectedSegment,
        check,
    )
}

/// [`along_path`] on the desired path projected onto the level set, when it starts at `Ω_a`
/// and ends at `Ω_b` at `a + span` (relative 1e-6).
pub fn along_desired<M: Model>(
    problem: &Problem<M>,
    params: &[f64],
    span: f64,
) -> Result<CollapsedControl, CollapseError> {
    let set = problem.level_set();
    let path = Projected::new(problem.desired.clone(), set)?;
    let n = M::DIM;
    let mut v = vec![0.0; n];
    let scale = norm(&problem.omega_a);
    for (t, target) in [
        (problem.t0, &problem.omega_a),
        (problem.t0 + span, &problem.omega_b),
    ] {
        path.value_into(t, &mut v);
        let d: Vec<f64> = v.iter().zip(target).map(|(p, q)| p - q).collect();
        let miss = norm(&d);
        if miss.is_nan() || miss > 1e-6 * scale {
            return Err(CollapseError::DesiredMissesEnds { span });
        }
    }
    along_path(problem, params, &path, span, Motion::DesiredPath)
}

/// The motion of `sol` driven by `ξ = ε ξ/|ξ|` (the same motion), at the constants `params`
/// (e.g. the target weights of a problem whose homotopy stopped at `sol`).
pub fn along_solution<M: Model>(
    sol: &LieSolution<M>,
    params: &[f64],
) -> Result<CollapsedControl, CollapseError> {
    if !crate::model::constraint_value_vanishes::<M>(params) {
        return Err(CollapseError::ConstraintValue);
    }
    let n = M::DIM;
    let control = |t: f64, eps: f64, z: &mut [f64]| -> Result<(), CollapseError> {
        with_buffer(M::N_STATE, |y| {
            sol.state_into(t, y);
            let (xi, xid) = (&y[M::XI], &y[M::XIDOT]);
            let size = norm(xi);
            if !(size > 0.0 && size.is_finite()) {
                return Err(CollapseError::SingularDirection { t });
            }
            // ê = ξ/|ξ|, ê' = (ξ' − ê⟨ê, ξ'⟩)/|ξ|.
            let along: f64 = xi.iter().zip(xid).map(|(a, b)| a * b).sum::<f64>() / size;
            z[M::OMEGA].copy_from_slice(&y[M::OMEGA]);
            for k in 0..n {
                let e = xi[k] / size;
                z[M::XI.start + k] = eps * e;
                z[M::XIDOT.start + k] = eps * (xid[k] - e * along) / size;
            }
            Ok(())
        })
    };
    evaluate::<M>(
        params,
        &*sol.problem.desired,
        (sol.problem.t0, sol.t_span),
        Motion::Solution,
        Check::Reintegrate,
        &control,
    )
}

/// [`along_segment`] at the spans `2^k (b_p − a)`, `k` in [`SPAN_EXPONENTS`], at the problem's
/// constants; the spans where no control could be evaluated are left out. Only the cheapest
/// control's motion is re-integrated (the others have `reintegration_error` NaN: the same
/// construction on the same path, at other speeds); if that fails, the next cheapest is tried.
pub fn best_span<M: Model>(problem: &Problem<M>, span_p: f64) -> Vec<CollapsedControl> {
    let params = problem.params();
    let scan: Vec<CollapsedControl> = SPAN_EXPONENTS
        .filter_map(|k| {
            segment_control(problem, params, span_p * 2f64.powi(k), Check::CostOnly).ok()
        })
        .collect();
    reintegrate_cheapest(scan, problem, params)
}

/// Re-integrate the cheapest control of `scan`; one whose re-integration fails is dropped and
/// the next cheapest tried, so the cheapest control left is always re-integrated.
fn reintegrate_cheapest<M: Model>(
    mut scan: Vec<CollapsedControl>,
    problem: &Problem<M>,
    params: &[f64],
) -> Vec<CollapsedControl> {
    while let Some(i) = (0..scan.len()).min_by(|&i, &j| scan[i].cost.total_cmp(&scan[j].cost)) {
        match along_segment(problem, params, scan[i].span) {
            Ok(checked) => {
                scan[i] = checked;
                return scan;
            }
            Err(_) => {
                scan.remove(i);
            }
        }
    }
    scan
}

/// The cheapest of `controls`.
pub fn cheapest(controls: &[CollapsedControl]) -> Option<CollapsedControl> {
    controls
        .iter()
        .copied()
        .min_by(|a, b| a.cost.total_cmp(&b.cost))
}

/// Whether `control` costs less than `cost`, beyond the quadrature errors (`quadrature` for
/// `cost`) and the control's own `O(ε²)` terms at a relative 1e-6.
pub fn undercuts(control: &CollapsedControl, cost: f64, quadrature: f64) -> bool {
    control.cost + 10.0 * (control.quadrature_error + quadrature) + 1e-6 * cost.abs() < cost
}

/// What the controls of this module show about one case.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CollapseEvidence {
    /// Every control evaluated (the motions and spans tried).
    pub controls: Vec<CollapsedControl>,
    /// The cheapest of them.
    pub least: CollapsedControl,
    /// The cost it is compared with.
    pub compared_cost: f64,
    /// What that cost is (the extremal computed, the least fixed-time extremal of the
    /// value-function scan, the last solution's control at the target weights).
    pub compared_with: &'static str,
    /// Whether [`Self::least`] costs less than that ([`undercuts`]).
    pub undercuts: bool,
    /// What the relaxed problem gave (`None` where it was not tried).
    pub relaxed: Option<RelaxedOutcome>,
    /// Free terminal time: the cheapest control is at the shortest span tried and the costs
    /// fall toward it, so the infimum is approached as `b → a` and no optimal `b` exists.
    pub no_optimal_time: bool,
    /// The finding in words.
    pub sentence: String,
    /// The discrete cost of the direct method's minimum (fixed `b`), when it lies below every
    /// control evaluated beyond its quadrature's error (a relative [`DIRECT_COST_RTOL`]): a
    /// cheaper minimum may exist, regular or collapsing on some arcs only (docs/collapse.md,
    /// "What is left"), so the cheapest control is not known to approach the infimum and is
    /// not written as the ε-optimal one. `None` otherwise, or where the direct method did not
    /// run (then absent from `summary.json`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cheaper_discrete: Option<f64>,
}

/// How far (relative) below the cheapest control with a vanishing `ξ` the direct method's
/// discrete minimum must lie to count as cheaper ([`CollapseEvidence::cheaper_discrete`]): its
/// cost is a quadrature on the direct mesh (100 or 200 intervals).
pub const DIRECT_COST_RTOL: f64 = 1e-3;

impl CollapseEvidence {
    /// Record `direct_cost`, the discrete cost of the direct method's minimum (its smallest
    /// `|ξ|` `min_xi`), when it is cheaper than every control evaluated
    /// ([`Self::cheaper_discrete`]); the sentence then says so.
    pub fn compare_direct(&mut self, direct_cost: f64, min_xi: f64) {
        if direct_cost * (1.0 + DIRECT_COST_RTOL) < self.least.cost {
            self.cheaper_discrete = Some(direct_cost);
            self.sentence.push_str(&format!(
                "; but the direct method's minimum of the transcribed problem costs {} \
                 (min |xi| {min_xi:.2e}), less than every control with a vanishing xi: a cheaper \
                 minimum may exist (regular, or collapsing on some arcs only), so the infimum is \
                 not established",
                Cost(direct_cost)
            ));
        }
    }
}

/// The controls for `problem` at its own constants: for a free terminal time the projected
/// segment over the spans of [`best_span`] around `span`, for a fixed one the segment at
/// `span`; with `relaxed`, the relaxed minimum's motion ([`along_relaxed`], whose outcome is
/// returned too); the projected desired path at `span` when it joins the end points.
fn candidates<M: Model>(
    problem: &Problem<M>,
    span: f64,
    free: bool,
    relaxed: bool,
) -> (Vec<CollapsedControl>, Option<RelaxedOutcome>) {
    let mut controls = if free {
        best_span(problem, span)
    } else {
        along_segment(problem, problem.params(), span)
            .into_iter()
            .collect()
    };
    let outcome = relaxed.then(|| {
        // For a free b, from the problem's guess and from the cheapest span of the scan.
        let mut spans = vec![span];
        spans.extend(
            cheapest(&controls)
                .map(|c| c.span)
                .filter(|s| (s - span).abs() > 1e-9 * span),
        );
        let (outcome, control) = along_relaxed_from(problem, &spans);
        controls.extend(control);
        outcome
    });
    controls.extend(along_desired(problem, problem.params(), span));
    (controls, outcome)
}

/// Whether the cheapest of `controls` is the shortest span and the costs fall toward it over
/// the five shortest spans.
fn falls_to_shortest(controls: &[CollapsedControl], least: &CollapsedControl) -> bool {
    let mut segment: Vec<&CollapsedControl> = controls
        .iter()
        .filter(|c| c.motion == Motion::ProjectedSegment)
        .collect();
    segment.sort_by(|a, b| a.span.total_cmp(&b.span));
    segment.len() >= 5
        && segment[0] == least
        && segment[..5].windows(2).all(|w| w[0].cost < w[1].cost)
}

fn evidence(
    (controls, relaxed): (Vec<CollapsedControl>, Option<RelaxedOutcome>),
    compared_cost: f64,
    compared_with: &'static str,
    quadrature: f64,
    free: bool,
) -> Option<CollapseEvidence> {
    let least = cheapest(&controls)?;
    let undercuts = undercuts(&least, compared_cost, quadrature);
    let no_optimal_time = free && undercuts && falls_to_shortest(&controls, &least);
    let mut sentence = if undercuts {
        let mut s = format!(
            "an admissible control with |xi| = {:.0e} along {} over b - a = {:.6} costs J = {}, \
             less than {compared_with} (J = {}; its motion re-integrated to \
             within {:.1e}): the problem's infimum is at most that, approached as xi -> 0, \
             where the optimality system is singular",
            least.eps,
            least.motion.describe(),
            least.span,
            Cost(least.cost),
            Cost(compared_cost),
            least.reintegration_error
        );
        if no_optimal_time {
            s.push_str(
                "; the cost of such controls keeps falling as b -> a: no optimal terminal \
                 time exists",
            );
        }
        s
    } else {
        format!(
            "no control with a vanishing xi tried costs less than {compared_with} (least: J = \
             {} along {} over b - a = {:.6}, against {})",
            Cost(least.cost),
            least.motion.describe(),
            least.span,
            Cost(compared_cost)
        )
    };
    if let Some(RelaxedOutcome::Computed {
        intervals,
        costs,
        spans,
        ..
    }) = &relaxed
    {
        sentence.push_str(&format!(
            "; the relaxed problem (the limit xi -> 0: a torque orthogonal to Omega as the \
             control) has its minimum at J = {:.8} on {} intervals ({:.8} on {})",
            costs[1], intervals[1], costs[0], intervals[0]
        ));
        if free {
            sentence.push_str(&format!(" at b - a = {:.6}", spans[1]));
        }
    }
    Some(CollapseEvidence {
        controls,
        least,
        compared_cost,
        compared_with,
        undercuts,
        relaxed,
        no_optimal_time,
        sentence,
        cheaper_discrete: None,
    })
}

/// The evidence for a computed extremal `sol` of cost `cost` (quadrature error `quadrature`):
/// whether a control with a vanishing `ξ` costs less (then `sol` is a local minimum only).
pub fn for_solution<M: Model>(
    sol: &LieSolution<M>,
    cost: f64,
    quadrature: f64,
) -> Option<CollapseEvidence> {
    if !sol.problem.conserves_energy() {
        return None;
    }
    let free = matches!(
        sol.problem.terminal,
        super::problem::TerminalTime::Free { .. }
    );
    // Not the relaxed minimum: an extremal's evidence is computed on every solve, and the
    // relaxed SQPs cost more than the paper's cases take to solve (session 16, release
    // build: 0.29 s against 0.16 s for η = 1, 0.19 s against 0.07 s for η = 0.01).
    let found = candidates(&sol.problem, sol.t_span, free, false);
    evidence(found, cost, "the computed extremal", quadrature, free)
}

/// The evidence for a problem whose homotopy stopped at `partial`: the controls for `problem`
/// (its target constants), `partial`'s motion with a vanishing `ξ`, and that of the direct
/// start's minimum (`direct`: its times and `Ω` rows, when the SQP found one the BVP could not
/// take up), compared with the least verified fixed-time extremal of the value-function scan
/// (`scan_least`) when there is one, else with `partial`'s own control at the target constants.
pub fn for_stop<M: Model>(
    problem: &Problem<M>,
    partial: &LieSolution<M>,
    scan_least: Option<f64>,
    direct: Option<(&[f64], &[Vec<f64>])>,
) -> Option<CollapseEvidence> {
    if !problem.conserves_energy() {
        return None;
    }
    let free = matches!(problem.terminal, super::problem::TerminalTime::Free { .. });
    let span = problem.terminal.initial() - problem.t0;
    let (mut controls, relaxed) = candidates(problem, span, free, true);
    if !free {
        controls.extend(along_solution(partial, problem.params()));
    }
    if let Some((times, omegas)) = direct {
        controls.extend(along_samples(
            problem,
            problem.params(),
            times,
            omegas,
            Motion::DirectMinimum,
        ));
    }
    match scan_least {
        Some(j) => evidence(
            (controls, relaxed),
            j,
            "every fixed-time extremal of the value-function scan",
            0.0,
            free,
        ),
        None => evidence(
            (controls, relaxed),
            partial.cost_with(problem.params()),
            "the last solution's control at the target weights",
            0.0,
            free,
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lie::path::Constant;
    use crate::model::so3::So3;

    /// The constants of so(3) with every weight 0 but `alpha`: the running cost is then
    /// `alpha/4 (|ξ|² − 1)²` alone, whatever `Ω` and `ξ̇`.
    fn alpha_only(alpha: f64) -> Vec<f64> {
        So3::PARAM_NAMES
            .iter()
            .map(|name| match *name {
                "alpha" => alpha,
                n if n.starts_with('I') => 1.0,
                _ => 0.0,
            })
            .collect()
    }

    /// A control with `|ξ|² = 2 + tanh(u)`, `u = (t − c)/w` (ξ ⟂ Ω), so the cost is
    /// `alpha/4 (1 + tanh u)²`, a step of width `w` at `c`, with the exact integral
    /// `alpha/4 [2t + 2w ln cosh u − w tanh u]`.
    #[test]
    fn the_adaptive_quadrature_resolves_a_sharp_step_to_its_estimate() {
        let alpha = 4.0;
        let params = alpha_only(alpha);
        let desired = Constant::new(vec![0.0; 3]).unwrap();
        for (span, c, w) in [(90.0, 10.0, 0.01), (11.36, 10.0, 0.01), (1.0, 0.5, 1e-4)] {
            let evaluations = std::cell::Cell::new(0usize);
            let control = |t: f64, _eps: f64, z: &mut [f64]| -> Result<(), CollapseError> {
                evaluations.set(evaluations.get() + 1);
                z.iter_mut().for_each(|v| *v = 0.0);
                z[So3::OMEGA.start] = 1.0;
                z[So3::XI.start + 1] = (2.0 + ((t - c) / w).tanh()).sqrt();
                Ok(())
            };
            let (value, error) =
                cost_on::<So3>(&params, &desired, (0.0, span), COLLAPSE_EPS, &control).unwrap();
            let ln_cosh = |u: f64| u.abs() + (-2.0 * u.abs()).exp().ln_1p() - 2f64.ln();
            let exact_at = |t: f64| {
                let u = (t - c) / w;
                alpha / 4.0 * (2.0 * t + 2.0 * w * ln_cosh(u) - w * u.tanh())
            };
            let exact = exact_at(span) - exact_at(0.0);
            let actual = (value - exact).abs();
            eprintln!(
                "span {span}: {value} against {exact} (error {actual:.1e}, estimate {error:.1e}, \
                 {} evaluations)",
                evaluations.get()
            );
            assert!(error <= QUADRATURE_RTOL * (1.0 + value.abs()), "{error}");
            assert!(
                actual <= error.max(1e-13 * exact.abs()),
                "{actual} > {error}"
            );
            // Uniform doubling needs about span / w panels here (90 / 0.01: 8192 and more);
            // the adaptive rule a few hundred.
            assert!(evaluations.get() < 20_000, "{}", evaluations.get());
        }
    }
}

#[cfg(test)]
mod reintegration_message_tests {
    #[test]
    fn a_failed_reintegration_is_said_in_words_not_as_nan() {
        let failed = super::reintegration_message(f64::NAN);
        assert!(
            !failed.contains("NaN") && failed.contains("failed"),
            "{failed}"
        );
        let measured = super::reintegration_message(2.5e-3);
        assert!(measured.contains("2.5e-3"), "{measured}");
    }
}
