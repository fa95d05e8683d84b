"""Python-side checks of the derivation (run by tests/python_derivation.rs via `cargo test`)."""

import os
import random
import subprocess
import sys
import tempfile
import unittest

import mpmath
import sympy as sp

HERE = os.path.dirname(os.path.abspath(__file__))
CODEGEN = os.path.dirname(HERE)
sys.path.insert(0, CODEGEN)

import derive as D  # noqa: E402
import model  # noqa: E402
from emit_rust import RustPrinter  # noqa: E402
import slp  # noqa: E402
from slp import Program  # noqa: E402

M = model.load("so3")
OPT = D.Optimality(M)


def random_values(rng, symbols):
    vals = {}
    for s in symbols:
        name = str(s)
        if name.startswith("I"):
            vals[s] = rng.uniform(0.5, 3.0)
        elif name in ("alpha", "beta", "gamma", "eta", "delta"):
            vals[s] = rng.uniform(0.1, 2.0)
        elif name.startswith("xi") and not name.startswith("xiDot"):
            vals[s] = rng.choice([-1, 1]) * rng.uniform(0.4, 1.6)
        else:
            vals[s] = rng.uniform(-2.0, 2.0)
    return vals


class ShermanMorrison(unittest.TestCase):
    def test_closed_form_equals_direct_linear_solve(self):
        """xi'', kappa' and Om'' from the block elimination + Sherman-Morrison equal the
        solution of the full 9x9 top-derivative system, at random points (40 digits)."""
        prog = Program(M.STATE + list(M.Om_d) + list(M.Om_dDot), M.PARAMS)
        f, a1, b1, sm = OPT.rhs_program(prog)
        om_dd = [a1[i] - b1[i] * sm for i in range(3)]
        outs = list(M.OmDot) + om_dd + list(M.xiDDot) + list(M.kappaDot)
        run = prog.evaluator(outs)
        A, b = OPT.direct_top_derivatives()
        syms = sorted((A.free_symbols | b.free_symbols), key=sp.default_sort_key)
        fa = sp.lambdify(syms, A, modules="mpmath")
        fb = sp.lambdify(syms, b, modules="mpmath")
        rng = random.Random(11)
        for _ in range(25):
            vals = random_values(rng, prog.inputs + prog.constants)
            got = run(vals)
            env = dict(vals)
            env.update(zip(M.OmDot, got[:3]))
            with mpmath.workdps(40):
                args = [mpmath.mpf(env[s]) for s in syms]
                z = mpmath.lu_solve(mpmath.matrix(fa(*args)), mpmath.matrix(fb(*args)))
                for i in range(9):
                    self.assertLess(abs(z[i] - got[3 + i]), mpmath.mpf(10) ** -30 * (1 + abs(z[i])))

    def test_structure_of_the_top_derivative_system(self):
        (M11, M12, M13), (M21, M22, M23), (M31, M32, M33) = OPT.blocks
        den = OPT.suslov.den
        self.assertEqual(sp.simplify(M11 - den * M.INERTIA), sp.zeros(3))
        self.assertEqual(sp.simplify(M12 - M.xi * M.Om.T), sp.zeros(3))
        self.assertEqual(sp.simplify(M32 + M.beta * sp.eye(3)), sp.zeros(3))
        self.assertEqual(sp.simplify(M33 + M.Om * M.xi.T), sp.zeros(3))


class SuslovEquations(unittest.TestCase):
    def test_lambda_and_q_match_the_paper(self):
        """eqs. Suslov_lambda and Suslov_q, transcribed, equal the derived ones exactly."""
        I, Om, xi, xiD, OmD = M.INERTIA, M.Om, M.xi, M.xiDot, M.OmDot
        IOmxOm = (I * Om).cross(Om)
        den = (xi.T * I.inv() * xi)[0]
        n1 = (Om.T * xiD)[0] + (IOmxOm.T * I.inv() * xi)[0]
        lam_paper = -n1 / den
        q_paper = den * (I * OmD - IOmxOm) + n1 * xi
        self.assertEqual(sp.simplify(OPT.suslov.lam - lam_paper), 0)
        self.assertEqual(sp.simplify(OPT.suslov.q - q_paper), sp.zeros(3, 1))

    def test_omega_dot_solves_q(self):
        q = OPT.suslov.q.subs(dict(zip(M.OmDot, OPT.suslov.omega_dot)))
        self.assertEqual(q.applyfunc(sp.simplify), sp.zeros(3, 1))


class Printer(unittest.TestCase):
    def test_parentheses_survive_where_sympys_rust_printer_drops_them(self):
        a, b, x, r = sp.symbols("a b x r", real=True)
        names = {a: "a", b: "b", x: "x", r: "r"}
        p = RustPrinter(names)
        self.assertEqual(p(a * (b + 1)), "a*(b + 1.0)")
        self.assertEqual(p(-x * (r - 1)), "-x*(r - 1.0)")
        self.assertEqual(p(a * (b + sp.Rational(1, 2))), "a*(b + (1.0/2.0))")
        self.assertEqual(p(2 + 16 / a ** 2), "2.0 + 16.0/a.powi(2)")
        self.assertEqual(p(1 / (a * b)), "1.0/(a*b)")
        self.assertEqual(p((a + b) ** -2), "1.0/(a + b).powi(2)")

    def test_unknown_nodes_are_refused(self):
        a = sp.Symbol("a", real=True)
        with self.assertRaises(TypeError):
            RustPrinter({a: "a"})(sp.besselj(0, a))


class Differentiation(unittest.TestCase):
    def test_memoised_diff_is_sympys_diff(self):
        """slp.diff builds the very expression sp.diff builds (same tree, same argument order),
        on every assignment of the so3 right-hand side and on the cost, w.r.t. every symbol
        it contains, and on a few nodes sympy handles itself (functions, symbolic powers)."""
        prog = Program(M.STATE + list(M.Om_d) + list(M.Om_dDot), M.PARAMS)
        OPT.rhs_program(prog)
        a, b = sp.symbols("a b", real=True)
        exprs = [e for _, e in prog.lets] + [OPT.C, sp.sqrt(a * b + 1) * sp.tanh(a) ** b,
                                             (a + 2 * b) ** -3 / (1 + a), sp.Integer(3)]
        for e in exprs:
            for s in sorted(e.free_symbols | {a}, key=sp.default_sort_key):
                got, want = slp.diff(e, s), sp.diff(e, s)
                self.assertEqual(sp.srepr(got), sp.srepr(want), (e, s))


class Evaluator(unittest.TestCase):
    def test_memoised_printer_prints_as_sympys(self):
        """The evaluators' printer (memoised per node, shared by every program) prints what a
        fresh MpmathPrinter prints, also for a node met again inside other expressions."""
        from sympy.printing.pycode import MpmathPrinter
        settings = {"fully_qualified_modules": False, "inline": True, "order": "none"}
        a, b = sp.symbols("a b", real=True)
        shared = (a + 2 * b) ** -3 / (1 + a)
        exprs = [shared, a * (b + 1) / 3 + shared, sp.sqrt(a * b + 1) * sp.Float("0.1", 40),
                 sp.pi * a - shared ** 2, 1 / sp.sqrt(a), sp.Rational(-5, 7) * b]
        for e in exprs + exprs:
            self.assertEqual(slp._printer().doprint(e), MpmathPrinter(settings).doprint(e))

    def test_only_needed_assignments_are_printed_under_their_own_names(self):
        x, y = sp.symbols("x y", real=True)
        prog = Program([x, y])
        u = prog.let("u", x * y)
        w = prog.let("w", x + y)
        src = prog.source([w ** 2])
        self.assertNotIn("v2 =", src)  # u (v2) is not needed
        self.assertIn("v3 = v0 + v1", src)  # w keeps the name of its position
        self.assertEqual(prog.evaluator([w ** 2, u])({x: 2, y: 3}), [25, 6])


class Determinism(unittest.TestCase):
    def test_output_is_byte_identical_across_hash_seeds(self):
        outs = []
        for seed in ("1", "2"):
            d = tempfile.mkdtemp()
            env = dict(os.environ, PYTHONHASHSEED=seed)
            subprocess.run([sys.executable, os.path.join(CODEGEN, "generate.py"), "--out", d,
                            "--models", "so3"],
                           check=True, env=env)
            files = {}
            for n in sorted(os.listdir(d)):
                with open(os.path.join(d, n), "rb") as fh:
                    files[n] = fh.read()
            outs.append(files)
        self.assertEqual(outs[0], outs[1])


if __name__ == "__main__":
    unittest.main()
