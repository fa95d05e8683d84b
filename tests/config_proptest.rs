//! Property: whatever numbers (NaN, infinities, zeros, negatives, huge and tiny ones), key
//! omissions, wrong types or unknown keys a problem file contains, loading it never panics;
//! it either yields a problem that validates or an error whose message names a field.
//! Nothing is solved here (parse, check and build only).

use proptest::prelude::*;
use suslov::config;

/// TOML text of a float, including TOML's `nan` and `inf`.
fn toml_float(x: f64) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{x:e}")
    }
}

/// Any number, with the awkward ones well represented.
fn number() -> impl Strategy<Value = f64> {
    prop_oneof![
        3 => -20.0..20.0f64,
        2 => 0.01..20.0f64,
        1 => prop::sample::select(vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.0,
            -0.0,
            -1.0,
            1e300,
            -1e300,
            1e-300,
            5e-324,
            f64::MAX,
        ]),
    ]
}

/// A replacement value for any key: a number (often awkward), a vector of such numbers,
/// a wrong type, another desired kind, or `None` to delete the key.
fn corruption() -> impl Strategy<Value = Option<String>> {
    prop_oneof![
        4 => number().prop_map(|x| Some(toml_float(x))),
        3 => [number(), number(), number()].prop_map(|v| Some(vec3(v))),
        1 => prop::sample::select(vec![
            "\"x\"", "true", "[1.0]", "[1.0, 2.0]", "{ a = 1 }", "7", "-5", "0", "[]",
            "\"desired_end\"", "\"segment\"", "\"constant\"", "\"samples\"",
            "{ free = true }", "{ free = false }", "{ free = true, fixed = 3.0 }",
        ])
        .prop_map(|s| Some(s.to_string())),
        1 => Just(None),
    ]
}

fn vec3(v: [f64; 3]) -> String {
    format!(
        "[{}, {}, {}]",
        toml_float(v[0]),
        toml_float(v[1]),
        toml_float(v[2])
    )
}

/// `(table, key, value)` of a valid problem file with random but admissible values.
type Entries = Vec<(&'static str, &'static str, Option<String>)>;

fn valid_entries() -> impl Strategy<Value = Entries> {
    let body = [0.5..5.0f64, 0.5..5.0f64, 0.5..5.0f64];
    let boundary = (0.5..10.0f64, prop::bool::ANY, 1.0..20.0f64);
    let cost = (
        0.01..10.0f64,
        0.01..10.0f64,
        0.0..10.0f64,
        0.0..10.0f64,
        0.0..10.0f64,
    );
    let desired = (0.5..20.0f64, 0.001..1.0f64, 1.0..20.0f64);
    let solver = (
        1e-10..1e-4f64,
        1e-8..1e-3f64,
        1e-4..1.0f64,
        2usize..500,
        1000usize..50_000,
    );
    (body, boundary, cost, desired, solver).prop_map(
        |(i, (x, free, b), (al, be, ga, et, de), (c, w, bd), (tol, ctol, bm, ni, nmax))| {
            let f = |x: f64| Some(toml_float(x));
            let terminal = if free {
                format!("{{ free = true, guess = {} }}", toml_float(b))
            } else {
                format!("{{ fixed = {} }}", toml_float(b))
            };
            vec![
                ("", "name", Some("\"random\"".to_string())),
                ("body", "inertia", Some(vec3(i))),
                ("boundary", "t0", f(0.0)),
                ("boundary", "omega_a", Some(vec3([x, 0.0, 0.0]))),
                ("boundary", "omega_b", Some("\"desired_end\"".to_string())),
                ("boundary", "terminal_time", Some(terminal)),
                ("cost", "alpha", f(al)),
                ("cost", "beta", f(be)),
                ("cost", "gamma", f(ga)),
                ("cost", "eta", f(et)),
                ("cost", "delta", f(de)),
                ("desired", "kind", Some("\"paper-spiral\"".to_string())),
                ("desired", "c", f(c)),
                ("desired", "width", f(w)),
                ("desired", "b_d", f(bd)),
                ("solver", "tolerance", f(tol)),
                ("solver", "continuation_tolerance", f(ctol)),
                // beta_m as a fraction of beta (it must lie in [1e-8 beta, beta]).
                ("solver", "beta_m", f(bm * be)),
                ("solver", "initial_intervals", Some(ni.to_string())),
                ("solver", "max_nodes", Some(nmax.to_string())),
            ]
        },
    )
}

/// A valid file with 0–3 values replaced or deleted and maybe an unknown key.
fn doc() -> impl Strategy<Value = String> {
    (
        valid_entries(),
        prop::collection::vec((0usize..20, corruption()), 0..4),
        prop::option::weighted(0.15, (0usize..6, "[a-z_]{1,8}")),
    )
        .prop_map(|(mut entries, changes, unknown)| {
            for (i, value) in changes {
                let n = entries.len();
                entries[i % n].2 = value;
            }
            if let Some((t, key)) = unknown {
                entries.push((TABLES[t], "zz_unknown", Some(format!("\"{key}\""))));
            }
            let mut out = String::new();
            for table in TABLES {
                if !table.is_empty() {
                    out.push_str(&format!("[{table}]\n"));
                }
                for (_, key, value) in entries.iter().filter(|e| e.0 == table) {
                    if let Some(v) = value {
                        out.push_str(&format!("{key} = {v}\n"));
                    }
                }
            }
            out
        })
}

const TABLES: [&str; 6] = ["", "body", "boundary", "cost", "desired", "solver"];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_documents_load_or_name_a_field(text in doc()) {
        match config::from_toml_str(&text) {
            Ok(loaded) => {
                prop_assert!(loaded.problem.validate().is_ok(), "{text}");
                prop_assert!(loaded.options.tol > 0.0 && loaded.options.tol.is_finite());
            }
            Err(e) => {
                let msg = e.to_string();
                prop_assert!(!msg.trim().is_empty(), "{text}");
                prop_assert!(msg.len() <= 1000, "{} characters: {msg}", msg.len());
                let field = e.field();
                prop_assert!(field.is_some(), "no field in {msg:?} for\n{text}");
                let field = field.unwrap_or_default();
                prop_assert!(msg.contains(field), "{msg:?} does not name {field}\n{text}");
                let table = field.split(['.', '[', ' ']).next().unwrap_or_default();
                prop_assert!(
                    ["name", "body", "boundary", "cost", "desired", "solver"].contains(&table)
                        || table.starts_with("zz_"),
                    "{field} is no key of the schema\n{text}"
                );
            }
        }
    }

    #[test]
    fn mangled_files_never_panic(cut in 0usize..800, len in 0usize..40, insert in "[ -~\n]{0,20}") {
        let base = include_str!("../examples/paper_eta1.toml");
        let start = cut.min(base.len());
        let end = (start + len).min(base.len());
        let text = format!("{}{}{}", &base[..start], insert, &base[end..]);
        match config::from_toml_str(&text) {
            Ok(loaded) => prop_assert!(loaded.problem.validate().is_ok()),
            Err(e) => prop_assert!(!e.to_string().trim().is_empty()),
        }
    }

    #[test]
    fn arbitrary_text_never_panics(text in "[ -~\n\t]{0,300}") {
        match config::from_toml_str(&text) {
            Ok(loaded) => prop_assert!(loaded.problem.validate().is_ok()),
            Err(e) => prop_assert!(!e.to_string().trim().is_empty()),
        }
    }
}
