//! Error estimation and mesh adaptation.
//!
//! 1. `estimate_errors`: sample the residual `r = u' - f(x, u, p)` of the collocation
//!    polynomial at the three interior 5-point Lobatto points of every interval (it vanishes
//!    at the four collocation points) and form the per-interval measures of
//!    [`ErrorControl`]; also verify the discrete equations and the boundary conditions.
//!    The discrete equations' defects are compared with the tolerance after an allowance for
//!    the rounding of `f`, probed where a defect exceeds the tolerance: where `f` is a small
//!    difference of large intermediate terms, its evaluation's rounding is far above `ε |f|`,
//!    and no Newton iteration brings the defects below it (the Suslov problem's `ξ̈`
//!    equations with large costates and a small `β`: `tests/rounding_floor.rs`). The error
//!    estimate, which the allowance does not touch, still bounds the solution's accuracy.
//! 2. `adapt_mesh`: equidistribute the predicted number of subintervals. With
//!    `e_i ~ C h_i^q` (`q = 5` for error control, 4 for residual control) interval `i` wants
//!    `m_i = (e_i / target)^(1/q)` subintervals. Intervals far below the tolerance
//!    (`m_i <= 1/2`: two of them merged would still be below the target) keep their `m_i`,
//!    but at least 1/4 (at most four merge per pass: coarsening); intervals in between keep
//!    `m_i = 1`, and `m_i <= 8` per pass (the estimate is asymptotic). The new mesh
//!    equidistributes the piecewise-constant density `m_i / h_i`.
//! 3. `halve_mesh`: uniform bisection, used when Newton fails on a mesh.
//! 4. `transfer_solution`: move the iterate to a new mesh through the dense output.

use super::collocation::{eval_collocation_polynomial, Collocation};
use super::options::{ErrorControl, Options};
use super::problem::{BvpProblem, Evaluator};

/// The relative target of equidistribution: aim at `e_i = 0.25` (the tolerance is 1).
pub(crate) const EQUIDISTRIBUTION_TARGET: f64 = 0.25;
/// At most this many subintervals are made from one interval per pass.
const MAX_SPLIT: f64 = 8.0;
/// Smallest weight: at most four intervals merge into one per pass.
const MIN_WEIGHT: f64 = 0.25;

/// Per-interval estimates and the after-the-fact verification of a candidate solution.
#[derive(Debug, Clone, Default)]
pub(crate) struct ErrorEstimate {
    /// Normalised per-interval estimate of the chosen [`ErrorControl`] (`<= 1` passes).
    pub errors: Vec<f64>,
    /// Per-interval RMS relative residual (scipy's measure).
    pub residuals: Vec<f64>,
    pub max_error: f64,
    pub max_residual: f64,
    /// Largest scaled defect of the discrete equations (`<= 1` passes): continuity defect
    /// `|Phi_4| (b - a) / h` and stage defect `|Phi_s| (b - a) / h`, over `atol s_j + tol |y_j|`.
    pub max_defect: f64,
    /// [`Self::max_defect`] without the allowance for the rounding of `f` (equal to it when no
    /// interval needed one).
    pub max_raw_defect: f64,
    /// `max |g|`.
    pub bc_residual: f64,
    /// All sampled values finite.
    pub finite: bool,
}

/// Estimate errors of the iterate `u` on the mesh of `col`.
///
/// Requires [`Collocation::evaluate_residual`] at `u` just before (it provides `f` at the
/// collocation points and the residual `res`). Costs `3N` evaluations of `f`.
pub(crate) fn estimate_errors<P: BvpProblem + ?Sized>(
    ev: &Evaluator<P>,
    col: &Collocation,
    u: &[f64],
    res: &[f64],
    opts: &Options,
) -> ErrorEstimate {
    let lay = col.lay;
    let (n, k) = (lay.n, lay.k);
    let nn = lay.intervals();
    let tol = opts.tol;
    let absw = opts.abs_weights(n);
    let p = &u[lay.p_offset()..lay.p_offset() + k];
    let mut est = ErrorEstimate {
        errors: vec![0.0; nn],
        residuals: vec![0.0; nn],
        finite: true,
        ..Default::default()
    };
    let mut uq = vec![0.0; n];
    let mut duq = vec![0.0; n];
    let mut fq = vec![0.0; n];
    let mut defects = vec![0.0; nn];
    for i in 0..nn {
        let h = col.h[i];
        let mut err2 = 0.0;
        let mut res2 = 0.0;
        for &(t, wq) in &col.tab.sample {
            eval_collocation_polynomial(
                &col.tab,
                n,
                h,
                &u[i * n..(i + 1) * n],
                &col.fnodes[i * n..(i + 1) * n],
                &col.fstages[2 * i * n..(2 * i + 2) * n],
                &col.fnodes[(i + 1) * n..(i + 2) * n],
                t,
                &mut uq,
                &mut duq,
            );
            ev.eval_f(col.x[i] + t * h, &uq, p, &mut fq);
            let mut emax = 0.0_f64;
            let mut rsum = 0.0;
            for j in 0..n {
                let r = duq[j] - fq[j];
                emax = emax.max(r.abs() / (absw[j] + tol * uq[j].abs()));
                let rr = r / (1.0 + fq[j].abs());
                rsum += rr * rr;
            }
            err2 += wq * emax * emax;
            res2 += wq * rsum;
        }
        let rms_res = res2.sqrt();
        est.residuals[i] = rms_res;
        est.errors[i] = match opts.error_control {
            ErrorControl::Error => h * err2.sqrt(),
            ErrorControl::Residual => rms_res / tol,
        };
        // Discrete equations: continuity and stage defects, scaled to an accumulated error.
        defects[i] = interval_defect(col, u, res, i, &absw, tol, None);
    }
    est.max_raw_defect = defects.iter().fold(0.0_f64, |a, &v| a.max(v));
    if est.max_raw_defect > 1.0 {
        // Above the tolerance somewhere: allow for the rounding of f (module docs).
        allow_for_rounding(ev, col, u, res, &absw, tol, &mut defects);
    }
    est.max_defect = defects.iter().fold(0.0_f64, |a, &v| a.max(v));
    let bo = lay.bc_offset();
    est.bc_residual = res[bo..bo + n + k]
        .iter()
        .fold(0.0_f64, |a, v| a.max(v.abs()));
    est.max_error = est.errors.iter().fold(0.0_f64, |a, &v| a.max(v));
    est.max_residual = est.residuals.iter().fold(0.0_f64, |a, &v| a.max(v));
    est.finite = est
        .errors
        .iter()
        .chain(&est.residuals)
        .all(|v| v.is_finite())
        && est.max_defect.is_finite()
        && est.bc_residual.is_finite();
    if !est.finite {
        est.max_error = f64::INFINITY;
    }
    est
}

/// Relative size of the perturbations of `y` and `p` with which [`rounding_levels`] probes the
/// rounding of `f`: two units in the last place.
const ROUNDING_PROBE: f64 = 2.0 * f64::EPSILON;

/// Intervals on each side whose probes also count for an interval's rounding level: one probe
/// may happen to round alike (measured on fast-159: single probes from 1e-9 to 3e-7 on
/// neighbouring points, their maximum steady along the mesh).
const ROUNDING_WINDOW: usize = 2;

/// How many rounding levels a defect may reach before it counts against the tolerance: a
/// defect sums the rounding of four evaluations of `f`, each like a probe's difference.
const ROUNDING_ALLOWANCE: f64 = 4.0;

/// Replace each `defects[i] > 1` by the defect that remains above [`ROUNDING_ALLOWANCE`] times
/// the rounding level of the interval's equations ([`interval_defect`]). The level of each
/// component is the largest [`rounding_levels`] of the intervals within [`ROUNDING_WINDOW`].
fn allow_for_rounding<P: BvpProblem + ?Sized>(
    ev: &Evaluator<P>,
    col: &Collocation,
    u: &[f64],
    res: &[f64],
    absw: &[f64],
    tol: f64,
    defects: &mut [f64],
) {
    let n = col.lay.n;
    let nn = defects.len();
    let mut levels: Vec<Option<Vec<f64>>> = vec![None; nn];
    let mut window = vec![0.0_f64; n];
    for (i, defect) in defects.iter_mut().enumerate() {
        if *defect <= 1.0 {
            continue;
        }
        window.fill(0.0);
        let first = i.saturating_sub(ROUNDING_WINDOW);
        let last = (i + ROUNDING_WINDOW).min(nn - 1);
        for (w, level) in levels[first..=last].iter_mut().enumerate() {
            let level = level.get_or_insert_with(|| rounding_levels(ev, col, u, first + w));
            for (a, b) in window.iter_mut().zip(level.iter()) {
                *a = a.max(*b);
            }
        }
        *defect = interval_defect(col, u, res, i, absw, tol, Some(&window));
    }
}

/// The largest scaled defect of interval `i`'s discrete equations (continuity `Phi_4`, stages
/// `Phi_2`, `Phi_3`), accumulated over the horizon (`* length / h`) in tolerance units. With
/// the rounding `level` of `f` (per component) each defect is first reduced by
/// [`ROUNDING_ALLOWANCE`] times its own rounding: `h sum_s |w_s| level` with the quadrature
/// weights `w` of its equation, plus the rounding of the values it subtracts.
fn interval_defect(
    col: &Collocation,
    u: &[f64],
    res: &[f64],
    i: usize,
    absw: &[f64],
    tol: f64,
    level: Option<&[f64]>,
) -> f64 {
    let lay = col.lay;
    let n = lay.n;
    let so = lay.stage_offset();
    let h = col.h[i];
    let amp = (col.x[lay.intervals()] - col.x[0]) / h;
    let tab = &col.tab;
    let mut worst = 0.0_f64;
    for j in 0..n {
        let y0 = u[i * n + j];
        // (residual, the unknown its equation defines, quadrature weights)
        let eqs = [
            (res[i * n + j], u[(i + 1) * n + j], &tab.b),
            (res[so + 2 * i * n + j], u[so + 2 * i * n + j], &tab.a[1]),
            (
                res[so + (2 * i + 1) * n + j],
                u[so + (2 * i + 1) * n + j],
                &tab.a[2],
            ),
        ];
        for (r, v, w) in eqs {
            let floor = level.filter(|l| l[j].is_finite()).map_or(0.0, |level| {
                let weights: f64 = w.iter().map(|x| x.abs()).sum();
                ROUNDING_ALLOWANCE * (h * weights * level[j] + f64::EPSILON * (v.abs() + y0.abs()))
            });
            worst = worst.max(amp * (r.abs() - floor).max(0.0) / (absw[j] + tol * v.abs()));
        }
    }
    worst
}

/// Per component, the largest change of `f` at interval `i`'s four collocation points (node,
/// two stages, node) when every component of `y` and `p` is perturbed by [`ROUNDING_PROBE`]
/// relative, in two sign patterns. Where `f` is a small difference of large intermediate
/// terms (e.g. a costate equation divided by a small weight) this is the rounding of its
/// evaluation, far above `ε |f|` and above `ε |∂f/∂y| |y|`; no Newton iteration brings the
/// discrete equations below it.
fn rounding_levels<P: BvpProblem + ?Sized>(
    ev: &Evaluator<P>,
    col: &Collocation,
    u: &[f64],
    i: usize,
) -> Vec<f64> {
    let lay = col.lay;
    let (n, k) = (lay.n, lay.k);
    let so = lay.stage_offset();
    let p = &u[lay.p_offset()..lay.p_offset() + k];
    let mut level = vec![0.0_f64; n];
    let mut yp = vec![0.0; n];
    let mut pp = vec![0.0; k];
    let mut fp = vec![0.0; n];
    for s in 0..4 {
        let (y, f) = match s {
            0 | 3 => {
                let r = i + s / 3;
                (&u[r * n..(r + 1) * n], &col.fnodes[r * n..(r + 1) * n])
            }
            _ => {
                let o = (2 * i + s - 1) * n;
                (&u[so + o..so + o + n], &col.fstages[o..o + n])
            }
        };
        for pattern in 0..2 {
            // Signs from the bits of a fixed odd constant: deterministic, not all alike.
            let sign = |q: usize| {
                if (0x9E37_79B9_7F4A_7C15_u64 >> ((q + 11 * pattern) % 64)) & 1 == 1 {
                    ROUNDING_PROBE
                } else {
                    -ROUNDING_PROBE
                }
            };
            for (q, (t, v)) in yp.iter_mut().zip(y).enumerate() {
                *t = v * (1.0 + sign(q));
            }
            for (q, (t, v)) in pp.iter_mut().zip(p).enumerate() {
                *t = v * (1.0 + sign(n + q));
            }
            ev.eval_f(col.x[i] + col.tab.c[s] * col.h[i], &yp, &pp, &mut fp);
            for ((l, a), b) in level.iter_mut().zip(&fp).zip(f) {
                // A probe that is not finite makes the level infinite, which allows nothing.
                let d = (a - b).abs();
                *l = if d.is_finite() {
                    l.max(d)
                } else {
                    f64::INFINITY
                };
            }
        }
    }
    level
}

/// Equidistributing refinement and coarsening of `x` from normalised estimates `errors`
/// (`e_i ~ h_i^order`); see the module docs. Returns the new mesh (same end points).
///
/// With `keep_moderate` (refinement passes) intervals with `1/2 < m_i <= 1` keep `m_i = 1`, so
/// that a refinement pass only merges where the error is far below the target; without it
/// (coarsening a converged solution) the weights are pure equidistribution.
pub(crate) fn adapt_mesh(x: &[f64], errors: &[f64], order: f64, keep_moderate: bool) -> Vec<f64> {
    let weights: Vec<f64> = errors
        .iter()
        .map(|&e| {
            let raw = (e / EQUIDISTRIBUTION_TARGET).powf(1.0 / order);
            if raw > 1.0 {
                raw.min(MAX_SPLIT)
            } else if raw <= 0.5 || !keep_moderate {
                raw.max(MIN_WEIGHT)
            } else {
                1.0
            }
        })
        .collect();
    let total: f64 = weights.iter().sum();
    let intervals = (total.ceil() as usize).max(1);
    equidistribute(x, &weights, intervals)
}

/// Nodes `z_0 = x_0 < ... < z_J = x_N` with equal mass of the piecewise-constant density
/// `w_i / h_i` between consecutive nodes.
fn equidistribute(x: &[f64], weights: &[f64], intervals: usize) -> Vec<f64> {
    let total: f64 = weights.iter().sum();
    let step = total / intervals as f64;
    let mut out = Vec::with_capacity(intervals + 1);
    out.push(x[0]);
    let mut i = 0;
    let mut acc = 0.0; // mass up to x[i]
    for j in 1..intervals {
        let target = j as f64 * step;
        while i < weights.len() - 1 && acc + weights[i] < target {
            acc += weights[i];
            i += 1;
        }
        let frac = ((target - acc) / weights[i]).clamp(0.0, 1.0);
        let z = x[i] + frac * (x[i + 1] - x[i]);
        if z > *out.last().expect("mesh has a first node") {
            out.push(z);
        }
    }
    out.push(x[x.len() - 1]);
    out
}

/// Bisect every interval.
pub(crate) fn halve_mesh(x: &[f64]) -> Vec<f64> {
    let mut out = Vec::with_capacity(2 * x.len() - 1);
    for w in x.windows(2) {
        out.push(w[0]);
        out.push(0.5 * (w[0] + w[1]));
    }
    out.push(x[x.len() - 1]);
    out
}

/// The iterate `u` on the mesh of `col` resampled on `new_x` (nodes and stages) through the
/// collocation polynomials; parameters are copied. `col` must hold `f` at `u`.
pub(crate) fn transfer_solution(col: &Collocation, u: &[f64], new_x: &[f64]) -> Vec<f64> {
    let lay = col.lay;
    let (n, k) = (lay.n, lay.k);
    let m_new = new_x.len();
    let new_lay = super::collocation::Layout { n, k, m: m_new };
    let mut out = vec![0.0; new_lay.total()];
    let old_x = &col.x;
    let eval_at = |xq: f64, dst: &mut [f64]| {
        let i = old_x
            .partition_point(|&v| v <= xq)
            .saturating_sub(1)
            .min(lay.m - 2);
        let h = col.h[i];
        eval_collocation_polynomial(
            &col.tab,
            n,
            h,
            &u[i * n..(i + 1) * n],
            &col.fnodes[i * n..(i + 1) * n],
            &col.fstages[2 * i * n..(2 * i + 2) * n],
            &col.fnodes[(i + 1) * n..(i + 2) * n],
            (xq - old_x[i]) / h,
            dst,
            &mut [],
        );
    };
    for (i, &xq) in new_x.iter().enumerate() {
        // Reuse exact node values where a node is kept.
        let j = old_x.partition_point(|&v| v < xq);
        if j < lay.m && old_x[j] == xq {
            out[i * n..(i + 1) * n].copy_from_slice(&u[j * n..(j + 1) * n]);
        } else {
            eval_at(xq, &mut out[i * n..(i + 1) * n]);
        }
    }
    let po = lay.p_offset();
    out[new_lay.p_offset()..new_lay.p_offset() + k].copy_from_slice(&u[po..po + k]);
    let so = new_lay.stage_offset();
    for i in 0..m_new - 1 {
        let h = new_x[i + 1] - new_x[i];
        for s in 0..2 {
            let off = so + (2 * i + s) * n;
            eval_at(new_x[i] + col.tab.c[s + 1] * h, &mut out[off..off + n]);
        }
    }
    out
}
