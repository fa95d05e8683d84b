"""The Suslov optimal-control model: the ONE file to edit to change the physics or the cost.

Everything downstream (the Euler-Lagrange derivation in `derive.py`, the Rust emitter in
`emit_rust.py`, the generated Jacobians and the test vectors) is computed from the objects
defined here. Change the cost integrand or the constraint, run `cargo build`, and the crate is
rebuilt against the new equations (see codegen/README.md).

Conventions
-----------
* Body frame with principal axes, so the inertia tensor is diag(I1, I2, I3).
* `Om` is the body angular velocity Omega, `xi` the constraint (control) direction, `Om_d` the
  desired body angular velocity (a runtime input that depends on time).
* Jet symbols: `OmDot` is dOmega/dt, `xiDot` is dxi/dt, etc. The derivation treats them as
  independent symbols and applies the total time derivative itself.
"""

import sympy as sp


def vec(name, n=3):
    """A column vector of real symbols name1..nameN."""
    return sp.Matrix(sp.symbols(f"{name}1:{n + 1}", real=True))


# ---------------------------------------------------------------------------------------------
# Runtime constants (one value per solve). Order = order of the `p` array in the generated code.
I1, I2, I3 = sp.symbols("I1 I2 I3", positive=True)
alpha, beta, gamma, eta, delta = sp.symbols("alpha beta gamma eta delta", real=True)
PARAMS = [I1, I2, I3, alpha, beta, gamma, eta, delta]
PARAM_DOCS = [
    "principal moment of inertia I1 (> 0)",
    "principal moment of inertia I2 (> 0)",
    "principal moment of inertia I3 (> 0)",
    "alpha: weight of (|xi|^2 - 1)^2 / 4, keeps |xi| near 1 (> 0)",
    "beta: weight of |xi_dot|^2 / 2, the control effort (> 0; beta = 0 is singular)",
    "gamma: weight of |Omega - Omega_d|^2 / 2, tracking of the desired path (>= 0)",
    "eta: weight of |Omega_dot|^2 / 2, smoothness of Omega (>= 0)",
    "delta: weight of the time, delta * (b - a) (>= 0)",
]

INERTIA = sp.diag(I1, I2, I3)

# ---------------------------------------------------------------------------------------------
# Configuration variables and their jets.
Om, OmDot, OmDDot = vec("Om"), vec("OmDot"), vec("OmDDot")
xi, xiDot, xiDDot = vec("xi"), vec("xiDot"), vec("xiDDot")
kappa, kappaDot = vec("kappa"), vec("kappaDot")
# Time-dependent runtime input and its jet.
Om_d, Om_dDot, Om_dDDot = vec("Omd"), vec("OmdDot"), vec("OmdDDot")

# The state of the first-order BVP system (order matters: it is the layout of `y`).
STATE = list(Om) + list(xi) + list(xiDot) + list(kappa)
STATE_NAMES = ["omega1", "omega2", "omega3", "xi1", "xi2", "xi3",
               "xidot1", "xidot2", "xidot3", "kappa1", "kappa2", "kappa3"]

# The time derivative, symbol by symbol (the derivation's total derivative d/dt).
JET = {}
for a, b in zip(Om, OmDot):
    JET[a] = b
for a, b in zip(OmDot, OmDDot):
    JET[a] = b
for a, b in zip(xi, xiDot):
    JET[a] = b
for a, b in zip(xiDot, xiDDot):
    JET[a] = b
for a, b in zip(kappa, kappaDot):
    JET[a] = b
for a, b in zip(Om_d, Om_dDot):
    JET[a] = b
for a, b in zip(Om_dDot, Om_dDDot):
    JET[a] = b

# ---------------------------------------------------------------------------------------------
# Physics: the reduced Lagrangian on so(3) and the nonholonomic constraint.


def body_lagrangian(Om):
    """Kinetic energy of the free rigid body, l(Omega) = 1/2 <I Omega, Omega>."""
    return sp.Rational(1, 2) * (Om.T * INERTIA * Om)[0, 0]


def constraint(Om, xi):
    """Suslov's constraint phi(Omega, xi) = <Omega, xi>, required to vanish."""
    return (Om.T * xi)[0, 0]


# ---------------------------------------------------------------------------------------------
# The cost integrand C(Omega, Omega_dot, xi, xi_dot, Omega_d) (eq. cost_function).


def cost(Om, OmDot, xi, xiDot, Om_d):
    """C = alpha/4 (|xi|^2 - 1)^2 + beta/2 |xi_dot|^2 + gamma/2 |Om - Om_d|^2
         + eta/2 |Om_dot|^2 + delta."""
    sq = lambda v: (v.T * v)[0, 0]  # noqa: E731
    return (alpha / 4 * (sq(xi) - 1) ** 2
            + beta / 2 * sq(xiDot)
            + gamma / 2 * sq(Om - Om_d)
            + eta / 2 * sq(OmDot)
            + delta)
