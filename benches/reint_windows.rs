//! The measurements behind the windowed `reintegration` check (issue #12;
//! `REINTEGRATION_WINDOW_ANGLE` in `src/lie/checks.rs`, docs/verification.md). All
//! A measurement program (it prints, asserts nothing; the assertions on the check are in
//! `tests/suslov_verify.rs`), one of:
//!
//! - `experiment` (`IDS=fast-018,... TOLF=1,2`): corpus problems solved at `tol · TOLF`; the
//!   open-loop difference, the windowed one for several window angles, and (at the file's
//!   tol) the growth of a `1e-12` perturbation of `Ω_a` along the motion;
//! - `inspect` (`IDS=long-134`): the checks and the worst one-radian windows of one problem;
//! - `table`: the README's value / tol table for every example and tolerance;
//! - `loose`: the README's table of failed checks at loose tolerances.
//!
//! `cargo bench --bench reint_windows -- <name>` (release).
#[path = "../tests/corpus/mod.rs"]
mod corpus;

use suslov::ivp::{integrate, IvpOptions};
use suslov::lie::verify::{reintegrate_difference, reintegrate_windowed, rotation_windows};
use suslov::model::generated::So3;
use suslov::model::Model;
use suslov::so3::solve::{solve, SolveOptions};

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn experiment() {
    let ids: Vec<String> = std::env::var("IDS")
        .unwrap_or("fast-018".into())
        .split(',')
        .map(String::from)
        .collect();
    let all = corpus::generate(corpus::DEFAULT_N, corpus::SEED);
    let work = std::env::temp_dir().join("reint_windows_measurement");
    for id in ids {
        let p = all.iter().find(|p| p.id == id).expect("id");
        let path = corpus::write_problem(p, &work.join(&id)).unwrap();
        let loaded = suslov::config::load(&path).unwrap();
        let tol0 = loaded.options.tol;
        let factors: Vec<f64> = std::env::var("TOLF")
            .unwrap_or("1".into())
            .split(',')
            .map(|f| f.parse().unwrap())
            .collect();
        for tol in factors.iter().map(|f| tol0 * f) {
            let options = SolveOptions {
                tol,
                ..loaded.options.clone()
            };
            let sol = match solve(&loaded.problem, &options, &mut |_| {}) {
                Ok(s) => s,
                Err(e) => {
                    println!("{id} tol {tol:e}: solve failed: {e}");
                    continue;
                }
            };
            let g = &sol.generic;
            let v = suslov::lie::verify_solution(g);
            let om_max = v.diagnostics.omega_norm_max;
            let total: f64 = rotation_windows(g, f64::INFINITY).len() as f64;
            let one = rotation_windows(g, 0.0).len();
            let glob = reintegrate_difference(g);
            println!(
                "{id} tol {tol:e}: b = {:.4}, nodes {}, max|Om| {om_max:.3}, windows(inf) {total}, mesh intervals {one}, global diff/max|Om| = {:?}, verdict passed = {}",
                g.terminal_time(),
                g.bvp.num_nodes(),
                glob.as_ref().map(|r| r.max_abs_diff / om_max),
                v.verification.passed()
            );
            for angle in [
                1.0,
                std::f64::consts::PI,
                2.0 * std::f64::consts::PI,
                20.0,
                50.0,
                100.0,
                1e9,
            ] {
                let r = reintegrate_windowed(g, angle);
                println!(
                    "   angle {angle:>8.3}: {:?}",
                    r.map(|r| (r.windows, r.max_abs_diff / om_max, r.t_max_abs_diff))
                );
            }
            if tol != tol0 {
                continue;
            }
            // Sensitivity: two IVPs from Omega_a and Omega_a + 1e-10 (each direction).
            let (a, b) = (g.problem.t0, g.terminal_time());
            let params = g.problem.params().to_vec();
            let rhs = |t: f64, om: &[f64], dy: &mut [f64]| {
                let mut y = vec![0.0; So3::N_STATE];
                g.state_into(t.clamp(a, b), &mut y);
                let mut x = y[..So3::KAPPA.start].to_vec();
                x[So3::OMEGA].copy_from_slice(om);
                So3::suslov_omega_dot(&x, &params, dy);
            };
            let n_out = 160;
            let times: Vec<f64> = (0..=n_out)
                .map(|k| a + (b - a) * k as f64 / n_out as f64)
                .collect();
            let base = integrate(
                rhs,
                (a, b),
                &g.problem.omega_a,
                &times,
                &IvpOptions::default(),
            )
            .unwrap();
            // angle at output times
            let mut angle = vec![0.0];
            let mut y = vec![0.0; So3::N_STATE];
            for w in times.windows(2) {
                let m = 200;
                let mut acc = 0.0;
                for k in 0..m {
                    let t = w[0] + (w[1] - w[0]) * (k as f64 + 0.5) / m as f64;
                    g.state_into(t, &mut y);
                    acc += norm(&y[So3::OMEGA]) * (w[1] - w[0]) / m as f64;
                }
                angle.push(angle.last().unwrap() + acc);
            }
            let mut om = g.problem.omega_a.clone();
            om[0] += 1e-12;
            let pert = integrate(rhs, (a, b), &om, &times, &IvpOptions::default()).unwrap();
            let d: Vec<f64> = (0..=n_out)
                .map(|k| {
                    norm(
                        &pert.y[k]
                            .iter()
                            .zip(&base.y[k])
                            .map(|(p, q)| p - q)
                            .collect::<Vec<f64>>(),
                    )
                })
                .collect();
            let line: Vec<String> = (0..=n_out)
                .step_by(4)
                .map(|k| format!("{:.0}:{:.1}", angle[k], d[k].log10()))
                .collect();
            println!("   perturb 1e-12 (angle:log10|d|): {}", line.join(" "));
            // Largest growth of |d| over any stretch of at most A radians (while |d| < 1e-3 max|Om|).
            for span in [1.0, std::f64::consts::TAU, 20.0] {
                let mut best: f64 = 0.0;
                for i in 0..=n_out {
                    for j in i + 1..=n_out {
                        if angle[j] - angle[i] > span || d[j] > 1e-3 * om_max {
                            break;
                        }
                        best = best.max(d[j] / d[i]);
                    }
                }
                println!("   max growth over <= {span:.2} rad (unsaturated): {best:.3e}");
            }
            println!("   total angle {:.1} rad", angle[n_out]);
        }
    }
}

fn inspect() {
    use suslov::lie::verify::reintegrate_in_windows;
    let id = std::env::var("IDS").unwrap_or("long-134".into());
    let all = corpus::generate(corpus::DEFAULT_N, corpus::SEED);
    let work = std::env::temp_dir().join("reint_windows_measurement");
    let p = all.iter().find(|p| p.id == id).expect("id");
    let path = corpus::write_problem(p, &work.join(&id)).unwrap();
    println!("{}", p.toml);
    let loaded = suslov::config::load(&path).unwrap();
    let sol = solve(&loaded.problem, &loaded.options, &mut |_| {}).unwrap();
    let g = &sol.generic;
    let v = suslov::lie::verify_solution(g);
    for c in &v.verification.checks {
        println!("{} = {:e} (thr {:e})", c.name, c.value, c.threshold);
    }
    let om_max = v.diagnostics.omega_norm_max;
    let mut res: Vec<(f64, f64, f64)> = rotation_windows(g, 1.0)
        .into_iter()
        .map(|w| {
            (
                reintegrate_in_windows(g, &[w]).unwrap().max_abs_diff / om_max,
                w.0,
                w.1,
            )
        })
        .collect();
    res.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap());
    for r in res.iter().take(5) {
        let n = g
            .bvp
            .x
            .iter()
            .filter(|s| {
                let t = g.problem.t0 + *s * g.t_span;
                t >= r.1 && t <= r.2
            })
            .count();
        println!("window [{:.4}, {:.4}] nodes {n}: {:e}", r.1, r.2, r.0);
    }
    // Mesh around the worst window and the state there.
    let (t0, t1) = (res[0].1, res[0].2);
    let mut y = vec![0.0; So3::N_STATE];
    for k in 0..=10 {
        let t = t0 + (t1 - t0) * k as f64 / 10.0;
        g.state_into(t, &mut y);
        println!(
            "t {t:.4}: Om {:?} xi {:?} xidot {:?}",
            &y[So3::OMEGA],
            &y[So3::XI],
            &y[So3::XIDOT]
        );
    }
}

fn table() {
    let files = [
        "paper_eta1.toml",
        "paper_eta0.01.toml",
        "spiral_other_body.toml",
        "spiral_fixed_time.toml",
        "segment.toml",
        "no_tracking.toml",
        "spiral_samples.toml",
    ];
    for f in files {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("examples")
            .join(f);
        let loaded = suslov::config::load(&path).unwrap();
        for tol in [1e-4, 1e-6, 1e-8, 1e-10, 1e-12] {
            let options = SolveOptions {
                tol,
                ..loaded.options.clone()
            };
            let sol = match solve(&loaded.problem, &options, &mut |_| {}) {
                Ok(s) => s,
                Err(e) => {
                    println!(
                        "| `{f}` | {tol:e} | failed: {} |",
                        e.to_string().chars().take(60).collect::<String>()
                    );
                    continue;
                }
            };
            let v = suslov::lie::verify_solution(&sol.generic);
            let r = |n: &str| v.verification.check(n).unwrap().value / tol;
            let ol = v
                .open_loop
                .as_ref()
                .map(|o| o.max_abs_diff / v.diagnostics.omega_norm_max / tol)
                .unwrap_or(f64::NAN);
            println!(
                "| `{f}` | {tol:e} | {} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {:.2e} | {} | {:.2e} | {}",
                sol.generic.bvp.num_nodes(), r("local_error"), r("constraint"), r("energy"), r("omega_b"), r("boundary_conditions"), r("reintegration"),
                v.reintegration.as_ref().map(|x| x.windows).unwrap_or(0), ol, v.verification.passed()
            );
        }
    }
}

fn loose() {
    let files = [
        "paper_eta1.toml",
        "paper_eta0.01.toml",
        "spiral_other_body.toml",
        "spiral_fixed_time.toml",
        "segment.toml",
        "no_tracking.toml",
        "spiral_samples.toml",
    ];
    for f in files {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("examples")
            .join(f);
        let loaded = suslov::config::load(&path).unwrap();
        let mut cells = vec![];
        for tol in [1.0, 0.1, 1e-2, 1e-3] {
            let options = SolveOptions {
                tol,
                ..loaded.options.clone()
            };
            let cell = match solve(&loaded.problem, &options, &mut |_| {}) {
                Ok(sol) => {
                    let v = suslov::lie::verify_solution(&sol.generic).verification;
                    let failed: Vec<String> = v
                        .failures()
                        .filter(|c| c.name != "tolerance")
                        .map(|c| format!("{} {:.2}", c.name, c.value / c.threshold))
                        .collect();
                    if failed.is_empty() {
                        "—".to_string()
                    } else {
                        failed.join(", ")
                    }
                }
                Err(e) => format!("failed {e}"),
            };
            cells.push(cell);
        }
        println!("| `{f}` | {} |", cells.join(" | "));
    }
}

fn main() {
    let which: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let all = ["experiment", "inspect", "table", "loose"];
    let chosen: Vec<&str> = if which.is_empty() {
        eprintln!(
            "usage: cargo bench --bench reint_windows -- <{}>",
            all.join("|")
        );
        return;
    } else {
        which.iter().map(String::as_str).collect()
    };
    for name in chosen {
        match name {
            "experiment" => experiment(),
            "inspect" => inspect(),
            "table" => table(),
            "loose" => loose(),
            other => eprintln!("unknown measurement {other:?}; one of {}", all.join(", ")),
        }
    }
}
