//! Atomic file replacement: a file is either absent, its old complete contents, or its new
//! complete contents; never a half-written mixture, even if the process dies midway.
//!
//! Temporary files are named `.suslov-tmp-<pid>-<n>` (independent of the target's name, so a
//! target name of up to the file system's limit still works) and registered while they exist:
//! [`remove_in_flight`] deletes them (the command line calls it when SIGINT/SIGTERM arrives),
//! and [`is_temporary_name`] recognises the leftovers of a run that was killed outright
//! (SIGKILL, power loss), which the next run into the same directory sweeps
//! ([`super::OutputDir`]).

use super::ReportError;
use std::collections::BTreeSet;
use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard};

/// Distinguishes temporary files made by concurrent writers of one process.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// Temporary files that exist right now (created, not yet renamed or removed).
static IN_FLIGHT: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());

/// Prefix of every temporary file name.
pub const TEMP_PREFIX: &str = ".suslov-tmp-";

fn in_flight() -> MutexGuard<'static, BTreeSet<PathBuf>> {
    // A panic while holding the lock leaves the set itself consistent.
    IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner())
}

/// Whether `name` is a temporary file of [`write_atomic`]: `.suslov-tmp-<pid>-<n>`, or the
/// `.<file>.tmp.<pid>.<n>` of earlier versions.
pub fn is_temporary_name(name: &str) -> bool {
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if let Some(rest) = name.strip_prefix(TEMP_PREFIX) {
        return matches!(rest.split_once('-'), Some((p, n)) if digits(p) && digits(n));
    }
    // Earlier versions: `.<name>.tmp.<pid>.<n>`.
    let mut parts = name.rsplitn(4, '.');
    let (n, p, tmp, head) = (parts.next(), parts.next(), parts.next(), parts.next());
    matches!((n, p, tmp, head), (Some(n), Some(p), Some("tmp"), Some(h))
        if digits(n) && digits(p) && h.starts_with('.') && h.len() > 1)
}

/// Removes every temporary file this process is writing and keeps new ones from being
/// created; for a signal handler that is about to end the process. Returns the paths removed.
///
/// The registry stays locked afterwards (the lock guard is leaked), so a writer on another
/// thread blocks before it creates or renames anything: the process exits with no temporary
/// file of its own left behind.
pub fn remove_in_flight() -> Vec<PathBuf> {
    let guard = in_flight();
    let removed: Vec<PathBuf> = guard
        .iter()
        .filter(|p| fs::remove_file(p).is_ok())
        .cloned()
        .collect();
    std::mem::forget(guard);
    removed
}

/// Writes `bytes` to `path` atomically.
///
/// The data go to a fresh temporary file in the same directory (named
/// `.suslov-tmp-<pid>-<n>`, created exclusively), which is flushed to disk (`fsync`) and then
/// renamed over `path`; on Unix the directory is synced as well so that the rename itself is
/// durable. If anything fails, the temporary file is removed and the previous contents of
/// `path`, if any, are untouched.
///
/// The parent directory must exist: it is **not** created (a missing directory is an
/// [`ReportError::Io`] naming `path`). Callers that own an output directory create it
/// themselves (as [`write_case_figures`](super::write_case_figures) does).
///
/// # Errors
/// [`ReportError::NotAFile`] if `path` has no file name, [`ReportError::Io`] (naming `path`
/// and carrying the OS error) if creating, writing, syncing or renaming fails.
pub fn write_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> Result<(), ReportError> {
    let path = path.as_ref();
    if path.file_name().is_none() || is_special(path) {
        return Err(ReportError::NotAFile {
            path: path.to_path_buf(),
        });
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let io_err = |source: std::io::Error| ReportError::Io {
        path: path.to_path_buf(),
        source,
    };
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let tmp = dir.join(format!("{TEMP_PREFIX}{}-{n}", std::process::id()));

    // Created and renamed under the registry's lock, so that a signal handler calling
    // [`remove_in_flight`] sees every temporary file that exists.
    let mut file = {
        let mut registry = in_flight();
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(io_err)?;
        registry.insert(tmp.clone());
        file
    };
    let written = file.write_all(bytes).and_then(|()| file.sync_all());
    drop(file);
    let result = {
        let mut registry = in_flight();
        let result = written.and_then(|()| fs::rename(&tmp, path));
        if result.is_err() {
            // Best effort: the temporary file must not be left behind.
            let _ = fs::remove_file(&tmp);
        }
        registry.remove(&tmp);
        result
    };
    result.map_err(io_err)?;
    sync_dir(&dir);
    Ok(())
}

/// Checks, before any work, that [`write_atomic`] can later write `path`: its directory
/// exists (it is **not** created) and a temporary file can be created there (it is removed
/// again), and `path` is not a directory.
///
/// # Errors
/// As [`write_atomic`]; [`ReportError::NotAFile`] if `path` is a directory.
pub fn probe_writable(path: impl AsRef<Path>) -> Result<(), ReportError> {
    let path = path.as_ref();
    if path.file_name().is_none() || path.is_dir() || is_special(path) {
        return Err(ReportError::NotAFile {
            path: path.to_path_buf(),
        });
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let tmp = dir.join(format!("{TEMP_PREFIX}{}-{n}", std::process::id()));
    let mut registry = in_flight();
    OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .map_err(|source| ReportError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    let _ = fs::remove_file(&tmp);
    registry.remove(&tmp);
    Ok(())
}

/// Whether `path` exists and is neither a regular file nor a symbolic link: a directory, a
/// device (`/dev/null`, `/dev/full`), a FIFO or a socket. The rename of [`write_atomic`] would
/// replace it with a regular file (as root, `/dev/null` itself).
fn is_special(path: &Path) -> bool {
    fs::symlink_metadata(path)
        .is_ok_and(|m| !(m.file_type().is_file() || m.file_type().is_symlink()))
}

/// Makes a completed rename durable (Unix); a failure here cannot un-write the data, so it is
/// ignored (some file systems do not support syncing directories).
fn sync_dir(dir: &Path) {
    #[cfg(unix)]
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    #[cfg(not(unix))]
    let _ = dir;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!(
            "suslov-report-atomic-{}-{}",
            name,
            std::process::id()
        ));
        let _ = fs::remove_dir_all(&d);
        fs::create_dir_all(&d).unwrap();
        d
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn writes_and_replaces_without_leftovers() {
        let d = scratch("replace");
        let p = d.join("a.txt");
        write_atomic(&p, b"first").unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"first");
        write_atomic(&p, b"second, longer contents").unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"second, longer contents");
        write_atomic(&p, b"").unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"");
        assert_eq!(entries(&d), vec!["a.txt".to_string()]);
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn missing_directory_is_an_error_naming_the_path() {
        let d = scratch("missing");
        let p = d.join("no-such-dir").join("x.csv");
        let err = write_atomic(&p, b"data").unwrap_err();
        let msg = err.to_string();
        assert!(matches!(err, ReportError::Io { .. }), "{err:?}");
        assert!(msg.contains(&p.display().to_string()), "{msg}");
        assert!(msg.contains("os error"), "{msg}");
        assert!(!d.join("no-such-dir").exists());
        assert!(entries(&d).is_empty());
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn failed_rename_keeps_old_contents_and_removes_temp() {
        // The target is an existing non-empty directory: rename onto it fails.
        let d = scratch("rename");
        let target = d.join("occupied");
        fs::create_dir(&target).unwrap();
        fs::write(target.join("inner"), b"keep").unwrap();
        let err = write_atomic(&target, b"data").unwrap_err();
        assert!(err.to_string().contains("occupied"), "{err}");
        assert_eq!(entries(&d), vec!["occupied".to_string()]);
        assert_eq!(fs::read(target.join("inner")).unwrap(), b"keep");
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn probing_finds_unwritable_targets_and_leaves_nothing() {
        let d = scratch("probe");
        probe_writable(d.join("x.json")).unwrap();
        assert!(entries(&d).is_empty());
        assert!(probe_writable(d.join("missing").join("x.json")).is_err());
        assert!(matches!(
            probe_writable(&d),
            Err(ReportError::NotAFile { .. })
        ));
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn temporary_names_are_recognised_and_independent_of_the_target_name() {
        assert!(is_temporary_name(".suslov-tmp-123-0"));
        assert!(is_temporary_name(".trajectory.npy.tmp.4242.17"));
        assert!(!is_temporary_name("trajectory.npy"));
        assert!(!is_temporary_name(".suslov-tmp-12x-0"));
        assert!(!is_temporary_name(".suslov-tmp-12"));
        assert!(!is_temporary_name("a.tmp.1.2"));
        assert!(!is_temporary_name(".tmp.1.2"));
        // A target name near the 255-byte limit of common file systems: the temporary name
        // does not grow with it.
        let d = scratch("long");
        let name = "x".repeat(250) + ".json";
        write_atomic(d.join(&name), b"{}").unwrap();
        assert_eq!(entries(&d), vec![name]);
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn path_without_file_name_is_rejected() {
        let err = write_atomic(Path::new("/"), b"x").unwrap_err();
        assert!(matches!(err, ReportError::NotAFile { .. }), "{err:?}");
    }
}
