"""The steered Chaplygin sleigh: a planar rigid body on SE(2) whose body velocity Omega =
(omega, v1, v2) must annihilate a covector xi(t) in se(2)* that we steer (a knife edge whose
direction and contact point move).

Basis (e0 rotation, e1, e2 body translations), as 3 x 3 homogeneous matrices, so
[e0, e1] = e2, [e0, e2] = -e1, [e1, e2] = 0. The body has mass m and moment of inertia I_c
about its centre of mass, located at body coordinates (c1, c2) from the reference point:
    I = [[I_c + m (c1^2 + c2^2), -m c2, m c1], [-m c2, m, 0], [m c1, 0, m]],
the kinetic energy 1/2 m |v + omega z x c|^2 + 1/2 I_c omega^2.
Cost: the same weights as Suslov's problem (Euclidean norms in the coordinates (omega, v1, v2)):
    C = alpha/4 (|xi|^2 - 1)^2 + beta/2 |xi'|^2 + gamma/2 |Omega - Omega_d|^2
        + eta/2 |Omega'|^2 + delta.
"""

import sympy as sp

from lie import LieAlgebra
from model import Param, sq

NAME = "se2"
TITLE = "the steered Chaplygin sleigh on SE(2) (<xi, Omega> = 0)"

ALGEBRA = LieAlgebra.from_matrices(
    ["e0", "e1", "e2"],
    [sp.Matrix([[0, -1, 0], [1, 0, 0], [0, 0, 0]]),
     sp.Matrix([[0, 0, 1], [0, 0, 0], [0, 0, 0]]),
     sp.Matrix([[0, 0, 0], [0, 0, 1], [0, 0, 0]])])

INERTIA_PARAMS = [
    Param("m", "mass of the sleigh (> 0)", lower=0, strict=True),
    Param("Ic", "moment of inertia about the centre of mass (> 0)", lower=0, strict=True),
    Param("c1", "body coordinate c1 of the centre of mass (along e1)"),
    Param("c2", "body coordinate c2 of the centre of mass (along e2)"),
]


def inertia(p):
    return sp.Matrix([[p.Ic + p.m * (p.c1 ** 2 + p.c2 ** 2), -p.m * p.c2, p.m * p.c1],
                      [-p.m * p.c2, p.m, 0],
                      [p.m * p.c1, 0, p.m]])


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

SAMPLES = {"c1": (-0.6, 0.6), "c2": (-0.6, 0.6)}


def cost(w, Om, OmDot, xi, xiDot, Om_d):
    return (w.alpha / 4 * (sq(xi) - 1) ** 2
            + w.beta / 2 * sq(xiDot)
            + w.gamma / 2 * sq(Om - Om_d)
            + w.eta / 2 * sq(OmDot)
            + w.delta)
