//! The paper's stability experiment (section 5.3) on a computed solution: the control `ξ̇`
//! perturbed, Suslov's pure equations re-integrated from `Ω_a` (Verner 9(8),
//! rtol = atol = 1e-12), and the deviation of `Ω` (and of `ξ`, integrated from `ξ(a)`) from
//! the unperturbed re-integration.
//!
//! The checks of a solution (cost, constraint, energy, boundary residuals, the re-integration
//! with the unperturbed control) are the generic layer's, for every model
//! ([`crate::lie::verify`]); this experiment is the paper's, and stays with its so(3) outputs.

use nalgebra::Vector3;

use crate::ivp::IvpOptions;
use crate::lie::checks::fine_grid;
use crate::model::generated::{XI, XIDOT};

use super::reintegrate::{stability_experiment, Perturbation, StabilityReport};
use super::solve::SuslovSolution;
use super::SuslovError;

/// The relative size of both perturbations.
pub const PERTURBATION: f64 = 1e-3;

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

/// The paper's stability experiment on `sol`: `ξ̇` perturbed by a relative modulation
/// `ε sin(3t)` and by an additive `ε (1,1,1)/√3` (`ε` = [`PERTURBATION`]), each as
/// `(description, report)`, compared at the points of `fine_grid(mesh, 2)`.
pub fn stability_runs(sol: &SuslovSolution) -> Result<Vec<(String, StabilityReport)>, SuslovError> {
    let problem = &sol.problem;
    let (a, b) = (problem.t0, sol.terminal_time());
    let control = control_of(sol);
    let times: Vec<f64> = fine_grid(&sol.generic.bvp.x, 2)
        .iter()
        .map(|s| (a + s * sol.generic.t_span).min(b))
        .collect();
    let options = IvpOptions::default();
    let mut out = Vec::new();
    for (label, perturbation) in [
        (
            "xi_dot * (1 + 1e-3 sin 3t)",
            Perturbation::Modulated {
                eps: PERTURBATION,
                k: 3.0,
            },
        ),
        (
            "xi_dot + 1e-3 (1,1,1)/sqrt(3)",
            Perturbation::Additive {
                eps: PERTURBATION,
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
        out.push((label.to_string(), rep));
    }
    Ok(out)
}
