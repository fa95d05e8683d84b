//! A constraint-control problem of any generated model ([`Problem`]), its validation, and its
//! two-point BVP on normalized time ([`LieBvp`]), which joins the model's generated functions
//! to the generic solver in [`crate::bvp`].
//!
//! The BVP (paper section 3, eqs. `p_sys_explicit`, `p_lbc`, `p_rbc`, for any Lie algebra), on
//! `s ∈ [0, 1]`, `t = a + sT`:
//!
//! ```text
//! dy/ds = T f(y, Ω_d(a + sT)),       y = [Ω, ξ, ξ̇, κ] ∈ R^(4n)
//! Ω(0) = Ω_a,  p_ξ(0) = 0             (M::N_BC_ENDPOINT = 2n conditions at a)
//! Ω(1) = Ω_b,  p_ξ(1) = 0             (2n conditions at b)
//! C − ⟨p_Ω, Ω̇⟩ = 0 at b               (free terminal time only; T unknown)
//! ```
//!
//! Every size, block and index is the model's ([`Model`] constants); nothing here knows a
//! dimension.
//!
//! # The constraint level and the energy
//!
//! Suslov's equations keep `φ = ⟨Ω, ξ⟩ − γ(ξ)` constant (the multiplier λ is chosen so), but
//! its value is set by the initial data, and `ξ(a)` is free. The kinetic energy balances as
//! `Ṫ = λ⟨Ω, ξ⟩`.
//! - **Constraint value 0** (the paper): `Ṫ = λφ`, so a motion with `φ ≠ 0` leaves the energy
//!   level set of `Ω_a` unless `∫λ = 0`. With `Ω_b` on that level set (required, checked), the
//!   paper's conditions above select `φ = 0`: within `φ = 0` the motion stays on the level
//!   set and `Ω(b) = Ω_b` is `n − 1` conditions, the last one holds by itself.
//! - **A nonzero constraint value** (`M::HAS_CONSTRAINT_VALUE`, e.g. `⟨Ω, ξ⟩ = c`): the energy is
//!   not conserved (`Ṫ = λγ`), `Ω_b` may be anywhere, and nothing selects `φ = 0`: the paper's
//!   conditions, solved as they stand, return a motion on another constraint level (measured in
//!   `tests/lie_inhomogeneous.rs`). The start therefore imposes `φ(a) = 0` with a multiplier
//!   `μ`, an unknown parameter of the BVP: `ξ(a)` is free on `{φ = 0}` only, so the natural
//!   condition becomes `p_ξ(a) = μ ∂φ/∂ξ` (the generated `bc_start_constrained`, `2n + 1`
//!   rows; [`LieBvp::start_constraint`]).
//!
//! The two forms do not mix: with a vanishing constraint value the start constraint is
//! redundant and its form singular. `φ(a) = 0` and the energy part of `Ω(b) = Ω_b` are then
//! the same condition (`T(b) − T(a) = φ(a) ∫λ`), and the costates are determined only up to
//! `ν [𝕀Ω − Λξ; −ΛΩ]` with `Λ̇ = λ`, `Λ(b) = 0`, which shifts `μ` by `−ν Λ(a)`: the BVP has a
//! line of solutions with the same motion. With `c ≠ 0` it is regular (`Ṫ = λ(φ + c)` on the
//! motion breaks the tie). So the paper's form is used whenever the constraint value vanishes
//! (every `γ ≡ 0` model, and `c = 0`), the start constraint otherwise; the homotopy switches
//! from one to the other when it leaves `c = 0` ([`super::solve`](mod@super::solve)).
//!
//! Unknown parameters: `[T]` (free terminal time), then `[μ]` (with the start constraint), in
//! this order ([`LieBvp::span_index`], [`LieBvp::mu_index`]).

use std::marker::PhantomData;
use std::sync::Arc;

use crate::bvp::BvpProblem;
use crate::model::{fill_derived, DerivedError, Model, ParamMeta};
use crate::suslov::problem::{TerminalTime, ENERGY_REL_TOL};

use super::path::{LevelSet, Path, PathError};

/// What is wrong with a [`Problem`]; each names the field and the fix.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProblemError {
    /// A vector has the wrong number of entries.
    #[error("{field} has {got} entries; model {model} needs {expected} (one per basis element: {basis})")]
    Length {
        /// The field.
        field: &'static str,
        /// The model.
        model: &'static str,
        /// Its dimension.
        expected: usize,
        /// The length given.
        got: usize,
        /// The basis names.
        basis: String,
    },
    /// A number is NaN or infinite.
    #[error("{field} = {value} is not a finite number")]
    NotFinite {
        /// The field (with the index for a vector entry).
        field: String,
        /// Its value.
        value: f64,
    },
    /// A model parameter is outside its admissible range.
    #[error("{name} = {value} is not admissible: {doc}")]
    Parameter {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Its generated documentation (with the range).
        doc: &'static str,
    },
    /// `Ω_b = 0` with a nonzero constraint value: `⟨Ω(b), ξ(b)⟩ = γ ≠ 0` needs `Ω(b) ≠ 0`.
    #[error(
        "omega_b must be nonzero: the constraint <Omega, xi> = gamma(xi) has a nonzero value \
         ({names}), which no xi meets at Omega = 0"
    )]
    ZeroOmegaB {
        /// The constraint parameters and their values.
        names: String,
    },
    /// The inertia is not symmetric positive definite.
    #[error(transparent)]
    Inertia(#[from] DerivedError),
    /// `Ω_a = 0`.
    #[error("omega_a must be nonzero (it fixes the kinetic energy of the motion)")]
    ZeroOmegaA,
    /// `⟨Ω_a, 𝕀Ω_a⟩` is not a normal positive `f64`.
    #[error(
        "omega_a's energy level <omega_a, I omega_a> = {level:e} is not a normal positive f64; \
         rescale omega_a or the inertia"
    )]
    EnergyOutOfRange {
        /// The level as computed.
        level: f64,
    },
    /// `Ω_b` is off the level set of `Ω_a`.
    #[error(
        "omega_b = {omega_b:?} is off omega_a's energy level set by {mismatch:.3e} (relative; \
         allowed {ENERGY_REL_TOL:e}): the constrained motion conserves the kinetic energy, so \
         no control reaches it. Its radial projection onto the level set is {projection:?}"
    )]
    OffLevelSet {
        /// The given `Ω_b`.
        omega_b: Vec<f64>,
        /// Relative energy mismatch.
        mismatch: f64,
        /// The projection to use instead.
        projection: Vec<f64>,
    },
    /// The time interval is empty or reversed.
    #[error("terminal time b = {b} must be greater than t0 = {t0}")]
    EmptyInterval {
        /// `t0`.
        t0: f64,
        /// `b`.
        b: f64,
    },
    /// The desired path has another dimension than the model.
    #[error("the desired path has dimension {got}; model {model} needs {expected}")]
    DesiredDimension {
        /// The model.
        model: &'static str,
        /// Its dimension.
        expected: usize,
        /// The path's.
        got: usize,
    },
    /// A path could not be built (the level set of `Ω_a`, a projection).
    #[error(transparent)]
    Path(#[from] PathError),
}

/// A constraint-control problem of model `M`: minimise `∫ C dt` (the model's cost) subject to
/// the model's Suslov equations, `Ω(a) = Ω_a`, `Ω(b) = Ω_b`, fixed or free `b`.
#[derive(Clone)]
pub struct Problem<M: Model> {
    /// The constants `p` (layout `M::PARAM_NAMES`): the user parameters, then the derived
    /// constants (filled by [`Problem::new`]).
    params: Vec<f64>,
    /// Initial time `a`.
    pub t0: f64,
    /// `Ω(a)`.
    pub omega_a: Vec<f64>,
    /// `Ω(b)`, on the level set of `Ω_a`.
    pub omega_b: Vec<f64>,
    /// Fixed or free `b`.
    pub terminal: TerminalTime,
    /// The desired body velocity `Ω_d(t)`, with exact derivatives.
    pub desired: Arc<dyn Path>,
    model: PhantomData<M>,
}

impl<M: Model> std::fmt::Debug for Problem<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Problem")
            .field("model", &M::NAME)
            .field("params", &self.user_params())
            .field("t0", &self.t0)
            .field("omega_a", &self.omega_a)
            .field("omega_b", &self.omega_b)
            .field("terminal", &self.terminal)
            .finish_non_exhaustive()
    }
}

fn check_finite(field: &str, v: &[f64]) -> Result<(), ProblemError> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(ProblemError::NotFinite {
            field: format!("{field}[{i}]"),
            value: v[i],
        }),
        None => Ok(()),
    }
}

fn check_length<M: Model>(field: &'static str, v: &[f64]) -> Result<(), ProblemError> {
    if v.len() != M::DIM {
        return Err(ProblemError::Length {
            field,
            model: M::NAME,
            expected: M::DIM,
            got: v.len(),
            basis: M::BASIS_NAMES.join(", "),
        });
    }
    check_finite(field, v)
}

impl<M: Model> Problem<M> {
    /// A validated problem. `user` holds the model's user parameters in the order of
    /// `M::PARAM_NAMES` (`M::N_USER_PARAM` values: the inertia parameters, the weights, the
    /// constraint parameters); the derived constants (`𝕀⁻¹` of a non-diagonal inertia) are
    /// filled here.
    pub fn new(
        user: &[f64],
        t0: f64,
        omega_a: Vec<f64>,
        omega_b: Vec<f64>,
        terminal: TerminalTime,
        desired: Arc<dyn Path>,
    ) -> Result<Self, ProblemError> {
        if user.len() != M::N_USER_PARAM {
            return Err(ProblemError::Length {
                field: "parameters",
                model: M::NAME,
                expected: M::N_USER_PARAM,
                got: user.len(),
                basis: M::PARAM_NAMES[..M::N_USER_PARAM].join(", "),
            });
        }
        for meta in Self::user_metas() {
            let value = user[meta.index];
            if !meta.admits(value) {
                if !value.is_finite() {
                    return Err(ProblemError::NotFinite {
                        field: meta.name.to_string(),
                        value,
                    });
                }
                return Err(ProblemError::Parameter {
                    name: meta.name,
                    value,
                    doc: meta.doc,
                });
            }
        }
        let mut params = vec![0.0; M::N_PARAM];
        params[..M::N_USER_PARAM].copy_from_slice(user);
        fill_derived::<M>(&mut params)?;
        for (field, value) in [("t0", t0), ("terminal_time", terminal.initial())] {
            if !value.is_finite() {
                return Err(ProblemError::NotFinite {
                    field: field.to_string(),
                    value,
                });
            }
        }
        check_length::<M>("omega_a", &omega_a)?;
        check_length::<M>("omega_b", &omega_b)?;
        if desired.dim() != M::DIM {
            return Err(ProblemError::DesiredDimension {
                model: M::NAME,
                expected: M::DIM,
                got: desired.dim(),
            });
        }
        let b = terminal.initial();
        if b <= t0 {
            return Err(ProblemError::EmptyInterval { t0, b });
        }
        let problem = Self {
            params,
            t0,
            omega_a,
            omega_b,
            terminal,
            desired,
            model: PhantomData,
        };
        if problem.omega_a.iter().all(|x| *x == 0.0) {
            return Err(ProblemError::ZeroOmegaA);
        }
        let conserves_energy = problem.conserves_energy();
        if !conserves_energy && problem.omega_b.iter().all(|x| *x == 0.0) {
            return Err(ProblemError::ZeroOmegaB {
                names: M::CONSTRAINT_PARAMS
                    .iter()
                    .map(|m| format!("{} = {}", m.name, problem.params[m.index]))
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
        let set = LevelSet::through(&problem.inertia_matrix(), M::DIM, &problem.omega_a).map_err(
            |e| match e {
                PathError::LevelOutOfRange { level, .. } => {
                    ProblemError::EnergyOutOfRange { level }
                }
                other => ProblemError::Path(other),
            },
        )?;
        let mismatch = set.relative_mismatch(&problem.omega_b);
        let on_level_set = mismatch.abs() <= ENERGY_REL_TOL; // false for NaN
        if conserves_energy && !on_level_set {
            let projection = set
                .project(&problem.omega_b)
                .unwrap_or_else(|_| vec![f64::NAN; M::DIM]);
            return Err(ProblemError::OffLevelSet {
                omega_b: problem.omega_b.clone(),
                mismatch,
                projection,
            });
        }
        Ok(problem)
    }

    /// The metadata of every user parameter (inertia, weights, constraint), in `p`'s order.
    pub fn user_metas() -> impl Iterator<Item = &'static ParamMeta> {
        M::INERTIA_PARAMS
            .iter()
            .chain(M::WEIGHTS)
            .chain(M::CONSTRAINT_PARAMS)
    }

    /// The constants `p` (layout `M::PARAM_NAMES`, derived constants filled).
    pub fn params(&self) -> &[f64] {
        &self.params
    }

    /// The user parameters (the first `M::N_USER_PARAM` constants).
    pub fn user_params(&self) -> &[f64] {
        &self.params[..M::N_USER_PARAM]
    }

    /// The value of the user parameter `name`, if the model has one.
    pub fn param(&self, name: &str) -> Option<f64> {
        Self::user_metas()
            .find(|m| m.name == name)
            .map(|m| self.params[m.index])
    }

    /// Set the weight or constraint parameter at `index` (an index into `p`) to `value`
    /// (homotopy snapshots; the derived constants depend on the inertia only).
    pub(crate) fn set_weight(&mut self, index: usize, value: f64) {
        debug_assert!(M::WEIGHTS
            .iter()
            .chain(M::CONSTRAINT_PARAMS)
            .any(|w| w.index == index));
        self.params[index] = value;
    }

    /// Whether the kinetic energy is conserved: the constraint value vanishes for these
    /// constants ([`crate::model::constraint_value_vanishes`]). Then `Ω_b` is on the level set
    /// of `Ω_a`; otherwise the energy balances as `Ṫ = λγ`.
    pub fn conserves_energy(&self) -> bool {
        crate::model::constraint_value_vanishes::<M>(&self.params)
    }

    /// The inertia operator `𝕀` (row-major `n × n`).
    pub fn inertia_matrix(&self) -> Vec<f64> {
        let mut out = vec![0.0; M::DIM * M::DIM];
        M::inertia_matrix(&self.params, &mut out);
        out
    }

    /// The energy level set through `Ω_a`.
    pub fn level_set(&self) -> LevelSet {
        LevelSet::through(&self.inertia_matrix(), M::DIM, &self.omega_a)
            .expect("validated by Problem::new: finite, nonzero, representable level")
    }
}

/// Index of `T = b − a` among the BVP's unknown parameters (free terminal time only).
pub const SPAN: usize = 0;

/// Largest dimension whose per-point buffers live on the stack (larger models use the heap).
const STACK_DIM: usize = 16;

/// Run `f` on a zeroed scratch buffer of `len` entries, on the stack when small.
pub(crate) fn with_buffer<R>(len: usize, f: impl FnOnce(&mut [f64]) -> R) -> R {
    if len <= 4 * STACK_DIM {
        let mut buf = [0.0; 4 * STACK_DIM];
        f(&mut buf[..len])
    } else {
        f(&mut vec![0.0; len])
    }
}

/// The BVP of a [`Problem`] on normalized time `s ∈ [0, 1]`, for given constants (which
/// continuation changes) and a fixed or unknown `T = b − a`.
pub struct LieBvp<'a, M: Model> {
    /// The constants `p` (layout `M::PARAM_NAMES`).
    pub params: Vec<f64>,
    /// `Ω(a)`.
    pub omega_a: &'a [f64],
    /// `Ω(b)` (owned: the constraint stage of the homotopy moves it).
    pub omega_b: Vec<f64>,
    /// `a`.
    pub t0: f64,
    /// `Some(T)` for a fixed terminal time, `None` when `T` is the unknown parameter.
    pub fixed_span: Option<f64>,
    /// `Ω_d`.
    pub desired: &'a dyn Path,
    /// Whether the start imposes `φ(a) = 0` with the multiplier `μ` (module docs): true
    /// exactly when the constraint value does not vanish.
    pub start_constraint: bool,
    /// With the start constraint: impose `φ(a) = −level_shift` instead, i.e. the constraint
    /// level `⟨Ω, ξ⟩ = γ − level_shift` (0 but in the homotopy's constraint stage,
    /// [`super::solve`](mod@super::solve)).
    pub level_shift: f64,
    /// The model.
    pub model: PhantomData<M>,
}

impl<'a, M: Model> LieBvp<'a, M> {
    /// The BVP of `problem` with its own weights and terminal-time mode.
    pub fn new(problem: &'a Problem<M>) -> Self {
        let fixed_span = match problem.terminal {
            TerminalTime::Fixed(b) => Some(b - problem.t0),
            TerminalTime::Free { .. } => None,
        };
        Self {
            params: problem.params.clone(),
            omega_a: &problem.omega_a,
            omega_b: problem.omega_b.clone(),
            t0: problem.t0,
            fixed_span,
            desired: &*problem.desired,
            start_constraint: !problem.conserves_energy(),
            level_shift: 0.0,
            model: PhantomData,
        }
    }

    fn span(&self, p: &[f64]) -> f64 {
        self.fixed_span.unwrap_or_else(|| p[SPAN])
    }

    /// Index of `T` among the unknown parameters (free terminal time only).
    pub fn span_index(&self) -> Option<usize> {
        self.fixed_span.is_none().then_some(SPAN)
    }

    /// Index of the start multiplier `μ` among the unknown parameters (with the start
    /// constraint only; module docs).
    pub fn mu_index(&self) -> Option<usize> {
        self.start_constraint
            .then_some(usize::from(self.fixed_span.is_none()))
    }

    /// The unknown parameters `[T?, μ?]` from their values.
    pub fn parameters(&self, t_span: f64, mu: f64) -> Vec<f64> {
        let mut p = vec![0.0; self.k()];
        if let Some(i) = self.span_index() {
            p[i] = t_span;
        }
        if let Some(i) = self.mu_index() {
            p[i] = mu;
        }
        p
    }

    /// Number of boundary conditions at `a`.
    fn n_bc_start(&self) -> usize {
        M::N_BC_ENDPOINT + usize::from(self.start_constraint)
    }

    /// Writes `w = [Ω_d(t), Ω̇_d(t)]` (`M::N_DESIRED` entries) into `w`.
    pub fn desired_at(&self, t: f64, w: &mut [f64]) {
        with_buffer(4 * M::DIM, |jet| {
            self.desired.jet_into(t, jet);
            w.copy_from_slice(&jet[..M::N_DESIRED]);
        });
    }
}

impl<M: Model> BvpProblem for LieBvp<'_, M> {
    fn n(&self) -> usize {
        M::N_STATE
    }

    fn k(&self) -> usize {
        usize::from(self.fixed_span.is_none()) + usize::from(self.start_constraint)
    }

    fn f(&self, s: f64, y: &[f64], p: &[f64], dy: &mut [f64]) {
        let t_span = self.span(p);
        with_buffer(M::N_DESIRED, |w| {
            self.desired_at(self.t0 + s * t_span, w);
            M::ode_rhs_scaled(y, &self.params, w, t_span, dy);
        });
    }

    fn jac(&self, s: f64, y: &[f64], p: &[f64], dfdy: &mut [f64], dfdp: &mut [f64]) -> bool {
        let t_span = self.span(p);
        with_buffer(M::N_DESIRED + M::N_STATE, |buf| {
            let (w, dgdt) = buf.split_at_mut(M::N_DESIRED);
            self.desired_at(self.t0 + s * t_span, w);
            M::ode_jac_scaled(y, &self.params, w, t_span, s, dfdy, dgdt);
            // `dfdp` is n x k, row-major: the T column (free time), and 0 for μ (the ODE does
            // not contain it).
            dfdp.fill(0.0);
            if let Some(j) = self.span_index() {
                let k = self.k();
                for (row, d) in dgdt.iter().enumerate() {
                    dfdp[row * k + j] = *d;
                }
            }
        });
        true
    }

    fn bc(&self, ya: &[f64], yb: &[f64], p: &[f64], res: &mut [f64]) {
        // Rows: the conditions at a (N_BC_ENDPOINT, plus phi(a) = 0 with a constraint value),
        // N_BC_ENDPOINT at b, then the free-time condition.
        let (at_a, rest) = res.split_at_mut(self.n_bc_start());
        let (at_b, free_time) = rest.split_at_mut(M::N_BC_ENDPOINT);
        match self.mu_index() {
            Some(i) => {
                M::bc_start_constrained(ya, &self.params, self.omega_a, p[i], at_a);
                at_a[M::N_BC_ENDPOINT] += self.level_shift; // the row φ(a)
            }
            None => M::bc_endpoint(ya, &self.params, self.omega_a, at_a),
        }
        M::bc_endpoint(yb, &self.params, &self.omega_b, at_b);
        if self.fixed_span.is_none() {
            with_buffer(M::N_DESIRED, |wb| {
                self.desired_at(self.t0 + p[SPAN], wb);
                free_time[0] = M::free_time_condition(yb, &self.params, wb);
            });
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
        let (n, nb, na, k) = (M::N_STATE, M::N_BC_ENDPOINT, self.n_bc_start(), self.k());
        dya.fill(0.0);
        dyb.fill(0.0);
        dp.fill(0.0);
        // Row-major: rows 0..na are the conditions at a, na..na + nb those at b.
        match self.mu_index() {
            Some(i) => with_buffer(na, |d_mu| {
                M::bc_start_constrained_jac(
                    ya,
                    &self.params,
                    self.omega_a,
                    p[i],
                    &mut dya[..na * n],
                    d_mu,
                );
                for (row, d) in d_mu.iter().enumerate() {
                    dp[row * k + i] = *d;
                }
            }),
            None => M::bc_endpoint_jac(ya, &self.params, self.omega_a, &mut dya[..na * n]),
        }
        M::bc_endpoint_jac(
            yb,
            &self.params,
            &self.omega_b,
            &mut dyb[na * n..(na + nb) * n],
        );
        if self.fixed_span.is_none() {
            let row = na + nb;
            with_buffer(M::N_DESIRED, |wb| {
                self.desired_at(self.t0 + p[SPAN], wb);
                // `dp` is (n + k) x k, row-major.
                dp[row * k + SPAN] = M::free_time_condition_jac(
                    yb,
                    &self.params,
                    wb,
                    &mut dyb[row * n..(row + 1) * n],
                );
            });
        }
        true
    }
}
