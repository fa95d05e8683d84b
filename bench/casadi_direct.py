#!/usr/bin/env python3
"""Independent direct-transcription reference for Suslov's optimal control problem.

No suslov code is used: the problem file (TOML, the schema of README.md) is read here, the
desired path is re-implemented here, and the optimal control problem is transcribed by
direct collocation in CasADi and solved by IPOPT.

Problem (fixed terminal time b):

    minimize  int_a^b  alpha/4 (|xi|^2 - 1)^2 + beta/2 |xi'|^2 + gamma/2 |Om - Om_d(t)|^2
                       + eta/2 |Om'|^2  dt
    s.t.      I Om' = (I Om) x Om + lam xi,   <Om, xi> = 0,
              Om(a) = Om_a,  Om(b) = Om_b,  xi(a), xi(b) free.

Transcription (nothing divides by |xi|^2, so xi may pass through 0):

* states x = (Om, xi), controls u = xi' and the multiplier lam (algebraic), both defined
  at the collocation points only;
* Radau IIA collocation of degree 3 (LGR points 0.155, 0.645, 1) on each mesh interval:
  the state is a cubic through the interval's start node and its three collocation points
  (the last one is the next node, so states are continuous across nodes; xi' = u may jump
  there, which lets a corner of xi appear at a node);
* the DAE is kept at index 2: <Om, xi> = 0 is imposed at every collocation point and at
  t = a (consistency of the free xi(a)); no index reduction, because the index-1 form
  <Om', xi> + <Om, xi'> = 0 determines lam only through <xi, I^-1 xi> (it degenerates at
  xi = 0 exactly where we want to look).  Radau IIA is the standard scheme for index-2
  DAEs; the multiplier lam is an algebraic variable of the NLP;
* the cost is integrated with the 3-point Radau quadrature of each interval, Om' in the
  eta term is the dynamics' right-hand side (so it equals the collocation derivative);
* Om(a) = Om_a by bounds; at b only the two components of Om(b) - Om_b tangent to the
  energy ellipsoid at Om_b are imposed (energy is a first integral: a third equation would
  be redundant; the normal component's error is reported).

Usage:

    python3 bench/casadi_direct.py PROBLEM.toml [--N 100 200 400] [--guess segment-cross
        segment-invdyn random:1 csv:PATH ...] [--alpha-from K --alpha-steps S]
        [--out DIR] [--name NAME] [--cold]

For each initial guess the meshes N are solved in order, each warm-started from the previous
mesh's solution (``--cold``: every N from the guess itself).  Results are printed as a table
and written to DIR/<name>.results.json; every solution is written as CSV
``t,omega1,omega2,omega3,xi1,xi2,xi3,xidot1,xidot2,xidot3`` on the collocation grid (t = a
and the 3N collocation points; xi' = u there, at t = a the first cubic's derivative) to
DIR/<name>/<guess>_N<N>.csv, and ``t,lambda`` to DIR/<name>/<guess>_N<N>.lambda.csv.  The default DIR is target/tmp/casadi.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
import tomllib

os.environ.setdefault("OMP_NUM_THREADS", "1")  # single-threaded (shared machine)

import numpy as np  # noqa: E402
import casadi as ca  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_OUT = os.path.join(os.path.dirname(HERE), "target", "tmp", "casadi")


# ----------------------------------------------------------------------------------------
# Problem
# ----------------------------------------------------------------------------------------


class Problem:
    """The problem of a TOML file (fixed terminal time; desired kinds segment and
    paper-spiral)."""

    def __init__(self, path: str):
        with open(path, "rb") as fh:
            d = tomllib.load(fh)
        self.path = path
        self.name = d.get("name", os.path.splitext(os.path.basename(path))[0])
        self.I = np.array(d["body"]["inertia"], dtype=float)
        bd = d["boundary"]
        self.a = float(bd.get("t0", 0.0))
        tt = bd["terminal_time"]
        if "fixed" not in tt:
            raise SystemExit(f"{path}: only terminal_time = {{ fixed = b }} is supported")
        self.b = float(tt["fixed"])
        self.omega_a = np.array(bd["omega_a"], dtype=float)
        self.Ta = self.energy(self.omega_a)
        c = d["cost"]
        self.alpha = float(c["alpha"])
        self.beta = float(c["beta"])
        self.gamma = float(c.get("gamma", 0.0))
        self.eta = float(c.get("eta", 0.0))
        self.delta = float(c.get("delta", 0.0))  # only shifts the cost at fixed b
        des = d["desired"]
        self.kind = des["kind"]
        self.special = []  # (time, half-width) of sharp features of Om_d
        ob = bd["omega_b"]
        if self.kind == "segment":
            frm = np.array(des.get("from", self.omega_a), dtype=float)
            if "to" in des:
                to = np.array(des["to"], dtype=float)
            elif isinstance(ob, list):
                to = np.array(ob, dtype=float)
            else:
                raise SystemExit(f"{path}: segment needs desired.to with omega_b = desired_end")
            iv = des.get("interval", [self.a, self.b])
            self.seg = (self.project(frm), self.project(to), float(iv[0]), float(iv[1]))
            end = self.seg[1]
        elif self.kind == "paper-spiral":
            self.c = float(des.get("c", 10.0))
            self.width = float(des.get("width", 0.01))
            self.b_d = float(des.get("b_d", 10.0))
            self.spiral_end = self.project(self.phi(np.array([self.b_d]))[:, 0])
            end = self.spiral_end
            if self.a < self.b_d < self.b:
                self.special.append((self.b_d, 10.0 * self.width))
        else:
            raise SystemExit(f"{path}: desired.kind = {self.kind!r} not supported here")
        if isinstance(ob, str):
            if ob != "desired_end":
                raise SystemExit(f"{path}: omega_b = {ob!r}")
            self.omega_b = self.project(end)
        else:
            ob = np.array(ob, dtype=float)
            rel = abs(self.energy(ob) - self.Ta) / self.Ta
            if rel > 1e-9:
                print(f"warning: omega_b off the ellipsoid by {rel:.2e} (projected)", file=sys.stderr)
            self.omega_b = self.project(ob)

    # energy 2T = <Om, I Om>
    def energy(self, v):
        return float(np.dot(v, self.I * v))

    def project(self, v):
        """Radial projection onto E = {<Om, I Om> = <Om_a, I Om_a>} (v: 3 or 3xM)."""
        v = np.asarray(v, dtype=float)
        if v.ndim == 1:
            return v * math.sqrt(self.Ta / self.energy(v))
        e = np.sum(v * (self.I[:, None] * v), axis=0)
        return v * np.sqrt(self.Ta / e)[None, :]

    def phi(self, t):
        t = np.asarray(t, dtype=float)
        return np.vstack([np.full_like(t, self.c), t * np.cos(t), t * np.sin(t)])

    def desired(self, t):
        """Om_d(t), 3xM."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if self.kind == "segment":
            frm, to, t0, t1 = self.seg
            u = (t - t0) / (t1 - t0)
            return self.project(frm[:, None] + u[None, :] * (to - frm)[:, None])
        phip = self.project(self.phi(t))
        s = 0.5 * (1.0 + np.tanh((t - self.b_d) / self.width))
        return phip * (1.0 - s)[None, :] + self.spiral_end[:, None] * s[None, :]

    def segment_path(self, t):
        """Projected segment Om_a -> Om_b over [a, b] (initial guesses), and its derivative."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        T = self.b - self.a

        def p(tt):
            u = (tt - self.a) / T
            return self.project(self.omega_a[:, None] + u[None, :] * (self.omega_b - self.omega_a)[:, None])

        eps = 1e-6 * T
        return p(t), (p(t + eps) - p(t - eps)) / (2 * eps)


# ----------------------------------------------------------------------------------------
# Radau IIA (LGR) collocation data
# ----------------------------------------------------------------------------------------

DEG = 3
TAU = np.array([0.0] + list(ca.collocation_points(DEG, "radau")))  # 0, t1, t2, 1


def _lagrange(nodes):
    """Coefficient vectors (highest power first) of the Lagrange basis on nodes."""
    basis = []
    for r in range(len(nodes)):
        p = np.poly1d([1.0])
        for s in range(len(nodes)):
            if s != r:
                p *= np.poly1d([1.0, -nodes[s]]) / (nodes[r] - nodes[s])
        basis.append(p)
    return basis


BASIS = _lagrange(TAU)
# C[r, j] = d l_r / d tau at tau_j  (j = 1..DEG)
CMAT = np.array([[np.polyder(BASIS[r])(TAU[j]) for j in range(1, DEG + 1)] for r in range(DEG + 1)])
# Radau quadrature weights on the collocation points only
QW = np.array([np.polyint(p)(1.0) - np.polyint(p)(0.0) for p in _lagrange(TAU[1:])])


def make_mesh(prob: Problem, N: int, graded: bool = True):
    """Mesh nodes: uniform, or with 20 % of the intervals in windows around sharp features
    of Om_d (the paper spiral's sigmoid), with a node at the feature's time."""
    a, b = prob.a, prob.b
    if not graded or not prob.special:
        return np.linspace(a, b, N + 1)
    (ts, hw), = prob.special[:1]
    lo, hi = max(a, ts - hw), min(b, ts + hw)
    nw = max(2, int(round(0.2 * N)))
    nw += nw % 2
    rest = N - nw
    left_len, right_len = lo - a, b - hi
    nl = int(round(rest * left_len / (left_len + right_len))) if left_len + right_len > 0 else 0
    nr = rest - nl
    parts = []
    if nl > 0:
        parts.append(np.linspace(a, lo, nl + 1)[:-1])
    parts.append(np.linspace(lo, ts, nw // 2 + 1)[:-1])
    parts.append(np.linspace(ts, hi, nw // 2 + 1)[:-1] if nr > 0 else np.linspace(ts, hi, nw // 2 + 1))
    if nr > 0:
        parts.append(np.linspace(hi, b, nr + 1))
    return np.concatenate(parts)


def colloc_times(mesh):
    h = np.diff(mesh)
    tc = (mesh[:-1, None] + h[:, None] * TAU[None, 1:]).ravel()
    return np.concatenate([[mesh[0]], tc]), h  # 3N+1 state columns; tc[1:] are colloc pts


# ----------------------------------------------------------------------------------------
# Transcription
# ----------------------------------------------------------------------------------------


def cross_cols(p, q):
    return ca.vertcat(
        p[1, :] * q[2, :] - p[2, :] * q[1, :],
        p[2, :] * q[0, :] - p[0, :] * q[2, :],
        p[0, :] * q[1, :] - p[1, :] * q[0, :],
    )


class Transcription:
    def __init__(self, prob: Problem, mesh: np.ndarray, alpha: float, xi_min: float = 0.0,
                 relaxed: bool = False):
        """xi_min > 0 adds |xi|^2 >= xi_min^2 at every state column (a probe for regular
        solutions).  relaxed: the xi -> 0 limit problem (lam xi replaced by a free torque
        tau _|_ Om, stored in the xi slots with lam = 1; the alpha term becomes the constant
        alpha/4 (b - a), the beta term 0): its cost is the infimum of the costs of controls
        whose xi shrinks to 0 everywhere."""
        self.prob, self.mesh, self.alpha = prob, mesh, alpha
        self.xi_min, self.relaxed = xi_min, relaxed
        N = len(mesh) - 1
        self.N = N
        M = DEG * N
        self.tall, self.h = colloc_times(mesh)
        self.lam_scale = 1.0 if relaxed else max(prob.Ta, 1e-12)  # lam ~ |Om|^2 I
        nX, nU, nL = 6 * (M + 1), 3 * M, M
        self.nX, self.nU, self.nL = nX, nU, nL
        w = ca.SX.sym("w", nX + nU + nL)
        X = ca.reshape(w[:nX], 6, M + 1)
        U = ca.reshape(w[nX:nX + nU], 3, M)
        L = ca.reshape(w[nX + nU:], 1, M) * self.lam_scale
        Om, Xi = X[0:3, :], X[3:6, :]
        Ic = ca.DM(prob.I)
        IOm = ca.repmat(Ic, 1, M + 1) * Om
        Omc, Xic, IOmc = Om[:, 1:], Xi[:, 1:], IOm[:, 1:]
        Iinv = ca.repmat(ca.DM(1.0 / prob.I), 1, M)
        dOm = Iinv * (cross_cols(IOmc, Omc) + ca.repmat(L, 3, 1) * Xic)  # 3xM at colloc pts
        # collocation derivative at the colloc points
        hcol = np.repeat(self.h, DEG)
        dX = []
        for j in range(DEG):
            cols = [X[:, r:M + 1 - DEG + r:DEG] if r < DEG else X[:, DEG::DEG] for r in range(DEG + 1)]
            s = 0
            for r in range(DEG + 1):
                s = s + CMAT[r, j] * cols[r]
            dX.append(s)  # 6xN, interval k column
        # interleave to 6xM in column order 3k+j
        dXc = ca.SX.zeros(6, M)
        for j in range(DEG):
            dXc[:, j::DEG] = dX[j]
        hinv = ca.repmat(ca.DM(1.0 / hcol).T, 6, 1)
        g_col = dXc * hinv - ca.vertcat(dOm, U)
        g_path = ca.sum1(Om * Xi)  # 1x(M+1)
        n = prob.I * prob.omega_b
        n = n / np.linalg.norm(n)
        e1 = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)
        self.tangent = np.vstack([e1, e2])
        g_end = ca.mtimes(ca.DM(self.tangent), Om[:, M] - ca.DM(prob.omega_b))
        g = ca.vertcat(ca.vec(g_col), ca.vec(g_path), g_end)
        self.lbg = np.zeros(g.shape[0])
        self.ubg = np.zeros(g.shape[0])
        if xi_min > 0:
            g = ca.vertcat(g, ca.vec(ca.sum1(Xi * Xi)))
            self.lbg = np.concatenate([self.lbg, np.full(M + 1, xi_min ** 2)])
            self.ubg = np.concatenate([self.ubg, np.full(M + 1, np.inf)])
        # cost at the colloc points
        Omd = prob.desired(self.tall[1:])
        x2 = ca.sum1(Xic * Xic)
        a_term = alpha / 4 * (x2 - 1) ** 2 if not relaxed else alpha / 4 + 0 * x2
        b_coef = 0.0 if relaxed else prob.beta
        runn = (
            a_term
            + b_coef / 2 * ca.sum1(U * U)
            + prob.gamma / 2 * ca.sum1((Omc - ca.DM(Omd)) ** 2)
            + prob.eta / 2 * ca.sum1(dOm * dOm)
        )
        qw = np.tile(QW, N) * hcol
        J = ca.mtimes(runn, ca.DM(qw)) + prob.delta * (prob.b - prob.a)
        self.w, self.g, self.J = w, g, J
        self.ng = g.shape[0]
        lbx = -np.inf * np.ones(w.shape[0])
        ubx = np.inf * np.ones(w.shape[0])
        lbx[0:3] = ubx[0:3] = prob.omega_a
        if relaxed:
            lbx[nX + nU:] = ubx[nX + nU:] = 1.0
        self.lbx, self.ubx = lbx, ubx
        self.parts_fn = ca.Function(
            "parts",
            [w],
            [
                ca.mtimes(a_term, ca.DM(qw)),
                ca.mtimes(b_coef / 2 * ca.sum1(U * U), ca.DM(qw)),
                ca.mtimes(prob.gamma / 2 * ca.sum1((Omc - ca.DM(Omd)) ** 2), ca.DM(qw)),
                ca.mtimes(prob.eta / 2 * ca.sum1(dOm * dOm), ca.DM(qw)),
            ],
        )

    def solver(self, max_time: float, log: str | None, obj_scale: float = 1.0):
        opts = {
            "ipopt.tol": 1e-10,
            "ipopt.acceptable_tol": 1e-7,
            "ipopt.max_iter": 3000,
            "ipopt.max_cpu_time": max_time,
            "ipopt.linear_solver": "mumps",
            "ipopt.print_level": 5 if log else 0,
            "ipopt.mu_strategy": "adaptive",
            "print_time": False,
        }
        if obj_scale != 1.0:
            opts["ipopt.obj_scaling_factor"] = obj_scale
        if log:
            opts["ipopt.output_file"] = log
            opts["ipopt.file_print_level"] = 5
            opts["ipopt.print_level"] = 0
        return ca.nlpsol("S", "ipopt", {"x": self.w, "f": self.J, "g": self.g}, opts)

    # -- packing ----------------------------------------------------------------------
    def pack(self, Om, Xi, U, Lam):
        """Om, Xi: 3x(M+1) at tall; U: 3xM, Lam: M at the colloc points."""
        X = np.vstack([Om, Xi])
        return np.concatenate([X.T.ravel(), U.T.ravel(), np.asarray(Lam).ravel() / self.lam_scale])

    def unpack(self, w):
        w = np.asarray(w).ravel()
        M = DEG * self.N
        X = w[: self.nX].reshape(M + 1, 6).T
        U = w[self.nX: self.nX + self.nU].reshape(M, 3).T
        L = w[self.nX + self.nU:] * self.lam_scale
        return X[0:3], X[3:6], U, L


# ----------------------------------------------------------------------------------------
# Solutions: evaluation, diagnostics, interpolation
# ----------------------------------------------------------------------------------------


class Solution:
    def __init__(self, tr: Transcription, w):
        self.tr = tr
        self.Om, self.Xi, self.U, self.L = tr.unpack(w)
        self.tall = tr.tall

    def interval_poly(self, k, comp):
        """Values at tau nodes of interval k (6 x 4)."""
        X = np.vstack([self.Om, self.Xi])
        return X[:, DEG * k: DEG * k + DEG + 1]

    def dense(self, per=20):
        """States and their derivatives on a fine grid (per points per interval)."""
        X = np.vstack([self.Om, self.Xi])
        tau = np.linspace(0, 1, per + 1)[:-1]
        Lv = np.array([[p(t) for t in tau] for p in BASIS])  # 4 x per
        dLv = np.array([[np.polyder(p)(t) for t in tau] for p in BASIS])
        ts, xs, dxs = [], [], []
        for k in range(self.tr.N):
            seg = X[:, DEG * k: DEG * k + DEG + 1]
            ts.append(self.tr.mesh[k] + self.tr.h[k] * tau)
            xs.append(seg @ Lv)
            dxs.append(seg @ dLv / self.tr.h[k])
        ts.append([self.tr.mesh[-1]])
        xs.append(X[:, -1:])
        seg = X[:, -DEG - 1:]
        dxs.append(seg @ np.array([[np.polyder(p)(1.0)] for p in BASIS]) / self.tr.h[-1])
        return np.concatenate(ts), np.hstack(xs), np.hstack(dxs)

    def xidot_at_nodes(self):
        """xi' from the left and from the right at the interior nodes (polynomials)."""
        d0 = np.array([np.polyder(p)(0.0) for p in BASIS])
        d1 = np.array([np.polyder(p)(1.0) for p in BASIS])
        left, right = [], []
        for k in range(self.tr.N):
            seg = self.Xi[:, DEG * k: DEG * k + DEG + 1]
            right.append(seg @ d0 / self.tr.h[k])
            left.append(seg @ d1 / self.tr.h[k])
        return np.array(left[:-1]).T, np.array(right[1:]).T  # 3 x (N-1), node k+1

    def diagnostics(self):
        prob = self.tr.prob
        t, x, dx = self.dense()
        xin = np.linalg.norm(x[3:6], axis=0)
        imin = int(np.argmin(xin))
        cons_dense = np.abs(np.sum(x[0:3] * x[3:6], axis=0))
        cons_pts = np.abs(np.sum(self.Om * self.Xi, axis=0))
        left, right = self.xidot_at_nodes()
        jump = np.linalg.norm(left - right, axis=0)
        ij = int(np.argmax(jump)) if jump.size else 0
        unorm = np.linalg.norm(self.U, axis=0)
        energy = np.sum(self.Om * (prob.I[:, None] * self.Om), axis=0)
        ixc = int(np.argmin(np.linalg.norm(self.Xi[:, 1:], axis=0)))
        return {
            "min_xi": float(xin[imin]),
            "t_min_xi": float(t[imin]),
            "min_xi_colloc": float(np.linalg.norm(self.Xi, axis=0).min()),
            "max_xi": float(xin.max()),
            "max_constraint_colloc": float(cons_pts.max()),
            "max_constraint_dense": float(cons_dense.max()),
            "max_xidot": float(unorm.max()),
            "t_max_xidot": float(self.tall[1:][int(np.argmax(unorm))]),
            "max_xidot_jump": float(jump[ij]) if jump.size else 0.0,
            "t_max_xidot_jump": float(self.tr.mesh[ij + 1]) if jump.size else None,
            "max_lambda": float(np.abs(self.L).max()),
            "t_max_lambda": float(self.tall[1:][int(np.argmax(np.abs(self.L)))]),
            "lambda_at_min_xi": float(self.L[ixc]),
            "energy_drift_rel": float(np.abs(energy - prob.Ta).max() / prob.Ta),
            "omega_b_error": float(np.linalg.norm(self.Om[:, -1] - prob.omega_b)),
        }

    def write_csv(self, path):
        # colloc grid columns: tall; xi' = u at colloc points, polynomial derivative at a
        d0 = np.array([np.polyder(p)(0.0) for p in BASIS])
        xd_a = self.Xi[:, : DEG + 1] @ d0 / self.tr.h[0]
        XD = np.hstack([xd_a[:, None], self.U])
        data = np.vstack([self.tall, self.Om, self.Xi, XD]).T
        hdr = "t,omega1,omega2,omega3,xi1,xi2,xi3,xidot1,xidot2,xidot3"
        np.savetxt(path, data, delimiter=",", header=hdr, comments="", fmt="%.16e")
        # the multiplier (at the collocation points) in a sibling file
        lam = np.vstack([self.tall[1:], self.L]).T
        np.savetxt(path[:-4] + ".lambda.csv", lam, delimiter=",", header="t,lambda", comments="",
                   fmt="%.16e")

    def at(self, tq):
        """Interpolate states (polynomial) and controls/multiplier (linear) at times tq."""
        X = np.vstack([self.Om, self.Xi])
        mesh = self.tr.mesh
        k = np.clip(np.searchsorted(mesh, tq, side="right") - 1, 0, self.tr.N - 1)
        tau = (tq - mesh[k]) / self.tr.h[k]
        out = np.zeros((6, len(tq)))
        for r, p in enumerate(BASIS):
            out += X[:, DEG * k + r] * p(tau)[None, :]
        tc = self.tall[1:]
        U = np.vstack([np.interp(tq, tc, self.U[i]) for i in range(3)])
        L = np.interp(tq, tc, self.L)
        return out[0:3], out[3:6], U, L


# ----------------------------------------------------------------------------------------
# Initial guesses: functions t -> (Om, Xi, U, Lam) at arbitrary times
# ----------------------------------------------------------------------------------------


def _continuous_sign(xi):
    xi = xi.copy()
    for i in range(1, xi.shape[1]):
        if np.dot(xi[:, i], xi[:, i - 1]) < 0:
            xi[:, i] = -xi[:, i]
    return xi


def _num_deriv(t, v):
    return np.vstack([np.gradient(v[i], t) for i in range(v.shape[0])])


def guess_segment(prob: Problem, kind: str):
    def g(t):
        Om, dOm = prob.segment_path(t)
        if kind == "cross":
            xi = np.cross(Om.T, dOm.T).T
            lam = np.zeros(len(t))
        else:  # inverse dynamics: I dOm - (I Om) x Om = lam xi exactly, xi _|_ Om
            IOm = prob.I[:, None] * Om
            w = prob.I[:, None] * dOm - np.cross(IOm.T, Om.T).T
            xi = w
            lam = None
        nrm = np.linalg.norm(xi, axis=0)
        if nrm.min() < 1e-12 * max(1.0, nrm.max()):
            # degenerate: any unit vector orthogonal to Om
            alt = np.cross(Om.T, np.array([0.0, 0.0, 1.0])).T
            xi = np.where(nrm[None, :] > 1e-12, xi, alt)
            nrm = np.linalg.norm(xi, axis=0)
        xi = _continuous_sign(xi / nrm[None, :])
        if lam is None:
            IOm = prob.I[:, None] * Om
            w = prob.I[:, None] * dOm - np.cross(IOm.T, Om.T).T
            lam = np.sum(w * xi, axis=0)
        return Om, xi, _num_deriv(t, xi), lam

    return g


def guess_random(prob: Problem, seed: int, base="invdyn"):
    rng = np.random.default_rng(seed)
    base_g = guess_segment(prob, base)
    amp = rng.normal(0.0, 1.0, 3)
    sc = rng.normal(0.0, 0.2, 2)
    v = rng.normal(0.0, 1.0, 3)
    v *= 0.2 * np.linalg.norm(prob.omega_a) / np.linalg.norm(v)

    def g(t):
        s = (t - prob.a) / (prob.b - prob.a)
        Om, xi, _, lam = base_g(t)
        Om = prob.project(Om + np.sin(np.pi * s)[None, :] * v[:, None])
        # xi: projected onto Om^perp, rotated about Om by a random smooth angle, rescaled
        e = Om / np.linalg.norm(Om, axis=0)[None, :]
        xi = xi - np.sum(xi * e, axis=0)[None, :] * e
        xi /= np.linalg.norm(xi, axis=0)[None, :]
        th = sum(amp[m] * np.sin((m + 1) * np.pi * s) for m in range(3))
        xi = np.cos(th)[None, :] * xi + np.sin(th)[None, :] * np.cross(e.T, xi.T).T
        xi *= (1.0 + sc[0] * np.sin(np.pi * s) + sc[1] * np.sin(2 * np.pi * s))[None, :]
        return Om, xi, _num_deriv(t, xi), lam * 0.0

    return g


def guess_csv(prob: Problem, path: str):
    data = np.genfromtxt(path, delimiter=",", names=True)
    tt = data["t"]
    tt = (tt - tt[0]) / (tt[-1] - tt[0]) * (prob.b - prob.a) + prob.a  # same [a, b]
    Om0 = np.vstack([data[f"omega{i}"] for i in (1, 2, 3)])
    Xi0 = np.vstack([data[f"xi{i}"] for i in (1, 2, 3)])
    Xd0 = np.vstack([data[f"xidot{i}"] for i in (1, 2, 3)])
    dOm0 = _num_deriv(tt, Om0)
    IOm = prob.I[:, None] * Om0
    w = prob.I[:, None] * dOm0 - np.cross(IOm.T, Om0.T).T
    lam0 = np.sum(w * Xi0, axis=0) / np.maximum(np.sum(Xi0 * Xi0, axis=0), 1e-4)
    has_lam = "lambda" in data.dtype.names and np.isfinite(data["lambda"][1:]).all()
    if has_lam:
        lam0 = data["lambda"].copy()
        lam0[0] = lam0[1]

    def g(t):
        f = lambda v: np.vstack([np.interp(t, tt, v[i]) for i in range(v.shape[0])])  # noqa
        return f(Om0), f(Xi0), f(Xd0), np.interp(t, tt, lam0)

    return g


def guess_from_solution(sol: Solution):
    def g(t):
        return sol.at(t)

    return g


# ----------------------------------------------------------------------------------------
# Driver
# ----------------------------------------------------------------------------------------


def solve_once(prob, N, alpha, guess_fn, max_time, log, graded=True, xi_min=0.0, relaxed=False,
               obj_scale=1.0):
    mesh = make_mesh(prob, N, graded)
    tr = Transcription(prob, mesh, alpha, xi_min, relaxed)
    tall = tr.tall
    Om, Xi, U, L = guess_fn(tall)
    if relaxed:  # torque guess lam xi
        Xi = Xi * L[None, :]
        U = _num_deriv(tall, Xi)
        L = np.ones_like(L)
    w0 = tr.pack(Om, Xi, U[:, 1:], L[1:])
    S = tr.solver(max_time, log, obj_scale)
    t0 = time.time()
    r = S(x0=w0, lbx=tr.lbx, ubx=tr.ubx, lbg=tr.lbg, ubg=tr.ubg)
    dt = time.time() - t0
    st = S.stats()
    sol = Solution(tr, r["x"])
    parts = [float(p) for p in tr.parts_fn(r["x"])]
    gmax = float(np.abs(np.asarray(r["g"]).ravel()[: len(tr.lbg) - (DEG * N + 1 if xi_min > 0 else 0)]).max())
    res = {
        "N": N,
        "alpha": alpha,
        "status": st["return_status"],
        "success": bool(st["success"]),
        "iterations": st["iter_count"],
        "seconds": round(dt, 2),
        "cost": float(r["f"]),
        "cost_parts": dict(zip(["alpha", "beta", "gamma", "eta"], parts)),
        "max_abs_g": gmax,
    }
    res.update(sol.diagnostics())
    if xi_min > 0:
        res["xi_min_bound"] = xi_min
        res["xi_bound_active_points"] = int(np.sum(np.sum(sol.Xi ** 2, axis=0) < xi_min ** 2 * (1 + 1e-6)))
    if relaxed:
        res["relaxed"] = True
    return res, sol


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("problem")
    ap.add_argument("--N", type=int, nargs="+", default=[100, 200, 400])
    ap.add_argument("--guess", nargs="+", default=["segment-invdyn", "segment-cross"],
                    help="segment-invdyn, segment-cross, random:SEED, csv:PATH")
    ap.add_argument("--cold", action="store_true", help="each N from the guess (default: warm from previous N)")
    ap.add_argument("--alpha-from", type=float, default=None,
                    help="first solve at alpha*K on the first mesh, then lower alpha geometrically")
    ap.add_argument("--alpha-steps", type=int, default=6)
    ap.add_argument("--xi-min", type=float, default=0.0,
                    help="impose |xi| >= XI_MIN at every state column (probe for a regular solution)")
    ap.add_argument("--relaxed", action="store_true",
                    help="solve the xi -> 0 limit problem (free torque _|_ Om; cost + alpha/4 (b-a))")
    ap.add_argument("--obj-scale", type=float, default=1.0,
                    help="IPOPT obj_scaling_factor (e.g. 1e4 for a tiny optimal cost)")
    ap.add_argument("--uniform", action="store_true", help="uniform mesh even with sharp Om_d")
    ap.add_argument("--max-time", type=float, default=240.0, help="IPOPT CPU seconds per solve")
    ap.add_argument("--out", default=DEFAULT_OUT)
    ap.add_argument("--name", default=None)
    args = ap.parse_args(argv)

    prob = Problem(args.problem)
    name = args.name or prob.name
    odir = os.path.join(args.out, name)
    os.makedirs(odir, exist_ok=True)
    print(f"# {name}: I = {prob.I}, [a, b] = [{prob.a}, {prob.b}], alpha = {prob.alpha:.6g}, "
          f"beta = {prob.beta:.6g}, gamma = {prob.gamma:.6g}, eta = {prob.eta:.6g}, "
          f"sqrt(alpha/beta) = {math.sqrt(prob.alpha / prob.beta):.4g}", flush=True)
    results = []
    hdr = (f"{'guess':<18} {'N':>4} {'status':<22} {'it':>5} {'s':>6} {'cost':>16} {'min|xi|':>10} "
           f"{'t_min':>8} {'max|<O,xi>|':>11} {'max|xi`|':>9} {'jump xi`':>9} {'max|lam|':>9}")
    print(hdr, flush=True)
    for gspec in args.guess:
        if gspec in ("segment-invdyn", "segment-cross"):
            gfn = guess_segment(prob, gspec.split("-")[1])
        elif gspec.startswith("random:"):
            gfn = guess_random(prob, int(gspec.split(":")[1]))
        elif gspec.startswith("csv:"):
            gfn = guess_csv(prob, gspec[4:])
        else:
            raise SystemExit(f"unknown guess {gspec}")
        glabel = gspec if not gspec.startswith("csv:") else "csv:" + os.path.basename(os.path.dirname(gspec[4:]) or gspec[4:])
        tag = gspec.replace("/", "_").replace(":", "_")[-40:]
        cur = gfn
        alphas = [prob.alpha]
        if args.alpha_from:
            alphas = list(prob.alpha * np.geomspace(args.alpha_from, 1.0, args.alpha_steps + 1))
        for i, N in enumerate(args.N):
            seq = alphas if i == 0 else [prob.alpha]
            for al in seq:
                log = os.path.join(odir, f"{tag}_N{N}_a{al:.4g}.ipopt.log")
                res, sol = solve_once(prob, N, al, cur if not (args.cold and al == seq[0]) else gfn,
                                      args.max_time, log, not args.uniform, args.xi_min, args.relaxed,
                                      args.obj_scale)
                res["guess"] = glabel + ("" if al == prob.alpha else f" (alpha={al:.3g})")
                if res.get("xi_bound_active_points"):
                    res["guess"] += f" [|xi|>={args.xi_min:g} active at {res['xi_bound_active_points']}]"
                results.append(res)
                print(f"{res['guess']:<18} {N:>4} {res['status'][:22]:<22} {res['iterations']:>5} "
                      f"{res['seconds']:>6.1f} {res['cost']:>16.10g} {res['min_xi']:>10.3e} "
                      f"{res['t_min_xi']:>8.4f} {res['max_constraint_dense']:>11.2e} "
                      f"{res['max_xidot']:>9.3g} {res['max_xidot_jump']:>9.3g} {res['max_lambda']:>9.3g}",
                      flush=True)
                if al == prob.alpha:
                    sol.write_csv(os.path.join(odir, f"{tag}_N{N}.csv"))
                if res["success"] or not args.cold:
                    cur = guess_from_solution(sol)
            if args.cold:
                cur = gfn
    with open(os.path.join(args.out, f"{name}.results.json"), "w") as fh:
        json.dump({"problem": os.path.abspath(args.problem), "results": results}, fh, indent=1)
    return results


if __name__ == "__main__":
    main()
