//! Reading TOML configuration files.
//!
//! Every configuration struct is `#[serde(default, deny_unknown_fields)]` with a `Default`: a
//! missing key takes its default, a misspelt key is an error naming the key, the file and the line.

use crate::error::{Error, Result};
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};

/// Parses a configuration from TOML text; `origin` names the text in errors (usually the path).
///
/// # Errors
/// [`Error::Input`] naming `origin`, the line, and what is wrong (unknown key, wrong type...).
pub fn from_toml_str<T: DeserializeOwned>(text: &str, origin: &str) -> Result<T> {
    toml::from_str(text).map_err(|e| {
        let line = e
            .span()
            .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
        let what = match line {
            Some(l) => format!("{origin} line {l}"),
            None => origin.to_string(),
        };
        Error::input(what, e.message())
    })
}

/// Loads a configuration file, or the defaults when `path` is `None`.
///
/// # Errors
/// [`Error::Input`] if the file cannot be read or does not parse.
pub fn load<T: DeserializeOwned + Default>(path: Option<&Path>) -> Result<T> {
    match path {
        None => Ok(T::default()),
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .map_err(|e| Error::input(p.display(), format!("cannot read: {e}")))?;
            from_toml_str(&text, &p.display().to_string())
        }
    }
}

/// `Ok` if `v` is finite and > 0, else an input error naming `what` (a configuration key).
///
/// # Errors
/// [`Error::Input`] naming `what`.
pub fn positive(what: &str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(Error::input(
            what,
            format!("must be a finite number > 0, got {v}"),
        ))
    }
}

/// `Ok` if `v` is finite and ≥ 0, else an input error naming `what` (a configuration key).
///
/// # Errors
/// [`Error::Input`] naming `what`.
pub fn non_negative(what: &str, v: f64) -> Result<()> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(Error::input(
            what,
            format!("must be a finite number ≥ 0, got {v}"),
        ))
    }
}

/// `path` relative to the folder of the file `base` (unless absolute), made absolute: the
/// resolved configuration a command writes (`config.toml`) then names the same files wherever
/// it is read from (a path relative to the working folder, read back relative to the output
/// folder, named none).
pub fn relative_to(base: Option<&Path>, path: &Path) -> PathBuf {
    let joined = match base.and_then(Path::parent) {
        Some(dir) if path.is_relative() => dir.join(path),
        _ => path.to_path_buf(),
    };
    std::path::absolute(&joined).unwrap_or(joined)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Deserialize, Default, PartialEq)]
    #[serde(default, deny_unknown_fields)]
    struct Demo {
        seed: u64,
        inner: Inner,
    }
    #[derive(Debug, Deserialize, Default, PartialEq)]
    #[serde(default, deny_unknown_fields)]
    struct Inner {
        radius_m: f64,
    }

    #[test]
    fn missing_keys_take_defaults() {
        let d: Demo = from_toml_str("seed = 3\n", "x.toml").unwrap();
        assert_eq!(
            d,
            Demo {
                seed: 3,
                ..Default::default()
            }
        );
    }

    #[test]
    fn typo_names_key_file_and_line() {
        let err = from_toml_str::<Demo>("seed = 3\n[inner]\nradius = 1.0\n", "x.toml").unwrap_err();
        let msg = err.to_string();
        assert_eq!(err.exit_code(), 2);
        assert!(msg.contains("x.toml line 3") && msg.contains("radius"), "{msg}");
        assert!(!msg.contains('\n'));
    }
}
