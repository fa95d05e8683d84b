//! The robustness corpus of issue #12: a seeded generator of random *valid* so(3) problem
//! files (TOML text in the format of `suslov solve`, plus a samples CSV where the desired path
//! is sampled), the fixed hard files under `tests/corpus/hard/`, one solve as the CLI does it
//! ([`suslov::app::run_solve`]) with its classification, and an **independent** check of a
//! written `trajectory.csv` that uses no `suslov` code (only the problem file, read with the
//! `toml` crate, and the CSV, read by its header's column names).
//!
//! Shared by `tests/corpus_slice.rs` (a few problems in `cargo test`) and `benches/corpus.rs`
//! (the full run, `cargo bench --bench corpus`) through `#[path]`; each uses part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::time::Instant;

/// The corpus seed (fixed: the corpus is the same on every run unless `CORPUS_SEED` says
/// otherwise).
pub const SEED: u64 = 20_261_212;

/// Default number of generated problems of the full corpus.
pub const DEFAULT_N: usize = 200;

/// Label of the fixed files under `tests/corpus/hard/`.
pub const HARD: &str = "hard";

// ---------------------------------------------------------------------------------------
// Random numbers

/// xorshift64* seeded through splitmix64 (so nearby seeds give unrelated streams).
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        Self(z.max(1))
    }
    /// Uniform in [0, 1).
    pub fn next(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
    pub fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.uniform(lo.ln(), hi.ln()).exp()
    }
    pub fn coin(&mut self, p: f64) -> bool {
        self.next() < p
    }
    /// A uniformly random unit vector.
    pub fn unit(&mut self) -> [f64; 3] {
        loop {
            let v = [
                self.uniform(-1.0, 1.0),
                self.uniform(-1.0, 1.0),
                self.uniform(-1.0, 1.0),
            ];
            let n = norm(&v);
            if n > 0.1 && n <= 1.0 {
                return scale(&v, 1.0 / n);
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Small vector helpers (no suslov code: the check below must stay independent)

pub fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub fn norm(a: &[f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
pub fn scale(a: &[f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}
pub fn sub(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub fn cross(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
/// `I v` for principal moments `i`.
pub fn apply(i: &[f64; 3], v: &[f64; 3]) -> [f64; 3] {
    [i[0] * v[0], i[1] * v[1], i[2] * v[2]]
}
/// Twice the kinetic energy, `Ω · I Ω`.
pub fn energy2(i: &[f64; 3], v: &[f64; 3]) -> f64 {
    dot(v, &apply(i, v))
}
/// The radial projection of `v` onto the ellipsoid `Ω · I Ω = level`.
pub fn project(i: &[f64; 3], level: f64, v: &[f64; 3]) -> [f64; 3] {
    scale(v, (level / energy2(i, v)).sqrt())
}

// ---------------------------------------------------------------------------------------
// The generator

/// One problem of the corpus.
#[derive(Debug, Clone)]
pub struct CorpusProblem {
    /// Stable id: the category and the problem's index (`issue12-007`), or the hard file's stem.
    pub id: String,
    /// Category label (see [`CATEGORIES`]; [`HARD`] for the fixed files).
    pub category: String,
    /// The problem file's text.
    pub toml: String,
    /// A samples CSV to write next to the problem file: (file name, text).
    pub samples: Option<(String, String)>,
    /// Whether the terminal time is fixed.
    pub fixed_time: bool,
}

/// The categories of the generated corpus, and how many of every 20 problems each gets.
///
/// - `issue12`: exactly issue #12's ranges (moments in [0.5, 5], |Ω_a| in [0.5, 8], Ω_b a
///   random point of the same ellipsoid not near-antipodal, α in [0.1, 10] and β in
///   [1e-3, 10] log-uniform, γ = 0 (30 %) or in [0.01, 100], η = 0 (30 %) or in [1e-3, 10], δ in
///   [0.01, 2] when free, a `segment` path over [0, T], T in [1, 20], fixed/free half each);
/// - `spiral`: a `paper-spiral` path (c in [2, 15], width in [0.01, 0.5], b_d = t0 + T, t0 = 0
///   or in [0, 3]), Ω_a on the spiral's starting ray, γ in [0.01, 100];
/// - `samples`: a sampled path (a CSV of 15–80 rows: Ω_a plus random sines) from Ω_a;
/// - `near-symmetric`: two principal moments within a relative 1e-3 … 1e-2;
/// - `long`: T in [20, 100]; `short`: T in [0.2, 1]; `fast`: |Ω_a| in [8, 50].
///
/// All but the named differences are drawn as in `issue12`.
pub const CATEGORIES: [(&str, usize); 7] = [
    ("issue12", 8),
    ("spiral", 2),
    ("samples", 2),
    ("near-symmetric", 2),
    ("long", 2),
    ("short", 2),
    ("fast", 2),
];

/// Category of problem `index`: the pattern of [`CATEGORIES`] repeated every 20 problems, so
/// the first `n` problems are the same whatever `n` is.
pub fn category_of(index: usize) -> &'static str {
    let period: usize = CATEGORIES.iter().map(|c| c.1).sum();
    let mut k = index % period;
    for (name, count) in CATEGORIES {
        if k < count {
            return name;
        }
        k -= count;
    }
    unreachable!()
}

/// Weights and boundary data drawn with issue #12's ranges.
struct Draw {
    inertia: [f64; 3],
    omega_size: f64,
    alpha: f64,
    beta: f64,
    gamma: f64,
    eta: f64,
    delta: f64,
    span: f64,
    free: bool,
}

fn draw(rng: &mut Rng) -> Draw {
    let free = rng.coin(0.5);
    Draw {
        inertia: [
            rng.uniform(0.5, 5.0),
            rng.uniform(0.5, 5.0),
            rng.uniform(0.5, 5.0),
        ],
        omega_size: rng.uniform(0.5, 8.0),
        alpha: rng.log_uniform(0.1, 10.0),
        beta: rng.log_uniform(1e-3, 10.0),
        gamma: if rng.coin(0.3) {
            0.0
        } else {
            rng.log_uniform(0.01, 100.0)
        },
        eta: if rng.coin(0.3) {
            0.0
        } else {
            rng.log_uniform(1e-3, 10.0)
        },
        delta: if free { rng.uniform(0.01, 2.0) } else { 0.0 },
        span: rng.uniform(1.0, 20.0),
        free,
    }
}

/// A point of `Ω_a`'s energy ellipsoid in a random direction at most ~143° from `Ω_a`
/// (not near-antipodal, so the segment between them stays away from the origin).
fn omega_b_for(rng: &mut Rng, inertia: &[f64; 3], omega_a: &[f64; 3]) -> [f64; 3] {
    let level = energy2(inertia, omega_a);
    loop {
        let u = rng.unit();
        if dot(&u, omega_a) / norm(omega_a) > -0.8 {
            return project(inertia, level, &u);
        }
    }
}

fn f(x: f64) -> String {
    // Debug of f64 is the shortest text that reads back to the same number, and valid TOML.
    format!("{x:?}")
}
fn v3(v: &[f64; 3]) -> String {
    format!("[{}, {}, {}]", f(v[0]), f(v[1]), f(v[2]))
}

fn terminal_line(free: bool, b: f64) -> String {
    if free {
        format!("terminal_time = {{ free = true, guess = {} }}", f(b))
    } else {
        format!("terminal_time = {{ fixed = {} }}", f(b))
    }
}

fn cost_section(d: &Draw) -> String {
    let mut s = format!(
        "[cost]\nalpha = {}\nbeta = {}\ngamma = {}\neta = {}\n",
        f(d.alpha),
        f(d.beta),
        f(d.gamma),
        f(d.eta)
    );
    if d.free {
        s += &format!("delta = {}\n", f(d.delta));
    }
    s
}

/// Problem `index` of the corpus with seed `seed` (independent of how many are generated).
pub fn problem(seed: u64, index: usize) -> CorpusProblem {
    let category = category_of(index);
    let mut rng = Rng::new(seed ^ (index as u64).wrapping_mul(0xD1B5_4A32_D192_ED03));
    let mut d = draw(&mut rng);
    let id = format!("{category}-{index:03}");
    match category {
        "near-symmetric" => {
            // Two moments within a relative 1e-3 … 1e-2 of each other (either sign), the pair
            // chosen at random.
            let r = rng.log_uniform(1e-3, 1e-2) * if rng.coin(0.5) { 1.0 } else { -1.0 };
            let k = (rng.next() * 3.0) as usize % 3;
            let (p, q) = (k, (k + 1) % 3);
            d.inertia[q] = d.inertia[p] * (1.0 + r);
        }
        "long" => {
            d.span = if rng.coin(0.5) {
                rng.uniform(20.0, 50.0)
            } else {
                rng.uniform(50.0, 100.0)
            }
        }
        "short" => d.span = rng.log_uniform(0.2, 1.0),
        "fast" => d.omega_size = rng.log_uniform(8.0, 50.0),
        _ => {}
    }
    let header = format!(
        "# suslov robustness corpus (tests/corpus/mod.rs), seed {seed:#x}, problem {index}\n\
         name = \"{id}\"\n\n[body]\ninertia = {}\n\n",
        v3(&d.inertia)
    );
    match category {
        "spiral" => spiral(&mut rng, id, category, d, header),
        "samples" => samples(&mut rng, id, category, d, header),
        _ => segment(&mut rng, id, category, d, header),
    }
}

/// The issue's `segment` problem: `Ω_a` random, `Ω_b` on its ellipsoid, the projected
/// segment over `[0, T]`.
fn segment(rng: &mut Rng, id: String, category: &str, d: Draw, header: String) -> CorpusProblem {
    let omega_a = scale(&rng.unit(), d.omega_size);
    let omega_b = omega_b_for(rng, &d.inertia, &omega_a);
    let toml = format!(
        "{header}[boundary]\nomega_a = {}\nomega_b = {}\n{}\n\n{}\n[desired]\nkind = \"segment\"\n\
         interval = [0.0, {}]\n",
        v3(&omega_a),
        v3(&omega_b),
        terminal_line(d.free, d.span),
        cost_section(&d),
        f(d.span)
    );
    CorpusProblem {
        id,
        category: category.into(),
        toml,
        samples: None,
        fixed_time: !d.free,
    }
}

/// The paper's spiral with random parameters. `Ω_d(t0)` is the projection of
/// `φ(t0) = [c, t0 cos t0, t0 sin t0]`, so `Ω_a` is put on that ray (γ > 0 needs
/// `Ω_d(t0) = Ω_a`); `Ω_b` is the spiral's end (`"desired_end"`).
fn spiral(rng: &mut Rng, id: String, category: &str, mut d: Draw, header: String) -> CorpusProblem {
    let c = rng.uniform(2.0, 15.0);
    let width = rng.log_uniform(0.01, 0.5);
    let t0 = if rng.coin(0.5) {
        0.0
    } else {
        rng.uniform(0.0, 3.0)
    };
    let phi0 = [c, t0 * t0.cos(), t0 * t0.sin()];
    let omega_a = scale(&phi0, d.omega_size / norm(&phi0));
    let b_d = t0 + d.span;
    // Fixed time: b around the switching time b_d (before or after it).
    let b = t0 + d.span * rng.uniform(0.9, 1.1);
    if d.gamma == 0.0 {
        d.gamma = rng.log_uniform(0.01, 100.0);
    }
    let terminal = if d.free {
        "terminal_time = { free = true }".to_string()
    } else {
        terminal_line(false, b)
    };
    let toml = format!(
        "{header}[boundary]\nt0 = {}\nomega_a = {}\nomega_b = \"desired_end\"\n{terminal}\n\n{}\n\
         [desired]\nkind = \"paper-spiral\"\nc = {}\nwidth = {}\nb_d = {}\n",
        f(t0),
        v3(&omega_a),
        cost_section(&d),
        f(c),
        f(width),
        f(b_d)
    );
    CorpusProblem {
        id,
        category: category.into(),
        toml,
        samples: None,
        fixed_time: !d.free,
    }
}

/// A sampled desired path: rows `t_k = k T / m` of `Ω_a + Σ_j a_j sin(w_j t)` (so the
/// first row is `Ω_a` itself, as γ > 0 needs), `m` in [15, 80]; `Ω_b` is the projected last
/// row (`"desired_end"`).
fn samples(rng: &mut Rng, id: String, category: &str, d: Draw, header: String) -> CorpusProblem {
    let omega_a = scale(&rng.unit(), d.omega_size);
    let m = 15 + (rng.next() * 66.0) as usize;
    let terms: Vec<([f64; 3], f64)> = (0..3)
        .map(|_| {
            (
                scale(&rng.unit(), d.omega_size * rng.uniform(0.1, 0.6)),
                rng.uniform(0.1, 2.0) * 2.0 * std::f64::consts::PI / d.span.max(1.0),
            )
        })
        .collect();
    let value = |t: f64| {
        let mut v = omega_a;
        for (a, w) in &terms {
            for k in 0..3 {
                v[k] += a[k] * (w * t).sin();
            }
        }
        v
    };
    let mut csv = String::from("t,omega1,omega2,omega3\n");
    for k in 0..=m {
        let t = d.span * k as f64 / m as f64;
        let mut v = value(t);
        // The projection needs a ray: keep every row away from the origin.
        if norm(&v) < 0.2 * d.omega_size {
            let half = scale(&omega_a, 0.5);
            v = [half[0] + v[0], half[1] + v[1], half[2] + v[2]];
        }
        csv += &format!("{},{},{},{}\n", f(t), f(v[0]), f(v[1]), f(v[2]));
    }
    let file = format!("{id}.csv");
    let b = d.span * rng.uniform(0.8, 1.0);
    let terminal = if d.free {
        "terminal_time = { free = true }".to_string()
    } else {
        terminal_line(false, b)
    };
    let toml = format!(
        "{header}[boundary]\nomega_a = {}\nomega_b = \"desired_end\"\n{terminal}\n\n{}\n\
         [desired]\nkind = \"samples\"\nfile = \"{file}\"\n",
        v3(&omega_a),
        cost_section(&d),
    );
    CorpusProblem {
        id,
        category: category.into(),
        toml,
        samples: Some((file, csv)),
        fixed_time: !d.free,
    }
}

/// The first `n` problems of the corpus with seed `seed`.
pub fn generate(n: usize, seed: u64) -> Vec<CorpusProblem> {
    (0..n).map(|i| problem(seed, i)).collect()
}

/// The directory of the fixed hard files.
pub fn hard_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/hard")
}

/// The fixed files under `tests/corpus/hard/` (issue #12's three failing files and the hard
/// cases on the paper's data), sorted by name.
pub fn hard_problems() -> Vec<CorpusProblem> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(hard_dir())
        .expect("tests/corpus/hard exists")
        .map(|e| e.expect("readable directory").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    paths
        .into_iter()
        .map(|p| {
            let toml = std::fs::read_to_string(&p).expect("readable hard file");
            let fixed_time = toml::from_str::<toml::Table>(&toml)
                .ok()
                .and_then(|t| {
                    t.get("boundary")?
                        .get("terminal_time")?
                        .as_table()
                        .map(|tt| tt.contains_key("fixed"))
                })
                .unwrap_or(false);
            // A samples file named by the problem travels with it (next to the hard file).
            let samples = toml::from_str::<toml::Table>(&toml)
                .ok()
                .and_then(|t| Some(t.get("desired")?.get("file")?.as_str()?.to_string()))
                .map(|file| {
                    let csv = std::fs::read_to_string(hard_dir().join(&file))
                        .expect("the hard file's samples file");
                    (file, csv)
                });
            CorpusProblem {
                id: p.file_stem().unwrap().to_string_lossy().into_owned(),
                category: HARD.into(),
                toml,
                samples,
                fixed_time,
            }
        })
        .collect()
}

/// Write `p` into `dir` (the problem file `problem.toml` and its samples file); returns the
/// problem file's path.
pub fn write_problem(p: &CorpusProblem, dir: &Path) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(dir)?;
    if let Some((name, text)) = &p.samples {
        std::fs::write(dir.join(name), text)?;
    }
    let path = dir.join("problem.toml");
    std::fs::write(&path, &p.toml)?;
    Ok(path)
}

// ---------------------------------------------------------------------------------------
// What the problem file says the trajectory must satisfy (read with `toml`, not suslov)

/// The data the independent check needs, read from the problem file.
#[derive(Debug, Clone)]
pub struct Expected {
    pub inertia: [f64; 3],
    pub t0: f64,
    pub omega_a: [f64; 3],
    pub omega_b: [f64; 3],
    /// The terminal time when fixed.
    pub fixed_b: Option<f64>,
}

fn num(v: &toml::Value) -> Option<f64> {
    v.as_float().or_else(|| v.as_integer().map(|i| i as f64))
}
fn vec3(v: Option<&toml::Value>) -> Option<[f64; 3]> {
    let a = v?.as_array()?;
    if a.len() != 3 {
        return None;
    }
    Some([num(&a[0])?, num(&a[1])?, num(&a[2])?])
}

/// Read [`Expected`] from a problem file's text (`dir`: where its samples file is). `Ω_b` is
/// the file's vector, or for `"desired_end"` the path's end point computed here: the radial
/// projection onto `Ω_a`'s ellipsoid of `φ(b_d) = [c, b_d cos b_d, b_d sin b_d]`
/// (paper-spiral), of `desired.to` (segment) or of the last sample (samples).
pub fn expected(toml_text: &str, dir: &Path) -> Result<Expected, String> {
    let t: toml::Table = toml::from_str(toml_text).map_err(|e| e.to_string())?;
    let get = |k: &str| t.get(k).and_then(|v| v.as_table());
    let body = get("body").ok_or("no [body]")?;
    let boundary = get("boundary").ok_or("no [boundary]")?;
    let desired = get("desired").ok_or("no [desired]")?;
    let inertia = vec3(body.get("inertia")).ok_or("no body.inertia")?;
    let t0 = boundary.get("t0").and_then(num).unwrap_or(0.0);
    let omega_a = vec3(boundary.get("omega_a")).ok_or("no boundary.omega_a")?;
    let level = energy2(&inertia, &omega_a);
    let omega_b = match boundary.get("omega_b") {
        Some(toml::Value::String(s)) if s == "desired_end" => {
            let kind = desired.get("kind").and_then(|k| k.as_str()).unwrap_or("");
            let end = match kind {
                "paper-spiral" => {
                    let c = desired.get("c").and_then(num).unwrap_or(10.0);
                    let b_d = desired.get("b_d").and_then(num).unwrap_or(10.0);
                    [c, b_d * b_d.cos(), b_d * b_d.sin()]
                }
                "segment" => vec3(desired.get("to")).ok_or("desired_end needs desired.to")?,
                "constant" => vec3(desired.get("value")).ok_or("no desired.value")?,
                "samples" => {
                    let file = desired
                        .get("file")
                        .and_then(|f| f.as_str())
                        .ok_or("no file")?;
                    let text =
                        std::fs::read_to_string(dir.join(file)).map_err(|e| e.to_string())?;
                    let last = text
                        .lines()
                        .rev()
                        .find(|l| !l.trim().is_empty() && !l.starts_with('#'))
                        .ok_or("empty samples")?;
                    let x: Vec<f64> = last
                        .split(',')
                        .map(|s| s.trim().parse::<f64>())
                        .collect::<Result<_, _>>()
                        .map_err(|e| e.to_string())?;
                    [x[1], x[2], x[3]]
                }
                other => return Err(format!("unknown desired kind {other}")),
            };
            project(&inertia, level, &end)
        }
        v => vec3(v).ok_or("no boundary.omega_b")?,
    };
    let fixed_b = boundary
        .get("terminal_time")
        .and_then(|v| v.as_table())
        .and_then(|tt| tt.get("fixed"))
        .and_then(num);
    Ok(Expected {
        inertia,
        t0,
        omega_a,
        omega_b,
        fixed_b,
    })
}

// ---------------------------------------------------------------------------------------
// The independent check of a trajectory CSV

/// Relative tolerance of the boundary values, the constraint and the energy drift.
pub const REL_TOL: f64 = 1e-6;

/// The outcome of [`check_trajectory`].
#[derive(Debug, Clone, Default)]
pub struct TrajectoryCheck {
    /// Every violated condition, with where and how much.
    pub failures: Vec<String>,
    /// Rows of the CSV.
    pub rows: usize,
    /// Rows where Suslov's equation was tested.
    pub equation_rows: usize,
    /// Rows where the output grid does not resolve the motion well enough to test Suslov's
    /// equation by differences (estimated difference error above 1 % of the scale).
    pub unresolved_rows: usize,
    /// Largest relative values seen: constraint, energy drift, Suslov residual / scale.
    pub max_constraint: f64,
    pub max_energy_drift: f64,
    pub max_equation: f64,
}

impl TrajectoryCheck {
    pub fn passed(&self) -> bool {
        self.failures.is_empty()
    }
}

/// Finite-difference weights for the first derivative at `x0` from the nodes `x`
/// (Fornberg's algorithm, first derivative only).
fn fd_weights(x0: f64, x: &[f64]) -> Vec<f64> {
    let n = x.len();
    // c[j][k]: weight of node j for derivative k (k = 0, 1).
    let mut c = vec![[0.0f64; 2]; n];
    let mut c1 = 1.0;
    let mut c4 = x[0] - x0;
    c[0][0] = 1.0;
    for i in 1..n {
        let mut c2 = 1.0;
        let c5 = c4;
        c4 = x[i] - x0;
        for j in 0..i {
            let c3 = x[i] - x[j];
            c2 *= c3;
            if j == i - 1 {
                c[i][1] = c1 * (c[i - 1][0] - c5 * c[i - 1][1]) / c2;
                c[i][0] = -c1 * c5 * c[i - 1][0] / c2;
            }
            c[j][1] = (c4 * c[j][1] - c[j][0]) / c3;
            c[j][0] = c4 * c[j][0] / c3;
        }
        c1 = c2;
    }
    c.into_iter().map(|w| w[1]).collect()
}

/// Check a trajectory CSV (as `suslov solve` writes it) against the problem, with no suslov
/// code: columns are found by the header's names (`t`, `omega1..3`, `xi1..3`).
///
/// 1. `Ω(t0) = Ω_a`, `Ω(b) = Ω_b` (relative [`REL_TOL`]); the first time is `t0`, the last
///    the fixed terminal time (if fixed);
/// 2. `|⟨Ω, ξ⟩| / (|Ω| |ξ|) ≤ REL_TOL` at every row;
/// 3. `|T(t) − T(a)| / T(a) ≤ REL_TOL` at every row (T = ½ Ω·𝕀Ω);
/// 4. Suslov's equation: `v = 𝕀Ω̇ − (𝕀Ω)×Ω` is parallel to ξ (`v = λ ξ`), i.e. its component
///    orthogonal to ξ, `r = |v − (v·ξ̂)ξ̂|`, is small relative to `S = |𝕀Ω̇| + |𝕀Ω||Ω|`.
///
///    Ω̇ comes from differences on the written grid: the 5-point (4th-order) derivative
///    `D4`. The 3-point (2nd-order) one `D2` has the error `h²/6 Ω‴ + O(h⁴)`, so
///    `E = |D2 − D4|` estimates that error; `D4`'s own error is `h⁴/30 Ω⁽⁵⁾`, smaller than
///    `E` by a factor ~`(ωh)²/5` where `ω` is the motion's frequency, i.e. `E` bounds it
///    wherever the grid resolves the motion (`ωh < 1`). The converged solution itself
///    satisfies the equation to ~ the solver's tolerance (1e-8), far below `E` on the written
///    grid, so the test is `r ≤ REL_TOL · S + 2 ‖𝕀‖ max(E over the row and its neighbours)`
///    (factor 2 and the neighbours: margin for the rows where Ω‴ changes sign and `E`
///    under-estimates). Where that bound exceeds 1 % of `S` the grid does not resolve the
///    motion and the row is counted as unresolved instead of tested (a 1 %-wide test would
///    say nothing). A ξ turned about Ω by θ makes `r ≈ |λ| sin θ`, which this catches
///    wherever `|λ| sin θ` is above the difference error.
pub fn check_trajectory(csv: &str, e: &Expected) -> TrajectoryCheck {
    let mut out = TrajectoryCheck::default();
    let mut lines = csv.lines().filter(|l| !l.trim().is_empty());
    let Some(header) = lines.next() else {
        out.failures.push("empty CSV".into());
        return out;
    };
    let names: Vec<&str> = header.split(',').map(|s| s.trim()).collect();
    let col = |n: &str| names.iter().position(|c| *c == n);
    let want = ["t", "omega1", "omega2", "omega3", "xi1", "xi2", "xi3"];
    let mut idx = [0usize; 7];
    for (k, n) in want.iter().enumerate() {
        match col(n) {
            Some(i) => idx[k] = i,
            None => {
                out.failures.push(format!("no column '{n}' in the header"));
                return out;
            }
        }
    }
    let mut t = vec![];
    let mut om = vec![];
    let mut xi = vec![];
    for (r, line) in lines.enumerate() {
        let x: Result<Vec<f64>, _> = line.split(',').map(|s| s.trim().parse::<f64>()).collect();
        let x = match x {
            Ok(x) if x.len() == names.len() && x.iter().all(|v| v.is_finite()) => x,
            _ => {
                out.failures
                    .push(format!("row {r}: not {} finite numbers", names.len()));
                return out;
            }
        };
        t.push(x[idx[0]]);
        om.push([x[idx[1]], x[idx[2]], x[idx[3]]]);
        xi.push([x[idx[4]], x[idx[5]], x[idx[6]]]);
    }
    let n = t.len();
    out.rows = n;
    if n < 5 {
        out.failures.push(format!("only {n} rows"));
        return out;
    }
    if t.windows(2).any(|w| w[1] <= w[0]) {
        out.failures.push("times not strictly increasing".into());
    }
    let span = t[n - 1] - t[0];
    if (t[0] - e.t0).abs() > 1e-9 * span.max(e.t0.abs()) {
        out.failures
            .push(format!("first time {} is not t0 = {}", t[0], e.t0));
    }
    if let Some(b) = e.fixed_b {
        if (t[n - 1] - b).abs() > 1e-9 * b.abs().max(span) {
            out.failures
                .push(format!("last time {} is not the fixed b = {b}", t[n - 1]));
        }
    }
    // 1. Boundary values.
    for (name, got, want) in [
        ("Omega(a)", om[0], e.omega_a),
        ("Omega(b)", om[n - 1], e.omega_b),
    ] {
        let rel = norm(&sub(&got, &want)) / norm(&want);
        if rel.is_nan() || rel > REL_TOL {
            out.failures.push(format!(
                "{name} = {got:?} differs from {want:?} by {rel:.3e} (relative; allowed {REL_TOL:e})"
            ));
        }
    }
    // 2. Constraint and 3. energy, at every row.
    let e0 = energy2(&e.inertia, &om[0]);
    let (mut worst_c, mut row_c, mut worst_e, mut row_e) = (0.0f64, 0, 0.0f64, 0);
    for r in 0..n {
        let c = dot(&om[r], &xi[r]).abs() / (norm(&om[r]) * norm(&xi[r]));
        let c = if c.is_nan() { f64::INFINITY } else { c };
        if c > worst_c {
            (worst_c, row_c) = (c, r);
        }
        let d = (energy2(&e.inertia, &om[r]) - e0).abs() / e0;
        if d > worst_e {
            (worst_e, row_e) = (d, r);
        }
    }
    out.max_constraint = worst_c;
    out.max_energy_drift = worst_e;
    if worst_c > REL_TOL {
        out.failures.push(format!(
            "|<Omega, xi>| / (|Omega| |xi|) = {worst_c:.3e} at row {row_c} (t = {}; allowed {REL_TOL:e})",
            t[row_c]
        ));
    }
    if worst_e > REL_TOL {
        out.failures.push(format!(
            "kinetic energy drift {worst_e:.3e} at row {row_e} (t = {}; allowed {REL_TOL:e})",
            t[row_e]
        ));
    }
    // 4. Suslov's equation, rows 2 .. n-3 (the 5-point stencil is centred).
    let i_max = e.inertia.iter().cloned().fold(0.0, f64::max);
    let deriv = |r: usize, lo: usize, hi: usize| -> [f64; 3] {
        let w = fd_weights(t[r], &t[lo..=hi]);
        let mut d = [0.0; 3];
        for (k, wk) in w.iter().enumerate() {
            for c in 0..3 {
                d[c] += wk * om[lo + k][c];
            }
        }
        d
    };
    let mut d4 = vec![[0.0; 3]; n];
    let mut err = vec![0.0; n];
    for r in 2..n - 2 {
        d4[r] = deriv(r, r - 2, r + 2);
        err[r] = norm(&sub(&deriv(r, r - 1, r + 1), &d4[r]));
    }
    let (mut worst_q, mut row_q, mut worst_r, mut worst_bound) = (0.0f64, 0, 0.0, 0.0);
    for r in 3..n - 3 {
        let io = apply(&e.inertia, &om[r]);
        let idot = apply(&e.inertia, &d4[r]);
        let v = sub(&idot, &cross(&io, &om[r]));
        let xh = scale(&xi[r], 1.0 / norm(&xi[r]));
        let perp = norm(&sub(&v, &scale(&xh, dot(&v, &xh))));
        let s = norm(&idot) + norm(&io) * norm(&om[r]);
        let diff_err = 2.0 * i_max * err[r - 1].max(err[r]).max(err[r + 1]);
        if diff_err > 1e-2 * s {
            out.unresolved_rows += 1;
            continue;
        }
        out.equation_rows += 1;
        let bound = REL_TOL * s + diff_err;
        let q = perp / bound;
        let q = if q.is_nan() { f64::INFINITY } else { q };
        if q > worst_q {
            (worst_q, row_q, worst_r, worst_bound) = (q, r, perp, bound);
        }
        out.max_equation = out.max_equation.max(perp / s);
    }
    if worst_q > 1.0 {
        out.failures.push(format!(
            "Suslov's equation: the part of I Omega' - (I Omega) x Omega orthogonal to xi is \
             {worst_r:.3e} at row {row_q} (t = {}), above its bound {worst_bound:.3e} \
             (1e-6 of the scale + twice the estimated difference error)",
            t[row_q]
        ));
    }
    out
}

// ---------------------------------------------------------------------------------------
// One solve as the CLI does it, and its classification

/// How one problem ended.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// `converged` in the summary, and the independent check passed.
    Solved,
    /// Stopped with a reason: `key` groups the reasons (the stage name, `start`, or the failed
    /// check of an `unverified` solution), `reason` is the tool's text.
    Explained { key: String, reason: String },
    /// `no minimizer` in the summary (the infimum is approached as ξ → 0), and the written
    /// ε-optimal control `trajectory.infimum.csv` passes the independent check.
    NoMinimizer { reason: String },
    /// An error of `run_solve`, a panic, a timeout, a missing or inconsistent summary.
    Unexplained(String),
    /// `converged` (or `no minimizer`) in the summary, but the independent check of what it
    /// wrote (`trajectory.csv`, or `trajectory.infimum.csv`) failed.
    FalseConverged(Vec<String>),
}

impl Verdict {
    pub fn label(&self) -> &'static str {
        match self {
            Verdict::Solved => "solved",
            Verdict::Explained { .. } => "explained",
            Verdict::NoMinimizer { .. } => "no minimizer",
            Verdict::Unexplained(_) => "unexplained",
            Verdict::FalseConverged(_) => "FALSE-CONVERGED",
        }
    }
}

/// One problem's result.
#[derive(Debug, Clone)]
pub struct Outcome {
    pub verdict: Verdict,
    /// Wall time of `run_solve` (seconds).
    pub seconds: f64,
    /// The independent check of the written trajectory (of a converged case).
    pub check: Option<TrajectoryCheck>,
    /// The homotopy route of the solution (`summary.json`'s `routes`, the last one), if the
    /// summary lists one.
    pub route: Option<String>,
    /// `summary.json`'s `extra.collapse` (`suslov::lie::collapse`): whether a control with a
    /// vanishing xi undercuts the extremal or the stop, and whether it shows that no optimal
    /// terminal time exists; `None` without that record.
    pub collapse: Option<CollapseFlags>,
    /// The independent check of a stop's ε-optimal control `trajectory.infimum.csv`
    /// ([`infimum_check`]), when it wrote one.
    pub infimum: Option<TrajectoryCheck>,
}

/// The independent check ([`check_trajectory`]) of `out/trajectory.infimum.csv` (the ε-optimal
/// control a stop writes when the problem's infimum is approached as ξ → 0), if written.
pub fn infimum_check(
    problem_toml: &str,
    problem_dir: &Path,
    out: &Path,
) -> Option<TrajectoryCheck> {
    if !out.join("trajectory.infimum.csv").exists() {
        return None;
    }
    Some(
        match independent(problem_toml, problem_dir, out, "trajectory.infimum.csv") {
            Ok((check, _)) => check,
            Err(e) => TrajectoryCheck {
                failures: vec![e],
                ..TrajectoryCheck::default()
            },
        },
    )
}

/// The verdicts of `summary.json`'s `extra.collapse`, and the cheapest control's motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CollapseFlags {
    pub undercuts: bool,
    pub no_optimal_time: bool,
    /// The motion of the cheapest control (`projected_segment`, `desired_path`, `solution`,
    /// `direct_minimum`, `relaxed_minimum`).
    pub least_motion: Option<&'static str>,
    /// The relaxed minimum's status (`computed`, `failed`, `falls with the span`).
    pub relaxed: Option<&'static str>,
}

/// `out/summary.json`'s `extra.collapse` flags, if recorded.
pub fn collapse_flags(out: &Path) -> Option<CollapseFlags> {
    let text = std::fs::read_to_string(out.join("summary.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    let c = &v["cases"][0]["extra"]["collapse"];
    let least_motion = match c["least"]["motion"].as_str() {
        Some("projected_segment") => Some("projected_segment"),
        Some("desired_path") => Some("desired_path"),
        Some("solution") => Some("solution"),
        Some("direct_minimum") => Some("direct_minimum"),
        Some("relaxed_minimum") => Some("relaxed_minimum"),
        _ => None,
    };
    let relaxed = match c["relaxed"]["status"].as_str() {
        Some("computed") => Some("computed"),
        Some("failed") => Some("failed"),
        Some("falls_with_span") => Some("falls with the span"),
        _ => None,
    };
    Some(CollapseFlags {
        undercuts: c.get("undercuts")?.as_bool()?,
        no_optimal_time: c.get("no_optimal_time")?.as_bool()?,
        least_motion,
        relaxed,
    })
}

/// The last route in `out/summary.json` (the one that solved a solved case).
pub fn last_route(out: &Path) -> Option<String> {
    let text = std::fs::read_to_string(out.join("summary.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v["cases"][0]["extra"]["routes"]
        .as_array()?
        .last()?
        .get("route")?
        .as_str()
        .map(str::to_string)
}

/// How `run_solve` ended (the panic or error as text).
pub enum RunResult {
    Ok,
    Err(String),
    Panic(String),
}

/// Run `suslov::app::run_solve(problem, out, |_| {})` catching a panic; returns how it ended
/// and its wall time in seconds.
pub fn run_solve_caught(problem: &Path, out: &Path) -> (RunResult, f64) {
    let clock = Instant::now();
    let r = std::panic::catch_unwind(|| suslov::app::run_solve(problem, out, &mut |_| {}));
    let seconds = clock.elapsed().as_secs_f64();
    let r = match r {
        Ok(Ok(_)) => RunResult::Ok,
        Ok(Err(e)) => RunResult::Err(e.to_string()),
        Err(p) => RunResult::Panic(
            p.downcast_ref::<String>()
                .cloned()
                .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_else(|| "(non-text panic)".into()),
        ),
    };
    (r, seconds)
}

/// Classify a finished run from what it wrote into `out` (and the problem file's text, for
/// the independent check).
pub fn classify(
    run: &RunResult,
    problem_toml: &str,
    problem_dir: &Path,
    out: &Path,
) -> (Verdict, Option<TrajectoryCheck>) {
    match run {
        RunResult::Ok => {}
        RunResult::Err(e) => return (Verdict::Unexplained(format!("run_solve error: {e}")), None),
        RunResult::Panic(p) => return (Verdict::Unexplained(format!("panic: {p}")), None),
    }
    let bad = |m: String| (Verdict::Unexplained(format!("summary: {m}")), None);
    let summary: serde_json::Value = match std::fs::read_to_string(out.join("summary.json"))
        .map_err(|e| e.to_string())
        .and_then(|s| serde_json::from_str(&s).map_err(|e| e.to_string()))
    {
        Ok(v) => v,
        Err(e) => return bad(format!("summary.json unreadable: {e}")),
    };
    let Some(cases) = summary.get("cases").and_then(|c| c.as_array()) else {
        return bad("no `cases` array".into());
    };
    if cases.len() != 1 {
        return bad(format!("{} cases, expected 1", cases.len()));
    }
    let case = &cases[0];
    let Some(status) = case.get("status").and_then(|s| s.as_str()) else {
        return bad("no `status`".into());
    };
    let passed = case
        .get("verification")
        .and_then(|v| v.get("passed"))
        .and_then(|p| p.as_bool());
    let exists = |f: &str| out.join(f).is_file();
    if status == "converged" {
        if passed != Some(true) {
            return bad(format!(
                "status converged but verification.passed = {passed:?}"
            ));
        }
        if !exists("trajectory.csv") {
            return bad("status converged but no trajectory.csv".into());
        }
        let (mut check, csv) = match independent(problem_toml, problem_dir, out, "trajectory.csv") {
            Ok(c) => c,
            Err(e) => return bad(e),
        };
        // The summary's terminal time is the trajectory's last time.
        let b = case.get("terminal_time").and_then(|b| b.as_f64());
        let last: Option<f64> = csv
            .lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .and_then(|l| l.split(',').next())
            .and_then(|s| s.trim().parse().ok());
        match (b, last) {
            (Some(b), Some(l)) if (b - l).abs() <= 1e-9 * b.abs().max(1.0) => {}
            _ => check.failures.push(format!(
                "summary terminal_time {b:?} is not the trajectory's last time {last:?}"
            )),
        }
        return if check.passed() {
            (Verdict::Solved, Some(check))
        } else {
            (Verdict::FalseConverged(check.failures.clone()), Some(check))
        };
    }
    if let Some(reason) = status.strip_prefix("no minimizer: ") {
        // The claim rests on the ε-optimal control: it must be written, and admissible by
        // the independent check.
        if !exists("trajectory.infimum.csv") {
            return bad("status no minimizer but no trajectory.infimum.csv".into());
        }
        let (check, _) = match independent(problem_toml, problem_dir, out, "trajectory.infimum.csv")
        {
            Ok(c) => c,
            Err(e) => return bad(e),
        };
        return if check.passed() {
            (
                Verdict::NoMinimizer {
                    reason: reason.into(),
                },
                Some(check),
            )
        } else {
            let mut failures = vec!["no minimizer, but trajectory.infimum.csv fails".to_string()];
            failures.extend(check.failures.iter().cloned());
            (Verdict::FalseConverged(failures), Some(check))
        };
    }
    if let Some(reason) = status.strip_prefix("partial: ") {
        if !exists("trajectory.partial.csv") {
            return bad("status partial but no trajectory.partial.csv".into());
        }
        let key = reason
            .strip_prefix("stage '")
            .and_then(|r| r.split('\'').next())
            .map(|s| s.to_string());
        return match key {
            Some(key) => (
                Verdict::Explained {
                    key,
                    reason: reason.into(),
                },
                None,
            ),
            None => bad(format!("partial status names no stage: {reason}")),
        };
    }
    if let Some(reason) = status.strip_prefix("unverified: ") {
        if !exists("trajectory.unverified.csv") {
            return bad("status unverified but no trajectory.unverified.csv".into());
        }
        if passed != Some(false) {
            return bad(format!(
                "status unverified but verification.passed = {passed:?}"
            ));
        }
        let failed = reason.split_whitespace().next().unwrap_or("?");
        // Information only: does the independent check agree that it fails?
        let check = independent(problem_toml, problem_dir, out, "trajectory.unverified.csv")
            .ok()
            .map(|c| c.0);
        return (
            Verdict::Explained {
                key: format!("unverified ({failed})"),
                reason: reason.into(),
            },
            check,
        );
    }
    if let Some(reason) = status.strip_prefix("failed: ") {
        // A failure with no solution is explained only when it is the analytic start's (a
        // problem the tool cannot start); a rejected input of a valid file is a bug.
        if reason.starts_with("cannot build the analytic start") {
            return (
                Verdict::Explained {
                    key: "start (failed)".into(),
                    reason: reason.into(),
                },
                None,
            );
        }
        return (Verdict::Unexplained(format!("failed: {reason}")), None);
    }
    bad(format!("unknown status {status:?}"))
}

/// The independent check of `out/<file>` against the problem file; also returns the CSV text.
fn independent(
    problem_toml: &str,
    problem_dir: &Path,
    out: &Path,
    file: &str,
) -> Result<(TrajectoryCheck, String), String> {
    let expected = expected(problem_toml, problem_dir)
        .map_err(|e| format!("problem file unreadable for the check: {e}"))?;
    let csv =
        std::fs::read_to_string(out.join(file)).map_err(|e| format!("{file} unreadable: {e}"))?;
    Ok((check_trajectory(&csv, &expected), csv))
}

/// Write, solve (in this process, panics caught) and classify one problem under `work`.
pub fn solve_and_classify(p: &CorpusProblem, work: &Path) -> Outcome {
    let dir = work.join(&p.id);
    let _ = std::fs::remove_dir_all(&dir);
    let path = write_problem(p, &dir).expect("writable work directory");
    let out = dir.join("out");
    let (run, seconds) = run_solve_caught(&path, &out);
    let (verdict, check) = classify(&run, &p.toml, &dir, &out);
    Outcome {
        verdict,
        seconds,
        check,
        route: last_route(&out),
        collapse: collapse_flags(&out),
        infimum: infimum_check(&p.toml, &dir, &out),
    }
}
