"""The derivation: from the model (model.py) to the explicit optimality system.

Every formula is computed here from first principles; the paper's printed results
(eqs. Suslov_q, Suslov_lambda, p_sys_explicit, p_lbc, p_rbc, delta_c_rbc) are only a
cross-check (see codegen/README.md and tests/paper_crosscheck.rs).

Steps, in the order they run:

1. Suslov's pure equations (Lagrange-d'Alembert on SO(3)):
       d/dt (dl/dOm) = (dl/dOm) x Om + lambda * dphi/dOm,
   lambda from d/dt phi = 0 (linear in lambda), and q = den(lambda) * residual, where den is the
   coefficient of lambda in d/dt phi, so that q is polynomial (eq. Suslov_q).
2. The augmented Lagrangian L = C + <kappa, q> and its Euler-Lagrange equations in Om and xi,
   with the total time derivative applied symbol by symbol (model.JET); kappa's equation is q = 0.
3. Top-derivative system: E = (d/dt q, EL_Om, EL_xi) = 0 is linear in z = (Om'', xi'', kappa').
   Its blocks are extracted as Jacobians and their structure is *checked* (zero blocks, diagonal
   blocks, the rank-one coupling xi'' -> Om'' through s = <dphi/dxi, xi''>). Block elimination
   leaves (m I + w v^T) xi'' = h, solved in closed form with the Sherman-Morrison formula.
4. Boundary conditions from the boundary terms of the first variation: Om fixed at both ends,
   the xi-momentum p_xi = dL/dxi_dot vanishes at both ends (xi free), and for free terminal time
   the energy function E = <p_Om, Om_dot> + <p_xi, xi_dot> - L vanishes at b.
5. Direct transcription (`DirectTranscription`): the OCP in classical state/control form,
   z = [x, u] = [Om, xi, xi_dot], f(z) = [Om_dot; xi_dot], running cost C on-shell, with df/dz,
   the cost gradient and the Hessian of w L + <lam, f>, all in forward mode.
"""

import random

import mpmath
import sympy as sp

import model as M
from slp import Program


def grad(expr, wrt):
    """Column gradient of a scalar w.r.t. a vector of symbols."""
    return sp.Matrix([sp.diff(expr, w) for w in wrt])


def total_derivative(expr, jet=M.JET):
    """d/dt of an expression of jet symbols (no explicit time dependence)."""
    expr = sp.sympify(expr)
    if isinstance(expr, sp.MatrixBase):
        return expr.applyfunc(lambda e: total_derivative(e, jet))
    out = sp.Integer(0)
    for s in sorted(expr.free_symbols, key=sp.default_sort_key):
        if s in jet:
            out += sp.diff(expr, s) * jet[s]
        elif s not in M.PARAMS:
            raise ValueError(f"no time derivative known for {s}")
    return out


def cross(a, b):
    return a.cross(b)


def dot(a, b):
    return (a.T * b)[0, 0]


def is_zero(e):
    return sp.expand(e) == 0


def check_zero(mat, what):
    bad = [e for e in mat if not is_zero(e)]
    if bad:
        raise AssertionError(f"structure check failed: {what} (e.g. {bad[0]})")


def solve_linear(A, b):
    """Solve A x = b symbolically; diagonal A is inverted entrywise."""
    if all(is_zero(A[i, j]) for i in range(A.rows) for j in range(A.cols) if i != j):
        return sp.Matrix([b[i] / A[i, i] for i in range(A.rows)])
    return A.LUsolve(b)


def diag_inverse(A, what):
    if not all(is_zero(A[i, j]) for i in range(A.rows) for j in range(A.cols) if i != j):
        raise AssertionError(f"structure check failed: {what} is not diagonal")
    return sp.diag(*[1 / A[i, i] for i in range(A.rows)])


# ---------------------------------------------------------------------------------------------
# 1. Suslov's pure equations


class Suslov:
    """lambda, q and Omega_dot for the model's Lagrangian and constraint."""

    def __init__(self, Om=M.Om, OmDot=M.OmDot, xi=M.xi, xiDot=M.xiDot):
        lam = sp.Symbol("lambda_", real=True)
        l = M.body_lagrangian(Om)
        mom = grad(l, Om)  # dl/dOm = I Om
        dmom = mom.jacobian(Om) * OmDot  # d/dt (dl/dOm)
        phi = M.constraint(Om, xi)
        gphi_om = grad(phi, Om)  # = xi
        gphi_xi = grad(phi, xi)  # = Om
        # Lagrange-d'Alembert: d/dt mom = mom x Om + lam * gphi_om; solve for Om_dot.
        omdot_of_lam = solve_linear(mom.jacobian(Om), cross(mom, Om) + lam * gphi_om)
        # The constraint is preserved: d/dt phi = <gphi_om, Om_dot> + <gphi_xi, xi_dot> = 0.
        dphi = dot(gphi_om, omdot_of_lam) + dot(gphi_xi, xiDot)
        den = sp.simplify(sp.diff(dphi, lam))
        if sp.diff(dphi, lam, 2) != 0:
            raise AssertionError("d/dt phi is not linear in lambda")
        rest = sp.expand(dphi.subs(lam, 0) * den)
        rest = sp.simplify(rest / den)
        self.lam_num = -rest  # lambda = lam_num / den
        self.den = den
        self.lam = self.lam_num / den
        self.mom = mom
        self.gphi_om = gphi_om
        self.gphi_xi = gphi_xi
        # q = den * (d/dt mom - mom x Om - lambda gphi_om): polynomial in the jets.
        self.q = (den * (dmom - cross(mom, Om)) - self.lam_num * gphi_om).applyfunc(sp.expand)
        # Om_dot from q = 0 (linear in Om_dot).
        A, b = sp.linear_eq_to_matrix(list(self.q), list(OmDot))
        self.omega_dot = solve_linear(A, b).applyfunc(sp.cancel)
        # The same solution in structured form, Om_dot = (dmom/dOm)^-1 (mom x Om + lambda
        # dphi/dOm), which is what the generated code evaluates (lambda as a named quantity).
        self.lam_symbol = lam
        self.omdot_of_lam = omdot_of_lam

    def let_omega_dot(self, prog):
        """Append lambda and Om_dot to a program; return Om_dot's symbols."""
        lam = prog.let("lam", self.lam)
        return prog.let(list(M.OmDot), self.omdot_of_lam.subs(self.lam_symbol, lam))


# ---------------------------------------------------------------------------------------------
# 2.-3. The optimality system


class Optimality:
    """Euler-Lagrange equations of C + <kappa, q> and their explicit first-order form."""

    def __init__(self):
        s = Suslov()
        self.suslov = s
        C = M.cost(M.Om, M.OmDot, M.xi, M.xiDot, M.Om_d)
        self.C = C
        q = s.q
        L = C + dot(M.kappa, q)
        self.L = L
        self.p_om = grad(L, M.OmDot)  # momentum conjugate to Om
        self.p_xi = grad(L, M.xiDot)  # momentum conjugate to xi
        self.el_om = grad(L, M.Om) - total_derivative(self.p_om)
        self.el_xi = grad(L, M.xi) - total_derivative(self.p_xi)
        self.dq = total_derivative(q)
        z = [list(M.OmDDot), list(M.xiDDot), list(M.kappaDot)]
        eqs = [self.dq, self.el_om, self.el_xi]
        flat = [v for zz in z for v in zz]
        blocks = [[e.jacobian(zz) for zz in z] for e in eqs]
        for row in blocks:
            for blk in row:
                for entry in blk:
                    if entry.free_symbols & set(flat):
                        raise AssertionError("top-derivative system is not linear")
        zero = {v: 0 for v in flat}
        rhs = [-e.subs(zero) for e in eqs]
        (M11, M12, M13), (M21, M22, M23), (M31, M32, M33) = blocks
        check_zero(M13, "d/dt q does not contain kappa'")
        check_zero(M22, "EL_Om does not contain xi''")
        check_zero(M31, "EL_xi does not contain Om''")
        m = M32[0, 0]
        check_zero(M32 - m * sp.eye(3), "EL_xi's xi'' block is a multiple of the identity")
        # xi'' enters d/dt q only through s = <v, xi''>, v = dphi/dxi: M12 = u v^T.
        v = s.gphi_xi
        j = next(i for i in range(3) if v[i] != 0)
        u = (M12[:, j] / v[j]).applyfunc(sp.cancel)
        check_zero(M12 - u * v.T, "M12 is rank one with row space dphi/dxi")
        self.blocks = blocks
        self.rhs = rhs
        self.m = m
        self.u = u
        self.v = v
        self.M11inv = diag_inverse(M11, "M11 (Om'' in d/dt q)")
        self.M23inv = diag_inverse(M23, "M23 (kappa' in EL_Om)")
        self.M21 = M21
        self.M33 = M33

    def rhs_program(self, prog):
        """Append the explicit right-hand side f(y) to `prog`; return f as a list of symbols.

        Assignments, in order: Om_dot (from q = 0); Om'' = a1 - b1 s (from d/dt q = 0);
        kappa' = c0 + c1 s (from EL_Om); h, w with (m I + w v^T) xi'' = h (from EL_xi);
        s = <v, h>/(m + <v, w>) and xi'' = (h - w s)/m (Sherman-Morrison); kappa'.
        """
        s = self.suslov
        r1, r2, r3 = self.rhs
        om_dot = s.let_omega_dot(prog)
        a1 = prog.let("a", self.M11inv * r1)
        b1 = prog.let("b", self.M11inv * self.u)
        c0 = prog.let("c", self.M23inv * (r2 - self.M21 * a1))
        c1 = prog.let("e", self.M23inv * self.M21 * b1)
        h = prog.let("h", r3 - self.M33 * c0)
        w = prog.let("w", self.M33 * c1)
        # (m I + w v^T) xi'' = h  =>  s = <v, xi''> = <v, h> / (m + <v, w>)
        sm = prog.let("sm", dot(self.v, h) / (self.m + dot(self.v, w)))
        xi_dd = prog.let(list(M.xiDDot), (h - w * sm) / self.m)
        kappa_dot = prog.let(list(M.kappaDot), c0 + c1 * sm)
        return list(om_dot) + list(M.xiDot) + list(xi_dd) + list(kappa_dot), a1, b1, sm

    def direct_top_derivatives(self):
        """(Matrix, rhs) of the full 9x9 linear system in z, for cross-checks."""
        A = sp.BlockMatrix(self.blocks).as_explicit()
        b = sp.Matrix.vstack(*self.rhs)
        return A, b


# ---------------------------------------------------------------------------------------------
# 4. Boundary quantities (all evaluated on-shell: Om_dot = F(Om, xi, xi_dot), so q = 0)


def onshell_program(inputs, constants):
    """A program whose first assignments are Om_dot = F(Om, xi, xi_dot)."""
    prog = Program(inputs, constants)
    Suslov().let_omega_dot(prog)
    return prog


def natural_bc(opt):
    """p_xi = dL/dxi_dot, which must vanish where xi is free (both ends)."""
    return opt.p_xi


def energy_function(opt):
    """E = <p_Om, Om_dot> + <p_xi, xi_dot> - L (the Hamiltonian of the augmented Lagrangian)."""
    return dot(opt.p_om, M.OmDot) + dot(opt.p_xi, M.xiDot) - opt.L


def free_time_condition(opt):
    """Transversality for free b: E(b) = 0. Returned in the paper's sign and simplified form
    -E + <p_xi, xi_dot> - <kappa, q> = C - <p_Om, Om_dot>, i.e. with the terms dropped that
    vanish by the other right conditions (p_xi(b) = 0) and on-shell (q = 0)."""
    return opt.C - dot(opt.p_om, M.OmDot)


def classical_costates(opt):
    """pi = -[p_Om; p_xi] (costates of the classical 6-state Hamiltonian formulation)."""
    return -sp.Matrix.vstack(opt.p_om, opt.p_xi)


# ---------------------------------------------------------------------------------------------
# Section 5.1: the analytic singular solution


def singular_xi():
    """xi_p = xi~/|xi~|, xi~ = d/dt(dl/dOm) - (dl/dOm) x Om (the constraint force lambda*xi),
    and its time derivative, for a given Om_p with derivatives Om_p', Om_p''.

    Valid for constraints whose Om-gradient is xi itself (phi = <Om, xi>), checked here."""
    s = Suslov()
    if not is_zero((s.gphi_om - M.xi).norm() ** 2):
        raise AssertionError("singular solution assumes dphi/dOm = xi")
    mom = s.mom
    xt = mom.jacobian(M.Om) * M.OmDot - cross(mom, M.Om)
    return xt


# ---------------------------------------------------------------------------------------------
# Direct transcription: the OCP in classical state/control form


class DirectTranscription:
    """Point functions of the optimal control problem in classical state/control form, for a
    direct transcription (discretize, then optimize) and its second-order certificate.

    State x = [Om, xi], control u = xi_dot, z = [x, u] = [Om, xi, xi_dot] (`Z`).
    Dynamics f(z) = [F(Om, xi, xi_dot); xi_dot] with F Suslov's Om_dot (step 1); running cost
    L(z, Om_d) = C(Om, F, xi, xi_dot, Om_d), the cost integrand on-shell. All derivatives are
    forward mode through one straight-line program (`slp.Program.jacobian`); the Hessian of the
    point Lagrangian l = w L + <lam, f> is the Jacobian of its gradient (forward over forward),
    asserted symmetric at seeded points and emitted from its upper triangle.
    """

    Z = list(M.Om) + list(M.xi) + list(M.xiDot)
    W = sp.Symbol("w", real=True)  # weight of the cost in the point Lagrangian
    LAM = list(sp.symbols("lam1:7", real=True))  # multipliers of the 6 dynamics rows

    def __init__(self, opt):
        self.suslov = opt.suslov
        self.C = opt.C  # in Om, OmDot, xi, xiDot, Om_d; OmDot is assigned on-shell below

    def program(self, extra_inputs=()):
        """A program over z, Om_d (and `extra_inputs`) whose first assignments are
        lambda and Om_dot = F(z). Returns (program, f) with f the 6 dynamics entries."""
        prog = Program(self.Z + list(M.Om_d) + list(extra_inputs), M.PARAMS)
        om_dot = self.suslov.let_omega_dot(prog)
        return prog, list(om_dot) + list(M.xiDot)

    def dynamics_jacobian(self, prog, f):
        """df/dz, 6 x 9."""
        return prog.jacobian(f, self.Z)

    def cost_gradient(self, prog):
        """(dL/dz, dL/dOm_d) as column matrices (9, 3)."""
        J = prog.jacobian([self.C], self.Z + list(M.Om_d))
        return J[0, :9].T, J[0, 9:].T

    def lagrangian_hessian(self, prog, f, check_points=3, seed=7):
        """The Hessian of l = w L + <lam, f> w.r.t. v = [z, Om_d] (12 x 12), symmetric.

        Forward over forward: the gradient is a Jacobian through the program (prefix d), the
        Hessian the Jacobian of that gradient (prefix dd). H[i][j] = d/dv_j (dl/dv_i) and
        H[j][i] are different expressions of the same number: they are compared at seeded
        points (mpmath, 40 digits) and the upper triangle is returned mirrored, so that the
        emitted Hessian is symmetric to the last bit.
        """
        v = self.Z + list(M.Om_d)
        ell = self.W * self.C + sum(l * e for l, e in zip(self.LAM, f))
        grad_ = prog.jacobian([ell], v, prefix="d")
        H = prog.jacobian(list(grad_), v, prefix="dd")
        n = len(v)
        pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
        run = prog.evaluator([H[i, j] - H[j, i] for i, j in pairs]
                             + [H[i, j] for i, j in pairs])
        rng = random.Random(seed)
        for _ in range(check_points):
            vals = {}
            for s in prog.inputs + prog.constants:
                x = rng.uniform(0.5, 2.0)
                vals[s] = x if s in M.PARAMS else rng.choice([-1, 1]) * x
            out = run(vals)
            diff, upper = out[:len(pairs)], out[len(pairs):]
            scale = max(1, max(abs(e) for e in upper))
            bad = [pairs[k] for k, d in enumerate(diff) if abs(d) > scale * mpmath.mpf(10) ** -30]
            if bad:
                raise AssertionError(f"Hessian of the point Lagrangian is not symmetric at {bad}")
        return sp.Matrix(n, n, lambda i, j: H[min(i, j), max(i, j)])
