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
//! path: φ(Ω, ξ) = ⟨Ω, ξ⟩ − γ(ξ) = 0 at every collocation point (an index-2 DAE; at `a` it
//! is the start condition), running cost C(Ω, Ω̇, ξ, ξ̇, Ω_d(t)),
//! ```
//!
//! All derivatives, to second order, are generated from
//! the model file (`multiplier_dynamics`, `multiplier_cost`, `multiplier_hessian`;
//! `codegen/derive.py`, `MultiplierTranscription`), as the independent direct method
//! `bench/casadi_direct.py` formulates the problem.

use std::marker::PhantomData;

use crate::model::Model;
use crate::ocp::{self, OcpProblem, Transcription};

use super::path::Path;
use super::problem::{with_buffer, Problem};

/// The multiplier form of a model's problem (module docs).
pub struct MultiplierOcp<'a, M: Model> {
    params: &'a [f64],
    desired: &'a dyn Path,
    model: PhantomData<M>,
}

impl<'a, M: Model> MultiplierOcp<'a, M> {
    /// The multiplier form of `problem` (its constants and desired path).
    pub fn for_problem(problem: &'a Problem<M>) -> Self {
        Self {
            params: problem.params(),
            desired: &*problem.desired,
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
        with_buffer(2 * nx + nx * nz + 1 + nz, |buf| {
            let (f0, rest) = buf.split_at_mut(nx);
            let (f1, rest) = rest.split_at_mut(nx);
            let (f_z, rest) = rest.split_at_mut(nx * nz);
            let (g, g_z) = rest.split_at_mut(1);
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
        with_buffer(1 + nz, |buf| {
            let (g, g_z) = buf.split_at_mut(1);
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
        let (nx, nz) = (Self::NX, Self::NZ);
        with_buffer(nx + nx * nz, |buf| {
            let (f, f_z) = buf.split_at_mut(nx);
            self.eval(z, f, f_z, g, g_z);
        });
        g_t[0] = 0.0;
    }

    fn lagrangian_hessian(&self, t: f64, z: &[f64], w: f64, lambda: &[f64], h: &mut [f64]) {
        let (n, nx, nz) = (M::DIM, Self::NX, Self::NZ);
        let mut jet = vec![0.0; 4 * n];
        self.desired.jet_into(t, &mut jet);
        let od = &jet[..n];
        let mut h_zz = vec![0.0; nz * nz];
        let mut h_zd = vec![0.0; nz * n];
        let mut h_dd = vec![0.0; n * n];
        M::multiplier_hessian(
            z,
            self.params,
            od,
            w,
            &lambda[..nx],
            &lambda[nx..],
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
/// `Ω(b) = Ω_b`, `ξ` free at both ends (`φ(a) = 0`, the path constraint at the first point,
/// is the start condition).
pub fn transcription_on<'a, M: Model>(
    ocp_problem: &'a MultiplierOcp<'a, M>,
    p: &Problem<M>,
    mesh: Vec<f64>,
) -> Result<Transcription<'a, MultiplierOcp<'a, M>>, ocp::TranscriptionError> {
    // φ(a) = 0 is the path constraint at the first point: no start condition.
    let (boundary, horizon) = super::certify::ends_and_horizon(p, vec![]);
    Transcription::new(ocp_problem, boundary, horizon, mesh)
}
