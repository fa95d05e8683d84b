//! The multiplier form of a model's control problem: the constraint force's multiplier `λ` a
//! control, the constraint a path constraint.
//!
//! # Why
//!
//! The classical form of [`super::certify::LieOcp`] eliminates `λ` (Suslov's `Ω̇ = F(Ω, ξ,
//! ξ̇)`), which divides by `⟨ξ, 𝕀⁻¹ξ⟩`: it is singular where `ξ` vanishes, and a direct
//! method on it cannot pass through or near `ξ = 0`. Many corpus problems have regular minima
//! that are reached only past such regions, and many have an infimum that is approached as
//! `ξ → 0` ([`super::collapse`], docs/collapse.md). Here nothing divides:
//!
//! ```text
//! state x = [Ω, ξ],   control u = [ξ̇, λ],   z = [Ω, ξ, ξ̇, λ]
//! Ω̇ = 𝕀⁻¹(ad*_Ω 𝕀Ω + λ ξ),   ξ̇ = u_ξ,
//! path: g(z) = 0 at every collocation point, running cost C(Ω, Ω̇, ξ, ξ̇, Ω_d(t)),
//! ```
//!
//! with `g` one of the two [`PathForm`]s. All derivatives, to second order, are generated from
//! the model file (`multiplier_dynamics`, `multiplier_cost`, `multiplier_hessian`;
//! `codegen/derive.py`, `MultiplierTranscription`), as the independent direct method
//! `bench/casadi_direct.py` formulates the problem.

use std::marker::PhantomData;

use crate::model::Model;
use crate::ocp::{self, Boundary, Horizon, LinearCondition, OcpProblem, Transcription};

use super::path::Path;
use super::problem::{with_buffer, Problem, TerminalTime};

/// Which form of the constraint the transcription imposes at every point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PathForm {
    /// `φ(Ω, ξ) = ⟨Ω, ξ⟩ − γ(ξ) = 0` at every point (an index-2 DAE, as in
    /// `bench/casadi_direct.py`); at `a` it is the start condition.
    Constraint,
    /// `d/dt φ = 0` at every point and `φ(a) = 0` at the start (index 1; the collocation
    /// polynomial then keeps `φ` only to the discretization error).
    Derivative,
}

impl PathForm {
    /// The generated path-constraint row this form uses (of `[φ, d/dt φ]`).
    fn row(self) -> usize {
        match self {
            PathForm::Constraint => 0,
            PathForm::Derivative => 1,
        }
    }
}

/// The multiplier form of a model's problem (module docs).
pub struct MultiplierOcp<'a, M: Model> {
    params: &'a [f64],
    desired: &'a dyn Path,
    form: PathForm,
    model: PhantomData<M>,
}

impl<'a, M: Model> MultiplierOcp<'a, M> {
    /// The multiplier form of `problem` (its constants and desired path).
    pub fn for_problem(problem: &'a Problem<M>, form: PathForm) -> Self {
        Self {
            params: problem.params(),
            desired: &*problem.desired,
            form,
            model: PhantomData,
        }
    }

    /// `x = [Ω, ξ]`.
    pub const NX: usize = M::XIDOT.start;
    /// `u = [ξ̇, λ]`.
    pub const NU: usize = M::DIM + 1;
    /// `z = [x, u]`.
    pub const NZ: usize = M::KAPPA.start + 1;
    /// The index of `λ` in `z`.
    pub const LAMBDA: usize = M::KAPPA.start;

    /// `[Ω̇]` and the path rows at `z` (buffers of the generated function).
    fn eval(&self, z: &[f64], f: &mut [f64], f_z: &mut [f64], g: &mut [f64], g_z: &mut [f64]) {
        M::multiplier_dynamics(z, self.params, f, f_z, g, g_z);
    }

    /// The multiplier `λ` that makes `Ω̇ = 𝕀⁻¹(ad*_Ω 𝕀Ω + λ ξ)` closest to `omega_dot` (in the
    /// Euclidean norm; exact when `omega_dot` is a motion of Suslov's equations driven by `ξ`).
    /// `z` holds `[Ω, ξ, ξ̇, ·]`; its `λ` entry is overwritten.
    pub fn fit_lambda(&self, z: &mut [f64], omega_dot: &[f64]) {
        let (n, nx, nz) = (M::DIM, Self::NX, Self::NZ);
        with_buffer(2 * nx + nx * nz + 2 + 2 * nz, |buf| {
            let (f0, rest) = buf.split_at_mut(nx);
            let (f1, rest) = rest.split_at_mut(nx);
            let (f_z, rest) = rest.split_at_mut(nx * nz);
            let (g, g_z) = rest.split_at_mut(2);
            z[Self::LAMBDA] = 0.0;
            self.eval(z, f0, f_z, g, g_z);
            z[Self::LAMBDA] = 1.0;
            self.eval(z, f1, f_z, g, g_z);
            let (mut num, mut den) = (0.0, 0.0);
            for i in 0..n {
                let d = f1[i] - f0[i];
                num += d * (omega_dot[i] - f0[i]);
                den += d * d;
            }
            z[Self::LAMBDA] = if den > 0.0 { num / den } else { 0.0 };
        });
    }
}

impl<M: Model> OcpProblem for MultiplierOcp<'_, M> {
    fn n_state(&self) -> usize {
        Self::NX
    }

    fn n_control(&self) -> usize {
        Self::NU
    }

    fn dynamics(&self, _t: f64, z: &[f64], f: &mut [f64], f_z: &mut [f64], f_t: &mut [f64]) {
        let nz = Self::NZ;
        with_buffer(2 + 2 * nz, |buf| {
            let (g, g_z) = buf.split_at_mut(2);
            self.eval(z, f, f_z, g, g_z);
        });
        f_t.fill(0.0); // Suslov's equations are autonomous.
    }

    fn running_cost(&self, t: f64, z: &[f64], l_z: &mut [f64]) -> (f64, f64) {
        let n = M::DIM;
        with_buffer(4 * n + n, |buf| {
            let (jet, l_d) = buf.split_at_mut(4 * n);
            self.desired.jet_into(t, jet);
            let l = M::multiplier_cost(z, self.params, &jet[..n], l_z, l_d);
            let l_t = l_d.iter().zip(&jet[n..2 * n]).map(|(l, d)| l * d).sum();
            (l, l_t)
        })
    }

    fn n_path(&self) -> usize {
        1
    }

    fn path(&self, _t: f64, z: &[f64], g: &mut [f64], g_z: &mut [f64], g_t: &mut [f64]) {
        let (nx, nz, row) = (Self::NX, Self::NZ, self.form.row());
        let mut gg = [0.0; 2];
        with_buffer(nx + nx * nz + 2 * nz, |buf| {
            let (f, rest) = buf.split_at_mut(nx);
            let (f_z, gg_z) = rest.split_at_mut(nx * nz);
            self.eval(z, f, f_z, &mut gg, gg_z);
            g[0] = gg[row];
            g_z.copy_from_slice(&gg_z[row * nz..(row + 1) * nz]);
        });
        g_t[0] = 0.0;
    }

    fn lagrangian_hessian(&self, t: f64, z: &[f64], w: f64, lambda: &[f64], h: &mut [f64]) {
        let (n, nx, nz) = (M::DIM, Self::NX, Self::NZ);
        let mut jet = vec![0.0; 4 * n];
        self.desired.jet_into(t, &mut jet);
        let od = &jet[..n];
        let mut mu = [0.0; 2];
        mu[self.form.row()] = lambda[nx];
        let mut h_zz = vec![0.0; nz * nz];
        let mut h_zd = vec![0.0; nz * n];
        let mut h_dd = vec![0.0; n * n];
        M::multiplier_hessian(
            z,
            self.params,
            od,
            w,
            &lambda[..nx],
            &mu,
            &mut h_zz,
            &mut h_zd,
            &mut h_dd,
        );
        let mut lz = vec![0.0; nz];
        let mut ld = vec![0.0; n];
        M::multiplier_cost(z, self.params, od, &mut lz, &mut ld);
        super::certify::with_time(nz, n, &h_zz, &h_zd, &h_dd, w, &ld, &jet, h);
    }
}

/// The transcription of `p`'s multiplier form on the normalized `mesh`: `Ω(a) = Ω_a`,
/// `Ω(b) = Ω_b`, `ξ` free at both ends, and for [`PathForm::Derivative`] the start condition
/// `⟨Ω_a, ξ(a)⟩ = γ` (linear in `ξ(a)`: the caller refuses a `γ` that depends on `ξ`).
pub fn transcription_on<'a, M: Model>(
    ocp_problem: &'a MultiplierOcp<'a, M>,
    p: &Problem<M>,
    mesh: Vec<f64>,
) -> Result<Transcription<'a, MultiplierOcp<'a, M>>, ocp::TranscriptionError> {
    let start_linear = match ocp_problem.form {
        PathForm::Constraint => vec![],
        PathForm::Derivative => {
            let gamma = crate::model::constant_constraint_value::<M>(p.params());
            vec![LinearCondition {
                coefficients: M::OMEGA.map(|i| (M::XI.start + i, p.omega_a[i])).collect(),
                value: gamma,
            }]
        }
    };
    let boundary = Boundary {
        start: M::OMEGA.map(|i| (i, p.omega_a[i])).collect(),
        end: M::OMEGA.map(|i| (i, p.omega_b[i])).collect(),
        start_linear,
        end_linear: vec![],
    };
    let horizon = match p.terminal {
        TerminalTime::Fixed(b) => Horizon::Fixed {
            t0: p.t0,
            length: b - p.t0,
        },
        TerminalTime::Free { .. } => Horizon::Free { t0: p.t0 },
    };
    Transcription::new(ocp_problem, boundary, horizon, mesh)
}
