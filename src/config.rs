//! Reading TOML configuration files.
//!
//! Every configuration struct is `#[serde(default, deny_unknown_fields)]` with a `Default`: a
//! missing key takes its default, a misspelt key is an error naming the key, the file and the line,
//! and so is an array of the wrong length.

use crate::error::{Error, Result};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};

/// Parses a configuration from TOML text; `origin` names the text in errors (usually the path).
///
/// # Errors
/// [`Error::Input`] naming `origin`, the line, and what is wrong (unknown key, wrong type, an
/// array of the wrong length...).
pub fn from_toml_str<T: DeserializeOwned + Serialize>(text: &str, origin: &str) -> Result<T> {
    let at = |line: Option<usize>| match line {
        Some(l) => format!("{origin} line {l}"),
        None => origin.to_string(),
    };
    let value: T = toml::from_str(text).map_err(|e| {
        let line = e
            .span()
            .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
        Error::input(at(line), e.message())
    })?;
    // A fixed-size array (`[f64; 3]`) takes the first values of a longer one and drops the
    // rest: the resolved value, written back, holds what was kept.
    if let (Ok(given), Ok(toml::Value::Table(kept))) =
        (text.parse::<toml::Table>(), toml::Value::try_from(&value))
        && let Some((key, n, m)) = array_kept_short(&given, &kept, "")
    {
        // The key's own name, without its tables and indices: `rows[0].inertia[1]` → `inertia`.
        let last = key
            .rsplit('.')
            .next()
            .and_then(|k| k.split('[').next())
            .unwrap_or(&key);
        let line = text
            .lines()
            .position(|l| {
                l.trim_start()
                    .strip_prefix(last)
                    .is_some_and(|r| r.trim_start().starts_with('='))
            })
            .map(|i| i + 1);
        return Err(Error::input(
            at(line),
            format!("{key} has {n} values, {m} expected"),
        ));
    }
    Ok(value)
}

/// The first array of `given` whose kept value (the same key in `kept`) is shorter: its key,
/// and the lengths given and kept.
fn array_kept_short(given: &toml::Table, kept: &toml::Table, prefix: &str) -> Option<(String, usize, usize)> {
    given.iter().find_map(|(k, g)| {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        value_kept_short(g, kept.get(k)?, key)
    })
}

fn value_kept_short(given: &toml::Value, kept: &toml::Value, key: String) -> Option<(String, usize, usize)> {
    match (given, kept) {
        (toml::Value::Table(g), toml::Value::Table(k)) => array_kept_short(g, k, &key),
        (toml::Value::Array(g), toml::Value::Array(k)) if g.len() != k.len() => Some((key, g.len(), k.len())),
        (toml::Value::Array(g), toml::Value::Array(k)) => g
            .iter()
            .zip(k)
            .enumerate()
            .find_map(|(i, (g, k))| value_kept_short(g, k, format!("{key}[{i}]"))),
        _ => None,
    }
}

/// Loads a configuration file, or the defaults when `path` is `None`.
///
/// # Errors
/// [`Error::Input`] if the file cannot be read or does not parse.
pub fn load<T: DeserializeOwned + Serialize + Default>(path: Option<&Path>) -> Result<T> {
    match path {
        None => Ok(T::default()),
        Some(p) => {
            let text = read_text(p, "a TOML file")?;
            from_toml_str(&text, &p.display().to_string())
        }
    }
}

/// A text file's contents.
///
/// # Errors
/// [`Error::Input`] naming the file: unreadable, or not UTF-8 text, then `not {what}` (a PLY or
/// other binary file given for a configuration, a trajectory, a pose), not the reader's
/// "stream did not contain valid UTF-8".
pub fn read_text(path: &Path, what: &str) -> Result<String> {
    std::fs::read_to_string(path).map_err(|e| {
        let why = if e.kind() == std::io::ErrorKind::InvalidData {
            format!("not {what} (not UTF-8 text: a PLY or other binary file?)")
        } else {
            format!("cannot read: {e}")
        };
        Error::input(path.display(), why)
    })
}

/// A value for a message: as written for everyday magnitudes, in exponent form beyond them
/// (`1e300`, not three hundred digits).
pub fn shown(v: f64) -> String {
    if v == 0.0 || !v.is_finite() || (1e-4..1e7).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// `Ok` if `v` is finite and > 0, else an input error naming `what` (a configuration key).
///
/// # Errors
/// [`Error::Input`] naming `what`.
pub fn positive(what: impl std::fmt::Display, v: f64) -> Result<()> {
    require(
        v.is_finite() && v > 0.0,
        what,
        format!("must be a finite number > 0, got {}", shown(v)),
    )
}

/// `Ok` if `v` is finite and ≥ 0, else an input error naming `what` (a configuration key).
///
/// # Errors
/// [`Error::Input`] naming `what`.
pub fn non_negative(what: impl std::fmt::Display, v: f64) -> Result<()> {
    require(
        v.is_finite() && v >= 0.0,
        what,
        format!("must be a finite number ≥ 0, got {}", shown(v)),
    )
}

/// `Ok` if `ok`, else an input error naming `what` (a configuration key) with `why`.
///
/// # Errors
/// [`Error::Input`] naming `what`.
pub fn require(ok: bool, what: impl std::fmt::Display, why: impl std::fmt::Display) -> Result<()> {
    if ok { Ok(()) } else { Err(Error::input(what, why)) }
}

/// `Ok` if `lo ≤ v ≤ hi`, else an input error naming `what`: a count with a documented bound
/// (a larger count would only exhaust memory or time).
///
/// # Errors
/// [`Error::Input`] naming `what`, with the bounds and the value.
pub fn count_between(what: impl std::fmt::Display, v: usize, lo: usize, hi: usize) -> Result<()> {
    require(
        (lo..=hi).contains(&v),
        what,
        format!("must be between {lo} and {hi}, got {v}"),
    )
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

    #[derive(Debug, Deserialize, Serialize, Default, PartialEq)]
    #[serde(default, deny_unknown_fields)]
    struct Demo {
        seed: u64,
        inner: Inner,
        rows: Vec<Inner>,
    }
    #[derive(Debug, Deserialize, Serialize, Default, PartialEq)]
    #[serde(default, deny_unknown_fields)]
    struct Inner {
        radius_m: f64,
        xyz_m: [f64; 3],
        inertia: [[f64; 2]; 2],
    }

    #[test]
    fn an_array_longer_than_its_field_is_an_error_naming_it() {
        for (text, key, line) in [
            (
                "[inner]\nxyz_m = [1.0, 2.0, 3.0, 99.0]\n",
                "inner.xyz_m has 4 values, 3 expected",
                2,
            ),
            (
                "seed = 1\n[inner]\nxyz_m = [1, 2, 3, \"junk\"]\n",
                "inner.xyz_m has 4",
                3,
            ),
            (
                "[[rows]]\ninertia = [[1.0, 0.0], [0.0, 1.0, 7.0]]\n",
                "rows[0].inertia[1] has 3 values, 2 expected",
                2,
            ),
        ] {
            let err = from_toml_str::<Demo>(text, "x.toml").unwrap_err();
            let msg = err.to_string();
            assert_eq!(err.exit_code(), 2);
            assert!(
                msg.contains(key) && msg.contains(&format!("x.toml line {line}")),
                "{msg}"
            );
        }
        // Exact lengths, and lists of any length, are fine.
        let d: Demo = from_toml_str(
            "[inner]\nxyz_m = [1.0, 2.0, 3.0]\n[[rows]]\nradius_m = 1.0\n[[rows]]\nradius_m = 2.0\n",
            "x.toml",
        )
        .unwrap();
        assert_eq!((d.inner.xyz_m, d.rows.len()), ([1.0, 2.0, 3.0], 2));
    }

    /// A binary file given for a configuration (a PLY as `sim.model`) says what it is not,
    /// not the reader's "stream did not contain valid UTF-8".
    #[test]
    fn a_binary_file_is_not_a_toml_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("model.ply");
        std::fs::write(&p, b"ply\nformat binary_little_endian 1.0\n\xff\xfe\x00\x80").unwrap();
        let err = load::<Demo>(Some(&p)).unwrap_err();
        let msg = err.to_string();
        assert_eq!(err.exit_code(), 2);
        assert!(
            msg.contains("model.ply") && msg.contains("not a TOML file"),
            "{msg}"
        );
    }

    #[test]
    fn huge_and_tiny_values_are_shown_in_exponent_form() {
        assert_eq!(shown(-1e300), "-1e300");
        assert_eq!(shown(2.5e-9), "2.5e-9");
        assert_eq!(
            (shown(0.0), shown(3600.5), shown(f64::NAN)),
            ("0".into(), "3600.5".into(), "NaN".into())
        );
        let msg = non_negative("k", -1e300).unwrap_err().to_string();
        assert!(msg.ends_with("got -1e300"), "{msg}");
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
