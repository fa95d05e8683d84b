"""The generalised rigid body on SO(4) with a steered Suslov constraint <xi, Omega> = 0: a test
that nothing assumes n = 3 (6-dimensional algebra, 24 states).

Basis E12, E13, E14, E23, E24, E34 with E_ij = e_i e_j^T - e_j e_i^T; the bracket is the matrix
commutator. Inertia I Omega = J Omega + Omega J with J = diag(J1, J2, J3, J4), i.e.
I = diag(J1+J2, J1+J3, J1+J4, J2+J3, J2+J4, J3+J4) in this basis.
Cost: the same weights as Suslov's problem (Euclidean norms in coordinates).
"""

import itertools

import sympy as sp

from lie import LieAlgebra
from model import Param, sq

NAME = "so4"
TITLE = "the generalised rigid body on SO(4) (<xi, Omega> = 0)"

PAIRS = list(itertools.combinations(range(4), 2))


def _e(i, j):
    m = sp.zeros(4, 4)
    m[i, j], m[j, i] = 1, -1
    return m


ALGEBRA = LieAlgebra.from_matrices([f"E{i + 1}{j + 1}" for i, j in PAIRS],
                                   [_e(i, j) for i, j in PAIRS])

INERTIA_PARAMS = [Param(f"J{k}", f"mass-matrix entry J{k} of J = diag(J1..J4) (> 0)",
                        lower=0, strict=True) for k in range(1, 5)]


def inertia(p):
    J = [p.J1, p.J2, p.J3, p.J4]
    return sp.diag(*[J[i] + J[j] for i, j in PAIRS])


WEIGHTS = [
    Param("alpha", "alpha: weight of (|xi|^2 - 1)^2 / 4, keeps |xi| near 1 (> 0)",
          lower=0, strict=True, role="fixed"),
    Param("beta", "beta: weight of |xi_dot|^2 / 2, the control effort (> 0)",
          lower=0, strict=True, role="beta"),
    Param("gamma", "gamma: weight of |Omega - Omega_d|^2 / 2, tracking of the desired path "
          "(>= 0)", lower=0, role="tracking"),
    Param("eta", "eta: weight of |Omega_dot|^2 / 2, smoothness of Omega (>= 0)",
          lower=0, role="smoothing"),
    Param("delta", "delta: weight of the time, delta * (b - a) (>= 0)", lower=0, role="time"),
]


def cost(w, Om, OmDot, xi, xiDot, Om_d):
    return (w.alpha / 4 * (sq(xi) - 1) ** 2
            + w.beta / 2 * sq(xiDot)
            + w.gamma / 2 * sq(Om - Om_d)
            + w.eta / 2 * sq(OmDot)
            + w.delta)
