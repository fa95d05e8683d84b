//! Unit tests of the internals: tableau, small dense LU, the exact sparsity pattern of the
//! global Jacobian, the condensed Jacobian against a finite-difference Jacobian of the
//! assembled residual, and the mesh operations.

use nalgebra::{DMatrix, DVector};

use super::collocation::{Collocation, Layout, Tableau};
use super::dense::{
    abs_max, abs_sum, lu_factor, lu_right_solve, lu_right_solve_strided, lu_solve, lu_solve_rows,
    sub_mat_mul_strided,
};
use super::linear::{global_jacobian_pattern, GlobalSystem};
use super::mesh::{adapt_mesh, halve_mesh, transfer_solution};
use super::newton::compute_correction;
use super::options::JacobianSource;
use super::problem::{estimate_bc_jac, estimate_fun_jac, BvpProblem, Evaluator};
use super::{solve, Guess, Options, Status};

#[test]
fn tableau_matches_closed_form() {
    let t = Tableau::lobatto_iiia4();
    let s5 = 5.0_f64.sqrt();
    let a2 = [
        (11.0 + s5) / 120.0,
        (25.0 - s5) / 120.0,
        (25.0 - 13.0 * s5) / 120.0,
        (-1.0 + s5) / 120.0,
    ];
    let a3 = [
        (11.0 - s5) / 120.0,
        (25.0 + 13.0 * s5) / 120.0,
        (25.0 + s5) / 120.0,
        (-1.0 - s5) / 120.0,
    ];
    let b = [1.0 / 12.0, 5.0 / 12.0, 5.0 / 12.0, 1.0 / 12.0];
    for j in 0..4 {
        assert!((t.a[0][j]).abs() < 1e-15);
        assert!((t.a[1][j] - a2[j]).abs() < 1e-14, "a2{j}");
        assert!((t.a[2][j] - a3[j]).abs() < 1e-14, "a3{j}");
        assert!((t.b[j] - b[j]).abs() < 1e-14, "b{j}");
    }
    // Row sums equal the nodes; the Lagrange basis is 1 at its node and 0 at the others.
    for s in 0..4 {
        assert!((t.a[s].iter().sum::<f64>() - t.c[s]).abs() < 1e-14);
        let (_, l) = t.basis(t.c[s]);
        for (j, lj) in l.iter().enumerate() {
            assert!((lj - if j == s { 1.0 } else { 0.0 }).abs() < 1e-13);
        }
    }
    // Sample weights plus the two end weights 1/20 integrate 1 and x^2 exactly.
    let w: f64 = t.sample.iter().map(|s| s.1).sum::<f64>() + 0.1;
    assert!((w - 1.0).abs() < 1e-15);
    let m2: f64 = t.sample.iter().map(|(x, w)| w * x * x).sum::<f64>() + 0.05;
    assert!((m2 - 1.0 / 3.0).abs() < 1e-15);
}

#[test]
fn dense_lu_solves_and_detects_singularity() {
    let a0 = [0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0];
    let mut a = a0;
    let mut piv = [0; 3];
    assert!(lu_factor(&mut a, 3, &mut piv));
    let x = [1.0, -2.0, 0.5, 3.0, 0.0, 1.0]; // two right-hand sides, row-major 3 x 2
    let mut b = [0.0; 6];
    for r in 0..3 {
        for c in 0..2 {
            b[r * 2 + c] = (0..3).map(|q| a0[r * 3 + q] * x[q * 2 + c]).sum();
        }
    }
    lu_solve(&a, 3, &piv, &mut b, 2);
    for (u, v) in b.iter().zip(&x) {
        assert!((u - v).abs() < 1e-14);
    }
    // One right-hand side (the dot-product path).
    let mut b1: Vec<f64> = (0..3)
        .map(|r| (0..3).map(|q| a0[r * 3 + q] * x[q * 2]).sum())
        .collect();
    lu_solve(&a, 3, &piv, &mut b1, 1);
    for (r, u) in b1.iter().enumerate() {
        assert!((u - x[r * 2]).abs() < 1e-14);
    }
    // Right solve: rows z with z A = w, i.e. w A^{-1} = z (pivoting needed: a0[0] = 0).
    let z = [1.0, -2.0, 0.5, 3.0, 0.0, 1.0]; // two rows, row-major 2 x 3
    let mut w = [0.0; 6];
    for r in 0..2 {
        for c in 0..3 {
            w[r * 3 + c] = (0..3).map(|q| z[r * 3 + q] * a0[q * 3 + c]).sum();
        }
    }
    lu_right_solve(&a, 3, &piv, &mut w, 2, &mut [0.0; 6]);
    for (u, v) in w.iter().zip(&z) {
        assert!((u - v).abs() < 1e-14, "{w:?}");
    }
    let mut s = [1.0, 2.0, 2.0, 4.0];
    assert!(!lu_factor(&mut s, 2, &mut [0; 2]));
    let mut nan = [f64::NAN, 0.0, 0.0, 1.0];
    assert!(!lu_factor(&mut nan, 2, &mut [0; 2]));
}

/// Deterministic values in [-1, 1] (a linear congruential stream).
fn stream(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// The register-tiled kernels give the same bits as the axpy forms they replaced (each entry
/// sees the same operations in the same order), on sizes that exercise every tile and
/// remainder: 4-row and 1-row tiles, 8-, 4- and 1-column chunks.
#[test]
fn tiled_kernels_match_the_axpy_forms_bitwise() {
    let mut rnd = stream(7);
    for &(r, q, s, ldc, off) in &[
        (12, 12, 12, 25, 0),
        (12, 24, 1, 25, 24),
        (5, 3, 13, 16, 2),
        (1, 7, 9, 9, 0),
    ] {
        let a: Vec<f64> = (0..r * q).map(|_| rnd()).collect();
        let b: Vec<f64> = (0..q * s).map(|_| rnd()).collect();
        let c0: Vec<f64> = (0..r * ldc).map(|_| rnd()).collect();
        let mut tiled = c0.clone();
        sub_mat_mul_strided(&mut tiled, ldc, off, &a, &b, r, q, s);
        let mut plain = c0.clone();
        for i in 0..r {
            for l in 0..q {
                let neg = -a[i * q + l];
                for j in 0..s {
                    plain[i * ldc + off + j] += neg * b[l * s + j];
                }
            }
        }
        assert!(
            tiled
                .iter()
                .zip(&plain)
                .all(|(x, y)| x.to_bits() == y.to_bits()),
            "{r}x{q}x{s}"
        );
    }
    for &(n, nrows, ld) in &[(12, 12, 24), (7, 5, 7), (24, 12, 24), (3, 1, 4)] {
        let a0: Vec<f64> = (0..n * n).map(|_| rnd()).collect();
        let mut a = a0.clone();
        let mut piv = vec![0; n];
        assert!(lu_factor(&mut a, n, &mut piv));
        // Right solve against the row-by-row form (U, then unit L, then the column swaps).
        let x0: Vec<f64> = (0..(nrows - 1) * ld + n).map(|_| rnd()).collect();
        let mut fast = x0.clone();
        let mut work = vec![0.0; n * nrows];
        lu_right_solve_strided(&a, n, &piv, &mut fast, nrows, ld, &mut work);
        let mut slow = x0.clone();
        for rr in 0..nrows {
            let row = &mut slow[rr * ld..rr * ld + n];
            for i in 0..n {
                row[i] *= 1.0 / a[i * n + i];
                let yi = row[i];
                for c in i + 1..n {
                    row[c] += -yi * a[i * n + c];
                }
            }
            for j in (1..n).rev() {
                let zj = row[j];
                for c in 0..j {
                    row[c] += -zj * a[j * n + c];
                }
            }
            for (i, &p) in piv.iter().enumerate().rev() {
                row.swap(i, p);
            }
        }
        assert!(
            fast.iter()
                .zip(&slow)
                .all(|(x, y)| x.to_bits() == y.to_bits()),
            "right {n}"
        );
        // And it is a solve: (X A^{-1}) A = X.
        for rr in 0..nrows {
            for c in 0..n {
                let v: f64 = (0..n).map(|q| fast[rr * ld + q] * a0[q * n + c]).sum();
                assert!(
                    (v - x0[rr * ld + c]).abs() < 1e-9,
                    "right solve residual {n}"
                );
            }
        }
        // Left solve with several columns against the row axpy form.
        let ncols = nrows;
        let b0: Vec<f64> = (0..n * ncols).map(|_| rnd()).collect();
        let mut fast = b0.clone();
        lu_solve_rows(&a, n, &piv, &mut fast, ncols);
        let mut slow = b0.clone();
        for (i, &p) in piv.iter().enumerate() {
            for c in 0..ncols {
                slow.swap(i * ncols + c, p * ncols + c);
            }
        }
        for i in 0..n {
            for j in 0..i {
                for c in 0..ncols {
                    slow[i * ncols + c] += -a[i * n + j] * slow[j * ncols + c];
                }
            }
        }
        for i in (0..n).rev() {
            for j in i + 1..n {
                for c in 0..ncols {
                    slow[i * ncols + c] += -a[i * n + j] * slow[j * ncols + c];
                }
            }
            let inv = 1.0 / a[i * n + i];
            for c in 0..ncols {
                slow[i * ncols + c] *= inv;
            }
        }
        assert!(
            fast.iter()
                .zip(&slow)
                .all(|(x, y)| x.to_bits() == y.to_bits()),
            "left {n}"
        );
    }
    // The reductions: maxima ignore NaN, the second value flags non-finite entries.
    let (m, bad) = abs_max(&[1.0, -3.0, 2.0, 0.5, -2.5]);
    assert_eq!(m, 3.0);
    assert_eq!(bad, 0.0);
    assert!(abs_max(&[1.0, f64::INFINITY, 0.0, 0.0, 0.0]).1.is_nan());
    assert!(abs_max(&[1.0, 0.0, 0.0, 0.0, f64::NAN]).1.is_nan());
    assert_eq!(abs_sum(&[1.0, -2.0, 3.0, -4.0, 5.0]), 15.0);
}

/// Exact 0/1 pattern for n = 2, k = 1, m = 3 (cf. scipy's `test_compute_jac_indices`).
#[test]
fn global_jacobian_pattern_is_exact() {
    let (n, k, m) = (2, 1, 3);
    let order = m * n + k;
    let mut dense = vec![vec![0u8; order]; order];
    let pattern = global_jacobian_pattern(n, k, m);
    for &(r, c) in &pattern {
        assert_eq!(dense[r][c], 0, "duplicate entry ({r}, {c})");
        dense[r][c] = 1;
    }
    let expected = [
        // y0   y1   y2   p
        [1, 1, 1, 1, 0, 0, 1], // interval 0
        [1, 1, 1, 1, 0, 0, 1],
        [0, 0, 1, 1, 1, 1, 1], // interval 1
        [0, 0, 1, 1, 1, 1, 1],
        [1, 1, 0, 0, 1, 1, 1], // boundary conditions (n + k rows)
        [1, 1, 0, 0, 1, 1, 1],
        [1, 1, 0, 0, 1, 1, 1],
    ];
    for r in 0..order {
        assert_eq!(dense[r], expected[r], "row {r}");
    }
    assert_eq!(
        pattern.len(),
        (m - 1) * n * (2 * n + k) + (n + k) * (2 * n + k)
    );
}

/// A nonlinear test problem exercising every Jacobian block (x, y and p dependence,
/// non-separated boundary conditions involving p).
struct Mixed;
impl BvpProblem for Mixed {
    fn n(&self) -> usize {
        2
    }
    fn k(&self) -> usize {
        1
    }
    fn f(&self, x: f64, y: &[f64], p: &[f64], dy: &mut [f64]) {
        dy[0] = y[1] + p[0] * x.sin() * y[0];
        dy[1] = -p[0] * p[0] * y[0] + y[0] * y[1] + x;
    }
    fn jac(&self, x: f64, y: &[f64], p: &[f64], dfdy: &mut [f64], dfdp: &mut [f64]) -> bool {
        dfdy.copy_from_slice(&[p[0] * x.sin(), 1.0, -p[0] * p[0] + y[1], y[0]]);
        dfdp.copy_from_slice(&[x.sin() * y[0], -2.0 * p[0] * y[0]]);
        true
    }
    fn bc(&self, ya: &[f64], yb: &[f64], p: &[f64], r: &mut [f64]) {
        r[0] = ya[0] - 1.0 + p[0] * ya[1];
        r[1] = yb[0] * yb[1] - 0.5;
        r[2] = ya[1] + yb[0] * yb[0] - p[0];
    }
    fn bc_jac(
        &self,
        ya: &[f64],
        yb: &[f64],
        p: &[f64],
        dya: &mut [f64],
        dyb: &mut [f64],
        dp: &mut [f64],
    ) -> bool {
        dya.copy_from_slice(&[1.0, p[0], 0.0, 0.0, 0.0, 1.0]);
        dyb.copy_from_slice(&[0.0, 0.0, yb[1], yb[0], 2.0 * yb[0], 0.0]);
        dp.copy_from_slice(&[ya[1], 0.0, -1.0]);
        true
    }
}

/// A deterministic, non-trivial iterate on a non-uniform mesh.
fn sample_state() -> (Vec<f64>, Vec<f64>) {
    let x = vec![0.0, 0.2, 0.5, 0.65, 1.0];
    let lay = Layout {
        n: 2,
        k: 1,
        m: x.len(),
    };
    let u: Vec<f64> = (0..lay.total())
        .map(|i| 0.3 + 0.1 * ((i * 7 % 11) as f64) - 0.05 * (i as f64).sin())
        .collect();
    (x, u)
}

fn residual(ev: &Evaluator<Mixed>, col: &mut Collocation, u: &[f64]) -> Vec<f64> {
    let mut r = vec![0.0; col.lay.total()];
    assert!(col.evaluate_residual(ev, u, &mut r));
    r
}

/// Central-difference Jacobian of the full (uncondensed) residual.
fn fd_full_jacobian(ev: &Evaluator<Mixed>, col: &mut Collocation, u: &[f64]) -> DMatrix<f64> {
    let len = u.len();
    let mut jac = DMatrix::zeros(len, len);
    let mut up = u.to_vec();
    for j in 0..len {
        let h = 1e-6 * (1.0 + u[j].abs());
        up[j] = u[j] + h;
        let rp = residual(ev, col, &up);
        up[j] = u[j] - h;
        let rm = residual(ev, col, &up);
        up[j] = u[j];
        for i in 0..len {
            jac[(i, j)] = (rp[i] - rm[i]) / (2.0 * h);
        }
    }
    jac
}

#[test]
fn analytic_and_fd_problem_jacobians_agree() {
    let (x, y, p) = (0.3, [0.7, -1.2], [1.5]);
    let mut f0 = [0.0; 2];
    Mixed.f(x, &y, &p, &mut f0);
    let (mut ja, mut pa) = ([0.0; 4], [0.0; 2]);
    let (mut jf, mut pf) = ([0.0; 4], [0.0; 2]);
    assert!(Mixed.jac(x, &y, &p, &mut ja, &mut pa));
    estimate_fun_jac(&Mixed, x, &y, &p, &f0, &mut jf, &mut pf, &mut [0.0; 5]);
    for (a, b) in ja.iter().chain(&pa).zip(jf.iter().chain(&pf)) {
        assert!((a - b).abs() <= 1e-6 * (1.0 + a.abs()), "{a} vs {b}");
    }
    let (ya, yb) = ([0.4, 0.9], [1.1, -0.3]);
    let mut g0 = [0.0; 3];
    Mixed.bc(&ya, &yb, &p, &mut g0);
    let (mut da, mut db, mut dp) = ([0.0; 6], [0.0; 6], [0.0; 3]);
    let (mut fa, mut fb, mut fp) = ([0.0; 6], [0.0; 6], [0.0; 3]);
    assert!(Mixed.bc_jac(&ya, &yb, &p, &mut da, &mut db, &mut dp));
    estimate_bc_jac(
        &Mixed,
        &ya,
        &yb,
        &p,
        &g0,
        &mut fa,
        &mut fb,
        &mut fp,
        &mut [0.0; 8],
    );
    for (a, b) in da
        .iter()
        .chain(&db)
        .chain(&dp)
        .zip(fa.iter().chain(&fb).chain(&fp))
    {
        assert!((a - b).abs() <= 1e-6 * (1.0 + a.abs()), "{a} vs {b}");
    }
}

/// The assembled condensed Newton matrix equals the Schur complement (stages eliminated)
/// of a finite-difference Jacobian of the assembled full residual, and the Newton correction
/// equals the dense solve with that FD Jacobian. Checked with analytic and FD problem
/// Jacobians.
#[test]
fn condensed_jacobian_and_correction_match_finite_differences() {
    for source in [JacobianSource::Analytic, JacobianSource::FiniteDifference] {
        let ev = Evaluator::new(&Mixed, source);
        let (x, u) = sample_state();
        let mut col = Collocation::new(2, 1, &x);
        let lay = col.lay;
        let jfull = fd_full_jacobian(&ev, &mut col, &u);
        let res = residual(&ev, &mut col, &u);
        col.evaluate_jacobian(&ev, &u, &res)
            .expect("nonsingular stage blocks");
        let mut sys = GlobalSystem::new(2, 1, x.len());
        col.assemble_global(&mut sys.values);
        let (g, total) = (lay.global(), lay.total());
        let jgg = jfull.view((0, 0), (g, g));
        let jgs = jfull.view((0, g), (g, total - g));
        let jsg = jfull.view((g, 0), (total - g, g));
        let jss = jfull.view((g, g), (total - g, total - g)).into_owned();
        let schur = jgg
            - jgs
                * jss
                    .lu()
                    .solve(&jsg.into_owned())
                    .expect("stage blocks invertible");
        let dense = sys.to_dense();
        for r in 0..g {
            for c in 0..g {
                let (a, b) = (dense[r * g + c], schur[(r, c)]);
                assert!(
                    (a - b).abs() <= 1e-6 * (1.0 + b.abs()),
                    "{source:?} ({r},{c}): {a} vs {b}"
                );
            }
        }
        // Newton correction vs dense FD solve.
        sys.factor().expect("nonsingular");
        let mut dx = vec![0.0; total];
        assert!(compute_correction(&mut col, &mut sys, &res, &mut dx));
        let expected = jfull
            .lu()
            .solve(&(-DVector::from_vec(res.clone())))
            .expect("nonsingular");
        for (i, (a, b)) in dx.iter().zip(expected.iter()).enumerate() {
            assert!(
                (a - b).abs() <= 1e-6 * (1.0 + b.abs()),
                "{source:?} dx[{i}]: {a} vs {b}"
            );
        }
    }
}

/// The stage blocks factored by blocks (`K_11`, then its Schur complement) and whole give
/// the same condensed matrix and Newton correction to rounding.
#[test]
fn stage_blocks_by_blocks_and_whole_agree() {
    let ev = Evaluator::new(&Mixed, JacobianSource::Analytic);
    let (x, u) = sample_state();
    let mut results = vec![];
    for (limit, by_blocks) in [(f64::INFINITY, true), (-1.0, false)] {
        let mut col = Collocation::new(2, 1, &x);
        col.set_kblock_growth_limit(limit);
        let res = residual(&ev, &mut col, &u);
        col.evaluate_jacobian(&ev, &u, &res)
            .expect("nonsingular stage blocks");
        assert!(col.stage_blocks_by_blocks().iter().all(|&b| b == by_blocks));
        let mut sys = GlobalSystem::new(2, 1, x.len());
        col.assemble_global(&mut sys.values);
        let values = sys.values.clone();
        sys.factor().expect("nonsingular");
        let mut dx = vec![0.0; col.lay.total()];
        assert!(compute_correction(&mut col, &mut sys, &res, &mut dx));
        results.push((values, dx));
    }
    let close = |a: &[f64], b: &[f64]| {
        let scale = b.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 1e-13 * scale)
    };
    assert!(close(&results[0].0, &results[1].0), "condensed matrices");
    assert!(close(&results[0].1, &results[1].1), "corrections");
}

/// y' = lambda y, y(0) = 1.
struct Growth(f64);
impl BvpProblem for Growth {
    fn n(&self) -> usize {
        1
    }
    fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
        dy[0] = self.0 * y[0];
    }
    fn bc(&self, ya: &[f64], _yb: &[f64], _p: &[f64], r: &mut [f64]) {
        r[0] = ya[0] - 1.0;
    }
}

/// With `h lambda a22 = 1` the block `K_11 = 1 - h a22 lambda` vanishes while `K` does not:
/// that interval is factored whole (the other, shorter one by blocks), and the correction
/// still solves the linear problem in one step (the discrete equations are linear).
#[test]
fn singular_first_stage_block_is_factored_whole() {
    let tab = Tableau::lobatto_iiia4();
    let lambda = 3.0;
    let h = 1.0 / (lambda * tab.a[1][1]);
    let x = vec![0.0, h, 1.3 * h];
    let problem = Growth(lambda);
    let ev = Evaluator::new(&problem, JacobianSource::Analytic);
    let mut col = Collocation::new(1, 0, &x);
    let u = vec![0.5; col.lay.total()];
    let mut res = vec![0.0; u.len()];
    assert!(col.evaluate_residual(&ev, &u, &mut res));
    col.evaluate_jacobian(&ev, &u, &res)
        .expect("K is nonsingular");
    assert_eq!(col.stage_blocks_by_blocks(), &[false, true]);
    let mut sys = GlobalSystem::new(1, 0, x.len());
    col.assemble_global(&mut sys.values);
    sys.factor().expect("nonsingular");
    let mut dx = vec![0.0; u.len()];
    assert!(compute_correction(&mut col, &mut sys, &res, &mut dx));
    let next: Vec<f64> = u.iter().zip(&dx).map(|(a, d)| a + d).collect();
    assert!(col.evaluate_residual(&ev, &next, &mut res));
    let worst = res.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    assert!(worst < 1e-12, "residual after one step {worst:e}");
}

#[test]
fn adapt_mesh_refines_and_merges() {
    let x: Vec<f64> = (0..=8).map(|i| i as f64 / 8.0).collect();
    // Intervals 0..4 far below tolerance, interval 5 far above, 6..8 around the target.
    let errors = [1e-9, 1e-9, 1e-9, 1e-9, 1e-9, 1e3, 0.2, 0.2];
    let new = adapt_mesh(&x, &errors, 5.0, true);
    assert_eq!(new[0], 0.0);
    assert_eq!(*new.last().unwrap(), 1.0);
    assert!(new.windows(2).all(|w| w[1] > w[0]));
    let count = |a: f64, b: f64| {
        new.windows(2)
            .filter(|w| w[0] >= a - 1e-12 && w[1] <= b + 1e-12)
            .count()
    };
    assert!(
        count(0.0, 0.625) < 5,
        "merged: {} intervals in [0, 0.625]",
        count(0.0, 0.625)
    );
    assert!(
        count(0.625, 0.75) >= 4,
        "refined: {} intervals in [0.625, 0.75]",
        count(0.625, 0.75)
    );
    assert_eq!(halve_mesh(&[0.0, 1.0, 3.0]), vec![0.0, 0.5, 1.0, 2.0, 3.0]);
}

#[test]
fn transfer_reproduces_the_collocation_polynomial() {
    // y' = (1, 2x, 3x^2)-like: a system with polynomial solution of degree <= 4 is
    // represented exactly, so transfer to any mesh reproduces it.
    struct Poly;
    impl BvpProblem for Poly {
        fn n(&self) -> usize {
            1
        }
        fn f(&self, x: f64, _y: &[f64], _p: &[f64], dy: &mut [f64]) {
            dy[0] = 4.0 * x * x * x - 1.0;
        }
        fn bc(&self, ya: &[f64], _yb: &[f64], _p: &[f64], r: &mut [f64]) {
            r[0] = ya[0];
        }
    }
    let exact = |x: f64| x.powi(4) - x;
    let x = vec![0.0, 0.3, 1.0];
    let lay = Layout { n: 1, k: 0, m: 3 };
    let tab = Tableau::lobatto_iiia4();
    let mut u = vec![0.0; lay.total()];
    for i in 0..3 {
        u[i] = exact(x[i]);
    }
    for i in 0..2 {
        for s in 0..2 {
            u[lay.stage_offset() + 2 * i + s] = exact(x[i] + tab.c[s + 1] * (x[i + 1] - x[i]));
        }
    }
    let ev = Evaluator::new(&Poly, JacobianSource::Analytic);
    let mut col = Collocation::new(1, 0, &x);
    let mut res = vec![0.0; lay.total()];
    assert!(col.evaluate_residual(&ev, &u, &mut res));
    assert!(
        res.iter().all(|r| r.abs() < 1e-14),
        "exact polynomial solves the collocation equations"
    );
    let new_x = [0.0, 0.1, 0.45, 0.8, 1.0];
    let v = transfer_solution(&col, &u, &new_x);
    for (i, &xi) in new_x.iter().enumerate() {
        assert!((v[i] - exact(xi)).abs() < 1e-14);
    }
}

/// `y'' = −y`, `y(0) = 0`, `y(1) = sin 1` (solution `sin x`) with a deterministic "rounding
/// noise" of relative size `eps` in `f` on `x ∈ [0.5, 0.52]` only: a hash of the bits of
/// `(x, y)`, so that every new iterate sees new noise and the corrections stop contracting at
/// the noise's level, as on a Newton matrix whose condition number amplifies rounding.
struct NoisyOscillator {
    eps: f64,
}
impl BvpProblem for NoisyOscillator {
    fn n(&self) -> usize {
        2
    }
    fn f(&self, x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
        let noise = if (0.5..=0.52).contains(&x) {
            let mut h =
                x.to_bits() ^ y[0].to_bits().rotate_left(21) ^ y[1].to_bits().rotate_left(42);
            h ^= h >> 33;
            h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
            h ^= h >> 33;
            self.eps * ((h >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
        } else {
            0.0
        };
        dy[0] = y[1];
        dy[1] = -y[0] * (1.0 + noise);
    }
    fn jac(&self, _x: f64, _y: &[f64], _p: &[f64], dfdy: &mut [f64], _dfdp: &mut [f64]) -> bool {
        dfdy.copy_from_slice(&[0.0, 1.0, -1.0, 0.0]);
        true
    }
    fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) {
        r[0] = ya[0];
        r[1] = yb[0] - 1f64.sin();
    }
}

/// Newton's rounding-limited stop (`newton` module docs) and the allowance for the rounding of
/// `f` in the defect check (`mesh` module docs), at `tol = 1e-10`, with the noise standing for
/// rounding. Noise of 3e-9 in `f`: the corrections stall above `newton_tol` and below the
/// tolerance, and the solve converges through that stop, to the solution within the
/// tolerance (with the stop switched off it did not converge: measured when this test was
/// written). Noise of 3e-8: the discrete equations' defects stay above the tolerance
/// (`max_raw_defect` 39 when this test was written), within the probed rounding; the solve
/// converges through the allowance, and its solution is still within the tolerance (error
/// 1.5e-12; before the allowance it stopped without converging). Noise of 3e-7 and more: the
/// error estimate sees it, and the solve fails, as it must (errors of 1e-10 to 1e-7).
#[test]
fn newton_stops_rounding_limited_only_below_the_tolerance() {
    let x: Vec<f64> = (0..=20).map(|i| i as f64 / 20.0).collect();
    let guess = Guess::from_fn(&x, 2, vec![], |x, y| {
        y[0] = x.sin() + 0.01 * x * (1.0 - x);
        y[1] = x.cos();
    });
    let options = Options {
        tol: 1e-10,
        max_nodes: 2000,
        ..Default::default()
    };
    let error = |sol: &super::Solution| {
        sol.x
            .iter()
            .zip(sol.y.chunks_exact(2))
            .fold(0.0_f64, |m, (x, y)| {
                m.max((y[0] - x.sin()).abs()).max((y[1] - x.cos()).abs())
            })
    };
    let quiet = solve(&NoisyOscillator { eps: 3e-9 }, &guess, &options).expect("valid input");
    assert_eq!(quiet.status, Status::Converged, "{:?}", quiet.stats);
    assert!(quiet.stats.rounding_limited >= 1, "{:?}", quiet.stats);
    assert!(error(&quiet) < 1e-9, "error {:e}", error(&quiet));
    let loud = solve(&NoisyOscillator { eps: 3e-8 }, &guess, &options).expect("valid input");
    assert_eq!(loud.status, Status::Converged, "{:?}", loud.stats);
    assert!(loud.stats.max_raw_defect > 1.0, "{:?}", loud.stats);
    assert!(loud.stats.max_defect <= 1.0, "{:?}", loud.stats);
    assert!(error(&loud) < options.tol, "error {:e}", error(&loud));
    for eps in [3e-7, 3e-5, 3e-3] {
        let louder = solve(&NoisyOscillator { eps }, &guess, &options).expect("valid input");
        assert_ne!(
            louder.status,
            Status::Converged,
            "{eps:e}: {:?}",
            louder.stats
        );
    }
}
