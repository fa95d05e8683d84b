//! The optimal control problem in classical state/control (Lagrange) form.
//!
//! ```text
//! minimize   J = ∫_{t0}^{t0+T} L(t, x, u) dt
//! subject to x' = f(t, x, u),  g(t, x, u) = 0 (optional path constraints),
//!            x_i(t0) = a_i (i ∈ fixed start components),  x_j(t0 + T) = b_j (j ∈ fixed end),
//!            T fixed or free.
//! ```
//!
//! `n` states, `m` controls; `z = [x, u]` has `nz = n + m` entries. A problem supplies values,
//! first derivatives and the Hessian of the *point Lagrangian* `ℓ = w L + λᵀ f (+ μᵀ g)`; everything
//! else (the discretization, the KKT conditions, the second-order check) is generic.

/// The problem functions. All matrices are row-major slices.
pub trait OcpProblem {
    /// `n`, the number of states.
    fn n_state(&self) -> usize;
    /// `m`, the number of controls.
    fn n_control(&self) -> usize;

    /// The dynamics at time `t`: `f` (`n`), `∂f/∂z` (`n × nz`), `∂f/∂t` (`n`).
    fn dynamics(&self, t: f64, z: &[f64], f: &mut [f64], f_z: &mut [f64], f_t: &mut [f64]);

    /// The running cost at time `t`: returns `(L, ∂L/∂t)` and writes `∂L/∂z` (`nz`).
    fn running_cost(&self, t: f64, z: &[f64], l_z: &mut [f64]) -> (f64, f64);

    /// The Hessian of `ℓ = w L(t, z) + Σ_i λ_i f_i(t, z) + Σ_j μ_j g_j(t, z)` with respect to
    /// `(z, t)`: `(nz + 1) × (nz + 1)`, symmetric, the time derivative last. `lambda` holds
    /// the `n` dynamics multipliers `λ`, then the [`Self::n_path`] path multipliers `μ`.
    fn lagrangian_hessian(&self, t: f64, z: &[f64], w: f64, lambda: &[f64], h: &mut [f64]);

    /// The number of path constraints `g(t, z) = 0`, imposed at every collocation point
    /// (none by default).
    fn n_path(&self) -> usize {
        0
    }

    /// The path constraints at time `t`: `g` (`n_path`), `∂g/∂z` (`n_path × nz`), `∂g/∂t`
    /// (`n_path`). Called only when [`Self::n_path`] is positive.
    fn path(&self, _t: f64, _z: &[f64], _g: &mut [f64], _g_z: &mut [f64], _g_t: &mut [f64]) {}
}

/// The interval: start time and a fixed or free length `T`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Horizon {
    /// `T` fixed.
    Fixed {
        /// Start time `t0`.
        t0: f64,
        /// The length `T > 0`.
        length: f64,
    },
    /// `T` is an unknown of the problem (its value is part of the primal point).
    Free {
        /// Start time `t0`.
        t0: f64,
    },
}

impl Horizon {
    /// The start time.
    pub fn t0(&self) -> f64 {
        match *self {
            Horizon::Fixed { t0, .. } | Horizon::Free { t0 } => t0,
        }
    }

    /// Whether `T` is an unknown.
    pub fn is_free(&self) -> bool {
        matches!(self, Horizon::Free { .. })
    }
}

/// Boundary conditions: prescribed state components at either end, and linear conditions on
/// the start state. The other components are free there.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Boundary {
    /// `(component, value)` pairs prescribed at `t0`.
    pub start: Vec<(usize, f64)>,
    /// `(component, value)` pairs prescribed at `t0 + T`.
    pub end: Vec<(usize, f64)>,
    /// Linear conditions `Σ cᵢ x_i(t0) = value` on the start state (e.g. a constraint level
    /// `⟨Ω_a, ξ(t0)⟩ = c` once `Ω(t0)` is prescribed).
    pub start_linear: Vec<LinearCondition>,
    /// Linear conditions `Σ cᵢ x_i(t0 + T) = value` on the end state (e.g. the components of
    /// `Ω(b) − Ω_b` tangent to a level set that the dynamics conserve).
    pub end_linear: Vec<LinearCondition>,
}

/// A linear condition `Σ coefficient · x_component = value` on a state.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LinearCondition {
    /// `(component, coefficient)` pairs.
    pub coefficients: Vec<(usize, f64)>,
    /// The right-hand side.
    pub value: f64,
}
