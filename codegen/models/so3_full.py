"""Suslov's problem with body axes that are not principal: a rigid body on SO(3) with a full
symmetric inertia matrix, whose body angular velocity Omega must stay orthogonal to a direction
xi(t) that we steer. The algebra, constraint and cost are those of `so3`; only the inertia
differs:
    I = [[I11, I12, I13], [I12, I22, I23], [I13, I23, I33]]  (symmetric positive definite),
entering the derivation through the derived constants Iinv_ij (I^-1, filled by the caller).
With I12 = I13 = I23 = 0 it is the `so3` model (checked in tests/lie_layer.rs).
"""

import sympy as sp

from lie import LieAlgebra, hat3
from model import Param, sq

NAME = "so3_full"
TITLE = "Suslov's problem with a full symmetric inertia matrix (<Omega, xi> = 0)"

ALGEBRA = LieAlgebra.from_matrices(
    ["e1", "e2", "e3"], [hat3(v) for v in ([1, 0, 0], [0, 1, 0], [0, 0, 1])])

INERTIA_PARAMS = [
    Param("I11", "inertia matrix entry I11 (> 0; the matrix must be positive definite)",
          lower=0, strict=True),
    Param("I22", "inertia matrix entry I22 (> 0; the matrix must be positive definite)",
          lower=0, strict=True),
    Param("I33", "inertia matrix entry I33 (> 0; the matrix must be positive definite)",
          lower=0, strict=True),
    Param("I12", "inertia matrix entry I12 = I21 (product of inertia)"),
    Param("I13", "inertia matrix entry I13 = I31 (product of inertia)"),
    Param("I23", "inertia matrix entry I23 = I32 (product of inertia)"),
]


def inertia(p):
    return sp.Matrix([[p.I11, p.I12, p.I13],
                      [p.I12, p.I22, p.I23],
                      [p.I13, p.I23, p.I33]])


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

# Diagonally dominant samples: positive definite.
SAMPLES = {"I11": (2.0, 4.0), "I22": (2.0, 4.0), "I33": (2.0, 4.0),
           "I12": (-0.5, 0.5), "I13": (-0.5, 0.5), "I23": (-0.5, 0.5)}


def cost(w, Om, OmDot, xi, xiDot, Om_d):
    return (w.alpha / 4 * (sq(xi) - 1) ** 2
            + w.beta / 2 * sq(xiDot)
            + w.gamma / 2 * sq(Om - Om_d)
            + w.eta / 2 * sq(OmDot)
            + w.delta)
