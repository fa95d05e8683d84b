//! Atomic file replacement: a file is either absent, its old complete contents, or its new
//! complete contents; never a half-written mixture, even if the process dies midway.

use super::ReportError;
use std::fs::{self, File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Distinguishes temporary files made by concurrent writers of one process.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `bytes` to `path` atomically.
///
/// The data go to a fresh temporary file in the same directory (named
/// `.<file name>.tmp.<pid>.<n>`, created exclusively), which is flushed to disk (`fsync`) and
/// then renamed over `path`; on Unix the directory is synced as well so that the rename
/// itself is durable. If anything fails, the temporary file is removed and the previous
/// contents of `path`, if any, are untouched.
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
    let name = path.file_name().ok_or_else(|| ReportError::NotAFile {
        path: path.to_path_buf(),
    })?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let io_err = |source: std::io::Error| ReportError::Io {
        path: path.to_path_buf(),
        source,
    };
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".tmp.{}.{}", std::process::id(), n));
    let tmp = dir.join(tmp_name);

    let mut file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .map_err(io_err)?;
    let written = file
        .write_all(bytes)
        .and_then(|()| file.sync_all())
        .and_then(|()| {
            drop(file);
            fs::rename(&tmp, path)
        });
    if let Err(e) = written {
        // Best effort: the temporary file must not be left behind.
        let _ = fs::remove_file(&tmp);
        return Err(io_err(e));
    }
    sync_dir(&dir);
    Ok(())
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
    fn path_without_file_name_is_rejected() {
        let err = write_atomic(Path::new("/"), b"x").unwrap_err();
        assert!(matches!(err, ReportError::NotAFile { .. }), "{err:?}");
    }
}
