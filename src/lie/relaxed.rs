//! The relaxed problem: the limit `ξ → 0` of the control problem, whose minimum is the
//! infimum that controls with a vanishing `ξ` approach.
//!
//! # Why
//!
//! When the constraint value vanishes, a control `ξ = ε d(t)` with `⟨Ω, d⟩ = 0` drives any
//! motion on the energy level set, and as `ε → 0` its cost tends to the cost of the motion
//! alone with the control terms at `ξ = ξ̇ = 0` ([`super::collapse`], docs/collapse.md). On
//! many corpus problems the minimizing controls do exactly that: the cost's infimum is
//! approached as `ξ → 0` and no control attains it, so the optimality system (singular at
//! `ξ = 0`) has nothing to converge to. [`super::collapse`] shows such controls costing less
//! than every extremal found; the relaxed problem computes the least of them, which is what
//! a stop should name as the infimum.
//!
//! For a free terminal time `b` is an unknown of the relaxed problem too. It has a minimum
//! over `b` when the cost has a term in `Ω̇` (the paper's `η > 0`: that term grows like
//! `1/(b − a)` as the span shrinks, the time weight and `α/4` like `b − a`); without one, the
//! relaxed cost falls with the span and [`relaxed_minimum`] says so instead.
//!
//! # The formulation
//!
//! In the limit the force `λξ` stays finite (`λ ~ 1/ε`): it becomes a torque `τ` with
//! `⟨Ω, τ⟩ = 0`, otherwise free.
//!
//! ```text
//! state x = Ω,   control u = τ,   z = [Ω, τ]
//! Ω̇ = 𝕀⁻¹(ad*_Ω 𝕀Ω + τ),   path: ⟨Ω, τ⟩ = 0 at every collocation point,
//! running cost C(Ω, Ω̇, ξ = 0, ξ̇ = 0, Ω_d(t)),   Ω(a) = Ω_a,  Ω(b) = Ω_b (along the level set).
//! ```
//!
//! Every derivative, to second order, is generated from the model file (`relaxed_dynamics`,
//! `relaxed_cost`, `relaxed_hessian`; `codegen/derive.py`, `RelaxedTranscription`, which
//! asserts that the dynamics are the multiplier form's with `λξ → τ`).
//! [`relaxed_minimum`] minimizes its transcription with [`crate::ocp::sqp()`] from the
//! projected segment `Ω_a → Ω_b` (τ from its inverse dynamics) on [`RELAXED_INTERVALS`]
//! intervals, then from that minimum's motion on twice as many (their difference estimates
//! the discretization error).
//! [`super::collapse::along_relaxed`] drives the minimum's motion by an admissible control
//! `ξ = ε τ̂` and re-integrates it: that control's cost, not the discrete value, is the upper
//! bound a stop reports; the discrete values show how close it is to the relaxed minimum.
//!
//! With no term of the cost that depends on `Ω̇` (the paper's `η = 0`), the relaxed problem
//! is degenerate: `τ` enters no cost, so the KKT matrix is singular until the SQP's inertia
//! correction regularizes it, and the infimum (a pointwise minimum over the level set, with
//! jumps at the ends) is approached by the discrete minima as the mesh is refined, not
//! attained.

use std::marker::PhantomData;

use crate::model::Model;
use crate::ocp::{self, OcpProblem, SqpOptions, SqpReport, Transcription};

use super::direct::{tangential_end, DirectError};
use super::path::{projected_segment, Path, Projected, Sampled};
use super::problem::{with_buffer, Problem, TerminalTime, ENERGY_REL_TOL};
use std::sync::Arc;

/// Intervals of the coarser of the two relaxed transcriptions.
pub const RELAXED_INTERVALS: usize = 100;

/// Tolerance of the relaxed SQP (relative stationarity and feasibility). The cost a stop
/// reports is not the SQP's but the re-integrated control's along its motion
/// ([`super::collapse::along_relaxed`]), whose accuracy does not hinge on this.
pub const RELAXED_TOLERANCE: f64 = 1e-8;

/// Iteration limit of the relaxed SQP. It runs only for the evidence of a stop. 200 left the
/// corpus problem samples-051 (η = 0, a sampled desired path) without a relaxed minimum: its
/// two levels needed 288 and 678 iterations in a probe.
pub const RELAXED_MAX_ITERATIONS: usize = 1000;

/// The relaxed form of a model's problem (module docs).
pub struct RelaxedOcp<'a, M: Model> {
    params: &'a [f64],
    desired: &'a dyn Path,
    model: PhantomData<M>,
}

impl<'a, M: Model> RelaxedOcp<'a, M> {
    /// The relaxed form of `problem` (its constants and desired path).
    pub fn for_problem(problem: &'a Problem<M>) -> Self {
        Self {
            params: problem.params(),
            desired: &*problem.desired,
            model: PhantomData,
        }
    }

    /// `x = Ω`.
    pub const NX: usize = M::DIM;
    /// `z = [Ω, τ]`.
    pub const NZ: usize = 2 * M::DIM;

    /// The torque `τ = 𝕀 (Ω̇ − 𝕀⁻¹ ad*_Ω 𝕀Ω)` that drives `Ω̇` at `Ω` (exact: the dynamics are
    /// affine in `τ`); `z` holds `[Ω, ·]`, its `τ` entries are overwritten.
    pub fn fit_tau(&self, z: &mut [f64], omega_dot: &[f64]) {
        let n = M::DIM;
        let (nx, nz) = (Self::NX, Self::NZ);
        with_buffer(nx + nx * nz + 1 + nz + n * n, |buf| {
            let (f0, rest) = buf.split_at_mut(nx);
            let (f_z, rest) = rest.split_at_mut(nx * nz);
            let (g, rest) = rest.split_at_mut(1);
            let (g_z, inertia) = rest.split_at_mut(nz);
            z[n..].fill(0.0);
            M::relaxed_dynamics(z, self.params, f0, f_z, g, g_z);
            M::inertia_matrix(self.params, inertia);
            for i in 0..n {
                z[n + i] = (0..n)
                    .map(|j| inertia[i * n + j] * (omega_dot[j] - f0[j]))
                    .sum();
            }
        });
    }
}

impl<M: Model> OcpProblem for RelaxedOcp<'_, M> {
    fn n_state(&self) -> usize {
        Self::NX
    }

    fn n_control(&self) -> usize {
        M::DIM
    }

    fn dynamics(&self, _t: f64, z: &[f64], f: &mut [f64], f_z: &mut [f64], f_t: &mut [f64]) {
        let nz = Self::NZ;
        with_buffer(1 + nz, |buf| {
            let (g, g_z) = buf.split_at_mut(1);
            M::relaxed_dynamics(z, self.params, f, f_z, g, g_z);
        });
        f_t.fill(0.0); // autonomous
    }

    fn running_cost(&self, t: f64, z: &[f64], l_z: &mut [f64]) -> (f64, f64) {
        let n = M::DIM;
        with_buffer(5 * n, |buf| {
            let (jet, l_d) = buf.split_at_mut(4 * n);
            self.desired.jet_into(t, jet);
            let l = M::relaxed_cost(z, self.params, &jet[..n], l_z, l_d);
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
            M::relaxed_dynamics(z, self.params, f, f_z, g, g_z);
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
        M::relaxed_hessian(
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
        M::relaxed_cost(z, self.params, od, &mut lz, &mut ld);
        super::certify::with_time(nz, n, &h_zz, &h_zd, &h_dd, w, &ld, &jet, h);
    }
}

/// One discrete relaxed minimum.
#[derive(Debug, Clone)]
pub struct RelaxedLevel {
    /// Intervals of its mesh.
    pub intervals: usize,
    /// Its discrete cost.
    pub cost: f64,
    /// The SQP's iterations.
    pub report: SqpReport,
    /// The collocation points' times.
    pub times: Vec<f64>,
    /// `Ω` at the collocation points, one row each.
    pub omegas: Vec<Vec<f64>>,
    /// `b − a` (the problem's, or the minimum's for a free terminal time).
    pub span: f64,
}

/// The relaxed minimum of a problem (module docs).
#[derive(Debug, Clone)]
pub struct RelaxedMinimum {
    /// On [`RELAXED_INTERVALS`] intervals.
    pub coarse: RelaxedLevel,
    /// On twice as many.
    pub fine: RelaxedLevel,
}

/// Why no relaxed minimum was computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RelaxedError {
    /// The constraint value does not vanish: `ξ → 0` is not admissible.
    #[error("the constraint value is not zero: xi -> 0 is not admissible")]
    ConstraintValue,
    /// A free terminal time and no term of the cost in `Ω̇`: the relaxed cost of a motion
    /// falls with its span, so its minimum over `b` is at `b → a` (the span scan of the
    /// projected segment, [`super::collapse::best_span`], shows how it falls).
    #[error(
        "a free terminal time without a cost term in Omega': the relaxed cost falls with b - a, \
         no relaxed minimum over b"
    )]
    FreeTimeWithoutRate,
    /// The free terminal time's minimum ran to a span that is not positive.
    #[error("the relaxed minimum's span b - a = {span:e} is not positive")]
    Span {
        /// `b − a`.
        span: f64,
    },
    /// The start, the transcription or the SQP.
    #[error("{0}")]
    Direct(#[from] DirectError),
}

/// Whether the relaxed running cost of `problem` depends on `τ`, i.e. on `Ω̇` (the paper's
/// `η > 0`): its Hessian's `τ` block at `[Ω_a, 0]` is not zero. The cost is a polynomial of
/// degree 2 in `Ω̇` in every model, so one point decides.
pub fn has_rate_term<M: Model>(problem: &Problem<M>) -> bool {
    let (n, nz) = (M::DIM, RelaxedOcp::<M>::NZ);
    let mut z = vec![0.0; nz];
    z[..n].copy_from_slice(&problem.omega_a);
    let mut jet = vec![0.0; 4 * n];
    problem.desired.jet_into(problem.t0, &mut jet);
    let mut h_zz = vec![0.0; nz * nz];
    let mut h_zd = vec![0.0; nz * n];
    let mut h_dd = vec![0.0; n * n];
    M::relaxed_hessian(
        &z,
        problem.params(),
        &jet[..n],
        1.0,
        &vec![0.0; n],
        &[0.0],
        &mut h_zz,
        &mut h_zd,
        &mut h_dd,
    );
    (n..nz).any(|i| (n..nz).any(|j| h_zz[i * nz + j] != 0.0))
}

/// The relaxed minimum of `problem` (vanishing constraint value; module docs). For a free
/// terminal time `b` is an unknown too, started from the problem's guess; that needs a cost
/// term in `Ω̇` ([`has_rate_term`]), without which the relaxed cost falls as `b → a`.
pub fn relaxed_minimum<M: Model>(problem: &Problem<M>) -> Result<RelaxedMinimum, RelaxedError> {
    relaxed_minimum_from(problem, problem.terminal.initial() - problem.t0)
}

/// [`relaxed_minimum`], for a free terminal time started from the span `b − a = span` (for a
/// fixed one `span` is ignored). The relaxed cost need not be convex in the span: on the
/// paper's η = 1 problem, started from its guess b_p − a = 12, the SQP stops at a local
/// minimum at b − a = 10.93 (J = 17.757), above the projected segment's control at
/// b − a = 1.42 (J = 9.4245).
pub fn relaxed_minimum_from<M: Model>(
    problem: &Problem<M>,
    span: f64,
) -> Result<RelaxedMinimum, RelaxedError> {
    if !problem.conserves_energy() {
        return Err(RelaxedError::ConstraintValue);
    }
    if matches!(problem.terminal, TerminalTime::Free { .. }) && !has_rate_term(problem) {
        return Err(RelaxedError::FreeTimeWithoutRate);
    }
    let span = match problem.terminal {
        TerminalTime::Fixed(b) => b - problem.t0,
        TerminalTime::Free { .. } => span,
    };
    let start = projected_segment(
        &problem.level_set(),
        &problem.omega_a,
        &problem.omega_b,
        problem.t0,
        problem.t0 + span,
        ENERGY_REL_TOL,
    )
    .map_err(|e| DirectError::Start(e.to_string()))?;
    let coarse = level(problem, RELAXED_INTERVALS, span, &start)?;
    // The finer mesh starts from the coarse minimum's motion (its spline, on the level set).
    let spline = Sampled::new(&coarse.times, &coarse.omegas)
        .map_err(|e| DirectError::Start(e.to_string()))?;
    let warm = Projected::new(Arc::new(spline), problem.level_set())
        .map_err(|e| DirectError::Start(e.to_string()))?;
    let fine = level(problem, 2 * RELAXED_INTERVALS, coarse.span, &warm)?;
    Ok(RelaxedMinimum { coarse, fine })
}

/// The discrete relaxed minimum on a uniform mesh of `intervals` intervals, from `start`.
fn level<M: Model>(
    problem: &Problem<M>,
    intervals: usize,
    span: f64,
    start: &dyn Path,
) -> Result<RelaxedLevel, RelaxedError> {
    let n = M::DIM;
    let ocp_problem = RelaxedOcp::<M>::for_problem(problem);
    let mesh: Vec<f64> = (0..=intervals)
        .map(|k| k as f64 / intervals as f64)
        .collect();
    let (boundary, horizon) = super::certify::ends_and_horizon(problem, vec![]);
    let tr =
        Transcription::new(&ocp_problem, boundary, horizon, mesh).map_err(DirectError::from)?;
    let tr = tangential_end(problem, tr).map_err(DirectError::from)?;
    let v0 = tr.primal_from_fn(span, |t, z| {
        with_buffer(4 * n, |jet| {
            start.jet_into(t, jet);
            z[..n].copy_from_slice(&jet[..n]);
            ocp_problem.fit_tau(z, &jet[n..2 * n]);
        });
    });
    let options = SqpOptions {
        tolerance: RELAXED_TOLERANCE,
        max_iterations: RELAXED_MAX_ITERATIONS,
        ..SqpOptions::default()
    };
    let (point, report) = ocp::sqp(&tr, v0, &options).map_err(DirectError::from)?;
    let t_len = tr.length(&point.v);
    if t_len.is_nan() || t_len <= 0.0 {
        return Err(RelaxedError::Span { span: t_len });
    }
    let nz = tr.nz();
    let (times, omegas) = point
        .v
        .chunks_exact(nz)
        .take(tr.n_points())
        .enumerate()
        .map(|(p, z)| (tr.point_time(p, t_len), z[..n].to_vec()))
        .unzip();
    Ok(RelaxedLevel {
        intervals,
        cost: tr.objective(&point.v),
        report,
        times,
        omegas,
        span: t_len,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::so3::So3;

    /// The torque fitted to a motion's `Ω̇` drives exactly that `Ω̇`, and, for a motion along
    /// the level set (`⟨𝕀Ω, Ω̇⟩ = 0`), does no work (`⟨Ω, τ⟩ = 0`): the projected segment of
    /// the paper's problem at a few times.
    #[test]
    fn the_fitted_torque_drives_the_motion_and_does_no_work() {
        let problem = crate::so3::paper::problem(0.01).to_generic().unwrap();
        let ocp_problem = RelaxedOcp::<So3>::for_problem(&problem);
        let (n, nz) = (So3::DIM, RelaxedOcp::<So3>::NZ);
        let path = projected_segment(
            &problem.level_set(),
            &problem.omega_a,
            &problem.omega_b,
            0.0,
            2.0,
            ENERGY_REL_TOL,
        )
        .unwrap();
        let mut jet = vec![0.0; 4 * n];
        for t in [0.1, 0.7, 1.3, 1.9] {
            path.jet_into(t, &mut jet);
            let mut z = vec![0.0; nz];
            z[..n].copy_from_slice(&jet[..n]);
            ocp_problem.fit_tau(&mut z, &jet[n..2 * n]);
            let (mut f, mut f_z, mut f_t) = (vec![0.0; n], vec![0.0; n * nz], vec![0.0; n]);
            ocp_problem.dynamics(t, &z, &mut f, &mut f_z, &mut f_t);
            let scale = jet[n..2 * n].iter().fold(1.0_f64, |m, v| m.max(v.abs()));
            for i in 0..n {
                assert!((f[i] - jet[n + i]).abs() < 1e-12 * scale, "t = {t}: {f:?}");
            }
            let (mut g, mut g_z, mut g_t) = (vec![0.0; 1], vec![0.0; nz], vec![0.0; 1]);
            ocp_problem.path(t, &z, &mut g, &mut g_z, &mut g_t);
            let size: f64 = z.iter().map(|v| v * v).sum::<f64>();
            assert!(
                g[0].abs() < 1e-10 * size,
                "t = {t}: <Omega, tau> = {}",
                g[0]
            );
        }
    }
}
