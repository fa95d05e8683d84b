"""Suslov's problem: a rigid body on SO(3) whose body angular velocity Omega must stay
orthogonal to a direction xi(t) that we steer (Putkaradze & Rogers, sections 4-5).

Basis: the hat map, e_i -> hat(e_i), so [e_i, e_j] = eps_ijk e_k, ad_Omega Y = Omega x Y and
ad*_Omega Pi = Pi x Omega. Body axes are principal: I = diag(I1, I2, I3).
Cost (the paper's eq. cost_function):
    C = alpha/4 (|xi|^2 - 1)^2 + beta/2 |xi'|^2 + gamma/2 |Omega - Omega_d|^2
        + eta/2 |Omega'|^2 + delta.
"""

import sympy as sp

from lie import LieAlgebra, hat3
from model import Param, sq

NAME = "so3"
TITLE = "Suslov's problem (rigid body, <Omega, xi> = 0)"

ALGEBRA = LieAlgebra.from_matrices(
    ["e1", "e2", "e3"], [hat3(v) for v in ([1, 0, 0], [0, 1, 0], [0, 0, 1])])

INERTIA_PARAMS = [
    Param("I1", "principal moment of inertia I1 (> 0)", lower=0, strict=True),
    Param("I2", "principal moment of inertia I2 (> 0)", lower=0, strict=True),
    Param("I3", "principal moment of inertia I3 (> 0)", lower=0, strict=True),
]


def inertia(p):
    return sp.diag(p.I1, p.I2, p.I3)


WEIGHTS = [
    Param("alpha", "alpha: weight of (|xi|^2 - 1)^2 / 4, keeps |xi| near 1 (> 0)",
          lower=0, strict=True, role="fixed"),
    Param("beta", "beta: weight of |xi_dot|^2 / 2, the control effort (> 0; beta = 0 is "
          "singular)", lower=0, strict=True, role="beta"),
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
