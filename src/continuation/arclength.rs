//! Pseudo-arclength continuation of a one-parameter family of BVPs through folds (generic:
//! knows nothing of Suslov).
//!
//! [`natural`](super::natural) continuation fixes `λ` and solves for the state; at a fold
//! (turning point, `dλ/ds = 0`) the Jacobian of that problem becomes singular and the branch
//! cannot be followed further. [`pseudo_arclength`] (Keller 1977) makes `λ` an unknown and
//! parametrises the branch by an (approximate) arclength `s` instead, which stays regular
//! through folds.
//!
//! ```
//! use suslov::bvp::{self, BvpProblem, Guess};
//! use suslov::continuation::{pseudo_arclength, ArclengthOptions, ArclengthStatus};
//!
//! /// Bratu: y'' + λ e^y = 0, y(0) = y(1) = 0 (fold at λ* = 3.5138).
//! struct Bratu(f64);
//! impl BvpProblem for Bratu {
//!     fn n(&self) -> usize { 2 }
//!     fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
//!         dy[0] = y[1];
//!         dy[1] = -self.0 * y[0].exp();
//!     }
//!     fn bc(&self, ya: &[f64], yb: &[f64], _p: &[f64], r: &mut [f64]) {
//!         r[0] = ya[0];
//!         r[1] = yb[0];
//!     }
//! }
//! let x: Vec<f64> = (0..=10).map(|i| i as f64 / 10.0).collect();
//! let bvp = bvp::Options { tol: 1e-8, ..Default::default() };
//! let start = bvp::solve(&Bratu(1.0), &Guess::from_fn(&x, 2, vec![], |_, y| y.fill(0.0)), &bvp)
//!     .unwrap();
//! // Up the lower branch, round the fold, down the upper branch back to λ = 1.
//! let options = ArclengthOptions {
//!     initial_step: 0.05,
//!     max_step: 0.25,
//!     lambda_stop: Some(1.0),
//!     bvp,
//!     ..Default::default()
//! };
//! let monitor = |s: &bvp::Solution| s.eval(0.5)[0];
//! let out = pseudo_arclength(Bratu, 1.0, &start, monitor, &options, &mut |_| {}).unwrap();
//! assert_eq!(out.status, ArclengthStatus::ReachedStop);
//! assert!((out.folds[0].lambda - 3.513830719).abs() < 1e-6);
//! assert!(out.solution.eval(0.5)[0] > 4.0); // the upper solution at λ = 1
//! // `out.branch` holds (arclength, λ, y(1/2)) of every accepted point for a branch diagram.
//! ```
//!
//! # The augmented boundary value problem
//!
//! A point of the branch is `S = (y(·), p, λ)`: the state function `y: [a, b] → R^n`, the
//! `k` unknown parameters `p` of the family member and the continuation parameter `λ`. The
//! inner product used for lengths and angles is
//!
//! ```text
//! <S, T> = w_y/(b - a) ∫_a^b y_S(x)·y_T(x) dx  +  w_p p_S·p_T  +  λ_S λ_T,
//! w_y = 1/n,  w_p = 1/k  (fixed diagonal weights: state mean, parameter mean, λ).
//! ```
//!
//! Given the last two accepted points `S_{j-1}`, `S_j`, the secant tangent is
//! `τ = (S_j - S_{j-1}) / σ` with `σ = |S_j - S_{j-1}|`, i.e.
//! `τ_y(x) = (y_j(x) - y_{j-1}(x))/σ` from the two dense outputs. The next point `S` at
//! step `ds` solves the family's BVP together with Keller's pseudo-arclength condition
//! `<τ, S - S_j> = ds`. The integral in that condition becomes one extra state `z`:
//!
//! ```text
//! y' = f_λ(x, y, p)                                   (n equations, the member at λ)
//! z' = w_y τ_y(x)·(y - y_j(x))                        (1 equation)
//! g_λ(y(a), y(b), p) = 0                              (n + k conditions)
//! z(a) = 0
//! z(b)/(b - a) + w_p τ_p·(p - p_j) + τ_λ (λ - λ_j) - ds = 0
//! ```
//!
//! with unknowns `(y, z)` (`n + 1` states) and `(p, λ)` (`k + 1` parameters): `n + k + 2`
//! boundary conditions, a standard problem for [`bvp::solve`]. Its Jacobians are analytic in
//! the structural parts (`∂f/∂y` and `∂f/∂p` from the member's [`BvpProblem::jac`], the `z`
//! row `w_y τ_y(x)^T`, the two new boundary rows), with forward differences in `λ` (one extra
//! member `family(λ + h)`, `h = sqrt(eps)(1 + |λ|)`), and forward differences in `y`, `p`
//! where the member declines to give a Jacobian. The members at `λ` and `λ + h` are cached
//! while `λ` does not change (about two family constructions per Newton iteration), so the
//! family closure need not be cheap.
//!
//! # Predictor, corrector, step control
//!
//! 1. **First tangent.** One natural-parameter solve at `λ₀ ± initial_step` (sign
//!    [`ArclengthOptions::direction`]) gives a second point; the secant through the two is
//!    the first tangent (the step is cut by `shrink` on failure, like every step).
//! 2. **Predictor.** `S_j + ds τ`, sampled on the mesh of `S_j` (nodes and stages, through
//!    the dense outputs), with `z` predicted linearly.
//! 3. **Corrector.** A full BVP solve of the augmented problem (Newton with mesh
//!    adaptation). The solution is stripped back to the family's shape (`z` and `λ`
//!    removed): every point of the branch is a [`Solution`] of `family(λ)`.
//! 4. **Step control** (as AUTO, COCO, BifurcationKit): an easy step (at most `easy_newton`
//!    Newton iterations) grows `ds` by `grow` up to `max_step`, a hard one (more than
//!    `hard_newton`) shrinks it by 0.7, a failure or a secant that turns by more than
//!    `max_turn` radians against the previous one (a guard against branch jumping) cuts it by
//!    `shrink`; below `min_step` the continuation stops with
//!    [`ArclengthStatus::StepTooSmall`], keeping the last point.
//!
//! # Folds and stopping
//!
//! A fold lies between three accepted points `S_{j-1}, S_j, S_{j+1}` whose `λ` increments
//! change sign. It is reported as a [`Fold`] with the extreme `λ` seen, the vertex of the
//! parabola `λ(s)` through the three points (`s` = accumulated chord length, accurate to
//! `O(Δs³)`), and by default (`refine_folds`) a refined value: the arc between `S_{j-1}` and
//! `S_{j+1}` is parametrised by `t = <τ, S - S_{j-1}>` along the unit chord
//! `τ = (S_{j+1} - S_{j-1})/|S_{j+1} - S_{j-1}|` (each `t` is one augmented solve with the
//! same hyperplane condition as a step), and the extremum of `λ(t)` is located by
//! successive parabolic interpolation inside the bracket `(0, t_j, |S_{j+1} - S_{j-1}|)`
//! (at most [`MAX_FOLD_SOLVES`] solves). On Bratu's problem this gives the fold to 1e-10
//! with 9 solves. (An extended system for the fold itself, as in AUTO, would avoid the
//! iteration; the bracket search needs nothing beyond the step machinery.)
//!
//! The continuation stops when `λ` crosses [`lambda_stop`](ArclengthOptions::lambda_stop)
//! in either direction (the crossing is then solved exactly at `λ = lambda_stop` by one
//! fixed-`λ` solve from the guess interpolated linearly between the two points around it;
//! should that fail, e.g. with `lambda_stop` right next to a fold, the run ends with
//! [`ArclengthStatus::StopNotConverged`] at the point past it), after `max_steps`
//! corrector attempts or once the arclength exceeds `max_arclength`. Every accepted point
//! contributes a [`BranchPoint`] `(s, λ, monitor(solution))` for a branch diagram.
//!
//! # References
//!
//! * H. B. Keller, *Numerical solution of bifurcation and nonlinear eigenvalue problems*,
//!   in Applications of Bifurcation Theory, Academic Press, 1977 (pseudo-arclength).
//! * E. J. Doedel et al., *AUTO: software for continuation and bifurcation problems in
//!   ordinary differential equations* (the integral arclength condition for BVPs, step
//!   control).
//! * E. L. Allgower and K. Georg, *Numerical Continuation Methods: An Introduction*,
//!   Springer, 1990 (predictor–corrector methods, step length adaptation).

use std::cell::RefCell;

use crate::bvp::{self, estimate_bc_jac, estimate_fun_jac, BvpProblem, Guess, Solution, Status};

/// Options of [`pseudo_arclength`]. Steps are arclengths in the norm of the module docs.
#[derive(Debug, Clone)]
pub struct ArclengthOptions {
    /// First step: the `|λ|` step of the first (natural-parameter) solve, and the first
    /// arclength step (default 0.01).
    pub initial_step: f64,
    /// Smallest step before giving up (default 1e-6).
    pub min_step: f64,
    /// Largest step (default 0.2).
    pub max_step: f64,
    /// Cap on corrector attempts, the first step included (default 500).
    pub max_steps: usize,
    /// Stop once the accumulated arclength exceeds this (default: infinity).
    pub max_arclength: f64,
    /// Stop when `λ` crosses this value in either direction; the last point is then solved at
    /// exactly this value (default: None). A start at exactly this value does not count.
    pub lambda_stop: Option<f64>,
    /// Initial direction of `λ`: `+1.0` (default) or `-1.0`.
    pub direction: f64,
    /// Step growth after an easy step (default 1.6).
    pub grow: f64,
    /// Step reduction after a failed or rejected step (default 0.4).
    pub shrink: f64,
    /// A step with at most this many Newton iterations is "easy" (default 4).
    pub easy_newton: usize,
    /// A step with more than this many Newton iterations shrinks the next step (default 10).
    pub hard_newton: usize,
    /// Largest angle (radians) between consecutive secants before a step is rejected
    /// (default 0.5).
    pub max_turn: f64,
    /// Locate each fold to the accuracy of the BVP solves by a few extra augmented solves
    /// (default true); otherwise the fold is interpolated from the accepted points.
    pub refine_folds: bool,
    /// The BVP solver options of every corrector solve (a `scale` of length `n` is extended
    /// by 1 for the extra state `z`).
    pub bvp: bvp::Options,
}

impl Default for ArclengthOptions {
    fn default() -> Self {
        Self {
            initial_step: 0.01,
            min_step: 1e-6,
            max_step: 0.2,
            max_steps: 500,
            max_arclength: f64::INFINITY,
            lambda_stop: None,
            direction: 1.0,
            grow: 1.6,
            shrink: 0.4,
            easy_newton: 4,
            hard_newton: 10,
            max_turn: 0.5,
            refine_folds: true,
            bvp: bvp::Options::default(),
        }
    }
}

impl ArclengthOptions {
    fn validate(&self) -> Result<(), bvp::BvpError> {
        let check = |name, value: f64, ok: bool, expected| {
            if ok {
                Ok(())
            } else {
                Err(bvp::BvpError::InvalidOption {
                    name,
                    value,
                    expected,
                })
            }
        };
        let pos = |v: f64| v > 0.0 && v.is_finite();
        check(
            "initial_step",
            self.initial_step,
            pos(self.initial_step),
            "a finite number > 0",
        )?;
        check(
            "min_step",
            self.min_step,
            pos(self.min_step),
            "a finite number > 0",
        )?;
        check(
            "max_step",
            self.max_step,
            pos(self.max_step) && self.max_step >= self.min_step,
            "a finite number >= min_step",
        )?;
        check(
            "max_arclength",
            self.max_arclength,
            self.max_arclength > 0.0,
            "a number > 0 (infinity: no limit)",
        )?;
        check(
            "lambda_stop",
            self.lambda_stop.unwrap_or(0.0),
            self.lambda_stop.is_none_or(f64::is_finite),
            "a finite number",
        )?;
        check(
            "direction",
            self.direction,
            self.direction == 1.0 || self.direction == -1.0,
            "1 or -1",
        )?;
        check("grow", self.grow, self.grow >= 1.0, "a number >= 1")?;
        check(
            "shrink",
            self.shrink,
            self.shrink > 0.0 && self.shrink < 1.0,
            "a number in (0, 1)",
        )?;
        check(
            "max_turn",
            self.max_turn,
            self.max_turn > 0.0,
            "an angle > 0 (radians; >= pi disables the test)",
        )
    }
}

/// One corrector attempt of [`pseudo_arclength`].
#[derive(Debug, Clone, PartialEq)]
pub struct ArclengthStep {
    /// The step tried: an arclength, or for a fixed-`λ` solve the `λ` increment.
    pub ds: f64,
    /// `λ` of the result (accepted or not).
    pub lambda: f64,
    /// Whether the point was accepted. A converged `status` with `accepted == false` means
    /// the secant turned by more than [`ArclengthOptions::max_turn`].
    pub accepted: bool,
    /// The solver's status.
    pub status: Status,
    /// Newton iterations of this solve.
    pub newton_iterations: usize,
    /// Mesh nodes of the result.
    pub nodes: usize,
    /// True for a pseudo-arclength corrector, false for a fixed-`λ` solve (the first step
    /// and the final solve at `lambda_stop`).
    pub arclength: bool,
}

/// An accepted point of the branch, for branch diagrams.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BranchPoint {
    /// Accumulated arclength (sum of the chords `|S_j - S_{j-1}|`).
    pub arclength: f64,
    /// The continuation parameter.
    pub lambda: f64,
    /// The user's monitor functional of the solution.
    pub monitor: f64,
}

/// A fold (turning point) of `λ` along the branch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fold {
    /// Index in [`ArclengthOutcome::branch`] of the accepted point with the extreme `λ`.
    pub index: usize,
    /// `λ` at the fold: refined to the accuracy of the BVP solves if
    /// [`refined`](Self::refined), else the vertex of the parabola `λ(s)` through the three
    /// accepted points around the fold.
    pub lambda: f64,
    /// The extreme `λ` among the accepted points (`branch[index].lambda`).
    pub lambda_extreme: f64,
    /// Arclength of the fold (approximate).
    pub arclength: f64,
    /// The monitor at the refined fold, else at the extreme accepted point.
    pub monitor: f64,
    /// True at a maximum of `λ`, false at a minimum.
    pub maximum: bool,
    /// Whether the refinement improved on the accepted points (module docs).
    pub refined: bool,
    /// Augmented solves spent on the refinement (not reported as steps).
    pub refinement_solves: usize,
}

/// How [`pseudo_arclength`] ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArclengthStatus {
    /// `λ` crossed `lambda_stop`; the last point is at exactly `lambda_stop`.
    ReachedStop,
    /// The solve at exactly `lambda_stop` failed; the last point is the accepted one just
    /// past it.
    StopNotConverged {
        /// The status of that solve.
        last_failure: Status,
    },
    /// `max_steps` corrector attempts were made.
    MaxSteps,
    /// The accumulated arclength exceeds `max_arclength`.
    MaxArclength,
    /// The step fell below `min_step`.
    StepTooSmall {
        /// The status of the last failed corrector solve (`Converged` if the last rejection
        /// was by the turn-angle test).
        last_failure: Status,
    },
}

impl std::fmt::Display for ArclengthStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ArclengthStatus::ReachedStop => write!(f, "lambda reached the stop value"),
            ArclengthStatus::StopNotConverged { last_failure } => write!(
                f,
                "lambda crossed the stop value but the solve there failed: {}",
                last_failure.message()
            ),
            ArclengthStatus::MaxSteps => write!(f, "maximum number of steps reached"),
            ArclengthStatus::MaxArclength => write!(f, "maximum arclength reached"),
            // A converged corrector was rejected by the turn-angle test, not by the solver.
            ArclengthStatus::StepTooSmall { last_failure } if last_failure.is_success() => write!(
                f,
                "step size fell below the minimum (the last steps converged but turned the \
                 branch by more than max_turn: it bends too sharply to follow)"
            ),
            ArclengthStatus::StepTooSmall { last_failure } => write!(
                f,
                "step size fell below the minimum (last failure: {})",
                last_failure.message()
            ),
        }
    }
}

/// The result of [`pseudo_arclength`].
#[derive(Debug, Clone)]
pub struct ArclengthOutcome {
    /// How it ended.
    pub status: ArclengthStatus,
    /// `λ` of the last accepted point.
    pub lambda: f64,
    /// The last accepted point: a solution of `family(lambda)` (the family's `n` states and
    /// `k` parameters; its `stats` are those of the augmented solve).
    pub solution: Solution,
    /// Every accepted point in order, the start first. When `lambda_stop` is reached, the
    /// point past it is replaced by the point at exactly `lambda_stop`.
    pub branch: Vec<BranchPoint>,
    /// Folds passed, in order.
    pub folds: Vec<Fold>,
    /// Every corrector attempt, in order (fold refinements are counted in
    /// [`Fold::refinement_solves`] instead).
    pub records: Vec<ArclengthStep>,
}

impl ArclengthOutcome {
    /// Accepted steps (the start not counted).
    pub fn steps(&self) -> usize {
        self.records.iter().filter(|r| r.accepted).count()
    }
    /// Rejected attempts.
    pub fn failures(&self) -> usize {
        self.records.iter().filter(|r| !r.accepted).count()
    }
    /// Newton iterations over all attempts.
    pub fn newton_iterations(&self) -> usize {
        self.records.iter().map(|r| r.newton_iterations).sum()
    }
}

/// An accepted point: `λ` and a solution of `family(λ)`.
#[derive(Debug, Clone)]
struct Point {
    lambda: f64,
    sol: Solution,
}

/// Fixed weights of the inner product (module docs).
#[derive(Debug, Clone, Copy)]
struct Weights {
    wy: f64,
    wp: f64,
}

impl Weights {
    fn new(n: usize, k: usize) -> Self {
        Self {
            wy: 1.0 / n as f64,
            wp: 1.0 / k.max(1) as f64,
        }
    }

    /// `<A1 - A0, B1 - B0>`, the integral by 3-point Gauss–Legendre on the mesh of `b1`.
    fn inner_of_differences(&self, a1: &Point, a0: &Point, b1: &Point, b0: &Point) -> f64 {
        let n = b1.sol.n();
        let x = &b1.sol.x;
        let (a, b) = (x[0], x[x.len() - 1]);
        let g = (0.6f64).sqrt() / 2.0;
        let nodes = [
            (0.5 - g, 5.0 / 18.0),
            (0.5, 8.0 / 18.0),
            (0.5 + g, 5.0 / 18.0),
        ];
        let mut v = [vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        let mut integral = 0.0;
        for w in x.windows(2) {
            let h = w[1] - w[0];
            for &(c, wt) in &nodes {
                let t = w[0] + c * h;
                for (s, pt) in v.iter_mut().zip([a1, a0, b1, b0]) {
                    pt.sol.eval_into(t, s);
                }
                let dot: f64 = (0..n)
                    .map(|j| (v[0][j] - v[1][j]) * (v[2][j] - v[3][j]))
                    .sum();
                integral += wt * h * dot;
            }
        }
        let dp: f64 = (0..a1.sol.p.len())
            .map(|j| (a1.sol.p[j] - a0.sol.p[j]) * (b1.sol.p[j] - b0.sol.p[j]))
            .sum();
        self.wy * integral / (b - a)
            + self.wp * dp
            + (a1.lambda - a0.lambda) * (b1.lambda - b0.lambda)
    }
}

/// The hyperplane of the arclength condition: a base point `S_j` and the unit secant
/// direction `τ = (to - from) / σ`. A continuation step has `base = to = S_j`,
/// `from = S_{j-1}`; the fold refinement uses the chord across the fold from its first end.
#[derive(Clone)]
struct Secant<'a> {
    base: &'a Point,
    from: &'a Point,
    to: &'a Point,
    sigma: f64,
}

impl<'a> Secant<'a> {
    /// The continuation step from `cur`, with the secant through `prev` and `cur`.
    fn step(prev: &'a Point, cur: &'a Point, sigma: f64) -> Self {
        Self {
            base: cur,
            from: prev,
            to: cur,
            sigma,
        }
    }

    /// The base `y_j(x)` into `y` and `τ_y(x)` into `t` (both of length `n`).
    fn eval(&self, x: f64, y: &mut [f64], t: &mut [f64]) {
        self.to.sol.eval_into(x, y);
        self.from.sol.eval_into(x, t);
        for (tj, yj) in t.iter_mut().zip(y.iter()) {
            *tj = (yj - *tj) / self.sigma;
        }
        if !std::ptr::eq(self.base, self.to) {
            self.base.sol.eval_into(x, y);
        }
    }
    fn tau_p(&self, j: usize) -> f64 {
        (self.to.sol.p[j] - self.from.sol.p[j]) / self.sigma
    }
    fn tau_lambda(&self) -> f64 {
        (self.to.lambda - self.from.lambda) / self.sigma
    }
}

/// Scratch buffers of the augmented problem.
struct Scratch {
    y: Vec<f64>,
    t: Vec<f64>,
    f0: Vec<f64>,
    fh: Vec<f64>,
    jy: Vec<f64>,
    jp: Vec<f64>,
    work: Vec<f64>,
    g0: Vec<f64>,
    gh: Vec<f64>,
    dya: Vec<f64>,
    dyb: Vec<f64>,
    dp: Vec<f64>,
    bc_work: Vec<f64>,
}

impl Scratch {
    fn new(n: usize, k: usize) -> Self {
        let m = n + k;
        Self {
            y: vec![0.0; n],
            t: vec![0.0; n],
            f0: vec![0.0; n],
            fh: vec![0.0; n],
            jy: vec![0.0; n * n],
            jp: vec![0.0; n * k],
            work: vec![0.0; 2 * n + k],
            g0: vec![0.0; m],
            gh: vec![0.0; m],
            dya: vec![0.0; m * n],
            dyb: vec![0.0; m * n],
            dp: vec![0.0; m * k],
            bc_work: vec![0.0; 3 * n + 2 * k],
        }
    }
}

/// Members `family(λ)` built on demand and kept while used: two slots, so that the member
/// at `λ` and the shifted one at `λ + h` of a difference quotient (ours, or the solver's
/// when it differentiates the augmented problem itself) are both kept.
struct MemberCache<'a, P> {
    family: &'a dyn Fn(f64) -> P,
    /// The slots and the index of the most recently used one.
    slots: RefCell<([Slot<P>; 2], usize)>,
}

/// A member and its `λ`.
type Slot<P> = Option<(f64, P)>;

impl<'a, P> MemberCache<'a, P> {
    fn new(family: &'a dyn Fn(f64) -> P) -> Self {
        Self {
            family,
            slots: RefCell::new(([None, None], 0)),
        }
    }

    /// `g(family(lambda))`, building the member only if neither slot holds it.
    fn with<R>(&self, lambda: f64, g: impl FnOnce(&P) -> R) -> R {
        let mut cache = self.slots.borrow_mut();
        let (slots, recent) = &mut *cache;
        let hit = |s: &Slot<P>| {
            s.as_ref()
                .is_some_and(|(l, _)| l.to_bits() == lambda.to_bits())
        };
        let i = match (hit(&slots[*recent]), hit(&slots[1 - *recent])) {
            (true, _) => *recent,
            (false, true) => 1 - *recent,
            (false, false) => {
                let i = 1 - *recent;
                slots[i] = Some((lambda, (self.family)(lambda)));
                i
            }
        };
        *recent = i;
        g(&slots[i].as_ref().expect("hit or just filled").1)
    }
}

/// Forward-difference step in `λ`.
fn lambda_step(lambda: f64) -> f64 {
    let h = f64::EPSILON.sqrt() * (1.0 + lambda.abs());
    (lambda + h) - lambda
}

/// The augmented BVP of the module docs: states `(y, z)`, parameters `(p, λ)`.
struct Arclength<'a, P> {
    n: usize,
    k: usize,
    /// `b - a`.
    length: f64,
    weights: Weights,
    secant: Secant<'a>,
    ds: f64,
    members: MemberCache<'a, P>,
    scratch: RefCell<Scratch>,
}

impl<'a, P: BvpProblem> Arclength<'a, P> {
    fn new(family: &'a dyn Fn(f64) -> P, weights: Weights, secant: Secant<'a>, ds: f64) -> Self {
        let sol = &secant.base.sol;
        let (n, k) = (sol.n(), sol.k());
        Self {
            n,
            k,
            length: sol.x[sol.x.len() - 1] - sol.x[0],
            weights,
            secant,
            ds,
            members: MemberCache::new(family),
            scratch: RefCell::new(Scratch::new(n, k)),
        }
    }
}

impl<P: BvpProblem> BvpProblem for Arclength<'_, P> {
    fn n(&self) -> usize {
        self.n + 1
    }

    fn k(&self) -> usize {
        self.k + 1
    }

    fn f(&self, x: f64, y: &[f64], p: &[f64], dy: &mut [f64]) {
        let (n, k) = (self.n, self.k);
        self.members
            .with(p[k], |m| m.f(x, &y[..n], &p[..k], &mut dy[..n]));
        let mut s = self.scratch.borrow_mut();
        let Scratch { y: yj, t, .. } = &mut *s;
        self.secant.eval(x, yj, t);
        dy[n] = self.weights.wy * (0..n).map(|j| t[j] * (y[j] - yj[j])).sum::<f64>();
    }

    fn jac(&self, x: f64, y: &[f64], p: &[f64], dfdy: &mut [f64], dfdp: &mut [f64]) -> bool {
        let (n, k) = (self.n, self.k);
        let (na, ka) = (n + 1, k + 1);
        let lambda = p[k];
        let (ys, ps) = (&y[..n], &p[..k]);
        let mut s = self.scratch.borrow_mut();
        let s = &mut *s;
        self.members.with(lambda, |m| {
            m.f(x, ys, ps, &mut s.f0);
            if !m.jac(x, ys, ps, &mut s.jy, &mut s.jp) {
                estimate_fun_jac(m, x, ys, ps, &s.f0, &mut s.jy, &mut s.jp, &mut s.work);
            }
        });
        let h = lambda_step(lambda);
        self.members.with(lambda + h, |m| m.f(x, ys, ps, &mut s.fh));
        dfdy.fill(0.0);
        dfdp.fill(0.0);
        for i in 0..n {
            dfdy[i * na..i * na + n].copy_from_slice(&s.jy[i * n..(i + 1) * n]);
            dfdp[i * ka..i * ka + k].copy_from_slice(&s.jp[i * k..(i + 1) * k]);
            dfdp[i * ka + k] = (s.fh[i] - s.f0[i]) / h;
        }
        self.secant.eval(x, &mut s.y, &mut s.t);
        for j in 0..n {
            dfdy[n * na + j] = self.weights.wy * s.t[j];
        }
        true
    }

    fn bc(&self, ya: &[f64], yb: &[f64], p: &[f64], res: &mut [f64]) {
        let (n, k) = (self.n, self.k);
        self.members.with(p[k], |m| {
            m.bc(&ya[..n], &yb[..n], &p[..k], &mut res[..n + k]);
        });
        res[n + k] = ya[n];
        let base = self.secant.base;
        let dp: f64 = (0..k)
            .map(|j| self.secant.tau_p(j) * (p[j] - base.sol.p[j]))
            .sum();
        res[n + k + 1] = yb[n] / self.length
            + self.weights.wp * dp
            + self.secant.tau_lambda() * (p[k] - base.lambda)
            - self.ds;
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
        let (n, k) = (self.n, self.k);
        let (na, ka, m) = (n + 1, k + 1, n + k);
        let lambda = p[k];
        let (yas, ybs, ps) = (&ya[..n], &yb[..n], &p[..k]);
        let mut s = self.scratch.borrow_mut();
        let s = &mut *s;
        self.members.with(lambda, |g| {
            g.bc(yas, ybs, ps, &mut s.g0);
            if !g.bc_jac(yas, ybs, ps, &mut s.dya, &mut s.dyb, &mut s.dp) {
                estimate_bc_jac(
                    g,
                    yas,
                    ybs,
                    ps,
                    &s.g0,
                    &mut s.dya,
                    &mut s.dyb,
                    &mut s.dp,
                    &mut s.bc_work,
                );
            }
        });
        let h = lambda_step(lambda);
        self.members
            .with(lambda + h, |g| g.bc(yas, ybs, ps, &mut s.gh));
        dya.fill(0.0);
        dyb.fill(0.0);
        dp.fill(0.0);
        for i in 0..m {
            dya[i * na..i * na + n].copy_from_slice(&s.dya[i * n..(i + 1) * n]);
            dyb[i * na..i * na + n].copy_from_slice(&s.dyb[i * n..(i + 1) * n]);
            dp[i * ka..i * ka + k].copy_from_slice(&s.dp[i * k..(i + 1) * k]);
            dp[i * ka + k] = (s.gh[i] - s.g0[i]) / h;
        }
        dya[m * na + n] = 1.0;
        dyb[(m + 1) * na + n] = 1.0 / self.length;
        for j in 0..k {
            dp[(m + 1) * ka + j] = self.weights.wp * self.secant.tau_p(j);
        }
        dp[(m + 1) * ka + k] = self.secant.tau_lambda();
        true
    }
}

/// The augmented solution back in the family's shape: `z` and `λ` removed.
fn strip(sol: Solution, n: usize, k: usize) -> Point {
    let na = n + 1;
    let keep = |v: &[f64]| -> Vec<f64> {
        v.chunks_exact(na)
            .flat_map(|row| row[..n].iter().copied())
            .collect()
    };
    let lambda = sol.p[k];
    let sol = Solution {
        status: sol.status,
        y: keep(&sol.y),
        yp: keep(&sol.yp),
        p: sol.p[..k].to_vec(),
        stages: keep(&sol.stages),
        stage_f: keep(&sol.stage_f),
        n,
        k,
        x: sol.x,
        errors: sol.errors,
        residuals: sol.residuals,
        stats: sol.stats,
        tab: sol.tab,
    };
    Point { lambda, sol }
}

/// The predictor `S_j + ds τ` as a guess of the augmented problem on the mesh of `S_j`.
fn predict(secant: &Secant, weights: Weights, ds: f64) -> Guess {
    let cur = &secant.base.sol;
    let (n, k) = (cur.n(), cur.k());
    let x = &cur.x;
    let a = x[0];
    let mut p: Vec<f64> = (0..k).map(|j| cur.p[j] + ds * secant.tau_p(j)).collect();
    p.push(secant.base.lambda + ds * secant.tau_lambda());
    // The state part of |τ|² = 1, i.e. the predicted z(b)/(b - a) / ds.
    let tp2: f64 = (0..k).map(|j| secant.tau_p(j).powi(2)).sum();
    let state_part = (1.0 - weights.wp * tp2 - secant.tau_lambda().powi(2)).max(0.0);
    let mut t = vec![0.0; n];
    Guess::from_fn(x, n + 1, p, |xi, out| {
        secant.eval(xi, &mut out[..n], &mut t);
        for (o, tj) in out[..n].iter_mut().zip(&t) {
            *o += ds * tj;
        }
        out[n] = ds * state_part * (xi - a);
    })
}

/// The vertex `(t, λ)` of the parabola through three points, if it has one.
fn parabola_vertex(t: [f64; 3], l: [f64; 3]) -> Option<(f64, f64)> {
    let d01 = (l[1] - l[0]) / (t[1] - t[0]);
    let d12 = (l[2] - l[1]) / (t[2] - t[1]);
    let c = (d12 - d01) / (t[2] - t[0]);
    // λ(s) = λ1 + b (s - t1) + c (s - t1)^2, b the slope at t1.
    let b = d01 + c * (t[1] - t[0]);
    let h = -b / (2.0 * c);
    (c != 0.0 && h.is_finite()).then(|| (t[1] + h, l[1] + b * h + c * h * h))
}

/// Cap on the augmented solves that refine one fold.
pub const MAX_FOLD_SOLVES: usize = 12;

/// Options of the augmented solves: the `scale` extended for `z`.
fn augmented_options(options: &bvp::Options) -> bvp::Options {
    let mut o = options.clone();
    if let Some(s) = &mut o.scale {
        s.push(1.0);
    }
    o
}

/// Follow the branch of `family` through `(lambda0, start)` by pseudo-arclength
/// continuation, through folds, until `λ` crosses [`ArclengthOptions::lambda_stop`] or a
/// limit is met (see the [module docs](self)).
///
/// `start` must be a converged solution of `family(lambda0)`. `monitor` maps each accepted
/// solution (in the family's shape) to the scalar recorded in the branch diagram, e.g.
/// `|s| s.eval(0.5)[0]`. `on_step` is called after every corrector attempt.
///
/// Errors: invalid options, a `start` whose dimensions differ from `family(lambda0)`, or
/// invalid input to [`bvp::solve`].
pub fn pseudo_arclength<P, F, M>(
    family: F,
    lambda0: f64,
    start: &Solution,
    monitor: M,
    options: &ArclengthOptions,
    on_step: &mut dyn FnMut(&ArclengthStep),
) -> Result<ArclengthOutcome, bvp::BvpError>
where
    P: BvpProblem,
    F: Fn(f64) -> P,
    M: Fn(&Solution) -> f64,
{
    options.validate()?;
    let (n, k) = {
        let member = family(lambda0);
        (member.n(), member.k())
    };
    if start.n() != n {
        return Err(bvp::BvpError::DimensionMismatch {
            what: "start solution states",
            expected: n,
            found: start.n(),
        });
    }
    if start.k() != k {
        return Err(bvp::BvpError::DimensionMismatch {
            what: "start solution parameters",
            expected: k,
            found: start.k(),
        });
    }
    let family: &dyn Fn(f64) -> P = &family;
    let weights = Weights::new(n, k);
    let mut run = Run {
        family,
        monitor: &monitor,
        options,
        weights,
        aug_options: augmented_options(&options.bvp),
        on_step,
        records: Vec::new(),
        branch: vec![BranchPoint {
            arclength: 0.0,
            lambda: lambda0,
            monitor: monitor(start),
        }],
        folds: Vec::new(),
    };
    let first = Point {
        lambda: lambda0,
        sol: start.clone(),
    };

    // First step: a natural-parameter solve gives the second point and the first secant.
    let mut step = options.initial_step.min(options.max_step);
    let mut last_failure = Status::Converged;
    let second = loop {
        if run.records.len() >= options.max_steps {
            return Ok(run.finish(ArclengthStatus::MaxSteps, first));
        }
        if step < options.min_step {
            return Ok(run.finish(ArclengthStatus::StepTooSmall { last_failure }, first));
        }
        let lambda = lambda0 + options.direction * step;
        let sol = bvp::solve(&family(lambda), &Guess::from_solution(start), &options.bvp)?;
        let accepted = sol.is_success();
        run.record(step, lambda, &sol, accepted, false);
        if accepted {
            break Point { lambda, sol };
        }
        last_failure = sol.status;
        step *= options.shrink;
    };
    let sigma = weights
        .inner_of_differences(&second, &first, &second, &first)
        .sqrt();
    run.accept(&second, sigma);
    let mut cur = match run.check_stop(&first, second)? {
        Next::Continue(point) => point,
        Next::Done(end) => return Ok(end),
    };
    let mut prev = first;
    let mut sigma_prev = sigma;
    let mut arclength = sigma;
    let mut ds = step;

    loop {
        if run.records.len() >= options.max_steps {
            return Ok(run.finish(ArclengthStatus::MaxSteps, cur));
        }
        if arclength >= options.max_arclength {
            return Ok(run.finish(ArclengthStatus::MaxArclength, cur));
        }
        if ds < options.min_step {
            return Ok(run.finish(ArclengthStatus::StepTooSmall { last_failure }, cur));
        }
        let secant = Secant::step(&prev, &cur, sigma_prev);
        let guess = predict(&secant, weights, ds);
        let problem = Arclength::new(family, weights, secant, ds);
        let sol = bvp::solve(&problem, &guess, &run.aug_options)?;
        drop(problem);
        let converged = sol.is_success();
        let newton = sol.stats.newton_iterations;
        let next = strip(sol, n, k);
        let (accepted, sigma) = if converged {
            let sigma = weights
                .inner_of_differences(&next, &cur, &next, &cur)
                .sqrt();
            let cos = weights.inner_of_differences(&cur, &prev, &next, &cur) / (sigma_prev * sigma);
            (
                cos >= options.max_turn.min(std::f64::consts::PI).cos(),
                sigma,
            )
        } else {
            (false, 0.0)
        };
        run.record(ds, next.lambda, &next.sol, accepted, true);
        if !accepted {
            last_failure = next.sol.status;
            ds *= options.shrink;
            continue;
        }
        arclength += sigma;
        run.accept(&next, sigma);
        let (l0, l1, l2) = (prev.lambda, cur.lambda, next.lambda);
        if (l1 - l0) * (l2 - l1) < 0.0 {
            run.fold(&prev, &cur, &next)?;
        }
        match run.check_stop(&cur, next)? {
            Next::Continue(point) => prev = std::mem::replace(&mut cur, point),
            Next::Done(end) => return Ok(end),
        }
        sigma_prev = sigma;
        if newton <= options.easy_newton {
            ds = (ds * options.grow).min(options.max_step);
        } else if newton > options.hard_newton {
            ds *= 0.7;
        }
    }
}

/// What follows an accepted point.
enum Next {
    /// Go on from this point.
    Continue(Point),
    /// The run is over.
    Done(ArclengthOutcome),
}

/// The bookkeeping of one continuation run.
struct Run<'a, P> {
    family: &'a dyn Fn(f64) -> P,
    monitor: &'a dyn Fn(&Solution) -> f64,
    options: &'a ArclengthOptions,
    weights: Weights,
    aug_options: bvp::Options,
    on_step: &'a mut dyn FnMut(&ArclengthStep),
    records: Vec<ArclengthStep>,
    branch: Vec<BranchPoint>,
    folds: Vec<Fold>,
}

impl<P: BvpProblem> Run<'_, P> {
    fn record(&mut self, ds: f64, lambda: f64, sol: &Solution, accepted: bool, arclength: bool) {
        let record = ArclengthStep {
            ds,
            lambda,
            accepted,
            status: sol.status,
            newton_iterations: sol.stats.newton_iterations,
            nodes: sol.num_nodes(),
            arclength,
        };
        (self.on_step)(&record);
        self.records.push(record);
    }

    /// Append an accepted point at chord distance `sigma` from the previous one.
    fn accept(&mut self, point: &Point, sigma: f64) {
        let s = self.branch.last().map_or(0.0, |b| b.arclength) + sigma;
        self.branch.push(BranchPoint {
            arclength: s,
            lambda: point.lambda,
            monitor: (self.monitor)(&point.sol),
        });
    }

    /// Record the fold at `p1`, the second-to-last branch point, between `p0` and `p2`:
    /// the vertex of the parabola `λ(s)` through the three, then, if
    /// [`ArclengthOptions::refine_folds`], the refinement of [`Run::refine_fold`].
    fn fold(&mut self, p0: &Point, p1: &Point, p2: &Point) -> Result<(), bvp::BvpError> {
        let i = self.branch.len() - 2;
        let [b0, b1, b2] = [self.branch[i - 1], self.branch[i], self.branch[i + 1]];
        let maximum = p1.lambda > p0.lambda;
        let (arclength, lambda) = parabola_vertex(
            [b0.arclength, b1.arclength, b2.arclength],
            [b0.lambda, b1.lambda, b2.lambda],
        )
        .unwrap_or((b1.arclength, b1.lambda));
        let mut fold = Fold {
            index: i,
            lambda,
            lambda_extreme: p1.lambda,
            arclength,
            monitor: b1.monitor,
            maximum,
            refined: false,
            refinement_solves: 0,
        };
        if self.options.refine_folds {
            self.refine_fold(p0, p1, p2, &mut fold)?;
        }
        self.folds.push(fold);
        Ok(())
    }

    /// Locate the fold between `p0` and `p2` (extreme point `p1`) to the accuracy of the BVP
    /// solves: the branch between them is parametrised by `t = <τ, S - p0>` along the unit
    /// chord `τ = (p2 - p0)/|p2 - p0|` (each point one augmented solve), and the extremum of
    /// `λ(t)` is found by successive parabolic interpolation, keeping a bracket. Stops when
    /// `t` changes by less than `1e-7 |p2 - p0|`, after [`MAX_FOLD_SOLVES`] solves, or at the
    /// first failed solve (the fold then keeps the best value found).
    fn refine_fold(
        &mut self,
        p0: &Point,
        p1: &Point,
        p2: &Point,
        fold: &mut Fold,
    ) -> Result<(), bvp::BvpError> {
        let (n, k) = (p1.sol.n(), p1.sol.k());
        let sigma = self.weights.inner_of_differences(p2, p0, p2, p0).sqrt();
        let t1 = self.weights.inner_of_differences(p1, p0, p2, p0) / sigma;
        if !(t1 > 0.0 && t1 < sigma) {
            return Ok(());
        }
        let sign = if fold.maximum { 1.0 } else { -1.0 };
        // Bracket t_a < t_b < t_c with λ(t_b) the most extreme.
        let mut t = [0.0, t1, sigma];
        let mut l = [p0.lambda, p1.lambda, p2.lambda];
        let mut best: Option<Point> = None;
        let secant = Secant {
            base: p0,
            from: p0,
            to: p2,
            sigma,
        };
        while fold.refinement_solves < MAX_FOLD_SOLVES {
            let Some((tv, _)) = parabola_vertex(t, l) else {
                break;
            };
            if !(tv > t[0] && tv < t[2]) || (tv - t[1]).abs() < 1e-7 * sigma {
                break;
            }
            let guess = predict(&secant, self.weights, tv);
            let problem = Arclength::new(self.family, self.weights, secant.clone(), tv);
            let sol = bvp::solve(&problem, &guess, &self.aug_options)?;
            fold.refinement_solves += 1;
            if !sol.is_success() {
                break;
            }
            let point = strip(sol, n, k);
            let lv = point.lambda;
            let better = sign * (lv - l[1]) > 0.0;
            (t, l) = match (tv < t[1], better) {
                (true, true) => ([t[0], tv, t[1]], [l[0], lv, l[1]]),
                (true, false) => ([tv, t[1], t[2]], [lv, l[1], l[2]]),
                (false, true) => ([t[1], tv, t[2]], [l[1], lv, l[2]]),
                (false, false) => ([t[0], t[1], tv], [l[0], l[1], lv]),
            };
            if better {
                best = Some(point);
            }
        }
        if let Some(point) = best {
            fold.refined = true;
            fold.lambda = point.lambda;
            fold.monitor = (self.monitor)(&point.sol);
            let chord = self
                .weights
                .inner_of_differences(&point, p0, &point, p0)
                .sqrt();
            fold.arclength = self.branch[fold.index - 1].arclength + chord;
        }
        Ok(())
    }

    /// After accepting `next` (from `cur`): stop if `λ` crossed `lambda_stop` (solving there
    /// exactly), else continue from `next`.
    fn check_stop(&mut self, cur: &Point, next: Point) -> Result<Next, bvp::BvpError> {
        let Some(stop) = self.options.lambda_stop else {
            return Ok(Next::Continue(next));
        };
        let (d0, d1) = (cur.lambda - stop, next.lambda - stop);
        if d0 == 0.0 || (d1 != 0.0 && d0.signum() == d1.signum()) {
            return Ok(Next::Continue(next));
        }
        if d1 == 0.0 {
            return Ok(Next::Done(self.finish(ArclengthStatus::ReachedStop, next)));
        }
        let theta = d0 / (d0 - d1);
        let n = next.sol.n();
        let mut y0 = vec![0.0; n];
        let p: Vec<f64> = (0..next.sol.k())
            .map(|j| cur.sol.p[j] + theta * (next.sol.p[j] - cur.sol.p[j]))
            .collect();
        let guess = Guess::from_fn(&next.sol.x, n, p, |x, out| {
            next.sol.eval_into(x, out);
            cur.sol.eval_into(x, &mut y0);
            for (o, v) in out.iter_mut().zip(&y0) {
                *o = v + theta * (*o - v);
            }
        });
        let sol = bvp::solve(&(self.family)(stop), &guess, &self.options.bvp)?;
        let accepted = sol.is_success();
        self.record(stop - cur.lambda, stop, &sol, accepted, false);
        if !accepted {
            let status = ArclengthStatus::StopNotConverged {
                last_failure: sol.status,
            };
            return Ok(Next::Done(self.finish(status, next)));
        }
        // The exact point replaces `next` as the end of the branch.
        let point = Point { lambda: stop, sol };
        let before = self.branch[self.branch.len() - 2];
        let chord = self
            .weights
            .inner_of_differences(&point, cur, &point, cur)
            .sqrt();
        let last = self.branch.len() - 1;
        self.branch[last] = BranchPoint {
            arclength: before.arclength + chord,
            lambda: stop,
            monitor: (self.monitor)(&point.sol),
        };
        Ok(Next::Done(self.finish(ArclengthStatus::ReachedStop, point)))
    }

    fn finish(&mut self, status: ArclengthStatus, point: Point) -> ArclengthOutcome {
        ArclengthOutcome {
            status,
            lambda: point.lambda,
            solution: point.sol,
            branch: std::mem::take(&mut self.branch),
            folds: std::mem::take(&mut self.folds),
            records: std::mem::take(&mut self.records),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::continuation::{natural, ContinuationStatus, Options};

    /// Bratu: y'' + λ e^y = 0, y(0) = y(1) = 0, as y0' = y1, y1' = -λ e^y0. The branch from
    /// y = 0 at λ = 0 folds at λ* = 3.513830719 and comes back to λ -> 0 on the upper branch.
    /// `param`: also the unknown parameter p = y'(0) (a third condition y1(0) - p = 0), to
    /// exercise the parameter parts; `analytic`: provide Jacobians (else FD fallback).
    struct Bratu {
        lambda: f64,
        param: bool,
        analytic: bool,
    }

    const FOLD: f64 = 3.513830719;

    impl BvpProblem for Bratu {
        fn n(&self) -> usize {
            2
        }
        fn k(&self) -> usize {
            usize::from(self.param)
        }
        fn f(&self, _x: f64, y: &[f64], _p: &[f64], dy: &mut [f64]) {
            dy[0] = y[1];
            dy[1] = -self.lambda * y[0].exp();
        }
        fn jac(&self, _x: f64, y: &[f64], _p: &[f64], dfdy: &mut [f64], dfdp: &mut [f64]) -> bool {
            if !self.analytic {
                return false;
            }
            dfdy.copy_from_slice(&[0.0, 1.0, -self.lambda * y[0].exp(), 0.0]);
            dfdp.fill(0.0);
            true
        }
        fn bc(&self, ya: &[f64], yb: &[f64], p: &[f64], r: &mut [f64]) {
            r[0] = ya[0];
            r[1] = yb[0];
            if self.param {
                r[2] = ya[1] - p[0];
            }
        }
        fn bc_jac(
            &self,
            _ya: &[f64],
            _yb: &[f64],
            _p: &[f64],
            dya: &mut [f64],
            dyb: &mut [f64],
            dp: &mut [f64],
        ) -> bool {
            if !self.analytic {
                return false;
            }
            dya.fill(0.0);
            dyb.fill(0.0);
            dp.fill(0.0);
            let n = 2;
            dya[0] = 1.0;
            dyb[n] = 1.0;
            if self.param {
                dya[2 * n + 1] = 1.0;
                dp[2] = -1.0;
            }
            true
        }
    }

    fn family(param: bool, analytic: bool) -> impl Fn(f64) -> Bratu {
        move |lambda| Bratu {
            lambda,
            param,
            analytic,
        }
    }

    fn bvp_options() -> bvp::Options {
        bvp::Options {
            tol: 1e-8,
            max_newton_failures: 1,
            ..Default::default()
        }
    }

    fn lower_branch(lambda: f64, param: bool) -> Solution {
        let x: Vec<f64> = (0..=10).map(|i| i as f64 / 10.0).collect();
        let p = if param { vec![0.0] } else { vec![] };
        let guess = Guess::from_fn(&x, 2, p, |_, out| out.fill(0.0));
        let problem = family(param, true)(lambda);
        let sol = bvp::solve(&problem, &guess, &bvp_options()).expect("valid input");
        assert!(sol.is_success(), "{}", sol.status);
        sol
    }

    /// θ of the upper Bratu branch: the larger root of `θ = sqrt(2λ) cosh(θ/4)`, by Newton
    /// from the right (the function `θ - sqrt(2λ) cosh(θ/4)` is concave, so the iterates
    /// decrease monotonically to that root).
    fn upper_theta(lambda: f64) -> f64 {
        let c = (2.0 * lambda).sqrt();
        let mut theta: f64 = 30.0;
        for _ in 0..100 {
            let g = theta - c * (theta / 4.0).cosh();
            let dg = 1.0 - c * (theta / 4.0).sinh() / 4.0;
            theta -= g / dg;
        }
        assert!((theta - c * (theta / 4.0).cosh()).abs() < 1e-12);
        theta
    }

    /// The exact Bratu solution `(y, y')`, `y(x) = -2 ln(cosh((x - 1/2) θ/2) / cosh(θ/4))`, on
    /// the upper branch.
    fn upper_exact(lambda: f64) -> impl Fn(f64) -> [f64; 2] {
        let theta = upper_theta(lambda);
        move |x| {
            let u = (x - 0.5) * theta / 2.0;
            [
                -2.0 * (u.cosh() / (theta / 4.0).cosh()).ln(),
                -theta * u.tanh(),
            ]
        }
    }

    /// Largest error of `sol` against `exact` (values and derivatives) on 101 points.
    fn max_error(sol: &Solution, exact: &dyn Fn(f64) -> [f64; 2]) -> f64 {
        (0..=100)
            .map(|i| {
                let x = i as f64 / 100.0;
                let (y, e) = (sol.eval(x), exact(x));
                (y[0] - e[0])
                    .abs()
                    .max((y[1] - e[1]).abs() / (1.0 + e[1].abs()))
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn exact_upper_solution_helper_is_right() {
        // λ = 1: the roots are 1.5171646 (lower branch) and 10.9387028 (upper branch).
        let theta = upper_theta(1.0);
        assert!((theta - 10.938702772).abs() < 1e-8, "{theta}");
        let g = |t: f64| t - 2f64.sqrt() * (t / 4.0).cosh();
        assert!(g(1.5171646).abs() < 1e-6 && g(3.0) > 0.0);
        let exact = upper_exact(1.0);
        assert!(exact(0.0)[0].abs() < 1e-12 && exact(1.0)[0].abs() < 1e-12);
        // y'' = -λ e^y by central differences at x = 0.3.
        let (h, x) = (1e-4, 0.3);
        let ypp = (exact(x + h)[0] - 2.0 * exact(x)[0] + exact(x - h)[0]) / (h * h);
        assert!((ypp + exact(x)[0].exp()).abs() < 1e-4, "{ypp}");
    }

    #[test]
    fn augmented_jacobians_match_finite_differences() {
        for (param, analytic) in [(false, true), (false, false), (true, true), (true, false)] {
            let s0 = lower_branch(1.0, param);
            let s1 = lower_branch(1.3, param);
            let (p0, p1) = (
                Point {
                    lambda: 1.0,
                    sol: s0,
                },
                Point {
                    lambda: 1.3,
                    sol: s1,
                },
            );
            let k = usize::from(param);
            let weights = Weights::new(2, k);
            let sigma = weights.inner_of_differences(&p1, &p0, &p1, &p0).sqrt();
            let fam = family(param, analytic);
            let secant = Secant::step(&p0, &p1, sigma);
            let problem = Arclength::new(&fam, weights, secant, 0.1);
            let (na, ka) = (3, k + 1);
            let y = [0.3, 0.7, 0.05];
            let p: Vec<f64> = if param { vec![0.6, 1.7] } else { vec![1.7] };
            let mut f0 = vec![0.0; na];
            problem.f(0.37, &y, &p, &mut f0);
            let (mut jy, mut jp) = (vec![0.0; na * na], vec![0.0; na * ka]);
            assert!(problem.jac(0.37, &y, &p, &mut jy, &mut jp));
            let (mut ey, mut ep) = (jy.clone(), jp.clone());
            let mut work = vec![0.0; 2 * na + ka];
            estimate_fun_jac(&problem, 0.37, &y, &p, &f0, &mut ey, &mut ep, &mut work);
            for (a, e) in jy.iter().zip(&ey).chain(jp.iter().zip(&ep)) {
                assert!((a - e).abs() < 1e-6 * (1.0 + e.abs()), "{jy:?} {ey:?}");
            }
            let (ya, yb) = ([0.01, 0.9, 0.0], [-0.02, -0.8, 0.04]);
            let mb = na + ka;
            let mut g0 = vec![0.0; mb];
            problem.bc(&ya, &yb, &p, &mut g0);
            let (mut da, mut db, mut dp) =
                (vec![0.0; mb * na], vec![0.0; mb * na], vec![0.0; mb * ka]);
            assert!(problem.bc_jac(&ya, &yb, &p, &mut da, &mut db, &mut dp));
            let (mut ea, mut eb, mut ep) = (da.clone(), db.clone(), dp.clone());
            let mut work = vec![0.0; 3 * na + 2 * ka];
            estimate_bc_jac(
                &problem, &ya, &yb, &p, &g0, &mut ea, &mut eb, &mut ep, &mut work,
            );
            for (a, e) in da
                .iter()
                .zip(&ea)
                .chain(db.iter().zip(&eb))
                .chain(dp.iter().zip(&ep))
            {
                assert!((a - e).abs() < 1e-6 * (1.0 + e.abs()), "{da:?} {ea:?}");
            }
        }
    }

    fn arclength_options(lambda_stop: f64) -> ArclengthOptions {
        ArclengthOptions {
            initial_step: 0.05,
            max_step: 0.25,
            lambda_stop: Some(lambda_stop),
            bvp: bvp_options(),
            ..Default::default()
        }
    }

    /// Around the fold from λ = 1 on the lower branch back to λ = 1 on the upper one.
    fn around_the_fold(param: bool, analytic: bool) {
        let start = lower_branch(1.0, param);
        let mut calls = 0;
        let out = pseudo_arclength(
            family(param, analytic),
            1.0,
            &start,
            |s| s.eval(0.5)[0],
            &arclength_options(1.0),
            &mut |_| calls += 1,
        )
        .expect("valid input");
        assert_eq!(out.status, ArclengthStatus::ReachedStop, "{}", out.status);
        assert_eq!(calls, out.records.len());
        assert_eq!(out.lambda, 1.0);
        // A fixed-λ first step, then arclength steps, then the fixed-λ solve at λ = 1.
        let last = out.records.last().expect("records");
        assert!(!out.records[0].arclength && !last.arclength && last.lambda == 1.0);
        assert!(out.records[1..out.records.len() - 1]
            .iter()
            .all(|r| r.arclength));
        assert_eq!(out.folds.len(), 1, "{:?}", out.folds);
        let fold = out.folds[0];
        assert!(fold.maximum);
        assert!(fold.refined, "{fold:?}");
        assert!((fold.lambda - FOLD).abs() < 1e-6, "{fold:?}");
        assert!((fold.lambda_extreme - FOLD).abs() < 1e-3, "{fold:?}");
        assert!(fold.lambda_extreme <= FOLD + 1e-9 && fold.lambda >= fold.lambda_extreme);
        // The monitor y(1/2) grows monotonically along the branch.
        assert!(out.branch.windows(2).all(|w| w[1].monitor > w[0].monitor));
        assert!(out
            .branch
            .windows(2)
            .all(|w| w[1].arclength > w[0].arclength));
        let sol = &out.solution;
        assert!(sol.is_success());
        assert_eq!((sol.n(), sol.k()), (2, usize::from(param)));
        let exact = upper_exact(1.0);
        let err = max_error(sol, &exact);
        assert!(err < 1e-6, "max error {err:e}");
        assert!((out.branch.last().expect("points").monitor - exact(0.5)[0]).abs() < 1e-6);
        if param {
            assert!((sol.p[0] - exact(0.0)[1]).abs() < 1e-6);
        }
        eprintln!(
            "param {param} analytic {analytic}: fold {:.10} (extreme {:.10}), upper error {err:.2e}, \
             {} steps, {} failures, {} Newton, {} points",
            fold.lambda,
            fold.lambda_extreme,
            out.steps(),
            out.failures(),
            out.newton_iterations(),
            out.branch.len()
        );
    }

    #[test]
    fn passes_the_bratu_fold_and_lands_on_the_exact_upper_branch() {
        around_the_fold(false, true);
    }

    #[test]
    fn passes_the_fold_with_finite_difference_jacobians_and_a_parameter() {
        around_the_fold(true, false);
    }

    #[test]
    fn fold_without_refinement_is_the_parabola_through_the_accepted_points() {
        let start = lower_branch(1.0, false);
        let out = pseudo_arclength(
            family(false, true),
            1.0,
            &start,
            |s| s.eval(0.5)[0],
            &ArclengthOptions {
                refine_folds: false,
                ..arclength_options(1.0)
            },
            &mut |_| {},
        )
        .expect("valid input");
        assert_eq!(out.status, ArclengthStatus::ReachedStop);
        assert_eq!(out.folds.len(), 1);
        let fold = out.folds[0];
        assert!(!fold.refined && fold.refinement_solves == 0);
        assert!((fold.lambda - FOLD).abs() < 1e-3, "{fold:?}");
        assert!(fold.lambda >= fold.lambda_extreme);
        let b = &out.branch;
        assert_eq!(fold.lambda_extreme, b[fold.index].lambda);
        assert!(b[fold.index - 1].lambda < fold.lambda_extreme);
        assert!(b[fold.index + 1].lambda < fold.lambda_extreme);
        assert_eq!(fold.monitor, b[fold.index].monitor);
        assert!(fold.arclength > b[fold.index - 1].arclength);
        assert!(fold.arclength < b[fold.index + 1].arclength);
    }

    #[test]
    fn family_members_are_cached() {
        let start = lower_branch(1.0, false);
        let built = std::cell::Cell::new(0usize);
        let counting = |lambda| {
            built.set(built.get() + 1);
            family(false, true)(lambda)
        };
        let out = pseudo_arclength(
            counting,
            1.0,
            &start,
            |s| s.eval(0.5)[0],
            &arclength_options(1.0),
            &mut |_| {},
        )
        .expect("valid input");
        assert_eq!(out.status, ArclengthStatus::ReachedStop);
        let newton = out.newton_iterations() + out.folds[0].refinement_solves * 8;
        eprintln!(
            "{} members built, {} Newton iterations",
            built.get(),
            out.newton_iterations()
        );
        assert!(built.get() <= 3 * newton, "{} > 3 * {newton}", built.get());
    }

    #[test]
    fn natural_continuation_stops_at_the_fold_where_arclength_passes_it() {
        let start = lower_branch(1.0, false);
        let opts = Options {
            bvp: bvp_options(),
            min_step: Some(1e-4),
            ..Default::default()
        };
        let stuck = natural(family(false, true), 1.0, 4.0, &start, &opts, &mut |_| {})
            .expect("valid input");
        let reached = match stuck.status {
            ContinuationStatus::StepTooSmall { reached, .. } => reached,
            other => panic!("expected a stop before the fold, got {other}"),
        };
        assert!(reached < FOLD && reached > FOLD - 0.05, "{reached}");
        // From natural's last point, pseudo-arclength turns round and reaches λ = 3 on the
        // upper branch.
        let out = pseudo_arclength(
            family(false, true),
            reached,
            &stuck.solution,
            |s| s.eval(0.5)[0],
            &arclength_options(3.0),
            &mut |_| {},
        )
        .expect("valid input");
        assert_eq!(out.status, ArclengthStatus::ReachedStop, "{}", out.status);
        assert_eq!(out.lambda, 3.0);
        assert_eq!(out.folds.len(), 1);
        let err = max_error(&out.solution, &upper_exact(3.0));
        assert!(err < 1e-6, "max error {err:e}");
        eprintln!(
            "natural stopped at {reached:.6}; arclength: fold {:.10}, error at λ = 3 {err:.2e}, \
             {} steps",
            out.folds[0].lambda,
            out.steps()
        );
    }

    /// Bratu, except that the member at exactly `λ = 2` returns NaN.
    struct Poisoned(Bratu);

    impl BvpProblem for Poisoned {
        fn n(&self) -> usize {
            2
        }
        fn f(&self, x: f64, y: &[f64], p: &[f64], dy: &mut [f64]) {
            self.0.f(x, y, p, dy);
            if self.0.lambda == 2.0 {
                dy[1] = f64::NAN;
            }
        }
        fn bc(&self, ya: &[f64], yb: &[f64], p: &[f64], r: &mut [f64]) {
            self.0.bc(ya, yb, p, r);
        }
    }

    #[test]
    fn a_failed_solve_at_lambda_stop_keeps_the_point_past_it() {
        let start = lower_branch(1.0, false);
        let out = pseudo_arclength(
            |lambda| Poisoned(family(false, true)(lambda)),
            1.0,
            &start,
            |s| s.eval(0.5)[0],
            &arclength_options(2.0),
            &mut |_| {},
        )
        .expect("valid input");
        assert_eq!(
            out.status,
            ArclengthStatus::StopNotConverged {
                last_failure: Status::NonFinite
            }
        );
        assert!(out.lambda > 2.0 && out.solution.is_success());
        assert_eq!(out.branch.last().expect("points").lambda, out.lambda);
        let last = out.records.last().expect("records");
        assert!(!last.accepted && !last.arclength && last.lambda == 2.0);
    }

    #[test]
    fn limits_and_invalid_input() {
        let start = lower_branch(1.0, false);
        let run = |options: &ArclengthOptions| {
            pseudo_arclength(
                family(false, true),
                1.0,
                &start,
                |s| s.eval(0.5)[0],
                options,
                &mut |_| {},
            )
        };
        let capped = run(&ArclengthOptions {
            max_steps: 4,
            ..arclength_options(1.0)
        })
        .expect("valid");
        assert_eq!(capped.status, ArclengthStatus::MaxSteps);
        assert_eq!(capped.records.len(), 4);
        assert_eq!(capped.branch.len(), capped.steps() + 1);
        assert!(capped.solution.is_success());
        let short = run(&ArclengthOptions {
            max_arclength: 0.3,
            lambda_stop: None,
            ..arclength_options(1.0)
        })
        .expect("valid");
        assert_eq!(short.status, ArclengthStatus::MaxArclength);
        let s = short.branch.last().expect("points").arclength;
        assert!((0.3..0.9).contains(&s), "{s}");
        // A turn limit no secant can meet: every arclength step is rejected although its
        // corrector converged, until the step is too small.
        let stiff = run(&ArclengthOptions {
            max_turn: 1e-9,
            ..arclength_options(1.0)
        })
        .expect("valid");
        assert_eq!(
            stiff.status,
            ArclengthStatus::StepTooSmall {
                last_failure: Status::Converged
            }
        );
        // Its message names the turn-angle test, not a "converged" failure.
        let msg = stiff.status.to_string();
        assert!(
            msg.contains("turned the branch by more than max_turn"),
            "{msg}"
        );
        assert!(!msg.contains("converged to the desired accuracy"), "{msg}");
        assert_eq!(stiff.steps(), 1);
        assert!(stiff.records[1..]
            .iter()
            .all(|r| r.arclength && !r.accepted && r.status.is_success()));
        assert_eq!(stiff.branch.len(), 2);
        // Downwards from λ = 1 the branch reaches λ = 0.5 without a fold.
        let down = run(&ArclengthOptions {
            direction: -1.0,
            ..arclength_options(0.5)
        })
        .expect("valid");
        assert_eq!(down.status, ArclengthStatus::ReachedStop);
        assert_eq!(down.lambda, 0.5);
        assert!(down.folds.is_empty());
        assert!(down.branch.windows(2).all(|w| w[1].lambda < w[0].lambda));
        for bad in [
            ArclengthOptions {
                direction: 0.0,
                ..Default::default()
            },
            ArclengthOptions {
                min_step: 1.0,
                max_step: 0.1,
                ..Default::default()
            },
            ArclengthOptions {
                lambda_stop: Some(f64::NAN),
                ..Default::default()
            },
        ] {
            assert!(matches!(
                run(&bad),
                Err(bvp::BvpError::InvalidOption { .. })
            ));
        }
        let wrong = pseudo_arclength(
            family(true, true),
            1.0,
            &start,
            |s| s.eval(0.5)[0],
            &ArclengthOptions::default(),
            &mut |_| {},
        );
        assert!(matches!(
            wrong,
            Err(bvp::BvpError::DimensionMismatch { .. })
        ));
    }
}
