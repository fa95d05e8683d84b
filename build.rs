//! Runs the symbolic pipeline (`codegen/generate.py`) and puts its output in `OUT_DIR`.
//!
//! * Python 3 with the pinned sympy available: the model is regenerated whenever a codegen
//!   source changes (PYTHONHASHSEED=0, deterministic output). If the result differs from the
//!   reviewed committed copy in `codegen/generated/`, a warning says so and the test
//!   `committed_copy_is_current` fails until the copy is refreshed.
//! * Python or the pinned sympy missing: the committed copy is used, loudly, but only if the
//!   hash of the codegen sources recorded in it matches the sources on disk. Otherwise the
//!   build fails and says what to install: stale formulas are never used silently.

use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::{env, fs};

fn main() {
    let root = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR"));
    let codegen = root.join("codegen");
    let committed = codegen.join("generated");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=SUSLOV_PYTHON");
    for (_, entry) in codegen_sources(&codegen) {
        println!("cargo:rerun-if-changed={}", entry.display());
    }
    println!(
        "cargo:rerun-if-changed={}",
        codegen.join("models").display()
    );
    let files = committed_files(&committed);
    for f in &files {
        println!("cargo:rerun-if-changed={}", committed.join(f).display());
    }
    let hash = source_hash(&codegen);
    let python = env::var("SUSLOV_PYTHON").unwrap_or_else(|_| "python3".to_string());
    let run = Command::new(&python)
        .arg(codegen.join("generate.py"))
        .arg("--out")
        .arg(&out)
        .env("PYTHONHASHSEED", "0")
        .output();
    let fallback_reason = match run {
        Ok(o) if o.status.success() => {
            if !files
                .iter()
                .all(|f| same_file(&out.join(f), &committed.join(f)))
            {
                println!(
                    "cargo:warning=the generated model differs from the committed copy in \
                     codegen/generated/: review it (cargo insta review) and refresh the copy \
                     with `python3 codegen/generate.py --out codegen/generated`"
                );
            }
            return;
        }
        Ok(o) if o.status.code() == Some(3) => String::from_utf8_lossy(&o.stderr).into_owned(),
        Ok(o) => panic!(
            "codegen/generate.py failed ({}):\n{}",
            o.status,
            String::from_utf8_lossy(&o.stderr)
        ),
        Err(e) => format!("could not run `{python}`: {e}"),
    };
    let recorded = fs::read_to_string(committed.join("models.rs"))
        .ok()
        .and_then(|s| recorded_hash(&s));
    if recorded.as_deref() != Some(hash.as_str()) {
        panic!(
            "the codegen sources changed (sha256 {hash}) but the formulas cannot be regenerated: \
             {}. The committed copy in codegen/generated/ is for {} and would be stale. Install \
             the pinned generator: `pip install -r codegen/requirements.txt` (Python 3), or set \
             SUSLOV_PYTHON to a python that has it.",
            fallback_reason.trim(),
            recorded.unwrap_or_else(|| "nothing".into())
        );
    }
    for f in &files {
        fs::copy(committed.join(f), out.join(f)).expect("copy committed generated file");
    }
    println!(
        "cargo:warning=using the committed copy of the generated model (codegen/generated/, \
         matching the codegen sources): {}",
        fallback_reason.trim()
    );
}

/// The generated files of the committed copy (`*.rs` and `*.txt` in `codegen/generated/`).
fn committed_files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(dir)
        .expect("read codegen/generated/")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".rs") || n.ends_with(".txt"))
        .collect();
    v.sort();
    v
}

/// The codegen sources that the hash covers: top-level `*.py`, `models/*.py` and
/// `requirements.txt`, sorted by their path relative to `codegen/` (`/`-separated).
fn codegen_sources(dir: &Path) -> Vec<(String, PathBuf)> {
    let mut v: Vec<(String, PathBuf)> = Vec::new();
    for (prefix, sub) in [("", dir.to_path_buf()), ("models/", dir.join("models"))] {
        for p in fs::read_dir(&sub)
            .expect("read codegen sources")
            .filter_map(|e| e.ok().map(|e| e.path()))
        {
            let name = p
                .file_name()
                .expect("file name")
                .to_string_lossy()
                .into_owned();
            if p.is_file()
                && (name.ends_with(".py") || (prefix.is_empty() && name == "requirements.txt"))
            {
                v.push((format!("{prefix}{name}"), p));
            }
        }
    }
    v.sort();
    v
}

/// Same hash as `source_hash()` in codegen/generate.py.
fn source_hash(dir: &Path) -> String {
    let mut h = Sha256::new();
    for (name, p) in codegen_sources(dir) {
        h.update(name.as_bytes());
        h.update([0u8]);
        h.update(fs::read(&p).expect("read codegen source"));
        h.update([0u8]);
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

fn recorded_hash(text: &str) -> Option<String> {
    let line = text
        .lines()
        .find(|l| l.contains("codegen sources sha256"))?;
    Some(line.rsplit(' ').next()?.trim().to_string())
}

fn same_file(a: &Path, b: &Path) -> bool {
    matches!((fs::read(a), fs::read(b)), (Ok(x), Ok(y)) if x == y)
}
