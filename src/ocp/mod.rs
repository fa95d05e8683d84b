//! Generic optimal control: direct transcription of an OCP on a collocation mesh, its KKT
//! conditions, and second-order (local minimum) certification. Knows nothing of Suslov.
//!
//! - [`problem`]: the problem (dynamics, running cost, their derivatives and Hessians).
//! - [`transcription`]: the NLP on a mesh (4-stage Lobatto IIIA, as the BVP solver).
//! - [`kkt`]: KKT residuals, least-squares multipliers, Newton's method on the KKT system.
//! - [`mod@certify`]: the second-order test (inertia of the KKT matrix) and its margin.
//! - [`mod@sqp`]: a globalized SQP method (inertia correction, filter line search, restoration): the
//!   direct method that finds a minimum from a rough start.
//! - [`conjugate`]: the discrete conjugate point (where positivity is first lost in time).
//! - [`inertia`]: inertia (numbers of positive, negative and zero eigenvalues) of sparse
//!   symmetric (indefinite) matrices through an `L B Lᵀ` factorization.

pub mod certify;
pub mod conjugate;
pub mod inertia;
pub mod kkt;
pub mod problem;
pub mod sqp;
pub mod transcription;

pub use certify::{
    certify, certify_with_costates, Certificate, CertifyError, MultiplierStart, SecondOrderOptions,
    SecondOrderReport, Verdict,
};
pub use kkt::{KktError, KktPoint, KktResidual, NewtonOptions};
pub use problem::{Boundary, Horizon, LinearCondition, OcpProblem};
pub use sqp::{sqp, SqpError, SqpIterate, SqpOptions, SqpReport};
pub use transcription::{Transcription, TranscriptionError};
