//! Dense reference computations for the second-order certificate tests.
#![allow(dead_code)]

use nalgebra::{DMatrix, DVector, SymmetricEigen};
use suslov::ocp::kkt::KktPoint;
use suslov::ocp::{OcpProblem, Transcription};

/// A dense matrix from entries `(row, col, value)` (summed; mirrored if `mirror`).
pub fn dense(
    entries: &[(usize, usize, f64)],
    rows: usize,
    cols: usize,
    mirror: bool,
) -> DMatrix<f64> {
    let mut d = DMatrix::zeros(rows, cols);
    for &(r, c, v) in entries {
        d[(r, c)] += v;
        if mirror && r != c {
            d[(c, r)] += v;
        }
    }
    d
}

/// Independent of the sparse inertia: an orthonormal basis Z of null(A) (eigenvectors of AᵀA
/// with eigenvalues below `1e-10 · max`), then the number of negative eigenvalues of ZᵀHZ and
/// the smallest generalized eigenvalue of (ZᵀHZ, ZᵀMZ). Asserts that A has full row rank.
pub fn dense_reduced<P: OcpProblem + ?Sized>(
    tr: &Transcription<'_, P>,
    pt: &KktPoint,
) -> (usize, f64) {
    let (nv, nc) = (tr.n_var(), tr.n_con());
    let a = dense(&tr.jacobian(&pt.v), nc, nv, false);
    let h = dense(&tr.lagrangian_hessian(&pt.v, &pt.y), nv, nv, true);
    let eig = SymmetricEigen::new(a.transpose() * &a);
    let scale = eig.eigenvalues.amax();
    let cols: Vec<usize> = (0..nv)
        .filter(|&i| eig.eigenvalues[i] < 1e-10 * scale)
        .collect();
    assert_eq!(cols.len(), nv - nc, "A has full row rank");
    let z = eig.eigenvectors.select_columns(&cols);
    let red = z.transpose() * &h * &z;
    let red = (&red + red.transpose()) * 0.5;
    let neg = SymmetricEigen::new(red.clone())
        .eigenvalues
        .iter()
        .filter(|&&e| e < 0.0)
        .count();
    let m = DMatrix::from_diagonal(&DVector::from_vec(tr.metric_diagonal(&pt.v)));
    let mz = z.transpose() * m * &z;
    let l = mz
        .cholesky()
        .expect("M is positive definite on null(A)")
        .l();
    let li = l.try_inverse().expect("invertible");
    let g = &li * red * li.transpose();
    let mu = SymmetricEigen::new((&g + g.transpose()) * 0.5)
        .eigenvalues
        .min();
    (neg, mu)
}
