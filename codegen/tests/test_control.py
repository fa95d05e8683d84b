"""Controllability (paper section 4.3): the derived affine system vs the paper's printed formulas,
and exact ranks of V = [g1, g2, g3, [g1,g2], [g1,g3], [g2,g3]] in rational arithmetic."""

import os
import random
import sys
import unittest

import sympy as sp

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

import control as C  # noqa: E402
import derive as D  # noqa: E402
import model  # noqa: E402

M = model.load("so3")
AFF = C.AffineSystem(D.Suslov(M))
Om, xi = M.Om, M.xi
Iinv = sp.diag(1 / M.I1, 1 / M.I2, 1 / M.I3)
DEN = (xi.T * Iinv * xi)[0, 0]  # <xi, I^-1 xi>


def zero(e):
    return sp.cancel(sp.together(e)) == 0


def paper_f():
    """Eq. state_f."""
    IOmxOm = (M.INERTIA * Om).cross(Om)
    top = Iinv / DEN * (DEN * IOmxOm - (IOmxOm.T * Iinv * xi)[0, 0] * xi)
    return sp.Matrix(list(top) + [0, 0, 0])


def paper_g(i):
    """Eq. state_gi."""
    top = -Iinv / DEN * Om[i] * xi
    e = [0, 0, 0]
    e[i] = 1
    return sp.Matrix(list(top) + e)


def paper_bracket(i, j):
    """The last line of the paper's computation of [g_i, g_j] (d_m = I_m)."""
    d = [M.I1, M.I2, M.I3]
    top = sp.zeros(3, 1)
    for l in range(3):
        top[l] = (Om[j] * xi[i] / d[i] - Om[i] * xi[j] / d[j]) / DEN ** 2 * xi[l] / d[l]
    top[j] += Om[i] / (d[j] * DEN)
    top[i] -= Om[j] / (d[i] * DEN)
    return sp.Matrix(list(top) + [0, 0, 0])


def paper_V():
    """Eqs. Veqn and Aeqn."""
    P = sp.Matrix([[-Om[1], -Om[2], 0], [Om[0], 0, -Om[2]], [0, Om[0], Om[1]]])
    D = sp.Matrix([[0, 0, -1], [0, 1, 0], [-1, 0, 0]])
    A = P + xi * ((Om.cross(Iinv * xi)).T * D) / DEN
    top = sp.Matrix.hstack(-Iinv / DEN * xi * Om.T, Iinv / DEN * A)
    bottom = sp.Matrix.hstack(sp.eye(3), sp.zeros(3, 3))
    return sp.Matrix.vstack(top, bottom)


def rational_point(rng, on_m=True, inertia=None):
    q = lambda: sp.Rational(rng.randint(-20, 20), rng.randint(1, 7))  # noqa: E731
    om = sp.Matrix([q(), q(), q()])
    while om.norm() == 0:
        om = sp.Matrix([q(), q(), q()])
    if on_m:
        x = om.cross(sp.Matrix([q(), q(), q()]))
        while x.norm() == 0:
            x = om.cross(sp.Matrix([q(), q(), q()]))
    else:
        x = sp.Matrix([q(), q(), q()])
        while (om.T * x)[0, 0] == 0:
            x = sp.Matrix([q(), q(), q()])
    ins = inertia or [sp.Rational(rng.randint(1, 30), rng.randint(1, 9)) for _ in range(3)]
    vals = dict(zip(list(Om) + list(xi), list(om) + list(x)))
    vals.update(zip([M.I1, M.I2, M.I3], ins))
    return vals


class PaperFormulas(unittest.TestCase):
    def test_drift_equals_eq_state_f(self):
        for a, b in zip(AFF.f, paper_f()):
            self.assertTrue(zero(a - b))

    def test_control_fields_equal_eq_state_gi(self):
        for i in range(3):
            for a, b in zip(AFF.g[i], paper_g(i)):
                self.assertTrue(zero(a - b))

    def test_brackets_equal_the_papers_computation(self):
        for (i, j), br in zip(AFF.PAIRS, AFF.brackets):
            for a, b in zip(br, paper_bracket(i, j)):
                self.assertTrue(zero(a - b), f"[g{i + 1}, g{j + 1}]")

    def test_V_equals_eqs_Veqn_Aeqn(self):
        for a, b in zip(AFF.accessibility_columns(), paper_V()):
            self.assertTrue(zero(a - b))

    def test_bracket_is_antisymmetric_and_jacobi_free_of_sign_errors(self):
        # [g2, g1] = -[g1, g2], computed independently.
        b21 = C.lie_bracket(AFF.g[1], AFF.g[0], AFF.X)
        for a, b in zip(b21, AFF.brackets[0]):
            self.assertTrue(zero(a + b))


class Drift(unittest.TestCase):
    def test_spherical_body_is_driftless_everywhere(self):
        c = sp.Symbol("c", positive=True)
        for e in AFF.f:
            self.assertTrue(zero(e.subs({M.I1: c, M.I2: c, M.I3: c})))

    def test_non_spherical_drift_is_nonzero_on_M(self):
        rng = random.Random(7)
        for _ in range(5):
            vals = rational_point(rng, inertia=[1, 2, 3])
            self.assertNotEqual(AFF.f.subs(vals), sp.zeros(6, 1))


class ExactRanks(unittest.TestCase):
    """Ranks of V in exact rational arithmetic (no threshold)."""

    def rank(self, vals, mat=None):
        m = (mat if mat is not None else AFF.accessibility_columns()).subs(vals)
        return m.rank()  # exact: the entries are Rationals (no nsimplify, it rounds)

    def test_rank_4_on_M(self):
        rng = random.Random(11)
        for _ in range(10):
            self.assertEqual(self.rank(rational_point(rng)), 4)

    def test_rank_5_off_M(self):
        # Off M only <Om, xi> (a level set in R^6) is invariant: V spans its 5-dim tangent space.
        rng = random.Random(12)
        for _ in range(10):
            self.assertEqual(self.rank(rational_point(rng, on_m=False)), 5)

    def test_rank_3_at_rest(self):
        # Omega = 0 (e_S = 0): g_i = e_i in the xi-block and every bracket vanishes.
        vals = {Om[0]: 0, Om[1]: 0, Om[2]: 0, xi[0]: 1, xi[1]: 2, xi[2]: -1,
                M.I1: 1, M.I2: 2, M.I3: 3}
        self.assertEqual(self.rank(vals), 3)

    def test_drift_brackets_stay_in_TM(self):
        # Adding f and [f, g_i] does not raise the rank above dim T_x M = 4 on M.
        extra = [AFF.f] + [C.lie_bracket(AFF.f, g, AFF.X) for g in AFF.g]
        full = sp.Matrix.hstack(AFF.accessibility_columns(), *extra)
        rng = random.Random(13)
        for _ in range(3):
            self.assertEqual(self.rank(rational_point(rng, inertia=[1, 2, 3]), full), 4)


if __name__ == "__main__":
    unittest.main()
