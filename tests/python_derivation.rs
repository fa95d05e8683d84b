//! Runs the Python-side tests of the derivation (`codegen/tests/`) as part of `cargo test`:
//! Sherman–Morrison vs a direct 9x9 solve, the structure of the top-derivative system, the
//! paper's q and lambda, the printer's parentheses, byte-identical output across hash seeds.

use std::process::Command;

#[test]
fn python_derivation_tests_pass() {
    let root = env!("CARGO_MANIFEST_DIR");
    let python = std::env::var("SUSLOV_PYTHON").unwrap_or_else(|_| "python3".into());
    let out = Command::new(&python)
        .args(["-m", "unittest", "discover", "-s", "codegen/tests"])
        .current_dir(root)
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "cannot run `{python}` ({e}): the derivation tests need Python 3 with \
                 `pip install -r codegen/requirements.txt`"
            )
        });
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "codegen/tests failed:\n{stderr}");
    assert!(
        stderr.contains("OK"),
        "unexpected unittest output:\n{stderr}"
    );
    assert!(
        !stderr.contains("Ran 0 tests"),
        "no Python test ran:\n{stderr}"
    );
}
