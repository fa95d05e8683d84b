"""Lie algebras in coordinates: the bracket, ad and ad* from structure constants.

Conventions (fixed for every model, see codegen/README.md "Model files"):

* g is identified with Rⁿ through the declared basis e_1 .. e_n; a vector is a column of its
  coordinates.
* The bracket is given by structure constants, [e_i, e_j] = sum_k c[i][j][k] e_k, either
  declared directly or computed from a faithful matrix representation (the bracket is then the
  matrix commutator, [A, B] = AB - BA).
* ad_X Y = [X, Y]; as a matrix, (ad_X)[k][j] = sum_i X_i c[i][j][k].
* g* is identified with Rⁿ through the dual basis, and the pairing <mu, X> is the Euclidean dot
  product of coordinates, so ad*_X = (ad_X)^T: <ad*_X mu, Y> = <mu, ad_X Y>.

For so(3) with the hat-map basis, [e_i, e_j] = eps_ijk e_k, ad_X Y = X x Y and
ad*_X mu = -X x mu = mu x X, the paper's (I Omega) x Omega.

Nothing here knows a model: models/*.py build their algebra with `LieAlgebra`.
"""

import itertools

import sympy as sp


class LieAlgebra:
    """An n-dimensional real Lie algebra with named basis and structure constants.

    The constructor checks antisymmetry and the Jacobi identity exactly (rational arithmetic),
    so a typo in a model's structure constants fails at generation, not in a solve.
    """

    def __init__(self, basis_names, structure, matrices=None):
        self.names = list(basis_names)
        self.n = n = len(self.names)
        if n < 1:
            raise ValueError("a Lie algebra needs at least one basis element")
        if len(set(self.names)) != n:
            raise ValueError(f"basis names must be distinct: {self.names}")
        c = [[[sp.nsimplify(structure[i][j][k]) for k in range(n)] for j in range(n)]
             for i in range(n)]
        self.c = c
        self.matrices = None if matrices is None else [sp.Matrix(m) for m in matrices]
        self._check()

    # -- constructors ----------------------------------------------------------------------
    @classmethod
    def from_brackets(cls, basis_names, brackets):
        """From the nonzero brackets {(i, j): {k: c_ijk}} with i < j (the rest by antisymmetry)."""
        n = len(basis_names)
        c = [[[0] * n for _ in range(n)] for _ in range(n)]
        for (i, j), out in brackets.items():
            if not (0 <= i < n and 0 <= j < n) or i == j:
                raise ValueError(f"bracket index ({i}, {j}) out of range or diagonal")
            for k, v in out.items():
                c[i][j][k] = sp.nsimplify(v)
                c[j][i][k] = -sp.nsimplify(v)
        return cls(basis_names, c)

    @classmethod
    def from_matrices(cls, basis_names, matrices):
        """From a faithful matrix representation: [E_i, E_j] = E_i E_j - E_j E_i, expanded in
        the basis (the expansion must exist and be unique: the matrices are linearly
        independent and their span is closed under the commutator)."""
        mats = [sp.Matrix(m) for m in matrices]
        n = len(mats)
        if n != len(basis_names):
            raise ValueError("one matrix per basis element")
        k = mats[0].rows
        if any(m.shape != (k, k) for m in mats):
            raise ValueError("the representation matrices must all be square of one size")
        B = sp.Matrix.hstack(*[m.reshape(k * k, 1) for m in mats])
        if B.rank() != n:
            raise ValueError("the representation matrices are linearly dependent")
        c = [[[0] * n for _ in range(n)] for _ in range(n)]
        for i, j in itertools.product(range(n), repeat=2):
            comm = (mats[i] * mats[j] - mats[j] * mats[i]).reshape(k * k, 1)
            sol, params = B.gauss_jordan_solve(comm)
            if params.shape[0] != 0:
                raise ValueError("the commutator expansion is not unique")
            for kk in range(n):
                c[i][j][kk] = sol[kk]
            if not (B * sol - comm).is_zero_matrix:
                raise ValueError(f"[E_{i}, E_{j}] is not in the span of the basis")
        return cls(basis_names, c, matrices=mats)

    # -- operations ------------------------------------------------------------------------
    def bracket(self, X, Y):
        """[X, Y] in coordinates."""
        n = self.n
        return sp.Matrix([sum(X[i] * Y[j] * self.c[i][j][k]
                              for i in range(n) for j in range(n) if self.c[i][j][k] != 0)
                          for k in range(n)])

    def ad(self, X):
        """The matrix of ad_X: (ad_X)[k][j] = sum_i X_i c[i][j][k]."""
        n = self.n
        return sp.Matrix(n, n, lambda k, j: sum(X[i] * self.c[i][j][k] for i in range(n)
                                                if self.c[i][j][k] != 0))

    def ad_star(self, X, mu):
        """ad*_X mu = (ad_X)^T mu."""
        return (self.ad(X).T * mu).applyfunc(sp.expand)

    def hat(self, X):
        """X as a matrix of the declared representation (for reconstruction)."""
        if self.matrices is None:
            raise ValueError("no matrix representation declared")
        out = sp.zeros(*self.matrices[0].shape)
        for x, m in zip(X, self.matrices):
            out += x * m
        return out

    # -- checks ----------------------------------------------------------------------------
    def _check(self):
        n, c = self.n, self.c
        for i, j, k in itertools.product(range(n), repeat=3):
            if c[i][j][k] + c[j][i][k] != 0:
                raise ValueError(f"structure constants not antisymmetric at ({i}, {j}, {k})")
        # Jacobi: [e_i, [e_j, e_k]] + cyclic = 0
        e = [sp.Matrix([1 if a == b else 0 for b in range(n)]) for a in range(n)]
        for i, j, k in itertools.combinations(range(n), 3):
            J = (self.bracket(e[i], self.bracket(e[j], e[k]))
                 + self.bracket(e[j], self.bracket(e[k], e[i]))
                 + self.bracket(e[k], self.bracket(e[i], e[j])))
            if not J.is_zero_matrix:
                raise ValueError(f"Jacobi identity fails for ({self.names[i]}, "
                                 f"{self.names[j]}, {self.names[k]})")


def hat3(v):
    """The so(3) hat map: hat3(v) w = v x w."""
    x, y, z = v
    return sp.Matrix([[0, -z, y], [z, 0, -x], [-y, x, 0]])
