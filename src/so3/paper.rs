//! The paper's numerical example (section 5.3): `I = diag(1, 2, 3)`, `a = 0`,
//! `Ω_a = φ(0)/2 = [5, 0, 0]`, `Ω_b = φ_∥(10)`, the spiral `Ω_d`, `α = 1`, `β = 0.1`,
//! `γ = 1`, `δ = 0.2`, free terminal time, `η = 1` and `η = 0.01`.
//! Published optimal terminal times: `b = 11.36` (`η = 1`) and `b = 9.84` (`η = 0.01`).

use std::sync::Arc;

use super::desired::PaperSpiral;
use super::ellipsoid::Inertia;
use super::problem::{CostWeights, SuslovProblem, TerminalTime};

/// One case of the paper: name, `η`, published `b`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PaperCase {
    /// Directory-friendly name.
    pub name: &'static str,
    /// `η`.
    pub eta: f64,
    /// The published optimal terminal time (two decimals).
    pub published_b: f64,
}

/// The paper's two cases.
pub const CASES: [PaperCase; 2] = [
    PaperCase {
        name: "eta_1",
        eta: 1.0,
        published_b: 11.36,
    },
    PaperCase {
        name: "eta_0.01",
        eta: 0.01,
        published_b: 9.84,
    },
];

/// The paper's problem for a given `η` (free terminal time, continuation from `b_p = 10`).
pub fn problem(eta: f64) -> SuslovProblem {
    let spiral = PaperSpiral::paper();
    SuslovProblem {
        inertia: Inertia::paper(),
        weights: CostWeights::paper(eta),
        t0: 0.0,
        omega_a: spiral.omega_a(),
        omega_b: spiral.omega_b(),
        terminal: TerminalTime::Free {
            guess: spiral.b_d(),
        },
        desired: Arc::new(spiral),
    }
}

/// The paper's setup with a fixed terminal time `b` (not in the paper; a check of the
/// fixed-time path of the solver).
pub fn fixed_time_problem(eta: f64, b: f64) -> SuslovProblem {
    SuslovProblem {
        terminal: TerminalTime::Fixed(b),
        ..problem(eta)
    }
}
