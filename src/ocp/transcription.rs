//! Direct transcription: the OCP of [`super::problem`] as a finite-dimensional NLP on a mesh,
//! with the same 4-stage Lobatto IIIA collocation as the BVP solver ([`crate::bvp`]).
//!
//! # Layout
//!
//! Normalized time `s ∈ [0, 1]`, `t = t0 + s T`; mesh `0 = s_0 < … < s_N = 1`,
//! `h_k = s_{k+1} − s_k`. Interval `k` has the Lobatto points `s_k + c_j h_k`, `j = 0..3`;
//! point `p = 3k + j` is global (the end point of interval `k` is the start of `k + 1`), so
//! there are `P = 3N + 1` points. Unknowns (`n_var = P nz (+ 1)`):
//!
//! ```text
//! v = [ z_0 | z_1 | … | z_{P−1} | T (only if free) ],   z_p = [x_p, u_p]
//! ```
//!
//! Constraints (`n_con = 3 N n + P n_g + #start + #start_linear + #end + #end_linear`), in
//! this order:
//!
//! ```text
//! c_{k,i} = x_{3k+i} − x_{3k} − T h_k Σ_j a_ij f(t_{3k+j}, z_{3k+j}),   i = 1, 2, 3
//! T g(t_p, z_p)      the n_g path constraints at every point p
//! x_i(p = 0) − a_i   for the prescribed start components
//! Σ c_i x_i(p = 0) − v for the linear start conditions
//! x_j(p = P−1) − b_j for the prescribed end components
//! Σ c_j x_j(p = P−1) − v for the linear end conditions
//! ```
//!
//! Objective (Lobatto quadrature, exact for degree 5): `J = T Σ_k h_k Σ_j b_j L(t_{3k+j}, z_{3k+j})`.
//!
//! # Lagrangian and its Hessian
//!
//! `ℒ = J + Σ ν_{k,i}·c_{k,i} + Σ μ_p·T g_p + Σ μ·bc`. Grouping by point,
//! `ℒ = T Σ_p ℓ_p(t_p, z_p) +` (terms linear in `v`) with `ℓ_p = ω_p L + λ_pᵀ f + μ_pᵀ g`, the
//! *point weights*
//!
//! ```text
//! ω_p = Σ_{(k,j) ∋ p} h_k b_j,      λ_p = − Σ_{(k,j) ∋ p} h_k Σ_i a_ij ν_{k,i}.
//! ```
//!
//! (The path rows are scaled by `T` — the same feasible set — so that they join the point
//! Lagrangian like the dynamics, and the derivatives in `T` below cover them too.)
//!
//! Hence the Hessian is block diagonal in the points, bordered by `T`:
//! `∂²ℒ/∂z_p² = T ∂²ℓ_p/∂z²`, `∂²ℒ/∂z_p∂T = ∂ℓ_p/∂z + T s_p ∂²ℓ_p/∂z∂t`,
//! `∂²ℒ/∂T² = Σ_p 2 s_p ∂ℓ_p/∂t + T s_p² ∂²ℓ_p/∂t²`.
//!
//! At an optimum `λ_p / ω_p` approximates the costate `π(t_p)` of Pontryagin's principle
//! (`H = L + πᵀ f`), which is how the multipliers are compared with an indirect solution.

use super::problem::{Boundary, Horizon, OcpProblem};
use crate::bvp::collocation::Tableau;

/// A sparse matrix entry `(row, column, value)`; duplicates are summed.
pub type Entry = (usize, usize, f64);

/// The NLP of one problem on one mesh.
pub struct Transcription<'a, P: OcpProblem + ?Sized> {
    problem: &'a P,
    boundary: Boundary,
    horizon: Horizon,
    mesh: Vec<f64>,
    tab: Tableau,
    n: usize,
    m: usize,
    /// Path constraints per point.
    n_g: usize,
}

/// Why a transcription cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TranscriptionError {
    /// The mesh is not `0 = s_0 < … < s_N = 1` with `N ≥ 1`.
    #[error("the mesh must increase strictly from 0 to 1 with at least 2 nodes")]
    BadMesh,
    /// A prescribed component is out of range or repeated.
    #[error("boundary component {0} is out of range or given twice at the same end")]
    BadBoundary(usize),
    /// A fixed `T` that is not positive and finite.
    #[error("the fixed interval length must be positive and finite, got {0}")]
    BadLength(f64),
}

impl<'a, P: OcpProblem + ?Sized> Transcription<'a, P> {
    /// The NLP of `problem` on the normalized `mesh` (`0 = s_0 < … < s_N = 1`).
    pub fn new(
        problem: &'a P,
        boundary: Boundary,
        horizon: Horizon,
        mesh: Vec<f64>,
    ) -> Result<Self, TranscriptionError> {
        let ok = mesh.len() >= 2
            && mesh[0] == 0.0
            && mesh[mesh.len() - 1] == 1.0
            && mesh.windows(2).all(|w| w[1] > w[0]);
        if !ok {
            return Err(TranscriptionError::BadMesh);
        }
        let n = problem.n_state();
        for list in [&boundary.start, &boundary.end] {
            for (i, &(c, _)) in list.iter().enumerate() {
                if c >= n || list[..i].iter().any(|&(d, _)| d == c) {
                    return Err(TranscriptionError::BadBoundary(c));
                }
            }
        }
        for cond in boundary.start_linear.iter().chain(&boundary.end_linear) {
            for (i, &(c, _)) in cond.coefficients.iter().enumerate() {
                if c >= n || cond.coefficients[..i].iter().any(|&(d, _)| d == c) {
                    return Err(TranscriptionError::BadBoundary(c));
                }
            }
        }
        if let Horizon::Fixed { length, .. } = horizon {
            if !(length > 0.0 && length.is_finite()) {
                return Err(TranscriptionError::BadLength(length));
            }
        }
        Ok(Self {
            problem,
            boundary,
            horizon,
            mesh,
            tab: Tableau::lobatto_iiia4(),
            n,
            m: problem.n_control(),
            n_g: problem.n_path(),
        })
    }

    /// The same problem, horizon and mesh with other boundary conditions (validated as by
    /// [`Self::new`]).
    pub fn with_boundary(self, boundary: Boundary) -> Result<Self, TranscriptionError> {
        Self::new(self.problem, boundary, self.horizon, self.mesh)
    }

    /// Number of states `n`.
    pub fn n_state(&self) -> usize {
        self.n
    }

    /// Number of controls `m`.
    pub fn n_control(&self) -> usize {
        self.m
    }

    /// `nz = n + m`.
    pub fn nz(&self) -> usize {
        self.n + self.m
    }

    /// Number of intervals `N`.
    pub fn n_intervals(&self) -> usize {
        self.mesh.len() - 1
    }

    /// Number of collocation points `P = 3N + 1`.
    pub fn n_points(&self) -> usize {
        3 * self.n_intervals() + 1
    }

    /// Number of unknowns.
    pub fn n_var(&self) -> usize {
        self.n_points() * self.nz() + usize::from(self.horizon.is_free())
    }

    /// Number of equality constraints.
    pub fn n_con(&self) -> usize {
        self.path_row(self.n_points()) + self.n_start_rows() + self.n_end_rows()
    }

    /// Number of conditions at the end (prescribed components, then linear conditions).
    fn n_end_rows(&self) -> usize {
        self.boundary.end.len() + self.boundary.end_linear.len()
    }

    /// Number of path constraints per point.
    pub fn n_path(&self) -> usize {
        self.n_g
    }

    /// The first row of point `p`'s path constraints (`p = P`: the first row after them).
    fn path_row(&self, p: usize) -> usize {
        3 * self.n_intervals() * self.n + p * self.n_g
    }

    /// Number of conditions at the start (prescribed components, then linear conditions).
    fn n_start_rows(&self) -> usize {
        self.boundary.start.len() + self.boundary.start_linear.len()
    }

    /// The horizon.
    pub fn horizon(&self) -> Horizon {
        self.horizon
    }

    /// The boundary conditions.
    pub fn boundary(&self) -> &Boundary {
        &self.boundary
    }

    /// The normalized mesh.
    pub fn mesh(&self) -> &[f64] {
        &self.mesh
    }

    /// Normalized time of point `p`.
    pub fn point_s(&self, p: usize) -> f64 {
        let (k, j) = (p / 3, p % 3);
        if k == self.n_intervals() {
            return 1.0;
        }
        self.mesh[k] + self.tab.c[j] * (self.mesh[k + 1] - self.mesh[k])
    }

    /// The interval length `T` at the primal point `v`.
    pub fn length(&self, v: &[f64]) -> f64 {
        match self.horizon {
            Horizon::Fixed { length, .. } => length,
            Horizon::Free { .. } => v[self.n_var() - 1],
        }
    }

    /// Physical time of point `p` for length `t_len`.
    pub fn point_time(&self, p: usize, t_len: f64) -> f64 {
        self.horizon.t0() + self.point_s(p) * t_len
    }

    /// Index of `T` among the unknowns, if free.
    pub fn length_index(&self) -> Option<usize> {
        self.horizon.is_free().then(|| self.n_var() - 1)
    }

    /// The primal point of a trajectory `z(t)` (and `T`, used only if free).
    pub fn primal_from_fn(&self, t_len: f64, mut z: impl FnMut(f64, &mut [f64])) -> Vec<f64> {
        let nz = self.nz();
        let mut v = vec![0.0; self.n_var()];
        for p in 0..self.n_points() {
            z(self.point_time(p, t_len), &mut v[p * nz..(p + 1) * nz]);
        }
        if let Some(i) = self.length_index() {
            v[i] = t_len;
        }
        v
    }

    /// Lobatto quadrature weights `ω_p = Σ h_k b_j` of the points (sum 1).
    pub fn quadrature_weights(&self) -> Vec<f64> {
        let mut w = vec![0.0; self.n_points()];
        for k in 0..self.n_intervals() {
            let h = self.mesh[k + 1] - self.mesh[k];
            for j in 0..4 {
                w[3 * k + j] += h * self.tab.b[j];
            }
        }
        w
    }

    /// The dynamics multipliers `λ_p = − Σ h_k Σ_i a_ij ν_{k,i}` of every point (`P × n`)
    /// from the constraint multipliers `y` (`n_con`).
    pub fn point_multipliers(&self, y: &[f64]) -> Vec<f64> {
        let n = self.n;
        let mut lam = vec![0.0; self.n_points() * n];
        for k in 0..self.n_intervals() {
            let h = self.mesh[k + 1] - self.mesh[k];
            for j in 0..4 {
                let p = 3 * k + j;
                for i in 1..4 {
                    let coef = -h * self.tab.a[i][j];
                    if coef == 0.0 {
                        continue;
                    }
                    let row = (3 * k + i - 1) * n;
                    for r in 0..n {
                        lam[p * n + r] += coef * y[row + r];
                    }
                }
            }
        }
        lam
    }

    /// The rows of the boundary conditions (after the dynamics and path rows).
    pub fn boundary_rows(&self) -> std::ops::Range<usize> {
        self.path_row(self.n_points())..self.n_con()
    }

    /// Dynamics multipliers `ν` (the rows of the collocation conditions; all other rows 0)
    /// whose point multipliers ([`Self::point_multipliers`]) approximate `ω_p π_p` for the
    /// costates `pi` (`P × n`, e.g. of an indirect solution): the inverse of
    /// `point_multipliers` interval by interval. Interval `k` contributes
    /// `−h_k Σ_i a_ij ν_{k,i}` to its four points `j`, and its share of `ω_p π_p` is
    /// `h_k b_j π_p`; the three `ν_{k,i}` are fitted to those four conditions by least squares
    /// (they are consistent only up to the discretization error, which Newton's method on the
    /// KKT conditions then removes).
    pub fn dynamics_multipliers_from_costates(&self, pi: &[f64]) -> Vec<f64> {
        let n = self.n;
        // A = (a_ij), i = 1..3 (rows), j = 0..3 (columns); ν = −(A Aᵀ)⁻¹ A (b ∘ π).
        let a = nalgebra::Matrix3x4::from_fn(|i, j| self.tab.a[i + 1][j]);
        let gram = a * a.transpose();
        // The Lobatto IIIA rows are independent: the Gram matrix is invertible.
        let fit = gram
            .try_inverse()
            .map(|g| g * a)
            .unwrap_or_else(nalgebra::Matrix3x4::zeros);
        let mut y = vec![0.0; self.n_con()];
        for k in 0..self.n_intervals() {
            for i in 0..3 {
                let row = (3 * k + i) * n;
                for r in 0..n {
                    y[row + r] = -(0..4)
                        .map(|j| fit[(i, j)] * self.tab.b[j] * pi[(3 * k + j) * n + r])
                        .sum::<f64>();
                }
            }
        }
        y
    }

    /// The objective `J(v)`.
    pub fn objective(&self, v: &[f64]) -> f64 {
        let nz = self.nz();
        let t_len = self.length(v);
        let mut l_z = vec![0.0; nz];
        let w = self.quadrature_weights();
        let mut sum = 0.0;
        for (p, wp) in w.iter().enumerate() {
            let (l, _) = self.problem.running_cost(
                self.point_time(p, t_len),
                &v[p * nz..(p + 1) * nz],
                &mut l_z,
            );
            sum += wp * l;
        }
        t_len * sum
    }

    /// The gradient of the objective (`n_var`).
    pub fn gradient(&self, v: &[f64]) -> Vec<f64> {
        let nz = self.nz();
        let t_len = self.length(v);
        let mut g = vec![0.0; self.n_var()];
        let mut l_z = vec![0.0; nz];
        let w = self.quadrature_weights();
        let mut d_t = 0.0;
        for (p, wp) in w.iter().enumerate() {
            let s = self.point_s(p);
            let (l, l_t) = self.problem.running_cost(
                self.point_time(p, t_len),
                &v[p * nz..(p + 1) * nz],
                &mut l_z,
            );
            for (gi, lz) in g[p * nz..(p + 1) * nz].iter_mut().zip(&l_z) {
                *gi = t_len * wp * lz;
            }
            d_t += wp * (l + t_len * s * l_t);
        }
        if let Some(i) = self.length_index() {
            g[i] = d_t;
        }
        g
    }

    /// Dynamics at every point: `(f (P n), f_z (P n nz), f_t (P n))`.
    fn all_dynamics(&self, v: &[f64]) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let (n, nz, np) = (self.n, self.nz(), self.n_points());
        let t_len = self.length(v);
        let mut f = vec![0.0; np * n];
        let mut f_z = vec![0.0; np * n * nz];
        let mut f_t = vec![0.0; np * n];
        for p in 0..np {
            self.problem.dynamics(
                self.point_time(p, t_len),
                &v[p * nz..(p + 1) * nz],
                &mut f[p * n..(p + 1) * n],
                &mut f_z[p * n * nz..(p + 1) * n * nz],
                &mut f_t[p * n..(p + 1) * n],
            );
        }
        (f, f_z, f_t)
    }

    /// The constraint residuals (`n_con`).
    pub fn constraints(&self, v: &[f64]) -> Vec<f64> {
        let (n, nz) = (self.n, self.nz());
        let t_len = self.length(v);
        let (f, _, _) = self.all_dynamics(v);
        let mut c = vec![0.0; self.n_con()];
        for k in 0..self.n_intervals() {
            let h = self.mesh[k + 1] - self.mesh[k];
            for i in 1..4 {
                let row = (3 * k + i - 1) * n;
                for r in 0..n {
                    let mut quad = 0.0;
                    for j in 0..4 {
                        quad += self.tab.a[i][j] * f[(3 * k + j) * n + r];
                    }
                    c[row + r] = v[(3 * k + i) * nz + r] - v[3 * k * nz + r] - t_len * h * quad;
                }
            }
        }
        if self.n_g > 0 {
            let (mut g_z, mut g_t) = (vec![0.0; self.n_g * nz], vec![0.0; self.n_g]);
            for p in 0..self.n_points() {
                let row = self.path_row(p);
                let g = &mut c[row..row + self.n_g];
                let z = &v[p * nz..(p + 1) * nz];
                self.problem
                    .path(self.point_time(p, t_len), z, g, &mut g_z, &mut g_t);
                g.iter_mut().for_each(|gi| *gi *= t_len);
            }
        }
        let mut row = self.path_row(self.n_points());
        let last = (self.n_points() - 1) * nz;
        for &(comp, val) in &self.boundary.start {
            c[row] = v[comp] - val;
            row += 1;
        }
        for cond in &self.boundary.start_linear {
            c[row] = cond
                .coefficients
                .iter()
                .map(|&(comp, coef)| coef * v[comp])
                .sum::<f64>()
                - cond.value;
            row += 1;
        }
        for &(comp, val) in &self.boundary.end {
            c[row] = v[last + comp] - val;
            row += 1;
        }
        for cond in &self.boundary.end_linear {
            c[row] = cond
                .coefficients
                .iter()
                .map(|&(comp, coef)| coef * v[last + comp])
                .sum::<f64>()
                - cond.value;
            row += 1;
        }
        c
    }

    /// The constraint Jacobian as entries `(constraint, unknown, value)`; the positions are
    /// the same for every `v`.
    pub fn jacobian(&self, v: &[f64]) -> Vec<Entry> {
        self.jacobian_at(Some(v))
    }

    /// The positions of [`Self::jacobian`]'s entries, in its order, without evaluating the
    /// problem (values 0; the structural `±1` and boundary coefficients are kept).
    pub fn jacobian_positions(&self) -> Vec<Entry> {
        self.jacobian_at(None)
    }

    /// [`Self::jacobian`] at `v`, or (`None`) its positions alone: the same loops, so the two
    /// cannot disagree.
    fn jacobian_at(&self, v: Option<&[f64]>) -> Vec<Entry> {
        let (n, nz) = (self.n, self.nz());
        let t_len = v.map_or(0.0, |v| self.length(v));
        let (f, f_z, f_t) = match v {
            Some(v) => self.all_dynamics(v),
            None => {
                let np = self.n_points();
                (vec![0.0; np * n], vec![0.0; np * n * nz], vec![0.0; np * n])
            }
        };
        let t_col = self.length_index();
        let mut out = Vec::with_capacity(3 * self.n_intervals() * n * (4 * nz + 3));
        for k in 0..self.n_intervals() {
            let h = self.mesh[k + 1] - self.mesh[k];
            for i in 1..4 {
                let row = (3 * k + i - 1) * n;
                for r in 0..n {
                    out.push((row + r, (3 * k + i) * nz + r, 1.0));
                    out.push((row + r, 3 * k * nz + r, -1.0));
                    let mut d_t = 0.0;
                    for j in 0..4 {
                        let p = 3 * k + j;
                        let coef = -t_len * h * self.tab.a[i][j];
                        // Structural: the tableau's zeros (not the value's, so that the
                        // positions do not depend on the point).
                        if self.tab.a[i][j] != 0.0 {
                            for col in 0..nz {
                                out.push((
                                    row + r,
                                    p * nz + col,
                                    coef * f_z[(p * n + r) * nz + col],
                                ));
                            }
                        }
                        d_t -= h
                            * self.tab.a[i][j]
                            * (f[p * n + r] + t_len * self.point_s(p) * f_t[p * n + r]);
                    }
                    if let Some(tc) = t_col {
                        out.push((row + r, tc, d_t));
                    }
                }
            }
        }
        if self.n_g > 0 {
            let ng = self.n_g;
            let (mut g, mut g_z, mut g_t) = (vec![0.0; ng], vec![0.0; ng * nz], vec![0.0; ng]);
            for p in 0..self.n_points() {
                let s = self.point_s(p);
                if let Some(v) = v {
                    let z = &v[p * nz..(p + 1) * nz];
                    self.problem
                        .path(self.point_time(p, t_len), z, &mut g, &mut g_z, &mut g_t);
                }
                for r in 0..ng {
                    let row = self.path_row(p) + r;
                    for col in 0..nz {
                        out.push((row, p * nz + col, t_len * g_z[r * nz + col]));
                    }
                    if let Some(tc) = t_col {
                        out.push((row, tc, g[r] + t_len * s * g_t[r]));
                    }
                }
            }
        }
        let mut row = self.path_row(self.n_points());
        let last = (self.n_points() - 1) * nz;
        for &(comp, _) in &self.boundary.start {
            out.push((row, comp, 1.0));
            row += 1;
        }
        for cond in &self.boundary.start_linear {
            for &(comp, coef) in &cond.coefficients {
                out.push((row, comp, coef));
            }
            row += 1;
        }
        for &(comp, _) in &self.boundary.end {
            out.push((row, last + comp, 1.0));
            row += 1;
        }
        for cond in &self.boundary.end_linear {
            for &(comp, coef) in &cond.coefficients {
                out.push((row, last + comp, coef));
            }
            row += 1;
        }
        out
    }

    /// The Hessian of the Lagrangian `ℒ = J + yᵀ c` at `(v, y)`, lower triangle only
    /// (`row ≥ column`). The positions are the same for every `(v, y)`.
    pub fn lagrangian_hessian(&self, v: &[f64], y: &[f64]) -> Vec<Entry> {
        self.lagrangian_hessian_at(Some((v, y)))
    }

    /// The positions of [`Self::lagrangian_hessian`]'s entries, in its order, without
    /// evaluating the problem (values 0).
    pub fn lagrangian_hessian_positions(&self) -> Vec<Entry> {
        self.lagrangian_hessian_at(None)
    }

    /// [`Self::lagrangian_hessian`] at `(v, y)`, or (`None`) its positions alone: the same
    /// loops, so the two cannot disagree.
    fn lagrangian_hessian_at(&self, at: Option<(&[f64], &[f64])>) -> Vec<Entry> {
        let (n, nz) = (self.n, self.nz());
        let t_len = at.map_or(0.0, |(v, _)| self.length(v));
        let omega = self.quadrature_weights();
        let lam = match at {
            Some((_, y)) => self.point_multipliers(y),
            None => vec![0.0; self.n_points() * n],
        };
        let t_col = self.length_index();
        let (ng, nm) = (self.n_g, n + self.n_g);
        let d = nz + 1;
        let mut hess = vec![0.0; d * d];
        let mut l_z = vec![0.0; nz];
        let mut f = vec![0.0; n];
        let mut f_z = vec![0.0; n * nz];
        let mut f_t = vec![0.0; n];
        let (mut g, mut g_z, mut g_t) = (vec![0.0; ng], vec![0.0; ng * nz], vec![0.0; ng]);
        // [λ_p, μ_p] of the point being assembled.
        let mut lp = vec![0.0; nm];
        let mut out = Vec::with_capacity(self.n_points() * (nz * (nz + 1) / 2 + nz) + 1);
        let mut d_tt = 0.0;
        for p in 0..self.n_points() {
            let (s, t) = (self.point_s(p), self.point_time(p, t_len));
            if let Some((v, y)) = at {
                let z = &v[p * nz..(p + 1) * nz];
                lp[..n].copy_from_slice(&lam[p * n..(p + 1) * n]);
                let path_rows = self.path_row(p)..self.path_row(p) + ng;
                lp[n..].copy_from_slice(&y[path_rows]);
                self.problem
                    .lagrangian_hessian(t, z, omega[p], &lp, &mut hess);
            }
            for r in 0..nz {
                for c in 0..=r {
                    // Zeros are kept: the pattern is the same at every point (the KKT
                    // pattern is analysed once).
                    out.push((p * nz + r, p * nz + c, t_len * hess[r * d + c]));
                }
            }
            if let Some(tc) = t_col {
                // ℓ_z and ℓ_t of this point.
                let mut l_t = 0.0;
                if let Some((v, _)) = at {
                    let z = &v[p * nz..(p + 1) * nz];
                    l_t = self.problem.running_cost(t, z, &mut l_z).1;
                    self.problem.dynamics(t, z, &mut f, &mut f_z, &mut f_t);
                    if ng > 0 {
                        self.problem.path(t, z, &mut g, &mut g_z, &mut g_t);
                    }
                }
                let mut ell_t = omega[p] * l_t;
                for r in 0..n {
                    ell_t += lp[r] * f_t[r];
                }
                for r in 0..ng {
                    ell_t += lp[n + r] * g_t[r];
                }
                for c in 0..nz {
                    let mut ell_z = omega[p] * l_z[c];
                    for r in 0..n {
                        ell_z += lp[r] * f_z[r * nz + c];
                    }
                    for r in 0..ng {
                        ell_z += lp[n + r] * g_z[r * nz + c];
                    }
                    out.push((tc, p * nz + c, ell_z + t_len * s * hess[c * d + nz]));
                }
                d_tt += 2.0 * s * ell_t + t_len * s * s * hess[nz * d + nz];
            }
        }
        if let Some(tc) = t_col {
            out.push((tc, tc, d_tt));
        }
        out
    }

    /// Pivot groups of the KKT matrix `[[H, Aᵀ], [A, 0]]` (unknowns `0..n_var`, then
    /// constraints), in elimination order, for [`super::inertia::SymmetricPattern::with_groups`]:
    /// first `z_0` with its path constraints and the start conditions; then, interval by
    /// interval, its `3n` collocation constraints and the path constraints of its three new
    /// points with the unknowns of those points; last `T` and the
    /// end conditions. The constraints come first in their group because they are all that an
    /// earlier group touches (through the interval's first point, `z_{3k}`), and `T` first
    /// in the last: the factor of a group then reaches into the next one only by its
    /// constraints (see [`super::inertia::SymmetricPattern::with_groups`]). Each interval's
    /// group is itself a small KKT matrix whose constraint block `∂c_k/∂x_k ≈ I` has full
    /// rank, so Bunch–Kaufman inside the group always finds good `1 × 1` or `2 × 2` pivots (a
    /// state with the constraint that determines it), the fill stays banded, and the
    /// factorization runs forward in time like a null-space method: what the constraints
    /// leave behind are the controls, the free initial data and `T`.
    ///
    /// Why the interval's end point stays in its group: moved to the head of the next group,
    /// it would be the only thing an earlier group touches (`nz` rows instead of `3n`; 14 %
    /// fewer factor values on the paper's meshes), but every leading block of the elimination
    /// would then be the problem with its end state held fixed. Where the dynamics conserve
    /// a quantity (Suslov's energy) that problem's constraints are dependent, and each group
    /// gave a zero pivot: measured on the paper's η = 0.01 case, 274 zero eigenvalues for
    /// 278 intervals, the certificate degenerate; η = 1, an unreliable factorization. With the
    /// end point in its own group the leading blocks leave the end state free.
    pub fn kkt_pivot_groups(&self) -> Vec<Vec<usize>> {
        let (n, nz, nv) = (self.n, self.nz(), self.n_var());
        let n_int = self.n_intervals();
        let mut groups = Vec::with_capacity(n_int + 2);
        let start_rows = nv + self.path_row(self.n_points());
        let mut first: Vec<usize> = (0..nz).collect();
        first.extend(nv + self.path_row(0)..nv + self.path_row(1));
        first.extend(start_rows..start_rows + self.n_start_rows());
        groups.push(first);
        for k in 0..n_int {
            let mut g: Vec<usize> = (nv + 3 * k * n..nv + 3 * (k + 1) * n).collect();
            g.extend(nv + self.path_row(3 * k + 1)..nv + self.path_row(3 * k + 4));
            g.extend((3 * k + 1) * nz..(3 * k + 4) * nz);
            groups.push(g);
        }
        let mut last: Vec<usize> = self.length_index().into_iter().collect();
        let end_rows = start_rows + self.n_start_rows();
        last.extend(end_rows..end_rows + self.n_end_rows());
        if !last.is_empty() {
            groups.push(last);
        }
        groups
    }

    /// Where a direction `δv` (e.g. the weakest direction of the second-order test) lives in
    /// time, measured in the metric `M` (see [`Self::metric_diagonal`]).
    pub fn profile(&self, v: &[f64], dv: &[f64]) -> DirectionProfile {
        let (n, nz) = (self.n, self.nz());
        let t_len = self.length(v);
        let metric = self.metric_diagonal(v);
        let energy = |range: std::ops::Range<usize>| -> f64 {
            range.map(|i| metric[i] * dv[i] * dv[i]).sum()
        };
        let total = energy(0..self.n_var()).max(f64::MIN_POSITIVE);
        let w = self.quadrature_weights();
        let (mut start, mut end, mut peak, mut peak_density) = (0.0, 0.0, 0.0, -1.0);
        for (p, wp) in w.iter().enumerate() {
            let controls = energy(p * nz + n..(p + 1) * nz);
            let s = self.point_s(p);
            if s <= 0.05 {
                start += controls;
            }
            if s >= 0.95 {
                end += controls;
            }
            let density = controls / wp;
            if density > peak_density {
                peak_density = density;
                peak = self.point_time(p, t_len);
            }
        }
        DirectionProfile {
            peak_time: peak,
            initial_state_fraction: energy(0..n) / total,
            start_fraction: (start + energy(0..n)) / total,
            end_fraction: end / total,
            length_fraction: self.length_index().map_or(0.0, |i| energy(i..i + 1)) / total,
        }
    }

    /// The diagonal of the metric `M` in which the second-order margin is measured:
    /// `‖δv‖²_M = T Σ_p ω_p |δu_p|² + Σ_{free start components} δx_i(t0)² + δT²`, the discrete
    /// `∫|δu|² dt` plus the free initial data. Positive definite on the null space of the
    /// constraint Jacobian whenever the collocation equations determine the states from them.
    pub fn metric_diagonal(&self, v: &[f64]) -> Vec<f64> {
        let (n, nz) = (self.n, self.nz());
        let t_len = self.length(v);
        let mut d = vec![0.0; self.n_var()];
        for (p, w) in self.quadrature_weights().iter().enumerate() {
            for c in n..nz {
                d[p * nz + c] = t_len * w;
            }
        }
        for (i, di) in d.iter_mut().enumerate().take(n) {
            if !self.boundary.start.iter().any(|&(c, _)| c == i) {
                *di = 1.0;
            }
        }
        if let Some(tc) = self.length_index() {
            d[tc] = 1.0;
        }
        d
    }
}

/// Where a direction lives in time (fractions of its `M`-energy; see
/// [`Transcription::profile`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionProfile {
    /// Time where the control part `|δu|²` has its largest density.
    pub peak_time: f64,
    /// Fraction in the free initial state components `δx(t0)`.
    pub initial_state_fraction: f64,
    /// Fraction in `δx(t0)` and in the controls of the first 5 % of the interval.
    pub start_fraction: f64,
    /// Fraction in the controls of the last 5 % of the interval.
    pub end_fraction: f64,
    /// Fraction in `δT`.
    pub length_fraction: f64,
}
