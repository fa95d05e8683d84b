//! Desired paths written as formulas in `t`, with exact derivatives.
//!
//! `Ω_d(t)` can be given component by component as text, e.g.
//! `["3 cos(0.5 t)", "2 sin(0.5 t)", "1 + 0.1 t^2"]` (a problem file's `kind = "expression"`).
//! The homotopy and the optimality system need `Ω_d` and its first three derivatives
//! ([`Path::jet_into`]); they are computed exactly (to rounding) by evaluating the formula's
//! syntax tree over third-order dual numbers (`num_dual::Dual3`: forward-mode automatic
//! differentiation, as the other paths of this layer are), and the value alone over `f64`.
//! No symbolic differentiation, no finite differences.
//!
//! # Grammar
//!
//! ```text
//! expr    = term (("+" | "-") term)*
//! term    = factor (("*" | "/") factor | factor)*      (juxtaposition: "2 t", "3 cos(t)")
//! factor  = ("-" | "+") factor | power
//! power   = atom ("^" factor)?                          (right-associative; -t^2 = -(t^2))
//! atom    = number | name | name "(" expr ")" | "(" expr ")"
//! ```
//!
//! Names: `t` (time), `pi`, the constants the caller passes ([`Expression::parse`]), and the
//! functions `sin cos tan exp log sqrt sinh cosh tanh asin acos atan`. `**` is accepted for
//! `^`. A power with a constant integer exponent is repeated multiplication (so `t^3` is
//! defined at `t < 0`); any other power is `exp(b log a)` and needs `a > 0`.
//!
//! Hostile input is bounded: at most [`MAX_EXPRESSION_CHARS`] characters and
//! [`MAX_DEPTH`] levels of nesting (a parser without that limit overflows its stack on
//! `((((…`), and every error names the position (in characters) and what was expected.
//! Values that leave the domain of a function (`log(t - 5)` at `t = 0`, `sqrt(-1)`) evaluate
//! to NaN; [`Expression::check_finite`] finds the first such time on a grid so that a problem
//! file is refused before solving.

use num_dual::Dual3;

use super::path::{Path, Scalar};

/// Longest formula accepted, in characters.
pub const MAX_EXPRESSION_CHARS: usize = 2000;
/// Deepest nesting of parentheses, function calls, signs and powers accepted.
pub const MAX_DEPTH: usize = 64;

/// The functions a formula may call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Func {
    Sin,
    Cos,
    Tan,
    Exp,
    Log,
    Sqrt,
    Sinh,
    Cosh,
    Tanh,
    Asin,
    Acos,
    Atan,
}

const FUNCS: [(&str, Func); 13] = [
    ("sin", Func::Sin),
    ("cos", Func::Cos),
    ("tan", Func::Tan),
    ("exp", Func::Exp),
    ("log", Func::Log),
    ("ln", Func::Log),
    ("sqrt", Func::Sqrt),
    ("sinh", Func::Sinh),
    ("cosh", Func::Cosh),
    ("tanh", Func::Tanh),
    ("asin", Func::Asin),
    ("acos", Func::Acos),
    ("atan", Func::Atan),
];

impl Func {
    fn apply<D: Scalar>(self, a: D) -> D {
        match self {
            Func::Sin => a.sin(),
            Func::Cos => a.cos(),
            Func::Tan => a.tan(),
            Func::Exp => a.exp(),
            Func::Log => a.ln(),
            Func::Sqrt => a.sqrt(),
            Func::Sinh => a.sinh(),
            Func::Cosh => a.cosh(),
            Func::Tanh => a.tanh(),
            Func::Asin => a.asin(),
            Func::Acos => a.acos(),
            Func::Atan => a.atan(),
        }
    }
}

/// The syntax tree of a formula.
#[derive(Debug, Clone, PartialEq)]
enum Node {
    Num(f64),
    T,
    Neg(Box<Node>),
    Add(Box<Node>, Box<Node>),
    Sub(Box<Node>, Box<Node>),
    Mul(Box<Node>, Box<Node>),
    Div(Box<Node>, Box<Node>),
    Pow(Box<Node>, Box<Node>),
    Call(Func, Box<Node>),
}

impl Node {
    /// Subtrees without `t` replaced by their value (so that `t^(1 + 1)` is `t^2`, an integer
    /// power by multiplication, and constants are not re-evaluated at every time).
    fn fold(self) -> Node {
        let both = |a: Box<Node>, b: Box<Node>| (Box::new(a.fold()), Box::new(b.fold()));
        let folded = match self {
            Node::Num(_) | Node::T => return self,
            Node::Neg(a) => Node::Neg(Box::new(a.fold())),
            Node::Call(f, a) => Node::Call(f, Box::new(a.fold())),
            Node::Add(a, b) => {
                let (a, b) = both(a, b);
                Node::Add(a, b)
            }
            Node::Sub(a, b) => {
                let (a, b) = both(a, b);
                Node::Sub(a, b)
            }
            Node::Mul(a, b) => {
                let (a, b) = both(a, b);
                Node::Mul(a, b)
            }
            Node::Div(a, b) => {
                let (a, b) = both(a, b);
                Node::Div(a, b)
            }
            Node::Pow(a, b) => {
                let (a, b) = both(a, b);
                Node::Pow(a, b)
            }
        };
        if folded.has_t() {
            folded
        } else {
            Node::Num(folded.eval(0.0))
        }
    }

    fn has_t(&self) -> bool {
        match self {
            Node::Num(_) => false,
            Node::T => true,
            Node::Neg(a) | Node::Call(_, a) => a.has_t(),
            Node::Add(a, b)
            | Node::Sub(a, b)
            | Node::Mul(a, b)
            | Node::Div(a, b)
            | Node::Pow(a, b) => a.has_t() || b.has_t(),
        }
    }

    fn eval<D: Scalar>(&self, t: D) -> D {
        match self {
            Node::Num(v) => D::from(*v),
            Node::T => t,
            Node::Neg(a) => -a.eval(t),
            Node::Add(a, b) => a.eval(t) + b.eval(t),
            Node::Sub(a, b) => a.eval(t) - b.eval(t),
            Node::Mul(a, b) => a.eval(t) * b.eval(t),
            Node::Div(a, b) => a.eval(t) / b.eval(t),
            Node::Pow(a, b) => match b.as_ref() {
                // A constant exponent: an integer one is repeated multiplication (defined
                // for negative bases), any other `a^p` needs `a > 0`.
                Node::Num(p) if *p == p.trunc() && p.abs() <= 64.0 => a.eval(t).powi(*p as i32),
                Node::Num(p) => a.eval(t).powf(*p),
                _ => (b.eval(t) * a.eval(t).ln()).exp(),
            },
            Node::Call(f, a) => f.apply(a.eval(t)),
        }
    }
}

/// Why a formula cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExpressionError {
    /// The text is not a formula of the grammar (module docs).
    #[error("at character {position}: {message}")]
    Syntax {
        /// 1-based position, in characters.
        position: usize,
        /// What was found and what was expected.
        message: String,
    },
    /// Longer than [`MAX_EXPRESSION_CHARS`] or nested deeper than [`MAX_DEPTH`].
    #[error("{0}")]
    TooLarge(String),
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Num(f64),
    Name(String),
    Op(char),
    Pow,
}

/// Tokens with their 1-based character positions.
fn tokenize(text: &str) -> Result<Vec<(Token, usize)>, ExpressionError> {
    let chars: Vec<char> = text.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let pos = i + 1;
        if c.is_whitespace() {
            i += 1;
        } else if c.is_ascii_digit()
            || (c == '.' && chars.get(i + 1).is_some_and(char::is_ascii_digit))
        {
            let start = i;
            while i < chars.len() && (chars[i].is_ascii_digit() || chars[i] == '.') {
                i += 1;
            }
            // An exponent: e or E, an optional sign, digits (else `e` starts a name: `2e`
            // is refused below, `2 e` is not a thing either).
            if i < chars.len() && (chars[i] == 'e' || chars[i] == 'E') {
                let mut j = i + 1;
                if j < chars.len() && (chars[j] == '+' || chars[j] == '-') {
                    j += 1;
                }
                if j < chars.len() && chars[j].is_ascii_digit() {
                    while j < chars.len() && chars[j].is_ascii_digit() {
                        j += 1;
                    }
                    i = j;
                }
            }
            let lit: String = chars[start..i].iter().collect();
            let v: f64 = lit.parse().map_err(|_| ExpressionError::Syntax {
                position: pos,
                message: format!("`{lit}` is not a number"),
            })?;
            if !v.is_finite() {
                return Err(ExpressionError::Syntax {
                    position: pos,
                    message: format!("`{lit}` is not a finite number"),
                });
            }
            out.push((Token::Num(v), pos));
        } else if c.is_alphabetic() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push((Token::Name(chars[start..i].iter().collect()), pos));
        } else if c == '*' && chars.get(i + 1) == Some(&'*') {
            out.push((Token::Pow, pos));
            i += 2;
        } else if c == '^' {
            out.push((Token::Pow, pos));
            i += 1;
        } else if "+-*/()".contains(c) {
            out.push((Token::Op(c), pos));
            i += 1;
        } else {
            return Err(ExpressionError::Syntax {
                position: pos,
                message: format!(
                    "unexpected `{c}`; a formula uses numbers, t, pi, constants, + - * / ^, \
                     parentheses and the functions {}",
                    function_list()
                ),
            });
        }
    }
    Ok(out)
}

/// Whether `name` can be a constant of the formulas: a name as the formulas spell names (a
/// letter or `_`, then letters, digits or `_`) that is not `t`, `pi` or a function, which
/// would always win over it (`Err` says why).
pub fn check_constant_name(name: &str) -> Result<(), String> {
    let mut chars = name.chars();
    let spelled = chars.next().is_some_and(|c| c.is_alphabetic() || c == '_')
        && chars.all(|c| c.is_alphanumeric() || c == '_');
    if !spelled {
        return Err(
            "is not a name a formula can use (a letter or `_`, then letters, digits or `_`)".into(),
        );
    }
    if name == "t" || name == "pi" || FUNCS.iter().any(|(n, _)| *n == name) {
        return Err(format!(
            "is a built-in name (t, pi and the functions {}), which a formula would read as \
             the built-in",
            function_list()
        ));
    }
    Ok(())
}

fn function_list() -> String {
    FUNCS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(" ")
}

struct Parser<'a> {
    tokens: Vec<(Token, usize)>,
    at: usize,
    depth: usize,
    end: usize,
    constants: &'a [(String, f64)],
}

impl Parser<'_> {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.at).map(|(t, _)| t)
    }

    fn position(&self) -> usize {
        self.tokens.get(self.at).map_or(self.end, |(_, p)| *p)
    }

    fn error<T>(&self, message: impl Into<String>) -> Result<T, ExpressionError> {
        Err(ExpressionError::Syntax {
            position: self.position(),
            message: message.into(),
        })
    }

    fn found(&self) -> String {
        match self.peek() {
            None => "the end of the formula".to_string(),
            Some(Token::Num(v)) => format!("the number {v}"),
            Some(Token::Name(n)) => format!("`{n}`"),
            Some(Token::Op(c)) => format!("`{c}`"),
            Some(Token::Pow) => "`^`".to_string(),
        }
    }

    fn descend(&mut self) -> Result<(), ExpressionError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(ExpressionError::TooLarge(format!(
                "the formula nests deeper than {MAX_DEPTH} levels (parentheses, calls, signs, \
                 powers); simplify it"
            )));
        }
        Ok(())
    }

    fn expr(&mut self) -> Result<Node, ExpressionError> {
        self.descend()?;
        let mut left = self.term()?;
        while let Some(Token::Op(c @ ('+' | '-'))) = self.peek() {
            let c = *c;
            self.at += 1;
            let right = self.term()?;
            left = if c == '+' {
                Node::Add(Box::new(left), Box::new(right))
            } else {
                Node::Sub(Box::new(left), Box::new(right))
            };
        }
        self.depth -= 1;
        Ok(left)
    }

    fn term(&mut self) -> Result<Node, ExpressionError> {
        let mut left = self.factor()?;
        loop {
            match self.peek() {
                Some(Token::Op(c @ ('*' | '/'))) => {
                    let c = *c;
                    self.at += 1;
                    let right = self.factor()?;
                    left = if c == '*' {
                        Node::Mul(Box::new(left), Box::new(right))
                    } else {
                        Node::Div(Box::new(left), Box::new(right))
                    };
                }
                // Juxtaposition: "2 t", "3 cos(t)", "(1 + t)(2 - t)".
                Some(Token::Num(_) | Token::Name(_) | Token::Op('(')) => {
                    let right = self.factor()?;
                    left = Node::Mul(Box::new(left), Box::new(right));
                }
                _ => return Ok(left),
            }
        }
    }

    fn factor(&mut self) -> Result<Node, ExpressionError> {
        match self.peek() {
            Some(Token::Op('-')) => {
                self.at += 1;
                self.descend()?;
                let inner = self.factor()?;
                self.depth -= 1;
                Ok(Node::Neg(Box::new(inner)))
            }
            Some(Token::Op('+')) => {
                self.at += 1;
                self.descend()?;
                let inner = self.factor()?;
                self.depth -= 1;
                Ok(inner)
            }
            _ => self.power(),
        }
    }

    fn power(&mut self) -> Result<Node, ExpressionError> {
        let base = self.atom()?;
        if let Some(Token::Pow) = self.peek() {
            self.at += 1;
            self.descend()?;
            let exponent = self.factor()?;
            self.depth -= 1;
            return Ok(Node::Pow(Box::new(base), Box::new(exponent)));
        }
        Ok(base)
    }

    fn atom(&mut self) -> Result<Node, ExpressionError> {
        match self.peek().cloned() {
            Some(Token::Num(v)) => {
                self.at += 1;
                Ok(Node::Num(v))
            }
            Some(Token::Op('(')) => {
                self.at += 1;
                let inner = self.expr()?;
                self.close("the parenthesis")?;
                Ok(inner)
            }
            Some(Token::Name(name)) => {
                self.at += 1;
                if let Some((_, f)) = FUNCS.iter().find(|(n, _)| *n == name) {
                    if self.peek() != Some(&Token::Op('(')) {
                        return self.error(format!(
                            "expected `(` after the function `{name}`, found {}",
                            self.found()
                        ));
                    }
                    self.at += 1;
                    let arg = self.expr()?;
                    self.close(&format!("`{name}(`"))?;
                    return Ok(Node::Call(*f, Box::new(arg)));
                }
                match name.as_str() {
                    "t" => Ok(Node::T),
                    "pi" => Ok(Node::Num(std::f64::consts::PI)),
                    _ => match self.constants.iter().find(|(n, _)| *n == name) {
                        Some((_, v)) => Ok(Node::Num(*v)),
                        None => {
                            self.at -= 1;
                            self.error(format!(
                                "unknown name `{name}`; the names are t, pi{}{} and the \
                                 functions {}",
                                if self.constants.is_empty() { "" } else { ", " },
                                self.constants
                                    .iter()
                                    .map(|(n, _)| n.as_str())
                                    .collect::<Vec<_>>()
                                    .join(", "),
                                function_list()
                            ))
                        }
                    },
                }
            }
            _ => self.error(format!(
                "expected a number, t, a name, a function call or `(`, found {}",
                self.found()
            )),
        }
    }

    fn close(&mut self, what: &str) -> Result<(), ExpressionError> {
        if self.peek() == Some(&Token::Op(')')) {
            self.at += 1;
            Ok(())
        } else {
            self.error(format!(
                "expected `)` to close {what}, found {}",
                self.found()
            ))
        }
    }
}

/// One formula in `t`.
#[derive(Debug, Clone, PartialEq)]
pub struct Formula {
    text: String,
    root: Node,
}

impl Formula {
    /// Parse `text` (module docs for the grammar); `constants` are extra names with values.
    pub fn parse(text: &str, constants: &[(String, f64)]) -> Result<Self, ExpressionError> {
        let chars = text.chars().count();
        if chars > MAX_EXPRESSION_CHARS {
            return Err(ExpressionError::TooLarge(format!(
                "the formula has {chars} characters, more than {MAX_EXPRESSION_CHARS}"
            )));
        }
        let tokens = tokenize(text)?;
        if tokens.is_empty() {
            return Err(ExpressionError::Syntax {
                position: 1,
                message: "the formula is empty; write a function of t, e.g. \"cos(t)\"".into(),
            });
        }
        let mut p = Parser {
            tokens,
            at: 0,
            depth: 0,
            end: chars + 1,
            constants,
        };
        let root = p.expr()?;
        if p.at < p.tokens.len() {
            return p.error(format!(
                "expected an operator or the end of the formula, found {}",
                p.found()
            ));
        }
        Ok(Self {
            text: text.to_string(),
            root: root.fold(),
        })
    }

    /// The text it was parsed from.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// `(f, f', f'', f''')` at `t`.
    pub fn derivatives(&self, t: f64) -> [f64; 4] {
        let d = self.root.eval(Dual3::from_re(t).derivative());
        [d.re, d.v1, d.v2, d.v3]
    }

    /// `f(t)`.
    pub fn value(&self, t: f64) -> f64 {
        self.root.eval(t)
    }
}

/// `Ω_d(t)` given by one [`Formula`] per component.
#[derive(Debug, Clone, PartialEq)]
pub struct Expression {
    components: Vec<Formula>,
}

impl Expression {
    /// Parse one formula per component, with the named `constants`. An error names the
    /// component (0-based) and the position in it.
    pub fn parse(
        texts: &[String],
        constants: &[(String, f64)],
    ) -> Result<Self, (usize, ExpressionError)> {
        let components = texts
            .iter()
            .enumerate()
            .map(|(i, text)| Formula::parse(text, constants).map_err(|e| (i, e)))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self { components })
    }

    /// The formulas.
    pub fn components(&self) -> &[Formula] {
        &self.components
    }

    /// The first `(component, t)` on `points` uniform times of `[t0, t1]` (ends included)
    /// where a component or one of its first three derivatives is not finite (a formula
    /// outside its domain there, e.g. `log(t - 5)` at `t = 0`), if any.
    pub fn check_finite(&self, t0: f64, t1: f64, points: usize) -> Option<(usize, f64)> {
        let points = points.max(2);
        for k in 0..points {
            let t = if k + 1 == points {
                t1
            } else {
                t0 + (t1 - t0) * k as f64 / (points - 1) as f64
            };
            for (i, f) in self.components.iter().enumerate() {
                if f.derivatives(t).iter().any(|v| !v.is_finite()) {
                    return Some((i, t));
                }
            }
        }
        None
    }
}

impl Path for Expression {
    fn dim(&self) -> usize {
        self.components.len()
    }

    fn value_into(&self, t: f64, out: &mut [f64]) {
        assert_eq!(
            out.len(),
            self.dim(),
            "Path::value_into: `out` has {} entries, but this path needs {}",
            out.len(),
            self.dim()
        );
        for (o, f) in out.iter_mut().zip(&self.components) {
            *o = f.value(t);
        }
    }

    fn jet_into(&self, t: f64, out: &mut [f64]) {
        let n = self.dim();
        assert_eq!(
            out.len(),
            4 * n,
            "Path::jet_into: `out` has {} entries, but this path needs {}",
            out.len(),
            4 * n
        );
        for (i, f) in self.components.iter().enumerate() {
            let d = f.derivatives(t);
            for (k, v) in d.iter().enumerate() {
                out[k * n + i] = *v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(text: &str, t: f64) -> [f64; 4] {
        Formula::parse(text, &[]).unwrap().derivatives(t)
    }

    fn close(a: [f64; 4], b: [f64; 4], tol: f64) -> bool {
        a.iter()
            .zip(&b)
            .all(|(x, y)| (x - y).abs() <= tol * (1.0 + y.abs()))
    }

    #[test]
    fn derivatives_match_closed_forms() {
        let t = 0.7_f64;
        let (s, c) = t.sin_cos();
        let cases: Vec<(&str, [f64; 4])> = vec![
            ("3", [3.0, 0.0, 0.0, 0.0]),
            ("t", [t, 1.0, 0.0, 0.0]),
            ("t^3", [t.powi(3), 3.0 * t * t, 6.0 * t, 6.0]),
            (
                "2 t^2 - t + 1",
                [2.0 * t * t - t + 1.0, 4.0 * t - 1.0, 4.0, 0.0],
            ),
            ("sin(t)", [s, c, -s, -c]),
            ("cos(2 t)", {
                let (s2, c2) = (2.0 * t).sin_cos();
                [c2, -2.0 * s2, -4.0 * c2, 8.0 * s2]
            }),
            ("exp(-t)", {
                let e = (-t).exp();
                [e, -e, e, -e]
            }),
            ("log(t)", [t.ln(), 1.0 / t, -1.0 / (t * t), 2.0 / t.powi(3)]),
            ("sqrt(t)", {
                let r = t.sqrt();
                [r, 0.5 / r, -0.25 / (r * t), 0.375 / (r * t * t)]
            }),
            (
                "1/t",
                [1.0 / t, -1.0 / (t * t), 2.0 / t.powi(3), -6.0 / t.powi(4)],
            ),
            ("t^0.5", {
                let r = t.sqrt();
                [r, 0.5 / r, -0.25 / (r * t), 0.375 / (r * t * t)]
            }),
            ("tan(t)", {
                let tn = t.tan();
                let sec2 = 1.0 + tn * tn;
                [
                    tn,
                    sec2,
                    2.0 * tn * sec2,
                    2.0 * sec2 * (sec2 + 2.0 * tn * tn),
                ]
            }),
            ("tanh(t)", {
                let y = t.tanh();
                let u = 1.0 - y * y;
                [y, u, -2.0 * y * u, -2.0 * u * (u - 2.0 * y * y)]
            }),
            ("atan(t)", {
                let q = 1.0 + t * t;
                [
                    t.atan(),
                    1.0 / q,
                    -2.0 * t / (q * q),
                    (6.0 * t * t - 2.0) / q.powi(3),
                ]
            }),
            ("asin(t)", {
                let q = 1.0 - t * t;
                [
                    t.asin(),
                    q.powf(-0.5),
                    t * q.powf(-1.5),
                    (1.0 + 2.0 * t * t) * q.powf(-2.5),
                ]
            }),
            ("sinh(t) + cosh(t)", {
                let e = t.exp();
                [e, e, e, e]
            }),
            ("t^t", {
                // y = e^{t ln t}: y' = y (ln t + 1), y'' = y ((ln t + 1)^2 + 1/t),
                // y''' = y ((ln t + 1)^3 + 3 (ln t + 1)/t - 1/t^2).
                let y = t.powf(t);
                let l = t.ln() + 1.0;
                [
                    y,
                    y * l,
                    y * (l * l + 1.0 / t),
                    y * (l.powi(3) + 3.0 * l / t - 1.0 / (t * t)),
                ]
            }),
        ];
        for (text, want) in cases {
            let got = d(text, t);
            assert!(close(got, want, 1e-13), "{text}: {got:?} vs {want:?}");
        }
    }

    #[test]
    fn derivatives_agree_with_finite_differences_on_a_composition() {
        let f = Formula::parse(
            "3 cos(0.5 t) exp(-0.1 t^2) / (1 + sin(t)^2) + atan(t - 1)",
            &[],
        )
        .unwrap();
        for &t in &[-2.0, 0.0, 0.3, 1.0, 4.5] {
            let d = f.derivatives(t);
            // Central differences of the derivative below (h = 1e-4: error ~1e-8).
            let h = 1e-4;
            for k in 0..3 {
                let fd = (f.derivatives(t + h)[k] - f.derivatives(t - h)[k]) / (2.0 * h);
                assert!(
                    (fd - d[k + 1]).abs() < 1e-6 * (1.0 + d[k + 1].abs()),
                    "t = {t}, derivative {}: {} vs fd {fd}",
                    k + 1,
                    d[k + 1]
                );
            }
        }
    }

    #[test]
    fn precedence_signs_powers_and_juxtaposition() {
        let v = |s: &str| d(s, 2.0)[0];
        assert_eq!(v("-t^2"), -4.0);
        assert_eq!(v("2^3^2"), 512.0); // right-associative
        assert_eq!(v("2 t"), 4.0);
        assert_eq!(v("2*t**2"), 8.0);
        assert_eq!(v("(1 + t)(2 - t)"), 0.0);
        assert_eq!(v("1 - t - t"), -3.0);
        assert_eq!(v("8 / 2 / 2"), 2.0);
        assert_eq!(v("2^-1"), 0.5);
        assert_eq!(v("t^-2"), 0.25);
        assert_eq!(v("1.5e1 + .5"), 15.5);
        assert!((v("pi") - std::f64::consts::PI).abs() < 1e-16);
        // Negative bases with integer powers are defined.
        assert_eq!(d("t^3", -2.0), [-8.0, 12.0, -12.0, 6.0]);
        assert!(d("t^0.5", -1.0)[0].is_nan());
    }

    #[test]
    fn constants_are_names() {
        let c = vec![("w".to_string(), 0.5), ("amp".to_string(), 3.0)];
        let f = Formula::parse("amp cos(w t)", &c).unwrap();
        let dd = f.derivatives(1.0);
        assert!((dd[0] - 3.0 * 0.5_f64.cos()).abs() < 1e-15);
        assert!((dd[1] + 1.5 * 0.5_f64.sin()).abs() < 1e-15);
    }

    #[test]
    fn errors_name_the_position_and_what_was_expected() {
        let err = |s: &str| Formula::parse(s, &[]).unwrap_err().to_string();
        assert!(err("").contains("empty"), "{}", err(""));
        assert!(err("sin t").contains("expected `(` after the function `sin`"));
        assert!(err("2 +").contains("at character 4"), "{}", err("2 +"));
        assert!(err("(1 + t").contains("expected `)`"), "{}", err("(1 + t"));
        assert!(
            err("1 + x").contains("unknown name `x`"),
            "{}",
            err("1 + x")
        );
        assert!(err("1 + x").contains("at character 5"), "{}", err("1 + x"));
        assert!(err("t $ 2").contains("unexpected `$`"));
        assert!(err("1e999").contains("not a finite number"));
        assert!(err("t)").contains("found `)`"), "{}", err("t)"));
        assert!(err("sin()").contains("found `)`"), "{}", err("sin()"));
    }

    #[test]
    fn hostile_inputs_are_refused_not_crashed_on() {
        let deep = format!("{}t{}", "(".repeat(10_000), ")".repeat(10_000));
        assert!(matches!(
            Formula::parse(&deep[..1990], &[]),
            Err(ExpressionError::TooLarge(_))
        ));
        let long = "t+".repeat(1500) + "t";
        assert!(matches!(
            Formula::parse(&long, &[]),
            Err(ExpressionError::TooLarge(_))
        ));
        let signs = "-".repeat(1000) + "t";
        assert!(matches!(
            Formula::parse(&signs, &[]),
            Err(ExpressionError::TooLarge(_))
        ));
        let powers = "t^".repeat(500) + "t";
        assert!(matches!(
            Formula::parse(&powers, &[]),
            Err(ExpressionError::TooLarge(_))
        ));
        // Within the limits: fine.
        let ok = format!("{}t{}", "(".repeat(60), ")".repeat(60));
        assert_eq!(Formula::parse(&ok, &[]).unwrap().derivatives(1.5)[0], 1.5);
    }

    #[test]
    fn the_path_gives_the_jet_and_finds_where_it_is_undefined() {
        let e = Expression::parse(
            &[
                "3 cos(t)".to_string(),
                "3 sin(t)".to_string(),
                "log(t - 1)".to_string(),
            ],
            &[],
        )
        .unwrap();
        assert_eq!(e.dim(), 3);
        let mut out = [0.0; 12];
        e.jet_into(2.0, &mut out);
        assert!((out[0] - 3.0 * 2.0_f64.cos()).abs() < 1e-15);
        assert!((out[3] + 3.0 * 2.0_f64.sin()).abs() < 1e-15); // Ω̇_1
        assert!((out[5] - 1.0).abs() < 1e-15); // d/dt log(t - 1) at 2
        assert!((out[11] - 2.0).abs() < 1e-15); // third derivative: 2/(t-1)^3
        let (component, t) = e.check_finite(0.0, 5.0, 11).unwrap();
        assert_eq!((component, t), (2, 0.0));
        assert_eq!(e.check_finite(1.5, 5.0, 11), None);
        let (i, err) = Expression::parse(&["t".into(), "t +".into()], &[]).unwrap_err();
        assert_eq!(i, 1);
        assert!(err.to_string().contains("at character"));
    }
}
