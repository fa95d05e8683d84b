#!/usr/bin/env python3
"""Generate the Rust models from codegen/models/*.py: `python3 codegen/generate.py --out DIR`.

Writes, deterministically (run with PYTHONHASHSEED=0; build.rs does), for each model NAME:
  DIR/NAME_model.rs     the generated functions and metadata
  DIR/NAME_vectors.rs   `check_vectors`: sympy-evaluated outputs at seeded sample points
  DIR/NAME_formulas.txt the derived formulas in readable form (guarded by an insta snapshot)
and DIR/models.rs, one module per model (included by src/model/mod.rs).

Exit status 3 means the environment is wrong (sympy missing or not the pinned version).
"""

import argparse
import hashlib
import json
import os
import random
import sys
from types import SimpleNamespace

HERE = os.path.dirname(os.path.abspath(__file__))


def pinned_sympy():
    with open(os.path.join(HERE, "requirements.txt")) as fh:
        for line in fh:
            line = line.split("#")[0].strip()
            if line.lower().startswith("sympy=="):
                return line.split("==")[1].strip()
    raise SystemExit("codegen/requirements.txt does not pin sympy")


def source_hash(model=None):
    """sha256 over the codegen sources (top-level *.py, models/*.py and requirements.txt),
    sorted by relative path ("/"-separated). With `model`, over the top-level sources and that
    model's file only: the per-model hash recorded in its generated file and cache key.

    build.rs computes the same (all-models) hash to decide whether a committed copy is
    current."""
    h = hashlib.sha256()
    names = [n for n in os.listdir(HERE) if n.endswith(".py") or n == "requirements.txt"]
    names += ["models/" + n for n in os.listdir(os.path.join(HERE, "models"))
              if n.endswith(".py") and (model is None or n == f"{model}.py")]
    for n in sorted(names):
        with open(os.path.join(HERE, n), "rb") as fh:
            data = fh.read()
        h.update(n.encode() + b"\0" + data + b"\0")
    return h.hexdigest()


# sympy's cache is an LRU of 1000 entries by default, which the derivation of the larger models
# overflows over and over: unbounded, generation takes about 10% less CPU (memory stays near
# 300 MB for so4). The cache only returns equal objects sooner, so the output does not depend on
# its size. Read when sympy is imported, hence set here; an explicit setting is kept.
os.environ.setdefault("SYMPY_CACHE_SIZE", "None")

try:
    import sympy as sp
except ImportError:
    sys.stderr.write("sympy is not installed: pip install -r codegen/requirements.txt\n")
    sys.exit(3)

if sp.__version__ != pinned_sympy():
    sys.stderr.write(f"sympy {sp.__version__} found, {pinned_sympy()} pinned: "
                     "pip install -r codegen/requirements.txt\n")
    sys.exit(3)

sys.path.insert(0, HERE)
import control as CTRL  # noqa: E402
import derive as D  # noqa: E402
import model as MODEL  # noqa: E402
from emit_rust import Arg, Function, Out, Scalar, emit_function, emit_vector_checks, \
    flat_outputs, impl_text, trait_text  # noqa: E402
from slp import Program  # noqa: E402

T_SPAN = sp.Symbol("t_span", positive=True)
S_NORM = sp.Symbol("s", real=True)


def u(lo, hi):
    return lambda rng, i: rng.uniform(lo, hi)


def state_sampler(n):
    def sample(rng, i):
        if n <= i < 2 * n:  # xi: keep away from 0 (Suslov's equations need xi != 0)
            return rng.choice([-1, 1]) * rng.uniform(0.4, 1.6)
        return rng.uniform(-2.0, 2.0)
    return sample


def param_sampler(M):
    """Sample the user parameters from the model's ranges; derived constants (I^-1) are
    computed from the sampled inertia (40 digits), so test vectors are consistent."""
    def sample_vector(rng):
        vals = [rng.uniform(*M.sample_range(p)) for p in M.user_params]
        if M.derived:
            sub = {p.symbol: sp.Float(v, 40) for p, v in zip(M.user_params, vals)}
            inv = M.INERTIA.subs(sub).evalf(40).inv()
            vals += [float(inv[i, j]) for _, (i, j) in M.derived]
        return vals
    return sample_vector


def args_common(M):
    names = ", ".join(str(s) for s in M.PARAMS)
    return (
        Arg("y", M.STATE, "the state [Omega, xi, xi_dot, kappa]", state_sampler(M.n)),
        Arg("p", M.PARAMS, f"the constants [{names}]", None, param_sampler(M)),
        Arg("w", list(M.Om_d) + list(M.Om_dDot),
            "the desired path at this time [Omega_d, Omega_d']", u(-2.0, 2.0)),
    )


def build_functions(opt):
    M = opt.M
    n, ny = M.n, len(M.STATE)
    state_sample = state_sampler(n)
    OMA = MODEL.vec("OmEnd", n)
    fns = []
    y_arg, p_arg, w_arg = args_common(M)
    inputs = M.STATE + list(M.Om_d) + list(M.Om_dDot)

    # ---- ODE right-hand side, physical time --------------------------------------------
    prog = Program(inputs, M.PARAMS)
    f, *_ = opt.rhs_program(prog)
    fns.append(Function(
        "ode_rhs",
        "The optimality system dy/dt = f(y, Omega_d) in physical time: Omega' from Suslov's\n"
        "equations (q = 0), xi'' by Sherman-Morrison, kappa' from the Euler-Lagrange\n"
        "equation in Omega (paper eq. p_sys_explicit).",
        prog, [y_arg, p_arg, w_arg], [Out("out", sp.Matrix(f), "array", f"f(y), {ny} entries")]))

    # ---- scaled to s in [0, 1], t = a + s T -------------------------------------------
    prog = Program(inputs, M.PARAMS + [T_SPAN, S_NORM])
    f, *_ = opt.rhs_program(prog)
    t_arg = Scalar(T_SPAN, "T = b - a, the length of the time interval", u(1.0, 12.0))
    s_arg = Scalar(S_NORM, "normalized time s = (t - a)/T in [0, 1]", u(0.0, 1.0))
    fns.append(Function(
        "ode_rhs_scaled",
        "The optimality system on normalized time: dy/ds = T f(y, Omega_d(a + s T)).",
        prog, [y_arg, p_arg, w_arg, t_arg],
        [Out("out", sp.Matrix([T_SPAN * e for e in f]), "array", "T f(y)")]))

    prog = Program(inputs, M.PARAMS + [T_SPAN, S_NORM])
    f, *_ = opt.rhs_program(prog)
    J = prog.jacobian(f, M.STATE + list(M.Om_d))
    Jy = J[:, :ny] * T_SPAN
    dT = sp.Matrix([f[i] + T_SPAN * S_NORM * sum(J[i, ny + k] * M.Om_dDot[k] for k in range(n))
                    for i in range(ny)])
    fns.append(Function(
        "ode_jac_scaled",
        "Jacobians of the scaled system g(s, y, T) = T f(y, Omega_d(a + s T)):\n"
        "dg/dy = T df/dy and dg/dT = f + T s (df/dOmega_d) Omega_d'.",
        prog, [y_arg, p_arg, w_arg, t_arg, s_arg],
        [Out("dgdy", Jy, "matrix", "dg/dy, row-major: `dgdy[i][j]` = d g_i / d y_j"),
         Out("dgdt", dT, "array", "dg/dT")]))

    # ---- boundary conditions -------------------------------------------------------------
    ep_inputs = M.STATE + list(OMA)
    end_arg = Arg("omega_end", list(OMA), "the prescribed Omega at this end", u(-2.0, 2.0))
    prog = D.onshell_program(opt, ep_inputs)
    bc = list(M.Om - OMA) + list(D.natural_bc(opt))
    fns.append(Function(
        "bc_endpoint",
        "Boundary conditions at either end (paper eqs. p_lbc, p_rbc): Omega = Omega_end and\n"
        "the natural condition p_xi = dL/dxi' = <kappa, xi> Omega + beta xi' = 0 (xi is free).",
        prog, [y_arg, p_arg, end_arg],
        [Out("out", sp.Matrix(bc), "array", f"the {len(bc)} residuals")]))
    prog = D.onshell_program(opt, ep_inputs)
    Jbc = prog.jacobian(bc, M.STATE)
    fns.append(Function(
        "bc_endpoint_jac", "Jacobian of `bc_endpoint` with respect to the state y.",
        prog, [y_arg, p_arg, end_arg],
        [Out("d_y", Jbc, "matrix", "d residual_i / d y_j")]))

    # ---- the constraint, and the start conditions that impose it ---------------------------
    # phi = <Omega, xi> - gamma(xi) is conserved by Suslov's equations (lambda is chosen so),
    # but its value is set by the initial data. With gamma = 0 the paper's conditions above
    # select phi = 0 (the energy at b then matches; src/lie/problem.rs); with a constraint
    # value they do not, and the start imposes phi(a) = 0 with a multiplier mu: xi(a) is free
    # on {phi = 0}, so the natural condition becomes p_xi(a) = mu dphi/dxi.
    cx_syms = list(M.Om) + list(M.xi)
    phi = M.constraint(M.Om, M.xi)
    prog = Program(cx_syms, M.PARAMS)
    gphi = prog.jacobian([phi], cx_syms)
    fns.append(Function(
        "constraint_residual",
        "The constraint phi(Omega, xi) = <Omega, xi> - gamma(xi) (zero on the constraint\n"
        "manifold) and its gradient with respect to [Omega, xi].",
        prog, [Arg("x", cx_syms, "[Omega, xi]", state_sample), p_arg],
        [Out("d_x", gphi.T, "array", f"dphi/d[Omega, xi], {2 * n} entries"),
         Out("value", phi, "return", "phi")]))
    mu = sp.Symbol("mu", real=True)
    mu_arg = Scalar(mu, "the multiplier of the start constraint phi(a) = 0", u(-2.0, 2.0))
    gphi_xi = sp.Matrix([sp.diff(phi, s) for s in M.xi])
    bcs = list(M.Om - OMA) + list(D.natural_bc(opt) - mu * gphi_xi) + [phi]
    prog = Program(ep_inputs, M.PARAMS + [mu])
    opt.suslov.let_omega_dot(prog)
    fns.append(Function(
        "bc_start_constrained",
        "Start conditions of a model with a constraint value: Omega = Omega_end, the natural\n"
        "condition on {phi = 0}, p_xi - mu dphi/dxi = 0, and phi = 0 itself (2n + 1 rows).",
        prog, [y_arg, p_arg, end_arg, mu_arg],
        [Out("out", sp.Matrix(bcs), "array", f"the {len(bcs)} residuals")]))
    prog = Program(ep_inputs, M.PARAMS + [mu])
    opt.suslov.let_omega_dot(prog)
    Jbs = prog.jacobian(bcs, M.STATE)
    d_mu = sp.Matrix([0] * n + list(-gphi_xi) + [0])
    fns.append(Function(
        "bc_start_constrained_jac",
        "Jacobians of `bc_start_constrained` with respect to the state y and to mu.",
        prog, [y_arg, p_arg, end_arg, mu_arg],
        [Out("d_y", Jbs, "matrix", "d residual_i / d y_j"),
         Out("d_mu", d_mu, "array", "d residual_i / d mu")]))

    wb_arg = Arg("wb", list(M.Om_d) + list(M.Om_dDot),
                 "the desired path at the terminal time [Omega_d(b), Omega_d'(b)]", u(-2.0, 2.0))
    ftc = D.free_time_condition(opt)
    prog = D.onshell_program(opt, inputs)
    fns.append(Function(
        "free_time_condition",
        "Transversality condition for a free terminal time (paper eq. p_rbc, third line):\n"
        "C - <p_Omega, Omega'> at t = b, with p_Omega = dL/dOmega'. Vanishes at the optimum.",
        prog, [y_arg, p_arg, wb_arg], [Out("value", ftc, "return", "the residual")]))
    prog = D.onshell_program(opt, inputs)
    Jf = prog.jacobian([ftc], M.STATE + list(M.Om_d))
    d_t = sum(Jf[0, ny + k] * M.Om_dDot[k] for k in range(n))
    fns.append(Function(
        "free_time_condition_jac",
        "Gradient of `free_time_condition` w.r.t. y(b), and its derivative w.r.t. T = b - a\n"
        "through Omega_d(b) (returned).",
        prog, [y_arg, p_arg, wb_arg],
        [Out("d_y", sp.Matrix(Jf[0, :ny]), "array", "d/dy(b)"),
         Out("d_t", d_t, "return", "d/dT")]))

    time_weight = next(p for p in M.weights if p.role == "time")
    prog = D.onshell_program(opt, inputs)
    fns.append(Function(
        "delta_start",
        "The delta that makes the free-time condition hold at the current terminal state\n"
        "(paper eq. delta_c_rbc): the start of the delta continuation stage.",
        prog, [y_arg, p_arg, wb_arg],
        [Out("value", -ftc.subs(time_weight.symbol, 0), "return", "delta_c")]))

    prog = D.onshell_program(opt, inputs)
    fns.append(Function(
        "cost_integrand", "The running cost C on a solution (Omega' = F(Omega, xi, xi')).",
        prog, [y_arg, p_arg, w_arg], [Out("value", opt.C, "return", "C")]))

    prog = D.onshell_program(opt, inputs)
    fns.append(Function(
        "energy_function",
        "E = <p_Omega, Omega'> + <p_xi, xi'> - L on a solution. Along solutions\n"
        "dE/dt = -dC/dt|explicit = gamma <Omega - Omega_d, Omega_d'> (a check of the system).",
        prog, [y_arg, p_arg, w_arg], [Out("value", D.energy_function(opt), "return", "E")]))

    prog = D.onshell_program(opt, inputs)
    fns.append(Function(
        "classical_costates",
        "The costates pi of the classical Hamiltonian formulation (state [Omega, xi]),\n"
        "pi = -[p_Omega; p_xi] (paper, after eq. red_Hamiltonian).",
        prog, [y_arg, p_arg, w_arg],
        [Out("out", D.classical_costates(opt), "array", f"pi, {2 * n} entries")]))

    # ---- Suslov's pure equations ----------------------------------------------------------
    x_syms = list(M.Om) + list(M.xi) + list(M.xiDot)
    x_arg = Arg("x", x_syms, "[Omega, xi, xi']", state_sample)
    prog = Program(x_syms, M.PARAMS)
    om_dot = opt.suslov.let_omega_dot(prog)
    fns.append(Function(
        "suslov_omega_dot",
        "Suslov's pure equations: Omega' = I^-1 [ad*_Omega (I Omega) + lambda xi] with the\n"
        "multiplier lambda (eqs. Suslov_eq_3D, Suslov_lambda), for a given control xi(t).",
        prog, [x_arg, p_arg],
        [Out("out", om_dot, "array", "Omega'"),
         Out("lambda", sp.Symbol("lam", real=True), "return", "lambda")]))
    q_syms = list(M.Om) + list(M.OmDot) + list(M.xi) + list(M.xiDot)
    prog = Program(q_syms, M.PARAMS)
    fns.append(Function(
        "suslov_q",
        "Suslov's residual q(Omega, Omega', xi, xi') (eq. Suslov_q); zero on solutions.",
        prog, [Arg("x", q_syms, "[Omega, Omega', xi, xi']", u(-2.0, 2.0)), p_arg],
        [Out("out", opt.suslov.q, "array", "q")]))

    # ---- the analytic singular solution (section 5.1) ------------------------------------
    sp_syms = list(M.Om) + list(M.OmDot) + list(M.OmDDot)
    prog = Program(sp_syms, M.PARAMS)
    xt = prog.let("xt", D.singular_xi(opt))
    nrm = prog.let("xtn", sp.sqrt(sum(e ** 2 for e in xt)))
    xi_p = prog.let("xip", xt / nrm)
    dxt = D.total_derivative(M, D.singular_xi(opt))
    dxt_s = prog.let("dxt", dxt)
    xi_p_dot = (dxt_s - xi_p * sum(a * b for a, b in zip(xi_p, dxt_s))) / nrm
    fns.append(Function(
        "singular_control",
        "The analytic singular solution's control (paper eq. xi_p_eq): xi_p = xi~/|xi~| with\n"
        "xi~ = I Omega_p' - ad*_Omega_p (I Omega_p), and its derivative xi_p'. Requires\n"
        "|xi~| > 0 (Property 3).",
        prog, [Arg("omega_p", sp_syms, "[Omega_p, Omega_p', Omega_p'']", u(-2.0, 2.0)), p_arg],
        [Out("out", sp.Matrix(list(xi_p) + list(xi_p_dot)), "array", "[xi_p, xi_p']")]))

    # ---- controllability of the pure equations (section 4.3, codegen/control.py) ---------
    aff = CTRL.AffineSystem(opt.suslov)
    cx_arg = Arg("x", aff.X, "the state [Omega, xi] (xi != 0)", state_sample)
    prog, rows, brackets = aff.program()
    field_names = ", ".join(["f"] + [f"g{i + 1}" for i in range(n)])
    fns.append(Function(
        "control_fields",
        "Suslov's pure equations as a control-affine system x' = f(x) + sum_i g_i(x) u_i with\n"
        "x = [Omega, xi], u = xi' (paper eqs. state_eqns, state_f, state_gi): g_i = dx'/du_i,\n"
        "f = x' at u = 0.",
        prog, [cx_arg, p_arg],
        [Out("out", sp.Matrix(rows), "matrix",
             f"rows {field_names}; `out[k][j]` = component j of field k")]))
    pair_names = ", ".join(f"[g{i + 1}, g{j + 1}]" for i, j in aff.PAIRS)
    fns.append(Function(
        "lie_brackets",
        "The Lie brackets [g_i, g_j] = (Dg_j) g_i - (Dg_i) g_j (i < j) of the control fields of\n"
        "`control_fields` (for so(3): the last three columns of the paper's matrix V, eq. Veqn),\n"
        "Dg by forward mode through the program.",
        prog, [cx_arg, p_arg],
        [Out("out", sp.Matrix(brackets), "matrix",
             f"rows {pair_names}; `out[k][j]` = component j")]))

    # ---- direct transcription: classical state/control form (derive.DirectTranscription) --
    dt = D.DirectTranscription(opt)
    z_arg = Arg("z", dt.Z, "[x, u] = [Omega, xi, xi'] (state x = [Omega, xi], control u = xi')",
                state_sample)
    od_arg = Arg("od", list(M.Om_d), "the desired Omega_d at this time", u(-2.0, 2.0))
    prog, f = dt.program()
    fns.append(Function(
        "direct_dynamics",
        "The dynamics of the direct transcription, x' = f(z) = [F(Omega, xi, xi'); xi'] with F\n"
        "Suslov's Omega' (as `suslov_omega_dot`), and its Jacobian df/dz.",
        prog, [z_arg, p_arg],
        [Out("f", sp.Matrix(f), "array", f"f(z), {len(f)} entries"),
         Out("f_z", dt.dynamics_jacobian(prog, f), "matrix",
             "df/dz, row-major: `f_z[i][j]` = d f_i / d z_j")]))
    prog, f = dt.program()
    l_z, l_d = dt.cost_gradient(prog)
    fns.append(Function(
        "direct_cost",
        "The running cost of the direct transcription, L(z, Omega_d) = C(Omega, F, xi, xi',\n"
        "Omega_d) (the cost integrand with Omega' = F; as `cost_integrand`), and its gradients.",
        prog, [z_arg, p_arg, od_arg],
        [Out("l_z", l_z, "array", "dL/dz"),
         Out("l_d", l_d, "array", "dL/dOmega_d"),
         Out("value", dt.C, "return", "L")]))
    prog, f = dt.program([dt.W] + dt.LAM)
    H = dt.lagrangian_hessian(prog, f)
    nz = len(dt.Z)
    fns.append(Function(
        "direct_hessian",
        "Second derivatives of the point Lagrangian l = w L(z, Omega_d) + sum_i lam_i f_i(z) of\n"
        "the direct transcription (f does not depend on Omega_d). Exactly symmetric.",
        prog, [z_arg, p_arg, od_arg,
               Scalar(dt.W, "the weight w of the running cost L", u(0.1, 2.0)),
               Arg("lam", dt.LAM, "the multipliers of the dynamics rows f_i", u(-2.0, 2.0))],
        [Out("h_zz", H[:nz, :nz], "matrix", "d2l/dz2, `h_zz[i][j]` = d2 l / dz_i dz_j"),
         Out("h_zd", H[:nz, nz:], "matrix",
             "d2l/dz dOmega_d, `h_zd[i][k]` = d2 l / dz_i dOmega_d_k"),
         Out("h_dd", H[nz:, nz:], "matrix", "d2l/dOmega_d2")]))

    # ---- the multiplier form: lambda a control, the constraint a path constraint ----------
    mt = D.MultiplierTranscription(opt)

    def lambda_sample(rng, i):
        return rng.uniform(-2.0, 2.0) if i == 3 * n else state_sample(rng, i)

    zl_arg = Arg("z", mt.Z, "[x, u] = [Omega, xi, xi', lambda] (state x = [Omega, xi], control "
                 "u = [xi', lambda])", lambda_sample)
    prog, f = mt.program()
    g = mt.path()
    fg_z = prog.jacobian(list(f) + g, mt.Z)  # one forward pass for f and g
    fns.append(Function(
        "multiplier_dynamics",
        "The dynamics of the multiplier form, x' = f(z) = [I^-1 (ad*_Omega I Omega + lambda xi);\n"
        "xi'] (no division: defined at xi = 0), its Jacobian df/dz, and the path constraint\n"
        "g(z) = phi = <Omega, xi> - gamma(xi) with dg/dz.",
        prog, [zl_arg, p_arg],
        [Out("f", sp.Matrix(f), "array", f"f(z), {len(f)} entries"),
         Out("f_z", fg_z[:len(f), :], "matrix",
             "df/dz, row-major: `f_z[i][j]` = d f_i / d z_j"),
         Out("g", sp.Matrix(g), "array", "g(z) = phi"),
         Out("g_z", fg_z[len(f):, :], "matrix", "dg/dz, row-major")]))
    prog, f = mt.program()
    l_z, l_d = mt.cost_gradient(prog)
    fns.append(Function(
        "multiplier_cost",
        "The running cost of the multiplier form, L(z, Omega_d) = C(Omega, f_Omega, xi, xi',\n"
        "Omega_d), and its gradients.",
        prog, [zl_arg, p_arg, od_arg],
        [Out("l_z", l_z, "array", "dL/dz"),
         Out("l_d", l_d, "array", "dL/dOmega_d"),
         Out("value", mt.C, "return", "L")]))
    prog, f = mt.program([mt.W] + mt.LAM + mt.MU)
    H = mt.lagrangian_hessian(prog, f)
    nzl = len(mt.Z)
    fns.append(Function(
        "multiplier_hessian",
        "Second derivatives of the point Lagrangian l = w L + sum_i lam_i f_i + mu phi of the\n"
        "multiplier form. Exactly symmetric.",
        prog, [zl_arg, p_arg, od_arg,
               Scalar(mt.W, "the weight w of the running cost L", u(0.1, 2.0)),
               Arg("lam", mt.LAM, "the multipliers of the dynamics rows f_i", u(-2.0, 2.0)),
               Arg("mu", mt.MU, "the multiplier of the path constraint phi", u(-2.0, 2.0))],
        [Out("h_zz", H[:nzl, :nzl], "matrix", "d2l/dz2, `h_zz[i][j]` = d2 l / dz_i dz_j"),
         Out("h_zd", H[:nzl, nzl:], "matrix",
             "d2l/dz dOmega_d, `h_zd[i][k]` = d2 l / dz_i dOmega_d_k"),
         Out("h_dd", H[nzl:, nzl:], "matrix", "d2l/dOmega_d2")]))

    # ---- the relaxed form: the limit xi -> 0, a torque tau _|_ Omega as the control --------
    rt = D.RelaxedTranscription(opt)
    zr_arg = Arg("z", rt.Z, "[x, u] = [Omega, tau] (state x = Omega, control u = tau, the "
                 "torque lambda xi in the limit xi -> 0)", u(-2.0, 2.0))
    prog, f = rt.program()
    g = rt.path()
    fg_z = prog.jacobian(list(f) + g, rt.Z)
    fns.append(Function(
        "relaxed_dynamics",
        "The dynamics of the relaxed form (the limit xi -> 0 of the multiplier form),\n"
        "x' = f(z) = I^-1 (ad*_Omega I Omega + tau), its Jacobian df/dz, and the path\n"
        "constraint g(z) = <Omega, tau> with dg/dz.",
        prog, [zr_arg, p_arg],
        [Out("f", sp.Matrix(f), "array", f"f(z), {len(f)} entries"),
         Out("f_z", fg_z[:len(f), :], "matrix",
             "df/dz, row-major: `f_z[i][j]` = d f_i / d z_j"),
         Out("g", sp.Matrix(g), "array", "g(z) = <Omega, tau>"),
         Out("g_z", fg_z[len(f):, :], "matrix", "dg/dz, row-major")]))
    prog, f = rt.program()
    l_z, l_d = rt.cost_gradient(prog)
    fns.append(Function(
        "relaxed_cost",
        "The running cost of the relaxed form, L(z, Omega_d) = C(Omega, f, 0, 0, Omega_d) (the\n"
        "cost integrand with xi = xi' = 0), and its gradients.",
        prog, [zr_arg, p_arg, od_arg],
        [Out("l_z", l_z, "array", "dL/dz"),
         Out("l_d", l_d, "array", "dL/dOmega_d"),
         Out("value", rt.C, "return", "L")]))
    prog, f = rt.program([rt.W] + rt.LAM + rt.MU)
    H = rt.lagrangian_hessian(prog, f)
    nzr = len(rt.Z)
    fns.append(Function(
        "relaxed_hessian",
        "Second derivatives of the point Lagrangian l = w L + sum_i lam_i f_i + mu <Omega, tau>\n"
        "of the relaxed form. Exactly symmetric.",
        prog, [zr_arg, p_arg, od_arg,
               Scalar(rt.W, "the weight w of the running cost L", u(0.1, 2.0)),
               Arg("lam", rt.LAM, "the multipliers of the dynamics rows f_i", u(-2.0, 2.0)),
               Arg("mu", rt.MU, "the multiplier of the path constraint", u(-2.0, 2.0))],
        [Out("h_zz", H[:nzr, :nzr], "matrix", "d2l/dz2, `h_zz[i][j]` = d2 l / dz_i dz_j"),
         Out("h_zd", H[:nzr, nzr:], "matrix",
             "d2l/dz dOmega_d, `h_zd[i][k]` = d2 l / dz_i dOmega_d_k"),
         Out("h_dd", H[nzr:, nzr:], "matrix", "d2l/dOmega_d2")]))

    # ---- the inertia operator (callers invert it to fill INERTIA_INVERSE_SLOTS) -----------
    prog = Program([], M.PARAMS)
    fns.append(Function(
        "inertia_matrix",
        "The inertia operator I (Pi = I Omega) as a matrix in the model's basis, from the\n"
        "inertia parameters in p (symmetric positive definite for admissible parameters).",
        prog, [p_arg], [Out("out", M.INERTIA, "matrix", "I, `out[i][j]` = I_ij")]))

    # ---- the singular solution's jet (section 5.1), for src/so3/singular.rs ------------
    # xi~ = I Omega_p' - ad*_Omega_p (I Omega_p), lambda = |xi~|, xi_p = xi~/lambda and their
    # first two time derivatives; the second needs Omega_p''' (OmDDDot: not in the model's
    # jet, so a copy of the jet with it is used here).
    om3 = MODEL.vec("OmDDDot", n)
    jet3 = SimpleNamespace(JET={**M.JET, **dict(zip(M.OmDDot, om3))}, PARAMS=M.PARAMS)
    sj_syms = list(M.Om) + list(M.OmDot) + list(M.OmDDot) + list(om3)
    prog = Program(sj_syms, M.PARAMS)
    xt_e = D.singular_xi(opt)
    dxt_e = D.total_derivative(M, xt_e)
    xt = prog.let("xt", xt_e)
    dxt = prog.let("dxt", dxt_e)
    ddxt = prog.let("ddxt", D.total_derivative(jet3, dxt_e))
    lam = prog.let("xtn", sp.sqrt(sum(e ** 2 for e in xt)))
    xi_p = prog.let("xip", xt / lam)
    lam_d = prog.let("lamDot", sum(a * b for a, b in zip(xi_p, dxt)))
    xi_pd = prog.let("xipDot", (dxt - xi_p * lam_d) / lam)
    lam_dd = prog.let("lamDDot", sum(a * b for a, b in zip(xi_pd, dxt))
                      + sum(a * b for a, b in zip(xi_p, ddxt)))
    xi_pdd = (ddxt - 2 * lam_d * xi_pd - lam_dd * xi_p) / lam
    fns.append(Function(
        "singular_jet",
        "The analytic singular solution to second order (paper eq. xi_p_eq):\n"
        "xi~ = I Omega_p' - ad*_Omega_p (I Omega_p), lambda = |xi~| (its multiplier),\n"
        "xi_p = xi~/lambda, and their derivatives lambda' = <xi_p, xi~'>,\n"
        "xi_p' = (xi~' - lambda' xi_p)/lambda, lambda'' = <xi_p', xi~'> + <xi_p, xi~''>,\n"
        "xi_p'' = (xi~'' - 2 lambda' xi_p' - lambda'' xi_p)/lambda. Requires |xi~| > 0\n"
        "(Property 3); Omega_p''' enters xi_p'' and lambda'' only.",
        prog, [Arg("omega_p", sj_syms, "[Omega_p, Omega_p', Omega_p'', Omega_p''']",
                   u(-2.0, 2.0)), p_arg],
        [Out("xi", sp.Matrix(list(xt) + list(xi_p) + list(xi_pd) + list(xi_pdd)), "array",
             f"[xi~, xi_p, xi_p', xi_p''], {4 * n} entries"),
         Out("lambda", sp.Matrix([lam, lam_d, lam_dd]), "array",
             "[lambda, lambda', lambda'']")]))
    return fns


def sample(fns, n_points=4, seed=20261122):
    rng = random.Random(seed)
    for fn in fns:
        outs = flat_outputs(fn)
        run = fn.program.evaluator(outs)
        fn.samples = []
        for _ in range(n_points):
            vals, inputs = {}, []
            for a in fn.args:
                if isinstance(a, Arg) and a.sample_vector is not None:
                    v = a.sample_vector(rng)
                    vals.update(zip(a.symbols, v))
                    inputs.append(v)
                elif isinstance(a, Arg):
                    v = [a.sample(rng, i) for i in range(len(a.symbols))]
                    vals.update(zip(a.symbols, v))
                    inputs.append(v)
                else:
                    v = a.sample(rng, 0)
                    vals[a.symbol] = v
                    inputs.append(v)
            for c in fn.program.constants:
                vals.setdefault(c, 0.0)  # constants not exposed as args (unused)
            # inputs not exposed as args of this function
            for s in fn.program.inputs:
                vals.setdefault(s, 0.0)
            fn.samples.append((inputs, [float(v) for v in run(vals)]))


def formulas_text(opt, fns):
    s = opt.suslov
    lines = ["# Derived formulas (codegen/derive.py); reviewed through an insta snapshot.", ""]
    lines.append(f"den = <xi, I^-1 xi> = {sp.sstr(s.den)}")
    lines.append(f"lambda * den = {sp.sstr(s.lam_num)}")
    for i, e in enumerate(s.q):
        lines.append(f"q[{i}] = {sp.sstr(e)}")
    lines.append(f"m (coefficient of xi'' in EL_xi) = {sp.sstr(opt.m)}")
    lines.append(f"u (d/dt q = M11 Om'' + u <v, xi''> + ...) = {sp.sstr(list(opt.u))}")
    lines.append(f"v = dphi/dxi = {sp.sstr(list(opt.v))}")
    lines.append(f"p_Om = dL/dOm' = {sp.sstr(list(opt.p_om))}")
    lines.append(f"p_xi = dL/dxi' = {sp.sstr(list(opt.p_xi))}")
    lines.append(f"free-time condition = {sp.sstr(D.free_time_condition(opt))}")
    lines.append("")
    rhs = next(f for f in fns if f.name == "ode_rhs")
    lines.append("# ode_rhs, assignment by assignment")
    for sym, e in rhs.program.lets:
        lines.append(f"{sym} = {sp.sstr(e)}")
    lines.append("")
    lines.append("# generated functions")
    for fn in fns:
        lines.append(f"{fn.name}: {len(fn.program.lets)} assignments, "
                     f"{len(flat_outputs(fn))} outputs")
    return "\n".join(lines) + "\n"


HEADER = """\
// @generated by codegen/generate.py from codegen/models/{model}.py. DO NOT EDIT.
// Regenerate: edit the model file and run `cargo build` (see codegen/README.md).
// sympy {version}; codegen sources sha256 {hash}
"""


def rust_str(text):
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def rust_f64(v):
    return "None" if v is None else f"Some({float(v)!r})"


def param_meta(M, p):
    return (f"ParamMeta {{ name: {rust_str(p.name)}, index: {M.PARAMS.index(p.symbol)}, "
            f"doc: {rust_str(p.doc)}, lower: {rust_f64(p.lower)}, upper: {rust_f64(p.upper)}, "
            f"strict: {'true' if p.strict else 'false'}, "
            f"role: HomotopyRole::{p.role.capitalize()} }}")


def metadata(M):
    """Rust constants describing the model: sizes, layouts, names, parameter metadata."""
    n, ny = M.n, len(M.STATE)
    gamma = M.constraint_value(M.xi)
    strs = lambda xs: ", ".join(rust_str(str(x)) for x in xs)  # noqa: E731
    parts = [
        f"/// The model's name (`codegen/models/{M.NAME}.py`).\n"
        f"pub const MODEL_NAME: &str = {rust_str(M.NAME)};",
        f"/// One line on what the model is.\npub const MODEL_TITLE: &str = {rust_str(M.TITLE)};",
        f"/// Dimension n of the Lie algebra (Omega, xi, kappa each have n entries).\n"
        f"pub const DIM: usize = {n};",
        f"/// Names of the basis elements of the Lie algebra, in order.\n"
        f"pub const BASIS_NAMES: [&str; {n}] = [{strs(M.algebra.names)}];",
        f"/// Number of states y = [Omega, xi, xi', kappa].\npub const N_STATE: usize = {ny};",
        f"/// Names of the states, in order.\n"
        f"pub const STATE_NAMES: [&str; {ny}] = [{strs(M.STATE_NAMES)}];",
    ]
    for k, (block, label) in enumerate(M.BLOCKS):
        parts.append(f"/// Where {label} sits in the state y.\n"
                     f"pub const {block.upper()}: core::ops::Range<usize> = "
                     f"{k * n}..{(k + 1) * n};")
    parts += [
        f"/// Number of constants p (user parameters, then derived constants).\n"
        f"pub const N_PARAM: usize = {len(M.PARAMS)};",
        f"/// Number of user parameters (inertia, weights, constraint value) at the front of p.\n"
        f"pub const N_USER_PARAM: usize = {M.N_USER_PARAMS};",
        f"/// Names of the constants p, in order.\n"
        f"pub const PARAM_NAMES: [&str; {len(M.PARAMS)}] = [{strs(M.PARAMS)}];",
        f"/// What each constant means.\npub const PARAM_DOCS: [&str; {len(M.PARAMS)}] = [\n    "
        + ",\n    ".join(rust_str(d) for d in M.PARAM_DOCS) + ",\n];",
        "/// Index of each constant in p, by name.\npub mod idx {\n"
        + "\n".join(f"    /// `{s}`.\n    pub const {str(s).upper()}: usize = {i};"
                     for i, s in enumerate(M.PARAMS)) + "\n}",
    ]
    for const, group, what in [("INERTIA_PARAMS", M.inertia_params, "the inertia operator"),
                               ("WEIGHTS", M.weights, "the cost"),
                               ("CONSTRAINT_PARAMS", M.constraint_params,
                                "the constraint value gamma")]:
        body = "".join(f"\n    {param_meta(M, p)}," for p in group)
        parts.append(f"/// The parameters of {what}.\n"
                     f"pub const {const}: [ParamMeta; {len(group)}] = [{body}{chr(10) if group else ''}];")
    der = ", ".join(f"({M.PARAMS.index(s)}, {i}, {j})" for s, (i, j) in M.derived)
    parts.append(f"/// Derived constants: (index in p, row, column) of each entry of I^-1 that the\n"
                 f"/// caller fills by inverting `inertia_matrix` (empty for a diagonal inertia).\n"
                 f"pub const INERTIA_INVERSE_SLOTS: [(usize, usize, usize); {len(M.derived)}] = "
                 f"[{der}];")
    if M.algebra.matrices is not None:
        k = M.algebra.matrices[0].rows
        mats = ",\n    ".join(
            "[" + ", ".join("[" + ", ".join(f"{float(m[r, c])!r}" for c in range(k)) + "]"
                            for r in range(k)) + "]" for m in M.algebra.matrices)
        parts.append(f"/// A faithful matrix representation of the basis ({k} x {k} matrices), for\n"
                     f"/// the reconstruction g' = g hat(Omega).\n"
                     f"pub const REPRESENTATION: [[[f64; {k}]; {k}]; {n}] = [\n    {mats},\n];")
        parts.append(f"/// [`REPRESENTATION`] flat: the basis matrices one after the other, row-major.\n"
                     f"pub const REPRESENTATION_FLAT: [f64; {n * k * k}] = "
                     f"[{', '.join(repr(float(m[r, c])) for m in M.algebra.matrices for r in range(k) for c in range(k))}];")
    parts += [
        f"/// Number of desired-path inputs w = [Omega_d, Omega_d'].\n"
        f"pub const N_DESIRED: usize = {2 * n};",
        f"/// Number of boundary conditions at each end (without the free-time condition).\n"
        f"pub const N_BC_ENDPOINT: usize = {2 * n};",
        f"/// Number of Lie brackets [g_i, g_j], i < j, of the control fields.\n"
        f"pub const N_BRACKETS: usize = {n * (n - 1) // 2};",
        f"/// Whether the constraint value gamma(xi) in <Omega, xi> = gamma(xi) is not identically\n"
        f"/// 0: the kinetic energy is then balanced (dT/dt = lambda gamma), not conserved.\n"
        f"pub const HAS_CONSTRAINT_VALUE: bool = {str(gamma != 0).lower()};",
        f"/// Whether gamma depends on xi.\n"
        f"pub const CONSTRAINT_VALUE_DEPENDS_ON_XI: bool = "
        f"{str(bool(gamma.free_symbols & set(M.xi))).lower()};",
    ]
    return parts


def module_text(M, fns, h):
    parts = [HEADER.format(model=M.NAME, version=sp.__version__, hash=h),
             "use super::{HomotopyRole, ParamMeta};",
             f'/// The sympy version that derived these formulas.\n'
             f'pub const SYMPY_VERSION: &str = "{sp.__version__}";',
             f'/// sha256 of the codegen sources these formulas came from (the top-level\n'
             f'/// sources and this model\'s file).\n'
             f'pub const SOURCE_HASH: &str = "{h}";'] + metadata(M)
    for fn in fns:
        parts.append(emit_function(fn))
    tn = type_name(M.NAME)
    parts.append(f"/// The `{M.NAME}` model as a type, for code generic over [`super::Model`].\n"
                 f"#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]\npub struct {tn};")
    rep = ("None" if M.algebra.matrices is None
           else f"Some(({M.algebra.matrices[0].rows}, &REPRESENTATION_FLAT))")
    parts.append(impl_text(tn, fns, rep))
    return "\n\n".join(parts) + "\n"


def type_name(name):
    """The model's type: its name in upper camel case (so3 -> So3)."""
    return "".join(w[:1].upper() + w[1:] for w in name.split("_"))


def model_key(name, h):
    """The cache key of one model's output: the codegen sources' hash and sympy's version."""
    return f"{name} {h} sympy {sp.__version__}\n"


def cached(name, out, h):
    """Whether `out` holds this model's files for exactly these sources (per-model cache)."""
    try:
        with open(os.path.join(out, f".{name}.key")) as fh:
            key = fh.read()
    except OSError:
        return False
    return key == model_key(name, h) and all(
        os.path.isfile(os.path.join(out, f"{name}{suffix}"))
        for suffix in ("_model.rs", "_vectors.rs", "_formulas.txt")) and os.path.isfile(
        os.path.join(out, f".{name}.sig.json"))


def signatures(fns):
    """What the trait needs of a function list: names, docs, argument and output kinds."""
    return [{"name": f.name, "doc": f.doc,
             "args": [[a.name, "array" if isinstance(a, Arg) else "scalar"] for a in f.args],
             "outputs": [[o.name, o.kind, list(o.exprs.shape) if o.kind == "matrix" else None]
                         for o in f.outputs]} for f in fns]


def read_signatures(out, name):
    with open(os.path.join(out, f".{name}.sig.json")) as fh:
        return json.load(fh)


def generate_model(name, out, h):
    """Derive one model and write its three files into `out` (atomically, each)."""
    M = MODEL.load(name)
    opt = D.Optimality(M)
    fns = build_functions(opt)
    sample(fns)
    header = HEADER.format(model=name, version=sp.__version__, hash=h)
    files = {
        f"{name}_model.rs": module_text(M, fns, h),
        f"{name}_vectors.rs": header + "\n" + emit_vector_checks(fns) + "\n",
        f"{name}_formulas.txt": formulas_text(opt, fns),
    }
    for fname, text in files.items():
        write(out, fname, text)
    write(out, f".{name}.sig.json", json.dumps(signatures(fns), indent=1, sort_keys=True))
    write(out, f".{name}.key", model_key(name, h))
    return name


def model_size(name):
    """A rough measure of a model's generation time, to schedule the largest first: the
    dimension of its algebra, then its number of constants (a non-diagonal inertia adds the
    derived entries of I^-1 and larger expressions)."""
    M = MODEL.load(name)
    return (M.n, len(M.PARAMS))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", required=True, help="output directory")
    ap.add_argument("--models", nargs="*", help="models to generate (default: all shipped)")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    h = source_hash()
    names = args.models or MODEL.available()
    hashes = {n: source_hash(n) for n in names}
    todo = [n for n in names if not cached(n, args.out, hashes[n])]
    if len(todo) > 1:
        # One task per model, the largest first (longest processing time first: so4 alone takes
        # about as long as the others together, so it must not start last), each in a fresh
        # process forked from this one (maxtasksperchild=1: no caches or memory carried over
        # from the previous model, as when a model is generated alone); results are files, so
        # the output does not depend on the order in which the models finish.
        import multiprocessing
        todo.sort(key=model_size, reverse=True)
        ctx = multiprocessing.get_context("fork")
        with ctx.Pool(min(len(todo), os.cpu_count() or 1), maxtasksperchild=1) as pool:
            pool.starmap(generate_model, [(n, args.out, hashes[n]) for n in todo], chunksize=1)
    elif todo:
        generate_model(todo[0], args.out, hashes[todo[0]])
    write(args.out, "models.rs", index_text(names, h, args.out))
    write(args.out, "vectors.rs", vectors_index_text(names, h))


ALLOW = "#[allow(clippy::all, non_snake_case, unused_variables, unused_parens, " \
    "clippy::too_many_arguments, clippy::excessive_precision)]"


def index_text(names, h, out):
    """models.rs: one module per model (included by src/model/mod.rs), and `vectors`, the
    test-vector checks of every model (included by tests/generated_vectors.rs)."""
    lines = [HEADER.format(model="*", version=sp.__version__, hash=h)]
    # The trait is the same for every model (one derivation, one list of functions); it is
    # printed from the first model's list, and every model's list is checked to match it.
    lists = {n: read_signatures(out, n) for n in names}

    def shape(sigs):  # what the trait's methods depend on
        return [(f["name"], f["args"], [o[:2] for o in f["outputs"]]) for f in sigs]
    for n in names:
        if shape(lists[n]) != shape(lists[names[0]]):
            raise AssertionError(f"model {n} emits a different list of functions")
    lines.append(trait_text(lists[names[0]]))
    lines.append("")
    for name in names:
        M = MODEL.load(name)
        lines += [f"/// `{name}`: {M.TITLE} (generated from `codegen/models/{name}.py`).",
                  ALLOW,
                  f'pub mod {name} {{\n    include!(concat!(env!("OUT_DIR"), "/{name}_model.rs"));\n}}',
                  ""]
    lines.append("/// sha256 of the codegen sources of every model (build.rs checks the committed copy "
                 "against it).")
    lines.append(f'pub const SOURCE_HASH_ALL: &str = "{h}";')
    lines.append("/// (model, sha256 of its sources) for every model.")
    pairs = ", ".join(f"({rust_str(n)}, {n}::SOURCE_HASH)" for n in names)
    lines.append(f"pub const SOURCE_HASHES: [(&str, &str); {len(names)}] = [{pairs}];")
    lines.append("/// The shipped models, by name (`codegen/models/*.py`).")
    lines.append(f"pub const MODEL_NAMES: [&str; {len(names)}] = "
                 f"[{', '.join(rust_str(n) for n in names)}];")
    arms = "\n".join(f"            {rust_str(n)} => {{\n                type $M = $crate::model::{n}::"
                     f"{type_name(n)};\n                $body\n            }}" for n in names)
    # (textual scope: `#[macro_export]` on an included macro cannot be named by path)
    lines += [
        "/// `with_model!(name, M => body, _ => other)`: evaluate `body` with the type `M` set to",
        "/// the generated model named `name` (a `&str`: one of [`MODEL_NAMES`]), or `other` for",
        "/// any other name. The one place where a model name becomes a type (re-exported as",
        "/// `crate::model::with_model`).",
        "macro_rules! with_model {",
        "    ($name:expr, $M:ident => $body:expr, _ => $other:expr) => {",
        "        match $name {",
        arms,
        "            _ => $other,",
        "        }",
        "    };",
        "}",
    ]
    return "\n".join(lines) + "\n"


def vectors_index_text(names, h):
    """vectors.rs: `check_all`, the test-vector checks of every model (included by
    tests/generated_vectors.rs)."""
    lines = [HEADER.format(model="*", version=sp.__version__, hash=h)]
    for name in names:
        lines += [ALLOW,
                  f"pub mod {name} {{\n    use suslov::model::{name}::*;\n"
                  f'    include!(concat!(env!("OUT_DIR"), "/{name}_vectors.rs"));\n}}', ""]
    lines += ["/// Every model's `check_vectors(rtol)`, messages prefixed by the model's name.",
              "pub fn check_all(rtol: f64) -> Vec<String> {",
              "    let mut failures = Vec::new();"]
    for name in names:
        lines.append(f"    failures.extend({name}::check_vectors(rtol).into_iter()"
                     f".map(|m| format!(\"{name}: {{m}}\")));")
    lines += ["    failures", "}"]
    return "\n".join(lines) + "\n"


def write(out, fname, text):
    path = os.path.join(out, fname)
    tmp = path + ".tmp"
    with open(tmp, "w") as fh:
        fh.write(text)
    os.replace(tmp, path)


if __name__ == "__main__":
    main()
