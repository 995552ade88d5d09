//! Output folders whose files appear complete or not at all.
//!
//! Every file is written to a temporary name in the same folder (`.NAME.tmp`) and renamed into
//! place once it is complete, so a failed run leaves nothing half-written. A write that would
//! replace one of the run's inputs is refused.

use crate::error::{Error, Result};
use serde::Serialize;
use std::fs;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// A folder the run writes its products into.
#[derive(Debug, Clone)]
pub struct OutDir {
    dir: PathBuf,
    inputs: Vec<PathBuf>,
}

impl OutDir {
    /// Creates the folder (and its parents) if needed. `inputs` are the run's input files: none
    /// of them may be overwritten.
    ///
    /// # Errors
    /// [`Error::Input`] if `dir` exists and is not a folder, or cannot be created.
    pub fn create(dir: &Path, inputs: &[&Path]) -> Result<Self> {
        if dir.exists() && !dir.is_dir() {
            return Err(Error::input(dir.display(), "--out exists and is not a folder"));
        }
        fs::create_dir_all(dir)
            .map_err(|e| Error::input(dir.display(), format!("cannot create the output folder: {e}")))?;
        let inputs = inputs.iter().filter_map(|p| fs::canonicalize(p).ok()).collect();
        Ok(OutDir {
            dir: dir.to_path_buf(),
            inputs,
        })
    }

    /// The folder's path.
    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// The path a product named `name` will have.
    pub fn file(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// Writes `name` through `fill`, atomically (temporary name, then rename).
    ///
    /// # Errors
    /// [`Error::Input`] if the target is one of the run's inputs; [`Error::Failed`] if writing
    /// fails (the temporary file is removed); any error `fill` returns.
    pub fn write_with(&self, name: &str, fill: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<PathBuf> {
        let target = self.file(name);
        if let Ok(canon) = fs::canonicalize(&target)
            && self.inputs.contains(&canon)
        {
            return Err(Error::input(
                target.display(),
                "refusing to overwrite an input file; choose another --out",
            ));
        }
        let tmp = self.dir.join(format!(".{name}.tmp"));
        let stage = format!("write {}", target.display());
        let result = (|| {
            let file = fs::File::create(&tmp).map_err(|e| Error::failed(&stage, e))?;
            let mut w = BufWriter::new(file);
            fill(&mut w)?;
            w.flush().map_err(|e| Error::failed(&stage, e))?;
            let file = w.into_inner().map_err(|e| Error::failed(&stage, e.error()))?;
            file.sync_all().map_err(|e| Error::failed(&stage, e))?;
            fs::rename(&tmp, &target).map_err(|e| Error::failed(&stage, e))
        })();
        if result.is_err() {
            let _ = fs::remove_file(&tmp);
        }
        result.map(|()| target)
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
        let out = OutDir::create(dir.path(), &[]).unwrap();
        let err = out
            .write_with("a.txt", |w| {
                w.write_all(b"half").unwrap();
                Err(Error::failed("test", "stopped"))
            })
            .unwrap_err();
        assert_eq!(err.exit_code(), 1);
        assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn refuses_to_overwrite_an_input() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("scan.ply");
        fs::write(&input, b"x").unwrap();
        let out = OutDir::create(dir.path(), &[&input]).unwrap();
        let err = out.write_bytes("scan.ply", b"y").unwrap_err();
        assert_eq!(err.exit_code(), 2);
        assert_eq!(fs::read(&input).unwrap(), b"x");
    }
}
