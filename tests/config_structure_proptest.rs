//! Structure properties of problem files (issue #10): arrays of any length, values of the
//! wrong type, huge and tiny magnitudes, keys removed or duplicated, arbitrary bytes.
//!
//! Property: loading never panics, and returns either a problem whose every vector is
//! finite (and whose options lie in their documented ranges), or an error whose message
//! names the offending field (or, for text that is no TOML at all, gives the line and
//! column) in at most [`MAX_MESSAGE`] characters.

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use suslov::config::{self, ConfigError, FileProblem, LoadedProblem};

/// The paper's η = 1 problem (a paper-spiral).
const BASE: &str = include_str!("../examples/paper_eta1.toml");

/// A fixed-time segment problem with every segment key given.
const SEGMENT: &str = "name = \"seg\"\n[body]\ninertia = [1.0, 2.0, 3.0]\n[boundary]\nt0 = 0.0\n\
                       omega_a = [3.0, 0.0, 0.0]\nomega_b = [1.0, 2.0, 0.0]\n\
                       terminal_time = { fixed = 4.0 }\n[cost]\nalpha = 1.0\nbeta = 0.1\n\
                       gamma = 1.0\neta = 0.1\ndelta = 0.1\n[desired]\nkind = \"segment\"\n\
                       from = [3.0, 0.0, 0.0]\nto = [1.0, 2.0, 0.0]\ninterval = [0.0, 4.0]\n\
                       [solver]\ntolerance = 1e-8\ncontinuation_tolerance = 1e-4\n\
                       beta_m = 1e-3\ninitial_intervals = 100\nmax_nodes = 20000\n\
                       start = \"auto\"\n";

/// A constant-path problem.
const CONSTANT: &str = "[body]\ninertia = [1.0, 2.0, 3.0]\n[boundary]\n\
                        omega_a = [3.0, 0.0, 0.0]\nomega_b = \"desired_end\"\n\
                        terminal_time = { fixed = 4.0 }\n[cost]\nalpha = 1.0\nbeta = 0.1\n\
                        gamma = 0.0\n[desired]\nkind = \"constant\"\nvalue = [1.0, 2.0, 0.0]\n";

/// Longest acceptable error message.
const MAX_MESSAGE: usize = 1000;

/// `(document, TOML path, entries)` of every fixed-length vector key.
const VECTOR_KEYS: [(&str, &str, usize); 8] = [
    (BASE, "body.inertia", 3),
    (BASE, "boundary.omega_a", 3),
    (SEGMENT, "boundary.omega_b", 3),
    (SEGMENT, "desired.from", 3),
    (SEGMENT, "desired.to", 3),
    (SEGMENT, "desired.interval", 2),
    (CONSTANT, "desired.value", 3),
    (CONSTANT, "body.inertia", 3),
];

/// `doc` with the value of the key `path` (`table.key`, first occurrence in that table)
/// replaced by `value`, or its line removed (`None`).
fn replace_value(doc: &str, path: &str, value: Option<&str>) -> String {
    let (table, key) = path.rsplit_once('.').unwrap_or(("", path));
    let mut current = String::new();
    let mut done = false;
    let mut out = Vec::new();
    for line in doc.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            current = t.trim_matches(['[', ']']).to_string();
        }
        let is_key = !done
            && current == table
            && t.split('=').next().map(str::trim) == Some(key)
            && t.contains('=');
        if is_key {
            done = true;
            if let Some(v) = value {
                out.push(format!("{key} = {v}"));
            }
        } else {
            out.push(line.to_string());
        }
    }
    assert!(done, "no key {path}");
    out.join("\n") + "\n"
}

/// `doc` with the line of key `path` written twice.
fn duplicate(doc: &str, path: &str) -> String {
    let (table, key) = path.rsplit_once('.').unwrap_or(("", path));
    let mut current = String::new();
    let mut out = Vec::new();
    let mut done = false;
    for line in doc.lines() {
        let t = line.trim();
        if t.starts_with('[') {
            current = t.trim_matches(['[', ']']).to_string();
        }
        out.push(line.to_string());
        if !done && current == table && t.split('=').next().map(str::trim) == Some(key) {
            out.push(line.to_string());
            done = true;
        }
    }
    assert!(done, "no key {path}");
    out.join("\n") + "\n"
}

/// Every `table.key` path of a document (keys of inline tables excluded).
fn key_paths(doc: &str) -> Vec<String> {
    let mut current = String::new();
    let mut keys = Vec::new();
    for line in doc.lines() {
        let t = line.split('#').next().unwrap_or("").trim();
        if t.starts_with('[') {
            current = t.trim_matches(['[', ']']).to_string();
        } else if let Some((k, _)) = t.split_once('=') {
            let k = k.trim();
            keys.push(if current.is_empty() {
                k.to_string()
            } else {
                format!("{current}.{k}")
            });
        }
    }
    keys
}

/// The property for a successful load: every vector finite, options in range.
fn check_loaded(p: &LoadedProblem) -> Result<(), TestCaseError> {
    let q = &p.problem;
    prop_assert!(q.validate().is_ok());
    for v in [q.omega_a, q.omega_b, q.inertia.diag()] {
        prop_assert!(v.iter().all(|x| x.is_finite()), "{q:?}");
    }
    let b = q.terminal.initial();
    prop_assert!(q.t0.is_finite() && b.is_finite() && b > q.t0);
    for t in [q.t0, b] {
        let jet = q.desired.jet(t);
        for v in [jet.value, jet.d1, jet.d2, jet.d3] {
            prop_assert!(v.iter().all(|x| x.is_finite()), "t = {t}: {jet:?}");
        }
    }
    let o = &p.options;
    let (lo, hi) = config::TOLERANCE_RANGE;
    prop_assert!((lo..=hi).contains(&o.tol));
    let (lo, hi) = config::CONTINUATION_TOLERANCE_RANGE;
    prop_assert!((lo..=hi).contains(&o.continuation_tol));
    prop_assert!(o.initial_intervals <= config::MAX_INITIAL_INTERVALS);
    prop_assert!(o.max_nodes <= config::MAX_NODES && o.max_nodes > o.initial_intervals);
    prop_assert!(p.name.chars().count() <= config::MAX_NAME_CHARS);
    Ok(())
}

/// The property for an error: short, names a field (which its message contains), or is a
/// TOML syntax error located by line and column, or is about the file as a whole.
fn check_error(e: &ConfigError, input: &str) -> Result<(), TestCaseError> {
    let msg = e.to_string();
    prop_assert!(
        msg.len() <= MAX_MESSAGE,
        "{} characters: {}…",
        msg.len(),
        msg.chars().take(300).collect::<String>()
    );
    prop_assert!(!msg.trim().is_empty());
    match e.field() {
        Some(field) => {
            prop_assert!(!field.is_empty());
            prop_assert!(
                msg.contains(field),
                "{msg:?} does not name {field:?}\n{input}"
            );
        }
        None => {
            let located = matches!(e.inner(), ConfigError::Toml { .. })
                && msg.contains("TOML parse error at line");
            let whole_file = matches!(
                e.inner(),
                ConfigError::File { .. } | ConfigError::TooLarge { .. } | ConfigError::Read { .. }
            );
            prop_assert!(located || whole_file, "no field in {msg:?}\n{input}");
        }
    }
    Ok(())
}

fn check(result: &Result<LoadedProblem, ConfigError>, input: &str) -> Result<(), TestCaseError> {
    match result {
        Ok(p) => check_loaded(p),
        Err(e) => check_error(e, input),
    }
}

/// TOML text of a float (TOML's `nan`, `inf` included).
fn toml_float(x: f64) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{x:e}")
    }
}

/// Numbers with huge and tiny magnitudes well represented.
fn magnitude() -> impl Strategy<Value = f64> {
    prop_oneof![
        2 => (-308i32..=308, prop::bool::ANY).prop_map(|(e, neg)| {
            let x = 10f64.powi(e);
            if neg { -x } else { x }
        }),
        1 => prop::sample::select(vec![
            f64::MAX,
            -f64::MAX,
            f64::MIN_POSITIVE,
            5e-324,
            -5e-324,
            0.0,
            -0.0,
            1.0,
            f64::NAN,
            f64::INFINITY,
        ]),
        1 => -10.0..10.0f64,
    ]
}

/// A value of any TOML type (often the wrong one).
fn any_value() -> impl Strategy<Value = String> {
    prop_oneof![
        magnitude().prop_map(toml_float),
        (-1_000_000i64..1_000_000).prop_map(|n| n.to_string()),
        "[a-z_ -]{0,12}".prop_map(|s| format!("{s:?}")),
        prop::bool::ANY.prop_map(|b| b.to_string()),
        prop::collection::vec(magnitude(), 0..5).prop_map(|v| {
            format!(
                "[{}]",
                v.iter()
                    .map(|x| toml_float(*x))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        }),
        Just("{ a = 1 }".to_string()),
        Just("{ fixed = 3.0 }".to_string()),
        Just("{ free = true }".to_string()),
        Just("[\"x\", 1]".to_string()),
        Just("[[1, 2], [3]]".to_string()),
        Just("1979-05-27T07:32:00Z".to_string()),
        Just("\"desired_end\"".to_string()),
    ]
}

/// Every key of every sample document.
fn any_key() -> impl Strategy<Value = (&'static str, String)> {
    let mut all = Vec::new();
    for doc in [BASE, SEGMENT, CONSTANT] {
        for k in key_paths(doc) {
            all.push((doc, k));
        }
    }
    prop::sample::select(all)
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("config_struct_{name}"));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn arrays_of_any_length_are_rejected_unless_exact(
        which in 0usize..VECTOR_KEYS.len(),
        entries in prop::collection::vec(magnitude(), 0..=10),
    ) {
        let (doc, key, n) = VECTOR_KEYS[which];
        let value = format!(
            "[{}]",
            entries.iter().map(|x| toml_float(*x)).collect::<Vec<_>>().join(", ")
        );
        let text = replace_value(doc, key, Some(&value));
        let result = config::from_toml_str(&text);
        check(&result, &text)?;
        if entries.len() != n {
            match result {
                Err(ConfigError::Length { field, found, expected, .. }) => {
                    prop_assert_eq!(field, key);
                    prop_assert_eq!((found, expected), (entries.len(), n));
                }
                other => prop_assert!(false, "{key} with {} entries: {other:?}", entries.len()),
            }
        }
    }

    #[test]
    fn any_value_of_any_type_at_any_key(
        (doc, key) in any_key(),
        value in any_value(),
    ) {
        let text = replace_value(doc, &key, Some(&value));
        check(&config::from_toml_str(&text), &text)?;
    }

    #[test]
    fn huge_and_tiny_magnitudes_at_numeric_keys(
        (doc, key) in any_key(),
        x in magnitude(),
        y in magnitude(),
    ) {
        // Vectors get two awkward entries, scalars one; other keys keep their type.
        let original = doc
            .lines()
            .find(|l| l.trim_start().starts_with(key.rsplit('.').next().unwrap()))
            .unwrap_or("");
        let value = if original.contains('[') {
            format!("[{}, {}, 1.0]", toml_float(x), toml_float(y))
        } else {
            toml_float(x)
        };
        let text = replace_value(doc, &key, Some(&value));
        let result = config::from_toml_str(&text);
        check(&result, &text)?;
        if let Err(e) = &result {
            if !(x.is_nan() || y.is_nan()) {
                prop_assert!(!e.to_string().contains("NaN"), "{e}\n{text}");
            }
        }
    }

    #[test]
    fn arbitrary_bytes_never_panic(
        bytes in prop::collection::vec(any::<u8>(), 0..400),
        cut in 0usize..800,
        bom in prop::bool::ANY,
    ) {
        // Arbitrary bytes spliced into a valid file (invalid UTF-8 included), maybe after a
        // byte order mark; loaded from a file.
        let base = BASE.as_bytes();
        let at = cut.min(base.len());
        let mut data = Vec::new();
        if bom {
            data.extend_from_slice("\u{feff}".as_bytes());
        }
        data.extend_from_slice(&base[..at]);
        data.extend_from_slice(&bytes);
        data.extend_from_slice(&base[at..]);
        let path = scratch("bytes").join("p.toml");
        std::fs::write(&path, &data).unwrap();
        let result = config::load(&path);
        check(&result, &String::from_utf8_lossy(&data))?;
        if let Err(e) = &result {
            if std::str::from_utf8(&data).is_err() {
                prop_assert!(
                    matches!(
                        e.inner(),
                        ConfigError::File { problem: FileProblem::NotUtf8 { .. }, .. }
                    ),
                    "{e}"
                );
            }
        }
    }
}

#[test]
fn every_key_removed_is_optional_or_named_as_missing() {
    for doc in [BASE, SEGMENT, CONSTANT] {
        for key in key_paths(doc) {
            let text = replace_value(doc, &key, None);
            match config::from_toml_str(&text) {
                Ok(p) => check_loaded(&p).unwrap(),
                Err(e) => {
                    check_error(&e, &text).unwrap();
                    let field = e.field().unwrap();
                    assert!(
                        field.starts_with(&key) || key.starts_with(field),
                        "removing {key}: {e}"
                    );
                }
            }
        }
    }
}

#[test]
fn every_key_duplicated_is_a_toml_error_naming_it() {
    for doc in [BASE, SEGMENT, CONSTANT] {
        for key in key_paths(doc) {
            let text = duplicate(doc, &key);
            let e = config::from_toml_str(&text).unwrap_err();
            check_error(&e, &text).unwrap();
            let msg = e.to_string();
            assert!(matches!(e, ConfigError::Toml { .. }), "{msg}");
            assert_eq!(e.field(), Some(key.as_str()), "{msg}");
            assert!(msg.contains("duplicate key"), "{msg}");
        }
    }
}

#[test]
fn a_huge_array_is_counted_and_reported_briefly() {
    // 300 000 entries (600 kB, under the 1 MiB cap) at every vector key.
    let long = format!("[{}]", vec!["1"; 300_000].join(","));
    for (doc, key, n) in VECTOR_KEYS {
        let text = replace_value(doc, key, Some(&long));
        let e = config::from_toml_str(&text).unwrap_err();
        check_error(&e, key).unwrap();
        assert!(
            matches!(e, ConfigError::Length { found: 300_000, expected, .. } if expected == n),
            "{e}"
        );
    }
}
