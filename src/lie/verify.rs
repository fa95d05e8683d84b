//! Verify, don't trust: the a-posteriori checks of a [`LieSolution`] of any model: the
//! [`Diagnostics`] and the [`Verification`] of [`super::checks`] (thresholds calibrated on the
//! paper's cases and the examples, shared with the so(3) layer).
//!
//! Computed from the solution's dense output on the fine grid (every mesh interval subdivided
//! [`FINE_PER_INTERVAL`] times), independently of the solver's error estimate:
//! - the cost, by 5-point Gauss–Legendre per interval;
//! - the constraint `max |φ|`, `φ = ⟨Ω, ξ⟩ − γ(ξ)` (the generated `constraint_residual`);
//! - the kinetic energy `T = ½⟨Ω, 𝕀Ω⟩` (𝕀 the model's full inertia matrix) against its balance
//!   `T(a) + ∫ λ⟨Ω, ξ⟩ dt` (λ from the generated `suslov_omega_dot`). When the constraint value
//!   vanishes the balance is `T(a)` itself: the integral is left out, so the check stays the
//!   strict one;
//! - `|Ω(b) − Ω_b|`, the residual of the interpolant and the boundary residuals;
//! - the re-integration of the model's Suslov equations (the generated `suslov_omega_dot`) as
//!   an initial value problem (Verner 9(8), rtol = atol = 1e-12) driven by the computed
//!   `ξ(t), ξ̇(t)`, in windows ([`reintegrate_windowed`]): the mesh cut into groups of
//!   intervals of about one radian of rotation each ([`REINTEGRATION_WINDOW_ANGLE`] of `∫ |Ω| dt`),
//!   the IVP restarted from the BVP's `Ω` at each window's start and compared inside the
//!   window. This difference is what the `reintegration` check judges;
//! - the open-loop re-integration from `Ω_a` over the whole `[a, b]`
//!   ([`reintegrate_difference`]), as information only ([`Verified::open_loop`]): along
//!   unstable stretches of a motion it amplifies the BVP's and its own errors exponentially
//!   (issue #12: 1.79 `max |Ω|` on a correct solution at `tol = 1e-8`; see
//!   [`REINTEGRATION_WINDOW_ANGLE`]), so it measures the motion's sensitivity, not the
//!   solution's correctness.

use std::cell::RefCell;

use super::checks::{
    fine_grid, Diagnostics, Verification, FINE_PER_INTERVAL, GAUSS5, REINTEGRATION_WINDOW_ANGLE,
};
use crate::bvp::BvpProblem;
use crate::ivp::{integrate, IvpOptions};
use crate::model::Model;

use super::problem::LieBvp;
use super::solve::LieSolution;

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Diagnostics of `sol` (module docs).
pub fn diagnose<M: Model>(sol: &LieSolution<M>) -> Diagnostics {
    let problem = &sol.problem;
    let params = problem.params();
    let t_span = sol.t_span;
    let full = LieBvp::new(problem);
    let bvp = LieBvp {
        fixed_span: Some(t_span),
        ..LieBvp::new(problem)
    };
    let set = problem.level_set();
    let kinetic = |om: &[f64]| 0.5 * set.quadratic(om);
    let t_a = kinetic(&problem.omega_a);
    let balance = !problem.conserves_energy();
    let mut x = vec![0.0; M::KAPPA.start];
    let mut grad = vec![0.0; M::XIDOT.start];
    let mut om_dot = vec![0.0; M::DIM];
    // The power of the constraint force, λ⟨Ω, ξ⟩ (dT/dt along every solution of Suslov's
    // equations), at s.
    let mut power = |y: &[f64]| {
        x.copy_from_slice(&y[..M::KAPPA.start]);
        let lambda = M::suslov_omega_dot(&x, params, &mut om_dot);
        lambda
            * y[M::OMEGA]
                .iter()
                .zip(&y[M::XI])
                .map(|(o, x)| o * x)
                .sum::<f64>()
    };
    let mesh = &sol.bvp.x;
    let n_state = M::N_STATE;
    let mut y = vec![0.0; n_state];
    let cost = sol.cost();

    let grid = fine_grid(&sol.bvp.x, FINE_PER_INTERVAL);
    let mut d = Diagnostics {
        terminal_time: sol.terminal_time(),
        cost,
        max_abs_constraint: 0.0,
        xi_norm_min: f64::INFINITY,
        xi_norm_max: 0.0,
        omega_norm_max: 0.0,
        kinetic_energy: t_a,
        energy_drift: 0.0,
        omega_b_error: 0.0,
        max_residual: 0.0,
        max_relative_residual: 0.0,
        max_local_error: 0.0,
        bc_residual: 0.0,
        grid_points: grid.len(),
    };
    let mut yp = vec![0.0; n_state];
    let mut f = vec![0.0; n_state];
    // ∫_a^t λ⟨Ω, ξ⟩ dt up to the current sample (balance only).
    let mut work = 0.0;
    let mut sample = |d: &mut Diagnostics, s: f64, h: f64, work: f64| {
        sol.bvp.eval_into(s, &mut y);
        sol.bvp.eval_derivative_into(s, &mut yp);
        bvp.f(s, &y, &[], &mut f);
        let (om, xi) = (&y[M::OMEGA], &y[M::XI]);
        let c = M::constraint_residual(&y[..M::XIDOT.start], params, &mut grad);
        d.max_abs_constraint = d.max_abs_constraint.max(c.abs());
        let xn = norm(xi);
        d.xi_norm_min = d.xi_norm_min.min(xn);
        d.xi_norm_max = d.xi_norm_max.max(xn);
        d.omega_norm_max = d.omega_norm_max.max(norm(om));
        d.energy_drift = d.energy_drift.max((kinetic(om) - t_a - work).abs());
        for i in 0..n_state {
            let r = (yp[i] - f[i]).abs();
            d.max_residual = d.max_residual.max(r);
            d.max_relative_residual = d.max_relative_residual.max(r / (1.0 + f[i].abs()));
            d.max_local_error = d.max_local_error.max(h * r / (1.0 + y[i].abs()));
        }
    };
    let mut y_work = vec![0.0; n_state];
    for w in mesh.windows(2) {
        let h = w[1] - w[0];
        let piece = h / FINE_PER_INTERVAL as f64;
        for k in 0..FINE_PER_INTERVAL {
            let s = w[0] + piece * k as f64;
            sample(&mut d, s, h, work);
            if balance {
                for (node, weight) in GAUSS5 {
                    sol.bvp.eval_into(s + node * piece, &mut y_work);
                    work += weight * piece * t_span * power(&y_work);
                }
            }
        }
    }
    let h_last = mesh[mesh.len() - 1] - mesh[mesh.len() - 2];
    sample(&mut d, mesh[mesh.len() - 1], h_last, work);
    let ya = sol.bvp.eval(0.0);
    let yb = sol.bvp.eval(1.0);
    let diff: Vec<f64> = yb[M::OMEGA]
        .iter()
        .zip(&problem.omega_b)
        .map(|(a, b)| a - b)
        .collect();
    d.omega_b_error = norm(&diff);
    // The solution's unknown parameters, [T?, μ?], in the layout of the problem's own BVP.
    debug_assert_eq!(sol.bvp.p.len(), full.k());
    debug_assert!(full.span_index().is_none_or(|i| sol.bvp.p[i] == t_span));
    let mut res = vec![0.0; full.n() + full.k()];
    full.bc(&ya, &yb, &sol.bvp.p, &mut res);
    d.bc_residual = res.iter().fold(0.0, |m, v| m.max(v.abs()));
    d
}

/// The re-integration's result: `max |Ω_ivp − Ω_bvp|` and where.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Reintegration {
    /// `max |Ω_ivp(t) − Ω_bvp(t)|` at the points of `fine_grid(mesh, 2)`.
    pub max_abs_diff: f64,
    /// Where.
    pub t_max_abs_diff: f64,
    /// Relative kinetic-energy drift along the re-integration: `|T_ivp(t) − T(a)| / T(a)`,
    /// or, when the constraint value does not vanish (the energy is not conserved),
    /// `|T_ivp(t) − T_bvp(t)| / T(a)`.
    pub max_rel_energy_drift: f64,
    /// The number of windows (1: the open-loop re-integration from `Ω_a` over `[a, b]`).
    pub windows: usize,
}

/// Re-integrate the model's Suslov equations `Ω̇ = F(Ω, ξ(t), ξ̇(t))` (the generated
/// `suslov_omega_dot`) from `Ω_a` over the whole `[a, b]` with the computed control, and
/// compare with the BVP's `Ω` (the open-loop re-integration: one window).
pub fn reintegrate_difference<M: Model>(sol: &LieSolution<M>) -> Result<Reintegration, String> {
    reintegrate_in_windows(sol, &[(sol.problem.t0, sol.terminal_time())])
}

/// The windows of [`reintegrate_windowed`]: `[a, b]` cut at mesh nodes into consecutive
/// windows, each ending at the first mesh node where the rotation angle `∫ |Ω| dt` since the
/// window's start reaches `max_angle` (5-point Gauss–Legendre per mesh interval); physical
/// times. One window when the whole motion turns by less than `max_angle`. A mesh interval
/// that turns by more than `max_angle` by itself gets windows of its own, equal in time and
/// as many as it turns by multiples of `max_angle` (rounded up), so that no window's
/// amplification grows with the mesh's step.
pub fn rotation_windows<M: Model>(sol: &LieSolution<M>, max_angle: f64) -> Vec<(f64, f64)> {
    let a = sol.problem.t0;
    let b = sol.terminal_time();
    let mesh = &sol.bvp.x;
    let mut y = vec![0.0; M::N_STATE];
    let mut windows = Vec::new();
    let mut start = a;
    let mut angle = 0.0;
    for (i, w) in mesh.windows(2).enumerate() {
        let h = w[1] - w[0];
        let mut turn = 0.0;
        for (node, weight) in GAUSS5 {
            sol.bvp.eval_into(w[0] + node * h, &mut y);
            turn += weight * h * sol.t_span * norm(&y[M::OMEGA]);
        }
        let end = if i + 2 == mesh.len() {
            b
        } else {
            (a + w[1] * sol.t_span).min(b)
        };
        // An interval that turns by more than `max_angle` on its own (a long, nearly steady
        // stretch that the mesh spans in one step) is cut into equal windows inside it,
        // restarted from the solution's interpolant, so that no window turns by much more.
        if turn > max_angle {
            // Close the window open before this interval at its first node.
            let node = (a + w[0] * sol.t_span).min(b);
            if node > start {
                windows.push((start, node));
                start = node;
            }
            let pieces = (turn / max_angle).ceil();
            let t_begin = start;
            for k in 1..=(pieces as usize) {
                let t = if k == pieces as usize {
                    end
                } else {
                    t_begin + (end - t_begin) * k as f64 / pieces
                };
                if t > start {
                    windows.push((start, t));
                    start = t;
                }
            }
            angle = 0.0;
            continue;
        }
        angle += turn;
        if angle >= max_angle || i + 2 == mesh.len() {
            if end > start {
                windows.push((start, end));
            }
            start = end;
            angle = 0.0;
        }
    }
    windows
}

/// Re-integrate the model's Suslov equations in windows ([`rotation_windows`] of
/// `max_angle`): in each, from the BVP's `Ω` at the window's start, compared with the BVP's
/// `Ω` inside the window.
pub fn reintegrate_windowed<M: Model>(
    sol: &LieSolution<M>,
    max_angle: f64,
) -> Result<Reintegration, String> {
    reintegrate_in_windows(sol, &rotation_windows(sol, max_angle))
}

/// Re-integrate the model's Suslov equations `Ω̇ = F(Ω, ξ(t), ξ̇(t))` (the generated
/// `suslov_omega_dot`) with the computed control in each window `(t_start, t_end)`, from the
/// BVP's `Ω(t_start)`, and compare with the BVP's `Ω` at the points of `fine_grid(mesh, 2)`
/// inside the window.
pub fn reintegrate_in_windows<M: Model>(
    sol: &LieSolution<M>,
    windows: &[(f64, f64)],
) -> Result<Reintegration, String> {
    let problem = &sol.problem;
    let (a, b) = (problem.t0, sol.terminal_time());
    let params = problem.params();
    let times: Vec<f64> = fine_grid(&sol.bvp.x, 2)
        .iter()
        .map(|s| (a + s * sol.t_span).min(b))
        .collect();
    // `suslov_omega_dot` takes x = [Ω, ξ, ξ̇]: the state's first three blocks.
    let scratch = RefCell::new((vec![0.0; M::N_STATE], vec![0.0; M::KAPPA.start]));
    let rhs = |t: f64, om: &[f64], dy: &mut [f64]| {
        let (y, x) = &mut *scratch.borrow_mut();
        sol.state_into(t.clamp(a, b), y);
        x.copy_from_slice(&y[..M::KAPPA.start]);
        x[M::OMEGA].copy_from_slice(om);
        M::suslov_omega_dot(x, params, dy);
    };
    let set = problem.level_set();
    let balance = !problem.conserves_energy();
    let mut out = Reintegration {
        max_abs_diff: 0.0,
        t_max_abs_diff: a,
        max_rel_energy_drift: 0.0,
        windows: windows.len(),
    };
    let mut y = vec![0.0; M::N_STATE];
    for &(t0, t1) in windows {
        let window_times: Vec<f64> = times
            .iter()
            .copied()
            .filter(|t| (t0..=t1).contains(t))
            .collect();
        sol.state_into(t0, &mut y);
        let run = integrate(
            rhs,
            (t0, t1),
            &y[M::OMEGA],
            &window_times,
            &IvpOptions::default(),
        )
        .map_err(|e| e.to_string())?;
        for (t, om) in run.t.iter().zip(&run.y) {
            sol.state_into(*t, &mut y);
            let diff: Vec<f64> = om.iter().zip(&y[M::OMEGA]).map(|(a, b)| a - b).collect();
            let dn = norm(&diff);
            if dn > out.max_abs_diff || dn.is_nan() {
                out.max_abs_diff = dn;
                out.t_max_abs_diff = *t;
            }
            let drift = if balance {
                ((set.quadratic(om) - set.quadratic(&y[M::OMEGA])) / set.level()).abs()
            } else {
                set.relative_mismatch(om).abs()
            };
            out.max_rel_energy_drift = out.max_rel_energy_drift.max(drift);
        }
    }
    Ok(out)
}

/// Diagnose `sol`, re-integrate its control in windows of
/// [`REINTEGRATION_WINDOW_ANGLE`] and check both against its requested tolerance (the so(3)
/// layer's [`Verification`]); the open-loop re-integration over `[a, b]` is measured too, as
/// information ([`Verified::open_loop`]).
///
/// A solution returned by the solver carries the solver's own verification of it; that result
/// is returned as long as nothing the checks read has changed (the numbers, compared by a
/// fingerprint, and the desired path, by identity), and the checks are run afresh otherwise.
pub fn verify_solution<M: Model>(sol: &LieSolution<M>) -> Verified {
    if let Some(kept) = &sol.checked {
        if kept.matches(sol) {
            return kept.verified.clone();
        }
    }
    verify_afresh(sol)
}

/// [`verify_solution`], and the result kept in `sol` for the next call (the solver verifies
/// what it returns; the summary of the same solution then reads the kept result).
pub(crate) fn verify_and_keep<M: Model>(sol: &mut LieSolution<M>) -> Verified {
    let verified = verify_solution(sol);
    sol.checked = Some(std::sync::Arc::new(KeptVerification {
        fingerprint: fingerprint(sol),
        desired: sol.problem.desired.clone(),
        verified: verified.clone(),
    }));
    verified
}

/// A verification kept in the [`LieSolution`] it judged, with what it depends on: the
/// fingerprint of the solution's numbers and the desired path itself (an `Arc` clone, so a
/// replaced path can never be mistaken for the one judged). A solution changed in anything
/// the checks read is verified again.
#[derive(Clone)]
pub(crate) struct KeptVerification {
    fingerprint: u64,
    desired: std::sync::Arc<dyn super::path::Path>,
    verified: Verified,
}

impl KeptVerification {
    fn matches<M: Model>(&self, sol: &LieSolution<M>) -> bool {
        std::sync::Arc::ptr_eq(&self.desired, &sol.problem.desired)
            && self.fingerprint == fingerprint(sol)
    }
}

/// A 64-bit hash of every number [`verify_solution`] reads: the mesh, node values, node
/// derivatives, stage values and their derivatives, parameters of the BVP solution, `T`, the
/// tolerance, and the problem's constants, end points and times (the desired path is compared
/// by identity). Multiply-rotate mixing of the bit patterns, word by word; the lengths are
/// mixed in too.
fn fingerprint<M: Model>(sol: &LieSolution<M>) -> u64 {
    let mut h: u64 = 0x243F_6A88_85A3_08D3;
    let mut word = |w: u64| {
        h = (h ^ w).wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(29);
    };
    let slice = |v: &[f64], word: &mut dyn FnMut(u64)| {
        word(v.len() as u64);
        for x in v {
            word(x.to_bits());
        }
    };
    let b = &sol.bvp;
    for v in [
        &b.x[..],
        &b.y,
        &b.yp,
        &b.p,
        &b.stages,
        &b.stage_f,
        sol.problem.params(),
        &sol.problem.omega_a,
        &sol.problem.omega_b,
    ] {
        slice(v, &mut word);
    }
    let (kind, time) = match sol.problem.terminal {
        super::problem::TerminalTime::Fixed(b) => (1, b),
        super::problem::TerminalTime::Free { guess } => (2, guess),
    };
    for w in [
        kind,
        time.to_bits(),
        sol.problem.t0.to_bits(),
        sol.t_span.to_bits(),
        sol.tolerance.to_bits(),
        b.n as u64,
        b.k as u64,
    ] {
        word(w);
    }
    h
}

/// The checks themselves (no kept result consulted).
fn verify_afresh<M: Model>(sol: &LieSolution<M>) -> Verified {
    let diagnostics = diagnose(sol);
    let reintegration = reintegrate_windowed(sol, REINTEGRATION_WINDOW_ANGLE);
    let open_loop = reintegrate_difference(sol);
    let mut verification = Verification::new(
        &diagnostics,
        reintegration
            .as_ref()
            .map(|r| r.max_abs_diff)
            .map_err(Clone::clone),
        norm(&sol.problem.omega_b),
        sol.tolerance,
    );
    if !sol.problem.conserves_energy() {
        // The same checks and thresholds; what `diagnose` measured is the constraint with its
        // value and the energy against its balance.
        for check in &mut verification.checks {
            match check.name {
                "constraint" => {
                    check.quantity = "max |<Omega, xi> - gamma(xi)| / (max |Omega| max |xi|)";
                }
                "energy" => {
                    check.quantity = "max |T(t) - T(a) - int_a^t lambda <Omega, xi> dt| / T(a) \
                                      (the energy balance)";
                }
                _ => {}
            }
        }
    }
    Verified {
        diagnostics,
        reintegration,
        open_loop,
        verification,
    }
}

/// Everything [`verify_solution`] measured, and its verdict.
#[derive(Debug, Clone)]
pub struct Verified {
    /// The diagnostics.
    pub diagnostics: Diagnostics,
    /// The windowed re-integration the `reintegration` check judges
    /// ([`reintegrate_windowed`] with [`REINTEGRATION_WINDOW_ANGLE`]), or why it failed.
    pub reintegration: Result<Reintegration, String>,
    /// The open-loop re-integration from `Ω_a` over `[a, b]` ([`reintegrate_difference`]), or
    /// why it failed: not judged. It measures how sensitive the motion is to its initial
    /// value and control (unstable stretches amplify the BVP's and the integrator's errors
    /// exponentially), not whether the solution satisfies Suslov's equations.
    pub open_loop: Result<Reintegration, String>,
    /// The checks against the requested tolerance.
    pub verification: Verification,
}
