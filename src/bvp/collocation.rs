//! The discretisation: 4-stage Lobatto IIIA collocation, its residual, its Jacobian, and the
//! local elimination (condensation) of the interior stages.
//!
//! # Notation
//!
//! Mesh `a = x_0 < ... < x_{m-1} = b`, `N = m - 1` intervals, `h_i = x_{i+1} - x_i`.
//! Nodes `c = (0, c_2, c_3, 1)`, `c_{2,3} = (5 -+ sqrt 5) / 10`. On interval `i` the stage
//! values are `Y_1 = y_i`, `Y_2`, `Y_3`, `Y_4 = y_{i+1}` and `F_j = f(x_i + c_j h_i, Y_j, p)`.
//!
//! Unknown vector `u` (flat): `[ y_0 .. y_{m-1} (m*n) | p (k) | Y_2,Y_3 of each interval (N*2n) ]`.
//! Residual vector (same length):
//!
//! ```text
//! [ Phi_4 of each interval (N*n) | g (n+k) | Phi_2, Phi_3 of each interval (N*2n) ]
//! Phi_s = Y_s     - y_i - h_i sum_j a_sj F_j    (s = 2, 3: stage equations)
//! Phi_4 = y_{i+1} - y_i - h_i sum_j b_j  F_j    (continuity / collocation equation)
//! ```
//!
//! The first `m*n + k` rows/unknowns form the *global* system; the stage rows/unknowns are
//! eliminated interval by interval (see `Collocation::evaluate_jacobian`).

use super::dense::{
    abs_sum, avx2, dot, lu_factor, lu_right_solve, lu_right_solve_strided, lu_solve, lu_solve_rows,
    sub_mat_mul_strided,
};
use super::problem::{BvpProblem, Evaluator};

/// Butcher tableau of the 4-stage Lobatto IIIA method and the polynomial basis of its
/// collocation polynomial (used for dense output and error estimation).
#[derive(Debug, Clone)]
pub struct Tableau {
    /// Nodes `c_j`.
    pub c: [f64; 4],
    /// `a[s][j] = int_0^{c_s} L_j(t) dt`.
    pub a: [[f64; 4]; 4],
    /// `b[j] = int_0^1 L_j(t) dt`.
    pub b: [f64; 4],
    /// Monomial coefficients of the Lagrange basis `L_j(t) = sum_q lag[j][q] t^q`.
    pub lag: [[f64; 4]; 4],
    /// Monomial coefficients of `beta_j(t) = int_0^t L_j`.
    pub beta: [[f64; 5]; 4],
    /// Interior 5-point Lobatto points where the residual is sampled, and their weights on
    /// `[0, 1]` (the end points carry weight 1/20 each but the residual vanishes there).
    pub sample: [(f64, f64); 3],
}

impl Tableau {
    /// The 4-stage Lobatto IIIA tableau, computed from its nodes by exact integration of the
    /// Lagrange basis.
    pub fn lobatto_iiia4() -> Self {
        let s5 = 5.0_f64.sqrt();
        let c = [0.0, (5.0 - s5) / 10.0, (5.0 + s5) / 10.0, 1.0];
        let mut lag = [[0.0; 4]; 4];
        for j in 0..4 {
            let mut poly = [1.0, 0.0, 0.0, 0.0];
            let mut deg = 0;
            for (q, &cq) in c.iter().enumerate() {
                if q == j {
                    continue;
                }
                let d = c[j] - cq;
                let mut next = [0.0; 4];
                for e in 0..=deg {
                    next[e + 1] += poly[e] / d;
                    next[e] -= poly[e] * cq / d;
                }
                poly = next;
                deg += 1;
            }
            lag[j] = poly;
        }
        let mut beta = [[0.0; 5]; 4];
        for j in 0..4 {
            for q in 0..4 {
                beta[j][q + 1] = lag[j][q] / (q + 1) as f64;
            }
        }
        let mut a = [[0.0; 4]; 4];
        for s in 0..4 {
            for j in 0..4 {
                a[s][j] = eval_poly5(&beta[j], c[s]);
            }
        }
        let b = a[3];
        let r = (3.0_f64 / 7.0).sqrt();
        let sample = [
            (0.5 * (1.0 - r), 49.0 / 180.0),
            (0.5, 16.0 / 45.0),
            (0.5 * (1.0 + r), 49.0 / 180.0),
        ];
        Self {
            c,
            a,
            b,
            lag,
            beta,
            sample,
        }
    }

    /// Weights `(beta_j(t))_j` and `(L_j(t))_j` at `t` in `[0, 1]`.
    pub fn basis(&self, t: f64) -> ([f64; 4], [f64; 4]) {
        let mut bv = [0.0; 4];
        let mut lv = [0.0; 4];
        for j in 0..4 {
            bv[j] = eval_poly5(&self.beta[j], t);
            lv[j] =
                self.lag[j][0] + t * (self.lag[j][1] + t * (self.lag[j][2] + t * self.lag[j][3]));
        }
        (bv, lv)
    }
}

fn eval_poly5(p: &[f64; 5], t: f64) -> f64 {
    p[0] + t * (p[1] + t * (p[2] + t * (p[3] + t * p[4])))
}

/// The stage block `K` of an interval is factored by blocks (`K_11 = I - h a22 J_2`, then its
/// Schur complement) when the block factorisation's growth `(||K_11|| + ||K_21|| + ||S||)
/// (1 + ||K_11^{-1} K_12||) / ||K||` (infinity norms) is at most this, and whole by partial
/// pivoting otherwise. Block elimination's backward error is bounded by a modest multiple
/// of that growth times the unit roundoff (Demmel, Higham & Schreiber, *Stability of block
/// LU factorization*, Numer. Linear Algebra Appl. 2 (1995)).
const KBLOCK_GROWTH_LIMIT: f64 = 1e2;

/// Flat layout of unknowns and residuals for `n` states, `k` parameters, `m` nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Layout {
    pub n: usize,
    pub k: usize,
    pub m: usize,
}

impl Layout {
    /// Number of intervals `N = m - 1`.
    pub fn intervals(&self) -> usize {
        self.m - 1
    }
    /// Size of the global (condensed) system: `m*n + k`.
    pub fn global(&self) -> usize {
        self.m * self.n + self.k
    }
    /// Total number of unknowns, stages included.
    pub fn total(&self) -> usize {
        self.global() + 2 * self.n * self.intervals()
    }
    /// Offset of the parameters in `u`.
    pub fn p_offset(&self) -> usize {
        self.m * self.n
    }
    /// Offset of the stages in `u` (and of the stage residuals).
    pub fn stage_offset(&self) -> usize {
        self.global()
    }
    /// Offset of the boundary residual `g` in the residual vector.
    pub fn bc_offset(&self) -> usize {
        self.intervals() * self.n
    }
}

/// Per-mesh workspace: function values, Jacobians and condensed blocks of every interval.
/// Allocated once per mesh; Newton iterations on that mesh allocate nothing.
pub(crate) struct Collocation {
    pub lay: Layout,
    pub tab: Tableau,
    pub x: Vec<f64>,
    pub h: Vec<f64>,
    /// `f` at the nodes (`m x n`) and at the interior stages (`N x 2 x n`).
    pub fnodes: Vec<f64>,
    pub fstages: Vec<f64>,
    jy_nodes: Vec<f64>,
    jp_nodes: Vec<f64>,
    jy_stages: Vec<f64>,
    jp_stages: Vec<f64>,
    /// LU factors of the stage blocks `K_i` (`2n x 2n`) and their pivots.
    klu: Vec<f64>,
    kpiv: Vec<usize>,
    /// Whether `K_i` is factored by blocks (`klu` then holds the LU factors of `K_11` and
    /// of the Schur complement `S`, and `G = K_11^{-1} K_12`; `kpiv` their pivots) or whole.
    kblock: Vec<bool>,
    /// `KBLOCK_GROWTH_LIMIT`, or what a test sets (negative: never by blocks; infinite: by
    /// blocks whenever `K_11` can be factored).
    kblock_growth_limit: f64,
    /// `M_p` of every interval (`2n x k`): the parameter columns of the stage equations.
    mp: Vec<f64>,
    /// `X_i = C_i K_i^{-1}` (`n x 2n`), `C_i = -h_i [b_2 J_2, b_3 J_3]`.
    xmat: Vec<f64>,
    /// Condensed blocks `[A_i B_i P_i]` (`n x (2n+k)`).
    pub abp: Vec<f64>,
    /// Boundary Jacobians `[dg/dya dg/dyb dg/dp]` (`(n+k) x (2n+k)`).
    pub bc_blocks: Vec<f64>,
    /// The stage residuals `Phi_st,i` of the last [`reduce_residual`](Self::reduce_residual).
    z: Vec<f64>,
    work: Vec<f64>,
    /// Scratch of the condensation (`2 n^2`).
    cond_work: Vec<f64>,
    bc_work: Vec<f64>,
}

impl Collocation {
    /// Workspace for the mesh `x` (strictly increasing, at least two nodes).
    pub fn new(n: usize, k: usize, x: &[f64]) -> Self {
        let m = x.len();
        let lay = Layout { n, k, m };
        let nn = m - 1;
        let s = 2 * n;
        let wc = 2 * n + k;
        Self {
            lay,
            tab: Tableau::lobatto_iiia4(),
            x: x.to_vec(),
            h: x.windows(2).map(|w| w[1] - w[0]).collect(),
            fnodes: vec![0.0; m * n],
            fstages: vec![0.0; nn * s],
            jy_nodes: vec![0.0; m * n * n],
            jp_nodes: vec![0.0; m * n * k],
            jy_stages: vec![0.0; nn * 2 * n * n],
            jp_stages: vec![0.0; nn * 2 * n * k],
            klu: vec![0.0; nn * s * s],
            kpiv: vec![0; nn * s],
            kblock: vec![false; nn],
            kblock_growth_limit: KBLOCK_GROWTH_LIMIT,
            mp: vec![0.0; nn * s * k],
            xmat: vec![0.0; nn * n * s],
            abp: vec![0.0; nn * n * wc],
            bc_blocks: vec![0.0; (n + k) * wc],
            z: vec![0.0; nn * s],
            work: vec![0.0; (3 * n).max(2 * n + k)],
            cond_work: vec![0.0; 3 * n * n],
            bc_work: vec![0.0; 4 * n + 3 * k + (n + k) * wc],
        }
    }

    /// Evaluate `f` at all nodes and stages of `u` and write the full residual `res`
    /// (layout in the module docs). Returns `false` if `f` or `g` produced NaN/inf.
    pub fn evaluate_residual<P: BvpProblem + ?Sized>(
        &mut self,
        ev: &Evaluator<P>,
        u: &[f64],
        res: &mut [f64],
    ) -> bool {
        let Layout { n, k, m } = self.lay;
        let p = &u[self.lay.p_offset()..self.lay.p_offset() + k];
        let so = self.lay.stage_offset();
        for i in 0..m {
            ev.eval_f(
                self.x[i],
                &u[i * n..(i + 1) * n],
                p,
                &mut self.fnodes[i * n..(i + 1) * n],
            );
        }
        for i in 0..m - 1 {
            for s in 0..2 {
                let off = (2 * i + s) * n;
                let xs = self.x[i] + self.tab.c[s + 1] * self.h[i];
                ev.eval_f(
                    xs,
                    &u[so + off..so + off + n],
                    p,
                    &mut self.fstages[off..off + n],
                );
            }
        }
        let tab = &self.tab;
        for i in 0..m - 1 {
            let h = self.h[i];
            let f0 = &self.fnodes[i * n..(i + 1) * n];
            let f3 = &self.fnodes[(i + 1) * n..(i + 2) * n];
            let f1 = &self.fstages[2 * i * n..(2 * i + 1) * n];
            let f2 = &self.fstages[(2 * i + 1) * n..(2 * i + 2) * n];
            let yi = &u[i * n..(i + 1) * n];
            let yj = &u[(i + 1) * n..(i + 2) * n];
            for r in 0..n {
                let quad = |w: &[f64; 4]| w[0] * f0[r] + w[1] * f1[r] + w[2] * f2[r] + w[3] * f3[r];
                res[i * n + r] = yj[r] - yi[r] - h * quad(&tab.b);
                for s in 0..2 {
                    let off = (2 * i + s) * n + r;
                    res[so + off] = u[so + off] - yi[r] - h * quad(&tab.a[s + 1]);
                }
            }
        }
        let bo = self.lay.bc_offset();
        ev.eval_bc(
            &u[0..n],
            &u[(m - 1) * n..m * n],
            p,
            &mut res[bo..bo + n + k],
        );
        self.fnodes
            .iter()
            .chain(self.fstages.iter())
            .all(|v| v.is_finite())
            && res.iter().all(|v| v.is_finite())
    }

    /// Evaluate all Jacobians at `u` and condense every interval.
    ///
    /// Requires that [`evaluate_residual`](Self::evaluate_residual) was last called with the
    /// same `u` (its `f` values serve the finite-difference fallback); `res` is that residual.
    ///
    /// Linearising the stage equations of interval `i` gives
    ///
    /// ```text
    /// K dY + M_a dy_i + M_b dy_{i+1} + M_p dp = -Phi_st,
    /// K   = [[I - h a22 J2, -h a23 J3], [-h a32 J2, I - h a33 J3]]         (2n x 2n)
    /// M_a = [-I - h a21 J1; -I - h a31 J1],  M_b = [-h a24 J4; -h a34 J4]
    /// M_p = [-h sum_j a2j P_j; -h sum_j a3j P_j]
    /// ```
    ///
    /// (`J_j = df/dy`, `P_j = df/dp` at stage `j`), so `dY = -K^{-1} (Phi_st + M delta)` with
    /// `delta = [dy_i; dy_{i+1}; dp]`. Substituting into the linearised continuity equation
    /// gives the condensed blocks
    ///
    /// ```text
    /// [A_i B_i P_i] = [-I - h b1 J1,  I - h b4 J4,  -h sum_j b_j P_j] - X M,
    /// X = C K^{-1},  C = [-h b2 J2, -h b3 J3],   right-hand side  -(Phi_4 - X Phi_st).
    /// ```
    ///
    /// `X` is `n x 2n`, so forming it by a right solve with the factors of `K` costs `n`
    /// right-hand sides rather than the `2n + k` of `K^{-1} M`; and the `y` columns of `M` are
    /// `-[I; I] - h [a21; a31] J1` and `-h [a24; a34] J4`, so `X M` needs two `n x n`
    /// products with `J1` and `J4` (`X = [X_2 X_3]`):
    ///
    /// ```text
    /// X M_a = -(X_2 + X_3) - h (a21 X_2 + a31 X_3) J1,   X M_b = -h (a24 X_2 + a34 X_3) J4.
    /// ```
    ///
    /// Only `M_p` is stored; the expansion rebuilds `M delta` from `J1`, `J4` and `M_p`.
    ///
    /// `K` itself is factored by blocks where that is safe (see `KBLOCK_GROWTH_LIMIT`):
    /// `K_11 = I - h a22 J2`, `K_12 = -h a23 J3`, `K_21 = -h a32 J2 = w (K_11 - I)` and
    /// `C_2 = -h b2 J2 = beta (K_11 - I)` (`w = a32 / a22`, `beta = b2 / a22`), so with
    /// `G = K_11^{-1} K_12` the Schur complement is `S = K_22 - w (K_12 - G)`, and
    /// `X_3 S = C_3 - beta (K_12 - G)`, `X_2 = (beta I - w X_3) (I - K_11^{-1})`: two `n x n`
    /// LUs and four `n x n x n` solves instead of a `2n x 2n` LU and a right solve with it
    /// (about 55 % of the arithmetic). Elsewhere `K` is factored whole.
    ///
    /// Returns `Err(i)` if `K_i` is singular or a Jacobian is not finite (interval `i`;
    /// `i = N` for the boundary Jacobian).
    pub fn evaluate_jacobian<P: BvpProblem + ?Sized>(
        &mut self,
        ev: &Evaluator<P>,
        u: &[f64],
        res: &[f64],
    ) -> Result<(), usize> {
        let Layout { n, k, m } = self.lay;
        let nn = m - 1;
        let p = &u[self.lay.p_offset()..self.lay.p_offset() + k];
        let so = self.lay.stage_offset();
        let (n2, nk) = (n * n, n * k);
        for i in 0..m {
            ev.eval_jac(
                self.x[i],
                &u[i * n..(i + 1) * n],
                p,
                &self.fnodes[i * n..(i + 1) * n],
                &mut self.jy_nodes[i * n2..(i + 1) * n2],
                &mut self.jp_nodes[i * nk..(i + 1) * nk],
                &mut self.work,
            );
        }
        for i in 0..nn {
            for s in 0..2 {
                let q = 2 * i + s;
                let xs = self.x[i] + self.tab.c[s + 1] * self.h[i];
                ev.eval_jac(
                    xs,
                    &u[so + q * n..so + (q + 1) * n],
                    p,
                    &self.fstages[q * n..(q + 1) * n],
                    &mut self.jy_stages[q * n2..(q + 1) * n2],
                    &mut self.jp_stages[q * nk..(q + 1) * nk],
                    &mut self.work,
                );
            }
        }
        self.condense_all()?;
        self.evaluate_bc_jacobian(
            ev,
            u,
            &res[self.lay.bc_offset()..self.lay.bc_offset() + n + k],
        )
        .map_err(|_| nn)
    }

    /// Condense every interval (in the AVX2 copy where the CPU has it). (Two threads, each
    /// condensing half of the intervals, were tried and measured: no faster on this 2-core
    /// machine even at N = 10^4, and 3x slower at N = 100 when the other core is busy;
    /// bench/README.md.)
    fn condense_all(&mut self) -> Result<(), usize> {
        let jac = StageJacobians {
            lay: self.lay,
            tab: &self.tab,
            h: &self.h,
            jy_nodes: &self.jy_nodes,
            jy_stages: &self.jy_stages,
            jp_nodes: &self.jp_nodes,
            jp_stages: &self.jp_stages,
            kblock_growth_limit: self.kblock_growth_limit,
        };
        let out = CondensedBlocks {
            klu: &mut self.klu,
            kpiv: &mut self.kpiv,
            kblock: &mut self.kblock,
            mp: &mut self.mp,
            xmat: &mut self.xmat,
            abp: &mut self.abp,
            scratch: &mut self.cond_work,
        };
        condense_range(&jac, 0, out)
    }

    /// Boundary Jacobians into `bc_blocks` (row-major `(n+k) x (2n+k)`: `[dya dyb dp]`).
    fn evaluate_bc_jacobian<P: BvpProblem + ?Sized>(
        &mut self,
        ev: &Evaluator<P>,
        u: &[f64],
        g0: &[f64],
    ) -> Result<(), ()> {
        let Layout { n, k, m } = self.lay;
        let rows = n + k;
        let wc = 2 * n + k;
        let (work, jacs) = self.bc_work.split_at_mut(3 * n + 2 * k);
        let (dya, rest) = jacs.split_at_mut(rows * n);
        let (dyb, dp) = rest.split_at_mut(rows * n);
        let p = &u[self.lay.p_offset()..self.lay.p_offset() + k];
        ev.eval_bc_jac(
            &u[0..n],
            &u[(m - 1) * n..m * n],
            p,
            g0,
            dya,
            dyb,
            &mut dp[..rows * k],
            work,
        );
        for r in 0..rows {
            self.bc_blocks[r * wc..r * wc + n].copy_from_slice(&dya[r * n..(r + 1) * n]);
            self.bc_blocks[r * wc + n..r * wc + 2 * n].copy_from_slice(&dyb[r * n..(r + 1) * n]);
            self.bc_blocks[r * wc + 2 * n..(r + 1) * wc].copy_from_slice(&dp[r * k..(r + 1) * k]);
        }
        if self.bc_blocks.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(())
        }
    }

    /// Eliminate the stage residuals from `res` (full residual) and write the global
    /// right-hand side `rhs = -[Phi_4 - X Phi_st; g]` (length `m*n + k`); keeps `Phi_st` for
    /// [`expand_correction`](Self::expand_correction).
    pub fn reduce_residual(&mut self, res: &[f64], rhs: &mut [f64]) {
        avx2!(fn(this: &mut Collocation, res: &[f64], rhs: &mut [f64]) -> () {
            match this.lay.n {
                12 => this.reduce_impl(res, rhs, 12),
                24 => this.reduce_impl(res, rhs, 24),
                n => this.reduce_impl(res, rhs, n),
            }
        }, self, res, rhs)
    }

    #[inline(always)]
    fn reduce_impl(&mut self, res: &[f64], rhs: &mut [f64], n: usize) {
        debug_assert_eq!(n, self.lay.n);
        let s = 2 * n;
        let so = self.lay.stage_offset();
        let nn = self.lay.intervals();
        self.z.copy_from_slice(&res[so..so + nn * s]);
        for i in 0..nn {
            let z = &self.z[i * s..(i + 1) * s];
            let xm = &self.xmat[i * n * s..(i + 1) * n * s];
            for r in 0..n {
                rhs[i * n + r] = dot(&xm[r * s..(r + 1) * s], z) - res[i * n + r];
            }
        }
        let bo = self.lay.bc_offset();
        let g = self.lay.global();
        for (r, v) in rhs[bo..g].iter_mut().zip(&res[bo..g]) {
            *r = -v;
        }
    }

    /// Given the global part `delta[..m*n+k]` of a correction, fill its stage part:
    /// `dY_i = -K_i^{-1} (Phi_st,i + M_i [dy_i; dy_{i+1}; dp])`, with
    /// `M [dy_i; dy_{i+1}; dp] = -[dy_i; dy_i] - h [a21; a31] J1 dy_i - h [a24; a34] J4 dy_{i+1}
    /// + M_p dp`.
    pub fn expand_correction(&mut self, delta: &mut [f64]) {
        avx2!(fn(this: &mut Collocation, delta: &mut [f64]) -> () {
            // The common sizes as constants (as in `condense_range`; the same bits).
            match (this.lay.n, this.lay.k) {
                (12, 1) => this.expand_impl(delta, 12, 1),
                (24, 1) => this.expand_impl(delta, 24, 1),
                (n, k) => this.expand_impl(delta, n, k),
            }
        }, self, delta)
    }

    #[inline(always)]
    fn expand_impl(&mut self, delta: &mut [f64], n: usize, k: usize) {
        debug_assert_eq!((n, k), (self.lay.n, self.lay.k));
        let s = 2 * n;
        let n2 = n * n;
        let po = self.lay.p_offset();
        let so = self.lay.stage_offset();
        let tab = &self.tab;
        let (glob, stages) = delta.split_at_mut(so);
        let dp = &glob[po..po + k];
        // `J(y_i) dy_i` is needed by the intervals on both sides of node i: computed once,
        // as `j4y` of interval i - 1, and kept as `j1y` of interval i.
        let (j1y, rest) = self.work.split_at_mut(n);
        let (j4y, scratch) = rest.split_at_mut(n);
        let scratch = &mut scratch[..n];
        for (r, v) in j1y.iter_mut().enumerate() {
            *v = dot(&self.jy_nodes[r * n..(r + 1) * n], &glob[..n]);
        }
        for i in 0..self.lay.intervals() {
            let h = self.h[i];
            let dyi = &glob[i * n..(i + 1) * n];
            let dyj = &glob[(i + 1) * n..(i + 2) * n];
            if i > 0 {
                j1y.copy_from_slice(j4y);
            }
            let j4 = &self.jy_nodes[(i + 1) * n2..(i + 2) * n2];
            for r in 0..n {
                j4y[r] = dot(&j4[r * n..(r + 1) * n], dyj);
            }
            let mp = &self.mp[i * s * k..(i + 1) * s * k];
            let v = &mut stages[i * s..(i + 1) * s];
            for sr in 0..2 {
                let arow = &tab.a[sr + 1];
                for r in 0..n {
                    let row = sr * n + r;
                    v[row] =
                        self.z[i * s + row] - dyi[r] - h * (arow[0] * j1y[r] + arow[3] * j4y[r])
                            + dot(&mp[row * k..(row + 1) * k], dp);
                }
            }
            let klu = &self.klu[i * s * s..(i + 1) * s * s];
            let piv = &self.kpiv[i * s..(i + 1) * s];
            if self.kblock[i] {
                // K [v2; v3] = [r2; r3]: t = K_11^{-1} r2, S v3 = r3 - K_21 t with
                // K_21 t = w (r2 - t), then v2 = t - G v3.
                let w = tab.a[2][1] / tab.a[1][1];
                let (k11, rest) = klu.split_at(n2);
                let (sm, g) = rest.split_at(n2);
                let (r2, r3) = v.split_at_mut(n);
                let t = &mut scratch[..];
                t.copy_from_slice(r2);
                lu_solve(k11, n, &piv[..n], t, 1);
                for c in 0..n {
                    r3[c] -= w * (r2[c] - t[c]);
                }
                lu_solve(sm, n, &piv[n..s], r3, 1);
                for r in 0..n {
                    r2[r] = t[r] - dot(&g[r * n..(r + 1) * n], r3);
                }
            } else {
                lu_solve(klu, s, piv, v, 1);
            }
            for x in v.iter_mut() {
                *x = -*x;
            }
        }
    }
}

/// What the condensation of an interval reads: the Jacobians at nodes and stages.
struct StageJacobians<'a> {
    lay: Layout,
    tab: &'a Tableau,
    h: &'a [f64],
    jy_nodes: &'a [f64],
    jy_stages: &'a [f64],
    jp_nodes: &'a [f64],
    jp_stages: &'a [f64],
    kblock_growth_limit: f64,
}

/// What it writes, for a run of consecutive intervals (the slices start at the run's first
/// interval), and a scratch of `3 n^2`. (Runs of intervals are independent: they could go
/// to different threads.)
struct CondensedBlocks<'a> {
    klu: &'a mut [f64],
    kpiv: &'a mut [usize],
    kblock: &'a mut [bool],
    mp: &'a mut [f64],
    xmat: &'a mut [f64],
    abp: &'a mut [f64],
    scratch: &'a mut [f64],
}

/// Condense the intervals `first ..` covered by `out` (in the AVX2 copy where the CPU has
/// it); `Err(i)` names the first interval whose `K_i` is singular or whose blocks are not
/// finite.
fn condense_range(jac: &StageJacobians, first: usize, out: CondensedBlocks) -> Result<(), usize> {
    avx2!(fn(jac: &StageJacobians, first: usize, out: CondensedBlocks) -> Result<(), usize> {
        let Layout { n, k, .. } = jac.lay;
        let count = out.kpiv.len() / (2 * n);
        let mut out = out;
        // The common sizes with the dimensions as constants (the inlined kernels then have
        // fixed trip counts: unrolled, no bounds checks); the same operations in the same
        // order as the generic copy, so the same bits.
        match (n, k) {
            (12, 1) => {
                for i in first..first + count {
                    condense_interval(jac, i, i - first, &mut out, 12, 1)?;
                }
            }
            (24, 1) => {
                for i in first..first + count {
                    condense_interval(jac, i, i - first, &mut out, 24, 1)?;
                }
            }
            _ => {
                for i in first..first + count {
                    condense_interval(jac, i, i - first, &mut out, n, k)?;
                }
            }
        }
        Ok(())
    }, jac, first, out)
}

/// Build and factor `K_i`, then `X_i`, `M_p` and `[A_i B_i P_i]` of interval `i` (stored at
/// position `at` of `out`; formulas in [`Collocation::evaluate_jacobian`]).
#[inline(always)]
fn condense_interval(
    jac: &StageJacobians,
    i: usize,
    at: usize,
    out: &mut CondensedBlocks,
    n: usize,
    k: usize,
) -> Result<(), usize> {
    debug_assert_eq!((n, k), (jac.lay.n, jac.lay.k));
    let s = 2 * n;
    let wc = 2 * n + k;
    let (n2, nk) = (n * n, n * k);
    let h = jac.h[i];
    let tab = jac.tab;
    let jy = |j: usize| -> &[f64] {
        match j {
            0 => &jac.jy_nodes[i * n2..(i + 1) * n2],
            3 => &jac.jy_nodes[(i + 1) * n2..(i + 2) * n2],
            _ => &jac.jy_stages[(2 * i + j - 1) * n2..(2 * i + j) * n2],
        }
    };
    let jp = |j: usize| -> &[f64] {
        match j {
            0 => &jac.jp_nodes[i * nk..(i + 1) * nk],
            3 => &jac.jp_nodes[(i + 1) * nk..(i + 2) * nk],
            _ => &jac.jp_stages[(2 * i + j - 1) * nk..(2 * i + j) * nk],
        }
    };
    let klu = &mut out.klu[at * s * s..(at + 1) * s * s];
    let mp = &mut out.mp[at * s * k..(at + 1) * s * k];
    let xm = &mut out.xmat[at * n * s..(at + 1) * n * s];
    let abp = &mut out.abp[at * n * wc..(at + 1) * n * wc];
    for sr in 0..2 {
        let arow = &tab.a[sr + 1];
        for r in 0..n {
            for c in 0..k {
                let mut acc = 0.0;
                for (j, &aj) in arow.iter().enumerate() {
                    acc += aj * jp(j)[r * k + c];
                }
                mp[(sr * n + r) * k + c] = -h * acc;
            }
        }
    }
    // The uncondensed part of [A B P].
    for r in 0..n {
        let (j0, j3) = (jy(0), jy(3));
        for c in 0..n {
            let delta = if r == c { 1.0 } else { 0.0 };
            abp[r * wc + c] = -delta - h * tab.b[0] * j0[r * n + c];
            abp[r * wc + n + c] = delta - h * tab.b[3] * j3[r * n + c];
        }
        for c in 0..k {
            let mut acc = 0.0;
            for (j, &bj) in tab.b.iter().enumerate() {
                acc += bj * jp(j)[r * k + c];
            }
            abp[r * wc + 2 * n + c] = -h * acc;
        }
    }
    let piv = &mut out.kpiv[at * s..(at + 1) * s];
    let (j2, j3) = (jy(1), jy(2));
    let (a22, a23, a32, a33) = (tab.a[1][1], tab.a[1][2], tab.a[2][1], tab.a[2][2]);
    let (b2, b3) = (tab.b[1], tab.b[2]);
    // X = C K^{-1} by block elimination with K_11 = I - h a22 J2 (partial pivoting inside
    // the blocks), unless its growth says it may be inaccurate: then as a whole.
    let (w, beta) = (a32 / a22, b2 / a22);
    let block = 'block: {
        // K_21 = w (K_11 - I), C_2 = beta (K_11 - I); with G = K_11^{-1} K_12:
        //   S = K_22 - K_21 G = K_22 - w (K_12 - G),   X_3 S = C_3 - beta (K_12 - G),
        //   X_2 = (beta I - w X_3) (I - K_11^{-1}).
        let (k11, rest) = klu.split_at_mut(n2);
        let (sm, rest) = rest.split_at_mut(n2);
        let (g, _) = rest.split_at_mut(n2);
        let (p11, ps) = piv.split_at_mut(n);
        // Row sums: ||K||_inf, ||K_11||_inf, ||K_21||_inf (row by row, the loops over a row
        // without branches so that they vectorise; the diagonal is fixed after).
        let (mut norm_k, mut norm_k11, mut norm_k21) = (0.0_f64, 0.0_f64, 0.0_f64);
        for r in 0..n {
            let (j2r, j3r) = (&j2[r * n..(r + 1) * n], &j3[r * n..(r + 1) * n]);
            let k11r = &mut k11[r * n..(r + 1) * n];
            let gr = &mut g[r * n..(r + 1) * n];
            for ((kv, gv), (x2, x3)) in k11r.iter_mut().zip(gr.iter_mut()).zip(j2r.iter().zip(j3r))
            {
                *kv = -h * a22 * x2;
                *gv = -h * a23 * x3;
            }
            k11r[r] = 1.0 - h * a22 * j2r[r];
            let s11 = abs_sum(k11r);
            let s12 = abs_sum(gr);
            let s21 = (h * a32).abs() * abs_sum(j2r);
            let d22 = h * a33 * j3r[r];
            let s22 = (h * a33).abs() * abs_sum(j3r) - d22.abs() + (1.0 - d22).abs();
            norm_k = norm_k.max(s11 + s12).max(s21 + s22);
            norm_k11 = norm_k11.max(s11);
            norm_k21 = norm_k21.max(s21);
        }
        if !lu_factor(k11, n, p11) {
            break 'block false;
        }
        lu_solve_rows(k11, n, p11, g, n);
        let (mut norm_g, mut norm_s) = (0.0_f64, 0.0_f64);
        for r in 0..n {
            let j3r = &j3[r * n..(r + 1) * n];
            let gr = &g[r * n..(r + 1) * n];
            let smr = &mut sm[r * n..(r + 1) * n];
            let x3r = &mut xm[r * s + n..(r + 1) * s];
            for ((sv, xv), (jv, gv)) in smr.iter_mut().zip(x3r.iter_mut()).zip(j3r.iter().zip(gr)) {
                let d = -h * a23 * jv - gv;
                *sv = -h * a33 * jv - w * d;
                *xv = -h * b3 * jv - beta * d;
            }
            let d = -h * a23 * j3r[r] - gr[r];
            smr[r] = 1.0 - h * a33 * j3r[r] - w * d;
            norm_g = norm_g.max(abs_sum(gr));
            norm_s = norm_s.max(abs_sum(smr));
        }
        // K = [[K_11, 0], [K_21, S]] [[I, G], [0, I]]: backward stable when the factors'
        // norms are not much above ||K|| (Demmel, Higham & Schreiber 1995).
        let growth = (norm_k11 + norm_k21 + norm_s) * (1.0 + norm_g) / norm_k;
        if growth.is_nan() || growth > jac.kblock_growth_limit || !lu_factor(sm, n, ps) {
            break 'block false;
        }
        lu_right_solve_strided(&sm[..], n, ps, &mut xm[n..], n, s, out.scratch);
        let (z, work) = out.scratch.split_at_mut(n2);
        for r in 0..n {
            for c in 0..n {
                let delta = if r == c { beta } else { 0.0 };
                z[r * n + c] = delta - w * xm[r * s + n + c];
            }
        }
        for r in 0..n {
            xm[r * s..r * s + n].copy_from_slice(&z[r * n..(r + 1) * n]);
        }
        lu_right_solve(&k11[..], n, p11, z, n, work);
        for r in 0..n {
            for c in 0..n {
                xm[r * s + c] -= z[r * n + c];
            }
        }
        true
    };
    out.kblock[at] = block;
    if block {
    } else {
        // The whole 2n x 2n stage block.
        for sr in 0..2 {
            let arow = &tab.a[sr + 1];
            for r in 0..n {
                let row = sr * n + r;
                for sc in 0..2 {
                    let jac = &jy(sc + 1)[r * n..(r + 1) * n];
                    let coef = -h * arow[sc + 1];
                    let out = &mut klu[row * s + sc * n..row * s + sc * n + n];
                    for (o, jv) in out.iter_mut().zip(jac) {
                        *o = coef * jv;
                    }
                    if sr == sc {
                        out[r] += 1.0;
                    }
                }
            }
        }
        // C into X, overwritten by the right solve.
        for r in 0..n {
            for sc in 0..2 {
                let jac = &jy(sc + 1)[r * n..(r + 1) * n];
                let coef = -h * tab.b[sc + 1];
                for (o, jv) in xm[r * s + sc * n..r * s + sc * n + n].iter_mut().zip(jac) {
                    *o = coef * jv;
                }
            }
        }
        if !lu_factor(klu, s, piv) {
            return Err(i);
        }
        lu_right_solve(klu, s, piv, xm, n, out.scratch);
    }
    // X M_a = -(X_2 + X_3) - h (a21 X_2 + a31 X_3) J1,  X M_b = -h (a24 X_2 + a34 X_3) J4.
    let (ya, yb) = out.scratch.split_at_mut(n2);
    let (a2, a3) = (&tab.a[1], &tab.a[2]);
    for r in 0..n {
        let x2 = &xm[r * s..r * s + n];
        let x3 = &xm[r * s + n..(r + 1) * s];
        for c in 0..n {
            ya[r * n + c] = -h * (a2[0] * x2[c] + a3[0] * x3[c]);
            yb[r * n + c] = -h * (a2[3] * x2[c] + a3[3] * x3[c]);
            abp[r * wc + c] += x2[c] + x3[c];
        }
    }
    sub_mat_mul_strided(&mut abp[..], wc, 0, ya, jy(0), n, n, n);
    sub_mat_mul_strided(&mut abp[..], wc, n, yb, jy(3), n, n, n);
    if k > 0 {
        sub_mat_mul_strided(&mut abp[..], wc, 2 * n, xm, mp, n, s, k);
    }
    if abp.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(i)
    }
}

impl Collocation {
    /// Which intervals' stage blocks were factored by blocks in the last condensation.
    #[cfg(test)]
    pub fn stage_blocks_by_blocks(&self) -> &[bool] {
        &self.kblock
    }

    /// Replace `KBLOCK_GROWTH_LIMIT` (negative: never by blocks; infinite: by blocks whenever
    /// `K_11` can be factored).
    #[cfg(test)]
    pub fn set_kblock_growth_limit(&mut self, limit: f64) {
        self.kblock_growth_limit = limit;
    }

    /// Copy the condensed blocks and the boundary Jacobian into `values`, in
    /// [`global_jacobian_pattern`](super::linear::global_jacobian_pattern) order.
    pub fn assemble_global(&self, values: &mut [f64]) {
        let (blocks, bc) = values.split_at_mut(self.abp.len());
        blocks.copy_from_slice(&self.abp);
        bc.copy_from_slice(&self.bc_blocks);
    }
}

/// Evaluate the collocation polynomial of interval `i` at `t` in `[0, 1]` (local
/// coordinate): `u = y_i + h sum_j beta_j(t) F_j` and `u' = sum_j L_j(t) F_j`, with
/// `F = (f_i, F_2, F_3, f_{i+1})`. Either output may be empty to skip it.
#[allow(clippy::too_many_arguments)]
pub(crate) fn eval_collocation_polynomial(
    tab: &Tableau,
    n: usize,
    h: f64,
    yi: &[f64],
    fi: &[f64],
    fst: &[f64],
    fj: &[f64],
    t: f64,
    y_out: &mut [f64],
    dy_out: &mut [f64],
) {
    let (bv, lv) = tab.basis(t);
    for r in 0..n {
        let fs = [fi[r], fst[r], fst[n + r], fj[r]];
        if !y_out.is_empty() {
            y_out[r] = yi[r] + h * (bv[0] * fs[0] + bv[1] * fs[1] + bv[2] * fs[2] + bv[3] * fs[3]);
        }
        if !dy_out.is_empty() {
            dy_out[r] = lv[0] * fs[0] + lv[1] * fs[1] + lv[2] * fs[2] + lv[3] * fs[3];
        }
    }
}
