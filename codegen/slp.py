"""Straight-line programs: the derivation's intermediate representation.

A `Program` is an ordered list of assignments `v_k = e_k(inputs, constants, v_<k)`. The
derivation builds one program per emitted function, naming its intermediate quantities
(Omega_dot, the eliminated blocks, the Sherman-Morrison scalar, ...) instead of substituting
them into one enormous expression. Jacobians are then taken in forward mode *through* the
program (chain rule over the assignments), so every expression stays small, generation is fast
and the generated code keeps the structure of the derivation.

Also here, for speed without changing any result: `diff`, sympy's derivative memoised over
subexpressions (the derivation uses it everywhere), and the mpmath evaluators of the test
vectors, printed through a per-node memo.

Nothing here knows about Suslov.
"""

import mpmath
import sympy as sp
from sympy.ntheory.multinomial import multinomial_coefficients_iterator

# ---------------------------------------------------------------------------------------------
# Differentiation
#
# `diff(e, s)` is `sp.diff(e, s)` for a symbol s, memoised over subexpressions. sympy's
# `Derivative.__new__` recomputes `free_symbols` of every subexpression it visits (quadratic in
# the depth), asks `is_zero` of every intermediate result and walks it once more to canonicalise
# nested Derivatives; on the big expressions of the optimality system that was most of the
# generation time. Here the same rules are applied, in the same order and with the same
# constructor calls (Add: `Add(*[d a])`, Mul: sympy's general Leibniz rule
# `Mul._eval_derivative_n_times` for n = 1, Pow: `Pow._eval_derivative`), so the result is the
# very expression sympy builds (tests/test_derive.py compares them); the checks that do not
# change the result (`is_zero`, the Derivative canonicalisation, which finds none) are skipped.
# Any other node type goes to sympy's own `diff`.

_FREE = {}  # expr -> its free symbols
_DIFF = {}  # (expr, symbol) -> derivative


def _free(e):
    """e.free_symbols, memoised over subexpressions (Add, Mul, Pow; sympy's for others)."""
    r = _FREE.get(e)
    if r is None:
        if e.is_Add or e.is_Mul or e.is_Pow:
            r = set().union(*[_free(a) for a in e.args])
        else:
            r = e.free_symbols
        _FREE[e] = r
    return r


def diff(e, s):
    """d e / d s for a Symbol s: exactly `sp.diff(e, s)` (see above), memoised."""
    e = sp.sympify(e)
    key = (e, s)
    r = _DIFF.get(key)
    if r is not None:
        return r
    if s not in _free(e):
        r = sp.S.Zero
    elif e.is_Add:
        r = e.func(*[diff(a, s) for a in e.args])
    elif e.is_Mul:
        args = e.args
        terms = [c * sp.Mul(*[diff(a, s) if k else a for k, a in zip(kvals, args)])
                 for kvals, c in multinomial_coefficients_iterator(len(args), 1)]
        r = sp.Add(*terms)
    elif e.is_Pow:
        dbase, dexp = diff(e.base, s), diff(e.exp, s)
        r = e * (dexp * sp.log(e.base) + dbase * e.exp / e.base)
    elif e.is_Symbol:
        r = sp.S.One  # (s is free in e)
    else:
        r = sp.diff(e, s)
    _DIFF[key] = r
    return r


class Program:
    """Ordered assignments over a fixed set of inputs."""

    def __init__(self, inputs, constants=()):
        self.inputs = list(inputs)
        self.constants = list(constants)
        self.lets = []  # [(Symbol, Expr)]
        self._defined = {}
        known = set(self.inputs) | set(self.constants)
        if len(known) != len(self.inputs) + len(self.constants):
            raise ValueError("inputs and constants must be distinct symbols")
        self._known = known
        self._names = self._rename = None  # see _naming

    # -- building --------------------------------------------------------------------------
    def let(self, target, expr):
        """Assign `expr` to `target` (a Symbol, a name, or a Matrix of Symbols/names).

        Returns the assigned symbol(s), to be used in later expressions.
        """
        if isinstance(expr, sp.MatrixBase):
            if isinstance(target, str):
                names = [f"{target}{i + 1}" for i in range(len(expr))]
            else:
                names = list(target)
            if len(names) != len(expr):
                raise ValueError("target and expression sizes differ")
            syms = [self.let(n, e) for n, e in zip(names, expr)]
            return sp.Matrix(expr.rows, expr.cols, syms)
        sym = sp.Symbol(target, real=True) if isinstance(target, str) else target
        if sym in self._defined or sym in self._known:
            raise ValueError(f"{sym} assigned twice")
        expr = sp.sympify(expr)
        unknown = [s for s in _free(expr) if s not in self._known and s not in self._defined]
        if unknown:
            raise ValueError(f"{sym} uses undefined symbols {sorted(map(str, unknown))}")
        self.lets.append((sym, expr))
        self._defined[sym] = expr
        return sym

    def copy(self):
        p = Program(self.inputs, self.constants)
        p.lets = list(self.lets)
        p._defined = dict(self._defined)
        return p

    # -- analysis --------------------------------------------------------------------------
    def inline(self, expr):
        """`expr` with every assigned symbol replaced by its definition (for tests)."""
        expr = sp.sympify(expr)
        for sym, e in reversed(self.lets):
            if sym in expr.free_symbols:
                expr = expr.xreplace({sym: e})
        return expr

    def jacobian(self, outputs, wrt, prefix="d"):
        """Forward-mode Jacobian of `outputs` (list of exprs) w.r.t. `wrt` (input symbols).

        New assignments for the derivatives of intermediate quantities are appended to this
        program; the result is a Matrix (len(outputs) x len(wrt)) of expressions in the
        program's symbols. Derivatives that are structurally zero are not materialised.
        """
        wrt = list(wrt)
        for w in wrt:
            if w not in self._known:
                raise ValueError(f"can only differentiate w.r.t. inputs/constants, not {w}")
        # tangent[sym][j] = d sym / d wrt_j (an atom or a new symbol); absent = 0
        tangent = {w: {j: sp.Integer(1)} for j, w in enumerate(wrt)}
        base = list(self.lets)
        for sym, e in base:
            deps = [s for s in _free(e) if s in tangent]
            if not deps:
                continue
            partial = {s: diff(e, s) for s in sorted(deps, key=sp.default_sort_key)}
            cols = sorted({j for s in deps for j in tangent[s]})
            tan = {}
            for j in cols:
                d = sp.Add(*[partial[s] * tangent[s][j] for s in partial if j in tangent[s]])
                if d == 0:
                    continue
                if d.is_Atom:
                    tan[j] = d
                else:
                    tan[j] = self.let(f"{prefix}_{sym}__{wrt[j]}", d)
            if tan:
                tangent[sym] = tan
        jac = sp.zeros(len(outputs), len(wrt))
        for i, out in enumerate(outputs):
            out = sp.sympify(out)
            deps = [s for s in out.free_symbols if s in tangent]
            for s in deps:
                ds = diff(out, s)
                for j, t in tangent[s].items():
                    jac[i, j] += ds * t
        return jac

    def needed(self, exprs):
        """The assigned symbols that `exprs` depend on, directly or through other assignments."""
        need = set()
        stack = [s for e in exprs for s in _free(e) if s in self._defined]
        while stack:
            s = stack.pop()
            if s not in need:
                need.add(s)
                stack.extend(t for t in _free(self._defined[s]) if t in self._defined)
        return need

    # -- numerics --------------------------------------------------------------------------
    def _naming(self):
        """(names, renamer): `v<k>` for the k-th of the inputs, constants and assignments, and
        the memoised renaming to them. Kept with the program and extended as assignments are
        appended (a name never changes), so the evaluators of one program share the work."""
        if self._names is None:
            self._names, self._rename = {}, _Renamer({})
        names, rule = self._names, self._rename.rule
        order = self.inputs + self.constants + [s for s, _ in self.lets]
        for sym in order[len(names):]:
            names[sym] = f"v{len(names)}"
            rule[sym] = sp.Symbol(names[sym])
        return names, self._rename

    def source(self, outputs):
        """The straight-line Python source of `evaluator` (a function `_program(_in)`)."""
        pr = _printer()
        known = self.inputs + self.constants
        names, rename = self._naming()
        outputs = [sp.sympify(o) for o in outputs]
        extra = [s for o in outputs for s in o.free_symbols if s not in names]
        if extra:  # symbols outside the program (never in practice): named after the others
            names, rename = dict(names), _Renamer(dict(rename.rule))
            for s in extra:
                if s not in names:
                    names[s] = f"v{len(names)}"
                    rename.rule[s] = sp.Symbol(names[s])
        # Only the assignments the outputs depend on are printed; every assignment keeps its
        # name (v<k>, k its position), so the printed ones, and the values, do not depend on
        # which others are needed.
        needed = self.needed(outputs)
        lines = ["def _program(_in):"]
        for k, sym in enumerate(known):
            lines.append(f"    {names[sym]} = _in[{k}]")
        for sym, e in self.lets:
            # (every symbol of an assignment is known or assigned before: `let` checks)
            if sym in needed:
                lines.append(f"    {names[sym]} = {pr.doprint(rename(e))}")
        outs = [pr.doprint(rename(o)) for o in outputs]
        lines.append(f"    return [{', '.join(outs)}]")
        return "\n".join(lines)

    def evaluator(self, outputs, dps=40):
        """Compile an mpmath evaluator of `outputs`: call it with a dict {symbol: value}.

        The whole program is printed once as straight-line Python (sympy's MpmathPrinter, its
        symbols renamed v0, v1, ... in the order inputs, constants, assignments) and compiled as
        one function: much faster than a lambdify per assignment for programs of thousands of
        assignments."""
        known = self.inputs + self.constants
        namespace = {k: getattr(mpmath, k) for k in dir(mpmath) if not k.startswith("_")}
        exec(compile(self.source(outputs), "<slp.Program>", "exec"), namespace)
        f = namespace["_program"]
        needed = set(known)

        def run(values):
            missing = needed - set(values)
            if missing:
                raise ValueError(f"missing values for {sorted(map(str, missing))}")
            with mpmath.workdps(dps):
                return [mpmath.mpf(v) for v in f([mpmath.mpf(values[s]) for s in known])]

        return run


class _Renamer:
    """`e.xreplace(rule)` memoised over subexpressions (the assignments of a program share
    many): the same constructor calls as xreplace (`func(*args)` where a replacement happened
    below), hence the same expressions."""

    def __init__(self, rule):
        self.rule = rule
        self.memo = {}  # expr -> (renamed, changed)

    def __call__(self, e):
        return self._x(e)[0]

    def _x(self, e):
        r = self.memo.get(e)
        if r is None:
            if e in self.rule:
                r = (self.rule[e], True)
            else:
                args, changed = [], False
                for a in e.args:
                    a2, c = self._x(a)
                    args.append(a2)
                    changed |= c
                r = (e.func(*args), True) if changed else (e, False)
            self.memo[e] = r
        return r


_PRINTER = None


def _printer():
    """The one MpmathPrinter of the evaluators, with its output memoised per node.

    order="none": terms in their stored order (sorting them for print dominated the time).
    sympy's printers are compositional (a node's text depends on the node and the settings
    only), so a node's text is cached and reused across assignments and programs. What a node
    records on the printer while printed (`_not_supported`, `_number_symbols`, which `doprint`
    turns into extra lines) is cached with it and recorded again on reuse."""
    global _PRINTER
    if _PRINTER is None:
        from sympy.printing.pycode import MpmathPrinter

        class Printer(MpmathPrinter):
            _memo = {}  # expr -> (text, its _not_supported, its _number_symbols)
            _no_re = {}  # expr -> whether it contains no `re` node

            def _handle_UnevaluatedExpr(self, expr):
                # sympy's replaces every re(...) node, a walk over the whole expression on
                # every doprint; a memoised check returns the expression as it is without one
                if self._without_re(expr):
                    return expr
                return super()._handle_UnevaluatedExpr(expr)

            def _without_re(self, e):
                r = self._no_re.get(e)
                if r is None:
                    r = not isinstance(e, sp.re) and all(
                        self._without_re(a) for a in e.args if isinstance(a, sp.Basic))
                    self._no_re[e] = r
                return r

            def _print(self, expr, **kwargs):
                if kwargs or not isinstance(expr, sp.Basic):
                    return super()._print(expr, **kwargs)
                hit = self._memo.get(expr)
                if hit is None:
                    outer = self._not_supported, self._number_symbols
                    self._not_supported, self._number_symbols = set(), set()
                    try:
                        text = super()._print(expr)
                        hit = (text, self._not_supported, self._number_symbols)
                    finally:
                        self._not_supported, self._number_symbols = outer
                    self._memo[expr] = hit
                text, unsupported, numbers = hit
                self._not_supported |= unsupported
                self._number_symbols |= numbers
                return text

        _PRINTER = Printer({"fully_qualified_modules": False, "inline": True, "order": "none"})
    return _PRINTER
