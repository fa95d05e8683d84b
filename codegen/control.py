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

import sympy as sp

import derive as D


def lie_bracket(a, b, x):
    """[a, b] = (Db) a - (Da) b for column vector fields a, b on the coordinates x."""
    return (b.jacobian(x) * a - a.jacobian(x) * b).applyfunc(sp.cancel)


def _zero(e):
    return sp.cancel(sp.together(e)) == 0


def _check(cond, what):
    if not cond:
        raise AssertionError(f"controllability structure check failed: {what}")


class AffineSystem:
    """Drift f, control fields g_i and the brackets [g_i, g_j] of Suslov's pure equations."""

    def __init__(self, suslov):
        s = suslov
        M = self.M = s.M
        n = M.n
        self.X = X = list(M.Om) + list(M.xi)
        self.U = U = list(M.xiDot)
        self.PAIRS = list(itertools.combinations(range(n), 2))
        self.suslov = s
        xdot = sp.Matrix(list(s.omega_dot) + U)  # x_dot(x, u) with u = xi_dot
        G = xdot.jacobian(U).applyfunc(sp.cancel)  # 2n x n, columns g_i
        _check(not (set().union(*[e.free_symbols for e in G]) & set(U)),
               "d x_dot / d u depends on u (not control-affine)")
        f = xdot.subs({v: 0 for v in U}).applyfunc(sp.cancel)
        _check(all(_zero(e) for e in xdot - f - G * sp.Matrix(U)),
               "x_dot != f + sum g_i u_i")
        self.f = f
        self.g = [G[:, i] for i in range(n)]
        self.brackets = [lie_bracket(self.g[i], self.g[j], X) for i, j in self.PAIRS]

        # -- structure checks (I^-1 replaced by the inverse of the inertia) -----------------
        inv = M.inverse_substitution()
        phi = M.constraint(M.Om, M.xi)
        energy = M.body_lagrangian(M.Om)
        dphi = sp.Matrix([phi]).jacobian(X)
        dE = sp.Matrix([energy]).jacobian(X)
        gamma_zero = M.constraint_value(M.xi) == 0
        # M: <Om, xi> = gamma(xi), solved for Om_1.
        on_m = {M.Om[0]: (M.constraint_value(M.xi)
                          - sum(M.Om[i] * M.xi[i] for i in range(1, n))) / M.xi[0]}
        fields = [("f", f)] + [(f"g{i + 1}", g) for i, g in enumerate(self.g)] \
            + [(f"[g{i + 1},g{j + 1}]", b) for (i, j), b in zip(self.PAIRS, self.brackets)]
        for name, v in fields:
            v = v.subs(inv)
            _check(_zero((dphi * v)[0, 0]), f"d phi({name}) != 0")
            if gamma_zero:
                _check(_zero((dE * v)[0, 0].subs(on_m)), f"d energy({name}) != 0 on M")
        for b in self.brackets:
            _check(all(e == 0 for e in b[n:]), "brackets have xi-components")
        self.spherical_symbol = c = sp.Symbol("c", positive=True)
        self.spherical = None
        ad_invariant = all((M.algebra.ad(e) + M.algebra.ad(e).T).is_zero_matrix
                           for e in sp.eye(n).columnspace())
        if ad_invariant:
            params = [p.symbol for p in M.inertia_params]
            sol = sp.solve(list(M.INERTIA - c * sp.eye(n)), params, dict=True)
            if sol:
                self.spherical = sol[0]
                sph = dict(sol[0])
                _check(all(_zero(e.subs(inv).subs(sph)) for e in f),
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
