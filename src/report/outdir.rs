//! An output directory owned by one run: nothing mixed, nothing stale, nothing half-done.
//!
//! [`OutputDir::open`] takes a directory for one run of `suslov paper` or `suslov solve`:
//!
//! 1. **Lock.** An exclusive advisory lock (`flock`) on `DIR/.suslov.lock`, held until the
//!    run ends (the operating system releases it when the process exits, however it exits).
//!    A second run into the same directory fails at once with [`ReportError::Busy`], naming
//!    the process that holds it. The lock file itself is never removed (removing it would let
//!    a third run lock a new file while the first still writes).
//! 2. **Mark.** `DIR/INCOMPLETE` is written: a short text saying that a run is writing here,
//!    or, if none is, that one was interrupted. It is removed only after `summary.json`, the
//!    last file of a run, is complete. So a directory with `INCOMPLETE`, or without
//!    `summary.json`, never holds a finished run's results.
//! 3. **Sweep.** The files the previous run wrote are removed: they are listed in
//!    `DIR/.suslov-manifest`, which every run keeps up to date *before* it creates a file
//!    (write-ahead), so even a run killed outright leaves a complete list. `summary.json` goes
//!    first; then the other files; then the directories that run created, if they are empty.
//!    Leftover temporary files of [`write_atomic`] (a killed run's) are removed from the
//!    directory and from every directory of the manifest. Files this tool did not write are
//!    left alone, and the manifest is trusted only for plain relative paths below `DIR`
//!    (no `..`, no absolute paths, no symbolic links on the way).
//!
//! Files are then written with [`OutputDir::write`] (atomically, recorded in the manifest
//! first) and the run ends with [`OutputDir::finish`], which writes `summary.json` and
//! removes the `INCOMPLETE` mark.

use std::collections::BTreeSet;
use std::fs::{self, File, OpenOptions, TryLockError};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Component, Path, PathBuf};

use super::atomic::{is_temporary_name, write_atomic};
use super::ReportError;

/// The lock file of an output directory.
pub const LOCK_FILE: &str = ".suslov.lock";
/// The list of what the last run wrote (one `f <path>` or `d <path>` per line).
pub const MANIFEST_FILE: &str = ".suslov-manifest";
/// Present while a run writes, and after a run that did not finish.
pub const INCOMPLETE_FILE: &str = "INCOMPLETE";
/// The run summary, written last.
pub const SUMMARY_FILE: &str = "summary.json";

/// Largest manifest read back (a real one has a few dozen short lines).
const MANIFEST_MAX_BYTES: u64 = 1 << 20;

/// A directory owned by the current run (see the module docs). Dropping it without
/// [`OutputDir::finish`] leaves the `INCOMPLETE` mark: the run did not finish.
#[derive(Debug)]
pub struct OutputDir {
    root: PathBuf,
    /// Held for the lifetime of the run.
    _lock: File,
    /// Relative paths of the files this run wrote (or is about to write).
    files: BTreeSet<PathBuf>,
    /// Relative paths of the directories this run created.
    dirs: BTreeSet<PathBuf>,
}

impl OutputDir {
    /// Takes `root` (created with its parents if missing) for a new run: lock, mark,
    /// sweep (the module docs).
    ///
    /// # Errors
    /// [`ReportError::Busy`] if another run holds the directory; [`ReportError::Io`] naming
    /// the path if it cannot be created, locked, cleaned or written.
    pub fn open(root: impl AsRef<Path>) -> Result<Self, ReportError> {
        let root = root.as_ref().to_path_buf();
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |source: std::io::Error| ReportError::Io { path, source }
        };
        if root.exists() && !root.is_dir() {
            return Err(ReportError::InvalidInput(format!(
                "the output directory {} exists and is not a directory; choose another --out",
                root.display()
            )));
        }
        fs::create_dir_all(&root).map_err(io(&root))?;
        let lock_path = root.join(LOCK_FILE);
        let mut lock = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&lock_path)
            .map_err(io(&lock_path))?;
        match lock.try_lock() {
            Ok(()) => {}
            Err(TryLockError::WouldBlock) => {
                let mut holder = String::new();
                let _ = (&lock).take(200).read_to_string(&mut holder);
                return Err(ReportError::Busy {
                    dir: root,
                    holder: match holder.trim() {
                        "" => "pid not yet recorded".to_string(),
                        h => h.to_string(),
                    },
                });
            }
            Err(TryLockError::Error(source)) => {
                return Err(ReportError::Io {
                    path: lock_path,
                    source,
                })
            }
        }
        let stamp = format!("pid {}\n", std::process::id());
        lock.set_len(0)
            .and_then(|()| lock.seek(SeekFrom::Start(0)))
            .and_then(|_| lock.write_all(stamp.as_bytes()))
            .map_err(io(&lock_path))?;

        let (old_files, old_dirs) = read_manifest(&root);
        // Until they are gone, the previous run's files stay in the manifest (a run killed
        // during the sweep leaves a complete list for the next).
        let mut dir = OutputDir {
            root,
            _lock: lock,
            files: old_files.clone(),
            dirs: old_dirs.clone(),
        };
        // The mark first: from here on the directory says it is not a finished run.
        dir.write(
            INCOMPLETE_FILE,
            format!(
                "suslov (pid {}) is writing results into this directory. If no suslov process \
                 is running, that run was interrupted and the files here are incomplete: \
                 summary.json is written last, and this file is removed after it.\n",
                std::process::id()
            )
            .as_bytes(),
        )?;

        // Sweep: summary first, then the other files, temporaries, empty directories.
        let summary = PathBuf::from(SUMMARY_FILE);
        let order = old_files
            .iter()
            .filter(|p| **p == summary)
            .chain(old_files.iter().filter(|p| **p != summary));
        for rel in order {
            if rel.as_os_str() == INCOMPLETE_FILE {
                continue;
            }
            let path = dir.root.join(rel);
            match fs::remove_file(&path) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(source) => return Err(ReportError::Io { path, source }),
            }
        }
        let mut swept_dirs: Vec<PathBuf> = vec![dir.root.clone()];
        swept_dirs.extend(old_dirs.iter().map(|d| dir.root.join(d)));
        for d in &swept_dirs {
            sweep_temporaries(d)?;
        }
        // Deepest first.
        let mut by_depth: Vec<&PathBuf> = old_dirs.iter().collect();
        by_depth.sort_by_key(|p| std::cmp::Reverse(p.components().count()));
        for rel in by_depth {
            // Only if empty: a file of the user's keeps its directory.
            let _ = fs::remove_dir(dir.root.join(rel));
        }
        dir.files.retain(|p| p.as_os_str() == INCOMPLETE_FILE);
        dir.dirs.clear();
        dir.save_manifest()?;
        Ok(dir)
    }

    /// The directory.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Writes `bytes` to `rel` (a relative path below the directory, subdirectories created
    /// as needed), atomically; recorded in the manifest before the file is created. Returns
    /// the full path.
    ///
    /// # Errors
    /// [`ReportError::InvalidInput`] for a path that is not plainly relative (or has a line
    /// break); [`ReportError::Io`] naming the path.
    pub fn write(&mut self, rel: impl AsRef<Path>, bytes: &[u8]) -> Result<PathBuf, ReportError> {
        let rel = rel.as_ref().to_path_buf();
        if !is_plain_relative(&rel) || rel.to_string_lossy().contains(['\n', '\r']) {
            return Err(ReportError::InvalidInput(format!(
                "output file {} is not a plain relative path",
                rel.display()
            )));
        }
        self.check_free([&rel])?;
        let mut changed = self.files.insert(rel.clone());
        let mut parents: Vec<PathBuf> = rel
            .ancestors()
            .skip(1)
            .filter(|p| !p.as_os_str().is_empty())
            .map(Path::to_path_buf)
            .collect();
        parents.reverse();
        for p in &parents {
            if !self.root.join(p).is_dir() {
                changed |= self.dirs.insert(p.clone());
            }
        }
        if changed {
            self.save_manifest()?;
        }
        if let Some(parent) = parents.last() {
            let full = self.root.join(parent);
            fs::create_dir_all(&full).map_err(|source| ReportError::Io { path: full, source })?;
        }
        let path = self.root.join(&rel);
        write_atomic(&path, bytes)?;
        Ok(path)
    }

    /// Checks that this run may write each of `rels`: a path is free unless something this
    /// run did not write is there (a user's file or directory, or one of an older version of
    /// this tool that kept no manifest), or a directory on the way below the root is not a
    /// real directory (a file, or a symbolic link, which would lead out of it). Callers check
    /// every name a run may write before the work, so that a conflict costs no solving;
    /// [`OutputDir::write`] checks again, so that nothing is ever overwritten.
    ///
    /// # Errors
    /// [`ReportError::InvalidInput`] naming the path and the fix.
    pub fn check_free<P: AsRef<Path>>(
        &self,
        rels: impl IntoIterator<Item = P>,
    ) -> Result<(), ReportError> {
        for rel in rels {
            let rel = rel.as_ref();
            if self.files.contains(rel) {
                continue;
            }
            let mut parents: Vec<&Path> = rel
                .ancestors()
                .skip(1)
                .filter(|p| !p.as_os_str().is_empty())
                .collect();
            parents.reverse();
            for p in parents {
                let full = self.root.join(p);
                match fs::symlink_metadata(&full) {
                    Ok(m) if m.file_type().is_dir() => {}
                    Ok(_) => {
                        return Err(ReportError::InvalidInput(format!(
                            "{} is in the way of the output {}: it is a file or a symbolic link, \
                             not a directory; move it away or choose another --out",
                            full.display(),
                            self.root.join(rel).display()
                        )))
                    }
                    Err(_) => break,
                }
            }
            let full = self.root.join(rel);
            if fs::symlink_metadata(&full).is_ok() {
                return Err(ReportError::InvalidInput(format!(
                    "{} exists and was not written by a suslov run into {} (it is not in its \
                     {MANIFEST_FILE}); suslov does not overwrite it: move it away or choose \
                     another --out",
                    full.display(),
                    self.root.display()
                )));
            }
        }
        Ok(())
    }

    /// Ends the run: writes `summary.json` (the last file) and removes the `INCOMPLETE`
    /// mark. Returns the summary's path.
    ///
    /// # Errors
    /// As [`OutputDir::write`].
    pub fn finish(mut self, summary_json: &[u8]) -> Result<PathBuf, ReportError> {
        let path = self.write(SUMMARY_FILE, summary_json)?;
        let mark = self.root.join(INCOMPLETE_FILE);
        match fs::remove_file(&mark) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(source) => return Err(ReportError::Io { path: mark, source }),
        }
        self.files.remove(Path::new(INCOMPLETE_FILE));
        self.save_manifest()?;
        Ok(path)
    }

    fn save_manifest(&self) -> Result<(), ReportError> {
        let mut text = String::from(
            "# suslov: the files and directories of the last run into this directory; the next \
             run removes them.\n",
        );
        for d in &self.dirs {
            text += &format!("d {}\n", d.display());
        }
        for f in &self.files {
            text += &format!("f {}\n", f.display());
        }
        write_atomic(self.root.join(MANIFEST_FILE), text.as_bytes())
    }
}

/// Whether `path` is a file of the output directory it lies in: `dir` is an output directory
/// (it has [`LOCK_FILE`]) and `path` is one of its bookkeeping files, its `summary.json`, a
/// temporary, or a file its last run wrote (listed in its manifest). Another program writing
/// `path` would replace a run's result; a file of another name there is the user's.
pub fn belongs_to_a_run(path: &Path) -> bool {
    let (Some(dir), Some(name)) = (path.parent(), path.file_name()) else {
        return false;
    };
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    if !dir.join(LOCK_FILE).exists() {
        return false;
    }
    let own = [LOCK_FILE, MANIFEST_FILE, INCOMPLETE_FILE, SUMMARY_FILE];
    if own.iter().any(|n| name == *n) || name.to_str().is_some_and(is_temporary_name) {
        return true;
    }
    let (files, _) = read_manifest(dir);
    files.contains(Path::new(name))
}

/// Only normal components: no root, no `..`, no `.` (so it stays below the directory).
fn is_plain_relative(p: &Path) -> bool {
    !p.as_os_str().is_empty() && p.components().all(|c| matches!(c, Component::Normal(_)))
}

/// The previous run's files and directories, as far as they can be trusted: plain relative
/// paths whose every directory on the way is a real directory (not a symbolic link).
fn read_manifest(root: &Path) -> (BTreeSet<PathBuf>, BTreeSet<PathBuf>) {
    let mut files = BTreeSet::new();
    let mut dirs = BTreeSet::new();
    let Ok(f) = File::open(root.join(MANIFEST_FILE)) else {
        return (files, dirs);
    };
    let mut text = String::new();
    if f.take(MANIFEST_MAX_BYTES)
        .read_to_string(&mut text)
        .is_err()
    {
        return (files, dirs);
    }
    let safe = |rel: &Path| {
        is_plain_relative(rel)
            && rel
                .ancestors()
                .skip(1)
                .filter(|a| !a.as_os_str().is_empty())
                .all(|a| {
                    fs::symlink_metadata(root.join(a)).map_or(true, |m| m.file_type().is_dir())
                })
    };
    for line in text.lines() {
        let (kind, rel) = match line.split_once(' ') {
            Some((k @ ("f" | "d"), rel)) => (k, PathBuf::from(rel)),
            _ => continue,
        };
        if !safe(&rel) || rel.as_os_str() == LOCK_FILE || rel.as_os_str() == MANIFEST_FILE {
            continue;
        }
        if kind == "f" {
            files.insert(rel);
        } else {
            dirs.insert(rel);
        }
    }
    (files, dirs)
}

/// Removes the temporary files of [`write_atomic`] left in `dir` by a killed run (the caller
/// holds the directory's lock, so no live run of this tool is writing them).
fn sweep_temporaries(dir: &Path) -> Result<(), ReportError> {
    let Ok(entries) = fs::read_dir(dir) else {
        return Ok(());
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let is_file = entry.file_type().is_ok_and(|t| t.is_file());
        if is_file && name.to_str().is_some_and(is_temporary_name) {
            let path = entry.path();
            match fs::remove_file(&path) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(source) => return Err(ReportError::Io { path, source }),
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("suslov-outdir-{}-{}", name, std::process::id()));
        let _ = fs::remove_dir_all(&d);
        d
    }

    /// Every entry below `dir`, relative, sorted; hidden bookkeeping files excluded.
    fn tree(dir: &Path) -> Vec<String> {
        fn walk(base: &Path, dir: &Path, out: &mut Vec<String>) {
            for e in fs::read_dir(dir).unwrap() {
                let e = e.unwrap();
                let rel = e.path().strip_prefix(base).unwrap().display().to_string();
                if rel == LOCK_FILE || rel == MANIFEST_FILE {
                    continue;
                }
                if e.file_type().unwrap().is_dir() {
                    out.push(format!("{rel}/"));
                    walk(base, &e.path(), out);
                } else {
                    out.push(rel);
                }
            }
        }
        let mut out = Vec::new();
        walk(dir, dir, &mut out);
        out.sort();
        out
    }

    #[test]
    fn a_run_replaces_exactly_the_previous_runs_files() {
        let d = scratch("replace");
        let mut run = OutputDir::open(&d).unwrap();
        assert_eq!(tree(&d), vec!["INCOMPLETE"]);
        run.write("case_a/trajectory.csv", b"1").unwrap();
        run.write("case_a/omega.png", b"2").unwrap();
        run.write("problem.toml", b"3").unwrap();
        run.finish(b"{}").unwrap();
        assert_eq!(
            tree(&d),
            vec![
                "case_a/",
                "case_a/omega.png",
                "case_a/trajectory.csv",
                "problem.toml",
                "summary.json"
            ]
        );
        // A user's file, in the directory and in a run's subdirectory, and a killed run's
        // temporaries.
        fs::write(d.join("notes.txt"), b"mine").unwrap();
        fs::write(d.join("case_a/mine.txt"), b"mine").unwrap();
        fs::write(d.join(".suslov-tmp-999999-3"), b"half").unwrap();
        fs::write(d.join("case_a/.trajectory.npy.tmp.999999.1"), b"half").unwrap();

        let mut run = OutputDir::open(&d).unwrap();
        assert_eq!(
            tree(&d),
            vec!["INCOMPLETE", "case_a/", "case_a/mine.txt", "notes.txt"]
        );
        run.write("trajectory.partial.csv", b"4").unwrap();
        drop(run); // not finished: the mark stays, no summary
        assert_eq!(
            tree(&d),
            vec![
                "INCOMPLETE",
                "case_a/",
                "case_a/mine.txt",
                "notes.txt",
                "trajectory.partial.csv"
            ]
        );
        let run = OutputDir::open(&d).unwrap();
        run.finish(b"{}").unwrap();
        assert_eq!(
            tree(&d),
            vec!["case_a/", "case_a/mine.txt", "notes.txt", "summary.json"]
        );
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_second_run_into_a_held_directory_is_refused() {
        let d = scratch("busy");
        let first = OutputDir::open(&d).unwrap();
        let err = OutputDir::open(&d).unwrap_err();
        assert!(matches!(err, ReportError::Busy { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(
            msg.contains(&format!("pid {}", std::process::id())),
            "{msg}"
        );
        assert!(msg.contains("--out"), "{msg}");
        drop(first);
        OutputDir::open(&d).unwrap().finish(b"{}").unwrap();
        fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_hostile_manifest_cannot_remove_files_outside_the_directory() {
        let base = scratch("hostile");
        let d = base.join("out");
        fs::create_dir_all(&d).unwrap();
        fs::write(base.join("victim.txt"), b"keep").unwrap();
        fs::create_dir_all(base.join("elsewhere")).unwrap();
        fs::write(base.join("elsewhere/victim.txt"), b"keep").unwrap();
        #[cfg(unix)]
        std::os::unix::fs::symlink(base.join("elsewhere"), d.join("link")).unwrap();
        let victim = base.join("victim.txt");
        fs::write(
            d.join(MANIFEST_FILE),
            format!(
                "f ../victim.txt\nf {}\nf link/victim.txt\nd ..\nf .suslov.lock\n",
                victim.display()
            ),
        )
        .unwrap();
        OutputDir::open(&d).unwrap().finish(b"{}").unwrap();
        assert_eq!(fs::read(&victim).unwrap(), b"keep");
        assert_eq!(
            fs::read(base.join("elsewhere/victim.txt")).unwrap(),
            b"keep"
        );
        assert!(d.join(LOCK_FILE).exists());
        fs::remove_dir_all(&base).unwrap();
    }

    #[test]
    fn paths_that_leave_the_directory_are_not_written() {
        let d = scratch("paths");
        let mut run = OutputDir::open(&d).unwrap();
        for bad in ["../x", "/tmp/x", "a/../../x", "", "a\nb"] {
            assert!(run.write(bad, b"x").is_err(), "{bad:?}");
        }
        drop(run);
        fs::remove_dir_all(&d).unwrap();
    }
}
