//! Second-order certificate of a computed Suslov solution (a local minimum, or not).
//!
//! The paper could only argue that its extremals are minima by re-solving them with direct
//! methods, and left the second-order sufficient conditions for future work. Here the
//! argument is made exact for the discretized problem:
//!
//! 1. **The direct problem.** Suslov's OCP in classical form ([`SuslovOcp`]): state
//!    `x = [Ω, ξ]`, control `u = ξ̇`, dynamics `Ω̇ = F(Ω, ξ, ξ̇)`, `ξ̇ = u`, running cost
//!    `C(Ω, F, ξ, ξ̇, Ω_d(t))`, `Ω(a) = Ω_a`, `Ω(b) = Ω_b`, `ξ` free at both ends, `b` fixed or
//!    free. All derivatives, to second order, are generated from `codegen/models/so3.py`
//!    (`direct_dynamics`, `direct_cost`, `direct_hessian`).
//! 2. **Transcription on the solution's own mesh** with the solver's collocation (4-stage
//!    Lobatto IIIA; [`crate::ocp::transcription`]).
//! 3. **KKT.** The indirect solution, sampled at the collocation points, with least-squares
//!    multipliers: its KKT residual measures how far it is from a KKT point of the
//!    discretized problem (discretization error: the indirect and direct discretizations are
//!    different). Newton's method on the KKT system moves it to the exact KKT point nearby;
//!    the displacement is reported. The discrete multipliers, read as costates
//!    (`λ_p/ω_p`), are compared with the classical costates `π` computed from the solution's
//!    `κ` (`classical_costates`): the multipliers *are* κ, up to discretization error.
//! 4. **Second order** ([`mod@crate::ocp::certify`]): the inertia of the KKT matrix decides
//!    whether the reduced Hessian is positive definite; bisection gives its smallest
//!    eigenvalue in the `∫|δξ̇|² dt + |δξ(a)|² (+ δb²)` metric.

//!
//! # Example
//!
//! ```
//! use std::sync::Arc;
//! use nalgebra::Vector3;
//! use suslov::ocp::{NewtonOptions, SecondOrderOptions, Verdict};
//! use suslov::suslov::certify::certify;
//! use suslov::suslov::{EnergyEllipsoid, Inertia, ProjectedSegment};
//! use suslov::{solve, CostWeights, SolveOptions, SuslovProblem, TerminalTime};
//!
//! let inertia = Inertia::new([1.0, 2.0, 3.0])?;
//! let omega_a = Vector3::new(3.0, 0.0, 0.0);
//! let omega_b = EnergyEllipsoid::through(inertia, &omega_a)?.project(&Vector3::new(1.0, 2.0, 0.0))?;
//! let problem = SuslovProblem {
//!     inertia,
//!     weights: CostWeights { alpha: 1.0, beta: 0.1, gamma: 1.0, eta: 0.1, delta: 0.0 },
//!     t0: 0.0,
//!     omega_a,
//!     omega_b,
//!     terminal: TerminalTime::Fixed(4.0),
//!     desired: Arc::new(ProjectedSegment::new(inertia, omega_a, omega_b, 0.0, 4.0)?),
//! };
//! let solution = solve(&problem, &SolveOptions::default(), &mut |_| {})?;
//! let cert = certify(&solution, &NewtonOptions::default(), &SecondOrderOptions::default())?;
//! assert_eq!(cert.verdict(), Verdict::Certified);
//! let (low, _high) = cert.certificate.second_order.margin.expect("bracketed");
//! assert!(low > 0.0); // δ²L ≥ low · ‖δ‖²_M on the linearized constraints
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::desired::DesiredPath;
use super::problem::{SuslovProblem, TerminalTime};
use super::solve::SuslovSolution;
use crate::model::generated::{self as g, DIM, N_PARAM, N_STATE, OMEGA, XI, XIDOT};
use crate::ocp::{
    self, Boundary, CertifyError, Horizon, NewtonOptions, OcpProblem, SecondOrderOptions,
    Transcription,
};

/// States of the direct form, `x = [Ω, ξ]`.
pub const NX: usize = 2 * DIM;
/// Controls of the direct form, `u = ξ̇`.
pub const NU: usize = DIM;
/// Entries of `z = [x, u] = [Ω, ξ, ξ̇]` (the generated `direct_*` functions' `z`).
pub const NZ: usize = NX + NU;
/// Rows (and columns) of the Hessian with respect to `(z, t)`, the time last.
const NH: usize = NZ + 1;

/// Suslov's optimal control problem in classical state/control form (`n = NX = 2 DIM`,
/// `m = NU = DIM`).
pub struct SuslovOcp<'a> {
    params: [f64; N_PARAM],
    desired: &'a dyn DesiredPath,
}

impl<'a> SuslovOcp<'a> {
    /// The direct form of `problem`.
    pub fn new(problem: &'a SuslovProblem) -> Self {
        Self {
            params: problem.params(),
            desired: &*problem.desired,
        }
    }
}

fn as_z(z: &[f64]) -> &[f64; NZ] {
    z.try_into()
        .expect("the transcription passes nz = NX + NU entries")
}

impl OcpProblem for SuslovOcp<'_> {
    fn n_state(&self) -> usize {
        NX
    }

    fn n_control(&self) -> usize {
        NU
    }

    fn dynamics(&self, _t: f64, z: &[f64], f: &mut [f64], f_z: &mut [f64], f_t: &mut [f64]) {
        let mut ff = [0.0; NX];
        let mut jac = [[0.0; NZ]; NX];
        g::direct_dynamics(as_z(z), &self.params, &mut ff, &mut jac);
        f.copy_from_slice(&ff);
        for (row, out) in jac.iter().zip(f_z.chunks_exact_mut(NZ)) {
            out.copy_from_slice(row);
        }
        f_t.fill(0.0); // Suslov's equations are autonomous.
    }

    fn running_cost(&self, t: f64, z: &[f64], l_z: &mut [f64]) -> (f64, f64) {
        let jet = self.desired.jet(t);
        let od: [f64; DIM] = jet.value.into();
        let mut lz = [0.0; NZ];
        let mut ld = [0.0; DIM];
        let l = g::direct_cost(as_z(z), &self.params, &od, &mut lz, &mut ld);
        l_z.copy_from_slice(&lz);
        // L depends on t only through Ω_d(t).
        let l_t = ld.iter().zip(jet.d1.iter()).map(|(l, d)| l * d).sum();
        (l, l_t)
    }

    fn lagrangian_hessian(&self, t: f64, z: &[f64], w: f64, lambda: &[f64], h: &mut [f64]) {
        let jet = self.desired.jet(t);
        let od: [f64; DIM] = jet.value.into();
        let lam: &[f64; NX] = lambda.try_into().expect("n = NX multipliers");
        let mut h_zz = [[0.0; NZ]; NZ];
        let mut h_zd = [[0.0; DIM]; NZ];
        let mut h_dd = [[0.0; DIM]; DIM];
        g::direct_hessian(
            as_z(z),
            &self.params,
            &od,
            w,
            lam,
            &mut h_zz,
            &mut h_zd,
            &mut h_dd,
        );
        let mut lz = [0.0; NZ];
        let mut ld = [0.0; DIM];
        g::direct_cost(as_z(z), &self.params, &od, &mut lz, &mut ld);
        // Chain rule through Ω_d(t): ℓ_zt = ℓ_zd Ω̇_d, ℓ_tt = Ω̇_dᵀ ℓ_dd Ω̇_d + w L_d Ω̈_d.
        // `h` is NH x NH, row-major, (z, t): rows 0..NZ are [ℓ_zz, ℓ_zt], the last [ℓ_tz, ℓ_tt].
        let d1 = jet.d1;
        let (rows, last) = h.split_at_mut(NZ * NH);
        for (r, row) in rows.chunks_exact_mut(NH).enumerate() {
            let (zz, zt) = row.split_at_mut(NZ);
            zz.copy_from_slice(&h_zz[r]);
            let v: f64 = h_zd[r].iter().zip(d1.iter()).map(|(a, b)| a * b).sum();
            zt[0] = v;
            last[r] = v;
        }
        let mut tt = 0.0;
        for a in 0..DIM {
            tt += w * ld[a] * jet.d2[a];
            for b in 0..DIM {
                tt += d1[a] * h_dd[a][b] * d1[b];
            }
        }
        last[NZ] = tt;
    }
}

pub use crate::lie::certify::{SuslovCertificate, DISPLACEMENT_WARNING};

/// The transcription of `sol`'s problem on `sol`'s mesh.
pub fn transcription<'a>(
    ocp_problem: &'a SuslovOcp<'a>,
    sol: &SuslovSolution,
) -> Result<Transcription<'a, SuslovOcp<'a>>, ocp::TranscriptionError> {
    let p = &sol.problem;
    let boundary = Boundary {
        // Ω is the first block of x = [Ω, ξ].
        start: (0..DIM).map(|i| (i, p.omega_a[i])).collect(),
        end: (0..DIM).map(|i| (i, p.omega_b[i])).collect(),
        start_linear: vec![],
    };
    let horizon = match p.terminal {
        TerminalTime::Fixed(b) => Horizon::Fixed {
            t0: p.t0,
            length: b - p.t0,
        },
        TerminalTime::Free { .. } => Horizon::Free { t0: p.t0 },
    };
    let mut mesh = sol.bvp.x.clone();
    // The BVP mesh is on s ∈ [0, 1]; pin the ends exactly.
    if let Some(last) = mesh.len().checked_sub(1) {
        mesh[0] = 0.0;
        mesh[last] = 1.0;
    }
    Transcription::new(ocp_problem, boundary, horizon, mesh)
}

/// Certify `sol` on its own mesh (see the module docs).
pub fn certify(
    sol: &SuslovSolution,
    newton: &NewtonOptions,
    opts: &SecondOrderOptions,
) -> Result<SuslovCertificate, CertifyError> {
    let ocp_problem = SuslovOcp::new(&sol.problem);
    let tr = transcription(&ocp_problem, sol)?;
    // The indirect solution's own values at the collocation points (the same points: the
    // transcription uses the solver's mesh and Lobatto nodes).
    let values = sol.bvp.collocation_values();
    let mut v0 = Vec::with_capacity(tr.n_var());
    for y in values.chunks_exact(N_STATE) {
        // z = [Ω, ξ, ξ̇] from y = [Ω, ξ, ξ̇, κ].
        for block in [OMEGA, XI, XIDOT] {
            v0.extend_from_slice(&y[block]);
        }
    }
    if tr.length_index().is_some() {
        v0.push(sol.t_span);
    }
    let size = v0.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
    let certificate = ocp::certify(&tr, v0, newton, opts)?;
    // Multipliers against κ: π(t_p) from the indirect solution.
    let t_len = tr.length(&certificate.point.v);
    let omega = tr.quadrature_weights();
    let lam = tr.point_multipliers(&certificate.point.y);
    let bvp = super::problem::SuslovBvp::new(&sol.problem);
    let (mut worst, mut scale) = (0.0_f64, 0.0_f64);
    for p in 0..tr.n_points() {
        let t = tr.point_time(p, sol.t_span);
        let y = sol.state(t);
        let mut pi = [0.0; NX];
        g::classical_costates(&y, &sol.problem.params(), &bvp.desired_at(t), &mut pi);
        for r in 0..NX {
            worst = worst.max((lam[p * NX + r] / omega[p] - pi[r]).abs());
            scale = scale.max(pi[r].abs());
        }
    }
    Ok(SuslovCertificate {
        intervals: tr.n_intervals(),
        costate_mismatch: worst / scale.max(f64::MIN_POSITIVE),
        free_time: tr.horizon().is_free(),
        terminal_time: sol.problem.t0 + t_len,
        cost: tr.objective(&certificate.point.v),
        relative_displacement: certificate.displacement / size,
        weakest: certificate
            .second_order
            .weakest_direction
            .as_ref()
            .map(|dv| tr.profile(&certificate.point.v, dv)),
        certificate,
    })
}
