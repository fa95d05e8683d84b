//! Controls whose ξ nearly vanishes (`suslov::lie::collapse`): admissible, verified by
//! re-integration, and cheaper than the extremals the homotopy computes on the paper's own
//! problem; on a free-time problem without the smoothing weight their cost falls to 0 with
//! b − a (no optimal terminal time exists).

use std::path::Path;

use suslov::lie::collapse::{self, Motion, COLLAPSE_EPS};
use suslov::lie::{self, Problem};
use suslov::model::so3::So3;
use suslov::model::Model;

#[path = "paper_lie/mod.rs"]
mod paper_lie;

/// The so(3) problem of an example file, with `edit` applied to its text.
fn example(file: &str, edit: impl Fn(&str) -> String) -> (Problem<So3>, lie::solve::SolveOptions) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = edit(&std::fs::read_to_string(root.join("examples").join(file)).unwrap());
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("collapse");
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(file);
    std::fs::write(&path, text).unwrap();
    let loaded = suslov::config::load(&path).unwrap();
    (loaded.problem.to_generic().unwrap(), loaded.options)
}

#[test]
fn a_control_with_a_vanishing_xi_undercuts_the_papers_optimum() {
    // The paper's eta = 0.01 case (free b; our b = 9.8383, J = 2.66585, the paper's 9.84).
    let problem = paper_lie::paper_problem::<So3>(0.01);
    let control = collapse::along_segment(&problem, problem.params(), 0.157).unwrap();
    eprintln!("{control:?}");
    assert_eq!(control.motion, Motion::ProjectedSegment);
    assert!(control.eps <= COLLAPSE_EPS);
    // Independent value: scipy's solve_ivp of Suslov's equations driven by the same control
    // (xi = 1e-3 times the unit singular direction along the projected segment, derivatives
    // by central differences), cost by the trapezoid rule on 4001 points: 0.85604, reaching
    // Omega_b to 1.4e-8.
    assert!(
        (control.cost - 0.85604).abs() < 2e-4,
        "cost {} against scipy's 0.85604",
        control.cost
    );
    assert!(control.quadrature_error < 1e-9, "{control:?}");
    assert!(control.reintegration_error < 1e-8, "{control:?}");
    assert!(collapse::undercuts(&control, 2.66585, 0.0));
}

#[test]
fn the_same_motion_with_a_small_xi_costs_what_the_formula_says() {
    // The solution's own motion driven by eps xi/|xi|: the motion terms of the cost are the
    // same, the control terms change from alpha/4 (|xi|^2 - 1)^2 + beta/2 |xi'|^2 to
    // alpha/4 (eps^2 - 1)^2 + beta/2 eps^2 |e'|^2 (e = xi/|xi|). Checked with the paper's
    // cost formula evaluated here from the trajectory.
    let problem = paper_lie::paper_problem::<So3>(0.01);
    let sol = lie::solve(&problem, &Default::default(), &mut |_| {}).unwrap();
    let j = lie::verify_solution(&sol).diagnostics.cost;
    let control = collapse::along_solution(&sol, sol.problem.params()).unwrap();
    assert_eq!(control.motion, Motion::Solution);
    assert!(control.reintegration_error < 1e-6, "{control:?}");
    let (alpha, beta) = (1.0, 0.1); // the paper's
    let eps = control.eps;
    let (t0, span) = (sol.problem.t0, sol.t_span);
    let panels = 4000;
    let h = span / panels as f64;
    let g = [
        (0.5 - 0.5 / 3f64.sqrt(), 0.5),
        (0.5 + 0.5 / 3f64.sqrt(), 0.5),
    ];
    let mut change = 0.0;
    for k in 0..panels {
        for (node, w) in g {
            let y = sol.state(t0 + (k as f64 + node) * h);
            let (xi, xid) = (&y[So3::XI], &y[So3::XIDOT]);
            let n2: f64 = xi.iter().map(|v| v * v).sum();
            let size = n2.sqrt();
            let along: f64 = xi.iter().zip(xid).map(|(a, b)| a * b).sum::<f64>() / size;
            let e_dot2: f64 = (0..3)
                .map(|i| ((xid[i] - xi[i] / size * along) / size).powi(2))
                .sum();
            let xid2: f64 = xid.iter().map(|v| v * v).sum();
            let before = alpha / 4.0 * (n2 - 1.0).powi(2) + beta / 2.0 * xid2;
            let after = alpha / 4.0 * (eps * eps - 1.0).powi(2) + beta / 2.0 * eps * eps * e_dot2;
            change += w * h * (after - before);
        }
    }
    eprintln!("J = {j}, collapsed {}, change {change}", control.cost);
    assert!(
        (control.cost - (j + change)).abs() < 1e-6 * j,
        "{} vs {} + {}",
        control.cost,
        j,
        change
    );
    // An extremal is stationary under xi -> (1 + s) xi, so shrinking xi uniformly never pays.
    assert!(control.cost > j);
}

#[test]
fn without_smoothing_the_cost_falls_to_zero_with_the_horizon() {
    // examples/segment.toml (free b, gamma = 1, delta = 0.1) with eta = 0: every term of the
    // collapsed cost but the speed-independent ones vanishes as b - a -> 0.
    let (problem, _) = example("segment.toml", |t| t.replace("\neta = 0.1", "\neta = 0.0"));
    assert_eq!(
        problem.params()[So3::PARAM_NAMES.iter().position(|n| *n == "eta").unwrap()],
        0.0
    );
    let samples = collapse::best_span(&problem, 4.0);
    assert!(samples.len() >= 15, "{samples:?}");
    // Below the horizon where alpha/4 + delta dominates, the cost falls with the span, about
    // linearly, to nearly 0.
    let small: Vec<_> = samples.iter().filter(|c| c.span < 0.05).collect();
    assert!(small.len() >= 5);
    for w in small.windows(2) {
        assert!(w[0].span < w[1].span && w[0].cost < w[1].cost, "{w:?}");
    }
    let least = collapse::cheapest(&samples).unwrap();
    assert!(least.span == samples[0].span, "{least:?}");
    assert!(least.cost < 1e-3, "{least:?}");
    // With eta > 0 the cost grows again as b - a -> 0 (eta/2 int |Omega'|^2 ~ 1/T).
    let (smooth, _) = example("segment.toml", |t| t.to_string());
    let samples = collapse::best_span(&smooth, 4.0);
    let least = collapse::cheapest(&samples).unwrap();
    assert!(least.span > samples[0].span, "{least:?}");
    assert!(
        samples[0].cost > 10.0 * least.cost,
        "{:?} {least:?}",
        samples[0]
    );
}

/// The motion through samples (`collapse::along_samples`, used for the direct start's
/// minimum): the projected segment sampled at 301 points gives the control of the exact
/// segment, to the spline's interpolation error.
#[test]
fn a_sampled_motion_costs_what_the_exact_motion_costs() {
    let problem = paper_lie::paper_problem::<So3>(0.01);
    let span = 0.157;
    let exact = collapse::along_segment(&problem, problem.params(), span).unwrap();
    let set = problem.level_set();
    let path = suslov::lie::path::projected_segment(
        &set,
        &problem.omega_a,
        &problem.omega_b,
        problem.t0,
        problem.t0 + span,
        1e-12,
    )
    .unwrap();
    let times: Vec<f64> = (0..=300)
        .map(|k| problem.t0 + span * k as f64 / 300.0)
        .collect();
    let omegas: Vec<Vec<f64>> = times
        .iter()
        .map(|&t| {
            let mut v = vec![0.0; So3::DIM];
            suslov::lie::path::Path::value_into(&path, t, &mut v);
            v
        })
        .collect();
    let sampled = collapse::along_samples(
        &problem,
        problem.params(),
        &times,
        &omegas,
        Motion::DirectMinimum,
    )
    .unwrap();
    eprintln!("exact {exact:?}\nsampled {sampled:?}");
    assert_eq!(sampled.motion, Motion::DirectMinimum);
    assert!((sampled.span - span).abs() < 1e-15);
    assert!(sampled.reintegration_error < 1e-8, "{sampled:?}");
    assert!(
        ((sampled.cost - exact.cost) / exact.cost).abs() < 1e-7,
        "{} vs {}",
        sampled.cost,
        exact.cost
    );
}
