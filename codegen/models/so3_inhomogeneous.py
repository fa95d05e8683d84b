"""The inhomogeneous Suslov problem: a rigid body on SO(3) whose body angular velocity keeps a
prescribed component along the steered direction, <Omega, xi> = c (Putkaradze & Rogers,
section 3 with a constant constraint value gamma(xi, t) = c; c = 0 is the paper's problem).

The constraint force lambda xi now does work: the kinetic energy T = 1/2 <Omega, I Omega> is not
conserved but balanced, dT/dt = lambda <Omega, xi> = lambda c, so Omega(b) need not lie on the
energy ellipsoid of Omega(a), and the constraint level <Omega, xi> = c is no longer implied by
the boundary conditions: the problem layer imposes <Omega(a), xi(a)> = c at the start, with
its multiplier (see src/lie/problem.rs).

Basis, inertia and cost as models/so3.py: principal axes, I = diag(I1, I2, I3),
    C = alpha/4 (|xi|^2 - 1)^2 + beta/2 |xi'|^2 + gamma/2 |Omega - Omega_d|^2
        + eta/2 |Omega'|^2 + delta.
"""

import sympy as sp

from lie import LieAlgebra, hat3
from model import Param, sq

NAME = "so3_inhomogeneous"
TITLE = "Inhomogeneous Suslov problem (rigid body, <Omega, xi> = c)"

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

CONSTRAINT_PARAMS = [
    Param("c", "c: the constraint value, <Omega, xi> = c (any real number; 0 is Suslov's "
          "problem)", role="constraint"),
]


def constraint_value(c, xi):
    return c.c


def cost(w, Om, OmDot, xi, xiDot, Om_d):
    return (w.alpha / 4 * (sq(xi) - 1) ** 2
            + w.beta / 2 * sq(xiDot)
            + w.gamma / 2 * sq(Om - Om_d)
            + w.eta / 2 * sq(OmDot)
            + w.delta)
