"""Controllability of Suslov's pure equations (paper section 4.3, sec_controllability).

For a model with an n-dimensional algebra, the state is x = [Omega, xi] in R^2n and the control
is u = xi_dot. Suslov's pure equations
(derive.Suslov) give Omega_dot = F(Omega, xi, xi_dot); with xi_dot = u the system is

    x_dot = f(x) + sum_i g_i(x) u_i,

and it is *derived* here, not transcribed:

* g_i = d x_dot / d u_i (a Jacobian of F with respect to xi_dot, plus e_i for xi_dot = u);
* affinity is checked symbolically: the Jacobian does not depend on u, and
  x_dot - f - sum g_i u_i simplifies to zero, with f = x_dot at u = 0;
* the Lie brackets [g_i, g_j] = (Dg_j) g_i - (Dg_i) g_j (i < j), by sympy Jacobians in R^2n.

Generation-time structure checks (they raise if the model changes and breaks them):
every field annihilates d phi, phi = <Omega, xi> - gamma(xi), identically (the constraint level
is invariant in R^2n); for gamma = 0, d(1/2 <I Omega, Omega>) applied to each field vanishes on
M = {phi = 0} (energy is conserved on M only); the xi-components of the brackets vanish; and
when the Euclidean metric is ad-invariant (ad_X antisymmetric, e.g. so(3), so(4)) and the
inertia can be spherical, I = c Id, then f = 0 there.

The paper's printed formulas (eqs. state_f, state_gi, the bracket and eqs. Veqn/Aeqn) are
compared in codegen/tests/test_control.py, not used here.
"""

import itertools
import random

import mpmath
import sympy as sp

import derive as D
from slp import Program, diff


def lie_bracket(a, b, x):
    """[a, b] = (Db) a - (Da) b for column vector fields a, b on the coordinates x."""
    return (b.jacobian(x) * a - a.jacobian(x) * b).applyfunc(sp.cancel)


def _zero(e):
    return sp.cancel(sp.together(e)) == 0


def _check(cond, what):
    if not cond:
        raise AssertionError(f"controllability structure check failed: {what}")


class AffineSystem:
    """Drift f, control fields g_i and the brackets [g_i, g_j] of Suslov's pure equations.

    `f` and `g` are sympy expressions (x_dot = f + G u with lambda substituted, not
    simplified); `program()` builds the straight-line program the generator emits, in which
    the brackets are forward-mode Jacobians through the program (no symbolic rational-function
    arithmetic, so a 6-dimensional algebra derives in seconds); `brackets` is the symbolic
    version, computed on demand (tests of the so(3) case against the paper). The structure
    checks run on the program at seeded points in 40-digit arithmetic.
    """

    def __init__(self, suslov, check_points=3, seed=11):
        s = suslov
        M = self.M = s.M
        n = M.n
        self.X = list(M.Om) + list(M.xi)
        self.U = U = list(M.xiDot)
        self.PAIRS = list(itertools.combinations(range(n), 2))
        self.suslov = s
        omdot = s.omdot_of_lam.subs(s.lam_symbol, s.lam)
        xdot = sp.Matrix(list(omdot) + U)  # x_dot(x, u) with u = xi_dot
        G = D.jacobian(xdot, U)  # 2n x n, columns g_i
        _check(not (set().union(*[e.free_symbols for e in G]) & set(U)),
               "d x_dot / d u depends on u (not control-affine)")
        self.f = xdot.subs({v: 0 for v in U})
        self.g = [G[:, i] for i in range(n)]
        self._brackets = None
        self._program = None
        self._check(check_points, seed)

    @property
    def brackets(self):
        """[g_i, g_j] (i < j) as cancelled sympy expressions (slow for large n)."""
        if self._brackets is None:
            g = [v.applyfunc(sp.cancel) for v in self.g]
            self._brackets = [lie_bracket(g[i], g[j], self.X) for i, j in self.PAIRS]
        return self._brackets

    def program(self):
        """(program over x, rows f, g_1..g_n as lists, brackets as lists), for emission;
        built once (the structure checks and the generator use the same program)."""
        if self._program is None:
            self._program = self._build_program()
        return self._program

    def _build_program(self):
        M, n = self.M, self.M.n
        prog = Program(self.X, M.PARAMS)
        om_u = {v: 0 for v in self.U}
        lam0 = prog.let("lam", self.suslov.lam.subs(om_u))  # lambda at u = 0
        dlam = prog.let("dlam", sp.Matrix([diff(self.suslov.lam, v) for v in self.U]))
        # Om_dot = I^-1 (ad*_Om I Om + lambda xi) is affine in lambda, lambda affine in u.
        om = self.suslov.omdot_of_lam
        f_om = prog.let("fom", om.subs(self.suslov.lam_symbol, lam0))
        dom = om.diff(self.suslov.lam_symbol)  # I^-1 xi
        f = list(f_om) + [0] * n
        g = []
        for i in range(n):
            gi = prog.let(f"g{i + 1}_", dom * dlam[i])
            g.append(list(gi) + [1 if k == i else 0 for k in range(n)])
        # Dg_i (2n x 2n) through the program; [g_i, g_j] = Dg_j g_i - Dg_i g_j.
        flat = [e for gi in g for e in gi[:n]]
        J = prog.jacobian(flat, self.X, prefix="dg")
        Dg = [sp.Matrix.vstack(J[i * n:(i + 1) * n, :], sp.zeros(n, 2 * n)) for i in range(n)]
        br = []
        for i, j in self.PAIRS:
            gi, gj = sp.Matrix(g[i]), sp.Matrix(g[j])
            br.append(list(Dg[j] * gi - Dg[i] * gj))
        return prog, [f] + g, br

    def _check(self, points, seed):
        M, n = self.M, self.M.n
        prog, rows, br = self.program()
        fields = rows + br
        names = ["f"] + [f"g{i + 1}" for i in range(n)] \
            + [f"[g{i + 1},g{j + 1}]" for i, j in self.PAIRS]
        phi = M.constraint(M.Om, M.xi)
        dphi = sp.Matrix([phi]).jacobian(self.X)
        dE = sp.Matrix([M.body_lagrangian(M.Om)]).jacobian(self.X)
        gamma_zero = M.constraint_value(M.xi) == 0
        outs = [(dphi * sp.Matrix(v))[0, 0] for v in fields] \
            + [(dE * sp.Matrix(v))[0, 0] for v in fields] \
            + [e for v in br for e in v[n:]] + [e for v in fields for e in v]
        run = prog.evaluator(outs)
        rng = random.Random(seed)
        tol = mpmath.mpf(10) ** -25
        nf = len(fields)
        for _ in range(points):
            vals = _sample_params(M, rng)
            for s in self.X:
                vals[s] = rng.uniform(-2, 2)
            if gamma_zero:  # put the point on M: <Om, xi> = 0, solved for Om_1 (50 digits)
                with mpmath.workdps(50):
                    vals[M.Om[0]] = -sum(mpmath.mpf(vals[M.Om[i]]) * vals[M.xi[i]]
                                         for i in range(1, n)) / mpmath.mpf(vals[M.xi[0]])
            out = run(vals)
            scale = 1 + max(abs(v) for v in out[-nf * 2 * n:])
            for k, name in enumerate(names):
                _check(abs(out[k]) <= tol * scale, f"d phi({name}) != 0")
                if gamma_zero:
                    _check(abs(out[nf + k]) <= tol * scale, f"d energy({name}) != 0 on M")
            _check(all(abs(v) <= tol * scale for v in out[2 * nf:2 * nf + len(br) * n]),
                   "brackets have xi-components")
        # Spherical bodies are driftless when the Euclidean metric is ad-invariant.
        self.spherical = None
        ad_invariant = all((M.algebra.ad(e) + M.algebra.ad(e).T).is_zero_matrix
                           for e in sp.eye(n).columnspace())
        if ad_invariant:
            c = sp.Symbol("c", positive=True)
            params = [p.symbol for p in M.inertia_params]
            sol = sp.solve(list(M.INERTIA - c * sp.eye(n)), params, dict=True)
            if sol:
                self.spherical = sol[0]
                inv = M.inverse_substitution()
                _check(all(_zero(e.subs(inv).subs(sol[0])) for e in self.f),
                       "f != 0 for a spherical body")

    def fields_matrix(self):
        """(n + 1) x 2n: rows f, g1, ..., gn."""
        return sp.Matrix.vstack(self.f.T, *[g.T for g in self.g])

    def brackets_matrix(self):
        """n(n-1)/2 x 2n: rows [g_i, g_j] for i < j in lexicographic order."""
        return sp.Matrix.vstack(*[b.T for b in self.brackets])

    def accessibility_columns(self):
        """V = [g_1 .. g_n, [g_i, g_j] (i < j)] (paper eq. Veqn for so(3))."""
        return sp.Matrix.hstack(*self.g, *self.brackets)


def _sample_params(M, rng):
    """Seeded parameter values (derived I^-1 entries consistent with the inertia)."""
    vals = {p.symbol: rng.uniform(*M.sample_range(p)) for p in M.user_params}
    if M.derived:
        with mpmath.workdps(50):
            exact = M.INERTIA.subs({k: sp.Rational(v) for k, v in vals.items()})
            mat = mpmath.matrix([[mpmath.mpf(e.p) / e.q for e in row] for row in exact.tolist()])
            inv = mpmath.inverse(mat)
            for s, (i, j) in M.derived:
                vals[s] = inv[i, j]
    return vals
