"""Models: one file per model in `models/`, turned into the symbols the derivation uses.

A model file (`models/<name>.py`, see models/so3.py for the reference and codegen/README.md
"Model files" for the format) declares, and nothing else:

* `NAME`, `TITLE` and a module docstring;
* `ALGEBRA`: a `lie.LieAlgebra` (basis names and structure constants, or a faithful matrix
  representation, which reconstruction g' = g hat(Omega) also uses);
* `INERTIA_PARAMS`: the named runtime parameters of the inertia operator (`Param`s) and
  `inertia(p)`: the n x n symmetric matrix of the inertia operator I: g -> g*, Pi = I Omega;
* `WEIGHTS`: the named weights of the cost (`Param`s with docs, admissible ranges and their role
  in the homotopy) and `cost(w, Om, OmDot, xi, xiDot, Om_d)`: the integrand C;
* optionally `CONSTRAINT_PARAMS` and `constraint_value(c, xi)`: gamma(xi) in <xi, Omega> =
  gamma(xi) (0 when absent);
* optionally `SAMPLES`: {param name: (lo, hi)} ranges for the generator's test vectors.

`load(name)` returns a `Model`: the model's declarations plus the symbols of the optimality
system (Om, xi, their jets, kappa, the desired path Om_d), the state layout and the runtime
constant vector `PARAMS` = inertia parameters, weights, constraint parameters and, when the
inertia is not diagonal, the entries of I^-1 (derived constants the caller fills by a numeric
inversion; they keep the generated expressions small).

Conventions: g = R^n in the declared basis, <mu, X> = sum mu_i X_i, ad*_X = (ad_X)^T, and the
norms in a cost are Euclidean in coordinates.
"""

import importlib.util
import os
import re
from dataclasses import dataclass

import sympy as sp

HERE = os.path.dirname(os.path.abspath(__file__))
MODELS_DIR = os.path.join(HERE, "models")

# Homotopy roles of a weight (how the solver reaches its target value; see src/so3/solve.rs).
ROLES = {
    "fixed": "used at its target value from the start",
    "beta": "control effort: the start uses a small beta_m, then continued to the target",
    "tracking": "continued from the start's value to the target (the tracking stage)",
    "smoothing": "continued from 0 to the target (the smoothing stage)",
    "time": "weight of the terminal time: continued from delta_c (free terminal time only)",
    "constraint": "constraint value: continued from 0 to the target",
}


@dataclass
class Param:
    """A named runtime constant of a model.

    `lower`/`upper` bound the admissible values (None: unbounded); `strict` makes the lower
    bound exclusive. `role` is one of ROLES (weights and constraint parameters only)."""
    name: str
    doc: str
    lower: object = None
    upper: object = None
    strict: bool = False
    role: str = "fixed"

    def __post_init__(self):
        if self.role not in ROLES:
            raise ValueError(f"{self.name}: unknown homotopy role {self.role!r}")
        self.symbol = sp.Symbol(self.name, real=True)

    def positive_symbol(self):
        """Inertia parameters with an exclusive lower bound 0 are positive symbols."""
        if self.lower == 0 and self.strict:
            self.symbol = sp.Symbol(self.name, positive=True)


# Names the derivation uses for its own symbols (followed by digits): a model parameter may not
# take one of them (checked by Model), nor contain "_" (Jacobian temporaries are d_..., dd_...).
# `t` is also the generated code's array of intermediates.
RESERVED_STEMS = ["Om", "OmDot", "OmDDot", "OmDDDot", "xi", "xiDot", "xiDDot", "kappa",
                  "kappaDot", "Omd", "OmdDot", "OmdDDot", "OmEnd", "Iinv", "lam", "lambda",
                  "lamDot", "lamDDot", "dlam", "fom", "oa", "ob", "ka", "kb", "sh", "sw", "sm",
                  "xt", "xtn", "xip", "xipDot", "dxt", "ddxt", "x", "w", "s", "t", "z", "y", "p",
                  "od", "wb", "out", "mu"]
RESERVED = re.compile(r"^(" + "|".join(RESERVED_STEMS) + r")\d*$")
IDENT = re.compile(r"^[A-Za-z][A-Za-z0-9]*$")


def vec(name, n):
    """A column vector of real symbols name1..nameN."""
    return sp.Matrix(sp.symbols(f"{name}1:{n + 1}", real=True))


def sq(v):
    """Euclidean squared norm of a column vector."""
    return (v.T * v)[0, 0]


class _Names:
    """Attribute access to symbols by name (w.alpha, p.I1)."""

    def __init__(self, params):
        for p in params:
            setattr(self, p.name, p.symbol)


def _load_spec(name):
    path = os.path.join(MODELS_DIR, f"{name}.py")
    if not os.path.isfile(path):
        raise ValueError(f"no model file {path}")
    spec = importlib.util.spec_from_file_location(f"suslov_models_{name}", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def available():
    """The shipped model names (models/*.py), sorted."""
    return sorted(f[:-3] for f in os.listdir(MODELS_DIR)
                  if f.endswith(".py") and not f.startswith("_"))


class Model:
    """A model file plus the symbols of its optimality system."""

    def __init__(self, spec):
        self.spec = spec
        self.NAME = spec.NAME
        self.TITLE = spec.TITLE
        self.DOC = (spec.__doc__ or "").strip()
        self.algebra = spec.ALGEBRA
        n = self.n = self.algebra.n
        self.inertia_params = list(spec.INERTIA_PARAMS)
        for p in self.inertia_params:
            p.positive_symbol()
        self.weights = list(spec.WEIGHTS)
        self.constraint_params = list(getattr(spec, "CONSTRAINT_PARAMS", []))
        user = self.inertia_params + self.weights + self.constraint_params
        names = [p.name for p in user]
        for nm in names:
            if not IDENT.match(nm) or RESERVED.match(nm):
                raise ValueError(f"{self.NAME}: parameter name {nm!r} must be letters and digits "
                                 f"(starting with a letter) and not one of the derivation's "
                                 f"names {RESERVED_STEMS} followed by digits: rename it")
        if len(set(names)) != len(names):
            raise ValueError(f"{self.NAME}: parameter names must be distinct: {names}")
        self.user_params = user
        self.INERTIA = sp.Matrix(spec.inertia(_Names(self.inertia_params)))
        if self.INERTIA.shape != (n, n):
            raise ValueError(f"{self.NAME}: the inertia must be {n} x {n}")
        if not (self.INERTIA - self.INERTIA.T).is_zero_matrix:
            raise ValueError(f"{self.NAME}: the inertia must be symmetric")
        self.inertia_diagonal = all(self.INERTIA[i, j] == 0
                                    for i in range(n) for j in range(n) if i != j)
        if self.inertia_diagonal:
            self.INERTIA_INV = sp.diag(*[1 / self.INERTIA[i, i] for i in range(n)])
            self.derived = []
        else:
            sym = {}
            for i in range(n):
                for j in range(i, n):
                    sym[(i, j)] = sym[(j, i)] = sp.Symbol(f"Iinv{i + 1}{j + 1}", real=True)
            self.INERTIA_INV = sp.Matrix(n, n, lambda i, j: sym[(i, j)])
            self.derived = [(sym[(i, j)], (i, j)) for i in range(n) for j in range(i, n)]
        self.PARAMS = [p.symbol for p in user] + [s for s, _ in self.derived]
        self.N_USER_PARAMS = len(user)
        self.PARAM_DOCS = [p.doc for p in user] + [
            f"derived: entry ({i + 1}, {j + 1}) of the inverse inertia I^-1 (filled by the "
            "caller)" for _, (i, j) in self.derived]
        for p in user:
            setattr(self, p.name, p.symbol)

        # Configuration variables, their jets, the costate and the desired path.
        self.Om, self.OmDot, self.OmDDot = vec("Om", n), vec("OmDot", n), vec("OmDDot", n)
        self.xi, self.xiDot, self.xiDDot = vec("xi", n), vec("xiDot", n), vec("xiDDot", n)
        self.kappa, self.kappaDot = vec("kappa", n), vec("kappaDot", n)
        self.Om_d, self.Om_dDot, self.Om_dDDot = vec("Omd", n), vec("OmdDot", n), vec("OmdDDot", n)
        # The state of the first-order BVP system (order = the layout of `y`).
        self.STATE = list(self.Om) + list(self.xi) + list(self.xiDot) + list(self.kappa)
        self.BLOCKS = [("omega", "Omega"), ("xi", "xi"), ("xidot", "xi'"), ("kappa", "kappa")]
        self.STATE_NAMES = [f"{b}{i + 1}" for b, _ in self.BLOCKS for i in range(n)]
        self.JET = {}
        for lo, hi in [(self.Om, self.OmDot), (self.OmDot, self.OmDDot), (self.xi, self.xiDot),
                       (self.xiDot, self.xiDDot), (self.kappa, self.kappaDot),
                       (self.Om_d, self.Om_dDot), (self.Om_dDot, self.Om_dDDot)]:
            for a, b in zip(lo, hi):
                self.JET[a] = b

    # -- physics ---------------------------------------------------------------------------
    def body_lagrangian(self, Om):
        """l(Omega) = 1/2 <I Omega, Omega>."""
        return sp.Rational(1, 2) * (Om.T * self.INERTIA * Om)[0, 0]

    def constraint_value(self, xi):
        """gamma(xi) in <xi, Omega> = gamma(xi) (0 by default)."""
        f = getattr(self.spec, "constraint_value", None)
        return sp.Integer(0) if f is None else sp.sympify(f(_Names(self.constraint_params), xi))

    def constraint(self, Om, xi):
        """phi(Omega, xi) = <Omega, xi> - gamma(xi), required to vanish."""
        return (Om.T * xi)[0, 0] - self.constraint_value(xi)

    def cost(self, Om, OmDot, xi, xiDot, Om_d):
        """The cost integrand C of the model file."""
        return self.spec.cost(_Names(self.weights), Om, OmDot, xi, xiDot, Om_d)

    def ad_star(self, X, mu):
        return self.algebra.ad_star(X, mu)

    def inverse_substitution(self):
        """{Iinv_ij: (I^-1)_ij} as expressions of the inertia parameters (for checks)."""
        if not self.derived:
            return {}
        inv = self.INERTIA.inv()
        return {s: sp.simplify(inv[i, j]) for s, (i, j) in self.derived}

    def sample_range(self, p):
        ranges = getattr(self.spec, "SAMPLES", {})
        if p.name in ranges:
            return ranges[p.name]
        return (0.5, 3.0) if p in self.inertia_params else (0.1, 2.0)


_CACHE = {}


def load(name="so3"):
    """The model `models/<name>.py` (cached)."""
    if name not in _CACHE:
        _CACHE[name] = Model(_load_spec(name))
    return _CACHE[name]
