"""The derivation is not tuned to the shipped models: it derives models of other algebras
(the Heisenberg algebra, sl(2, R) with a non-diagonal inertia, so(3) with a constraint value)
and their invariants hold at seeded points in 40-digit arithmetic.

Each test model is declared exactly like a file in codegen/models/ (a module-like object),
so this is also a test of the model-file format.
"""

import os
import random
import sys
import types
import unittest

import mpmath
import sympy as sp

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

import control as C  # noqa: E402
import derive as D  # noqa: E402
import model  # noqa: E402
from lie import LieAlgebra, hat3  # noqa: E402
from model import Param, sq  # noqa: E402
from slp import Program  # noqa: E402

TOL = mpmath.mpf(10) ** -28


def standard_weights():
    return [
        Param("alpha", "alpha", lower=0, strict=True, role="fixed"),
        Param("beta", "beta", lower=0, strict=True, role="beta"),
        Param("gamma", "gamma", lower=0, role="tracking"),
        Param("eta", "eta", lower=0, role="smoothing"),
        Param("delta", "delta", lower=0, role="time"),
    ]


def standard_cost(w, Om, OmDot, xi, xiDot, Om_d):
    return (w.alpha / 4 * (sq(xi) - 1) ** 2 + w.beta / 2 * sq(xiDot)
            + w.gamma / 2 * sq(Om - Om_d) + w.eta / 2 * sq(OmDot) + w.delta)


def spec(name, algebra, inertia_params, inertia, constraint_params=(), constraint_value=None,
         samples=None):
    s = types.SimpleNamespace(
        __doc__=f"test model {name}", NAME=name, TITLE=name, ALGEBRA=algebra,
        INERTIA_PARAMS=list(inertia_params), inertia=inertia, WEIGHTS=standard_weights(),
        cost=standard_cost, CONSTRAINT_PARAMS=list(constraint_params), SAMPLES=samples or {})
    if constraint_value is not None:
        s.constraint_value = constraint_value
    return s


def heisenberg():
    """[e1, e2] = e3, the other brackets 0 (nilpotent); diagonal inertia."""
    alg = LieAlgebra.from_brackets(["e1", "e2", "e3"], {(0, 1): {2: 1}})
    ps = [Param(f"A{k}", f"inertia A{k}", lower=0, strict=True) for k in (1, 2, 3)]
    return model.Model(spec("heis", alg, ps, lambda p: sp.diag(p.A1, p.A2, p.A3)))


def sl2():
    """sl(2, R) from its matrix representation (h, e, f); a full symmetric inertia."""
    h = sp.Matrix([[1, 0], [0, -1]])
    e = sp.Matrix([[0, 1], [0, 0]])
    f = sp.Matrix([[0, 0], [1, 0]])
    alg = LieAlgebra.from_matrices(["h", "e", "f"], [h, e, f])
    ps = [Param("A", "diagonal", lower=0, strict=True), Param("B", "off-diagonal")]
    return model.Model(spec("sl2", alg, ps,
                            lambda p: sp.Matrix([[p.A + 2, p.B, 0], [p.B, p.A + 1, 0],
                                                 [0, 0, p.A + 3]]),
                            samples={"B": (-0.4, 0.4)}))


def so3_inhomogeneous():
    """so(3) with the constraint <xi, Omega> = c (constant)."""
    alg = LieAlgebra.from_matrices(["e1", "e2", "e3"],
                                   [hat3(v) for v in ([1, 0, 0], [0, 1, 0], [0, 0, 1])])
    ps = [Param(f"I{k}", f"I{k}", lower=0, strict=True) for k in (1, 2, 3)]
    cp = [Param("cval", "constraint value", role="constraint")]
    return model.Model(spec("so3c", alg, ps, lambda p: sp.diag(p.I1, p.I2, p.I3),
                            constraint_params=cp, constraint_value=lambda c, xi: c.cval))


def values(M, rng, symbols):
    vals = C._sample_params(M, rng)
    for s in symbols:
        if s in vals:
            continue
        name = str(s)
        if name.startswith("xi") and not name.startswith("xiD"):
            vals[s] = rng.choice([-1, 1]) * rng.uniform(0.4, 1.6)
        else:
            vals[s] = rng.uniform(-2.0, 2.0)
    return vals


class GenericModels(unittest.TestCase):
    MODELS = {}

    @classmethod
    def setUpClass(cls):
        for make in (heisenberg, sl2, so3_inhomogeneous):
            M = make()
            cls.MODELS[M.NAME] = (M, D.Optimality(M))

    def test_algebras_are_checked(self):
        with self.assertRaises(ValueError):  # not antisymmetric / Jacobi fails
            LieAlgebra(["a", "b", "c"], [[[0, 0, 0], [0, 0, 1], [0, 0, 0]],
                                         [[0, 0, 0]] * 3, [[0, 0, 0]] * 3])
        # sl(2) brackets from the matrices: [h, e] = 2e, [h, f] = -2f, [e, f] = h
        M, _ = self.MODELS["sl2"]
        e = sp.eye(3).columnspace()
        self.assertEqual(list(M.algebra.bracket(e[0], e[1])), [0, 2, 0])
        self.assertEqual(list(M.algebra.bracket(e[0], e[2])), [0, 0, -2])
        self.assertEqual(list(M.algebra.bracket(e[1], e[2])), [1, 0, 0])

    def test_reserved_parameter_names_are_refused(self):
        alg = LieAlgebra.from_brackets(["e1", "e2", "e3"], {(0, 1): {2: 1}})
        for bad in ("xi1", "oa2", "x0", "a_b"):
            ps = [Param(bad, "bad", lower=0, strict=True), Param("A2", "a"), Param("A3", "a")]
            with self.assertRaises(ValueError):
                model.Model(spec("bad", alg, ps, lambda p: sp.eye(3)))

    def test_suslov_equations_preserve_the_constraint_and_balance_energy(self):
        """d/dt <Om, xi> = d/dt gamma, and dT/dt = lambda <Om, xi> everywhere, so dT/dt =
        lambda gamma on the constraint (paper, after eq. lambda_expression3), with Om_dot
        from the generated-program route."""
        for name, (M, opt) in self.MODELS.items():
            with self.subTest(model=name):
                x = list(M.Om) + list(M.xi) + list(M.xiDot)
                prog = Program(x, M.PARAMS)
                om_dot = opt.suslov.let_omega_dot(prog)
                gam = M.constraint_value(M.xi)
                dphi = sum(M.xi[i] * om_dot[i] + M.Om[i] * M.xiDot[i] for i in range(M.n)) \
                    - sum(sp.diff(gam, M.xi[i]) * M.xiDot[i] for i in range(M.n))
                dT = (M.Om.T * M.INERTIA * sp.Matrix(om_dot))[0, 0]
                lam = [s for s, _ in prog.lets if str(s) == "lam"][0]
                run = prog.evaluator([dphi, dT - lam * (M.Om.T * M.xi)[0, 0]])
                rng = random.Random(5)
                for _ in range(5):
                    vals = values(M, rng, x)
                    out = run(vals)
                    self.assertLess(abs(out[0]), TOL)
                    self.assertLess(abs(out[1]), TOL * 100)

    def test_explicit_system_solves_the_top_derivative_system(self):
        """Sherman-Morrison and the block elimination (with I^-1 as derived constants for a
        non-diagonal inertia) equal a direct solve of the full 3n x 3n system."""
        for name, (M, opt) in self.MODELS.items():
            with self.subTest(model=name):
                n = M.n
                prog = Program(M.STATE + list(M.Om_d) + list(M.Om_dDot), M.PARAMS)
                f, a1, b1, sm = opt.rhs_program(prog)
                om_dd = [a1[i] - b1[i] * sm for i in range(n)]
                outs = list(M.OmDot) + om_dd + list(M.xiDDot) + list(M.kappaDot)
                run = prog.evaluator(outs)
                A, b = opt.direct_top_derivatives()
                syms = sorted(A.free_symbols | b.free_symbols, key=sp.default_sort_key)
                fa = sp.lambdify(syms, A, modules="mpmath")
                fb = sp.lambdify(syms, b, modules="mpmath")
                rng = random.Random(3)
                for _ in range(4):
                    vals = values(M, rng, prog.inputs)
                    got = run(vals)
                    env = dict(vals)
                    env.update(zip(M.OmDot, got[:n]))
                    with mpmath.workdps(40):
                        z = mpmath.lu_solve(
                            mpmath.matrix(fa(*[mpmath.mpf(env[s]) for s in syms])),
                            mpmath.matrix(fb(*[mpmath.mpf(env[s]) for s in syms])))
                        for i in range(3 * n):
                            self.assertLess(abs(z[i] - got[n + i]), TOL * (1 + abs(z[i])))

    def test_control_affine_form_and_brackets(self):
        """The affine system derives (its structure checks run in the constructor) and the
        program's brackets equal the symbolic ones."""
        for name, (M, opt) in self.MODELS.items():
            with self.subTest(model=name):
                aff = C.AffineSystem(opt.suslov)
                prog, rows, br = aff.program()
                sym = [b.subs(M.inverse_substitution()) for b in aff.brackets]
                run = prog.evaluator([e for b in br for e in b])
                rng = random.Random(9)
                vals = values(M, rng, aff.X)
                got = run(vals)
                exact = {k: v for k, v in vals.items()}
                k = 0
                for b in sym:
                    for e in b:
                        want = sp.lambdify(sorted(e.free_symbols, key=sp.default_sort_key), e,
                                           modules="mpmath")
                        with mpmath.workdps(40):
                            ref = want(*[mpmath.mpf(exact[s]) for s in
                                         sorted(e.free_symbols, key=sp.default_sort_key)]) \
                                if e.free_symbols else mpmath.mpf(e)
                        self.assertLess(abs(ref - got[k]), mpmath.mpf(10) ** -20 * (1 + abs(ref)))
                        k += 1


if __name__ == "__main__":
    unittest.main()
