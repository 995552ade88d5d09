//! Output folders whose files appear complete or not at all.
//!
//! Every file is written to a temporary name in the same folder (`.NAME.tmp`) and renamed into
//! place once it is complete, so a failed run leaves nothing half-written. The temporary name is
//! the process's own (`.NAME.PID.tmp`), created new: two runs into one folder never rename each
//! other's half-written files, and no existing file is truncated. A command declares the
//! products it may write when it creates the folder, and one whose product is one of the run's
//! inputs is refused then, before anything is written: inputs are never overwritten, and a run
//! is not refused halfway. A run interrupted by a signal removes the temporary files it is
//! writing before it exits ([`remove_unfinished`]). A run that wrote anything removes, as it
//! ends, the products it declared but did not write, left in the folder by an earlier run and
//! untouched since this one started: a failed rerun into the same `--out` does not leave the
//! earlier run's summary and time series beside its own products, and a run into the same
//! folder meanwhile keeps what it wrote.

use crate::error::{Error, Result};
use serde::Serialize;
use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// The temporary files this process is writing now. A file is added as it is created and taken
/// off as it is renamed into place or removed, each under the lock.
static UNFINISHED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The folders this process made for its output folders, innermost first, while they live.
static CREATED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn unfinished() -> MutexGuard<'static, Vec<PathBuf>> {
    // A writer that panicked holding the lock left the list as it was: still the truth.
    UNFINISHED.lock().unwrap_or_else(PoisonError::into_inner)
}

fn created() -> MutexGuard<'static, Vec<PathBuf>> {
    CREATED.lock().unwrap_or_else(PoisonError::into_inner)
}

/// A temporary file being written, on the list from its creation: renamed into place, or
/// removed when dropped (an error, or a panic unwinding through the writer).
struct Unfinished(PathBuf);

impl Unfinished {
    /// Creates `path` new, and its folder if it is gone, and lists it, under the lock (a run
    /// stopped by a signal has removed the folders it made and holds the lock to its end: none
    /// is made again).
    fn create(path: PathBuf) -> std::io::Result<(Self, fs::File)> {
        let mut list = unfinished();
        // Another run into the same new folder that stopped before writing anything removes
        // it as it ends: made again.
        if let Some(dir) = path.parent() {
            fs::create_dir_all(dir)?;
        }
        let file = fs::File::create_new(&path)?;
        list.push(path.clone());
        Ok((Unfinished(path), file))
    }

    /// Renames the file to `target` and takes it off the list, under the lock (an
    /// interrupted run then finds it complete, or removes it before it is renamed). On an
    /// error the file is removed as `self` drops, after the lock (a local) is released.
    fn rename(self, target: &Path) -> std::io::Result<()> {
        let mut list = unfinished();
        fs::rename(&self.0, target)?;
        list.retain(|p| *p != self.0);
        Ok(())
    }
}

impl Drop for Unfinished {
    fn drop(&mut self) {
        let mut list = unfinished();
        if let Some(i) = list.iter().position(|p| *p == self.0) {
            let _ = fs::remove_file(&self.0);
            list.swap_remove(i);
        }
    }
}

/// The locks a run stopped by a signal holds until the process exits.
pub struct Stopped {
    _files: MutexGuard<'static, Vec<PathBuf>>,
    _folders: MutexGuard<'static, Vec<PathBuf>>,
}

/// Removes the temporary files this process is writing, for a run interrupted by a signal,
/// and the folders it made for its output that are left empty, and returns the locks on both
/// lists: held until the process exits, no file or folder is created or renamed into place
/// after it. A product already renamed is complete and stays.
pub fn remove_unfinished() -> Stopped {
    let mut files = unfinished();
    for tmp in files.drain(..) {
        let _ = fs::remove_file(tmp);
    }
    // Innermost first: a folder that holds anything stays, and so do those around it.
    let folders = created();
    for dir in folders.iter() {
        let _ = fs::remove_dir(dir);
    }
    Stopped {
        _files: files,
        _folders: folders,
    }
}

/// Whether this process was started with `signal` ignored (Linux's `/proc/self/status`,
/// `SigIgn`; elsewhere none is taken as ignored): `nohup`'s SIGHUP, a background job's SIGINT,
/// which an interrupted run leaves ignored (and a child inherits).
pub fn signal_ignored_at_start(signal: i32) -> bool {
    fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("SigIgn:"))
                .and_then(|mask| u64::from_str_radix(mask.trim(), 16).ok())
        })
        .is_some_and(|mask| signal >= 1 && (mask >> (signal - 1)) & 1 == 1)
}

/// A folder the run writes its products into.
#[derive(Debug)]
pub struct OutDir {
    dir: PathBuf,
    products: Vec<&'static str>,
    /// The folders [`OutDir::create`] made, deepest first: removed again when the run ends
    /// with them still empty (bad input found after the folder was made), so that a run that
    /// wrote nothing leaves nothing.
    created: Vec<PathBuf>,
    /// The products written so far.
    written: Mutex<Vec<&'static str>>,
    /// The products an earlier run left in the folder, as they were when this run started
    /// (length and modification time): removed as this run ends if it did not write them and
    /// nothing else has written them meanwhile.
    earlier: Vec<(&'static str, (u64, Option<std::time::SystemTime>))>,
}

/// What tells a file apart from one written over it: its length and modification time.
fn stamp(path: &Path) -> Option<(u64, Option<std::time::SystemTime>)> {
    let m = fs::metadata(path).ok().filter(fs::Metadata::is_file)?;
    Some((m.len(), m.modified().ok()))
}

impl Drop for OutDir {
    fn drop(&mut self) {
        let written = self.written.get_mut().unwrap_or_else(PoisonError::into_inner);
        if !written.is_empty() {
            for (name, was) in self.earlier.iter().filter(|(p, _)| !written.contains(p)) {
                let path = self.dir.join(name);
                // Another run into the folder may have written it since.
                if stamp(&path).as_ref() == Some(was) {
                    let _ = fs::remove_file(path);
                }
            }
        }
        let mut listed = created();
        listed.retain(|d| !self.created.contains(d));
        for dir in &self.created {
            // Stops at the first folder that holds anything.
            if fs::remove_dir(dir).is_err() {
                break;
            }
        }
    }
}

/// What every command writes into its folder besides its products.
const ALWAYS: [&str; 2] = ["config.toml", "summary.json"];

/// The temporary name a product is written under: this process's own, so that two runs
/// writing into one folder never rename each other's half-written files.
fn temporary(name: &str) -> String {
    format!(".{name}.{}.tmp", std::process::id())
}

impl OutDir {
    /// Creates the folder (and its parents) if needed, for a command that writes `products`
    /// (and `config.toml`, `summary.json`). `inputs` are the run's input files: none of them
    /// may be a product.
    ///
    /// # Errors
    /// [`Error::Input`] if an input would be overwritten, if `dir` exists and is not a folder,
    /// if a product's path is a folder, or if `dir` cannot be created or written in.
    pub fn create(dir: &Path, inputs: &[&Path], products: &[&'static str]) -> Result<Self> {
        if dir.exists() && !dir.is_dir() {
            return Err(Error::input(dir.display(), "--out exists and is not a folder"));
        }
        let inputs: Vec<PathBuf> = inputs.iter().filter_map(|p| fs::canonicalize(p).ok()).collect();
        let products: Vec<&'static str> = products.iter().chain(&ALWAYS).copied().collect();
        for name in &products {
            if dir.join(name).is_dir() {
                return Err(Error::input(
                    dir.join(name).display(),
                    format!("is a folder, where this command writes its {name}: choose another --out"),
                ));
            }
            if let Ok(canon) = fs::canonicalize(dir.join(name))
                && let Some(input) = inputs.iter().find(|i| **i == canon)
            {
                return Err(Error::input(
                    input.display(),
                    format!(
                        "is an input, and this command writes {name} into --out {}: choose another --out",
                        dir.display()
                    ),
                ));
            }
        }
        let missing: Vec<&Path> = dir
            .ancestors()
            .take_while(|d| !d.as_os_str().is_empty() && !d.exists())
            .collect();
        let earlier = products
            .iter()
            .filter_map(|name| Some((*name, stamp(&dir.join(name))?)))
            .collect();
        let mut out = OutDir {
            dir: dir.to_path_buf(),
            products,
            created: Vec::new(),
            written: Mutex::new(Vec::new()),
            earlier,
        };
        // Level by level, each folder listed only if this run made it (not one another run
        // made meanwhile, nor `new/..`, which is there once `new` is).
        for d in missing.into_iter().rev() {
            // Made and listed under the lock: a signal meanwhile finds it listed, or stops it
            // being made.
            let mut listed = created();
            match fs::create_dir(d) {
                Ok(()) => {
                    out.created.insert(0, d.to_path_buf());
                    listed.insert(0, d.to_path_buf());
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
                Err(e) => {
                    // (The lock first: `out`'s drop takes it to remove what it made.)
                    drop(listed);
                    return Err(Error::input(
                        dir.display(),
                        format!("cannot create the output folder: {e}"),
                    ));
                }
            }
        }
        // A folder the command could not write in is found before any stage runs.
        let (probe, file) = Unfinished::create(dir.join(temporary("write-check")))
            .map_err(|e| Error::input(dir.display(), format!("cannot write in the output folder: {e}")))?;
        drop(file);
        drop(probe);
        Ok(out)
    }

    /// The folder's path.
    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// The path a product named `name` will have.
    pub fn file(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// Writes `name`, one of the products declared at [`OutDir::create`], through `fill`,
    /// atomically (temporary name, then rename).
    ///
    /// # Errors
    /// [`Error::Failed`] if `name` was not declared (the inputs were not checked against it)
    /// or writing fails (the temporary file is removed); any error `fill` returns, a writer's
    /// own failure (a stage `write …`) named by the file.
    pub fn write_with(&self, name: &str, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<PathBuf> {
        let target = self.file(name);
        let Some(&product) = self.products.iter().find(|p| **p == name) else {
            return Err(Error::failed(
                format!("write {}", target.display()),
                "not a declared product of this command (the inputs were not checked against it)",
            ));
        };
        let stage = format!("write {}", target.display());
        // Never truncate an existing file, should one have the temporary name.
        let (tmp, file) =
            Unfinished::create(self.dir.join(temporary(name))).map_err(|e| Error::failed(&stage, e))?;
        let mut w = BufWriter::new(file);
        // A writer's own failure ("write PLY: No space left on device") names the file.
        fill(&mut w).map_err(|e| match e {
            Error::Failed {
                stage: writer,
                reason,
            } if writer.starts_with("write") => Error::failed(&stage, reason),
            other => other,
        })?;
        w.flush().map_err(|e| Error::failed(&stage, e))?;
        let file = w.into_inner().map_err(|e| Error::failed(&stage, e.error()))?;
        file.sync_all().map_err(|e| Error::failed(&stage, e))?;
        tmp.rename(&target).map_err(|e| Error::failed(&stage, e))?;
        let mut written = self.written.lock().unwrap_or_else(PoisonError::into_inner);
        if !written.contains(&product) {
            written.push(product);
        }
        Ok(target)
    }

    /// Writes raw bytes atomically.
    ///
    /// # Errors
    /// As [`OutDir::write_with`].
    pub fn write_bytes(&self, name: &str, bytes: &[u8]) -> Result<PathBuf> {
        self.write_with(name, |w| {
            w.write_all(bytes)
                .map_err(|e| Error::failed(format!("write {name}"), e))
        })
    }

    /// Writes a value as pretty JSON, atomically.
    ///
    /// # Errors
    /// As [`OutDir::write_with`].
    pub fn write_json<T: Serialize + ?Sized>(&self, name: &str, value: &T) -> Result<PathBuf> {
        let text =
            serde_json::to_string_pretty(value).map_err(|e| Error::failed(format!("write {name}"), e))?;
        self.write_bytes(name, format!("{text}\n").as_bytes())
    }

    /// Writes a value as TOML, atomically (the resolved configuration of a run).
    ///
    /// # Errors
    /// As [`OutDir::write_with`].
    pub fn write_toml<T: Serialize + ?Sized>(&self, name: &str, value: &T) -> Result<PathBuf> {
        let text = toml::to_string_pretty(value).map_err(|e| Error::failed(format!("write {name}"), e))?;
        self.write_bytes(name, text.as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_fill_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let out = OutDir::create(dir.path(), &[], &["a.txt"]).unwrap();
        let err = out
            .write_with("a.txt", |w| {
                w.write_all(b"half").unwrap();
                Err(Error::failed("test", "stopped"))
            })
            .unwrap_err();
        assert_eq!(err.exit_code(), 1);
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
        // A writer's own failure names the file it was writing (a full disk said "write PLY").
        let err = out
            .write_with("a.txt", |_| {
                Err(Error::failed("write PLY", "No space left on device"))
            })
            .unwrap_err();
        let file = dir.path().join("a.txt");
        assert_eq!(
            err.to_string(),
            format!("write {}: No space left on device", file.display())
        );
    }

    /// Found before any stage runs (an unwritable `--out` failed only at the first product,
    /// after the stages' work); the check leaves no file behind (see the test above).
    #[cfg(target_os = "linux")]
    #[test]
    fn a_folder_it_cannot_write_in_is_bad_input() {
        // procfs takes no new file whoever asks, root too (unlike a folder's permissions).
        let err = OutDir::create(Path::new("/proc/self"), &[], &["a.txt"]).unwrap_err();
        assert_eq!(err.exit_code(), 2);
        assert!(
            err.to_string()
                .starts_with("/proc/self: cannot write in the output folder"),
            "{err}"
        );
    }

    #[test]
    fn a_panicking_fill_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let out = OutDir::create(dir.path(), &[], &["a.txt"]).unwrap();
        let unwound = std::panic::catch_unwind(|| {
            out.write_with("a.txt", |w| {
                w.write_all(b"half").unwrap();
                panic!("a writer's bug");
            })
        });
        assert!(unwound.is_err());
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
        // Off the list too: an interruption now has nothing of it to remove.
        assert!(!unfinished().iter().any(|p| p.starts_with(dir.path())));
    }

    #[test]
    fn refuses_an_input_among_the_products_before_writing() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("out");
        // The product itself, and the files every command writes.
        for name in ["scan.ply", "config.toml"] {
            fs::create_dir_all(&sub).unwrap();
            let input = sub.join(name);
            fs::write(&input, b"x").unwrap();
            let err = OutDir::create(&sub, &[&input], &["scan.ply"]).unwrap_err();
            assert_eq!(err.exit_code(), 2);
            let msg = err.to_string();
            assert!(msg.contains(name) && !msg.contains('\n'), "{msg}");
            assert_eq!(fs::read(&input).unwrap(), b"x");
            fs::remove_dir_all(&sub).unwrap();
        }
        // An input in the folder that is no product is fine, and a missing folder is not made
        // when refused.
        let input = dir.path().join("trajectory.csv");
        fs::write(&input, b"x").unwrap();
        assert!(OutDir::create(dir.path(), &[&input], &["scan.ply"]).is_ok());
    }

    #[test]
    fn a_file_with_the_temporary_name_is_left_as_it_is() {
        let dir = tempfile::tempdir().unwrap();
        let squatter = dir.path().join(temporary("a.txt"));
        fs::write(&squatter, b"someone's").unwrap();
        let out = OutDir::create(dir.path(), &[&squatter], &["a.txt"]).unwrap();
        assert_eq!(out.write_bytes("a.txt", b"new").unwrap_err().exit_code(), 1);
        assert_eq!(fs::read(&squatter).unwrap(), b"someone's");
        assert!(!dir.path().join("a.txt").exists());
    }

    /// A rerun into the folder of an earlier run: what it does not write again is removed as it
    /// ends, once it has written anything (a run refused before writing leaves the folder as
    /// it was); files that are not its products, and products another run wrote meanwhile,
    /// stay. A folder with a product's name is refused before anything is written.
    #[test]
    fn a_run_that_wrote_removes_the_earlier_runs_products_it_did_not_write() {
        let dir = tempfile::tempdir().unwrap();
        let path = |name: &str| dir.path().join(name);
        for name in ["a.txt", "b.txt", "summary.json", "notes.txt"] {
            fs::write(path(name), b"earlier").unwrap();
        }
        let products = ["a.txt", "b.txt"];
        drop(OutDir::create(dir.path(), &[], &products).unwrap());
        assert!(
            ["a.txt", "b.txt", "summary.json"]
                .iter()
                .all(|n| path(n).exists())
        );
        let out = OutDir::create(dir.path(), &[], &products).unwrap();
        out.write_bytes("a.txt", b"now").unwrap();
        drop(out);
        assert_eq!(fs::read(path("a.txt")).unwrap(), b"now");
        assert!(!path("b.txt").exists() && !path("summary.json").exists());
        assert!(path("notes.txt").exists());
        // What another run into the folder wrote meanwhile stays (told apart by its length and
        // modification time).
        fs::write(path("b.txt"), b"earlier").unwrap();
        let out = OutDir::create(dir.path(), &[], &products).unwrap();
        out.write_bytes("a.txt", b"again").unwrap();
        std::thread::sleep(std::time::Duration::from_millis(20));
        fs::write(path("b.txt"), b"another run's").unwrap();
        drop(out);
        assert_eq!(fs::read(path("b.txt")).unwrap(), b"another run's");
        fs::remove_file(path("b.txt")).unwrap();
        fs::create_dir(path("b.txt")).unwrap();
        let err = OutDir::create(dir.path(), &[], &products).unwrap_err();
        assert_eq!(err.exit_code(), 2);
        assert!(
            err.to_string()
                .contains("b.txt: is a folder, where this command writes its b.txt"),
            "{err}"
        );
    }

    #[test]
    fn refuses_an_undeclared_product() {
        let dir = tempfile::tempdir().unwrap();
        let out = OutDir::create(dir.path(), &[], &["a.txt"]).unwrap();
        assert_eq!(out.write_bytes("b.txt", b"y").unwrap_err().exit_code(), 1);
        assert!(out.write_bytes("summary.json", b"{}").is_ok());
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);
    }
}
