//! The diagonal inertia tensor, kinetic energy and the constant-energy ellipsoid `E`.
//!
//! # Notation
//! - `I = diag(I1, I2, I3)`: principal moments of inertia (body frame), all finite and `> 0`.
//! - `T(Ω) = ½⟨IΩ, Ω⟩`: kinetic energy.
//! - `E(I, Ω_a) = { v : ⟨v, Iv⟩ = ⟨Ω_a, IΩ_a⟩ }` (paper eq. `eq_ellipsoid`). We call
//!   `⟨Ω_a, IΩ_a⟩ = 2T(Ω_a)` the *level* of `E`.
//! - `v_∥ = sqrt(⟨Ω_a, IΩ_a⟩ / ⟨v, Iv⟩) · v` (paper eq. `eq_par_proj`): the radial ("parallel")
//!   projection of `v ≠ 0` onto `E`, i.e. the intersection of the ray `{s v : s > 0}` with `E`.

use nalgebra::Vector3;

use super::desired::Scalar;
use super::SuslovError;

/// A diagonal inertia tensor `I = diag(I1, I2, I3)` with finite, strictly positive entries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inertia {
    diag: Vector3<f64>,
}

impl Inertia {
    /// Builds `diag(i1, i2, i3)`; every moment must be finite and `> 0`.
    pub fn new(diag: [f64; 3]) -> Result<Self, SuslovError> {
        if diag.iter().all(|d| d.is_finite() && *d > 0.0) {
            Ok(Self {
                diag: Vector3::from(diag),
            })
        } else {
            Err(SuslovError::InvalidInertia { inertia: diag })
        }
    }

    /// The paper's inertia `diag(1, 2, 3)` (section 5.3).
    pub fn paper() -> Self {
        Self {
            diag: Vector3::new(1.0, 2.0, 3.0),
        }
    }

    /// The principal moments `[I1, I2, I3]`.
    pub fn diag(&self) -> Vector3<f64> {
        self.diag
    }

    /// `I v`.
    pub fn apply(&self, v: &Vector3<f64>) -> Vector3<f64> {
        self.diag.component_mul(v)
    }

    /// `I⁻¹ v`.
    pub fn apply_inv(&self, v: &Vector3<f64>) -> Vector3<f64> {
        v.component_div(&self.diag)
    }

    /// `⟨v, I v⟩` for a generic (possibly dual) vector.
    pub(crate) fn quadratic_form<D: Scalar>(&self, v: &[D]) -> D {
        v[0] * v[0] * self.diag[0] + v[1] * v[1] * self.diag[1] + v[2] * v[2] * self.diag[2]
    }
}

pub(crate) use crate::lie::path::{is_normal_positive, project_radially_in_place};

/// Kinetic energy `T = ½⟨IΩ, Ω⟩`.
pub fn kinetic_energy(inertia: &Inertia, omega: &Vector3<f64>) -> f64 {
    0.5 * inertia.apply(omega).dot(omega)
}

/// The constant kinetic energy ellipsoid `E(I, Ω_a)` on which every Suslov trajectory with
/// `⟨Ω, ξ⟩ = 0` starting at `Ω_a` lies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyEllipsoid {
    inertia: Inertia,
    level: f64,
}

impl EnergyEllipsoid {
    /// The ellipsoid through `omega_a`; `omega_a` must be finite and non-zero, and its level
    /// `⟨Ω_a, IΩ_a⟩` a normal `f64` (neither overflowing nor in the subnormal range, where it
    /// has too few significant bits for the relative energy checks).
    pub fn through(inertia: Inertia, omega_a: &Vector3<f64>) -> Result<Self, SuslovError> {
        let level = inertia.apply(omega_a).dot(omega_a);
        if !is_normal_positive(level) {
            return Err(SuslovError::InvalidInput {
                what: format!(
                    "Omega_a = {:?} must be finite and non-zero to define an energy ellipsoid",
                    omega_a.as_slice()
                ),
            });
        }
        Ok(Self { inertia, level })
    }

    /// The inertia tensor `I`.
    pub fn inertia(&self) -> &Inertia {
        &self.inertia
    }

    /// The level `⟨Ω_a, IΩ_a⟩ = 2T`.
    pub fn level(&self) -> f64 {
        self.level
    }

    /// The kinetic energy `T` on `E`.
    pub fn energy(&self) -> f64 {
        0.5 * self.level
    }

    /// Relative energy mismatch `(⟨v, Iv⟩ − ⟨Ω_a, IΩ_a⟩) / ⟨Ω_a, IΩ_a⟩` (0 on `E`, `−1` at `v = 0`).
    pub fn relative_mismatch(&self, v: &Vector3<f64>) -> f64 {
        (self.inertia.apply(v).dot(v) - self.level) / self.level
    }

    /// Radial projection `v_∥ = sqrt(⟨Ω_a, IΩ_a⟩/⟨v, Iv⟩) v` (paper eq. `eq_par_proj`).
    ///
    /// Computed directly when `⟨v, Iv⟩` and the ratio are normal `f64`s, otherwise on
    /// `v / max|v_i|` (the projection only depends on the ray), so that a huge or tiny `v`
    /// (e.g. `1e200`, whose `⟨v, Iv⟩` overflows) is still projected. Errors for `v = 0` or a
    /// non-finite `v`, where the ray is undefined, and if the projection itself overflows.
    pub fn project(&self, v: &Vector3<f64>) -> Result<Vector3<f64>, SuslovError> {
        let fail = |reason| {
            Err(SuslovError::Projection {
                v: [v[0], v[1], v[2]],
                reason,
            })
        };
        if !v.iter().all(|x| x.is_finite()) {
            return fail("the vector is not finite");
        }
        let m = v.amax();
        if m == 0.0 {
            return fail("the zero vector spans no ray");
        }
        let q = self.inertia.apply(v).dot(v);
        let ratio = self.level / q;
        if is_normal_positive(q) && is_normal_positive(ratio) {
            return Ok(v * ratio.sqrt());
        }
        let u = v / m;
        let q = self.inertia.apply(&u).dot(&u);
        let p = u * (self.level.sqrt() / q.sqrt());
        if p.iter().all(|x| x.is_finite()) {
            Ok(p)
        } else {
            fail("its projection overflows f64")
        }
    }

    /// Generic radial projection used by the dual-number path code, scaled like
    /// [`EnergyEllipsoid::project`] when `⟨v, Iv⟩` over- or underflows (by the largest
    /// `|v_i|` at the point, a constant, so the derivatives stay exact). No other checks: a
    /// zero vector gives non-finite output.
    pub(crate) fn project_generic<D: Scalar>(&self, mut v: [D; 3]) -> [D; 3] {
        project_radially_in_place(self.level, &mut v, |u| self.inertia.quadratic_form(u));
        v
    }

    /// Checks that a boundary value `v` (named e.g. `"Omega_b"`) lies on `E` to relative
    /// tolerance `rel_tol`, i.e. `|relative_mismatch(v)| <= rel_tol`.
    ///
    /// The error message gives the mismatch and the radial projection, e.g.
    /// "Omega_b is off Omega_a's energy ellipsoid by 1.2e-3 (relative); its projection is [..]".
    pub fn check_on(&self, name: &str, v: &Vector3<f64>, rel_tol: f64) -> Result<(), SuslovError> {
        let mismatch = self.relative_mismatch(v);
        if mismatch.abs() <= rel_tol {
            return Ok(());
        }
        let projection = match self.project(v) {
            Ok(proj) => format!("[{:.16e}, {:.16e}, {:.16e}]", proj[0], proj[1], proj[2]),
            Err(e) => format!("undefined ({e})"),
        };
        Err(SuslovError::OffEllipsoid {
            name: name.to_string(),
            mismatch,
            projection,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn paper_e() -> EnergyEllipsoid {
        EnergyEllipsoid::through(Inertia::paper(), &Vector3::new(5.0, 0.0, 0.0)).unwrap()
    }

    #[test]
    fn kinetic_energy_of_paper_initial_state() {
        let om = Vector3::new(5.0, 0.0, 0.0);
        assert_eq!(kinetic_energy(&Inertia::paper(), &om), 12.5);
        assert_eq!(paper_e().energy(), 12.5);
        assert_eq!(paper_e().level(), 25.0);
        let om = Vector3::new(1.0, 1.0, 1.0);
        assert_eq!(kinetic_energy(&Inertia::paper(), &om), 3.0);
    }

    #[test]
    fn inertia_rejects_non_positive_or_non_finite() {
        assert!(Inertia::new([1.0, 0.0, 3.0]).is_err());
        assert!(Inertia::new([1.0, -2.0, 3.0]).is_err());
        assert!(Inertia::new([1.0, f64::NAN, 3.0]).is_err());
        assert!(Inertia::new([1.0, 2.0, f64::INFINITY]).is_err());
        assert_eq!(Inertia::new([1.0, 2.0, 3.0]).unwrap(), Inertia::paper());
        assert!(EnergyEllipsoid::through(Inertia::paper(), &Vector3::zeros()).is_err());
    }

    #[test]
    fn projection_lands_on_ellipsoid_along_the_ray() {
        let e = paper_e();
        let v = Vector3::new(10.0, -3.0, 7.5);
        let p = e.project(&v).unwrap();
        assert_relative_eq!(e.relative_mismatch(&p), 0.0, epsilon = 1e-15);
        // Same direction, positive factor.
        assert_relative_eq!(p.normalize(), v.normalize(), epsilon = 1e-15);
        // Idempotent.
        assert_relative_eq!(e.project(&p).unwrap(), p, epsilon = 1e-14);
        // phi(0) = [10, 0, 0] projects onto Omega_a = [5, 0, 0] exactly.
        assert_eq!(
            e.project(&Vector3::new(10.0, 0.0, 0.0)).unwrap(),
            Vector3::new(5.0, 0.0, 0.0)
        );
    }

    #[test]
    fn projection_errors_on_zero_and_non_finite() {
        let e = paper_e();
        assert!(matches!(
            e.project(&Vector3::zeros()),
            Err(SuslovError::Projection { .. })
        ));
        assert!(e.project(&Vector3::new(f64::NAN, 1.0, 0.0)).is_err());
        assert!(e.project(&Vector3::new(f64::INFINITY, 1.0, 0.0)).is_err());
        // An overflowing (or underflowing) quadratic form is projected on the scaled ray,
        // not reported as "not finite" or projected to 0 or NaN.
        assert_eq!(
            e.project(&Vector3::new(1e200, 0.0, 0.0)).unwrap(),
            Vector3::new(5.0, 0.0, 0.0)
        );
        let p = e.project(&Vector3::new(1e308, -1e308, 1e308)).unwrap();
        assert_relative_eq!(e.relative_mismatch(&p), 0.0, epsilon = 1e-15);
        assert_relative_eq!(p.normalize(), Vector3::new(1.0, -1.0, 1.0).normalize());
        let p = e.project(&Vector3::new(1e-320, 0.0, 0.0)).unwrap();
        assert_eq!(p, Vector3::new(5.0, 0.0, 0.0));
        // The generic (dual-number) projection agrees, derivatives included.
        let v = Vector3::new(3e300, -1e300, 2e300);
        let g = e.project_generic([v[0], v[1], v[2]]);
        assert_relative_eq!(Vector3::from(g), e.project(&v).unwrap(), epsilon = 1e-14);
        let small = e.project_generic([3e-300, -1e-300, 2e-300]);
        assert_relative_eq!(Vector3::from(small), Vector3::from(g), epsilon = 1e-14);
    }

    #[test]
    fn mismatch_message_names_the_point_and_its_projection() {
        let e = paper_e();
        let off = Vector3::new(2.7541, -2.3109, -1.4983);
        let err = e.check_on("Omega_b", &off, 1e-10).unwrap_err().to_string();
        assert!(
            err.starts_with("Omega_b is off Omega_a's energy ellipsoid by "),
            "{err}"
        );
        assert!(err.contains("(relative); its projection is ["), "{err}");
        let on = e.project(&off).unwrap();
        assert!(e.check_on("Omega_b", &on, 1e-12).is_ok());
        assert_relative_eq!(e.relative_mismatch(&Vector3::zeros()), -1.0);
    }
}
