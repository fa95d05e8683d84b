//! Checks of paper section 5.1, Properties 1–3, for a candidate `Ω_p` on `[a, b_p]`.
//!
//! - **P1** end points: `|Ω_p(a) − Ω_a|`, `|Ω_p(b_p) − Ω_b|`.
//! - **P2** on `E`: `max |⟨IΩ_p, Ω_p⟩ − ⟨IΩ_a, Ω_a⟩| / ⟨IΩ_a, Ω_a⟩` and `max |⟨IΩ_p, Ω̇_p⟩|`.
//! - **P3** not an Euler solution: `min |IΩ̇_p − (IΩ_p) × Ω_p|`, which must be bounded away
//!   from 0 (it is `|ξ̃|`, the normaliser of the singular control `ξ_p`).
//!
//! Extrema are taken over a uniform grid of `samples` points including both ends. The
//! largest `|ξ̇_p|` on the grid is also reported: it measures how hard the singular control
//! turns (it involves `Ω̈_p`).

use nalgebra::Vector3;
use serde::Serialize;

use super::desired::DesiredPath;
use super::ellipsoid::{EnergyEllipsoid, Inertia};
use super::singular::singular_control;
use super::SuslovError;

/// Measured Properties 1–3 of a path on `[a, b_p]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PropertyReport {
    /// Start of the interval.
    pub a: f64,
    /// End of the interval.
    pub b_p: f64,
    /// Number of grid points (uniform, both ends included).
    pub samples: usize,
    /// P1: `|Ω_p(a) − Ω_a|`.
    pub start_error: f64,
    /// P1: `|Ω_p(b_p) − Ω_b|`.
    pub end_error: f64,
    /// P2: max relative energy deviation `|⟨IΩ,Ω⟩ − ⟨IΩ_a,Ω_a⟩| / ⟨IΩ_a,Ω_a⟩`.
    pub max_rel_energy_deviation: f64,
    /// Where the max relative energy deviation occurs.
    pub t_max_rel_energy_deviation: f64,
    /// P2: max `|⟨IΩ, Ω̇⟩|` (the rate of change of `2T`, halved).
    pub max_power: f64,
    /// Where `max_power` occurs.
    pub t_max_power: f64,
    /// P3: min `|IΩ̇ − (IΩ) × Ω|`.
    pub min_euler_defect: f64,
    /// Where `min_euler_defect` occurs.
    pub t_min_euler_defect: f64,
    /// Max `|ξ̇_p|` of the singular control (infinite if P3 fails somewhere).
    pub max_xi_dot: f64,
    /// Where `max_xi_dot` occurs.
    pub t_max_xi_dot: f64,
}

impl PropertyReport {
    /// `true` if P1 holds to `abs_tol`, P2 to `rel_tol` (relative energy deviation) and P3
    /// with `min_euler_defect > min_defect`.
    pub fn holds(&self, abs_tol: f64, rel_tol: f64, min_defect: f64) -> bool {
        self.start_error <= abs_tol
            && self.end_error <= abs_tol
            && self.max_rel_energy_deviation <= rel_tol
            && self.min_euler_defect > min_defect
    }
}

/// Measures Properties 1–3 of `path` on `[a, b_p]` for `E(I, Ω_a)` and end point `Ω_b`,
/// sampling `samples >= 2` uniform points.
pub fn check_properties(
    path: &dyn DesiredPath,
    inertia: &Inertia,
    omega_a: &Vector3<f64>,
    omega_b: &Vector3<f64>,
    (a, b_p): (f64, f64),
    samples: usize,
) -> Result<PropertyReport, SuslovError> {
    if !(a.is_finite() && b_p.is_finite() && a < b_p && samples >= 2) {
        return Err(SuslovError::InvalidInput {
            what: format!(
                "check_properties needs finite a < b_p and samples >= 2; got a = {a}, b_p = {b_p}, samples = {samples}"
            ),
        });
    }
    let e = EnergyEllipsoid::through(*inertia, omega_a)?;
    let mut r = PropertyReport {
        a,
        b_p,
        samples,
        start_error: (path.value(a) - omega_a).norm(),
        end_error: (path.value(b_p) - omega_b).norm(),
        max_rel_energy_deviation: 0.0,
        t_max_rel_energy_deviation: a,
        max_power: 0.0,
        t_max_power: a,
        min_euler_defect: f64::INFINITY,
        t_min_euler_defect: a,
        max_xi_dot: 0.0,
        t_max_xi_dot: a,
    };
    let h = (b_p - a) / (samples - 1) as f64;
    for k in 0..samples {
        let t = if k + 1 == samples {
            b_p
        } else {
            a + k as f64 * h
        };
        let jet = path.jet(t);
        let dev = e.relative_mismatch(&jet.value).abs();
        if dev > r.max_rel_energy_deviation {
            r.max_rel_energy_deviation = dev;
            r.t_max_rel_energy_deviation = t;
        }
        let i_om = inertia.apply(&jet.value);
        let power = i_om.dot(&jet.d1).abs();
        if power > r.max_power {
            r.max_power = power;
            r.t_max_power = t;
        }
        // |ξ̃| = λ of the singular control, and |ξ̇_p| (infinite where P3 fails).
        let (defect, xi_dot) = match singular_control(inertia, &jet.value, &jet.d1, &jet.d2) {
            Ok(c) => (c.lambda, c.xi_dot.norm()),
            Err(SuslovError::EulerSolution { norm, .. }) => (norm, f64::INFINITY),
            Err(_) => (f64::NAN, f64::INFINITY),
        };
        if defect < r.min_euler_defect {
            r.min_euler_defect = defect;
            r.t_min_euler_defect = t;
        }
        if xi_dot > r.max_xi_dot {
            r.max_xi_dot = xi_dot;
            r.t_max_xi_dot = t;
        }
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::so3::desired::{Constant, PaperSpiral, Projected, ProjectedSegment};

    const N: usize = 100_001;

    #[test]
    fn measured_properties_of_the_paper_candidates() {
        let p = PaperSpiral::paper();
        let i = Inertia::paper();
        let (om_a, om_b) = (p.omega_a(), p.omega_b());
        let run = |path: &dyn DesiredPath, b: f64| {
            check_properties(path, &i, &om_a, &om_b, (0.0, b), N).unwrap()
        };
        let om_d = run(&p, 10.0);
        let projected = run(&Projected::new(p.clone(), *p.ellipsoid()), 10.0);
        let phi_par = run(p.phi_par(), 10.0);
        let seg = ProjectedSegment::new(i, om_a, om_b, 0.0, 10.0).unwrap();
        let segment = run(&seg, 10.0);
        for (name, r) in [
            ("Om_d", om_d),
            ("Projected(Om_d)", projected),
            ("phi_par", phi_par),
            ("segment", segment),
        ] {
            eprintln!("{name}: {r:#?}");
        }
        // How far the admissible candidates are from the paper's Om_d on [0, 10].
        let proj = Projected::new(p.clone(), *p.ellipsoid());
        let (mut gap_phi, mut gap_proj, mut first_diff) = (0.0f64, 0.0f64, f64::NAN);
        for k in 0..N {
            let t = 10.0 * k as f64 / (N - 1) as f64;
            let d = p.value(t);
            let g = (p.phi_par().value(t) - d).norm();
            if g > 0.0 && first_diff.is_nan() {
                first_diff = t;
            }
            gap_phi = gap_phi.max(g);
            gap_proj = gap_proj.max((proj.value(t) - d).norm());
        }
        eprintln!("max|phi_par - Om_d| = {gap_phi:e}, max|Projected(Om_d) - Om_d| = {gap_proj:e}, phi_par != Om_d from t = {first_diff}");
        assert!(first_diff > 9.8 && gap_phi < 5e-3 && gap_proj < 2e-5);
        // P1 for all four.
        for r in [om_d, projected, phi_par, segment] {
            assert!(r.start_error == 0.0 && r.end_error < 1e-14, "{r:?}");
        }
        // P2: the paper's Om_d leaves E near b_d; the projections do not.
        assert!(om_d.max_rel_energy_deviation > 1e-6, "{om_d:?}");
        assert!((om_d.t_max_rel_energy_deviation - 10.0).abs() < 0.05);
        for r in [projected, phi_par, segment] {
            assert!(r.max_rel_energy_deviation < 1e-14, "{r:?}");
            assert!(r.max_power < 1e-12, "{r:?}");
        }
        // P3 holds for the projected candidates.
        for r in [projected, phi_par, segment] {
            assert!(r.min_euler_defect > 0.1, "{r:?}");
            assert!(r.holds(1e-14, 1e-14, 0.1));
        }
        assert!(!om_d.holds(1e-14, 1e-14, 0.1));
    }

    #[test]
    fn euler_solution_fails_p3() {
        let i = Inertia::paper();
        let om_a = Vector3::new(5.0, 0.0, 0.0);
        let r = check_properties(&Constant(om_a), &i, &om_a, &om_a, (0.0, 1.0), 11).unwrap();
        assert_eq!(r.min_euler_defect, 0.0);
        assert_eq!(r.max_xi_dot, f64::INFINITY);
        assert!(!r.holds(1e-14, 1e-14, 1e-8));
        assert!(check_properties(&Constant(om_a), &i, &om_a, &om_a, (1.0, 0.0), 11).is_err());
    }
}
