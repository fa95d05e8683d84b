"""The derivation: from a model (model.py, models/*.py) to the explicit optimality system.

One derivation for every model: the paper's section 3 (an arbitrary Lie group), computed from
first principles with the model's algebra (ad* from its structure constants), inertia,
constraint value and cost. The paper's printed SO(3) results (eqs. Suslov_q, Suslov_lambda,
p_sys_explicit, p_lbc, p_rbc, delta_c_rbc) are only a cross-check (see codegen/README.md and
tests/paper_crosscheck.rs).

Steps, in the order they run (M is the model):

1. Suslov's pure equations (Lagrange-d'Alembert, eq. Suslov_gen2):
       d/dt (dl/dOm) = ad*_Om (dl/dOm) + lambda * xi,   phi = <Om, xi> - gamma(xi) = 0,
   lambda from d/dt phi = 0 (linear in lambda, eq. lambda_expression2p5), and
   q = den(lambda) * residual, where den = <xi, I^-1 xi> is the coefficient of lambda in
   d/dt phi, so that q is polynomial in the jets (eq. Suslov_q for so(3)).
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

from slp import Program, diff


def grad(expr, wrt):
    """Column gradient of a scalar w.r.t. a vector of symbols."""
    return sp.Matrix([diff(expr, w) for w in wrt])


def jacobian(vec, wrt):
    """`vec.jacobian(wrt)` (the same entries) with the memoised `slp.diff`."""
    return sp.Matrix(len(vec), len(wrt), lambda i, j: diff(vec[i], wrt[j]))


def total_derivative(M, expr):
    """d/dt of an expression of the model's jet symbols (no explicit time dependence)."""
    expr = sp.sympify(expr)
    if isinstance(expr, sp.MatrixBase):
        return expr.applyfunc(lambda e: total_derivative(M, e))
    out = sp.Integer(0)
    for s in sorted(expr.free_symbols, key=sp.default_sort_key):
        if s in M.JET:
            out += diff(expr, s) * M.JET[s]
        elif s not in M.PARAMS:
            raise ValueError(f"no time derivative known for {s}")
    return out


def dot(a, b):
    return (a.T * b)[0, 0]


def is_zero(e):
    return sp.expand(e) == 0


def check_zero(mat, what):
    bad = [e for e in mat if not is_zero(e)]
    if bad:
        raise AssertionError(f"structure check failed: {what} (e.g. {bad[0]})")


def inertia_solve(M, b):
    """I^-1 b: entrywise for a diagonal inertia, else with the model's I^-1."""
    if M.inertia_diagonal:
        return sp.Matrix([b[i] / M.INERTIA[i, i] for i in range(M.n)])
    return M.INERTIA_INV * b


def is_diagonal(A):
    return all(is_zero(A[i, j]) for i in range(A.rows) for j in range(A.cols) if i != j)


def block_inverse(M, A, what):
    """The inverse of a block of the top-derivative system that is diagonal (inverted
    entrywise) or a scalar multiple s I of the inertia (inverse s^-1 I^-1, with I^-1 the
    model's, symbolic or derived constants). Raises for any other structure."""
    if is_diagonal(A):
        return sp.diag(*[1 / A[i, i] for i in range(A.rows)])
    i, j = next((i, j) for i in range(A.rows) for j in range(A.cols)
                if not is_zero(M.INERTIA[i, j]))
    s = sp.cancel(A[i, j] / M.INERTIA[i, j])
    check_zero(A - s * M.INERTIA, f"{what} is diagonal or a scalar multiple of the inertia")
    return M.INERTIA_INV / s


# ---------------------------------------------------------------------------------------------
# 1. Suslov's pure equations


class Suslov:
    """lambda, q and Omega_dot for the model's Lagrangian and constraint."""

    def __init__(self, M):
        self.M = M
        Om, OmDot, xi, xiDot = M.Om, M.OmDot, M.xi, M.xiDot
        lam = sp.Symbol("lambda_", real=True)
        l = M.body_lagrangian(Om)
        mom = grad(l, Om)  # dl/dOm = I Om
        check_zero(mom.jacobian(Om) - M.INERTIA, "d2l/dOm2 is the inertia")
        dmom = mom.jacobian(Om) * OmDot  # d/dt (dl/dOm)
        phi = M.constraint(Om, xi)
        gphi_om = grad(phi, Om)  # = xi
        # Lagrange-d'Alembert with variations <xi, eta> = 0: the constraint force is lam xi.
        check_zero(gphi_om - xi, "dphi/dOm = xi (the constraint is <xi, Omega> = gamma(xi))")
        gphi_xi = grad(phi, xi)  # = Om - grad gamma
        self.ad_star_mom = M.ad_star(Om, mom)  # ad*_Om (I Om)
        # Euler-Poincare-Suslov: d/dt mom = ad*_Om mom + lam * xi; solve for Om_dot.
        omdot_of_lam = inertia_solve(M, self.ad_star_mom + lam * gphi_om)
        # The constraint is preserved: d/dt phi = <gphi_om, Om_dot> + <gphi_xi, xi_dot> = 0.
        dphi = dot(gphi_om, omdot_of_lam) + dot(gphi_xi, xiDot)
        den = sp.expand(sp.diff(dphi, lam))
        if sp.diff(dphi, lam, 2) != 0:
            raise AssertionError("d/dt phi is not linear in lambda")
        rest = sp.expand(dphi.subs(lam, 0))
        self.lam_num = -rest  # lambda = lam_num / den
        self.den = den
        self.lam = self.lam_num / den
        self.mom = mom
        self.gphi_om = gphi_om
        self.gphi_xi = gphi_xi
        # q = den * (d/dt mom - mom x Om - lambda gphi_om): polynomial in the jets.
        self.q = (den * (dmom - self.ad_star_mom) - self.lam_num * gphi_om).applyfunc(sp.expand)
        # Om_dot = I^-1 (ad*_Om I Om + lambda xi) in structured form, which is what the
        # generated code evaluates (lambda as a named quantity).
        self.lam_symbol = lam
        self.omdot_of_lam = omdot_of_lam
        self._omega_dot = None

    @property
    def omega_dot(self):
        """Om_dot solved from q = 0 (linear in Om_dot, coefficient den I) as cancelled
        rational functions: an independent route to the same Om_dot, for tests (slow for
        large n, hence on demand)."""
        if self._omega_dot is None:
            M = self.M
            A, b = sp.linear_eq_to_matrix(list(self.q), list(M.OmDot))
            self._omega_dot = (block_inverse(M, A, "dq/dOm_dot") * b).applyfunc(sp.cancel)
        return self._omega_dot

    def let_omega_dot(self, prog):
        """Append lambda and Om_dot to a program; return Om_dot's symbols."""
        lam = prog.let("lam", self.lam)
        return prog.let(list(self.M.OmDot), self.omdot_of_lam.subs(self.lam_symbol, lam))


# ---------------------------------------------------------------------------------------------
# 2.-3. The optimality system


class Optimality:
    """Euler-Lagrange equations of C + <kappa, q> and their explicit first-order form."""

    def __init__(self, M):
        self.M = M
        s = Suslov(M)
        self.suslov = s
        C = M.cost(M.Om, M.OmDot, M.xi, M.xiDot, M.Om_d)
        self.C = C
        q = s.q
        L = C + dot(M.kappa, q)
        self.L = L
        self.p_om = grad(L, M.OmDot)  # momentum conjugate to Om
        self.p_xi = grad(L, M.xiDot)  # momentum conjugate to xi
        self.el_om = grad(L, M.Om) - total_derivative(M, self.p_om)
        self.el_xi = grad(L, M.xi) - total_derivative(M, self.p_xi)
        self.dq = total_derivative(M, q)
        z = [list(M.OmDDot), list(M.xiDDot), list(M.kappaDot)]
        eqs = [self.dq, self.el_om, self.el_xi]
        flat = [v for zz in z for v in zz]
        blocks = [[jacobian(e, zz) for zz in z] for e in eqs]
        for row in blocks:
            for blk in row:
                for entry in blk:
                    if entry.free_symbols & set(flat):
                        raise AssertionError("top-derivative system is not linear")
        zero = {v: 0 for v in flat}
        rhs = [-e.xreplace(zero) for e in eqs]
        (M11, M12, M13), (M21, M22, M23), (M31, M32, M33) = blocks
        check_zero(M13, "d/dt q does not contain kappa'")
        check_zero(M22, "EL_Om does not contain xi''")
        check_zero(M31, "EL_xi does not contain Om''")
        m = M32[0, 0]
        check_zero(M32 - m * sp.eye(M.n), "EL_xi's xi'' block is a multiple of the identity")
        # xi'' enters d/dt q only through s = <v, xi''>, v = dphi/dxi: M12 = u v^T.
        v = s.gphi_xi
        j = next(i for i in range(M.n) if v[i] != 0)
        u = (M12[:, j] / v[j]).applyfunc(sp.cancel)
        check_zero(M12 - u * v.T, "M12 is rank one with row space dphi/dxi")
        self.blocks = blocks
        self.rhs = rhs
        self.m = m
        self.u = u
        self.v = v
        self.M11inv = block_inverse(M, M11, "M11 (Om'' in d/dt q)")
        self.M23inv = block_inverse(M, M23, "M23 (kappa' in EL_Om)")
        self.M21 = M21
        self.M33 = M33

    def rhs_program(self, prog):
        """Append the explicit right-hand side f(y) to `prog`; return f as a list of symbols.

        Assignments, in order: Om_dot (from q = 0); Om'' = a - b s (from d/dt q = 0, named
        oa, ob); kappa' = c + e s (from EL_Om, named ka, kb); h, w with (m I + w v^T) xi'' = h
        (from EL_xi, named sh, sw); s = <v, h>/(m + <v, w>) (sm) and xi'' = (h - w s)/m
        (Sherman-Morrison); kappa'. The internal names are reserved (model.RESERVED).
        """
        s, M = self.suslov, self.M
        r1, r2, r3 = self.rhs
        om_dot = s.let_omega_dot(prog)
        a1 = prog.let("oa", self.M11inv * r1)
        b1 = prog.let("ob", self.M11inv * self.u)
        c0 = prog.let("ka", self.M23inv * (r2 - self.M21 * a1))
        c1 = prog.let("kb", self.M23inv * self.M21 * b1)
        h = prog.let("sh", r3 - self.M33 * c0)
        w = prog.let("sw", self.M33 * c1)
        # (m I + w v^T) xi'' = h  =>  s = <v, xi''> = <v, h> / (m + <v, w>)
        sm = prog.let("sm", dot(self.v, h) / (self.m + dot(self.v, w)))
        xi_dd = prog.let(list(M.xiDDot), (h - w * sm) / self.m)
        kappa_dot = prog.let(list(M.kappaDot), c0 + c1 * sm)
        return list(om_dot) + list(M.xiDot) + list(xi_dd) + list(kappa_dot), a1, b1, sm

    def direct_top_derivatives(self):
        """(Matrix, rhs) of the full 3n x 3n linear system in z, for cross-checks."""
        A = sp.BlockMatrix(self.blocks).as_explicit()
        b = sp.Matrix.vstack(*self.rhs)
        return A, b


# ---------------------------------------------------------------------------------------------
# 4. Boundary quantities (all evaluated on-shell: Om_dot = F(Om, xi, xi_dot), so q = 0)


def onshell_program(opt, inputs):
    """A program whose first assignments are Om_dot = F(Om, xi, xi_dot)."""
    prog = Program(inputs, opt.M.PARAMS)
    opt.suslov.let_omega_dot(prog)
    return prog


def natural_bc(opt):
    """p_xi = dL/dxi_dot, which must vanish where xi is free (both ends)."""
    return opt.p_xi


def energy_function(opt):
    """E = <p_Om, Om_dot> + <p_xi, xi_dot> - L (the Hamiltonian of the augmented Lagrangian)."""
    return dot(opt.p_om, opt.M.OmDot) + dot(opt.p_xi, opt.M.xiDot) - opt.L


def free_time_condition(opt):
    """Transversality for free b: E(b) = 0. Returned in the paper's sign and simplified form
    -E + <p_xi, xi_dot> - <kappa, q> = C - <p_Om, Om_dot>, i.e. with the terms dropped that
    vanish by the other right conditions (p_xi(b) = 0) and on-shell (q = 0)."""
    return opt.C - dot(opt.p_om, opt.M.OmDot)


def classical_costates(opt):
    """pi = -[p_Om; p_xi] (costates of the classical 6-state Hamiltonian formulation)."""
    return -sp.Matrix.vstack(opt.p_om, opt.p_xi)


# ---------------------------------------------------------------------------------------------
# Section 5.1: the analytic singular solution


def singular_xi(opt):
    """xi~ = d/dt(dl/dOm) - ad*_Om (dl/dOm) = I Om' - ad*_Om I Om (the constraint force
    lambda xi of the Euler-Poincare-Suslov equation) for a given Om_p with derivative Om_p';
    xi_p = xi~/|xi~| is the singular control (section 5.1, for gamma = 0)."""
    s = opt.suslov
    return s.mom.jacobian(opt.M.Om) * opt.M.OmDot - s.ad_star_mom


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

    W = sp.Symbol("w", real=True)  # weight of the cost in the point Lagrangian

    def __init__(self, opt):
        M = self.M = opt.M
        self.Z = list(M.Om) + list(M.xi) + list(M.xiDot)
        # multipliers of the 2n dynamics rows
        self.LAM = list(sp.symbols(f"lam1:{2 * M.n + 1}", real=True))
        self.suslov = opt.suslov
        self.C = opt.C  # in Om, OmDot, xi, xiDot, Om_d; OmDot is assigned on-shell below

    def program(self, extra_inputs=()):
        """A program over z, Om_d (and `extra_inputs`) whose first assignments are
        lambda and Om_dot = F(z). Returns (program, f) with f the 6 dynamics entries."""
        M = self.M
        prog = Program(self.Z + list(M.Om_d) + list(extra_inputs), M.PARAMS)
        om_dot = self.suslov.let_omega_dot(prog)
        return prog, list(om_dot) + list(M.xiDot)

    def dynamics_jacobian(self, prog, f):
        """df/dz, 2n x 3n."""
        return prog.jacobian(f, self.Z)

    def cost_gradient(self, prog):
        """(dL/dz, dL/dOm_d) as column matrices (3n, n)."""
        J = prog.jacobian([self.C], self.Z + list(self.M.Om_d))
        nz = len(self.Z)
        return J[0, :nz].T, J[0, nz:].T

    def lagrangian_hessian(self, prog, f, check_points=3, seed=7, extra=0):
        """The Hessian of l = w L + <lam, f> (+ `extra`) w.r.t. v = [z, Om_d], symmetric.

        Forward over forward: the gradient is a Jacobian through the program (prefix d), the
        Hessian the Jacobian of that gradient (prefix dd). H[i][j] = d/dv_j (dl/dv_i) and
        H[j][i] are different expressions of the same number: they are compared at seeded
        points (mpmath, 40 digits) and the upper triangle is returned mirrored, so that the
        emitted Hessian is symmetric to the last bit.
        """
        M = self.M
        v = self.Z + list(M.Om_d)
        ell = self.W * self.C + sum(l * e for l, e in zip(self.LAM, f)) + extra
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


class MultiplierTranscription(DirectTranscription):
    """The OCP with the constraint force's multiplier as a control (the unreduced form).

    State x = [Om, xi], control u = [xi_dot, lambda], z = [Om, xi, xi_dot, lambda] (`Z`).
    Dynamics f(z) = [I^-1 (ad*_Om I Om + lambda xi); xi_dot] (Euler-Poincare-Suslov with the
    force lambda xi, no division: polynomial in z, defined at xi = 0); running cost
    L(z, Om_d) = C(Om, f_Om, xi, xi_dot, Om_d). The constraint is not built into f: the
    transcription imposes it at the points as the path constraint g(z) = phi = <Om, xi> -
    gamma(xi). (Imposing d/dt phi = 0 instead lets the discrete solution drift off phi = 0, and
    the optimizer exploits the drift: on the paper's fixed-time problem its discrete minimum
    was 11.72 against the true 13.12; tests/direct_forms.rs.) The Hessian is that of
    l = w L + <lam, f> + mu g.

    With lambda free and phi = 0 imposed, xi may pass through 0 (lambda xi stays finite), which
    the lambda-eliminated form (`DirectTranscription`, singular where <xi, I^-1 xi> = 0)
    cannot represent; this is the formulation of bench/casadi_direct.py.
    """

    def __init__(self, opt):
        super().__init__(opt)
        M = self.M
        self.LAMBDA = self.suslov.lam_symbol
        self.Z = list(M.Om) + list(M.xi) + list(M.xiDot) + [self.LAMBDA]
        self.MU = [sp.Symbol("mu", real=True)]  # multiplier of phi

    def program(self, extra_inputs=()):
        """A program over z, Om_d (and `extra_inputs`) whose first assignments are
        Om_dot = f_Om(z). Returns (program, f) with f the 2n dynamics entries."""
        M = self.M
        prog = Program(self.Z + list(M.Om_d) + list(extra_inputs), M.PARAMS)
        om_dot = prog.let(list(M.OmDot), self.suslov.omdot_of_lam)
        return prog, list(om_dot) + list(M.xiDot)

    def path(self):
        """g(z) = [phi]."""
        return [self.M.constraint(self.M.Om, self.M.xi)]

    def lagrangian_hessian(self, prog, f, check_points=3, seed=7):
        """As `DirectTranscription.lagrangian_hessian`, with <mu, g> in the point Lagrangian."""
        return super().lagrangian_hessian(prog, list(f), check_points, seed,
                                          extra=sum(m * g for m, g in zip(self.MU, self.path())))


class RelaxedTranscription(DirectTranscription):
    """The limit xi -> 0 of the multiplier form: the relaxed problem whose minimum is the
    infimum approached by controls with a vanishing xi (docs/collapse.md).

    Along xi = eps d(t) with <Om, d> = 0 (a vanishing constraint value), the force lambda xi
    stays finite as eps -> 0 (lambda ~ 1/eps): in the limit it is a torque tau with
    <Om, tau> = 0, free otherwise, and the cost's control terms take their values at
    xi = xi' = 0. State x = Om, control u = tau, z = [Om, tau] (`Z`); dynamics
    f(z) = I^-1 (ad*_Om I Om + tau) (the multiplier form's with lambda xi -> tau); path
    constraint g(z) = <Om, tau> = 0 at every point (the force does no work: the kinetic
    energy is conserved); running cost L(z, Om_d) = C(Om, f, 0, 0, Om_d). Every motion on
    the energy level set is reachable, and a relaxed minimum's cost is the limit of the
    costs of admissible controls xi = eps tau/|tau|. Valid where the constraint value
    vanishes (callers check it at run time). The Hessian is that of
    l = w L + <lam, f> + mu g.
    """

    def __init__(self, opt):
        super().__init__(opt)
        M = self.M
        self.TAU = list(sp.symbols(f"tau1:{M.n + 1}", real=True))
        self.Z = list(M.Om) + self.TAU
        self.LAM = list(sp.symbols(f"lam1:{M.n + 1}", real=True))
        self.MU = [sp.Symbol("mu", real=True)]
        zero = {s: 0 for s in list(M.xi) + list(M.xiDot)}
        self.C = opt.C.subs(zero, simultaneous=True)
        # The same force as the multiplier form's: lambda dphi/dOm = lambda xi (asserted in
        # `Suslov`), here with lambda xi -> tau.
        self.omdot = inertia_solve(M, self.suslov.ad_star_mom + sp.Matrix(self.TAU))
        check_zero(self.omdot.subs(dict(zip(self.TAU, self.suslov.lam_symbol * M.xi)),
                                   simultaneous=True) - self.suslov.omdot_of_lam,
                   "the relaxed dynamics are the multiplier form's with lambda xi -> tau")

    def program(self, extra_inputs=()):
        """A program over z, Om_d (and `extra_inputs`) whose first assignments are
        Om_dot = f(z). Returns (program, f) with f the n dynamics entries."""
        M = self.M
        prog = Program(self.Z + list(M.Om_d) + list(extra_inputs), M.PARAMS)
        om_dot = prog.let(list(M.OmDot), self.omdot)
        return prog, list(om_dot)

    def dynamics_jacobian(self, prog, f):
        """df/dz, n x 2n."""
        return prog.jacobian(f, self.Z)

    def path(self):
        """g(z) = [<Om, tau>]."""
        return [dot(self.M.Om, sp.Matrix(self.TAU))]

    def lagrangian_hessian(self, prog, f, check_points=3, seed=7):
        """As `DirectTranscription.lagrangian_hessian`, with <mu, g> in the point Lagrangian."""
        return super().lagrangian_hessian(prog, list(f), check_points, seed,
                                          extra=sum(m * g for m, g in zip(self.MU, self.path())))
