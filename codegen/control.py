"""Controllability of Suslov's pure equations (paper section 4.3, sec_controllability).

The state is x = [Omega, xi] in R^6 and the control is u = xi_dot. Suslov's pure equations
(derive.Suslov) give Omega_dot = F(Omega, xi, xi_dot); with xi_dot = u the system is

    x_dot = f(x) + sum_i g_i(x) u_i,

and it is *derived* here, not transcribed:

* g_i = d x_dot / d u_i (a Jacobian of F with respect to xi_dot, plus e_i for xi_dot = u);
* affinity is checked symbolically: the Jacobian does not depend on u, and
  x_dot - f - sum g_i u_i simplifies to zero, with f = x_dot at u = 0;
* the Lie brackets [g_i, g_j] = (Dg_j) g_i - (Dg_i) g_j, by sympy Jacobians in R^6.

Generation-time structure checks (they raise if the model changes and breaks them):
every field annihilates d<Omega, xi> identically (the constraint level is invariant in R^6),
d(1/2 <I Omega, Omega>) applied to each field is a multiple of <Omega, xi> (energy is conserved
on M only), the xi-components of the brackets vanish, and f = 0 for I = c Id.

The paper's printed formulas (eqs. state_f, state_gi, the bracket and eqs. Veqn/Aeqn) are
compared in codegen/tests/test_control.py, not used here.
"""

import sympy as sp

import derive as D
import model as M

X = list(M.Om) + list(M.xi)
U = list(M.xiDot)


def lie_bracket(a, b, x=X):
    """[a, b] = (Db) a - (Da) b for column vector fields a, b on the coordinates x."""
    return (b.jacobian(x) * a - a.jacobian(x) * b).applyfunc(sp.cancel)


def _zero(e):
    return sp.cancel(sp.together(e)) == 0


def _check(cond, what):
    if not cond:
        raise AssertionError(f"controllability structure check failed: {what}")


class AffineSystem:
    """Drift f, control fields g_i and the brackets [g_i, g_j] of Suslov's pure equations."""

    PAIRS = [(0, 1), (0, 2), (1, 2)]

    def __init__(self, suslov=None):
        s = suslov or D.Suslov()
        self.suslov = s
        xdot = sp.Matrix(list(s.omega_dot) + U)  # x_dot(x, u) with u = xi_dot
        G = xdot.jacobian(U).applyfunc(sp.cancel)  # 6 x 3, columns g_i
        _check(not (set().union(*[e.free_symbols for e in G]) & set(U)),
               "d x_dot / d u depends on u (not control-affine)")
        f = xdot.subs({v: 0 for v in U}).applyfunc(sp.cancel)
        _check(all(_zero(e) for e in xdot - f - G * sp.Matrix(U)),
               "x_dot != f + sum g_i u_i")
        self.f = f
        self.g = [G[:, i] for i in range(3)]
        self.brackets = [lie_bracket(self.g[i], self.g[j]) for i, j in self.PAIRS]

        # -- structure checks ------------------------------------------------------------
        phi = M.constraint(M.Om, M.xi)
        energy = M.body_lagrangian(M.Om)
        dphi = sp.Matrix([phi]).jacobian(X)
        dE = sp.Matrix([energy]).jacobian(X)
        for name, v in [("f", f)] + [(f"g{i + 1}", g) for i, g in enumerate(self.g)] \
                + [(f"[g{i + 1},g{j + 1}]", b) for (i, j), b in zip(self.PAIRS, self.brackets)]:
            _check(_zero((dphi * v)[0, 0]), f"d<Om,xi>({name}) != 0")
            # d energy (v) vanishes where <Om, xi> = 0: it is a polynomial multiple of phi.
            on_m = {M.Om[0]: -(M.Om[1] * M.xi[1] + M.Om[2] * M.xi[2]) / M.xi[0]}
            _check(_zero((dE * v)[0, 0].subs(on_m)), f"d energy({name}) != 0 on M")
        for b in self.brackets:
            _check(all(e == 0 for e in b[3:]), "brackets have xi-components")
        c = sp.Symbol("c", positive=True)
        sph = {M.I1: c, M.I2: c, M.I3: c}
        _check(all(_zero(e.subs(sph)) for e in f), "f != 0 for a spherical body")
        self.spherical_symbol = c

    def fields_matrix(self):
        """4 x 6: rows f, g1, g2, g3."""
        return sp.Matrix.vstack(self.f.T, *[g.T for g in self.g])

    def brackets_matrix(self):
        """3 x 6: rows [g1, g2], [g1, g3], [g2, g3]."""
        return sp.Matrix.vstack(*[b.T for b in self.brackets])

    def accessibility_columns(self):
        """V = [g1, g2, g3, [g1,g2], [g1,g3], [g2,g3]] (paper eq. Veqn), 6 x 6."""
        return sp.Matrix.hstack(*self.g, *self.brackets)
