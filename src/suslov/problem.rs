//! Suslov's optimal control problem as data ([`SuslovProblem`]), its validation, and its
//! two-point BVP on normalized time ([`SuslovBvp`]), which joins the generated model to the
//! generic solver in [`crate::bvp`].
//!
//! The BVP (paper eqs. `p_sys_explicit`, `p_lbc`, `p_rbc`), on `s ∈ [0, 1]`, `t = a + sT`:
//!
//! ```text
//! dy/ds = T f(y, Ω_d(a + sT)),       y = [Ω, ξ, ξ̇, κ] ∈ R^N_STATE (R¹² on so(3))
//! Ω(0) = Ω_a,  p_ξ(0) = ⟨κ,ξ⟩Ω + βξ̇ = 0        (N_BC_ENDPOINT = 6 conditions at a)
//! Ω(1) = Ω_b,  p_ξ(1) = 0                        (N_BC_ENDPOINT = 6 conditions at b)
//! C − ⟨p_Ω, Ω̇⟩ = 0 at b                          (free terminal time only; T unknown)
//! ```
//!
//! Every size, block and index is the generated model's (`N_STATE`, `OMEGA`, …, `idx::*`).

use std::ops::Range;
use std::sync::Arc;

use nalgebra::Vector3;

use crate::bvp::BvpProblem;
use crate::model::generated::{self as g, idx, DIM, N_BC_ENDPOINT, N_DESIRED, N_PARAM, N_STATE};

use super::desired::DesiredPath;
use super::ellipsoid::{EnergyEllipsoid, Inertia};
use super::layout::as_state;

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

/// Index of `T = b − a` among the BVP's unknown parameters (free terminal time only).
pub const SPAN: usize = 0;

/// Rows of the boundary conditions at `a` (the generated `bc_endpoint` at `Ω_a`).
const BC_LEFT: Range<usize> = 0..N_BC_ENDPOINT;
/// Rows of the boundary conditions at `b` (the generated `bc_endpoint` at `Ω_b`).
const BC_RIGHT: Range<usize> = N_BC_ENDPOINT..2 * N_BC_ENDPOINT;
/// Row of the free-time condition (after both ends' conditions).
const BC_FREE_TIME: usize = 2 * N_BC_ENDPOINT;

// The BVP is square: `N_STATE` conditions at the two ends, one more for the unknown `T`; `w`
// is `[Ω_d, Ω̇_d]`.
const _: () = assert!(BC_FREE_TIME == N_STATE && N_DESIRED == 2 * DIM);

/// The Suslov BVP on normalized time `s ∈ [0, 1]`, for given constants (which continuation
/// changes) and a fixed or unknown `T = b − a` (the BVP's one parameter when free).
pub struct SuslovBvp<'a> {
    /// The generated model's constants `p` (layout `PARAM_NAMES`).
    pub params: [f64; N_PARAM],
    /// `Ω(a)`.
    pub omega_a: [f64; DIM],
    /// `Ω(b)`.
    pub omega_b: [f64; DIM],
    /// `a`.
    pub t0: f64,
    /// `Some(T)` for a fixed terminal time, `None` when `T` is the unknown parameter.
    pub fixed_span: Option<f64>,
    /// `Ω_d`.
    pub desired: &'a dyn DesiredPath,
}

impl<'a> SuslovBvp<'a> {
    /// The BVP of `problem` with its own weights and terminal-time mode.
    pub fn new(problem: &'a SuslovProblem) -> Self {
        let fixed_span = match problem.terminal {
            TerminalTime::Fixed(b) => Some(b - problem.t0),
            TerminalTime::Free { .. } => None,
        };
        Self {
            params: problem.params(),
            omega_a: problem.omega_a.into(),
            omega_b: problem.omega_b.into(),
            t0: problem.t0,
            fixed_span,
            desired: &*problem.desired,
        }
    }

    fn span(&self, p: &[f64]) -> f64 {
        self.fixed_span.unwrap_or_else(|| p[SPAN])
    }

    /// `w = [Ω_d(t), Ω̇_d(t)]`.
    pub fn desired_at(&self, t: f64) -> [f64; N_DESIRED] {
        let jet = self.desired.jet(t);
        let mut w = [0.0; N_DESIRED];
        let (value, rate) = w.split_at_mut(DIM);
        value.copy_from_slice(jet.value.as_slice());
        rate.copy_from_slice(jet.d1.as_slice());
        w
    }
}

impl BvpProblem for SuslovBvp<'_> {
    fn n(&self) -> usize {
        N_STATE
    }

    fn k(&self) -> usize {
        usize::from(self.fixed_span.is_none())
    }

    fn f(&self, s: f64, y: &[f64], p: &[f64], dy: &mut [f64]) {
        let t_span = self.span(p);
        let w = self.desired_at(self.t0 + s * t_span);
        let out: &mut [f64; N_STATE] = dy.try_into().expect("n = N_STATE");
        g::ode_rhs_scaled(as_state(y), &self.params, &w, t_span, out);
    }

    fn jac(&self, s: f64, y: &[f64], p: &[f64], dfdy: &mut [f64], dfdp: &mut [f64]) -> bool {
        let t_span = self.span(p);
        let w = self.desired_at(self.t0 + s * t_span);
        let mut dgdy = [[0.0; N_STATE]; N_STATE];
        let mut dgdt = [0.0; N_STATE];
        g::ode_jac_scaled(
            as_state(y),
            &self.params,
            &w,
            t_span,
            s,
            &mut dgdy,
            &mut dgdt,
        );
        for (row, out) in dgdy.iter().zip(dfdy.chunks_exact_mut(N_STATE)) {
            out.copy_from_slice(row);
        }
        if self.fixed_span.is_none() {
            dfdp.copy_from_slice(&dgdt);
        }
        true
    }

    fn bc(&self, ya: &[f64], yb: &[f64], p: &[f64], res: &mut [f64]) {
        let mut left = [0.0; N_BC_ENDPOINT];
        let mut right = [0.0; N_BC_ENDPOINT];
        g::bc_endpoint(as_state(ya), &self.params, &self.omega_a, &mut left);
        g::bc_endpoint(as_state(yb), &self.params, &self.omega_b, &mut right);
        res[BC_LEFT].copy_from_slice(&left);
        res[BC_RIGHT].copy_from_slice(&right);
        if self.fixed_span.is_none() {
            let wb = self.desired_at(self.t0 + p[SPAN]);
            res[BC_FREE_TIME] = g::free_time_condition(as_state(yb), &self.params, &wb);
        }
    }

    fn bc_jac(
        &self,
        ya: &[f64],
        yb: &[f64],
        p: &[f64],
        dya: &mut [f64],
        dyb: &mut [f64],
        dp: &mut [f64],
    ) -> bool {
        dya.fill(0.0);
        dyb.fill(0.0);
        dp.fill(0.0);
        // Row-major: row i of the conditions is `d[i * N_STATE..(i + 1) * N_STATE]`.
        let mut d = [[0.0; N_STATE]; N_BC_ENDPOINT];
        g::bc_endpoint_jac(as_state(ya), &self.params, &self.omega_a, &mut d);
        for (row, out) in d
            .iter()
            .zip(dya.chunks_exact_mut(N_STATE).skip(BC_LEFT.start))
        {
            out.copy_from_slice(row);
        }
        g::bc_endpoint_jac(as_state(yb), &self.params, &self.omega_b, &mut d);
        for (row, out) in d
            .iter()
            .zip(dyb.chunks_exact_mut(N_STATE).skip(BC_RIGHT.start))
        {
            out.copy_from_slice(row);
        }
        if self.fixed_span.is_none() {
            let wb = self.desired_at(self.t0 + p[SPAN]);
            let mut d_y = [0.0; N_STATE];
            // `dp` is (n + k) x k with k = 1: the entry of row BC_FREE_TIME, column SPAN.
            dp[BC_FREE_TIME * self.k() + SPAN] =
                g::free_time_condition_jac(as_state(yb), &self.params, &wb, &mut d_y);
            dyb[BC_FREE_TIME * N_STATE..(BC_FREE_TIME + 1) * N_STATE].copy_from_slice(&d_y);
        }
        true
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
