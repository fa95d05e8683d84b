//! Shared helpers for the model tests: a seeded RNG, random admissible points, a smooth
//! synthetic desired path with exact derivatives, and Richardson-extrapolated differences.
#![allow(dead_code)]

/// SplitMix64: a tiny deterministic generator (no dependency, same numbers everywhere).
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
    }
    pub fn sign(&mut self) -> f64 {
        if self.next_u64() & 1 == 0 {
            1.0
        } else {
            -1.0
        }
    }
}

/// Constants [I1, I2, I3, alpha, beta, gamma, eta, delta].
pub fn random_params(rng: &mut Rng) -> [f64; 8] {
    let mut p = [0.0; 8];
    for (i, v) in p.iter_mut().enumerate() {
        *v = if i < 3 {
            rng.uniform(0.5, 3.0)
        } else {
            rng.uniform(0.1, 2.0)
        };
    }
    p
}

/// A state [Omega, xi, xi_dot, kappa] with xi away from zero; if `admissible`, <Omega, xi> = 0.
pub fn random_state(rng: &mut Rng, admissible: bool) -> [f64; 12] {
    let mut y = [0.0; 12];
    for (i, v) in y.iter_mut().enumerate() {
        *v = if (3..6).contains(&i) {
            rng.sign() * rng.uniform(0.4, 1.6)
        } else {
            rng.uniform(-2.0, 2.0)
        };
    }
    if admissible {
        let om = [y[0], y[1], y[2]];
        let n2 = om.iter().map(|v| v * v).sum::<f64>();
        let c = (0..3).map(|i| om[i] * y[3 + i]).sum::<f64>() / n2;
        for i in 0..3 {
            y[3 + i] -= c * om[i];
        }
    }
    y
}

/// A smooth desired path with exact derivatives, Omega_d(t) and Omega_d'(t), as `w`.
pub struct Path {
    pub a: [f64; 3],
    pub b: [f64; 3],
    pub c: [f64; 3],
}

impl Path {
    pub fn random(rng: &mut Rng) -> Self {
        let mut r = || {
            [
                rng.uniform(-2.0, 2.0),
                rng.uniform(-2.0, 2.0),
                rng.uniform(-2.0, 2.0),
            ]
        };
        Path {
            a: r(),
            b: r(),
            c: r(),
        }
    }
    /// Omega_d_i = a_i + b_i sin(t) + c_i t^2 / 10.
    pub fn w(&self, t: f64) -> [f64; 6] {
        let mut w = [0.0; 6];
        for i in 0..3 {
            w[i] = self.a[i] + self.b[i] * t.sin() + self.c[i] * t * t / 10.0;
            w[3 + i] = self.b[i] * t.cos() + self.c[i] * t / 5.0;
        }
        w
    }
}

/// d/dx of a vector function by central differences with one Richardson step (error O(h^4)).
pub fn derivative<const N: usize>(mut f: impl FnMut(f64) -> [f64; N], x: f64, h: f64) -> [f64; N] {
    let d = |f: &mut dyn FnMut(f64) -> [f64; N], h: f64| {
        let (p, m) = (f(x + h), f(x - h));
        let mut out = [0.0; N];
        for i in 0..N {
            out[i] = (p[i] - m[i]) / (2.0 * h);
        }
        out
    };
    let d1 = d(&mut f, h);
    let d2 = d(&mut f, h / 2.0);
    let mut out = [0.0; N];
    for i in 0..N {
        out[i] = (4.0 * d2[i] - d1[i]) / 3.0;
    }
    out
}

/// |a - b| <= tol * scale, with the scale a row or problem magnitude chosen by the caller.
pub fn close(a: f64, b: f64, tol: f64, scale: f64) -> bool {
    (a - b).abs() <= tol * scale.max(1.0)
}

/// "N entries disagree:" and the first 40 of them, one a line (assertion messages).
pub fn failure_report(failures: &[String]) -> String {
    let shown: Vec<&str> = failures.iter().take(40).map(String::as_str).collect();
    format!("{} entries disagree:\n{}", failures.len(), shown.join("\n"))
}
