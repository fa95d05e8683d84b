//! The plain data the output layer consumes, and quantities derived from it.

use super::ReportError;
use crate::model::generated::DIM;

/// One solved case, sampled on a grid (for example 2001 points) for output.
///
/// All columns must have the length of `t` (checked by [`TrajectoryTable::validate`], which
/// every writer calls). The table says nothing about how it was computed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TrajectoryTable {
    /// Time, increasing.
    pub t: Vec<f64>,
    /// Body angular velocity `Ω(t)` (the state block `OMEGA`).
    pub omega: Vec<[f64; DIM]>,
    /// Control direction `ξ(t)` (`XI`).
    pub xi: Vec<[f64; DIM]>,
    /// Control `ξ̇(t)` (`XIDOT`).
    pub xi_dot: Vec<[f64; DIM]>,
    /// Costates `κ(t)` (`KAPPA`).
    pub kappa: Vec<[f64; DIM]>,
    /// Desired body angular velocity `Ω_d(t)`.
    pub omega_d: Vec<[f64; DIM]>,
}

/// Summary statistics of a [`TrajectoryTable`] (see [`TrajectoryTable::stats`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableStats {
    /// `max_t |⟨Ω, ξ⟩|`.
    pub max_abs_constraint: f64,
    /// `min_t |ξ|`.
    pub xi_norm_min: f64,
    /// `max_t |ξ|`.
    pub xi_norm_max: f64,
    /// `max_t |⟨Ω, IΩ⟩ − ⟨Ω(t₀), IΩ(t₀)⟩| / ⟨Ω(t₀), IΩ(t₀)⟩`: relative drift of twice the
    /// kinetic energy, which the dynamics conserve.
    pub energy_drift: f64,
}

/// The constant-kinetic-energy ellipsoid `E = {v : ⟨v, I v⟩ = level}` of a rigid body with
/// diagonal inertia `I = diag(inertia)`; `level = ⟨Ω_a, I Ω_a⟩` (twice the kinetic energy).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyEllipsoid {
    /// Principal moments of inertia `[I1, I2, I3]`, all positive.
    pub inertia: [f64; 3],
    /// `⟨Ω_a, I Ω_a⟩`, positive.
    pub level: f64,
}

/// `⟨a, b⟩`.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Euclidean norm `|a|`.
pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

impl EnergyEllipsoid {
    /// The ellipsoid through `omega_a`: `level = ⟨Ω_a, I Ω_a⟩`.
    ///
    /// # Errors
    /// [`ReportError::InvalidInput`] if an inertia is not positive and finite or the level is
    /// not positive and finite (`Ω_a = 0`).
    pub fn through(inertia: [f64; 3], omega_a: [f64; 3]) -> Result<Self, ReportError> {
        let e = Self {
            inertia,
            level: Self::quadratic(inertia, omega_a),
        };
        e.check()?;
        Ok(e)
    }

    /// Checks that the inertia and the level are positive and finite.
    ///
    /// # Errors
    /// [`ReportError::InvalidInput`] describing the bad value.
    pub fn check(&self) -> Result<(), ReportError> {
        if !self.inertia.iter().all(|&i| i.is_finite() && i > 0.0) {
            return Err(ReportError::InvalidInput(format!(
                "inertia must be positive and finite, got {:?}",
                self.inertia
            )));
        }
        if !(self.level.is_finite() && self.level > 0.0) {
            return Err(ReportError::InvalidInput(format!(
                "energy level must be positive and finite, got {}",
                self.level
            )));
        }
        Ok(())
    }

    fn quadratic(inertia: [f64; 3], v: [f64; 3]) -> f64 {
        inertia[0] * v[0] * v[0] + inertia[1] * v[1] * v[1] + inertia[2] * v[2] * v[2]
    }

    /// `⟨v, I v⟩`.
    pub fn energy_form(&self, v: [f64; 3]) -> f64 {
        Self::quadratic(self.inertia, v)
    }

    /// The projection `v_∥ = sqrt(level / ⟨v, I v⟩) v` of `v` along its ray onto `E`; `None`
    /// for `v = 0` (or a non-finite `v`), whose ray does not meet `E`.
    pub fn project(&self, v: [f64; 3]) -> Option<[f64; 3]> {
        let q = self.energy_form(v);
        if !(q.is_finite() && q > 0.0) {
            return None;
        }
        let s = (self.level / q).sqrt();
        Some([s * v[0], s * v[1], s * v[2]])
    }

    /// Semi-axes `sqrt(level / I_k)`.
    pub fn semi_axes(&self) -> [f64; 3] {
        [
            (self.level / self.inertia[0]).sqrt(),
            (self.level / self.inertia[1]).sqrt(),
            (self.level / self.inertia[2]).sqrt(),
        ]
    }
}

impl TrajectoryTable {
    /// Number of rows (the length of `t`).
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether the table has no rows.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// Checks that every column has the length of `t`.
    ///
    /// # Errors
    /// [`ReportError::LengthMismatch`] naming the first offending column.
    pub fn validate(&self) -> Result<(), ReportError> {
        let expected = self.t.len();
        for (column, len) in [
            ("omega", self.omega.len()),
            ("xi", self.xi.len()),
            ("xi_dot", self.xi_dot.len()),
            ("kappa", self.kappa.len()),
            ("omega_d", self.omega_d.len()),
        ] {
            if len != expected {
                return Err(ReportError::LengthMismatch {
                    column,
                    len,
                    expected,
                });
            }
        }
        Ok(())
    }

    /// The nonholonomic constraint `⟨Ω(t), ξ(t)⟩` at every row (zero for an exact solution).
    pub fn constraint(&self) -> Vec<f64> {
        self.omega
            .iter()
            .zip(&self.xi)
            .map(|(&o, &x)| dot(o, x))
            .collect()
    }

    /// `|ξ(t)|` at every row.
    pub fn xi_norm(&self) -> Vec<f64> {
        self.xi.iter().map(|&x| norm(x)).collect()
    }

    /// `⟨Ω(t), I Ω(t)⟩` (twice the kinetic energy) at every row.
    pub fn energy(&self, inertia: [f64; 3]) -> Vec<f64> {
        self.omega
            .iter()
            .map(|&o| EnergyEllipsoid::quadratic(inertia, o))
            .collect()
    }

    /// The projection `ξ_∥` of `ξ(t)` onto the ellipsoid `E` at every row (see
    /// [`EnergyEllipsoid::project`]); rows where `ξ = 0` give `None`.
    pub fn xi_par(&self, ellipsoid: &EnergyEllipsoid) -> Vec<Option<[f64; 3]>> {
        self.xi.iter().map(|&x| ellipsoid.project(x)).collect()
    }

    /// `|Ω(t_end) − Ω_b|`: how well the terminal condition is met (NaN for an empty table).
    pub fn terminal_error(&self, omega_b: [f64; 3]) -> f64 {
        match self.omega.last() {
            Some(&o) => norm([o[0] - omega_b[0], o[1] - omega_b[1], o[2] - omega_b[2]]),
            None => f64::NAN,
        }
    }

    /// Constraint, `|ξ|` and energy statistics (see [`TableStats`]). Non-finite samples
    /// propagate (a NaN anywhere gives NaN), so that a broken solution is not hidden; an
    /// empty table gives NaN everywhere.
    pub fn stats(&self, inertia: [f64; 3]) -> TableStats {
        if self.is_empty() {
            return TableStats {
                max_abs_constraint: f64::NAN,
                xi_norm_min: f64::NAN,
                xi_norm_max: f64::NAN,
                energy_drift: f64::NAN,
            };
        }
        let c = self.constraint();
        let n = self.xi_norm();
        let e = self.energy(inertia);
        let e0 = e.first().copied().unwrap_or(f64::NAN);
        let drift = e.iter().map(|&v| ((v - e0) / e0).abs());
        TableStats {
            max_abs_constraint: nan_max(c.iter().map(|v| v.abs())),
            xi_norm_min: -nan_max(n.iter().map(|v| -v)),
            xi_norm_max: nan_max(n.iter().copied()),
            energy_drift: nan_max(drift),
        }
    }
}

/// Maximum that propagates NaN (unlike `f64::max`); `-inf` for an empty iterator.
fn nan_max(it: impl Iterator<Item = f64>) -> f64 {
    let mut m = f64::NEG_INFINITY;
    for v in it {
        if v.is_nan() {
            return f64::NAN;
        }
        if v > m {
            m = v;
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> TrajectoryTable {
        TrajectoryTable {
            t: vec![0.0, 1.0],
            omega: vec![[5.0, 0.0, 0.0], [0.0, 0.0, 5.0 / 3f64.sqrt()]],
            xi: vec![[0.0, 1.0, 0.0], [0.6, 0.0, 0.0]],
            xi_dot: vec![[0.0; 3]; 2],
            kappa: vec![[0.0; 3]; 2],
            omega_d: vec![[0.0; 3]; 2],
        }
    }

    #[test]
    fn derived_quantities() {
        let tab = small();
        tab.validate().unwrap();
        assert_eq!(tab.constraint(), vec![0.0, 0.0]);
        assert_eq!(tab.xi_norm(), vec![1.0, 0.6]);
        let s = tab.stats([1.0, 2.0, 3.0]);
        assert_eq!(s.max_abs_constraint, 0.0);
        assert_eq!((s.xi_norm_min, s.xi_norm_max), (0.6, 1.0));
        assert!(s.energy_drift < 1e-15, "{}", s.energy_drift);
        assert!((tab.terminal_error([0.0, 0.0, 5.0 / 3f64.sqrt()])).abs() < 1e-15);
    }

    #[test]
    fn projection_lands_on_the_ellipsoid() {
        let e = EnergyEllipsoid::through([1.0, 2.0, 3.0], [5.0, 0.0, 0.0]).unwrap();
        assert_eq!(e.level, 25.0);
        let proj = e.project([10.0, -3.0, 7.0]).unwrap();
        assert!((e.energy_form(proj) - 25.0).abs() < 1e-12);
        // Same ray: positive multiple of v.
        assert!((proj[1] / proj[0] + 0.3).abs() < 1e-15);
        assert_eq!(e.project([0.0; 3]), None);
        let xs = small().xi_par(&e);
        assert!((e.energy_form(xs[0].unwrap()) - 25.0).abs() < 1e-12);
        assert!(EnergyEllipsoid::through([1.0, 0.0, 3.0], [1.0, 0.0, 0.0]).is_err());
        assert!(EnergyEllipsoid::through([1.0, 2.0, 3.0], [0.0; 3]).is_err());
    }

    #[test]
    fn mismatched_lengths_are_reported() {
        let mut tab = small();
        tab.kappa.pop();
        let err = tab.validate().unwrap_err();
        assert!(
            matches!(
                err,
                ReportError::LengthMismatch {
                    column: "kappa",
                    len: 1,
                    expected: 2
                }
            ),
            "{err:?}"
        );
    }

    #[test]
    fn stats_propagate_nan() {
        let mut tab = small();
        tab.xi[1][0] = f64::NAN;
        let s = tab.stats([1.0, 2.0, 3.0]);
        assert!(s.max_abs_constraint.is_nan() && s.xi_norm_max.is_nan());
        assert!(TrajectoryTable::default()
            .stats([1.0; 3])
            .energy_drift
            .is_nan());
    }
}
