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

    /// Estimate of the 1-norm condition number `||DJ||_1 ||(DJ)^{-1}||_1` of the last factored
    /// matrix after row equilibration (`D` scales every row to unit max-norm, so a boundary
    /// condition multiplied by 1e20 does not count as ill-conditioning; the factorisation is
    /// of `DJ` itself). Hager's estimator as refined by Higham (TOMS 14, 1988): at most 5
    /// pairs of solves with `DJ` and `(DJ)^T`. Infinite if there is no factorisation or a
    /// solve fails.
    pub fn condition_estimate(&mut self) -> f64 {
        let (n, k, m) = (self.n, self.k, self.m);
        let order = self.order();
        let wc = 2 * n + k;
        let po = m * n;
        let mut col_sums = vec![0.0; order];
        let d = self.abd.row_scale();
        for (row, vals) in self.values.chunks_exact(wc).enumerate() {
            let (first, second) = row_nodes(row, n, m - 1);
            for c in 0..n {
                col_sums[first + c] += vals[c].abs() * d[row];
                col_sums[second + c] += vals[n + c].abs() * d[row];
            }
            for c in 0..k {
                col_sums[po + c] += vals[2 * n + c].abs() * d[row];
            }
        }
        let norm = col_sums.iter().fold(0.0_f64, |a, &v| a.max(v));
        let mut x = vec![1.0 / order as f64; order];
        let mut y = vec![0.0; order];
        let mut est = 0.0;
        for iter in 0..5 {
            y.copy_from_slice(&x);
            if !self.abd.solve_scaled_in_place(&mut y) {
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
            if !self.abd.solve_scaled_transpose_in_place(&mut z) {
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

    /// The blocked sensitivity (two solves for all boundary rows at once) is the value of the
    /// plain column-by-column computation, to the bit, after LU and after QR; and it is
    /// infinite where the plain one is (a singular matrix).
    #[test]
    fn the_blocked_sensitivity_is_the_columnwise_one() {
        for (n, k, m) in [(2, 0, 3), (3, 1, 8), (12, 1, 60), (24, 1, 7)] {
            for lu in [true, false] {
                let mut sys = GlobalSystem::new(n, k, m);
                let mut rnd = stream((n * 100 + k * 10 + m) as u64);
                let wc = 2 * n + k;
                for (i, v) in sys.values.iter_mut().enumerate() {
                    // Diagonally heavy interval blocks, random boundary rows.
                    let (row, col) = (i / wc, i % wc);
                    *v = rnd()
                        + if row < (m - 1) * n && col == row % n + n {
                            4.0
                        } else {
                            0.0
                        };
                }
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
}
