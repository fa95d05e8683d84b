"""The paper pipeline (section 5.3, both cases) with scipy.integrate.solve_bvp against ours.

Issue #13: one run, back to back, of

* **scipy**: the paper's problem (I = diag(1, 2, 3), Omega_a = [5, 0, 0], the spiral Omega_d,
  alpha = 1, beta = 0.1, gamma = 1, delta = 0.2, free terminal time, eta = 1 and eta = 0.01)
  solved by `scipy.integrate.solve_bvp` (collocation with a cubic spline, tol = RMS relative
  residual) through the same homotopy as `src/lie/solve.rs`, and
* **ours**: the frozen binary `suslov paper --out DIR -q` (default `/tmp/suslov-s10`; the
  whole run: both cases, verification, trajectory.csv/.npy, figures), with the solves alone
  read from its `summary.json` (`wall_seconds` per case),

alternately (ours, scipy, ours, scipy, ...), and a Markdown table of the medians and their
ratios, the b and J each reached, and the load average (`uptime`) around every run.

**The right-hand side is not retyped.** The scipy pipeline calls the derivation of `codegen/`
(`derive.Optimality` of `models/so3.py`) and the very functions `generate.build_functions`
hands to the Rust emitter (`ode_rhs_scaled`, `ode_jac_scaled`, `bc_endpoint`,
`bc_endpoint_jac`, `free_time_condition(_jac)`, `delta_start`, `cost_integrand`,
`singular_control`, ...): their straight-line programs (plus sympy's cse, as the emitter does)
are printed as numpy code, vectorised over the mesh. Checked at start-up: the compiled
programs against sympy/mpmath's evaluation of the same programs at seeded points, and the
compiled physical-time `ode_rhs` against the derivative of our `trajectory.csv` (first run of
ours; 6th-order central differences on its 2001 uniform rows, those within 0.3 of the switch
of Omega_d at t = b_d = 10 left out: its tanh layer is 0.01 wide). The desired path (the
projected spiral blended to Omega_b by tanh, eqs. `eq_phi` ... `eq_Om_d`) and the start path
(its radial projection onto the level set) are differentiated by sympy and lambdified.

**The homotopy** (src/lie/solve.rs `solve_route`, default route, SolveOptions::default()):

1. start: the analytic singular solution from Omega_p = the desired path projected radially
   onto the energy level set (the paper's third case: the desired path lies on the level set
   within 1e-4 on [a, b_p]; gamma at its target), y = [Omega_p, xi_p, xi_p', kappa = 0] from
   the generated `singular_control`, 101 uniform nodes, beta_m = 1e-2 min(alpha, beta, gamma)
   = 1e-3, eta = delta = 0, fixed b_p - a = 10;
2. (tracking stage: none in the third case); 3. beta: beta_m -> beta geometrically;
4. eta: 0 -> eta linearly; 6. free-time start: delta_c from the generated `delta_start` at
   y(b), T = b - a becomes the unknown parameter, one solve; delta: delta_c -> delta linearly;
7. polish at tol = 1e-8 (if the direct solve fails: the tolerance stepped down from the
   continuation's by 100x, 10x after a failed 100x step, as `Homotopy::polish`).

Every continuation and start solve uses tol 1e-4 (`continuation_tol`). Natural continuation
in lambda in [0, 1] as `continuation::natural`: first step 0.2, secant predictor on the newest
mesh (retried once from the last solution if it fails), step x1.6 after an easy step, x0.7
after a hard one, x0.4 after a failure, minimum step 1e-6. Ours counts Newton iterations (easy
<= 4, hard > 10); solve_bvp does not report them, so here a solve's number of collocation
Jacobians (easy <= 4, hard > 10) stands in for them. Not reproduced: ours' pseudo-arclength
rescue of a stalled stage, its other routes and the refine stage (none is taken on the paper's
cases: summary.json lists the stages); a stalled stage here stops the case (reported).

**Mesh growth in a continuation step.** Ours' continuation solves fail fast
(`max_newton_failures = 0`: a Newton failure on the current mesh rejects the step, which is
then cut). solve_bvp cannot be told so: when its Newton iteration stops unconverged it inserts
two nodes into every interval whose residual is >= 100 tol and tries again, and it never
removes nodes (ours also coarsens). Left alone, a too-large step thus triples the mesh and the
rest of the homotopy runs on it. As the stand-in for the fail-fast rule, a continuation step
may at most double the mesh (`max_nodes` of the step's solve = 2 x the current nodes, capped
at ours' 20000; exceeding it rejects the step, which is then cut); `--step-growth 0` turns
this off (plain solve_bvp, node cap 20000). Measured on eta = 1 (eta = 0.01 is unaffected;
load average 2.4 to 6): default 50 to 99 s over six runs, 2841 nodes after the eta stage,
15747 after the delta stage, 19151 after the polish; `--step-growth 0` (one run): 153 s,
14635 nodes after the eta stage, 19912 after the delta stage; an earlier variant with a
100000-node cap on every solve (one run): 774 s, 40414 and 81883 nodes. The solution itself
needs far fewer: a polish at 1e-8 from the final solution resampled on 1001 uniform nodes (a
one-off experiment, not part of this script) ends with 6250 nodes in 1.5 s.

What differs by construction: `tol` means different things (scipy: RMS relative residual of
a 4th-order cubic spline, checked at 1 + |f|; ours: an error estimate of the 6th-order
Lobatto IIIA solution), so the meshes differ; the polish may use up to 100000 nodes here (ours'
cap is 20000 for every solve), as the 4th-order method needs far more nodes at 1e-8.

**Acceptance checks** of the scipy solution (the thresholds ours' summary.json reports at tol
1e-8): solve_bvp status 0 at every stage, max |<Omega, xi>| / (max |Omega| max |xi|) <= 1e-8 and
the relative kinetic-energy drift <= 2e-8 on the nodes and 4 points per interval of the dense
output, |Omega(b) - Omega_b| / |Omega_b| <= 1e-8, max boundary residual <= 1e-8; the cost J by
5-point Gauss-Legendre per mesh interval on the dense output (as src/lie/verify.rs).

Timings: scipy's are the solves of the pipeline (from building the start guess to the
polished solution; the derivation, the numpy compilation and the checks are outside the
clock); ours are the wall time of the whole `suslov paper` process and, from its summary.json,
the solves alone. Medians over the runs; the ratio is scipy's median / ours.

Run: python3 bench/scipy_paper.py [--runs N] [--ours-runs M] [--binary PATH]
     [--step-growth G] [--verbose]
(needs numpy, scipy, and sympy as pinned in codegen/requirements.txt; see
bench/requirements-scipy.txt)
"""

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np
import scipy
from scipy.integrate import solve_bvp

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
CODEGEN = os.path.join(ROOT, "codegen")
sys.path.insert(0, CODEGEN)

import sympy as sp  # noqa: E402

import derive as D  # noqa: E402
import emit_rust as E  # noqa: E402
import generate as G  # noqa: E402  (checks the pinned sympy; exit status 3 otherwise)
import model as MODEL  # noqa: E402

# ---------------------------------------------------------------------------------------------
# The paper's data (src/so3/paper.rs, desired.rs, problem.rs CostWeights::paper)

INERTIA = np.array([1.0, 2.0, 3.0])
OMEGA_A = np.array([5.0, 0.0, 0.0])  # phi(0)/2
SPIRAL_C, SPIRAL_WIDTH, B_D = 10.0, 0.01, 10.0
ALPHA, BETA, GAMMA, DELTA = 1.0, 0.1, 1.0, 0.2
CASES = [("eta_1", 1.0), ("eta_0.01", 0.01)]
# Ours' answers (the brief's; the run's own summary.json is compared too).
EXPECTED = {"eta_1": (11.359616203476824, 15.394760771339968),
            "eta_0.01": (9.838326431487959, 2.665849059741015)}

# SolveOptions::default() and continuation_options() of src/lie/solve.rs
TOL = 1e-8
CONTINUATION_TOL = 1e-4
INITIAL_INTERVALS = 100
MAX_NODES = 20_000  # ours' cap, every solve but the polish
POLISH_MAX_NODES = 100_000
STEP_GROWTH = 2  # a continuation step may at most double the mesh (see the module docs)
ADMISSIBLE_ENERGY_TOL = 1e-4
CONT = dict(initial_step=0.2, max_step=1.0, min_step=1e-6, max_steps=500, grow=1.6,
            shrink=0.4, easy=4, hard=10)

# ---------------------------------------------------------------------------------------------
# The derivation, compiled to numpy


def _numpy_source(fn, name):
    """Straight-line numpy source of a generated function `fn` (a `emit_rust.Function`):
    the program's needed assignments and the outputs, through sympy's cse (as the emitter's
    `emit_body`), every intermediate emitted as soon as its inputs are defined."""
    from sympy.printing.numpy import NumPyPrinter

    pr = NumPyPrinter({"fully_qualified_modules": True, "inline": True})
    outs = E.flat_outputs(fn)
    prog = fn.program
    need = prog.needed(outs)
    lets = [(s, e) for s, e in prog.lets if s in need]
    repl, reduced = sp.cse([e for _, e in lets] + outs, symbols=sp.numbered_symbols("_c"),
                           order="none")
    # every symbol of the program gets a plain local name
    names = {}

    def nm(sym):
        if sym not in names:
            names[sym] = f"_v{len(names)}"
        return names[sym]

    lines = [f"def {name}({', '.join('_a%d' % i for i in range(len(fn.args)))}):"]
    first = None
    for i, a in enumerate(fn.args):
        if isinstance(a, E.Arg):
            for k, s in enumerate(a.symbols):
                lines.append(f"    {nm(s)} = _a{i}[{k}]")
                if first is None and a.name not in ("p",):
                    first = nm(s)
        else:
            lines.append(f"    {nm(a.symbol)} = _a{i}")
    lines.append(f"    _shape = numpy.shape({first})")
    defined = set(names)
    rdef = dict(repl)
    rename = {s: sp.Symbol(v) for s, v in names.items()}

    def printed(e):
        e = e.xreplace(rename)
        return pr.doprint(e)

    def ensure(e):
        for s in sorted(e.free_symbols, key=str):
            if s in rdef and s not in defined:
                ensure(rdef[s])
                rename[s] = sp.Symbol(nm(s))
                lines.append(f"    {nm(s)} = {printed(rdef[s])}")
                defined.add(s)

    for (s, _), e in zip(lets, reduced[:len(lets)]):
        ensure(e)
        rename[s] = sp.Symbol(nm(s))
        lines.append(f"    {nm(s)} = {printed(e)}")
        defined.add(s)
    k = len(lets)
    results = []
    for o in fn.outputs:
        if o.kind == "return":
            e = reduced[k]
            k += 1
            ensure(e)
            lines.append(f"    _r{len(results)} = {printed(e)} + numpy.zeros(_shape)")
        else:
            shape = (o.exprs.rows, o.exprs.cols) if o.kind == "matrix" else (len(o.exprs),)
            lines.append(f"    _r{len(results)} = numpy.zeros({shape} + _shape)")
            for idx in np.ndindex(*shape):
                e = reduced[k]
                k += 1
                if e == 0:
                    continue
                ensure(e)
                lines.append(f"    _r{len(results)}[{', '.join(map(str, idx))}] = {printed(e)}")
        results.append(f"_r{len(results)}")
    lines.append(f"    return ({', '.join(results)},)")
    return "\n".join(lines)


def compile_functions(names):
    """{name: numpy function} for the generated functions `names` of models/so3.py, and the
    model. Each returns a tuple of its outputs (arrays with the mesh as last axis)."""
    M = MODEL.load("so3")
    opt = D.Optimality(M)
    fns = {f.name: f for f in G.build_functions(opt)}
    out = {}
    for name in names:
        src = _numpy_source(fns[name], name)
        ns = {"numpy": np}
        exec(compile(src, f"<{name}>", "exec"), ns)
        out[name] = ns[name]
    return out, fns, M


def check_compiled(compiled, fns, M, points=3, seed=1):
    """max relative difference of each compiled function from the mpmath evaluation of the
    same program (flat outputs) at seeded points."""
    rng = np.random.default_rng(seed)
    worst = 0.0
    for name, f in compiled.items():
        fn = fns[name]
        run = fn.program.evaluator(E.flat_outputs(fn))
        for _ in range(points):
            vals, args = {}, []
            for a in fn.args:
                if isinstance(a, E.Arg):
                    v = rng.uniform(0.5, 2.0, len(a.symbols)) * rng.choice([-1, 1], len(a.symbols))
                    if a.name == "p":
                        v = np.abs(v)
                    vals.update(zip(a.symbols, v))
                    args.append(v)
                else:
                    v = rng.uniform(0.5, 2.0)
                    vals[a.symbol] = v
                    args.append(v)
            for sym in fn.program.inputs + fn.program.constants:
                vals.setdefault(sym, 0.5)  # symbols of the program that these outputs do not use
            ref = np.array([float(x) for x in run(vals)])
            got = np.concatenate([np.ravel(r) for r in f(*args)])
            worst = max(worst, float(np.max(np.abs(got - ref) / (1 + np.abs(ref)))))
    return worst


# ---------------------------------------------------------------------------------------------
# The desired path and the start path, with exact derivatives (sympy)


def paths():
    t = sp.Symbol("t", real=True)
    I = [sp.Float(v) for v in INERTIA]
    level = sum(i * float(o) ** 2 for i, o in zip(I, OMEGA_A))

    def proj(v):
        return [e * sp.sqrt(level / sum(i * x ** 2 for i, x in zip(I, v))) for e in v]

    phi = [sp.Float(SPIRAL_C), t * sp.cos(t), t * sp.sin(t)]
    phi_par = proj(phi)
    omega_b = np.array([float(e.subs(t, B_D)) for e in phi_par])
    sw = (1 + sp.tanh((t - B_D) / SPIRAL_WIDTH)) / 2
    om_d = [p * (1 - sw) + float(b) * sw for p, b in zip(phi_par, omega_b)]
    om_p = proj(om_d)  # the start path: Omega_d projected onto the level set (Projected)

    def jet(v, order):
        rows = list(v)
        d = list(v)
        for _ in range(order):
            d = [sp.diff(e, t) for e in d]
            rows += d
        f = sp.lambdify(t, rows, modules="numpy", cse=True)

        def g(tt):
            tt = np.asarray(tt, dtype=float)
            return np.array([np.broadcast_to(r, tt.shape) for r in f(tt)], dtype=float)
        return g

    return jet(om_d, 1), jet(om_p, 2), omega_b, level


# ---------------------------------------------------------------------------------------------
# The BVP with solve_bvp


class Bvp:
    """The scaled optimality system on s in [0, 1], t = a + s T, of the paper's problem with
    constants `params`; `span` = the fixed T, or None (then p = [T])."""

    def __init__(self, lib, desired, omega_b, params, span):
        self.lib, self.desired, self.omega_b = lib, desired, omega_b
        self.params, self.span = np.asarray(params, float), span

    def T(self, p):
        return self.span if self.span is not None else p[0]

    def fun(self, x, y, p=None):
        T = self.T(p)
        return self.lib["ode_rhs_scaled"](y, self.params, self.desired(T * x), T)[0]

    def fun_jac(self, x, y, p=None):
        T = self.T(p)
        dgdy, dgdt = self.lib["ode_jac_scaled"](y, self.params, self.desired(T * x), T, x)
        if self.span is not None:
            return dgdy
        return dgdy, dgdt[:, None, :]

    def bc(self, ya, yb, p=None):
        ra = self.lib["bc_endpoint"](ya, self.params, OMEGA_A)[0]
        rb = self.lib["bc_endpoint"](yb, self.params, self.omega_b)[0]
        if self.span is not None:
            return np.concatenate([ra, rb])
        ft = self.lib["free_time_condition"](yb, self.params, self.desired(p[0]))[0]
        return np.concatenate([ra, rb, [ft]])

    def bc_jac(self, ya, yb, p=None):
        n = ya.size
        ja = self.lib["bc_endpoint_jac"](ya, self.params, OMEGA_A)[0]
        jb = self.lib["bc_endpoint_jac"](yb, self.params, self.omega_b)[0]
        k = 0 if self.span is not None else 1
        nb = ja.shape[0]
        dya = np.zeros((2 * nb + k, n))
        dyb = np.zeros((2 * nb + k, n))
        dya[:nb] = ja
        dyb[nb:2 * nb] = jb
        if k == 0:
            return dya, dyb
        dy, dt = self.lib["free_time_condition_jac"](yb, self.params, self.desired(p[0]))
        dyb[2 * nb] = dy
        dp = np.zeros((2 * nb + 1, 1))
        dp[2 * nb, 0] = dt
        return dya, dyb, dp


class Counter:
    solves = 0
    jacobians = 0


def solve(bvp, x, y, p, tol, max_nodes=None):
    """One solve_bvp; returns (result, collocation Jacobians evaluated)."""
    calls = [0]

    def fj(*a):
        calls[0] += 1
        return bvp.fun_jac(*a)

    res = solve_bvp(bvp.fun, bvp.bc, x, y, p=p, fun_jac=fj, bc_jac=bvp.bc_jac, tol=tol,
                    max_nodes=max_nodes or MAX_NODES)
    Counter.solves += 1
    jac = calls[0] // 2  # scipy evaluates fun_jac at the nodes and the midpoints per Jacobian
    Counter.jacobians += jac
    return res, jac


def natural(family, sol, tol, record):
    """Natural continuation of `family(lam)` from `sol` (a solution at lam = 0) to lam = 1
    (src/continuation/mod.rs `natural_with_progress`). Returns (lam reached, solution)."""
    c = CONT
    step, prev, cur, attempts = c["initial_step"], None, (0.0, sol), 0
    while cur[0] != 1.0:
        if attempts >= c["max_steps"] or step < c["min_step"]:
            return cur
        lam = 1.0 if step >= 1.0 - cur[0] else cur[0] + step
        bvp = family(lam)
        x1, s1 = cur[1].x, cur[1]
        p1 = s1.p if s1.p is not None and bvp.span is None else None

        cap = min(MAX_NODES, int(STEP_GROWTH * x1.size)) if STEP_GROWTH else MAX_NODES

        def from_current():
            return solve(bvp, x1, s1.y, p1, tol, cap)

        if prev is not None:
            l0, s0 = prev
            th = (lam - cur[0]) / (cur[0] - l0)
            y = s1.y + th * (s1.y - s0.sol(x1))
            p = None if p1 is None else p1 + th * (p1 - s0.p)
            res, jac = solve(bvp, x1, y, p, tol, cap)
            attempts += 1
            if res.status != 0:
                res, jac = from_current()
                attempts += 1
        else:
            res, jac = from_current()
            attempts += 1
        record.append((lam, res.status, jac, res.x.size))
        if LOG:
            LOG(f"    lambda {lam:.6g}: status {res.status}, {jac} Jacobians, {res.x.size} nodes")
        if res.status == 0:
            prev, cur = cur, (lam, res)
            if jac <= c["easy"]:
                step = min(step * c["grow"], c["max_step"])
            elif jac > c["hard"]:
                step *= 0.7
        else:
            step *= c["shrink"]
    return cur


class StageFailed(Exception):
    pass


def pipeline(lib, desired, start_path, omega_b, eta, log=None):
    """The paper pipeline for one case; returns (solution, params reached, stages, paper
    case, delta_c). Raises StageFailed where a stage stops."""
    stages = []

    def note(name, lam, sol, steps=None):
        stages.append(dict(name=name, reached=lam, nodes=sol.x.size, steps=steps))
        if log:
            log(f"  {name}: lambda {lam} nodes {sol.x.size} steps {steps}")

    idx = {"alpha": 3, "beta": 4, "gamma": 5, "eta": 6, "delta": 7}
    target = np.array([*INERTIA, ALPHA, BETA, GAMMA, eta, DELTA])
    t_p = B_D  # b_p - a
    beta_m = 1e-2 * min(ALPHA, BETA, GAMMA)
    # Paper case: 3 when the desired path lies on the level set (it does: the start path is
    # then its projection and gamma starts at its target), else 2 (gamma from 0).
    ts = np.linspace(0.0, t_p, 4001)
    od = desired(ts)[:3]
    dev = np.max(np.abs((INERTIA[:, None] * od ** 2).sum(0) / LEVEL - 1.0))
    case = 3 if dev <= ADMISSIBLE_ENERGY_TOL else 2
    params = target.copy()
    params[idx["beta"]] = beta_m
    params[idx["eta"]] = 0.0
    params[idx["delta"]] = 0.0
    params[idx["gamma"]] = GAMMA if case == 3 else 0.0
    # 1. the analytic start
    x = np.linspace(0.0, 1.0, INITIAL_INTERVALS + 1)
    jet = start_path(x * t_p)  # [Omega_p, Omega_p', Omega_p'']
    xi = lib["singular_control"](jet, params)[0]
    y = np.vstack([jet[:3], xi, np.zeros((3, x.size))])
    bvp = Bvp(lib, desired, omega_b, params, t_p)
    sol, _ = solve(bvp, x, y, None, CONTINUATION_TOL)
    if sol.status != 0:
        raise StageFailed(f"start: {sol.message}")
    note("start", 0.0, sol)

    def stage(name, index, value):
        nonlocal sol, params
        base = params.copy()
        span = bvp_span[0]

        def family(lam):
            q = base.copy()
            q[index] = value(lam)
            return Bvp(lib, desired, omega_b, q, span)

        rec = []
        lam, sol = natural(family, sol, CONTINUATION_TOL, rec)
        params = base.copy()
        params[index] = value(lam)
        note(name, lam, sol, sum(1 for r in rec if r[1] == 0))
        if lam != 1.0:
            raise StageFailed(f"stage {name} stopped at lambda = {lam}")

    bvp_span = [t_p]
    if case == 2:
        stage("gamma", idx["gamma"], lambda l: l * GAMMA)
    lo, hi = np.log(beta_m), np.log(BETA)
    stage("beta", idx["beta"], lambda l: BETA if l >= 1.0 else np.exp(lo + l * (hi - lo)))
    stage("eta", idx["eta"], lambda l: l * eta)
    # free terminal time: delta_c at y(b), then T unknown
    yb = sol.sol(1.0)
    delta_c = float(lib["delta_start"](yb, params, desired(t_p))[0])
    params[idx["delta"]] = delta_c
    bvp_span[0] = None
    free = Bvp(lib, desired, omega_b, params, None)
    sol, _ = solve(free, sol.x, sol.y, np.array([t_p]), CONTINUATION_TOL)
    if sol.status != 0:
        raise StageFailed(f"free-time start: {sol.message}")
    note("free-time start", 0.0, sol)
    stage("delta", idx["delta"], lambda l: delta_c + l * (DELTA - delta_c))
    params[idx["delta"]] = DELTA
    # 7. polish
    final = Bvp(lib, desired, omega_b, params, None)
    res, _ = solve(final, sol.x, sol.y, sol.p, TOL, POLISH_MAX_NODES)
    steps = 1
    if res.status == 0:
        sol = res
    else:
        good, ratio = CONTINUATION_TOL, 1e-2
        while good > TOL * (1 + 1e-9):
            t = max(good * ratio, TOL)
            steps += 1
            res, _ = solve(final, sol.x, sol.y, sol.p, t, POLISH_MAX_NODES)
            if res.status == 0:
                sol, good, ratio = res, t, 1e-2
            elif ratio < 1e-1 and good * 1e-1 > TOL * (1 + 1e-9):
                ratio = 1e-1
            else:
                raise StageFailed(f"polish: the step from {good:e} to {t:e} failed: {res.message}")
    note("polish", 0.0, sol, steps)
    return sol, params, stages, case, delta_c


def _gauss5():
    xg, wg = np.polynomial.legendre.leggauss(5)
    return (xg + 1) / 2, wg / 2


def checks(lib, desired, omega_b, sol, params):
    """The acceptance quantities of a free-time solution (module docs)."""
    T = float(sol.p[0])
    x = sol.x
    h = np.diff(x)
    nodes, weights = _gauss5()
    s = (x[:-1, None] + nodes[None, :] * h[:, None]).ravel()
    wq = (weights[None, :] * h[:, None]).ravel() * T
    y = sol.sol(s)
    cost = float(np.sum(wq * lib["cost_integrand"](y, params, desired(T * s))[0]))
    fine = np.unique(np.concatenate([x, (x[:-1, None] + np.arange(1, 5)[None, :] / 5 * h[:, None]).ravel()]))
    yf = sol.sol(fine)
    om, xi = yf[:3], yf[3:6]
    constraint = float(np.max(np.abs((om * xi).sum(0))) /
                       (np.max(np.linalg.norm(om, axis=0)) * np.max(np.linalg.norm(xi, axis=0))))
    kin = (INERTIA[:, None] * om ** 2).sum(0)
    energy = float(np.max(np.abs(kin / LEVEL - 1.0)))
    ob_err = float(np.linalg.norm(sol.y[:3, -1] - omega_b) / np.linalg.norm(omega_b))
    bvp = Bvp(lib, desired, omega_b, params, None)
    bc = float(np.max(np.abs(bvp.bc(sol.y[:, 0], sol.y[:, -1], sol.p))))
    passed = (sol.status == 0 and constraint <= 1e-8 and energy <= 2e-8 and ob_err <= 1e-8
              and bc <= 1e-8)
    return dict(b=T, cost=cost, constraint=constraint, energy=energy, omega_b=ob_err, bc=bc,
                nodes=int(x.size), passed=passed,
                xi_min=float(np.min(np.linalg.norm(xi, axis=0))))


# ---------------------------------------------------------------------------------------------
# Cross-check of the compiled f against our trajectory.csv


def check_against_trajectory(lib, csv_path, eta):
    data = np.genfromtxt(csv_path, delimiter=",", names=True)
    cols = ["omega1", "omega2", "omega3", "xi1", "xi2", "xi3", "xidot1", "xidot2", "xidot3",
            "kappa1", "kappa2", "kappa3"]
    # The rows are 2001 uniform times merged with the mesh nodes (`--points`): keep the
    # uniform ones (the differences below need a uniform step).
    t_all = data["t"]
    h = (t_all[-1] - t_all[0]) / 2000
    grid = np.rint((t_all - t_all[0]) / h)
    uniform = np.abs(t_all - (t_all[0] + grid * h)) <= 1e-9 * (t_all[-1] - t_all[0])
    _, first = np.unique(grid[uniform], return_index=True)
    rows = np.flatnonzero(uniform)[first]
    assert len(rows) == 2001, f"{csv_path}: {len(rows)} uniform rows, expected 2001"
    t = t_all[rows]
    y = np.vstack([data[c][rows] for c in cols])
    params = np.array([*INERTIA, ALPHA, BETA, GAMMA, eta, DELTA])
    desired = DESIRED
    f = lib["ode_rhs"](y, params, desired(t))[0]
    # 6th-order central differences (truncation about h^6 y^(7) / 140, h = (b - a) / 2000)
    fd = (y[:, 6:] - 9 * y[:, 5:-1] + 45 * y[:, 4:-2] - 45 * y[:, 2:-4] + 9 * y[:, 1:-5]
          - y[:, :-6]) / (60 * h)
    keep = np.abs(t[3:-3] - B_D) > 0.3
    rel = (np.abs(fd - f[:, 3:-3]) / (1 + np.abs(f[:, 3:-3])))[:, keep]
    return float(np.max(rel)), float(np.median(rel)), int(keep.sum())


# ---------------------------------------------------------------------------------------------
# Runs and the table


def load_average():
    try:
        with open("/proc/loadavg") as fh:
            return tuple(float(v) for v in fh.read().split()[:3])
    except OSError:
        return tuple(float(v) for v in os.getloadavg())


def run_ours(binary, out):
    t = time.perf_counter()
    # Its result lines go to stdout (the command line's convention): not into the table.
    subprocess.run([binary, "paper", "--out", out, "-q"], check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t
    with open(os.path.join(out, "summary.json")) as fh:
        summary = json.load(fh)
    return wall, {c["name"]: c for c in summary["cases"]}


def run_scipy(lib, omega_b, log=None):
    out = {}
    for name, eta in CASES:
        Counter.solves = Counter.jacobians = 0
        t = time.perf_counter()
        try:
            sol, params, stages, case, delta_c = pipeline(lib, DESIRED, START_PATH, omega_b,
                                                          eta, log)
            err = None
        except StageFailed as e:
            sol, params, stages, case, delta_c, err = None, None, None, None, None, str(e)
        wall = time.perf_counter() - t
        out[name] = dict(wall=wall, sol=sol, params=params, stages=stages, case=case,
                         delta_c=delta_c, error=err, solves=Counter.solves,
                         jacobians=Counter.jacobians)
    return out


def median(v):
    return float(np.median(v)) if v else float("nan")


def fmt_s(v):
    return f"{v:.3f}" if v < 10 else f"{v:.1f}"


def main():
    global DESIRED, START_PATH, LEVEL, STEP_GROWTH, LOG
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=3, help="scipy pipeline runs (default 3)")
    ap.add_argument("--ours-runs", type=int, default=None,
                    help="runs of ours (default: max(5, 2 x runs)), spread between scipy's")
    ap.add_argument("--binary", default="/tmp/suslov-s10", help="our frozen `suslov` binary")
    ap.add_argument("--step-growth", type=float, default=STEP_GROWTH,
                    help="a continuation step may grow the mesh at most this many times "
                         f"(default {STEP_GROWTH}; 0: no limit, plain solve_bvp)")
    ap.add_argument("--verbose", action="store_true",
                    help="print the stages and steps of every scipy run (stderr)")
    args = ap.parse_args()
    STEP_GROWTH = args.step_growth
    ours_runs = args.ours_runs or max(5, 2 * args.runs)
    say = lambda *a: print(*a, file=sys.stderr, flush=True)  # noqa: E731

    t0 = time.perf_counter()
    names = ["ode_rhs", "ode_rhs_scaled", "ode_jac_scaled", "bc_endpoint", "bc_endpoint_jac",
             "free_time_condition", "free_time_condition_jac", "delta_start", "cost_integrand",
             "singular_control"]
    lib, fns, M = compile_functions(names)
    assert M.STATE_NAMES == ["omega1", "omega2", "omega3", "xi1", "xi2", "xi3", "xidot1",
                             "xidot2", "xidot3", "kappa1", "kappa2", "kappa3"], M.STATE_NAMES
    DESIRED, START_PATH, omega_b, LEVEL = paths()
    vs_mpmath = check_compiled(lib, fns, M)
    say(f"derivation + numpy compilation: {time.perf_counter() - t0:.1f} s; compiled vs "
        f"mpmath (same programs): max rel diff {vs_mpmath:.1e}")

    work = tempfile.mkdtemp(prefix="scipy_paper_")
    ours_wall, ours_cases, loads = [], [], []
    scipy_runs = []
    # ours first (also gives trajectory.csv for the f check), then alternate
    plan = []
    k_ours = 0
    for i in range(args.runs):
        share = (ours_runs - k_ours) // (args.runs - i)
        plan += ["ours"] * share + ["scipy"]
        k_ours += share
    plan += ["ours"] * (ours_runs - k_ours)
    checked = False
    for what in plan:
        before = load_average()
        if what == "ours":
            out = os.path.join(work, f"ours{len(ours_wall)}")
            wall, cases = run_ours(args.binary, out)
            ours_wall.append(wall)
            ours_cases.append(cases)
            loads.append(("ours", before, load_average()))
            say(f"ours #{len(ours_wall)}: {wall:.3f} s (solves "
                + ", ".join(f"{n} {c['wall_seconds']:.3f}" for n, c in cases.items())
                + f"), load {before[0]:.2f}")
            if not checked:
                for name, eta in CASES:
                    err, med, rows = check_against_trajectory(
                        lib, os.path.join(out, name, "trajectory.csv"), eta)
                    F_CHECK[name] = (err, med, rows)
                    say(f"f check on ours' {name}/trajectory.csv: |dy/dt (6th-order "
                        f"differences) - f(y)| / (1 + |f|): max {err:.1e}, median {med:.1e} "
                        f"over {rows} rows x 12 states")
                checked = True
        else:
            LOG = say if args.verbose else None
            res = run_scipy(lib, omega_b, LOG)
            scipy_runs.append(res)
            loads.append(("scipy", before, load_average()))
            say(f"scipy #{len(scipy_runs)}: " + ", ".join(
                f"{n} {r['wall']:.1f} s" + (f" (stopped: {r['error']})" if r["error"] else "")
                for n, r in res.items()) + f", load {before[0]:.2f}")

    shutil.rmtree(work, ignore_errors=True)

    # ---- table ---------------------------------------------------------------------------
    last = scipy_runs[-1]
    tot_scipy = [sum(r[n]["wall"] for n, _ in CASES) for r in scipy_runs]
    tot_ours_solve = [sum(c[n]["wall_seconds"] for n, _ in CASES) for c in ours_cases]
    print(f"Python {platform.python_version()}, numpy {np.__version__}, scipy "
          f"{scipy.__version__}, sympy {sp.__version__}; ours: {args.binary}; "
          f"{len(scipy_runs)} scipy runs, {len(ours_wall)} runs of ours, alternated. "
          f"step growth limit {STEP_GROWTH:g}.")
    print()
    print(f"Right-hand side: compiled codegen programs vs their mpmath evaluation: max rel diff "
          f"{vs_mpmath:.1e}; " + "; ".join(
              f"vs ours' {n}/trajectory.csv (6th-order differences, {r} rows x 12): max "
              f"{e:.1e}, median {m:.1e}" for n, (e, m, r) in F_CHECK.items()) + ".")
    print()
    print("| case | scipy median s (solves) | ours median s (solves, summary.json) | ratio (solves) "
          "| ours median s (whole `suslov paper`) | ratio (whole run) | scipy b | ours b | "
          "diff b | scipy J | ours J | diff J | scipy nodes | our nodes | scipy checks |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    whole = median(ours_wall)
    for name, _ in CASES:
        s_med = median([r[name]["wall"] for r in scipy_runs])
        o_med = median([c[name]["wall_seconds"] for c in ours_cases])
        oc = ours_cases[-1][name]
        r = last[name]
        if r["sol"] is not None:
            chk = checks(lib, DESIRED, omega_b, r["sol"], r["params"])
            r["checks"] = chk
            sb, sj, sn = f"{chk['b']:.12f}", f"{chk['cost']:.12f}", str(chk["nodes"])
            db = f"{chk['b'] - oc['terminal_time']:.1e}"
            dj = f"{chk['cost'] - oc['cost']:.1e}"
            verdict = ("passed" if chk["passed"] else "FAILED") + (
                f" (constraint {chk['constraint']:.0e}, energy {chk['energy']:.0e}, "
                f"bc {chk['bc']:.0e})")
        else:
            sb = sj = sn = db = dj = "-"
            verdict = f"stopped: {r['error']}"
        print(f"| {name} | {fmt_s(s_med)} | {fmt_s(o_med)} | {s_med / o_med:.0f}x | - | - | "
              f"{sb} | {oc['terminal_time']:.12f} | {db} | {sj} | {oc['cost']:.12f} | {dj} | "
              f"{sn} | {oc['mesh_nodes']} | {verdict} |")
    s_tot, o_tot = median(tot_scipy), median(tot_ours_solve)
    print(f"| total | {fmt_s(s_tot)} | {fmt_s(o_tot)} | {s_tot / o_tot:.0f}x | {fmt_s(whole)} | "
          f"{s_tot / whole:.0f}x | | | | | | | | | |")
    print()
    print("Runs (s), in order, with the 1-minute load average before / after each:")
    print()
    print("| run | what | seconds | load before | load after |")
    print("|---|---|---|---|---|")
    i_o = i_s = 0
    for k, (what, before, after) in enumerate(loads):
        if what == "ours":
            sec = f"{ours_wall[i_o]:.3f} (solves {tot_ours_solve[i_o]:.3f})"
            i_o += 1
        else:
            sec = f"{tot_scipy[i_s]:.1f} (" + ", ".join(
                f"{n} {scipy_runs[i_s][n]['wall']:.1f}" for n, _ in CASES) + ")"
            i_s += 1
        print(f"| {k + 1} | {what} | {sec} | {before[0]:.2f} | {after[0]:.2f} |")
    print()
    print("Against the expected answers (ours, issue #13 brief) and the stages of the last "
          "scipy run:")
    print()
    for name, _ in CASES:
        r = last[name]
        eb, ej = EXPECTED[name]
        if r["sol"] is None:
            print(f"* {name}: scipy stopped: {r['error']}")
            continue
        chk = r["checks"]
        st = "; ".join(f"{s['name']} ({s['steps']} steps, {s['nodes']} nodes)"
                       if s["steps"] is not None else f"{s['name']} ({s['nodes']} nodes)"
                       for s in r["stages"])
        print(f"* {name}: b - expected = {chk['b'] - eb:.2e}, J - expected = "
              f"{chk['cost'] - ej:.2e}; paper case {r['case']}, delta_c = {r['delta_c']:.6f}; "
              f"{r['solves']} solve_bvp calls, {r['jacobians']} collocation Jacobians; "
              f"min |xi| {chk['xi_min']:.4f}, |Omega(b) - Omega_b|/|Omega_b| "
              f"{chk['omega_b']:.0e}; stages: {st}")


DESIRED = START_PATH = LEVEL = LOG = None
F_CHECK = {}

if __name__ == "__main__":
    main()
