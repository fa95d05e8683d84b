//! A-posteriori check: re-integrate the pure Suslov equations with a computed control.
//!
//! Given a control `t ↦ (ξ(t), ξ̇(t))` on `[a, b]`, [`reintegrate`] solves the IVP
//! `Ω̇ = I⁻¹[(IΩ) × Ω + λξ]`, `λ = −(⟨Ω, ξ̇⟩ + ⟨(IΩ) × Ω, I⁻¹ξ⟩)/⟨ξ, I⁻¹ξ⟩`
//! (paper eqs. `Suslov_eq_3D`, `Suslov_lambda`), `Ω(a) = Ω_a`, with the adaptive integrator
//! of [`crate::ivp`] (default `rtol = atol = 1e-12`), and [`compare`] measures the distance to
//! a reference `Ω(t)` (e.g. the BVP solution, or `Ω_p` for the singular control `ξ_p`).
//!
//! [`stability_experiment`] repeats the paper's R2Q4 experiment (section 5.3): perturb `ξ̇`,
//! integrate `ξ` consistently from `ξ(a)` together with `Ω` (6 states), and report how far `Ω`
//! moves from the unperturbed re-integration. Because `ξ` is integrated from the perturbed
//! `ξ̇`, `⟨Ω, ξ⟩ = 0` and the energy stay exactly invariant, so the perturbed `Ω` stays on `E`.
//!
//! # Measured (tests of this module; `I = diag(1,2,3)`, `Ω_a = [5,0,0]`, `[0, 10]`)
//!
//! - **End-to-end check** (singular control of section 5.1 re-integrated, 501 output times,
//!   `rtol = atol = 1e-12`): `ξ_p` of `φ_∥` reproduces `φ_∥` to `max |ΔΩ| = 1.8e-12`
//!   (79 steps, 2194 evaluations); `ξ_p` of `Projected(Ω_d)` reproduces it to `2.1e-12`
//!   (91 steps). Energy drift and `|⟨Ω, ξ⟩|/(|Ω||ξ|)` stay below `5e-13`.
//! - **Stability experiment (R2Q4) on the singular control of `φ_∥`**, 201 output times:
//!   - `ξ̇(1 + ε sin 3t)`: `ε = 1e-2` moves `Ω` by at most 0.126 (at t ≈ 7.6; `|Ω| ≈ 3–5`),
//!     `ε = 1e-3` by 0.0126: linear response, gain ≈ 8 relative to the induced
//!     `max |Δξ|` (0.015 resp. 0.0015).
//!   - `ξ̇ + ε (1,1,1)/√3` (a secular drift of `ξ`, `|Δξ| = 10ε` at `t = 10`): `ε = 1e-4` moves
//!     `Ω` by 0.071, `ε = 1e-3` by 0.72, `ε = 1e-2` by 4.76 (no longer linear; comparable to
//!     the size of `E`). The open-loop singular control is thus robust to zero-mean
//!     perturbations of `ξ̇` but sensitive (gain ≈ 70 on `|Δξ|`) to a drift of `ξ`.
//!   - In all runs the perturbed `Ω` stays on `E` and `⟨Ω, ξ⟩ = 0` to `< 5e-13`.

use std::cell::RefCell;

use nalgebra::Vector3;
use serde::Serialize;

use super::desired::DesiredPath;
use super::ellipsoid::{EnergyEllipsoid, Inertia};
use super::equations::suslov_rhs;
use super::layout::stack;
use super::singular::singular_control_at;
use super::SuslovError;
use crate::ivp::{integrate, IvpOptions, IvpStats};
use crate::model::generated::DIM;

/// A control `t ↦ (ξ(t), ξ̇(t))`; an `Err` aborts the integration and is returned.
pub type Control<'c> = dyn Fn(f64) -> Result<(Vector3<f64>, Vector3<f64>), SuslovError> + 'c;

/// The singular control `t ↦ (ξ_p(t), ξ̇_p(t))` of a path (paper section 5.1) as a
/// [`Control`]; a violation of Property 3 becomes an `Err` that aborts the re-integration.
pub fn singular_control_fn(
    path: &dyn DesiredPath,
    inertia: Inertia,
) -> impl Fn(f64) -> Result<(Vector3<f64>, Vector3<f64>), SuslovError> + '_ {
    move |t| singular_control_at(path, &inertia, t).map(|c| (c.xi, c.xi_dot))
}

/// A re-integrated trajectory at the requested times.
#[derive(Debug, Clone, PartialEq)]
pub struct Reintegration {
    /// Output times.
    pub t: Vec<f64>,
    /// `Ω(t_k)`.
    pub omega: Vec<Vector3<f64>>,
    /// `ξ(t_k)` used (from the control, or integrated in the stability experiment).
    pub xi: Vec<Vector3<f64>>,
    /// Integrator work.
    pub stats: IvpStats,
}

/// Distance of a re-integrated `Ω` from a reference, and the invariants along it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Comparison {
    /// `max_k |Ω(t_k) − Ω_ref(t_k)|`.
    pub max_abs_diff: f64,
    /// Where it occurs.
    pub t_max_abs_diff: f64,
    /// `max_k |Ω(t_k) − Ω_ref(t_k)| / |Ω_ref(t_k)|`.
    pub max_rel_diff: f64,
    /// `max_k |⟨IΩ,Ω⟩ − ⟨IΩ_a,Ω_a⟩| / ⟨IΩ_a,Ω_a⟩` along the re-integration.
    pub max_rel_energy_drift: f64,
    /// `max_k |⟨Ω, ξ⟩| / (|Ω||ξ|)` along the re-integration.
    pub max_constraint: f64,
}

fn validate(
    inertia: &Inertia,
    omega_a: &Vector3<f64>,
    (a, b): (f64, f64),
    times: &[f64],
) -> Result<EnergyEllipsoid, SuslovError> {
    if !(a.is_finite() && b.is_finite() && a < b) || times.is_empty() {
        return Err(SuslovError::InvalidInput {
            what: format!(
                "re-integration needs finite a < b and output times; got a = {a}, b = {b}, {} times",
                times.len()
            ),
        });
    }
    EnergyEllipsoid::through(*inertia, omega_a)
}

/// Integrates the pure Suslov equations with the control `(ξ(t), ξ̇(t))` from `Ω(a) = Ω_a`
/// over `[a, b]` and returns `Ω` (and `ξ`) at `times` (non-decreasing, inside `[a, b]`).
pub fn reintegrate(
    inertia: &Inertia,
    omega_a: &Vector3<f64>,
    interval: (f64, f64),
    control: &Control<'_>,
    times: &[f64],
    options: &IvpOptions,
) -> Result<Reintegration, SuslovError> {
    validate(inertia, omega_a, interval, times)?;
    let failure: RefCell<Option<SuslovError>> = RefCell::new(None);
    let rhs = |t: f64, y: &[f64], dy: &mut [f64]| match control(t) {
        Ok((xi, xi_dot)) => {
            let om = Vector3::from_column_slice(y);
            dy.copy_from_slice(suslov_rhs(inertia, &om, &xi, &xi_dot).as_slice());
        }
        Err(e) => {
            failure.borrow_mut().get_or_insert(e);
            dy.fill(f64::NAN);
        }
    };
    let result = integrate(rhs, interval, omega_a.as_slice(), times, options);
    if let Some(e) = failure.into_inner() {
        return Err(e);
    }
    let sol = result?;
    let omega: Vec<Vector3<f64>> = sol
        .y
        .iter()
        .map(|y| Vector3::from_column_slice(y))
        .collect();
    let xi = times
        .iter()
        .map(|&t| control(t).map(|(xi, _)| xi))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(Reintegration {
        t: sol.t,
        omega,
        xi,
        stats: sol.stats,
    })
}

/// Like [`reintegrate`], but `ξ` is integrated from `ξ(a) = xi_a` with `ξ̇ = xi_dot(t, ξ)`
/// (state `[Ω, ξ]`, `2 DIM` components), so `ξ` and `ξ̇` are always consistent.
pub fn reintegrate_with_xi_dot(
    inertia: &Inertia,
    omega_a: &Vector3<f64>,
    xi_a: &Vector3<f64>,
    interval: (f64, f64),
    xi_dot: &dyn Fn(f64, &Vector3<f64>) -> Vector3<f64>,
    times: &[f64],
    options: &IvpOptions,
) -> Result<Reintegration, SuslovError> {
    validate(inertia, omega_a, interval, times)?;
    // The state [Ω, ξ]: Ω first, then ξ, `DIM` entries each.
    let split = |y: &[f64]| {
        let (om, xi) = y.split_at(DIM);
        (
            Vector3::from_column_slice(om),
            Vector3::from_column_slice(xi),
        )
    };
    let rhs = |t: f64, y: &[f64], dy: &mut [f64]| {
        let (om, xi) = split(y);
        let xd = xi_dot(t, &xi);
        let od = suslov_rhs(inertia, &om, &xi, &xd);
        let (d_om, d_xi) = dy.split_at_mut(DIM);
        d_om.copy_from_slice(od.as_slice());
        d_xi.copy_from_slice(xd.as_slice());
    };
    let y0: [f64; 2 * DIM] = stack(&[omega_a.as_slice(), xi_a.as_slice()]);
    let sol = integrate(rhs, interval, &y0, times, options)?;
    Ok(Reintegration {
        omega: sol.y.iter().map(|y| split(y).0).collect(),
        xi: sol.y.iter().map(|y| split(y).1).collect(),
        t: sol.t,
        stats: sol.stats,
    })
}

/// Compares a re-integration with reference values `reference[k] ≈ Ω(t_k)` and measures
/// the invariants (energy on `E(I, Ω_a)`, `⟨Ω, ξ⟩`) along it.
pub fn compare(
    run: &Reintegration,
    reference: &[Vector3<f64>],
    ellipsoid: &EnergyEllipsoid,
) -> Result<Comparison, SuslovError> {
    if reference.len() != run.omega.len() {
        return Err(SuslovError::InvalidInput {
            what: format!(
                "reference has {} values, the re-integration {}",
                reference.len(),
                run.omega.len()
            ),
        });
    }
    let mut c = Comparison {
        max_abs_diff: 0.0,
        t_max_abs_diff: run.t.first().copied().unwrap_or(f64::NAN),
        max_rel_diff: 0.0,
        max_rel_energy_drift: 0.0,
        max_constraint: 0.0,
    };
    for (k, &r) in reference.iter().enumerate() {
        let om = run.omega[k];
        let d = (om - r).norm();
        if d > c.max_abs_diff {
            c.max_abs_diff = d;
            c.t_max_abs_diff = run.t[k];
        }
        c.max_rel_diff = c.max_rel_diff.max(d / r.norm());
        c.max_rel_energy_drift = c
            .max_rel_energy_drift
            .max(ellipsoid.relative_mismatch(&om).abs());
        let xi = run.xi[k];
        c.max_constraint = c
            .max_constraint
            .max(om.dot(&xi).abs() / (om.norm() * xi.norm()));
    }
    Ok(c)
}

/// How `ξ̇` is perturbed in the stability experiment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Perturbation {
    /// `ξ̇ ↦ ξ̇ (1 + eps sin(k t))` (relative amplitude `eps`, angular frequency `k`).
    Modulated {
        /// Relative amplitude.
        eps: f64,
        /// Angular frequency.
        k: f64,
    },
    /// `ξ̇ ↦ ξ̇ + eps d` with `d` a fixed unit direction (absolute amplitude `eps`).
    Additive {
        /// Absolute amplitude.
        eps: f64,
        /// Direction (normalised internally).
        direction: Vector3<f64>,
    },
}

impl Perturbation {
    fn apply(&self, t: f64, xi_dot: Vector3<f64>) -> Vector3<f64> {
        match *self {
            Perturbation::Modulated { eps, k } => xi_dot * (1.0 + eps * (k * t).sin()),
            Perturbation::Additive { eps, direction } => xi_dot + direction.normalize() * eps,
        }
    }
}

/// Result of the stability experiment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StabilityReport {
    /// The perturbation applied.
    pub perturbation: Perturbation,
    /// `max_k |Ω_pert(t_k) − Ω(t_k)|` (both re-integrated with `ξ` integrated from `ξ̇`).
    pub max_deviation: f64,
    /// Where it occurs.
    pub t_max_deviation: f64,
    /// `|Ω_pert(b) − Ω(b)|` at the last output time.
    pub final_deviation: f64,
    /// `max_k |ξ_pert(t_k) − ξ(t_k)|`.
    pub max_xi_deviation: f64,
    /// Invariants along the perturbed run: max relative energy drift.
    pub max_rel_energy_drift: f64,
    /// Invariants along the perturbed run: max `|⟨Ω, ξ⟩|/(|Ω||ξ|)`.
    pub max_constraint: f64,
}

/// The paper's R2Q4 experiment: perturb `ξ̇` of `control` by `perturbation`, integrate `ξ`
/// consistently from `ξ(a)`, and report how far `Ω` moves from the unperturbed run.
pub fn stability_experiment(
    inertia: &Inertia,
    omega_a: &Vector3<f64>,
    interval: (f64, f64),
    control: &Control<'_>,
    perturbation: Perturbation,
    times: &[f64],
    options: &IvpOptions,
) -> Result<StabilityReport, SuslovError> {
    let ellipsoid = validate(inertia, omega_a, interval, times)?;
    if let Perturbation::Additive { direction, .. } = perturbation {
        if !(direction.norm() > 0.0 && direction.norm().is_finite()) {
            return Err(SuslovError::InvalidInput {
                what: format!("perturbation direction {direction:?} must be finite and non-zero"),
            });
        }
    }
    let (xi_a, _) = control(interval.0)?;
    let failure: RefCell<Option<SuslovError>> = RefCell::new(None);
    let xi_dot_of = |t: f64| match control(t) {
        Ok((_, xd)) => xd,
        Err(e) => {
            failure.borrow_mut().get_or_insert(e);
            Vector3::repeat(f64::NAN)
        }
    };
    let base = reintegrate_with_xi_dot(
        inertia,
        omega_a,
        &xi_a,
        interval,
        &|t, _| xi_dot_of(t),
        times,
        options,
    );
    let pert = reintegrate_with_xi_dot(
        inertia,
        omega_a,
        &xi_a,
        interval,
        &|t, _| perturbation.apply(t, xi_dot_of(t)),
        times,
        options,
    );
    if let Some(e) = failure.into_inner() {
        return Err(e);
    }
    let (base, pert) = (base?, pert?);
    let cmp = compare(&pert, &base.omega, &ellipsoid)?;
    let max_xi_deviation = pert
        .xi
        .iter()
        .zip(&base.xi)
        .map(|(p, b)| (p - b).norm())
        .fold(0.0, f64::max);
    let last = base.omega.len() - 1;
    Ok(StabilityReport {
        perturbation,
        max_deviation: cmp.max_abs_diff,
        t_max_deviation: cmp.t_max_abs_diff,
        final_deviation: (pert.omega[last] - base.omega[last]).norm(),
        max_xi_deviation,
        max_rel_energy_drift: cmp.max_rel_energy_drift,
        max_constraint: cmp.max_constraint,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::so3::desired::{DesiredPath, PaperSpiral, Projected};

    fn grid(a: f64, b: f64, m: usize) -> Vec<f64> {
        (0..=m)
            .map(|k| {
                if k == m {
                    b
                } else {
                    a + (b - a) * k as f64 / m as f64
                }
            })
            .collect()
    }

    fn singular_of(
        path: &dyn DesiredPath,
    ) -> impl Fn(f64) -> Result<(Vector3<f64>, Vector3<f64>), SuslovError> + '_ {
        singular_control_fn(path, Inertia::paper())
    }

    #[test]
    fn principal_axis_constraint_keeps_omega_constant() {
        // xi = e3, Omega in the e1-e2 plane: (I Om) x Om and lambda xi cancel, Om is constant.
        let i = Inertia::paper();
        let om_a = Vector3::new(3.0, -4.0, 0.0);
        let control = |_t: f64| Ok((Vector3::z(), Vector3::zeros()));
        let times = grid(0.0, 20.0, 40);
        let run = reintegrate(
            &i,
            &om_a,
            (0.0, 20.0),
            &control,
            &times,
            &IvpOptions::default(),
        )
        .unwrap();
        let e = EnergyEllipsoid::through(i, &om_a).unwrap();
        let c = compare(&run, &vec![om_a; times.len()], &e).unwrap();
        assert!(c.max_abs_diff < 1e-12, "{c:?}");
        assert!(
            c.max_rel_energy_drift < 1e-14 && c.max_constraint < 1e-15,
            "{c:?}"
        );
    }

    #[test]
    fn invariants_with_constant_and_rotating_constraints() {
        let i = Inertia::paper();
        // Constant, non-principal xi: Omega moves, energy and <Om, xi> are invariant.
        let xi = Vector3::new(1.0, 1.0, 1.0).normalize();
        let om_a = Vector3::new(2.0, -1.0, -1.0);
        let times = grid(0.0, 20.0, 200);
        let e = EnergyEllipsoid::through(i, &om_a).unwrap();
        let run = reintegrate(
            &i,
            &om_a,
            (0.0, 20.0),
            &|_t| Ok((xi, Vector3::zeros())),
            &times,
            &IvpOptions::default(),
        )
        .unwrap();
        let c = compare(&run, &vec![om_a; times.len()], &e).unwrap();
        assert!(c.max_abs_diff > 0.1, "Omega should move: {c:?}");
        assert!(
            c.max_rel_energy_drift < 1e-10 && c.max_constraint < 1e-10,
            "{c:?}"
        );
        // Rotating xi(t) = (cos t, sin t, 1/2), Omega_a ⟂ xi(0).
        let control = |t: f64| {
            let (s, co) = t.sin_cos();
            Ok((Vector3::new(co, s, 0.5), Vector3::new(-s, co, 0.0)))
        };
        let om_a = Vector3::new(0.0, 1.0, 0.0);
        let e = EnergyEllipsoid::through(i, &om_a).unwrap();
        let run = reintegrate(
            &i,
            &om_a,
            (0.0, 20.0),
            &control,
            &times,
            &IvpOptions::default(),
        )
        .unwrap();
        let c = compare(&run, &vec![om_a; times.len()], &e).unwrap();
        assert!(c.max_abs_diff > 0.1, "Omega should move: {c:?}");
        assert!(
            c.max_rel_energy_drift < 1e-10 && c.max_constraint < 1e-10,
            "{c:?}"
        );
    }

    #[test]
    fn singular_control_reproduces_the_projected_spiral() {
        let p = PaperSpiral::paper();
        let i = Inertia::paper();
        let times = grid(0.0, 10.0, 500);
        let projected = Projected::new(p.clone(), *p.ellipsoid());
        for (name, path) in [
            ("phi_par", p.phi_par() as &dyn DesiredPath),
            ("Projected(Om_d)", &projected as &dyn DesiredPath),
        ] {
            let control = singular_of(path);
            let run = reintegrate(
                &i,
                &p.omega_a(),
                (0.0, 10.0),
                &control,
                &times,
                &IvpOptions::default(),
            )
            .unwrap();
            let reference: Vec<_> = times.iter().map(|&t| path.value(t)).collect();
            let c = compare(&run, &reference, p.ellipsoid()).unwrap();
            eprintln!("{name}: {c:?}, {:?}", run.stats);
            assert!(c.max_abs_diff < 1e-8, "{name}: {c:?}");
            assert!(
                c.max_rel_energy_drift < 1e-10 && c.max_constraint < 1e-10,
                "{name}: {c:?}"
            );
            // End point: Omega(b_p) = Omega_b.
            assert!((run.omega[times.len() - 1] - p.omega_b()).norm() < 1e-8);
        }
    }

    #[test]
    fn stability_experiment_on_the_singular_control() {
        let p = PaperSpiral::paper();
        let i = Inertia::paper();
        let times = grid(0.0, 10.0, 200);
        let control = singular_of(p.phi_par());
        let o = IvpOptions::default();
        let run = |pert| {
            stability_experiment(&i, &p.omega_a(), (0.0, 10.0), &control, pert, &times, &o).unwrap()
        };
        let zero = run(Perturbation::Modulated { eps: 0.0, k: 3.0 });
        assert_eq!(zero.max_deviation, 0.0);
        let m2 = run(Perturbation::Modulated { eps: 1e-2, k: 3.0 });
        let m3 = run(Perturbation::Modulated { eps: 1e-3, k: 3.0 });
        let a2 = run(Perturbation::Additive {
            eps: 1e-2,
            direction: Vector3::new(1.0, 1.0, 1.0),
        });
        let a3 = run(Perturbation::Additive {
            eps: 1e-3,
            direction: Vector3::new(1.0, 1.0, 1.0),
        });
        let a4 = run(Perturbation::Additive {
            eps: 1e-4,
            direction: Vector3::new(1.0, 1.0, 1.0),
        });
        for r in [m2, m3, a2, a3, a4] {
            eprintln!("{r:?}");
            assert!(r.max_deviation > 0.0 && r.max_deviation.is_finite());
            assert!(
                r.max_rel_energy_drift < 1e-10 && r.max_constraint < 1e-10,
                "{r:?}"
            );
        }
        // Linear response: ten times smaller perturbation, about ten times smaller deviation.
        let ratio = m3.max_deviation / m2.max_deviation;
        assert!((0.07..0.13).contains(&ratio), "ratio {ratio}");
    }

    #[test]
    fn control_errors_are_returned() {
        let i = Inertia::paper();
        let om_a = Vector3::new(5.0, 0.0, 0.0);
        let control = |t: f64| {
            if t > 0.5 {
                Err(SuslovError::InvalidInput {
                    what: "boom".into(),
                })
            } else {
                Ok((Vector3::z(), Vector3::zeros()))
            }
        };
        let err = reintegrate(
            &i,
            &om_a,
            (0.0, 1.0),
            &control,
            &[1.0],
            &IvpOptions::default(),
        )
        .unwrap_err();
        assert!(err.to_string().contains("boom"), "{err}");
        assert!(reintegrate(
            &i,
            &om_a,
            (1.0, 0.0),
            &control,
            &[1.0],
            &IvpOptions::default()
        )
        .is_err());
    }
}
