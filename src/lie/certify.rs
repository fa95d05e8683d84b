//! Second-order certificate of a computed solution of any model (a local minimum of the
//! discretized problem, or not).
//!
//! The paper could only argue that its extremals are minima by re-solving them with direct
//! methods, and left the second-order sufficient conditions for future work. Here the
//! argument is made exact for the discretized problem:
//!
//! 1. **The direct problem.** The optimal control problem in classical form ([`LieOcp`]):
//!    state `x = [Ω, ξ]` (`2n`), control `u = ξ̇` (`n`), dynamics `Ω̇ = F(Ω, ξ, ξ̇)`, `ξ̇ = u`,
//!    running cost `C(Ω, F, ξ, ξ̇, Ω_d(t))`, `Ω(a) = Ω_a`, `Ω(b) = Ω_b`, `ξ` free at both ends
//!    (for a nonzero constraint value, the linear start condition `⟨Ω_a, ξ(a)⟩ = γ`), `b`
//!    fixed or free. All derivatives, to second order, are generated from the model file
//!    (`direct_dynamics`, `direct_cost`, `direct_hessian`).
//! 2. **Transcription on the solution's own mesh** with the solver's collocation (4-stage
//!    Lobatto IIIA; [`crate::ocp::transcription`]).
//! 3. **KKT.** The indirect solution, sampled at the collocation points, with the
//!    multipliers its classical costates `π` give (computed from its `κ` by the generated
//!    `classical_costates`; [`crate::ocp::kkt::multipliers_from_costates`]): its KKT residual
//!    measures how far the pair is from a KKT point of the discretized problem
//!    (discretization error: the indirect and direct discretizations are different).
//!    Newton's method on the KKT system moves it to the exact KKT point nearby (one step on
//!    the paper's meshes; from the least-squares multipliers instead where it fails from
//!    these); the displacement is reported. The discrete multipliers it ends with, read as
//!    costates (`λ_p/ω_p`), are compared with `π`: the multipliers *are* κ, up to
//!    discretization error.
//! 4. **Second order** ([`mod@crate::ocp::certify`]): the inertia of the KKT matrix decides
//!    whether the reduced Hessian is positive definite; bisection gives its smallest
//!    eigenvalue in the `∫|δξ̇|² dt + |δξ(a)|² (+ δb²)` metric.
//!
//! # Example
//!
//! ```
//! use std::sync::Arc;
//! use nalgebra::Vector3;
//! use suslov::lie::certify::certify;
//! use suslov::ocp::{NewtonOptions, SecondOrderOptions, Verdict};
//! use suslov::so3::{EnergyEllipsoid, Inertia, ProjectedSegment};
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
//! let cert = certify(&solution.generic, &NewtonOptions::default(), &SecondOrderOptions::default())?;
//! assert_eq!(cert.verdict(), Verdict::Certified);
//! let (low, _high) = cert.certificate.second_order.margin.expect("bracketed");
//! assert!(low > 0.0); // δ²L ≥ low · ‖δ‖²_M on the linearized constraints
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::marker::PhantomData;

use crate::model::Model;
use crate::ocp::{
    self, Boundary, Certificate, CertifyError, Horizon, LinearCondition, NewtonOptions, OcpProblem,
    SecondOrderOptions, Transcription, Verdict,
};

use super::path::Path;
use super::problem::{with_buffer, LieBvp, Problem, TerminalTime};
use super::solve::LieSolution;

/// The certificate of one solution, with the comparison of the multipliers and κ.
#[derive(Debug, Clone)]
pub struct SuslovCertificate {
    /// The generic certificate (KKT residuals, Newton, the second-order test).
    pub certificate: Certificate,
    /// Intervals of the mesh (the solution's own).
    pub intervals: usize,
    /// `max_p |λ_p/ω_p − π(t_p)| / max_p |π(t_p)|`: the discrete multipliers against the
    /// classical costates computed from the indirect solution's κ.
    pub costate_mismatch: f64,
    /// Whether the terminal time was an unknown.
    pub free_time: bool,
    /// `b` of the certified point.
    pub terminal_time: f64,
    /// The cost of the certified point (discrete, Lobatto quadrature).
    pub cost: f64,
    /// `‖v* − v₀‖∞ / max(1, ‖v₀‖∞)`: how far the certified point is from the indirect
    /// solution, relative to its size.
    pub relative_displacement: f64,
    /// Where the weakest (or most negative) direction of the second variation lives in time.
    pub weakest: Option<ocp::transcription::DirectionProfile>,
}

/// Above this relative displacement the certified KKT point is not the computed solution
/// to plotting accuracy, and [`SuslovCertificate::warning`] says so.
pub const DISPLACEMENT_WARNING: f64 = 1e-3;

impl SuslovCertificate {
    /// The verdict.
    pub fn verdict(&self) -> Verdict {
        self.certificate.second_order.verdict
    }

    /// A warning when the verdict is about a point visibly different from the computed
    /// solution (the mesh is too coarse for the discretized problem to represent it).
    pub fn warning(&self) -> Option<String> {
        (self.relative_displacement > DISPLACEMENT_WARNING).then(|| {
            format!(
                "the certified KKT point of the discretized problem is {:.1e} (relative) away from \
                 the computed solution: the mesh ({} intervals) is too coarse for the verdict to \
                 describe it; solve with a smaller tolerance",
                self.relative_displacement, self.intervals
            )
        })
    }
}

/// The direct (classical state/control) form of a model's problem.
pub struct LieOcp<'a, M: Model> {
    params: &'a [f64],
    desired: &'a dyn Path,
    model: PhantomData<M>,
}

impl<'a, M: Model> LieOcp<'a, M> {
    /// The direct problem of `sol`'s problem (its constants and desired path).
    pub fn new(sol: &'a LieSolution<M>) -> Self {
        Self::for_problem(&sol.problem)
    }

    /// The direct problem of `problem` (its constants and desired path).
    pub fn for_problem(problem: &'a Problem<M>) -> Self {
        Self {
            params: problem.params(),
            desired: &*problem.desired,
            model: PhantomData,
        }
    }

    /// `x = [Ω, ξ]`: the state's first two blocks.
    pub const NX: usize = M::XIDOT.start;
    /// `u = ξ̇`.
    pub const NU: usize = M::DIM;
    /// `z = [x, u]`.
    pub const NZ: usize = M::KAPPA.start;
}

impl<M: Model> OcpProblem for LieOcp<'_, M> {
    fn n_state(&self) -> usize {
        Self::NX
    }

    fn n_control(&self) -> usize {
        Self::NU
    }

    fn dynamics(&self, _t: f64, z: &[f64], f: &mut [f64], f_z: &mut [f64], f_t: &mut [f64]) {
        M::direct_dynamics(z, self.params, f, f_z);
        f_t.fill(0.0); // Suslov's equations are autonomous.
    }

    fn running_cost(&self, t: f64, z: &[f64], l_z: &mut [f64]) -> (f64, f64) {
        let n = M::DIM;
        with_buffer(4 * n + n, |buf| {
            let (jet, l_d) = buf.split_at_mut(4 * n);
            self.desired.jet_into(t, jet);
            let l = M::direct_cost(z, self.params, &jet[..n], l_z, l_d);
            let l_t = l_d.iter().zip(&jet[n..2 * n]).map(|(l, d)| l * d).sum();
            (l, l_t)
        })
    }

    fn lagrangian_hessian(&self, t: f64, z: &[f64], w: f64, lambda: &[f64], h: &mut [f64]) {
        let (n, nz) = (M::DIM, Self::NZ);
        let mut jet = vec![0.0; 4 * n];
        self.desired.jet_into(t, &mut jet);
        let od = &jet[..n];
        let mut h_zz = vec![0.0; nz * nz];
        let mut h_zd = vec![0.0; nz * n];
        let mut h_dd = vec![0.0; n * n];
        M::direct_hessian(
            z,
            self.params,
            od,
            w,
            lambda,
            &mut h_zz,
            &mut h_zd,
            &mut h_dd,
        );
        let mut lz = vec![0.0; nz];
        let mut ld = vec![0.0; n];
        M::direct_cost(z, self.params, od, &mut lz, &mut ld);
        with_time(nz, n, &h_zz, &h_zd, &h_dd, w, &ld, &jet, h);
    }
}

/// The `(nz + 1) × (nz + 1)` Hessian of a point Lagrangian `ℓ = w L(z, Ω_d(t)) + …` with
/// respect to `(z, t)`, when `t` enters only through the desired path: from the second
/// derivatives in `(z, Ω_d)` (`h_zz`, `h_zd`, `h_dd`), the cost's gradient `l_d = ∂L/∂Ω_d` and
/// the path's jet `[Ω_d, Ω̇_d, Ω̈_d, …]`:
/// `∂²ℓ/∂z∂t = h_zd Ω̇_d`, `∂²ℓ/∂t² = w ⟨l_d, Ω̈_d⟩ + Ω̇_dᵀ h_dd Ω̇_d`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn with_time(
    nz: usize,
    n: usize,
    h_zz: &[f64],
    h_zd: &[f64],
    h_dd: &[f64],
    w: f64,
    l_d: &[f64],
    jet: &[f64],
    h: &mut [f64],
) {
    let nh = nz + 1;
    let (d1, d2) = (&jet[n..2 * n], &jet[2 * n..3 * n]);
    let (rows, last) = h.split_at_mut(nz * nh);
    for (r, row) in rows.chunks_exact_mut(nh).enumerate() {
        let (zz, zt) = row.split_at_mut(nz);
        zz.copy_from_slice(&h_zz[r * nz..(r + 1) * nz]);
        let v: f64 = h_zd[r * n..(r + 1) * n]
            .iter()
            .zip(d1)
            .map(|(a, b)| a * b)
            .sum();
        zt[0] = v;
        last[r] = v;
    }
    let mut tt = 0.0;
    for a in 0..n {
        tt += w * l_d[a] * d2[a];
        for b in 0..n {
            tt += d1[a] * h_dd[a * n + b] * d1[b];
        }
    }
    last[nz] = tt;
}

/// The transcription of `sol`'s problem on `sol`'s own mesh.
pub fn transcription<'a, M: Model>(
    ocp_problem: &'a LieOcp<'a, M>,
    sol: &LieSolution<M>,
) -> Result<Transcription<'a, LieOcp<'a, M>>, ocp::TranscriptionError> {
    let mut mesh = sol.bvp.x.clone();
    if let Some(last) = mesh.len().checked_sub(1) {
        mesh[0] = 0.0;
        mesh[last] = 1.0;
    }
    transcription_on(ocp_problem, &sol.problem, mesh)
}

/// The transcription of `p` on the normalized `mesh` (`0 = s_0 < … < s_N = 1`).
pub fn transcription_on<'a, M: Model>(
    ocp_problem: &'a LieOcp<'a, M>,
    p: &Problem<M>,
    mesh: Vec<f64>,
) -> Result<Transcription<'a, LieOcp<'a, M>>, ocp::TranscriptionError> {
    // With a nonzero constraint value the start constraint φ(a) = ⟨Ω_a, ξ(a)⟩ − γ = 0 is
    // imposed as in the BVP (super::problem; with a vanishing one it is redundant, and its
    // multiplier not unique); with Ω(a) prescribed it is linear in ξ(a) when γ does not depend
    // on ξ (`certify` refuses the other case).
    let start_linear = if p.conserves_energy() {
        vec![]
    } else {
        vec![start_level(p)]
    };
    let (boundary, horizon) = ends_and_horizon(p, start_linear);
    Transcription::new(ocp_problem, boundary, horizon, mesh)
}

/// The start condition `⟨Ω_a, ξ(a)⟩ = γ` (linear in `ξ(a)` once `Ω(a) = Ω_a`), for a constraint
/// value `γ` that does not depend on `ξ`.
pub(super) fn start_level<M: Model>(p: &Problem<M>) -> LinearCondition {
    LinearCondition {
        coefficients: M::OMEGA.map(|i| (M::XI.start + i, p.omega_a[i])).collect(),
        value: crate::model::constant_constraint_value::<M>(p.params()),
    }
}

/// The boundary conditions of a direct transcription of `p` (`Ω(a) = Ω_a`, `Ω(b) = Ω_b`, `ξ`
/// free at both ends, and `start_linear`) and its horizon (`b` fixed or free).
pub(crate) fn ends_and_horizon<M: Model>(
    p: &Problem<M>,
    start_linear: Vec<LinearCondition>,
) -> (Boundary, Horizon) {
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
    (boundary, horizon)
}

/// Certify `sol` on its own mesh (see the module docs).
pub fn certify<M: Model>(
    sol: &LieSolution<M>,
    newton: &NewtonOptions,
    opts: &SecondOrderOptions,
) -> Result<SuslovCertificate, CertifyError> {
    if M::CONSTRAINT_VALUE_DEPENDS_ON_XI {
        return Err(CertifyError::Unsupported(format!(
            "model {}: the constraint value gamma(xi) depends on xi, so the start constraint \
             <Omega_a, xi(a)> = gamma(xi(a)) is nonlinear; the certificate handles linear start \
             conditions only",
            M::NAME
        )));
    }
    let ocp_problem = LieOcp::new(sol);
    let tr = transcription(&ocp_problem, sol)?;
    let values = sol.bvp.collocation_values();
    let mut v0 = Vec::with_capacity(tr.n_var());
    for y in values.chunks_exact(M::N_STATE) {
        v0.extend_from_slice(&y[..M::KAPPA.start]); // [Ω, ξ, ξ̇] = z
    }
    if tr.length_index().is_some() {
        v0.push(sol.t_span);
    }
    let size = v0.iter().fold(1.0_f64, |m, x| m.max(x.abs()));
    // The classical costates π of the indirect solution at the points: Newton's start
    // multipliers, and the reference of the discrete multipliers it ends with.
    let bvp = LieBvp::new(&sol.problem);
    let nx = LieOcp::<M>::NX;
    let mut pi = vec![0.0; tr.n_points() * nx];
    let mut w = vec![0.0; M::N_DESIRED];
    for (p, pi_p) in pi.chunks_exact_mut(nx).enumerate() {
        let t = tr.point_time(p, sol.t_span);
        bvp.desired_at(t, &mut w);
        M::classical_costates(&sol.state(t), sol.problem.params(), &w, pi_p);
    }
    let certificate = ocp::certify_with_costates(&tr, v0, Some(&pi), newton, opts)?;
    let t_len = tr.length(&certificate.point.v);
    let omega = tr.quadrature_weights();
    let lam = tr.point_multipliers(&certificate.point.y);
    let (mut worst, mut scale) = (0.0_f64, 0.0_f64);
    for (p, pi_p) in pi.chunks_exact(nx).enumerate() {
        for r in 0..nx {
            worst = worst.max((lam[p * nx + r] / omega[p] - pi_p[r]).abs());
            scale = scale.max(pi_p[r].abs());
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
