//! The direct start: a minimum of the discretized control problem, found by a globalized SQP
//! method from a motion's inverse dynamics, as a warm start for the BVP.
//!
//! # Why
//!
//! The homotopy follows a branch of extremals from the analytic start to the target weights.
//! When that branch folds back or heads where `ξ` collapses, no continuation reaches the
//! target, although the problem may still have a regular minimum elsewhere: the direct method
//! of `bench/casadi_direct.py` (IPOPT) found such minima for corpus problems on which every
//! route stopped, and the BVP converges from them (`tests/missed_regular.rs`). A better
//! *start* alone does not reach them (session 12's probe in `bench/README.md`): IPOPT gets
//! there by its globalisation, which minimizes the cost rather than solving the optimality
//! conditions. [`crate::ocp::sqp()`] is that globalisation (inertia correction, a filter line
//! search, feasibility restoration) on one of two transcriptions of the problem
//! ([`DirectForm`]), every derivative generated from the model file:
//!
//! - the **reduced form** ([`super::certify::LieOcp`]): state `[Ω, ξ]`, control `ξ̇`, Suslov's
//!   `Ω̇ = F(Ω, ξ, ξ̇)` with `λ` eliminated (it divides by `⟨ξ, 𝕀⁻¹ξ⟩`);
//! - the **multiplier form** ([`super::multiplier::MultiplierOcp`]): control `[ξ̇, λ]`,
//!   `Ω̇ = 𝕀⁻¹(ad*_Ω 𝕀Ω + λξ)`, and the constraint imposed at every point; nothing divides,
//!   so the SQP can pass where `ξ` nears 0 (corpus problem issue12-080 is reached only this
//!   way).
//!
//! In both, `Ω(b) = Ω_b` is imposed only along the energy level set when the dynamics
//! conserve the energy (`tangential_end`): the normal component is implied, and imposing it
//! makes the constraint Jacobian nearly rank-deficient. The reduced form leaves out the start
//! condition `⟨Ω_a, ξ(a)⟩ = γ` at first (a relaxation, `Ω(b) = Ω_b` in full) and imposes it
//! when the relaxation's minimum is not a motion of the problem (`reduced_transcription_on`,
//! [`energy_drift`]). The multiplier form's SQP, on the
//! 17 fixed-time stops of the corpus (session 15, 400 iterations at most), stopped on 10 with
//! the full end condition (a failed inertia correction 3, the line search 2, the iteration
//! limit 5) and on 1 with the tangential one; the other 16 converged in 23–237 iterations.
//!
//! # What it does
//!
//! 1. The start: the motion along the projected segment `Ω_a → Ω_b` over `[a, b]` (the
//!    problem's `b`, or its guess when `b` is free), driven by its unit singular control
//!    (`ξ = ξ̃/|ξ̃|`, `ξ̃ = 𝕀Ω̇ − ad*_Ω 𝕀Ω`, [`Model::singular_control`]), on a uniform mesh;
//!    in the multiplier form `λ` is fitted to the motion's `Ω̇`
//!    ([`MultiplierOcp::fit_lambda`]).
//! 2. [`crate::ocp::sqp()`] at the problem's own weights, to [`DIRECT_TOLERANCE`].
//! 3. The result, `[Ω, ξ, ξ̇, κ]` at every collocation point, is a [`WarmStart`] for
//!    [`super::solve::solve_from`]'s single BVP solve. `κ` comes from the SQP's multipliers:
//!    the reduced form's least-squares multipliers at the minimum (whichever form found it)
//!    are the classical costates `π = λ_p/ω_p` ([`crate::ocp::Transcription`]), and `κ` is
//!    fitted to them through the generated `classical_costates`, which is affine in `κ`
//!    (`reduced_costates`, `fit_kappa`). The multiplier form's own multipliers would not do:
//!    its path constraint `⟨Ω, ξ⟩ = γ` shifts the costates by `ν(t) [ξ; Ω]`. Where the
//!    reduced form is singular (`ξ` nearly vanishes) `κ = 0`, as before this step
//!    ([`DirectStart::kappa_fitted`]). On corpus problem fast-198 the BVP converges from the
//!    minimum with `κ` recovered and not with `κ = 0`.
//! 4. [`refine_start`]: the same minimum on a finer mesh, from the coarse one's points
//!    interpolated (a few SQP iterations), for a BVP that does not converge from the coarse
//!    one ([`super::solve`](mod@super::solve)'s direct route).
//!
//! A start whose SQP stops (the infimum is not attained and `ξ` collapses, the line search
//! fails) is reported with the method's reason, not hidden; so is a minimum whose `ξ`
//! collapses (its `min |ξ|` is in [`DirectStart`]).

use crate::model::Model;
use crate::ocp::{self, LinearCondition, OcpProblem, SqpOptions, SqpReport, Transcription};

use super::certify::{ends_and_horizon, start_level, transcription_on, LieOcp};
use super::multiplier::{self, MultiplierOcp};
use std::sync::Arc;

use super::path::{projected_segment, EndBlend, Path, PathError, Projected};
use super::problem::{with_buffer, Problem, ENERGY_REL_TOL};
use super::solve::WarmStart;

/// The tolerance of the SQP (relative stationarity and feasibility): the BVP solve that
/// follows sets the final accuracy; this only has to land in its basin.
pub const DIRECT_TOLERANCE: f64 = 1e-6;

/// Iteration limit of the SQP in the reduced form's relaxation (module docs).
pub const DIRECT_MAX_ITERATIONS: usize = 200;

/// Iteration limit of the SQP in the reduced form with the start condition imposed (corpus
/// problem fast-199 needs 334, with four feasibility restorations).
pub const DIRECT_CONSTRAINED_MAX_ITERATIONS: usize = 400;

/// The largest [`energy_drift`] of the reduced form's relaxed minimum that counts as a motion
/// of the problem. Measured on 100 intervals (session 33): the relaxation's minima of corpus
/// problems short-116 2e-9, spiral-149 3e-6, spiral-129 5.3e-4 (min |ξ| 0.025), fast-119
/// 6.3e-3 (a collapsed minimum, min |ξ| 7e-4), all motions up to the discretization; fast-199's,
/// which is not one, 1.09.
pub const DIRECT_ENERGY_TOLERANCE: f64 = 0.05;

/// Iteration limit of the SQP in the multiplier form: its iterations are as cheap, and on
/// corpus problem issue12-080 it needs 115 of them to the regular minimum (full steps with
/// inertia corrections most of the way: the problem is far from convex at the start).
pub const DIRECT_MULTIPLIER_MAX_ITERATIONS: usize = 400;

/// The direct start of a problem: the warm start and what the SQP did.
#[derive(Debug, Clone)]
pub struct DirectStart {
    /// `[Ω, ξ, ξ̇, κ = 0]` at the collocation points.
    pub warm: WarmStart,
    /// The SQP's iterations.
    pub report: SqpReport,
    /// The discrete cost of the direct minimum.
    pub cost: f64,
    /// `min |ξ|` over the collocation points.
    pub min_xi: f64,
    /// `b − a` of the direct minimum.
    pub span: f64,
    /// The SQP's primal point (every point's `z`, then `T` when it is free).
    pub primal: Vec<f64>,
    /// Whether `κ` in [`DirectStart::warm`] was recovered from the multipliers (else it is 0:
    /// the reduced form is singular at the minimum, `ξ` nearly vanishes).
    pub kappa_fitted: bool,
    /// Whether the transcription imposed the start condition `⟨Ω_a, ξ(a)⟩ = γ` (module
    /// docs: the reduced form imposes it only when its relaxation's minimum is not a motion of
    /// the problem; the multiplier form imposes the constraint at every point).
    pub start_imposed: bool,
}

impl DirectStart {
    /// `Ω` at the collocation points (`warm.times`), one row each.
    pub fn omegas<M: Model>(&self) -> Vec<Vec<f64>> {
        self.warm
            .states
            .chunks_exact(M::N_STATE)
            .map(|y| y[M::OMEGA].to_vec())
            .collect()
    }
}

/// Why no direct start was built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DirectError {
    /// The model's constraint value depends on ξ (the start condition is nonlinear).
    #[error("the direct start needs a constraint value that does not depend on xi")]
    Unsupported,
    /// The projected segment or its singular control could not be built.
    #[error("the start motion: {0}")]
    Start(String),
    /// The transcription could not be built.
    #[error("the transcription: {0}")]
    Transcription(#[from] ocp::TranscriptionError),
    /// The SQP stopped.
    #[error("the SQP stopped: {0}")]
    Sqp(#[from] ocp::SqpError),
    /// The reduced form's relaxed minimum (refined) is no motion of the problem
    /// ([`energy_drift`]).
    #[error(
        "the SQP's minimum is no motion of the problem: its energy drifts by {drift:.2e} \
         (relative; the start condition <Omega_a, xi(a)> = gamma was relaxed)"
    )]
    NotAMotion {
        /// Its [`energy_drift`].
        drift: f64,
    },
}

/// The motion the SQP starts from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DirectGuess {
    /// The projected segment `Ω_a → Ω_b`.
    Segment,
    /// The desired path bent to `Ω_a` and `Ω_b` over the first and last quarter of `[a, b]`
    /// and projected onto the level set.
    Desired,
}

impl DirectGuess {
    /// Words for messages.
    pub fn describe(self) -> &'static str {
        match self {
            DirectGuess::Segment => "the projected segment",
            DirectGuess::Desired => "the projected desired path",
        }
    }
}

/// The start motion of `guess` over `[a, a + span]`.
fn guess_path<M: Model>(
    problem: &Problem<M>,
    guess: DirectGuess,
    span: f64,
) -> Result<Arc<dyn Path>, PathError> {
    let (a, b) = (problem.t0, problem.t0 + span);
    let set = problem.level_set();
    Ok(match guess {
        DirectGuess::Segment => Arc::new(projected_segment(
            &set,
            &problem.omega_a,
            &problem.omega_b,
            a,
            b,
            ENERGY_REL_TOL,
        )?),
        DirectGuess::Desired => {
            let bent = EndBlend::new(
                problem.desired.clone(),
                (a, b),
                &problem.omega_a,
                &problem.omega_b,
                0.25 * span,
            )?;
            Arc::new(Projected::new(Arc::new(bent), set)?)
        }
    })
}

/// Which transcription the direct start minimizes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DirectForm {
    /// The classical form with `λ` eliminated ([`LieOcp`]; singular where `ξ` vanishes).
    Reduced,
    /// The multiplier form ([`MultiplierOcp`]): `λ` a control, the constraint imposed at every
    /// point; defined through `ξ = 0`.
    Multiplier,
}

/// The direct start of `problem` on a uniform mesh of `intervals` intervals, from the motion
/// `guess`, minimizing the reduced form (module docs).
pub fn direct_start<M: Model>(
    problem: &Problem<M>,
    intervals: usize,
    guess: DirectGuess,
) -> Result<DirectStart, DirectError> {
    direct_start_in(problem, intervals, guess, DirectForm::Reduced)
}

/// [`direct_start`] minimizing the transcription `form`.
pub fn direct_start_in<M: Model>(
    problem: &Problem<M>,
    intervals: usize,
    guess: DirectGuess,
    form: DirectForm,
) -> Result<DirectStart, DirectError> {
    if M::CONSTRAINT_VALUE_DEPENDS_ON_XI {
        return Err(DirectError::Unsupported);
    }
    let span = problem.terminal.initial() - problem.t0;
    let start = guess_path(problem, guess, span).map_err(|e| DirectError::Start(e.to_string()))?;
    let intervals = intervals.max(1);
    let mesh: Vec<f64> = (0..=intervals)
        .map(|k| k as f64 / intervals as f64)
        .collect();
    match form {
        DirectForm::Reduced => {
            let ocp_problem = LieOcp::<M>::for_problem(problem);
            let run = |imposed: bool, limit: usize| {
                let tr = reduced_transcription_on(&ocp_problem, problem, mesh.clone(), imposed)?;
                minimize::<M, _>(&tr, problem, &*start, guess, span, limit, |_, _| {}).map(|d| {
                    DirectStart {
                        start_imposed: imposed,
                        ..d
                    }
                })
            };
            match run(false, DIRECT_MAX_ITERATIONS) {
                Ok(d) if energy_drift(problem, &d) > DIRECT_ENERGY_TOLERANCE => {
                    run(true, DIRECT_CONSTRAINED_MAX_ITERATIONS)
                }
                relaxed => relaxed,
            }
        }
        DirectForm::Multiplier => {
            let ocp_problem = MultiplierOcp::<M>::for_problem(problem);
            let tr = multiplier::transcription_on(&ocp_problem, problem, mesh)?;
            let tr = tangential_end(problem, tr)?;
            let limit = DIRECT_MULTIPLIER_MAX_ITERATIONS;
            minimize::<M, _>(&tr, problem, &*start, guess, span, limit, |z, omega_dot| {
                ocp_problem.fit_lambda(z, omega_dot)
            })
        }
    }
}

/// The direct start on `intervals` uniform intervals from an earlier one (`previous`, in the
/// same `form`), its points interpolated linearly in time.
pub fn refine_start<M: Model>(
    problem: &Problem<M>,
    previous: &DirectStart,
    intervals: usize,
    form: DirectForm,
) -> Result<DirectStart, DirectError> {
    let mesh: Vec<f64> = (0..=intervals)
        .map(|k| k as f64 / intervals as f64)
        .collect();
    let times = &previous.warm.times;
    let interpolate = |nz: usize, t: f64, z: &mut [f64]| {
        let k = times.partition_point(|&s| s <= t).clamp(1, times.len() - 1);
        let (t0, t1) = (times[k - 1], times[k]);
        let w = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
        let (a, b) = (
            &previous.primal[(k - 1) * nz..k * nz],
            &previous.primal[k * nz..(k + 1) * nz],
        );
        for i in 0..nz {
            z[i] = (1.0 - w) * a[i] + w * b[i];
        }
    };
    match form {
        DirectForm::Reduced => {
            let ocp_problem = LieOcp::<M>::for_problem(problem);
            let imposed = previous.start_imposed;
            let tr = reduced_transcription_on(&ocp_problem, problem, mesh, imposed)?;
            let nz = tr.nz();
            let v0 = tr.primal_from_fn(previous.span, |t, z| interpolate(nz, t, z));
            let limit = if imposed {
                DIRECT_CONSTRAINED_MAX_ITERATIONS
            } else {
                DIRECT_MAX_ITERATIONS
            };
            let d = minimize_from(&tr, problem, v0, limit)?;
            let drift = energy_drift(problem, &d);
            if !imposed && drift > DIRECT_ENERGY_TOLERANCE {
                return Err(DirectError::NotAMotion { drift });
            }
            Ok(DirectStart {
                start_imposed: imposed,
                ..d
            })
        }
        DirectForm::Multiplier => {
            let ocp_problem = MultiplierOcp::<M>::for_problem(problem);
            let tr = multiplier::transcription_on(&ocp_problem, problem, mesh)?;
            let tr = tangential_end(problem, tr)?;
            let nz = tr.nz();
            let v0 = tr.primal_from_fn(previous.span, |t, z| interpolate(nz, t, z));
            minimize_from(&tr, problem, v0, DIRECT_MULTIPLIER_MAX_ITERATIONS)
        }
    }
}

/// `tr` with `Ω(b) = Ω_b` imposed only along the level set (both forms'
/// SQP; [`reduced_transcription_on`]), when the dynamics conserve the
/// kinetic energy (a vanishing constraint value): the `n − 1` components of `Ω(b) − Ω_b`
/// tangent to the level set at `Ω_b` (orthogonal to its normal `𝕀Ω_b`). The normal component
/// is then implied by the conservation in exact dynamics, and imposing it too makes the
/// constraint Jacobian nearly rank-deficient (the discrete dynamics conserve the energy up to
/// the discretization error), which the SQP's inertia correction cannot repair (as in
/// `bench/casadi_direct.py`). The BVP solved from the direct minimum imposes `Ω(b) = Ω_b`.
pub(super) fn tangential_end<'a, M: Model, P: OcpProblem>(
    problem: &Problem<M>,
    tr: Transcription<'a, P>,
) -> Result<Transcription<'a, P>, ocp::TranscriptionError> {
    if !problem.conserves_energy() {
        return Ok(tr);
    }
    let n = M::DIM;
    let set = problem.level_set();
    let inertia = set.inertia();
    let omega_b = &problem.omega_b;
    let normal: Vec<f64> = (0..n)
        .map(|i| (0..n).map(|j| inertia[i * n + j] * omega_b[j]).sum())
        .collect();
    // Gram–Schmidt on the normal and the unit vectors, the one most aligned with the normal
    // left out: an orthonormal basis of the tangent space.
    let skip = (0..n)
        .max_by(|&a, &b| normal[a].abs().total_cmp(&normal[b].abs()))
        .unwrap_or(0);
    let mut basis: Vec<Vec<f64>> = vec![normal];
    for e in (0..n).filter(|&e| e != skip) {
        let mut v: Vec<f64> = (0..n).map(|i| f64::from(u8::from(i == e))).collect();
        for _ in 0..2 {
            for b in &basis {
                let (bb, vb): (f64, f64) =
                    (0..n).fold((0.0, 0.0), |(x, y), i| (x + b[i] * b[i], y + v[i] * b[i]));
                v.iter_mut().zip(b).for_each(|(vi, bi)| *vi -= vb / bb * bi);
            }
        }
        let size = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v.iter_mut().for_each(|x| *x /= size);
        basis.push(v);
    }
    let mut boundary = tr.boundary().clone();
    boundary.end.clear();
    boundary.end_linear = basis[1..]
        .iter()
        .map(|t| LinearCondition {
            coefficients: M::OMEGA.map(|i| (i, t[i])).collect(),
            value: M::OMEGA.map(|i| t[i] * omega_b[i]).sum(),
        })
        .collect();
    tr.with_boundary(boundary)
}

/// The reduced form's transcription for the SQP: `Ω(a) = Ω_a` and `Ω(b) = Ω_b`, with the
/// start condition `⟨Ω_a, ξ(a)⟩ = γ` imposed or not.
///
/// With `λ` eliminated through the differentiated constraint, `c = ⟨Ω, ξ⟩` is a first
/// integral of the reduced dynamics and the energy changes at the rate `λ c`. Near a solution
/// with `c = γ = 0` the start condition is redundant (it and the normal component of
/// `Ω(b) = Ω_b` both fix `δc`, and its multiplier is not unique), and the transcription without
/// it ([`super::certify::transcription_on`]) is a *relaxation*: a minimum of it that is a
/// motion of the problem (`c = γ`: [`energy_drift`] within [`DIRECT_ENERGY_TOLERANCE`]) is a minimum of the
/// problem. Globally it is not redundant: a motion with `c ≠ 0` ends on the energy level of
/// `Ω_a` whenever `∫ λ dt = 0`, and on corpus problem fast-199 the relaxation's SQP converged
/// to one (`c = −0.18`, the energy rising from 4852 to 10 123 and back, discrete cost
/// 2.02e-5), which is no motion of Suslov's problem. Then the condition is imposed
/// (`imposed`), with `Ω(b) = Ω_b` along the level set only ([`tangential_end`]), as in the
/// multiplier form. Imposing it always is not better: on short-116 the SQP then converges to
/// a minimum whose `ξ` dips to 2e-4 (cost 7.173468), from which the BVP does not converge,
/// where the relaxation's minimum (7.160686, `|c| ≤ 4e-7`) is solved.
fn reduced_transcription_on<'a, M: Model>(
    ocp_problem: &'a LieOcp<'a, M>,
    problem: &Problem<M>,
    mesh: Vec<f64>,
    imposed: bool,
) -> Result<Transcription<'a, LieOcp<'a, M>>, ocp::TranscriptionError> {
    if !imposed || !problem.conserves_energy() {
        return transcription_on(ocp_problem, problem, mesh);
    }
    let (boundary, horizon) = ends_and_horizon(problem, vec![start_level(problem)]);
    tangential_end(
        problem,
        Transcription::new(ocp_problem, boundary, horizon, mesh)?,
    )
}

/// `max |T(Ω) − T(Ω_a)| / T(Ω_a)` over the points of the direct minimum `d`, with the kinetic
/// energy `T(Ω) = ⟨𝕀Ω, Ω⟩ / 2`: a motion of a problem whose dynamics conserve the energy keeps
/// it up to the discretization error; the reduced form's relaxation pumps it at the rate
/// `λ ⟨Ω, ξ⟩` where `⟨Ω, ξ⟩ ≠ 0` (`reduced_transcription_on`). 0 when the problem does not
/// conserve the energy (its reduced transcription imposes the start condition anyway).
pub fn energy_drift<M: Model>(problem: &Problem<M>, d: &DirectStart) -> f64 {
    if !problem.conserves_energy() {
        return 0.0;
    }
    let n = M::DIM;
    let inertia = problem.inertia_matrix();
    let energy = |omega: &[f64]| -> f64 {
        (0..n)
            .map(|i| omega[i] * (0..n).map(|j| inertia[i * n + j] * omega[j]).sum::<f64>())
            .sum::<f64>()
            / 2.0
    };
    let e0 = energy(&problem.omega_a);
    d.warm
        .states
        .chunks_exact(M::N_STATE)
        .map(|y| (energy(&y[M::OMEGA]) - e0).abs() / e0)
        .fold(0.0, f64::max)
}

/// The SQP of the direct start on `tr`, whose points begin with `[Ω, ξ, ξ̇]`, from the motion
/// `start` driven by its unit singular control; `complete(z, Ω̇)` fills the rest of a point.
fn minimize<M: Model, P: OcpProblem>(
    tr: &Transcription<'_, P>,
    problem: &Problem<M>,
    start: &dyn Path,
    guess: DirectGuess,
    span: f64,
    max_iterations: usize,
    mut complete: impl FnMut(&mut [f64], &[f64]),
) -> Result<DirectStart, DirectError> {
    let n = M::DIM;
    let params = problem.params();
    let mut bad_time = None;
    // ξ̃ may pass through 0 along the motion, where ξ̃/|ξ̃| flips; the motion only sees ξ up
    // to sign (λ is odd in ξ, λξ even), so the sign is chosen to keep ξ continuous (the points
    // come in time order).
    let mut previous: Option<Vec<f64>> = None;
    let v0 = tr.primal_from_fn(span, |t, z| {
        with_buffer(6 * n, |buf| {
            let (jet, xi) = buf.split_at_mut(4 * n);
            start.jet_into(t, jet);
            M::singular_control(&jet[..3 * n], params, xi);
            if let Some(prev) = &previous {
                let d: f64 = xi[..n].iter().zip(prev).map(|(a, b)| a * b).sum();
                if d < 0.0 {
                    xi.iter_mut().for_each(|v| *v = -*v);
                }
            }
            previous = Some(xi[..n].to_vec());
            z[M::OMEGA].copy_from_slice(&jet[..n]);
            z[M::XI.start..M::XIDOT.end].copy_from_slice(xi);
            complete(z, &jet[n..2 * n]);
        });
        if !z.iter().all(|v| v.is_finite()) && bad_time.is_none() {
            bad_time = Some(t);
        }
    });
    if let Some(t) = bad_time {
        return Err(DirectError::Start(format!(
            "the singular control of {} is not defined at t = {t} (it is a free motion \
             there)",
            guess.describe()
        )));
    }
    minimize_from(tr, problem, v0, max_iterations)
}

/// The SQP of the direct start on `tr` from the primal point `v0`.
fn minimize_from<M: Model, P: OcpProblem>(
    tr: &Transcription<'_, P>,
    problem: &Problem<M>,
    v0: Vec<f64>,
    max_iterations: usize,
) -> Result<DirectStart, DirectError> {
    let nz = tr.nz();
    let params = problem.params();
    let options = SqpOptions {
        tolerance: DIRECT_TOLERANCE,
        max_iterations,
        ..SqpOptions::default()
    };
    let (point, report) = ocp::sqp(tr, v0, &options)?;
    let t_len = tr.length(&point.v);
    let mut times = Vec::with_capacity(tr.n_points());
    let mut states = Vec::with_capacity(tr.n_points() * M::N_STATE);
    let mut min_xi = f64::INFINITY;
    // κ from the multipliers (module docs, item 3); κ = 0 where they are not available.
    let costates = reduced_costates(problem, tr.mesh().to_vec(), &point.v, nz);
    let bvp = super::problem::LieBvp::new(problem);
    let mut kappa_fitted = costates.is_ok();
    for (p, z) in point.v.chunks_exact(nz).take(tr.n_points()).enumerate() {
        let t = tr.point_time(p, t_len);
        times.push(t);
        let start = states.len();
        states.extend_from_slice(&z[..M::KAPPA.start]); // [Ω, ξ, ξ̇]
        states.resize(start + M::N_STATE, 0.0); // κ = 0 unless fitted
        if let Ok(pi) = &costates {
            let nx = pi.len() / tr.n_points();
            kappa_fitted &= fit_kappa::<M>(
                &bvp,
                params,
                t,
                &mut states[start..],
                &pi[p * nx..(p + 1) * nx],
            );
        }
        min_xi = min_xi.min(z[M::XI].iter().map(|v| v * v).sum::<f64>().sqrt());
    }
    if !kappa_fitted {
        for y in states.chunks_exact_mut(M::N_STATE) {
            y[M::KAPPA].iter_mut().for_each(|v| *v = 0.0);
        }
    }
    Ok(DirectStart {
        warm: WarmStart { times, states },
        primal: point.v.clone(),
        cost: tr.objective(&point.v),
        report,
        min_xi,
        span: t_len,
        kappa_fitted,
        start_imposed: true,
    })
}

/// The classical costates `π = λ_p / ω_p` (`P × 2n`) at the points of the primal point `v`
/// (points of `nz` entries beginning with `[Ω, ξ, ξ̇]`, then `T` when free): the least-squares
/// multipliers of the *reduced* form on the same mesh at `v`, whatever form found `v`.
///
/// Why the reduced form: the multiplier form imposes `⟨Ω, ξ⟩ = γ` at every point, a state
/// constraint whose multiplier shifts its costates by `ν(t) [ξ; Ω]`; the reduced form's
/// costates are those of the BVP's `κ` (`classical_costates`). Its end conditions are
/// `Ω(b) = Ω_b` in full, as in the BVP: with only the tangential ones its multipliers are
/// not unique, and the least-squares choice is another member of the family than the BVP's.
fn reduced_costates<M: Model>(
    problem: &Problem<M>,
    mesh: Vec<f64>,
    v: &[f64],
    nz: usize,
) -> Result<Vec<f64>, String> {
    let ocp_problem = LieOcp::<M>::for_problem(problem);
    let tr = transcription_on(&ocp_problem, problem, mesh).map_err(|e| e.to_string())?;
    let rz = tr.nz();
    let mut w = Vec::with_capacity(tr.n_var());
    for z in v.chunks_exact(nz).take(tr.n_points()) {
        w.extend_from_slice(&z[..rz]);
    }
    if tr.length_index().is_some() {
        w.push(v[v.len() - 1]);
    }
    if w.len() != tr.n_var() {
        return Err(format!("{} values for {} unknowns", w.len(), tr.n_var()));
    }
    let kkt = ocp::kkt::KktMatrix::new(&tr).map_err(|e| e.to_string())?;
    let y = ocp::kkt::least_squares_multipliers(&tr, &kkt, &w).map_err(|e| e.to_string())?;
    let weights = tr.quadrature_weights();
    let mut pi = tr.point_multipliers(&y);
    let nx = tr.n_state();
    for (p, row) in pi.chunks_exact_mut(nx).enumerate() {
        row.iter_mut().for_each(|l| *l /= weights[p]);
    }
    if pi.iter().all(|x| x.is_finite()) {
        Ok(pi)
    } else {
        Err("the multipliers are not finite".into())
    }
}

/// `κ` in `y` (whose `[Ω, ξ, ξ̇]` are set) fitted by least squares to the classical costates
/// `pi` at time `t`: the generated `classical_costates` (`π = −[p_Ω; p_ξ]` of `C + ⟨κ, q⟩`) is
/// affine in `κ`, so its map is read off at `κ = 0` and the unit vectors. Returns whether the
/// fit is finite (else `κ` is left at 0).
fn fit_kappa<M: Model>(
    bvp: &super::problem::LieBvp<'_, M>,
    params: &[f64],
    t: f64,
    y: &mut [f64],
    pi: &[f64],
) -> bool {
    let (nk, nx) = (M::KAPPA.len(), pi.len());
    let mut w = vec![0.0; M::N_DESIRED];
    bvp.desired_at(t, &mut w);
    y[M::KAPPA].iter_mut().for_each(|v| *v = 0.0);
    let mut base = vec![0.0; nx];
    M::classical_costates(y, params, &w, &mut base);
    let mut a = nalgebra::DMatrix::zeros(nx, nk);
    let mut col = vec![0.0; nx];
    for j in 0..nk {
        y[M::KAPPA.start + j] = 1.0;
        M::classical_costates(y, params, &w, &mut col);
        y[M::KAPPA.start + j] = 0.0;
        for r in 0..nx {
            a[(r, j)] = col[r] - base[r];
        }
    }
    let rhs = nalgebra::DVector::from_iterator(nx, (0..nx).map(|r| pi[r] - base[r]));
    match a.svd(true, true).solve(&rhs, 1e-14) {
        Ok(k) if k.iter().all(|v| v.is_finite()) => {
            y[M::KAPPA].copy_from_slice(k.as_slice());
            true
        }
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::so3::So3;

    /// The end conditions of the multiplier form on the paper's problem (the energy is
    /// conserved): `n − 1` orthonormal rows, orthogonal to the level set's normal `𝕀Ω_b`,
    /// met by `Ω_b`, and violated by another point of the level set near it.
    #[test]
    fn the_tangential_end_conditions_span_the_level_sets_tangent_space() {
        let problem = crate::so3::paper::problem(0.01).to_generic().unwrap();
        let ocp_problem = MultiplierOcp::<So3>::for_problem(&problem);
        let mesh = vec![0.0, 0.25, 0.5, 0.75, 1.0];
        let tr = multiplier::transcription_on(&ocp_problem, &problem, mesh).unwrap();
        assert_eq!(tr.boundary().end.len(), So3::DIM);
        let n_con = tr.n_con();
        let tr = tangential_end(&problem, tr).unwrap();
        assert_eq!(tr.n_con(), n_con - 1);
        let b = tr.boundary();
        assert!(b.end.is_empty());
        assert_eq!(b.end_linear.len(), So3::DIM - 1);
        let n = So3::DIM;
        let row = |c: &LinearCondition| {
            let mut v = vec![0.0; n];
            for &(i, x) in &c.coefficients {
                v[i] = x;
            }
            v
        };
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let inertia = problem.level_set().inertia().to_vec();
        let omega_b = &problem.omega_b;
        let normal: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| inertia[i * n + j] * omega_b[j]).sum())
            .collect();
        let scale = dot(&normal, &normal).sqrt();
        for (i, ci) in b.end_linear.iter().enumerate() {
            let ti = row(ci);
            assert!((ci.value - dot(&ti, omega_b)).abs() < 1e-14 * (1.0 + ci.value.abs()));
            assert!(dot(&ti, &normal).abs() < 1e-14 * scale, "{ti:?}");
            for (j, cj) in b.end_linear.iter().enumerate() {
                let want = f64::from(u8::from(i == j));
                assert!((dot(&ti, &row(cj)) - want).abs() < 1e-14);
            }
        }
        // Another point of the level set near Ω_b misses the conditions.
        let t0 = row(&b.end_linear[0]);
        let moved: Vec<f64> = omega_b.iter().zip(&t0).map(|(o, t)| o + 0.1 * t).collect();
        let other = problem.level_set().project(&moved).unwrap();
        let miss = (dot(&t0, &other) - b.end_linear[0].value).abs();
        assert!(miss > 0.05, "{miss}");
    }
}
