"""The emitter: straight-line programs -> Rust source.

We own the printer. sympy 1.14's `rust_code` silently drops parentheses when symbols are real
(`a*(b+1)` prints as `a*b + 1.0`; sympy issues #29709, #28418, #28776), so this module prints
the few node types the derivation produces itself, with explicit precedence handling, every
literal an f64, and raises on anything it does not know. The generated test vectors
(sympy/mpmath evaluation at seeded points, checked by tests/generated_vectors.rs to ~1e-12)
prove the printed Rust equal to sympy's own evaluation.
"""

from dataclasses import dataclass, field

import sympy as sp

# Precedence levels of the printed Rust expression.
ADD, MUL, NEG, ATOM = 1, 2, 3, 4


class RustPrinter:
    def __init__(self, names):
        self.names = names  # Symbol -> Rust identifier
        self._memo = {}  # expr -> _p(expr): a node's text depends on the node and names only

    def __call__(self, e):
        return self._p(sp.sympify(e))[0]

    # Each _p returns (text, precedence of its outermost operator).
    def _p(self, e):
        r = self._memo.get(e)
        if r is None:
            r = self._memo[e] = self._print(e)
        return r

    def _print(self, e):
        if e.is_Symbol:
            if e not in self.names:
                raise KeyError(f"no Rust name for symbol {e}")
            return self.names[e], ATOM
        if e.is_Integer:
            v = int(e)
            return (f"{v}.0", ATOM) if v >= 0 else (f"-{-v}.0", NEG)
        if e.is_Rational:
            p, q = int(e.p), int(e.q)
            return f"({p}.0/{q}.0)", ATOM
        if e.is_Float:
            v = float(e)
            return (repr(v), ATOM) if v >= 0 else (f"({repr(v)})", ATOM)
        if e.is_Add:
            return self._add(e)
        if e.is_Mul:
            return self._mul(e)
        if e.is_Pow:
            return self._pow(e)
        if isinstance(e, sp.Function):
            return self._func(e)
        raise TypeError(f"cannot print {type(e).__name__}: {e}")

    def _wrap(self, e, min_prec):
        text, prec = self._p(e)
        return text if prec >= min_prec else f"({text})"

    def _add(self, e):
        terms = e.as_ordered_terms()
        out = ""
        for i, t in enumerate(terms):
            neg = t.could_extract_minus_sign()
            body = self._wrap(-t if neg else t, MUL)
            if i == 0:
                out = f"-{self._wrap(-t, NEG)}" if neg else body
            else:
                out += f" - {body}" if neg else f" + {body}"
        return out, ADD

    def _mul(self, e):
        coeff, factors = e.as_coeff_mul()
        num, den = [], []
        for f in factors:
            if f.is_Pow and f.exp.is_Rational and f.exp.is_negative:
                den.append(sp.Pow(f.base, -f.exp))
            else:
                num.append(f)
        if coeff.is_Rational and coeff.q != 1:
            if coeff.p not in (1, -1):
                num.insert(0, sp.Integer(abs(coeff.p)))
            den.insert(0, sp.Integer(coeff.q))
            sign = -1 if coeff.p < 0 else 1
        elif coeff in (1, -1):
            sign = int(coeff)
        else:
            sign = -1 if coeff.is_negative else 1
            num.insert(0, -coeff if sign < 0 else coeff)
        text = "*".join(self._wrap(f, MUL) for f in num) if num else "1.0"
        if den:
            if len(den) == 1:
                d = self._wrap(den[0], NEG + 1)
            else:
                d = "(" + "*".join(self._wrap(f, MUL) for f in den) + ")"
            text = f"{text}/{d}"
        if sign < 0:
            # unary minus binds tighter than * and /: -a*b/c == ((-a)*b)/c, the same value.
            return f"-{text}", MUL
        if len(num) == 1 and not den:
            return text, self._p(num[0])[1]
        return text, MUL

    def _receiver(self, b):
        text, prec = self._p(b)
        if b.is_Number:
            return f"({text}_f64)" if prec == ATOM and not text.startswith("(") else f"{text}"
        return text if prec == ATOM and b.is_Symbol else f"({text})"

    def _pow(self, e):
        b, x = e.base, e.exp
        if x.is_Integer:
            k = int(x)
            if k == 1:
                return self._p(b)
            if k < 0:
                return f"1.0/{self._wrap(sp.Pow(b, -x), NEG + 1)}", MUL
            return f"{self._receiver(b)}.powi({k})", ATOM
        if x == sp.Rational(1, 2):
            return f"{self._receiver(b)}.sqrt()", ATOM
        if x == -sp.Rational(1, 2):
            return f"1.0/{self._receiver(b)}.sqrt()", MUL
        if x == sp.Rational(1, 3):
            return f"{self._receiver(b)}.cbrt()", ATOM
        return f"{self._receiver(b)}.powf({self(x)})", ATOM

    FUNCS = {sp.tanh: "tanh", sp.sinh: "sinh", sp.cosh: "cosh", sp.exp: "exp", sp.log: "ln",
             sp.sin: "sin", sp.cos: "cos", sp.tan: "tan", sp.Abs: "abs"}

    def _func(self, e):
        name = self.FUNCS.get(type(e))
        if name is None:
            raise TypeError(f"cannot print function {type(e).__name__}")
        return f"{self._receiver(e.args[0])}.{name}()", ATOM


# ---------------------------------------------------------------------------------------------
# Functions


@dataclass
class Arg:
    """An input array: `name: &[f64; len(symbols)]`, unpacked into one local per symbol."""
    name: str
    symbols: list
    doc: str
    sample: object = None  # callable(rng, index) -> float, for test vectors
    sample_vector: object = None  # callable(rng) -> list of floats (instead of `sample`)


@dataclass
class Scalar:
    """A scalar input passed by value."""
    symbol: sp.Symbol
    doc: str
    sample: object = None

    @property
    def name(self):
        return str(self.symbol)


@dataclass
class Out:
    """An output: 'return' (scalar), 'array' (&mut [f64; n]) or 'matrix' (&mut [[f64; c]; r])."""
    name: str
    exprs: object
    kind: str
    doc: str


@dataclass
class Function:
    name: str
    doc: str
    program: object
    args: list
    outputs: list
    samples: list = field(default_factory=list)  # filled by the generator
    wide: bool = False  # also compiled for AVX2 (set by `emit_function`)


def rust_ident(sym):
    return str(sym)


def _needed_lets(program, exprs):
    """The assignments `exprs` depend on, in program order."""
    need = program.needed([sp.sympify(e) for e in exprs])
    return [(s, e) for s, e in program.lets if s in need]


def flat_outputs(fn):
    out = []
    for o in fn.outputs:
        if o.kind == "matrix":
            out.extend(list(o.exprs))  # row-major
        elif o.kind == "array":
            out.extend(list(o.exprs))
        else:
            out.append(o.exprs)
    return [sp.sympify(e) for e in out]


def emit_body(fn, indent="    "):
    """cse over the needed assignments and outputs, in dependency order."""
    outs = flat_outputs(fn)
    lets = _needed_lets(fn.program, outs)
    exprs = [e for _, e in lets] + outs
    temps = sp.numbered_symbols("x")
    repl, reduced = sp.cse(exprs, symbols=temps, order="canonical")
    nodes = {}  # symbol -> expr
    index = {}
    for i, (s, e) in enumerate(repl):
        nodes[s] = e
        index[s] = (1, i)
    for i, ((s, _), e) in enumerate(zip(lets, reduced[: len(lets)])):
        nodes[s] = e
        index[s] = (0, i)
    out_exprs = reduced[len(lets):]
    emitted, order = set(), []

    def visit(s):
        if s in emitted:
            return
        emitted.add(s)
        deps = sorted((t for t in nodes[s].free_symbols if t in nodes), key=index.get)
        for t in deps:
            visit(t)
        order.append(s)

    for e in out_exprs:
        for t in sorted((t for t in e.free_symbols if t in nodes), key=index.get):
            visit(t)
    # Intermediate quantities live in one array `t`, not in one `let` each: every `let` opens
    # a nested lexical scope, and thousands of them (the so4 Jacobians) overflowed the stack
    # of LLVM's debug-info writer. Constant indices into a local array cost nothing once
    # optimised (SROA keeps them in registers). The trailing comment keeps the name.
    names = {s: f"t[{k}]" for k, s in enumerate(order)}
    for a in fn.args:
        for s in (a.symbols if isinstance(a, Arg) else [a.symbol]):
            names[s] = rust_ident(s)
    pr = RustPrinter(names)
    lines = []
    for a in fn.args:
        if isinstance(a, Arg):
            for i, s in enumerate(a.symbols):
                lines.append(f"{indent}let {names[s]} = {a.name}[{i}];")
    if order:
        lines.append(f"{indent}let mut t = [0.0f64; {len(order)}];")
    for s in order:
        lines.append(f"{indent}{names[s]} = {pr(nodes[s])}; // {rust_ident(s)}")
    k = 0
    for o in fn.outputs:
        if o.kind == "return":
            lines.append(f"{indent}{pr(out_exprs[k])}")
            k += 1
        elif o.kind == "array":
            for i in range(len(o.exprs)):
                lines.append(f"{indent}{o.name}[{i}] = {pr(out_exprs[k])};")
                k += 1
        else:
            r, c = o.exprs.shape
            for i in range(r):
                for j in range(c):
                    lines.append(f"{indent}{o.name}[{i}][{j}] = {pr(out_exprs[k])};")
                    k += 1
    return lines


def signature(fn):
    params, ret = [], ""
    for a in fn.args:
        if isinstance(a, Arg):
            params.append(f"{a.name}: &[f64; {len(a.symbols)}]")
        else:
            params.append(f"{a.name}: f64")
    for o in fn.outputs:
        if o.kind == "return":
            ret = " -> f64"
        elif o.kind == "array":
            params.append(f"{o.name}: &mut [f64; {len(o.exprs)}]")
        else:
            r, c = o.exprs.shape
            params.append(f"{o.name}: &mut [[f64; {c}]; {r}]")
    return f"pub fn {fn.name}({', '.join(params)}){ret}"


def doc_lines(fn):
    lines = [f"/// {line}" if line else "///" for line in fn.doc.strip().splitlines()]
    lines.append("///")
    lines.append("/// # Arguments")
    for a in fn.args:
        if isinstance(a, Arg):
            syms = ", ".join(str(s) for s in a.symbols)
            lines.append(f"/// * `{a.name}`: {a.doc} = `[{syms}]`")
        else:
            lines.append(f"/// * `{a.name}`: {a.doc}")
    for o in fn.outputs:
        if o.kind == "return":
            lines.append(f"/// * returns {o.doc}")
        else:
            lines.append(f"/// * `{o.name}` (written, every entry): {o.doc}")
    return lines


# Functions with at least this many intermediate quantities are also compiled for AVX2 and
# choose that copy at run time: the three-operand VEX forms and the wider registers spare many
# of the register copies and spills of a long straight-line body (the Jacobians of the
# optimality system: 743 intermediates for so(3)). The operations and their order are the
# same in both copies, and Rust never fuses a multiply and an add, so both give the same bits
# (`check_vectors` compares them bit for bit).
WIDE_MIN_TEMPORARIES = 100


def call_args(fn):
    return ", ".join([a.name for a in fn.args] + [o.name for o in fn.outputs if o.kind != "return"])


def emit_function(fn):
    body = emit_body(fn)
    n_temps = sum(1 for line in body if line.lstrip().startswith("t["))
    head = signature(fn)
    fn.wide = n_temps >= WIDE_MIN_TEMPORARIES
    if not fn.wide:
        return "\n".join(doc_lines(fn) + [head + " {"] + body + ["}"])
    params = head[len(f"pub fn {fn.name}"):]
    args = call_args(fn)
    dispatch = [
        head + " {",
        '    #[cfg(target_arch = "x86_64")]',
        '    if std::arch::is_x86_feature_detected!("avx2") {',
        "        // SAFETY: the CPU supports AVX2, checked just above.",
        f"        return unsafe {{ {fn.name}_avx2({args}) }};",
        "    }",
        f"    {fn.name}_portable({args})",
        "}",
        "",
        f"/// [`{fn.name}`] compiled for AVX2.",
        '#[cfg(target_arch = "x86_64")]',
        '#[target_feature(enable = "avx2")]',
        f"fn {fn.name}_avx2{params} {{",
        f"    {fn.name}_portable({args})",
        "}",
        "",
        f"/// [`{fn.name}`] as it runs on a CPU without AVX2 (the same operations in the same order;",
        "/// public for the check that both copies give the same bits).",
        "#[inline(always)]",
        f"pub fn {fn.name}_portable{params} {{",
    ]
    return "\n".join(doc_lines(fn) + dispatch + body + ["}"])


def fmt_f64(v):
    f = float(v)
    r = repr(f)
    if "inf" in r or "nan" in r:
        raise ValueError("non-finite test vector")
    if "e" not in r and "." not in r:
        r += ".0"
    return r


def _output_declarations(fn):
    """Fresh `let mut` outputs of `fn` for a call in `check_vectors` (matrices NaN-filled, so
    that an entry left unwritten shows)."""
    lines = []
    for o in fn.outputs:
        if o.kind == "array":
            lines.append(f"        let mut {o.name} = [0.0f64; {len(o.exprs)}];")
        elif o.kind == "matrix":
            r, c = o.exprs.shape
            lines.append(f"        let mut {o.name} = [[f64::NAN; {c}]; {r}];")
    return lines


def _call_line(ret, invocation):
    """A call statement, binding the returned scalar to `ret` when there is one."""
    return f"        let {ret} = {invocation};" if ret else f"        {invocation};"


def emit_vector_checks(functions):
    """Rust source of `check_vectors`, calling each generated function at its sample points."""
    lines = [
        "/// Calls every generated function at the generator's seeded sample points and returns",
        "/// one message per output that differs from sympy's (mpmath, 40 digits) evaluation by",
        "/// more than `rtol * (1 + |expected|)`.",
        "pub fn check_vectors(rtol: f64) -> Vec<String> {",
        "    let mut failures = Vec::new();",
        "    let mut count = 0usize;",
    ]
    for fn in functions:
        for k, (inputs, expected) in enumerate(fn.samples):
            lines.append("    {")
            call = []
            for a, vals in zip(fn.args, inputs):
                if isinstance(a, Arg):
                    lines.append(f"        let {a.name}: [f64; {len(vals)}] = "
                                 f"[{', '.join(fmt_f64(v) for v in vals)}];")
                    call.append(f"&{a.name}")
                else:
                    lines.append(f"        let {a.name}: f64 = {fmt_f64(vals)};")
                    call.append(a.name)
            got = []
            ret = None
            for o in fn.outputs:
                if o.kind == "return":
                    ret = o.name
                    got.append(f"std::iter::once({ret})")
                else:
                    call.append(f"&mut {o.name}")
                    flat = ".flatten()" if o.kind == "matrix" else ""
                    got.append(f"{o.name}.iter(){flat}.copied()")
            lines.extend(_output_declarations(fn))
            lines.append(_call_line(ret, f"{fn.name}({', '.join(call)})"))
            chain = got[0] + "".join(f".chain({g})" for g in got[1:])
            lines.append(f"        let got: Vec<f64> = {chain}.collect();")
            if fn.wide:
                # The portable copy, into fresh outputs: the same bits. The inputs go through
                # `black_box`: the inlined portable copy must run, not be folded at compile
                # time (LLVM folds `powi(x, 3)` with one rounding, not two).
                lines.extend(_output_declarations(fn))
                for a in fn.args:
                    lines.append(f"        let {a.name} = std::hint::black_box({a.name});")
                lines.append(_call_line(ret, f"{fn.name}_portable({', '.join(call)})"))
                lines.append(f"        let portable: Vec<f64> = {chain}.collect();")
                lines.append("        for (i, (fast, slow)) in got.iter().zip(&portable).enumerate() {")
                lines.append("            if fast.to_bits() != slow.to_bits() {")
                lines.append(f"                failures.push(format!(\"{fn.name} sample {k} output {{i}}: "
                             "{fast:e} here, {slow:e} from the portable copy\"));")
                lines.append("            }")
                lines.append("        }")
            lines.append(f"        let expected: [f64; {len(expected)}] = "
                         f"[{', '.join(fmt_f64(v) for v in expected)}];")
            lines.append("        assert_eq!(got.len(), expected.len());")
            lines.append("        for (i, (g, e)) in got.iter().zip(expected.iter()).enumerate() {")
            lines.append("            count += 1;")
            lines.append("            if !((g - e).abs() <= rtol * (1.0 + e.abs())) {")
            lines.append(f"                failures.push(format!(\"{fn.name} sample {k} output {{i}}: "
                         "got {g:e}, sympy {e:e}\"));")
            lines.append("            }")
            lines.append("        }")
            lines.append("    }")
    lines.append("    assert!(count > 0);")
    lines.append("    failures")
    lines.append("}")
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# The model-independent trait over every model's functions


def slice_signature(sig):
    """A signature dict (generate.signatures) with slices instead of fixed-size arrays
    (matrices row-major flat), for the `Model` trait that generic code uses."""
    params, ret = [], ""
    for name, kind in sig["args"]:
        params.append(f"{name}: &[f64]" if kind == "array" else f"{name}: f64")
    for name, kind, _ in sig["outputs"]:
        if kind == "return":
            ret = " -> f64"
        else:
            params.append(f"{name}: &mut [f64]")
    return f"fn {sig['name']}({', '.join(params)}){ret}"


def trait_text(sigs):
    """`pub trait Model`: every generated function as a slice-based method, plus metadata."""
    lines = [
        "/// A generated model: its metadata and every generated function, with slices instead",
        "/// of fixed-size arrays so that generic code (the BVP, the homotopy, the checks) can be",
        "/// written once for every model. Implemented by `so3::So3`, `se2::Se2`, ... (generated).",
        "#[allow(clippy::too_many_arguments)]",
        "pub trait Model: Copy + Default + Send + Sync + 'static {",
        "    /// The model's name (its file `codegen/models/<name>.py`).",
        "    const NAME: &'static str;",
        "    /// Dimension n of the Lie algebra.",
        "    const DIM: usize;",
        "    /// Number of states of the optimality system (4n).",
        "    const N_STATE: usize;",
        "    /// Number of constants p (user parameters, then derived constants).",
        "    const N_PARAM: usize;",
        "    /// Number of user parameters at the front of p.",
        "    const N_USER_PARAM: usize;",
        "    /// Names of the states.",
        "    const STATE_NAMES: &'static [&'static str];",
        "    /// Names of the constants p.",
        "    const PARAM_NAMES: &'static [&'static str];",
        "    /// The inertia parameters.",
        "    const INERTIA_PARAMS: &'static [ParamMeta];",
        "    /// The weights of the cost.",
        "    const WEIGHTS: &'static [ParamMeta];",
        "    /// The constraint-value parameters.",
        "    const CONSTRAINT_PARAMS: &'static [ParamMeta];",
        "    /// (index in p, row, column) of the derived entries of I^-1.",
        "    const INERTIA_INVERSE_SLOTS: &'static [(usize, usize, usize)];",
        "    /// The basis names of the Lie algebra.",
        "    const BASIS_NAMES: &'static [&'static str];",
        "    /// A one-line description of the model.",
        "    const TITLE: &'static str;",
        "    /// The blocks of the state y = [Omega, xi, xi', kappa].",
        "    const OMEGA: core::ops::Range<usize>;",
        "    /// See [`Model::OMEGA`].",
        "    const XI: core::ops::Range<usize>;",
        "    /// See [`Model::OMEGA`].",
        "    const XIDOT: core::ops::Range<usize>;",
        "    /// See [`Model::OMEGA`].",
        "    const KAPPA: core::ops::Range<usize>;",
        "    /// Number of desired-path inputs w = [Omega_d, Omega_d'].",
        "    const N_DESIRED: usize;",
        "    /// Number of boundary conditions at each end (without the free-time condition).",
        "    const N_BC_ENDPOINT: usize;",
        "    /// Number of Lie brackets [g_i, g_j], i < j, of the control fields.",
        "    const N_BRACKETS: usize;",
        "    /// A faithful matrix representation of the basis, `(k, E)` with the `n` basis",
        "    /// matrices `k x k` one after the other, row-major (`None` when the model declares",
        "    /// its algebra by structure constants only).",
        "    const REPRESENTATION: Option<(usize, &'static [f64])>;",
        "    /// Whether the constraint value gamma(xi) in <Omega, xi> = gamma(xi) is not",
        "    /// identically 0 (then the start imposes it: `bc_start_constrained`).",
        "    const HAS_CONSTRAINT_VALUE: bool;",
        "    /// Whether gamma depends on xi (else the constraint at a fixed Omega is linear in xi).",
        "    const CONSTRAINT_VALUE_DEPENDS_ON_XI: bool;",
    ]
    for sig in sigs:
        first = sig["doc"].strip().splitlines()[0]
        lines += [f"    /// {first}", "    ///",
                  "    /// Slices of exactly the sizes of the model's generated function of this",
                  "    /// name (matrices flat, row-major). Panics on a wrong length."]
        lines.append(f"    {slice_signature(sig)};")
    lines.append("}")
    return "\n".join(lines)


def impl_text(type_name, fns, representation):
    """`impl super::Model for <type_name>` forwarding to the module's functions;
    `representation` is the Rust expression of its `REPRESENTATION` constant."""
    lines = [
        "#[allow(clippy::too_many_arguments)]",
        "impl super::Model for " + type_name + " {",
        "    const NAME: &'static str = MODEL_NAME;",
        "    const DIM: usize = DIM;",
        "    const N_STATE: usize = N_STATE;",
        "    const N_PARAM: usize = N_PARAM;",
        "    const N_USER_PARAM: usize = N_USER_PARAM;",
        "    const STATE_NAMES: &'static [&'static str] = &STATE_NAMES;",
        "    const PARAM_NAMES: &'static [&'static str] = &PARAM_NAMES;",
        "    const INERTIA_PARAMS: &'static [ParamMeta] = &INERTIA_PARAMS;",
        "    const WEIGHTS: &'static [ParamMeta] = &WEIGHTS;",
        "    const CONSTRAINT_PARAMS: &'static [ParamMeta] = &CONSTRAINT_PARAMS;",
        "    const INERTIA_INVERSE_SLOTS: &'static [(usize, usize, usize)] = &INERTIA_INVERSE_SLOTS;",
        "    const BASIS_NAMES: &'static [&'static str] = &BASIS_NAMES;",
        "    const TITLE: &'static str = MODEL_TITLE;",
        "    const OMEGA: core::ops::Range<usize> = OMEGA;",
        "    const XI: core::ops::Range<usize> = XI;",
        "    const XIDOT: core::ops::Range<usize> = XIDOT;",
        "    const KAPPA: core::ops::Range<usize> = KAPPA;",
        "    const N_DESIRED: usize = N_DESIRED;",
        "    const N_BC_ENDPOINT: usize = N_BC_ENDPOINT;",
        "    const N_BRACKETS: usize = N_BRACKETS;",
        f"    const REPRESENTATION: Option<(usize, &'static [f64])> = {representation};",
        "    const HAS_CONSTRAINT_VALUE: bool = HAS_CONSTRAINT_VALUE;",
        "    const CONSTRAINT_VALUE_DEPENDS_ON_XI: bool = CONSTRAINT_VALUE_DEPENDS_ON_XI;",
    ]
    for fn in fns:
        call = []
        for a in fn.args:
            if isinstance(a, Arg):
                call.append(f"{a.name}.try_into().expect(\"{fn.name}: length of `{a.name}`\")")
            else:
                call.append(a.name)
        for o in fn.outputs:
            if o.kind == "array":
                call.append(f"{o.name}.try_into().expect(\"{fn.name}: length of `{o.name}`\")")
            elif o.kind == "matrix":
                r, c = o.exprs.shape
                call.append(f"{o.name}.as_chunks_mut::<{c}>().0.try_into()"
                            f".expect(\"{fn.name}: length of `{o.name}`\")")
        sig = {"name": fn.name,
               "args": [[a.name, "array" if isinstance(a, Arg) else "scalar"] for a in fn.args],
               "outputs": [[o.name, o.kind, None] for o in fn.outputs]}
        lines.append(f"    {slice_signature(sig)} {{")
        lines.append(f"        {fn.name}({', '.join(call)})")
        lines.append("    }")
    lines.append("}")
    return "\n".join(lines)
