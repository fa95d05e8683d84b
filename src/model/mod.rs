//! The models, generated from first principles: one module per file `codegen/models/<name>.py`.
//!
//! Each model module (e.g. [`so3`]) is emitted by the sympy program in `codegen/` (see
//! `codegen/README.md`): the model file declares the Lie algebra (structure constants or a
//! matrix representation), the inertia operator, the constraint value and the cost; one
//! derivation (the paper's section 3, for any Lie algebra) turns it into Suslov's equations,
//! the costate (κ) equations, the explicit `ξ̈` by Sherman–Morrison, the boundary conditions,
//! the singular start, the control-affine form with its Lie brackets, the direct-transcription
//! functions and every Jacobian, printed as allocation-free Rust functions writing into
//! caller-provided fixed-size arrays.
//!
//! Every layout is in the generated metadata, so no caller re-types it: `DIM`, `N_STATE`,
//! `STATE_NAMES` and the state blocks `OMEGA`, `XI`, `XIDOT`, `KAPPA` (ranges into `y`);
//! `N_PARAM`, `PARAM_NAMES`, `PARAM_DOCS`, the index of each constant by name (`idx::BETA`),
//! and [`ParamMeta`] for the inertia parameters, the weights and the constraint parameters
//! (docs, admissible ranges, [`HomotopyRole`]). `w` = `[Ω_d, Ω̇_d]` is the desired path and its
//! time derivative at the current time.

/// What a weight (or constraint parameter) does in the staged homotopy that reaches it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HomotopyRole {
    /// Used at its target value from the start.
    Fixed,
    /// The control effort: the start uses a small value `beta_m`, then it is continued.
    Beta,
    /// Tracking weight: continued from the start's value to the target.
    Tracking,
    /// Smoothing weight: continued from 0 to the target.
    Smoothing,
    /// Weight of the terminal time: continued from `δ_c` (free terminal time only).
    Time,
    /// Constraint value: continued from 0 to the target.
    Constraint,
}

/// Generated metadata of one runtime constant of a model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamMeta {
    /// Name (the problem-file key).
    pub name: &'static str,
    /// Index in the constant vector `p`.
    pub index: usize,
    /// What it means.
    pub doc: &'static str,
    /// Lower bound of the admissible values, if any.
    pub lower: Option<f64>,
    /// Upper bound of the admissible values, if any.
    pub upper: Option<f64>,
    /// Whether the lower bound is exclusive.
    pub strict: bool,
    /// Its role in the homotopy.
    pub role: HomotopyRole,
}

impl ParamMeta {
    /// Whether `v` is admissible (finite and within the bounds).
    pub fn admits(&self, v: f64) -> bool {
        v.is_finite()
            && self
                .lower
                .is_none_or(|lo| if self.strict { v > lo } else { v >= lo })
            && self.upper.is_none_or(|hi| v <= hi)
    }
}

include!(concat!(env!("OUT_DIR"), "/models.rs"));
pub(crate) use with_model;

/// Why the derived constants of a parameter vector could not be filled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DerivedError {
    /// `p` does not have the model's length.
    #[error("the constant vector has {got} entries, the model {model} needs {expected}")]
    Length {
        /// The model.
        model: &'static str,
        /// Its `N_PARAM`.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// The inertia is not symmetric positive definite (or not finite) for these parameters.
    #[error(
        "the inertia of model {model} is not symmetric positive definite for these \
         parameters: check {names}"
    )]
    NotPositiveDefinite {
        /// The model.
        model: &'static str,
        /// The inertia parameters, comma-separated.
        names: String,
    },
}

/// Fill the derived constants of `p` (the entries of 𝕀⁻¹ of a non-diagonal inertia, at
/// `M::INERTIA_INVERSE_SLOTS`) from its inertia parameters: 𝕀 from `inertia_matrix`, inverted
/// by a Cholesky factorisation, which also checks that 𝕀 is symmetric positive definite.
/// Nothing to do for a diagonal inertia, but the check is made all the same.
pub fn fill_derived<M: Model>(p: &mut [f64]) -> Result<(), DerivedError> {
    if p.len() != M::N_PARAM {
        return Err(DerivedError::Length {
            model: M::NAME,
            expected: M::N_PARAM,
            got: p.len(),
        });
    }
    let n = M::DIM;
    let mut flat = vec![0.0; n * n];
    M::inertia_matrix(p, &mut flat);
    let mat = nalgebra::DMatrix::from_row_slice(n, n, &flat);
    let not_pd = || DerivedError::NotPositiveDefinite {
        model: M::NAME,
        names: M::INERTIA_PARAMS
            .iter()
            .map(|m| m.name)
            .collect::<Vec<_>>()
            .join(", "),
    };
    if !flat.iter().all(|v| v.is_finite()) || mat != mat.transpose() {
        return Err(not_pd());
    }
    let inv = mat.cholesky().ok_or_else(not_pd)?.inverse();
    for &(slot, r, c) in M::INERTIA_INVERSE_SLOTS {
        p[slot] = inv[(r, c)];
    }
    Ok(())
}

/// Whether the constraint value `γ(ξ)` of `M` vanishes for the constants `p` (then
/// `⟨Ω, ξ⟩ = 0` and the kinetic energy is conserved), judged from the generated
/// `constraint_residual`: `γ(ξ) = −φ(0, ξ)` at the basis directions and one mixed `ξ`, each of
/// unit and of double length. Always true for a model without a constraint value.
pub fn constraint_value_vanishes<M: Model>(p: &[f64]) -> bool {
    if !M::HAS_CONSTRAINT_VALUE {
        return true;
    }
    let n = M::DIM;
    let mut x = vec![0.0; 2 * n];
    let mut grad = vec![0.0; 2 * n];
    let mut directions: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| f64::from(u8::from(i == j))).collect())
        .collect();
    directions.push((0..n).map(|j| 1.0 / (1.0 + j as f64)).collect());
    directions.iter().all(|d| {
        [1.0, 2.0].iter().all(|scale| {
            x[..n].fill(0.0);
            x[n..].iter_mut().zip(d).for_each(|(v, e)| *v = scale * e);
            M::constraint_residual(&x, p, &mut grad) == 0.0
        })
    })
}

/// The constraint value `γ = −φ(0, 0)` of a model whose `γ` does not depend on `ξ`
/// (`!M::CONSTRAINT_VALUE_DEPENDS_ON_XI`; 0 for a model without a constraint value).
pub fn constant_constraint_value<M: Model>(p: &[f64]) -> f64 {
    debug_assert!(!M::CONSTRAINT_VALUE_DEPENDS_ON_XI);
    let x = vec![0.0; 2 * M::DIM];
    let mut grad = vec![0.0; 2 * M::DIM];
    -M::constraint_residual(&x, p, &mut grad)
}

/// The recorded codegen source hash of the generated model `name` (`""` for a name that is
/// not one).
pub fn source_hash_of(name: &str) -> &'static str {
    SOURCE_HASHES
        .iter()
        .find(|(n, _)| *n == name)
        .map_or("", |(_, h)| h)
}

/// The paper's model, Suslov's problem on so(3), which the problem layer ([`crate::so3`])
/// solves.
pub use so3 as generated;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn with_model_maps_every_name_to_its_type_and_nothing_else() {
        for name in MODEL_NAMES {
            let (got, dim) = with_model!(name, M => (M::NAME, M::DIM), _ => ("", 0));
            assert_eq!(got, name);
            assert!(dim >= 1);
        }
        assert_eq!(
            with_model!("no-such-model", M => M::NAME, _ => "none"),
            "none"
        );
        // The generic layout: four blocks of DIM in the order Omega, xi, xi', kappa.
        for name in MODEL_NAMES {
            with_model!(name, M => {
                assert_eq!(M::OMEGA, 0..M::DIM);
                assert_eq!(M::XI, M::DIM..2 * M::DIM);
                assert_eq!(M::XIDOT, 2 * M::DIM..3 * M::DIM);
                assert_eq!(M::KAPPA, 3 * M::DIM..4 * M::DIM);
                assert_eq!(M::N_STATE, 4 * M::DIM);
                assert_eq!(M::N_DESIRED, 2 * M::DIM);
                if let Some((k, flat)) = M::REPRESENTATION {
                    assert_eq!(flat.len(), M::DIM * k * k);
                }
            }, _ => unreachable!());
        }
    }
}
