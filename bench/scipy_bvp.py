"""Solve the benchmark problems of `benches/bvp.rs` with scipy.integrate.solve_bvp.

Same problems, initial meshes (11 uniform nodes on [0, 1]), guesses and tolerances
(1e-6, 1e-8) as the Rust benchmark; analytic Jacobians (fun_jac, bc_jac) are supplied to
scipy as well. Prints a Markdown table: median wall time of repeated solves, nodes, status,
and the max error against the exact solution relative to 1 + |y| (nodes and dense output).

Note the tolerances mean different things: scipy controls the RMS relative residual
(4th-order cubic collocation), the Rust solver an error estimate of its 6th-order scheme.
The error column shows what each actually delivers.

Run: python3 bench/scipy_bvp.py   (needs numpy, scipy)
"""
import time

import numpy as np
from scipy.integrate import solve_bvp

PI = np.pi


def linear():
    def f(x, y):
        return np.vstack((y[1], PI**2 * (y[0] - x**2) - 2 * PI**2 * np.sin(PI * x) + 2))

    def fj(x, y):
        j = np.zeros((2, 2, x.size))
        j[0, 1] = 1
        j[1, 0] = PI**2
        return j

    def bc(ya, yb):
        return np.array([ya[0], yb[0] - 1])

    def bcj(ya, yb):
        return np.array([[1.0, 0], [0, 0]]), np.array([[0.0, 0], [1, 0]])

    def exact(x):
        return np.vstack((np.sin(PI * x) + x**2, PI * np.cos(PI * x) + 2 * x))

    return f, fj, bc, bcj, exact, lambda x: np.zeros((2, x.size)), None, None


def quadratic():
    def f(x, y):
        return np.vstack((y[1], 1.5 * y[0] ** 2))

    def fj(x, y):
        j = np.zeros((2, 2, x.size))
        j[0, 1] = 1
        j[1, 0] = 3 * y[0]
        return j

    def bc(ya, yb):
        return np.array([ya[0] - 4, yb[0] - 1])

    def bcj(ya, yb):
        return np.array([[1.0, 0], [0, 0]]), np.array([[0.0, 0], [1, 0]])

    def exact(x):
        return np.vstack((4 / (1 + x) ** 2, -8 / (1 + x) ** 3))

    return f, fj, bc, bcj, exact, lambda x: np.vstack((4 - 3 * x, -3 * np.ones_like(x))), None, None


def sturm():
    def f(x, y, p):
        return np.vstack((y[1], -p[0] ** 2 * y[0]))

    def fj(x, y, p):
        j = np.zeros((2, 2, x.size))
        j[0, 1] = 1
        j[1, 0] = -p[0] ** 2
        jp = np.zeros((2, 1, x.size))
        jp[1, 0] = -2 * p[0] * y[0]
        return j, jp

    def bc(ya, yb, p):
        return np.array([ya[0], yb[0], ya[1] - p[0]])

    def bcj(ya, yb, p):
        return (np.array([[1.0, 0], [0, 0], [0, 1]]), np.array([[0.0, 0], [1, 0], [0, 0]]),
                np.array([[0.0], [0], [-1]]))

    def exact(x):
        return np.vstack((np.sin(PI * x), PI * np.cos(PI * x)))

    return (f, fj, bc, bcj, exact, lambda x: np.vstack((np.sin(3 * x), 3 * np.cos(3 * x))),
            np.array([3.0]), np.array([PI]))


def layer(eps=1e-3):
    def f(x, y):
        return np.vstack((y[1], -y[1] / eps))

    def fj(x, y):
        j = np.zeros((2, 2, x.size))
        j[0, 1] = 1
        j[1, 1] = -1 / eps
        return j

    def bc(ya, yb):
        return np.array([ya[0], yb[0] - 1])

    def bcj(ya, yb):
        return np.array([[1.0, 0], [0, 0]]), np.array([[0.0, 0], [1, 0]])

    def exact(x):
        d = -np.expm1(-1 / eps)
        return np.vstack((-np.expm1(-x / eps) / d, np.exp(-x / eps) / (eps * d)))

    return f, fj, bc, bcj, exact, lambda x: np.vstack((x, np.ones_like(x))), None, None


def bratu_theta(lam, t):
    s = np.sqrt(2 * lam)
    for _ in range(100):
        t -= (t - s * np.cosh(t / 4)) / (1 - s * np.sinh(t / 4) / 4)
    return t


def bratu(theta0, guess):
    lam = 1.0
    th = bratu_theta(lam, theta0)

    def f(x, y):
        return np.vstack((y[1], -lam * np.exp(y[0])))

    def fj(x, y):
        j = np.zeros((2, 2, x.size))
        j[0, 1] = 1
        j[1, 0] = -lam * np.exp(y[0])
        return j

    def bc(ya, yb):
        return np.array([ya[0], yb[0]])

    def bcj(ya, yb):
        return np.array([[1.0, 0], [0, 0]]), np.array([[0.0, 0], [1, 0]])

    def exact(x):
        s = (x - 0.5) * th / 2
        return np.vstack((-2 * np.log(np.cosh(s) / np.cosh(th / 4)), -th * np.tanh(s)))

    return f, fj, bc, bcj, exact, guess, None, None


def tanh_layer(w=0.01):
    def prof(x):
        u = np.tanh((x - 0.5) / w)
        du = (1 - u * u) / w
        return u, du, -2 * u * du / w

    def f(x, y):
        u, _, d2u = prof(x)
        return np.vstack((y[1], y[0] ** 3 + d2u - u**3))

    def fj(x, y):
        j = np.zeros((2, 2, x.size))
        j[0, 1] = 1
        j[1, 0] = 3 * y[0] ** 2
        return j

    ua, ub = prof(np.array([0.0]))[0][0], prof(np.array([1.0]))[0][0]

    def bc(ya, yb):
        return np.array([ya[0] - ua, yb[0] - ub])

    def bcj(ya, yb):
        return np.array([[1.0, 0], [0, 0]]), np.array([[0.0, 0], [1, 0]])

    def exact(x):
        u, du, _ = prof(x)
        return np.vstack((u, du))

    return f, fj, bc, bcj, exact, lambda x: np.vstack((2 * x - 1, 2 * np.ones_like(x))), None, None


def layered_system():
    """n = 12, k = 1; see `LayeredSystem` in tests/common/mod.rs."""
    T = 2.0

    def profile(j, s):
        if j == 0:
            w = 0.01
            u = np.tanh((s - 0.5) / w)
            du = (1 - u * u) / w
            return u, du, -2 * u * du / w
        if j == 1:
            b = 1e-3
            e = np.exp(-s / b)
            return e + s, -e / b + 1, e / b**2
        if j == 2:
            return np.sin(3 * s), 3 * np.cos(3 * s), -9 * np.sin(3 * s)
        if j == 3:
            b = 5e-3
            e = np.exp((s - 1) / b)
            return e, e / b, e / b**2
        if j == 4:
            return s * s, 2 * s, 2 + 0 * s
        w = 0.05
        u = np.tanh((s - 0.3) / w)
        du = (1 - u * u) / w
        return u, du, -2 * u * du / w

    def f(s, y, p):
        out = np.empty_like(y)
        for j in range(6):
            uu, _, d2u = profile(j, s)
            u = y[2 * j]
            couple = 0.1 * (y[2 * j + 2] - profile(j + 1, s)[0]) if j < 5 else 0
            out[2 * j] = y[2 * j + 1]
            out[2 * j + 1] = (1 + j) ** 2 * (u - uu) + (u**3 - uu**3) + d2u + (p[0] - T) * u + couple
        return out

    def fj(s, y, p):
        j_ = np.zeros((12, 12, s.size))
        jp = np.zeros((12, 1, s.size))
        for j in range(6):
            u = y[2 * j]
            j_[2 * j, 2 * j + 1] = 1
            j_[2 * j + 1, 2 * j] = (1 + j) ** 2 + 3 * u * u + (p[0] - T)
            if j < 5:
                j_[2 * j + 1, 2 * j + 2] = 0.1
            jp[2 * j + 1, 0] = u
        return j_, jp

    def bc(ya, yb, p):
        r = np.empty(13)
        for j in range(6):
            r[j] = ya[2 * j] - profile(j, 0.0)[0]
            r[6 + j] = yb[2 * j] - profile(j, 1.0)[0]
        r[12] = ya[1] - profile(0, 0.0)[1]
        return r

    def bcj(ya, yb, p):
        da = np.zeros((13, 12))
        db = np.zeros((13, 12))
        for j in range(6):
            da[j, 2 * j] = 1
            db[6 + j, 2 * j] = 1
        da[12, 1] = 1
        return da, db, np.zeros((13, 1))

    def exact(s):
        rows = []
        for j in range(6):
            u, du, _ = profile(j, s)
            rows += [u, du]
        return np.vstack(rows)

    def guess(s):
        rows = []
        for j in range(6):
            a, b = profile(j, 0.0)[0], profile(j, 1.0)[0]
            rows += [a + (b - a) * s, (b - a) * np.ones_like(s)]
        return np.vstack(rows)

    return f, fj, bc, bcj, exact, guess, np.array([2.5]), np.array([T])


PROBLEMS = [
    ("linear", linear()),
    ("nonlinear y''=1.5y^2", quadratic()),
    ("sturm-liouville (k=1)", sturm()),
    ("boundary layer 1e-3", layer()),
    ("bratu lower", bratu(1.0, lambda x: np.zeros((2, x.size)))),
    ("bratu upper", bratu(10.0, lambda x: np.vstack((3 * np.ones_like(x), np.zeros_like(x))))),
    ("tanh layer w=0.01", tanh_layer()),
    ("layered n=12 k=1", layered_system()),
]


def median_time(fn, budget=0.4, min_reps=5, max_reps=101):
    times = []
    start = time.perf_counter()
    while True:
        t = time.perf_counter()
        res = fn()
        times.append(time.perf_counter() - t)
        if (len(times) >= min_reps and time.perf_counter() - start > budget) or len(times) >= max_reps:
            break
    return float(np.median(times)), res


def main():
    print("| problem                | tol   | median ms  | nodes  | status | max err  |")
    print("|------------------------|-------|------------|--------|--------|----------|")
    for name, (f, fj, bc, bcj, exact, guess, p0, p_exact) in PROBLEMS:
        x = np.linspace(0, 1, 21 if name.startswith("layered") else 11)
        for tol in (1e-6, 1e-8):
            def run():
                return solve_bvp(f, bc, x, guess(x), p=p0, fun_jac=fj, bc_jac=bcj, tol=tol, max_nodes=100000)

            t, res = median_time(run)
            xs = np.linspace(0, 1, 2001)
            ex_n, ex_d = exact(res.x), exact(xs)
            err = max(np.max(np.abs(res.y - ex_n) / (1 + np.abs(ex_n))),
                      np.max(np.abs(res.sol(xs) - ex_d) / (1 + np.abs(ex_d))))
            if p_exact is not None:
                err = max(err, np.max(np.abs(res.p - p_exact) / (1 + np.abs(p_exact))))
            print(f"| {name:<22} | {tol:.0e} | {t * 1e3:10.3f} | {res.x.size:6d} | {res.status:6d} | {err:8.1e} |")


if __name__ == "__main__":
    main()
