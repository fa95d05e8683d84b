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
//! The matrix is factored by structured elimination (in blocks without the `y_0` border
//! when the boundary rows are separated), or structured QR where elimination
//! grows ([`abd`](super::abd)): `O(N n^2 (n + k))` work,
//! storage linear in the number of intervals, no symbolic analysis, no allocation in the
//! Newton loop. The values live in [`global_jacobian_pattern`] order, which is the blocks'
//! row-major order, so the condensation writes them where the factorisation reads them.

use super::abd::{row_nodes, AbdError, BorderedAbd, Factorization};

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
    /// A row is zero or not finite, or the matrix is singular to working precision.
    Singular,
}

/// Sweeps of Ruiz's 1-norm equilibration in [`GlobalSystem::condition_estimate`]. Twelve
/// bring the estimate of a matrix with one unknown's columns scaled by 1e6 to within a
/// factor 2 of the unscaled matrix's (the test below; the row-equilibrated estimate moves by
/// 4e5 to 1e6 there).
const EQUILIBRATION_SWEEPS: usize = 12;

/// The global system of one mesh: its values and their structured factorisation.
pub(crate) struct GlobalSystem {
    n: usize,
    k: usize,
    m: usize,
    /// Values in [`global_jacobian_pattern`] order (the blocks, row-major).
    pub values: Vec<f64>,
    abd: BorderedAbd,
    /// Workspace of [`Self::bc_sensitivity`] (two `order x rows` blocks; grown on demand).
    sensitivity: Vec<f64>,
}

impl GlobalSystem {
    /// The system for `n` states, `k` parameters, `m >= 2` nodes.
    pub fn new(n: usize, k: usize, m: usize) -> Self {
        let wc = 2 * n + k;
        Self {
            n,
            k,
            m,
            values: vec![0.0; ((m - 1) * n + n + k) * wc],
            abd: BorderedAbd::new(n, k, m - 1),
            sensitivity: Vec::new(),
        }
    }

    fn order(&self) -> usize {
        self.m * self.n + self.k
    }

    /// Factor the current `values`.
    pub fn factor(&mut self) -> Result<(), FactorError> {
        self.abd
            .factor(&self.values)
            .map_err(|AbdError::Singular| FactorError::Singular)
    }

    /// Growth of the last factorisation (see `BorderedAbd::growth`).
    pub fn growth(&self) -> f64 {
        self.abd.growth()
    }

    /// The reduction of the last factorisation.
    pub fn method(&self) -> Factorization {
        self.abd.method()
    }

    /// Smallest relative pivot of the last factorisation (see `BorderedAbd::min_pivot`).
    pub fn min_pivot(&self) -> f64 {
        self.abd.min_pivot()
    }

    /// Solve `J x = rhs` in place with the last factorisation. Returns `false` if there is
    /// no factorisation or the solution is not finite.
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> bool {
        self.abd.solve_in_place(rhs)
    }

    /// `r -= J z` from the blocks.
    #[cfg(test)]
    fn sub_mul(&self, z: &[f64], r: &mut [f64]) {
        let (n, k, m) = (self.n, self.k, self.m);
        let wc = 2 * n + k;
        let po = m * n;
        for (row, vals) in self.values.chunks_exact(wc).enumerate() {
            let (first, second) = row_nodes(row, n, m - 1);
            let acc: f64 = vals[..n]
                .iter()
                .zip(&z[first..first + n])
                .chain(vals[n..2 * n].iter().zip(&z[second..second + n]))
                .chain(vals[2 * n..].iter().zip(&z[po..po + k]))
                .map(|(a, b)| a * b)
                .sum();
            r[row] -= acc;
        }
    }

    /// Sensitivity of the discrete solution to the boundary data: `max_r ||J^{-1} e_r||_inf`
    /// over the `rows` boundary rows starting at `first_row` (the response of `y` and `p` to a
    /// unit change of one boundary condition; TWPBVPC's `kappa_1` in discrete form). Costs
    /// two solves with the current factorisation, each for all `rows` right-hand sides at
    /// once ([`BorderedAbd::solve_scaled_multi_in_place`]: the blocks are read once, not
    /// once per row; the first solve skips the forward sweep, which only carries zeros).
    ///
    /// Every response is checked by one step of iterative refinement: if the refinement
    /// changes a response by more than 1e-3 of its size, the matrix is singular to working
    /// precision and the result is infinite (as it is without a factorisation).
    ///
    /// Each column gets exactly the arithmetic of a solve of its own, so the value is the
    /// one column-by-column solves give (`tests::the_blocked_sensitivity_is_the_columnwise_one`).
    pub fn bc_sensitivity(&mut self, first_row: usize, rows: usize) -> f64 {
        let order = self.order();
        let r = rows;
        let mut work = std::mem::take(&mut self.sensitivity);
        work.clear();
        work.resize(2 * order * r + r, 0.0);
        let value = self.bc_sensitivity_in(first_row, rows, &mut work);
        self.sensitivity = work;
        value
    }

    fn bc_sensitivity_in(&mut self, first_row: usize, rows: usize, work: &mut [f64]) -> f64 {
        let (n, k, m) = (self.n, self.k, self.m);
        let (order, r) = (self.order(), rows);
        let (z, rest) = work.split_at_mut(order * r);
        let (res, acc) = rest.split_at_mut(order * r);
        // Z = (D J)^{-1} D E: column c is e_{first_row + c} scaled as `solve_in_place` scales.
        let d = self.abd.row_scale();
        for c in 0..r {
            z[(first_row + c) * r + c] = d[first_row + c];
        }
        let zero_intervals = first_row >= (m - 1) * n;
        if !self.abd.solve_scaled_multi_in_place(z, r, zero_intervals) {
            return f64::INFINITY;
        }
        // R = D (E - J Z), then the refinement (D J)^{-1} R. The products sum in the order
        // of `sub_mul`.
        let wc = 2 * n + k;
        let po = m * n;
        let d = self.abd.row_scale();
        for (row, vals) in self.values.chunks_exact(wc).enumerate() {
            let (first, second) = row_nodes(row, n, m - 1);
            acc.fill(-0.0);
            let columns = (0..n)
                .map(|c| first + c)
                .chain((0..n).map(|c| second + c))
                .chain((0..k).map(|c| po + c));
            for (a, col) in vals.iter().zip(columns) {
                for (s, zv) in acc.iter_mut().zip(&z[col * r..(col + 1) * r]) {
                    *s += a * zv;
                }
            }
            let out = &mut res[row * r..(row + 1) * r];
            for (c, (o, s)) in out.iter_mut().zip(acc.iter()).enumerate() {
                let e = if row == first_row + c { 1.0 } else { 0.0 };
                *o = (e - s) * d[row];
            }
        }
        if !self.abd.solve_scaled_multi_in_place(res, r, false) {
            return f64::INFINITY;
        }
        let mut worst = 0.0_f64;
        for c in 0..r {
            let size = (0..order).fold(0.0_f64, |a, i| a.max(z[i * r + c].abs()));
            let change = (0..order).fold(0.0_f64, |a, i| a.max(res[i * r + c].abs()));
            if change.is_nan() || change > 1e-3 * size {
                return f64::INFINITY;
            }
            worst = worst.max(size);
        }
        worst
    }

    /// [`Self::bc_sensitivity`] one right-hand side at a time, the plain way (the reference
    /// of the blocked solve in the tests).
    #[cfg(test)]
    fn bc_sensitivity_by_columns(&mut self, first_row: usize, rows: usize) -> f64 {
        let mut worst = 0.0_f64;
        let order = self.order();
        let mut z = vec![0.0; order];
        let mut r = vec![0.0; order];
        for row in 0..rows {
            z.iter_mut().for_each(|v| *v = 0.0);
            z[first_row + row] = 1.0;
            if !self.solve_in_place(&mut z) {
                return f64::INFINITY;
            }
            // r = e - J z, then the refinement J^{-1} r.
            r.iter_mut().for_each(|v| *v = 0.0);
            r[first_row + row] = 1.0;
            self.sub_mul(&z, &mut r);
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

    /// Estimate of the 1-norm condition number `||B||_1 ||B^{-1}||_1` of the last factored
    /// matrix `J` equilibrated in its rows and columns: `B = E D J C`, where `D` scales
    /// every row of `J` to unit max-norm (the factorisation is of `DJ`), and the diagonal `E`
    /// and `C` come from [`EQUILIBRATION_SWEEPS`] sweeps of Ruiz's scaling in the 1-norm
    /// (every row and column divided by the square root of its sum of magnitudes), which
    /// tends to the matrix's doubly stochastic scaling. That limit does not depend on how
    /// the rows and columns of `J` were scaled, so neither a boundary condition multiplied
    /// by 1e20 nor an unknown measured in other units counts as ill-conditioning: corpus
    /// problem fast-199's costate, of size 1e-5 next to states of size 70, made the
    /// row-equilibrated estimate 4.6e12, above the limit, on a Newton matrix that solves
    /// its problem to 1e-8 (`tests/missed_regular.rs`). Row-pivoted elimination is
    /// invariant under column scaling, so `C` changes what is measured, not the solves.
    /// Hager's estimator as refined by Higham (TOMS 14, 1988): at most 5 pairs of solves with
    /// `DJ` and `(DJ)^T`. Infinite if there is no factorisation, a row or column is zero or a
    /// solve fails.
    pub fn condition_estimate(&mut self) -> f64 {
        let (n, k, m) = (self.n, self.k, self.m);
        let order = self.order();
        let wc = 2 * n + k;
        let po = m * n;
        let d = self.abd.row_scale();
        let values = &self.values;
        // Every entry of DJ with its row and column.
        let entries = || {
            (0..values.len() / wc).flat_map(move |row| {
                let (first, second) = row_nodes(row, n, m - 1);
                let dr = d[row];
                (0..wc).map(move |c| {
                    let col = if c < n {
                        first + c
                    } else if c < 2 * n {
                        second + c - n
                    } else {
                        po + c - 2 * n
                    };
                    (row, col, values[row * wc + c].abs() * dr)
                })
            })
        };
        let (mut e, mut c) = (vec![1.0_f64; order], vec![1.0_f64; order]);
        let (mut row_sum, mut col_sum) = (vec![0.0_f64; order], vec![0.0_f64; order]);
        for _ in 0..EQUILIBRATION_SWEEPS {
            row_sum.iter_mut().for_each(|v| *v = 0.0);
            col_sum.iter_mut().for_each(|v| *v = 0.0);
            for (row, col, a) in entries() {
                let b = e[row] * a * c[col];
                row_sum[row] += b;
                col_sum[col] += b;
            }
            if row_sum
                .iter()
                .chain(&col_sum)
                .any(|&v| !(v > 0.0 && v.is_finite()))
            {
                return f64::INFINITY;
            }
            e.iter_mut().zip(&row_sum).for_each(|(s, v)| *s /= v.sqrt());
            c.iter_mut().zip(&col_sum).for_each(|(s, v)| *s /= v.sqrt());
        }
        let mut col_sums = vec![0.0; order];
        for (row, col, a) in entries() {
            col_sums[col] += e[row] * a * c[col];
        }
        let norm = col_sums.iter().fold(0.0_f64, |a, &v| a.max(v));
        // B^{-1} x = C^{-1} (DJ)^{-1} (E^{-1} x) and B^{-T} z = E^{-1} (DJ)^{-T} (C^{-1} z).
        let mut x = vec![1.0 / order as f64; order];
        let mut y = vec![0.0; order];
        let mut est = 0.0;
        for iter in 0..5 {
            y.iter_mut()
                .zip(x.iter().zip(&e))
                .for_each(|(v, (x, e))| *v = x / e);
            if !self.abd.solve_scaled_in_place(&mut y) {
                return f64::INFINITY;
            }
            y.iter_mut().zip(&c).for_each(|(v, c)| *v /= c);
            let new_est: f64 = y.iter().map(|v| v.abs()).sum();
            if iter > 0 && new_est <= est {
                break;
            }
            est = new_est;
            let mut z: Vec<f64> = y
                .iter()
                .zip(&c)
                .map(|(&v, c)| if v >= 0.0 { 1.0 / c } else { -1.0 / c })
                .collect();
            if !self.abd.solve_scaled_transpose_in_place(&mut z) {
                return f64::INFINITY;
            }
            z.iter_mut().zip(&e).for_each(|(v, e)| *v /= e);
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
        let order = self.order();
        let mut d = vec![0.0; order * order];
        let pattern = global_jacobian_pattern(self.n, self.k, self.m);
        for (&(r, c), v) in pattern.iter().zip(&self.values) {
            d[r * order + c] += v;
        }
        d
    }
}

#[cfg(test)]
mod tests {
    use super::super::abd::tests::stream;
    use super::*;

    /// A random system with diagonally heavy interval blocks and random boundary rows.
    fn diagonally_heavy(n: usize, k: usize, m: usize, seed: u64) -> GlobalSystem {
        let mut sys = GlobalSystem::new(n, k, m);
        let mut rnd = stream(seed);
        let wc = 2 * n + k;
        for (i, v) in sys.values.iter_mut().enumerate() {
            let (row, col) = (i / wc, i % wc);
            let diagonal = row < (m - 1) * n && col == row % n + n;
            *v = rnd() + if diagonal { 4.0 } else { 0.0 };
        }
        sys
    }

    /// The blocked sensitivity (two solves for all boundary rows at once) is the value of the
    /// plain column-by-column computation, to the bit, after LU and after QR; and it is
    /// infinite where the plain one is (a singular matrix).
    #[test]
    fn the_blocked_sensitivity_is_the_columnwise_one() {
        for (n, k, m) in [(2, 0, 3), (3, 1, 8), (12, 1, 60), (24, 1, 7)] {
            for lu in [true, false] {
                let mut sys = diagonally_heavy(n, k, m, (n * 100 + k * 10 + m) as u64);
                sys.abd.set_try_lu(lu);
                sys.factor().expect("nonsingular");
                let (first, rows) = ((m - 1) * n, n + k);
                let plain = sys.bc_sensitivity_by_columns(first, rows);
                let blocked = sys.bc_sensitivity(first, rows);
                assert!(plain.is_finite() && plain > 0.0);
                assert_eq!(blocked, plain, "n {n} k {k} m {m} lu {lu}");
                // Again, from the kept workspace.
                assert_eq!(sys.bc_sensitivity(first, rows), plain);
            }
        }
        // Two equal boundary rows: singular, infinite both ways (the factorisation refuses it
        // or the refinement does).
        let (n, k, m) = (3, 0, 5);
        let mut sys = GlobalSystem::new(n, k, m);
        let mut rnd = stream(5);
        for v in sys.values.iter_mut() {
            *v = rnd();
        }
        let wc = 2 * n + k;
        let first = (m - 1) * n;
        let row: Vec<f64> = sys.values[first * wc..(first + 1) * wc].to_vec();
        sys.values[(first + 1) * wc..(first + 2) * wc].copy_from_slice(&row);
        if sys.factor().is_ok() {
            let plain = sys.bc_sensitivity_by_columns(first, n + k);
            assert_eq!(sys.bc_sensitivity(first, n + k), plain);
            assert!(plain.is_infinite() || plain > 1e12, "{plain}");
        }
    }

    /// The 1-norm condition number of `J` after row equilibration (every row to unit
    /// max-norm) and, if `columns`, then 12 sweeps of Ruiz's 1-norm equilibration, computed
    /// densely.
    fn dense_condition(sys: &GlobalSystem, columns: bool) -> f64 {
        let order = sys.order();
        let mut a = nalgebra::DMatrix::from_row_slice(order, order, &sys.to_dense());
        let max = |v: &mut dyn Iterator<Item = f64>| v.fold(0.0_f64, |m, x| m.max(x.abs()));
        for mut row in a.row_iter_mut() {
            row /= max(&mut row.iter().copied());
        }
        let sum = |v: &mut dyn Iterator<Item = f64>| v.map(f64::abs).sum::<f64>();
        for _ in 0..if columns { 12 } else { 0 } {
            let rows: Vec<f64> = a.row_iter().map(|r| sum(&mut r.iter().copied())).collect();
            let cols: Vec<f64> = a
                .column_iter()
                .map(|c| sum(&mut c.iter().copied()))
                .collect();
            for (mut row, s) in a.row_iter_mut().zip(&rows) {
                row /= s.sqrt();
            }
            for (mut col, s) in a.column_iter_mut().zip(&cols) {
                col /= s.sqrt();
            }
        }
        let norm1 = |m: &nalgebra::DMatrix<f64>| {
            m.column_iter()
                .map(|c| c.iter().map(|v| v.abs()).sum::<f64>())
                .fold(0.0_f64, f64::max)
        };
        let inverse = a.clone().try_inverse().expect("nonsingular");
        norm1(&a) * norm1(&inverse)
    }

    /// The condition estimate is Hager–Higham's estimate of the equilibrated matrix's 1-norm
    /// condition number: not above the dense value (up to the rounding of the scalings), and
    /// within a factor 3 of it. Measuring one state component in units 1e6 times smaller
    /// (its columns times 1e6) moves it by less than a factor 2 (1.14 to 1.62 measured),
    /// where the row-equilibrated condition number alone grows by more than 1e4 (4e5 to
    /// 1.3e6): units of the unknowns are not ill-conditioning.
    #[test]
    fn the_condition_estimate_is_the_equilibrated_matrix_s_and_ignores_units() {
        for (n, k, m) in [(3, 1, 6), (12, 1, 10), (6, 0, 20)] {
            let mut sys = diagonally_heavy(n, k, m, (n * 7 + k * 3 + m) as u64);
            let wc = 2 * n + k;
            let mut estimates = Vec::new();
            for scaled in [false, true] {
                if scaled {
                    // Component 1's columns (in y_i, y_{i+1} and the boundary rows) times 1e6.
                    for vals in sys.values.chunks_exact_mut(wc) {
                        vals[1] *= 1e6;
                        vals[n + 1] *= 1e6;
                    }
                }
                sys.factor().expect("nonsingular");
                let estimate = sys.condition_estimate();
                let exact = dense_condition(&sys, true);
                assert!(
                    estimate <= exact * 1.05 && estimate >= exact / 3.0,
                    "n {n} k {k} m {m} scaled {scaled}: {estimate:e} vs {exact:e}"
                );
                estimates.push((estimate, dense_condition(&sys, false)));
            }
            let (plain, scaled) = (estimates[0], estimates[1]);
            assert!(
                scaled.0 < 2.0 * plain.0 && plain.0 < 2.0 * scaled.0,
                "{plain:?} {scaled:?}"
            );
            assert!(scaled.1 > 1e4 * plain.1, "{plain:?} {scaled:?}");
        }
    }
}
