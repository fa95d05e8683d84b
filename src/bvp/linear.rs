//! The global (condensed) Newton system: pattern, assembly and sparse LU (faer).
//!
//! After condensation the unknowns are `y_0, ..., y_{m-1}` and `p`; the matrix is almost
//! block diagonal, bordered by the `k` parameter columns and the `n + k` boundary rows
//! (here `N = 3` intervals; `A_i`, `B_i` are `n x n`, `P_i` is `n x k`):
//!
//! ```text
//!            y_0   y_1   y_2   y_3    p
//!          +-----+-----+-----+-----+----+
//! Phi_0    | A_0 | B_0 |     |     | P_0|
//! Phi_1    |     | A_1 | B_1 |     | P_1|
//! Phi_2    |     |     | A_2 | B_2 | P_2|
//!          +-----+-----+-----+-----+----+
//! g        | Ga  |     |     | Gb  | Gp |   (n + k rows)
//!          +-----+-----+-----+-----+----+
//! ```
//!
//! The pattern depends only on `(n, k, m)`: it is built and analysed (COLAMD ordering,
//! symbolic LU) once per mesh size (and reused across solves on the same thread, which makes
//! warm starts on an unchanged mesh cheaper); each Newton Jacobian is a numeric
//! refactorisation only. The
//! fill of an LU with partial pivoting of this matrix stays `O(N n^2 (n + k))`, so work and
//! memory are linear in the number of intervals.

use std::cell::RefCell;
use std::rc::Rc;

use faer::linalg::solvers::SolveCore;
use faer::sparse::linalg::solvers::{Lu, SymbolicLu};
use faer::sparse::{Argsort, Pair, SparseColMat, SymbolicSparseColMat};
use faer::{Conj, MatMut};

/// Row/column index pairs of the structurally nonzero entries of the global Jacobian, in
/// assembly order: for each interval `i`, the rows `i*n .. i*n+n` of `[A_i B_i P_i]`
/// (row-major, columns `y_i`, `y_{i+1}`, `p`); then the `n + k` boundary rows `[Ga Gb Gp]`
/// (columns `y_0`, `y_{m-1}`, `p`). The matrix is square of order `m*n + k`.
pub fn global_jacobian_pattern(n: usize, k: usize, m: usize) -> Vec<(usize, usize)> {
    let nn = m - 1;
    let po = m * n;
    let mut idx = Vec::with_capacity((nn * n + n + k) * (2 * n + k));
    for i in 0..nn {
        for r in 0..n {
            let row = i * n + r;
            for c in 0..2 * n {
                idx.push((row, i * n + c));
            }
            for c in 0..k {
                idx.push((row, po + c));
            }
        }
    }
    for r in 0..n + k {
        let row = nn * n + r;
        for c in 0..n {
            idx.push((row, c));
        }
        for c in 0..n {
            idx.push((row, (m - 1) * n + c));
        }
        for c in 0..k {
            idx.push((row, po + c));
        }
    }
    idx
}

/// Why the global factorisation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FactorError {
    /// The LU found no usable pivot (column index) or produced non-finite factors.
    Singular,
}

/// The global sparse system of one mesh with its cached symbolic analysis.
pub(crate) struct GlobalSystem {
    order: usize,
    structure: Rc<Structure>,
    /// Values in [`global_jacobian_pattern`] order.
    pub values: Vec<f64>,
    lu: Option<Lu<usize, f64>>,
}

/// Everything that depends only on `(n, k, m)`: the pattern, its CSC structure with the
/// value order, and the symbolic LU (COLAMD ordering, elimination structure).
struct Structure {
    key: (usize, usize, usize),
    pattern: Vec<(usize, usize)>,
    symbolic: SymbolicSparseColMat<usize>,
    argsort: Argsort<usize>,
    symbolic_lu: SymbolicLu<usize>,
}

thread_local! {
    /// The structure of the last mesh size seen on this thread. Warm starts and continuation
    /// re-solve on the same mesh many times; the structure is a pure function of `(n, k, m)`,
    /// so reusing it changes no result and skips the COLAMD ordering and symbolic analysis.
    static LAST_STRUCTURE: RefCell<Option<Rc<Structure>>> = const { RefCell::new(None) };
}

impl Structure {
    fn build(n: usize, k: usize, m: usize) -> Self {
        let order = m * n + k;
        let pattern = global_jacobian_pattern(n, k, m);
        let pairs: Vec<Pair<usize, usize>> =
            pattern.iter().map(|&(r, c)| Pair::new(r, c)).collect();
        let (symbolic, argsort) = SymbolicSparseColMat::try_new_from_indices(order, order, &pairs)
            .expect("the global pattern has in-bounds, well-formed indices by construction");
        let symbolic_lu = SymbolicLu::try_new(symbolic.as_ref())
            .expect("symbolic LU of the global pattern (allocation failure)");
        Self {
            key: (n, k, m),
            pattern,
            symbolic,
            argsort,
            symbolic_lu,
        }
    }
}

impl GlobalSystem {
    /// The system for `n` states, `k` parameters, `m` nodes: pattern and symbolic LU are
    /// built, or reused if the previous system on this thread had the same sizes.
    pub fn new(n: usize, k: usize, m: usize) -> Self {
        let structure = LAST_STRUCTURE.with(|cell| {
            let mut last = cell.borrow_mut();
            match last.as_ref() {
                Some(s) if s.key == (n, k, m) => Rc::clone(s),
                _ => {
                    let s = Rc::new(Structure::build(n, k, m));
                    *last = Some(Rc::clone(&s));
                    s
                }
            }
        });
        Self {
            order: m * n + k,
            values: vec![0.0; structure.pattern.len()],
            structure,
            lu: None,
        }
    }

    /// Numeric LU of the current `values` (symbolic analysis reused).
    pub fn factor(&mut self) -> Result<(), FactorError> {
        self.lu = None;
        let st = &self.structure;
        let mat = SparseColMat::new_from_argsort(st.symbolic.clone(), &st.argsort, &self.values)
            .map_err(|_| FactorError::Singular)?;
        let lu = Lu::try_new_with_symbolic(st.symbolic_lu.clone(), mat.as_ref())
            .map_err(|_| FactorError::Singular)?;
        self.lu = Some(lu);
        Ok(())
    }

    /// Solve `J x = rhs` in place with the last factorisation. Returns `false` if there is
    /// no factorisation or the solution is not finite (a zero pivot).
    pub fn solve_in_place(&self, rhs: &mut [f64]) -> bool {
        let Some(lu) = &self.lu else { return false };
        let n = rhs.len();
        lu.solve_in_place_with_conj(Conj::No, MatMut::from_column_major_slice_mut(rhs, n, 1));
        rhs.iter().all(|v| v.is_finite())
    }

    /// Sensitivity of the discrete solution to the boundary data: `max_r ||J^{-1} e_r||_inf`
    /// over the `rows` boundary rows starting at `first_row` (the response of `y` and `p` to a
    /// unit change of one boundary condition; TWPBVPC's `kappa_1` in discrete form). Costs
    /// `2 rows` solves with the current factorisation.
    ///
    /// Every solve is checked by one step of iterative refinement: if the refinement changes
    /// the response by more than 1e-3 of its size, the matrix is singular to working
    /// precision and the result is infinite (as it is without a factorisation).
    pub fn bc_sensitivity(&self, first_row: usize, rows: usize) -> f64 {
        let mut worst = 0.0_f64;
        let mut z = vec![0.0; self.order];
        let mut r = vec![0.0; self.order];
        for row in 0..rows {
            z.iter_mut().for_each(|v| *v = 0.0);
            z[first_row + row] = 1.0;
            if !self.solve_in_place(&mut z) {
                return f64::INFINITY;
            }
            // r = e - J z, then the refinement J^{-1} r.
            r.iter_mut().for_each(|v| *v = 0.0);
            r[first_row + row] = 1.0;
            for (&(i, j), v) in self.structure.pattern.iter().zip(&self.values) {
                r[i] -= v * z[j];
            }
            if !self.solve_in_place(&mut r) {
                return f64::INFINITY;
            }
            let size = z.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
            let change = r.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
            if change.is_nan() || change > 1e-3 * size {
                return f64::INFINITY;
            }
            worst = worst.max(size);
        }
        worst
    }

    /// Estimate of the 1-norm condition number `||DJ||_1 ||(DJ)^{-1}||_1` of the last factored
    /// matrix after row equilibration (`D` scales every row to unit max-norm, so a boundary
    /// condition multiplied by 1e20 does not count as ill-conditioning). Hager's estimator as
    /// refined by Higham (TOMS 14, 1988): at most 5 pairs of solves with `J` and `J^T`.
    /// Infinite if there is no factorisation or a solve fails.
    pub fn condition_estimate(&self) -> f64 {
        let Some(lu) = &self.lu else {
            return f64::INFINITY;
        };
        let order = self.order;
        let pattern = &self.structure.pattern;
        let mut row_max = vec![0.0_f64; order];
        for (&(r, _), v) in pattern.iter().zip(&self.values) {
            row_max[r] = row_max[r].max(v.abs());
        }
        if row_max.iter().any(|&v| v == 0.0 || !v.is_finite()) {
            return f64::INFINITY;
        }
        let mut col_sums = vec![0.0; order];
        for (&(r, c), v) in pattern.iter().zip(&self.values) {
            col_sums[c] += v.abs() / row_max[r];
        }
        let norm = col_sums.iter().fold(0.0_f64, |a, &v| a.max(v));
        // (DJ)^{-1} x = J^{-1} (D^{-1} x),   (DJ)^{-T} z = D^{-1} (J^{-T} z).
        let mut x = vec![1.0 / order as f64; order];
        let mut y = vec![0.0; order];
        let mut est = 0.0;
        for iter in 0..5 {
            for ((yv, xv), d) in y.iter_mut().zip(&x).zip(&row_max) {
                *yv = xv * d;
            }
            lu.solve_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut y, order, 1),
            );
            if !y.iter().all(|v| v.is_finite()) {
                return f64::INFINITY;
            }
            let new_est: f64 = y.iter().map(|v| v.abs()).sum();
            if iter > 0 && new_est <= est {
                break;
            }
            est = new_est;
            let mut z: Vec<f64> = y
                .iter()
                .map(|&v| if v >= 0.0 { 1.0 } else { -1.0 })
                .collect();
            lu.solve_transpose_in_place_with_conj(
                Conj::No,
                MatMut::from_column_major_slice_mut(&mut z, order, 1),
            );
            for (zv, d) in z.iter_mut().zip(&row_max) {
                *zv *= d;
            }
            if !z.iter().all(|v| v.is_finite()) {
                return f64::INFINITY;
            }
            let (j, zmax) = z.iter().enumerate().fold((0, 0.0_f64), |(bj, bv), (i, v)| {
                if v.abs() > bv {
                    (i, v.abs())
                } else {
                    (bj, bv)
                }
            });
            let ztx: f64 = z.iter().zip(&x).map(|(a, b)| a * b).sum();
            if iter > 0 && zmax <= ztx {
                break;
            }
            x.iter_mut().for_each(|v| *v = 0.0);
            x[j] = 1.0;
        }
        norm * est
    }

    /// The assembled matrix as dense row-major (tests only).
    #[cfg(test)]
    pub fn to_dense(&self) -> Vec<f64> {
        let mut d = vec![0.0; self.order * self.order];
        for (&(r, c), v) in self.structure.pattern.iter().zip(&self.values) {
            d[r * self.order + c] += v;
        }
        d
    }
}
