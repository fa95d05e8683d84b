//! Verify, don't trust: a-posteriori diagnostics of a [`SuslovSolution`].
//!
//! Everything here is computed from the solution's dense output on a fine grid (every mesh
//! interval subdivided [`FINE_PER_INTERVAL`] times), independently of the solver's own
//! error estimate:
//! - the cost `∫ C dt` by 5-point Gauss–Legendre per mesh interval (exact for degree 9,
//!   above the order of the collocation interpolant);
//! - the constraint `max |⟨Ω, ξ⟩|`, `min/max |ξ|`, the kinetic-energy drift, `|Ω(b) − Ω_b|`;
//! - the ODE residual of the interpolant, `max |y'(s) − T f(y(s))|`;
//! - the boundary residuals (including the free-time condition);
//! - the re-integration of Suslov's pure equations as an initial value problem (Verner 9(8),
//!   rtol = atol = 1e-12) driven by the computed `ξ(t), ξ̇(t)`, compared with the BVP's `Ω(t)`;
//! - the paper's stability experiment (section 5.3, R2Q4): `ξ̇` perturbed, `Ω` re-integrated.

use nalgebra::Vector3;

use crate::bvp::BvpProblem;
use crate::ivp::IvpOptions;
use crate::model::generated::{self as g, DIM, N_STATE, OMEGA, XI, XIDOT};

use super::problem::SuslovBvp;
use super::reintegrate::{
    compare, reintegrate, stability_experiment, Perturbation, StabilityReport,
};
use super::solve::SuslovSolution;
use super::SuslovError;

pub use crate::lie::checks::{fine_grid, Diagnostics, FINE_PER_INTERVAL, GAUSS5};

/// The a-posteriori re-integration and the stability experiment.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Reintegration {
    /// `max |Ω_ivp(t) − Ω_bvp(t)|` at the fine-grid times.
    pub max_abs_diff: f64,
    /// Where.
    pub t_max_abs_diff: f64,
    /// Relative energy drift along the re-integration.
    pub max_rel_energy_drift: f64,
    /// Stability experiment: `(description, report)`.
    #[serde(skip)]
    pub stability: Vec<(String, StabilityReport)>,
}

/// Diagnostics of `sol` (see the module docs).
pub fn diagnose(sol: &SuslovSolution) -> Diagnostics {
    let problem = &sol.problem;
    let bvp = SuslovBvp::new(problem);
    let params = problem.params();
    let t_span = sol.t_span;
    let p_vec = if bvp.fixed_span.is_none() {
        vec![t_span]
    } else {
        vec![]
    };
    let bvp = SuslovBvp {
        fixed_span: Some(t_span),
        ..bvp
    };
    let inertia = problem.inertia.diag();
    let kinetic = |om: &[f64]| 0.5 * (0..DIM).map(|i| inertia[i] * om[i] * om[i]).sum::<f64>();
    let t_a = kinetic(problem.omega_a.as_slice());
    let x = &sol.bvp.x;

    let mut cost = 0.0;
    for w in x.windows(2) {
        let h = w[1] - w[0];
        for (node, weight) in GAUSS5 {
            let s = w[0] + node * h;
            let y: [f64; N_STATE] = sol.bvp.eval(s).try_into().expect("n = N_STATE");
            let wd = bvp.desired_at(problem.t0 + s * t_span);
            cost += weight * h * t_span * g::cost_integrand(&y, &params, &wd);
        }
    }

    let grid = fine_grid(x, FINE_PER_INTERVAL);
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
    let mut y = [0.0; N_STATE];
    let mut yp = [0.0; N_STATE];
    let mut f = [0.0; N_STATE];
    let mut sample = |d: &mut Diagnostics, s: f64, h: f64| {
        sol.bvp.eval_into(s, &mut y);
        sol.bvp.eval_derivative_into(s, &mut yp);
        bvp.f(s, &y, &[], &mut f);
        let (om, xi) = (&y[OMEGA], &y[XI]);
        let c = om.iter().zip(xi).map(|(o, x)| o * x).sum::<f64>();
        d.max_abs_constraint = d.max_abs_constraint.max(c.abs());
        let xn = xi.iter().map(|x| x * x).sum::<f64>().sqrt();
        d.xi_norm_min = d.xi_norm_min.min(xn);
        d.xi_norm_max = d.xi_norm_max.max(xn);
        let on = om.iter().map(|o| o * o).sum::<f64>().sqrt();
        d.omega_norm_max = d.omega_norm_max.max(on);
        d.energy_drift = d.energy_drift.max((kinetic(om) - t_a).abs());
        for i in 0..N_STATE {
            let r = (yp[i] - f[i]).abs();
            d.max_residual = d.max_residual.max(r);
            d.max_relative_residual = d.max_relative_residual.max(r / (1.0 + f[i].abs()));
            d.max_local_error = d.max_local_error.max(h * r / (1.0 + y[i].abs()));
        }
    };
    // The points of `fine_grid(x, FINE_PER_INTERVAL)`, each with the width of its mesh
    // interval (at an interior node, where the derivative is that of the right interval's
    // polynomial, the right interval's).
    for w in x.windows(2) {
        let h = w[1] - w[0];
        for k in 0..FINE_PER_INTERVAL {
            sample(&mut d, w[0] + h * k as f64 / FINE_PER_INTERVAL as f64, h);
        }
    }
    let h_last = x[x.len() - 1] - x[x.len() - 2];
    sample(&mut d, x[x.len() - 1], h_last);
    let yb = sol.bvp.eval(1.0);
    d.omega_b_error = (Vector3::from_column_slice(&yb[OMEGA]) - problem.omega_b).norm();
    let full = SuslovBvp::new(problem);
    // n + k conditions (n = N_STATE).
    let mut res = vec![0.0; full.n() + full.k()];
    full.bc(&sol.bvp.eval(0.0), &yb, &p_vec[..full.k()], &mut res);
    d.bc_residual = res.iter().fold(0.0, |m, v| m.max(v.abs()));
    d
}

/// The computed control `t ↦ (ξ(t), ξ̇(t))` of `sol` (clamped to `[a, b]`).
fn control_of(
    sol: &SuslovSolution,
) -> impl Fn(f64) -> Result<(Vector3<f64>, Vector3<f64>), SuslovError> + '_ {
    let (a, b) = (sol.problem.t0, sol.terminal_time());
    move |t: f64| {
        let y = sol.state(t.clamp(a, b));
        Ok((
            Vector3::from_column_slice(&y[XI]),
            Vector3::from_column_slice(&y[XIDOT]),
        ))
    }
}

/// Re-integrate Suslov's pure equations with the computed control and compare with the BVP's
/// `Ω` at the points of `fine_grid(mesh, 2)` ([`Reintegration::stability`] left empty; see
/// [`reintegrate_check`] for the full check).
pub fn reintegrate_difference(sol: &SuslovSolution) -> Result<Reintegration, SuslovError> {
    let problem = &sol.problem;
    let (a, b) = (problem.t0, sol.terminal_time());
    let control = control_of(sol);
    let times: Vec<f64> = fine_grid(&sol.bvp.x, 2)
        .iter()
        .map(|s| a + s * sol.t_span)
        .collect();
    let run = reintegrate(
        &problem.inertia,
        &problem.omega_a,
        (a, b),
        &control,
        &times,
        &IvpOptions::default(),
    )?;
    let reference: Vec<Vector3<f64>> = times
        .iter()
        .map(|&t| Vector3::from_column_slice(&sol.state(t)[OMEGA]))
        .collect();
    let cmp = compare(&run, &reference, &problem.ellipsoid())?;
    Ok(Reintegration {
        max_abs_diff: cmp.max_abs_diff,
        t_max_abs_diff: cmp.t_max_abs_diff,
        max_rel_energy_drift: cmp.max_rel_energy_drift,
        stability: Vec::new(),
    })
}

/// Re-integrate Suslov's pure equations with the computed control ([`reintegrate_difference`])
/// and run the paper's stability experiment (perturbed `ξ̇`: relative modulation
/// `eps sin(3t)` with eps = 1e-3, and an additive `1e-3` along `(1,1,1)/√3`).
pub fn reintegrate_check(sol: &SuslovSolution) -> Result<Reintegration, SuslovError> {
    let mut out = reintegrate_difference(sol)?;
    let problem = &sol.problem;
    let (a, b) = (problem.t0, sol.terminal_time());
    let control = control_of(sol);
    let times: Vec<f64> = fine_grid(&sol.bvp.x, 2)
        .iter()
        .map(|s| a + s * sol.t_span)
        .collect();
    let options = IvpOptions::default();
    for (label, perturbation) in [
        (
            "xi_dot * (1 + 1e-3 sin 3t)",
            Perturbation::Modulated { eps: 1e-3, k: 3.0 },
        ),
        (
            "xi_dot + 1e-3 (1,1,1)/sqrt(3)",
            Perturbation::Additive {
                eps: 1e-3,
                direction: Vector3::new(1.0, 1.0, 1.0),
            },
        ),
    ] {
        let rep = stability_experiment(
            &problem.inertia,
            &problem.omega_a,
            (a, b),
            &control,
            perturbation,
            &times,
            &options,
        )?;
        out.stability.push((label.to_string(), rep));
    }
    Ok(out)
}
