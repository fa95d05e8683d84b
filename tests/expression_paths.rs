//! `[desired] kind = "expression"`: a desired path as formulas in t, in the problem files of
//! so(3) and of the other models. Its jet (value and three derivatives, exact over dual numbers,
//! projected onto the energy level set like the other kinds) against the paper's spiral φ_∥;
//! end to end through `suslov solve`; every error names the key, the component and the position.

use std::path::{Path, PathBuf};

use suslov::config::{self, ConfigError, Loaded};
use suslov::so3::desired::DesiredPath;

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples")
}

fn problem_with(desired: &str, omega_b: &str) -> String {
    format!(
        r#"
[body]
inertia = [1.0, 2.0, 3.0]
[boundary]
omega_a = [5.0, 0.0, 0.0]
omega_b = {omega_b}
terminal_time = {{ fixed = 4.0 }}
[cost]
alpha = 1.0
beta = 0.1
gamma = 1.0
[desired]
{desired}
"#
    )
}

/// The paper's φ(t) = [c, t cos t, t sin t] written as formulas, projected onto the paper's
/// ellipsoid, has the jet of the library's φ_∥ (its own dual-number implementation) to rounding.
#[test]
fn a_formula_path_has_the_exact_jet_of_the_same_path_in_code() {
    let text = problem_with(
        "kind = \"expression\"\ncomponents = [\"c\", \"t cos(t)\", \"t sin(t)\"]\nconstants = { c = 10.0 }\nend_time = 4.0",
        "\"desired_end\"",
    );
    let loaded = config::from_toml_str(&text).unwrap();
    let spiral = suslov::so3::desired::PaperSpiral::paper();
    let reference = spiral.phi_par();
    let mut worst: f64 = 0.0;
    for k in 0..=40 {
        let t = 0.1 * f64::from(k);
        let (a, b) = (loaded.problem.desired.jet(t), reference.jet(t));
        for (x, y) in [(a.value, b.value), (a.d1, b.d1), (a.d2, b.d2), (a.d3, b.d3)] {
            worst = worst.max((x - y).norm() / (1.0 + y.norm()));
        }
    }
    assert!(worst < 1e-13, "jets differ by {worst}");
    // omega_b = "desired_end": the path's value at end_time.
    let end = reference.jet(4.0).value;
    assert!((loaded.problem.omega_b - end).norm() < 1e-12 * end.norm());
    // The resolved input keeps the formulas and the constants.
    let t = &loaded.resolved.table["desired"];
    assert_eq!(t["components"][1].as_str(), Some("t cos(t)"));
    assert_eq!(t["constants"]["c"].as_float(), Some(10.0));
}

/// examples/expression.toml solves and verifies (its path lies on E exactly), and another
/// model's file takes the same kind.
#[test]
fn formula_paths_solve_end_to_end() {
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("expression_paths_solve");
    let summary =
        suslov::app::run_solve(&examples().join("expression.toml"), &out, &mut |_| {}).unwrap();
    let c = &summary.cases[0];
    assert_eq!(c.status, "converged", "{}", c.status);
    assert!(c.max_abs_constraint < 1e-8);
    // se(2): the sleigh tracking a formula path, fixed time.
    let se2 = std::fs::read_to_string(examples().join("se2_sleigh.toml")).unwrap();
    let se2 = se2.replace(
        "kind = \"segment\"",
        "kind = \"expression\"\ncomponents = [\"1.0 - 0.3 t\", \"0.5 + 0.05 t\", \"0.05 t\"]",
    );
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("expression_paths_se2");
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("sleigh.toml");
    std::fs::write(&file, se2).unwrap();
    let Loaded::Other(f) = config::load_any(&file).unwrap().0 else {
        panic!("se2 file")
    };
    let l = f.build::<suslov::model::se2::Se2>().unwrap();
    let mut v = vec![0.0; 3];
    l.problem.desired.value_into(2.0, &mut v);
    assert!(v.iter().all(|x| x.is_finite()), "{v:?}");
    assert_eq!(
        l.resolved.table["desired"]["kind"].as_str(),
        Some("expression")
    );
}

fn error_of(desired: &str, omega_b: &str) -> (ConfigError, String) {
    let e = config::from_toml_str(&problem_with(desired, omega_b)).unwrap_err();
    let msg = e.to_string();
    (e, msg)
}

#[test]
fn formula_errors_name_the_component_and_the_position() {
    let (e, msg) = error_of(
        "kind = \"expression\"\ncomponents = [\"5\", \"sin(t\", \"0\"]",
        "[5.0, 0.0, 0.0]",
    );
    assert_eq!(e.field(), Some("desired.components[1]"), "{msg}");
    assert!(msg.contains("at character"), "{msg}");
    let (e, msg) = error_of(
        "kind = \"expression\"\ncomponents = [\"5\", \"k t\", \"0\"]",
        "[5.0, 0.0, 0.0]",
    );
    assert_eq!(e.field(), Some("desired.components[1]"), "{msg}");
    assert!(msg.contains('k'), "{msg}");
    let (e, msg) = error_of(
        "kind = \"expression\"\ncomponents = [\"5\", \"0\"]",
        "[5.0, 0.0, 0.0]",
    );
    assert_eq!(e.field(), Some("desired.components"), "{msg}");
    assert!(msg.contains('3'), "{msg}");
    // Outside its domain on [t0, b]: log(t - 2) for t < 2.
    let (e, msg) = error_of(
        "kind = \"expression\"\ncomponents = [\"5\", \"log(t - 2)\", \"0\"]",
        "[5.0, 0.0, 0.0]",
    );
    assert_eq!(e.field(), Some("desired.components[1]"), "{msg}");
    assert!(msg.contains("not finite at t = 0"), "{msg}");
    // A pole between the check times (2.0001 lies between 2 and 2.0039 on [0, 4]).
    let (e, msg) = error_of(
        "kind = \"expression\"\ncomponents = [\"5\", \"1/(t - 2.0001)\", \"0\"]",
        "[5.0, 0.0, 0.0]",
    );
    assert_eq!(e.field(), Some("desired.components[1]"), "{msg}");
    assert!(msg.contains("unbounded near t = 2.000"), "{msg}");
    // A jump between the check times, bounded on both sides (a sign written through a
    // division by zero): refused, with where, by how much and how to write a step instead.
    let (e, msg) = error_of(
        "kind = \"expression\"\ncomponents = [\"5\", \"atan(1/(t - 2.0001))\", \"0\"]",
        "[5.0, 0.0, 0.0]",
    );
    assert_eq!(e.field(), Some("desired.components[1]"), "{msg}");
    assert!(msg.contains("jumps near t = 2.000"), "{msg}");
    assert!(msg.contains("by about 3.14"), "{msg}");
    assert!(msg.contains("tanh((t - c)/w)"), "{msg}");
    // An unknown name lists the functions once.
    let (_, msg) = error_of(
        "kind = \"expression\"\ncomponents = [\"5\", \"foo(t)\", \"0\"]",
        "[5.0, 0.0, 0.0]",
    );
    assert_eq!(msg.matches("asin").count(), 1, "{msg}");
    // "desired_end" needs an end time.
    let (e, msg) = error_of(
        "kind = \"expression\"\ncomponents = [\"5\", \"0\", \"0\"]",
        "\"desired_end\"",
    );
    assert_eq!(e.field(), Some("desired.end_time"), "{msg}");
    // Keys of other kinds are refused.
    let (e, msg) = error_of(
        "kind = \"expression\"\ncomponents = [\"5\", \"0\", \"0\"]\nc = 1.0",
        "[5.0, 0.0, 0.0]",
    );
    assert_eq!(e.field(), Some("desired.c"), "{msg}");
    // A path that does not start at omega_a (gamma > 0).
    let (e, msg) = error_of(
        "kind = \"expression\"\ncomponents = [\"5 cos(t + 1)\", \"5 sin(t + 1)\", \"0\"]",
        "[5.0, 0.0, 0.0]",
    );
    assert!(matches!(e, ConfigError::DesiredStart { .. }), "{msg}");
}

/// Formulas of any size give the same projected path: the projection rescales a tiny or huge
/// vector before its factor sqrt(level / q), whose third derivative overflowed for
/// `1e-40 (...)` (refused as "not finite at t = 0") though the path is the unit one's.
#[test]
fn tiny_and_huge_formulas_give_the_projected_path_of_unit_ones() {
    let path = |scale: &str| {
        let text = problem_with(
            &format!(
                "kind = \"expression\"\ncomponents = [\"{scale} * 5\", \"{scale} * sin(t)\", \
                 \"{scale} * t^2 / 10\"]"
            ),
            "[5.0, 0.0, 0.0]",
        );
        config::from_toml_str(&text)
            .unwrap_or_else(|e| panic!("{scale}: {e}"))
            .problem
    };
    let unit = path("1");
    for scale in ["1e-40", "1e-100", "1e-200", "1e40", "1e100"] {
        let p = path(scale);
        for t in [0.0, 1.3, 4.0] {
            let (a, b) = (unit.desired.jet(t), p.desired.jet(t));
            for (x, y) in [a.value, a.d1, a.d2, a.d3]
                .iter()
                .zip([b.value, b.d1, b.d2, b.d3].iter())
            {
                assert!((x - y).norm() <= 1e-12 * (1.0 + x.norm()), "{scale} at {t}");
            }
        }
    }
}

/// Steep steps and pulses written as quotients (a logistic `1/(1 + exp(-k (t - c)))`, a pulse
/// `1/cosh(k (t - c))`, a high power `1/(1 + (t - c)^2)^p`) load: their denominators
/// overflow f64 far from the step, which made every derivative inf/inf = NaN and the file was
/// refused as "not finite at t = 0" although the path is smooth and its values there are 0.
/// Their jets are finite everywhere on [0, 4], and the step's value is 1/2 at its centre.
#[test]
fn steep_steps_and_pulses_written_as_quotients_load() {
    for components in [
        r#"["5", "1/(1 + exp(-355 (t - 2.0001)))", "0"]"#,
        r#"["5", "exp(400 (t - 2))/(1 + exp(400 (t - 2)))", "0"]"#,
        r#"["5", "1/cosh(360 (t - 2))", "0"]"#,
        r#"["5", "1/(1 + (t - 2)^2)^200", "0"]"#,
        r#"["5", "1/exp(400 (t - 2)^2)", "0"]"#,
    ] {
        let text = problem_with(
            &format!("kind = \"expression\"\ncomponents = {components}\nend_time = 4.0"),
            "\"desired_end\"",
        );
        let loaded = config::from_toml_str(&text).unwrap_or_else(|e| panic!("{components}: {e}"));
        for k in 0..=400 {
            let jet = loaded.problem.desired.jet(0.01 * f64::from(k));
            for v in [jet.value, jet.d1, jet.d2, jet.d3] {
                assert!(
                    v.iter().all(|x| x.is_finite()),
                    "{components} at {k}: {v:?}"
                );
            }
        }
    }
    let text = problem_with(
        "kind = \"expression\"\ncomponents = [\"5\", \"1/(1 + exp(-355 (t - 2)))\", \"0\"]\nend_time = 4.0",
        "\"desired_end\"",
    );
    let step = config::from_toml_str(&text)
        .unwrap()
        .problem
        .desired
        .jet(2.0)
        .value;
    // Projected radially onto the ellipsoid of omega_a = [5, 0, 0]: the direction [5, 1/2, 0].
    assert!((step[1] / step[0] - 0.1).abs() < 1e-14, "{step:?}");
}

/// A kink in the desired path (`sqrt(u^2)`: continuous, its slope jumps) is accepted, and the
/// solver resolves it: the kinked problem solves, verified, to the limit of its smoothings
/// `sqrt(u^2 + e^2)`. Measured: J = 1.16065103 against 1.16046167, 1.16064797 and
/// 1.16065098 for e = 1e-2, 1e-3, 1e-4 (the gaps fall by about e^2).
#[test]
fn a_kink_in_the_desired_path_solves_to_the_limit_of_its_smoothings() {
    let cost = |e2: &str| {
        let kink = if e2.is_empty() {
            "1 + sqrt((t - 0.7531)^2) - 0.7531".to_string()
        } else {
            format!("1 + sqrt((t - 0.7531)^2 + {e2}) - sqrt(0.7531^2 + {e2})")
        };
        let text = format!(
            r#"
[body]
inertia = [1.0, 2.0, 3.0]
[boundary]
omega_a = [1.0, 1.0, 1.0]
omega_b = [1.0, -1.0, 1.0]
terminal_time = {{ fixed = 2.0 }}
[cost]
alpha = 1.0
beta = 1.0
gamma = 1.0
eta = 0.1
[desired]
kind = "expression"
components = ["{kink}", "1", "1"]
"#
        );
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("expression_kink{e2}"));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("kink.toml");
        std::fs::write(&file, text).unwrap();
        let summary =
            suslov::app::run_solve(&file, &dir.join("out"), &mut |_| {}).unwrap_or_else(|e| {
                panic!("{kink}: {e}");
            });
        let c = &summary.cases[0];
        assert_eq!(c.status, "converged", "{kink}: {}", c.status);
        let verification = c.verification.as_ref().expect("a verification");
        assert!(verification.passed, "{kink}: {verification:?}");
        c.cost
    };
    let kinked = cost("");
    let gaps: Vec<f64> = ["1e-4", "1e-6", "1e-8"]
        .iter()
        .map(|e2| (cost(e2) - kinked).abs())
        .collect();
    // The smoothings approach the kinked cost, each about 100 times closer than the last,
    // and the finest agrees with it to 1e-7 (the smoothing matters: the first gap is 1e-4).
    assert!(gaps[0] > 1e-5, "{gaps:?}");
    assert!(
        gaps[1] < gaps[0] / 20.0 && gaps[2] < gaps[1] / 20.0,
        "{gaps:?}"
    );
    assert!(gaps[2] < 1e-7, "{gaps:?}");
}

/// `tan(t)` over `b − a = 1e4`: three poles between two of the 1025 check times. The file
/// loaded and the solver ran on it until the check times were refined where a formula varies
/// faster than they do; it is refused now, at a pole.
#[test]
fn poles_every_few_time_units_on_a_long_span_are_refused() {
    let text = problem_with(
        "kind = \"expression\"\ncomponents = [\"5\", \"tan(t)\", \"0\"]",
        "[5.0, 0.0, 0.0]",
    )
    .replace("fixed = 4.0", "fixed = 10000.0");
    let e = config::from_toml_str(&text).unwrap_err();
    let msg = e.to_string();
    assert_eq!(e.field(), Some("desired.components[1]"), "{msg}");
    assert!(msg.contains("unbounded near t = "), "{msg}");
    let at: f64 = msg
        .split("unbounded near t = ")
        .nth(1)
        .and_then(|s| s.split(',').next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no time in {msg}"));
    assert!(at.cos().abs() < 1e-3, "t = {at} is no pole of tan: {msg}");
}
