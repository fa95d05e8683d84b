//! "Converged" means verified: [`Verification`] (in [`crate::lie::checks`], shared by every
//! problem layer) applied to a [`SuslovSolution`].

use super::diagnostics::{diagnose, reintegrate_difference};
use super::solve::SuslovSolution;

pub use crate::lie::checks::{
    Check, Verdict, Verification, K_BC, K_CONSTRAINT, K_ENERGY, K_LOCAL_ERROR, K_OMEGA_B,
    K_REINTEGRATION, REINTEGRATION_FLOOR, TOLERANCE, TOL_MAX, TOL_MIN,
};

/// Diagnose `sol`, re-integrate its control and check both against its requested tolerance
/// ([`SuslovSolution::tolerance`]). For a caller that needs the diagnostics too, compute them
/// and use [`Verification::new`].
pub fn verify_solution(sol: &SuslovSolution) -> Verification {
    let d = diagnose(sol);
    let reintegration = reintegrate_difference(sol)
        .map(|r| r.max_abs_diff)
        .map_err(|e| e.to_string());
    Verification::new(&d, reintegration, sol.problem.omega_b.norm(), sol.tolerance)
}
