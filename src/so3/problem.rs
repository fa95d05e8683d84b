//! Suslov's optimal control problem as data ([`SuslovProblem`]) and its validation; solving
//! hands it to the generic layer as a problem of model `so3` ([`SuslovProblem::to_generic`]),
//! whose BVP ([`crate::lie::LieBvp`]) joins the generated model to the solver in
//! [`crate::bvp`].
//!
//! The constants' layout is the generated model's (`PARAM_NAMES`, `INERTIA_PARAMS`).

use std::sync::Arc;

use nalgebra::Vector3;

use crate::model::generated::{self as g, idx, N_PARAM};

use super::desired::DesiredPath;
use super::ellipsoid::{EnergyEllipsoid, Inertia};

/// The weights of the cost integrand
/// `C = α/4 (|ξ|² − 1)² + β/2 |ξ̇|² + γ/2 |Ω − Ω_d|² + η/2 |Ω̇|² + δ` (paper eq. `cost_function`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CostWeights {
    /// Keeps `|ξ|` near 1 (> 0).
    pub alpha: f64,
    /// Control effort `|ξ̇|²` (> 0; `β = 0` is a singular problem, paper section 4.4).
    pub beta: f64,
    /// Tracking of the desired path (≥ 0).
    pub gamma: f64,
    /// Smoothness `|Ω̇|²` (≥ 0).
    pub eta: f64,
    /// Weight of the time (≥ 0).
    pub delta: f64,
}

impl CostWeights {
    /// Every weight 0: for the functions of Suslov's pure equations, in which only the
    /// inertia enters (see [`inertia_params`]).
    pub const ZERO: Self = Self {
        alpha: 0.0,
        beta: 0.0,
        gamma: 0.0,
        eta: 0.0,
        delta: 0.0,
    };

    /// The weights held in a constant vector `p` of the generated model (the inverse of
    /// [`model_params`], by the generated `idx::*`).
    pub fn from_params(p: &[f64; N_PARAM]) -> Self {
        let [alpha, beta, gamma, eta, delta] = COST_WEIGHT_INDICES.map(|i| p[i]);
        Self {
            alpha,
            beta,
            gamma,
            eta,
            delta,
        }
    }

    /// The paper's weights (section 5.3) for a given `η`.
    pub fn paper(eta: f64) -> Self {
        Self {
            alpha: 1.0,
            beta: 0.1,
            gamma: 1.0,
            eta,
            delta: 0.2,
        }
    }
}

/// Number of principal moments of inertia in `p` (the generated `INERTIA_PARAMS`).
pub const N_INERTIA: usize = g::INERTIA_PARAMS.len();

/// The constants [`CostWeights`] holds, field by field (`alpha`, `beta`, `gamma`, `eta`,
/// `delta`): the generated model's weights, in its order.
const COST_WEIGHT_INDICES: [usize; 5] = [idx::ALPHA, idx::BETA, idx::GAMMA, idx::ETA, idx::DELTA];

/// Whether [`model_params`] fills every constant of `p`: the inertia, the model's weights
/// (exactly those of [`CostWeights`]), no constraint parameters and no derived constants (a
/// diagonal inertia has no `I⁻¹` slots).
const fn covers_every_param() -> bool {
    if !(g::CONSTRAINT_PARAMS.is_empty()
        && g::INERTIA_INVERSE_SLOTS.is_empty()
        && g::N_USER_PARAM == N_PARAM
        && N_INERTIA + COST_WEIGHT_INDICES.len() == N_PARAM
        && g::WEIGHTS.len() == COST_WEIGHT_INDICES.len())
    {
        return false;
    }
    let mut k = 0;
    while k < COST_WEIGHT_INDICES.len() {
        if g::WEIGHTS[k].index != COST_WEIGHT_INDICES[k] {
            return false;
        }
        k += 1;
    }
    true
}
const _: () = assert!(covers_every_param());

/// The generated model's constant vector `p` (layout `PARAM_NAMES`) for the principal
/// moments `moments` (in the order of `INERTIA_PARAMS`) and `weights`: the one place where
/// `p` is assembled, by the generated indices.
pub fn model_params(moments: [f64; N_INERTIA], weights: &CostWeights) -> [f64; N_PARAM] {
    let mut p = [0.0; N_PARAM];
    for (meta, m) in g::INERTIA_PARAMS.iter().zip(moments) {
        p[meta.index] = m;
    }
    let CostWeights {
        alpha,
        beta,
        gamma,
        eta,
        delta,
    } = *weights;
    for (i, w) in COST_WEIGHT_INDICES
        .into_iter()
        .zip([alpha, beta, gamma, eta, delta])
    {
        p[i] = w;
    }
    p
}

/// `p` for the functions of Suslov's pure equations, which depend on the inertia only
/// (every weight 0).
pub fn inertia_params(inertia: &Inertia) -> [f64; N_PARAM] {
    model_params(inertia.diag().into(), &CostWeights::ZERO)
}

pub use crate::lie::problem::{TerminalTime, ENERGY_REL_TOL};

/// A Suslov optimal control problem (paper eq. `dyn_opt_problem_spec` with the cost above).
#[derive(Clone)]
pub struct SuslovProblem {
    /// Principal moments of inertia.
    pub inertia: Inertia,
    /// Cost weights.
    pub weights: CostWeights,
    /// Initial time `a`.
    pub t0: f64,
    /// `Ω(a)`.
    pub omega_a: Vector3<f64>,
    /// `Ω(b)`, on the energy ellipsoid of `Ω_a`.
    pub omega_b: Vector3<f64>,
    /// Fixed or free `b`.
    pub terminal: TerminalTime,
    /// The desired body angular velocity `Ω_d(t)`, with exact derivatives.
    pub desired: Arc<dyn DesiredPath + Send + Sync>,
}

impl SuslovProblem {
    /// The same problem for the generic layer (model `so3`, [`crate::lie::Problem`]); the
    /// desired path is shared ([`super::desired::AsLiePath`]).
    pub fn to_generic(&self) -> Result<crate::lie::Problem<g::So3>, crate::lie::ProblemError> {
        let p = model_params(self.inertia.diag().into(), &self.weights);
        crate::lie::Problem::new(
            &p[..g::N_USER_PARAM],
            self.t0,
            self.omega_a.as_slice().to_vec(),
            self.omega_b.as_slice().to_vec(),
            self.terminal,
            Arc::new(super::desired::AsLiePath(self.desired.clone())),
        )
    }
}

impl std::fmt::Debug for SuslovProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SuslovProblem")
            .field("inertia", &self.inertia.diag())
            .field("weights", &self.weights)
            .field("t0", &self.t0)
            .field("omega_a", &self.omega_a)
            .field("omega_b", &self.omega_b)
            .field("terminal", &self.terminal)
            .finish_non_exhaustive()
    }
}

/// What is wrong with a [`SuslovProblem`]; each names the field and the fix.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProblemError {
    /// A number is NaN or infinite.
    #[error("{field} = {value} is not a finite number")]
    NotFinite {
        /// The field.
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// A weight is out of range.
    #[error("{field} = {value}: {requirement}")]
    Weight {
        /// The field.
        field: &'static str,
        /// Its value.
        value: f64,
        /// What is required and why.
        requirement: &'static str,
    },
    /// `Ω_b` is not on `Ω_a`'s energy ellipsoid.
    #[error(
        "omega_b = {omega_b:?} is off omega_a's energy ellipsoid by {mismatch:.3e} (relative; \
         allowed {ENERGY_REL_TOL:e}): Suslov's equations conserve the kinetic energy, so no \
         control reaches it. Its radial projection onto the ellipsoid is {projection:?}"
    )]
    OffEllipsoid {
        /// The given `Ω_b`.
        omega_b: [f64; 3],
        /// Relative energy mismatch.
        mismatch: f64,
        /// The projection to use instead.
        projection: [f64; 3],
    },
    /// `Ω_b = 0`: not on any energy ellipsoid, and with no radial projection.
    #[error(
        "omega_b must be nonzero: Suslov's equations conserve the kinetic energy of omega_a, \
         so no motion reaches 0"
    )]
    ZeroOmegaB,
    /// `Ω_a = 0`: the ellipsoid degenerates.
    #[error("omega_a must be nonzero (it fixes the kinetic energy of the motion)")]
    ZeroOmegaA,
    /// `⟨Ω_a, IΩ_a⟩` overflows `f64` or falls below its normal range (the ellipsoid is not
    /// representable to full precision).
    #[error(
        "omega_a's kinetic energy level <omega_a, I omega_a> = {level:e} is not a normal \
         positive f64 (overflow, or below 2.2e-308: too few significant bits); rescale \
         omega_a or the inertia"
    )]
    EnergyOutOfRange {
        /// `⟨Ω_a, IΩ_a⟩` as computed.
        level: f64,
    },
    /// The time interval is empty or reversed.
    #[error("terminal time b = {b} must be greater than t0 = {t0}")]
    EmptyInterval {
        /// `t0`.
        t0: f64,
        /// `b`.
        b: f64,
    },
}

impl SuslovProblem {
    /// The generated model's constant vector `p` (layout `PARAM_NAMES`; [`model_params`]).
    pub fn params(&self) -> [f64; N_PARAM] {
        model_params(self.inertia.diag().into(), &self.weights)
    }

    /// The energy ellipsoid through `Ω_a`.
    pub fn ellipsoid(&self) -> EnergyEllipsoid {
        EnergyEllipsoid::through(self.inertia, &self.omega_a)
            .expect("Ω_a validated: finite, nonzero, with a representable energy level")
    }

    /// Check every field; the first problem found is returned.
    pub fn validate(&self) -> Result<(), ProblemError> {
        let w = &self.weights;
        let finite = [
            ("t0", self.t0),
            ("terminal_time", self.terminal.initial()),
            ("omega_a[0]", self.omega_a[0]),
            ("omega_a[1]", self.omega_a[1]),
            ("omega_a[2]", self.omega_a[2]),
            ("omega_b[0]", self.omega_b[0]),
            ("omega_b[1]", self.omega_b[1]),
            ("omega_b[2]", self.omega_b[2]),
            ("alpha", w.alpha),
            ("beta", w.beta),
            ("gamma", w.gamma),
            ("eta", w.eta),
            ("delta", w.delta),
        ];
        for (field, value) in finite {
            if !value.is_finite() {
                return Err(ProblemError::NotFinite { field, value });
            }
        }
        let positive = "must be > 0: alpha keeps |xi| near 1 and beta > 0 makes the problem \
                        nonsingular (paper section 4.4; beta = 0 needs alpha > 0 too)";
        for (field, value) in [("alpha", w.alpha), ("beta", w.beta)] {
            if value <= 0.0 {
                return Err(ProblemError::Weight {
                    field,
                    value,
                    requirement: positive,
                });
            }
        }
        for (field, value) in [("gamma", w.gamma), ("eta", w.eta), ("delta", w.delta)] {
            if value < 0.0 {
                return Err(ProblemError::Weight {
                    field,
                    value,
                    requirement: "must be >= 0 (a negative weight rewards the term)",
                });
            }
        }
        if self.omega_a.iter().all(|x| *x == 0.0) {
            return Err(ProblemError::ZeroOmegaA);
        }
        let level = self.inertia.apply(&self.omega_a).dot(&self.omega_a);
        if !(level.is_finite() && level >= f64::MIN_POSITIVE) {
            return Err(ProblemError::EnergyOutOfRange { level });
        }
        let b = self.terminal.initial();
        if b <= self.t0 {
            return Err(ProblemError::EmptyInterval { t0: self.t0, b });
        }
        if self.omega_b.iter().all(|x| *x == 0.0) {
            return Err(ProblemError::ZeroOmegaB);
        }
        let e = self.ellipsoid();
        let mismatch = e.relative_mismatch(&self.omega_b);
        let on_ellipsoid = mismatch.abs() <= ENERGY_REL_TOL; // false for NaN too
        if !on_ellipsoid {
            // Finite and nonzero (checked above): the projection exists.
            let projection = e
                .project(&self.omega_b)
                .map(|v| [v[0], v[1], v[2]])
                .unwrap_or([f64::NAN; 3]);
            return Err(ProblemError::OffEllipsoid {
                omega_b: [self.omega_b[0], self.omega_b[1], self.omega_b[2]],
                mismatch,
                projection,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The value of the constant named `name` (a generated `PARAM_NAMES` entry) in `p`.
    fn by_name(p: &[f64; N_PARAM], name: &str) -> f64 {
        let i = g::PARAM_NAMES
            .iter()
            .position(|n| *n == name)
            .unwrap_or_else(|| panic!("no constant {name}"));
        p[i]
    }

    #[test]
    fn model_params_puts_every_value_under_its_generated_name() {
        let w = CostWeights {
            alpha: 1.5,
            beta: 0.25,
            gamma: 3.0,
            eta: 0.125,
            delta: 0.75,
        };
        let moments = std::array::from_fn(|k| 1.0 + k as f64 / 8.0);
        let p = model_params(moments, &w);
        for (meta, m) in g::INERTIA_PARAMS.iter().zip(moments) {
            assert_eq!(by_name(&p, meta.name), m);
        }
        for (name, v) in [
            ("alpha", w.alpha),
            ("beta", w.beta),
            ("gamma", w.gamma),
            ("eta", w.eta),
            ("delta", w.delta),
        ] {
            assert_eq!(by_name(&p, name), v, "{name}");
        }
        assert_eq!(CostWeights::from_params(&p), w);
        // SuslovProblem::params is the same assembly.
        let problem = super::super::paper::problem(0.5);
        assert_eq!(
            problem.params(),
            model_params(problem.inertia.diag().into(), &problem.weights)
        );
        assert_eq!(CostWeights::from_params(&problem.params()), problem.weights);
    }
}
