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
    let line_of = |e: &toml::de::Error| {
        e.span()
            .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1)
    };
    // A syntax error's message names no key ("duplicate key"): the text it points at does.
    let document = toml::Deserializer::parse(text).map_err(|e| {
        let snippet = e.span().and_then(|s| text.get(s)).map(str::trim).unwrap_or("");
        let message = if snippet.is_empty() || snippet.contains('\n') || snippet.len() > 60 {
            e.message().to_string()
        } else {
            format!("{} (at `{}`)", e.message(), snippet.escape_debug())
        };
        Error::input(at(line_of(&e)), message)
    })?;
    // The key the value belongs to, as the tables and arrays lead to it (`sim.hover.samples`):
    // serde's own messages ("invalid length 2, expected an array of length 3", "expected
    // usize") do not say which.
    let value: T = serde_path_to_error::deserialize(document).map_err(|e| {
        let mut key = String::new();
        for segment in e.path().iter() {
            key = match segment {
                serde_path_to_error::Segment::Seq { index } => element(&key, *index),
                serde_path_to_error::Segment::Map { key: k }
                | serde_path_to_error::Segment::Enum { variant: k } => subkey(&key, k),
                serde_path_to_error::Segment::Unknown => key + ".?",
            };
        }
        let inner = e.into_inner();
        let said = float_shown(inner.message());
        let message = if key.is_empty() || said.contains(&format!("`{key}`")) {
            said
        } else {
            format!("{key}: {said}")
        };
        Error::input(at(line_of(&inner)), message)
    })?;
    // A fixed-size array (`[f64; 3]`) takes the first values of a longer one and drops the
    // rest: the resolved value, written back, holds what was kept.
    if let (Ok(given), Ok(toml::Value::Table(kept))) =
        (text.parse::<toml::Table>(), toml::Value::try_from(&value))
        && let Some((key, n, m)) = array_kept_short(&given, &kept, "")
    {
        return Err(Error::input(
            at(line_of_key(text, &key)),
            format!("{key} has {n} values, {m} expected"),
        ));
    }
    Ok(value)
}

/// The line (from 1) that sets `key` (`plan.frames.vehicle_in_world.xyz_m`, `arm.links[2].dh`,
/// elements counted from 1; an index after the last name is the array's element, not a
/// table's): under its table's
/// header, or as a dotted key. A key inside an inline table gives the first line setting a key
/// of its own name.
fn line_of_key(text: &str, key: &str) -> Option<usize> {
    // The key without its own element index: `a.b[2]` → `a.b`.
    let key = match key.rfind('[') {
        Some(i) if !key[i..].contains('.') => &key[..i],
        _ => key,
    };
    let last = key.rsplit('.').next().unwrap_or(key);
    let sets = |l: &str, k: &str| l.strip_prefix(k).is_some_and(|r| r.trim_start().starts_with('='));
    let mut table = String::new();
    // The arrays of tables seen so far and their element counts.
    let mut arrays: Vec<(String, usize)> = Vec::new();
    let mut first_of_name = None;
    for (i, line) in text.lines().enumerate() {
        let l = line.trim_start();
        if let Some(name) = l.strip_prefix("[[").and_then(|r| r.split("]]").next()) {
            let name = name.trim().to_string();
            let n = match arrays.iter_mut().find(|(a, _)| *a == name) {
                Some((_, n)) => {
                    *n += 1;
                    *n
                }
                None => {
                    arrays.push((name.clone(), 1));
                    1
                }
            };
            table = format!("{name}[{n}]");
        } else if let Some(name) = l.strip_prefix('[').and_then(|r| r.split(']').next()) {
            let name = name.trim();
            // A sub-table of an array of tables belongs to its latest element.
            table = arrays
                .iter()
                .find_map(|(a, n)| {
                    name.strip_prefix(a.as_str())
                        .and_then(|r| r.strip_prefix('.'))
                        .map(|r| format!("{a}[{n}].{r}"))
                })
                .unwrap_or_else(|| name.to_string());
        } else if let Some(rest) = key.strip_prefix(table.as_str())
            && (table.is_empty() || rest.starts_with('.'))
            && sets(l, rest.trim_start_matches('.'))
        {
            return Some(i + 1);
        } else if first_of_name.is_none() && sets(l, last) {
            first_of_name = Some(i + 1);
        }
    }
    first_of_name
}

/// The key `name` under `parent` (`parent.name`; `name` at the top level).
fn subkey(parent: &str, name: &str) -> String {
    if parent.is_empty() {
        name.to_string()
    } else {
        format!("{parent}.{name}")
    }
}

/// The element `index` (from 0) of the array `parent`, as messages name it: counted from 1, as
/// a reader counts `[[arm.links]]` tables.
fn element(parent: &str, index: usize) -> String {
    format!("{parent}[{}]", index + 1)
}

/// The first array of `given` whose kept value (the same key in `kept`) is shorter: its key,
/// and the lengths given and kept.
fn array_kept_short(given: &toml::Table, kept: &toml::Table, prefix: &str) -> Option<(String, usize, usize)> {
    given
        .iter()
        .find_map(|(k, g)| value_kept_short(g, kept.get(k)?, subkey(prefix, k)))
}

fn value_kept_short(given: &toml::Value, kept: &toml::Value, key: String) -> Option<(String, usize, usize)> {
    match (given, kept) {
        (toml::Value::Table(g), toml::Value::Table(k)) => array_kept_short(g, k, &key),
        (toml::Value::Array(g), toml::Value::Array(k)) if g.len() != k.len() => Some((key, g.len(), k.len())),
        (toml::Value::Array(g), toml::Value::Array(k)) => g
            .iter()
            .zip(k)
            .enumerate()
            .find_map(|(i, (g, k))| value_kept_short(g, k, element(&key, i))),
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

/// `Ok` if `path` is a regular file (an input given as `what`: "a PLY file", "a TOML file").
///
/// # Errors
/// [`Error::Input`] naming the file: missing, a directory, or not a regular file (a device or
/// a pipe, which could be endless or never end).
pub fn regular_file(path: &Path, what: &str) -> Result<()> {
    let fail = |reason: String| Error::input(path.display(), reason);
    let meta = std::fs::metadata(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => fail("no such file".into()),
        _ => fail(format!("cannot open: {e}")),
    })?;
    if meta.is_dir() {
        return Err(fail(format!("is a directory, not {what}")));
    }
    if !meta.is_file() {
        return Err(fail("is not a regular file".into()));
    }
    Ok(())
}

/// serde's message with the real value it quotes (`floating point \`1000…0\``, a float given
/// for an integer) as [`shown`]: 1e300 is not three hundred digits.
fn float_shown(message: &str) -> String {
    const QUOTE: &str = "floating point `";
    let Some(start) = message.find(QUOTE).map(|i| i + QUOTE.len()) else {
        return message.to_string();
    };
    let Some(len) = message[start..].find('`') else {
        return message.to_string();
    };
    match message[start..start + len].parse::<f64>() {
        Ok(v) => format!("{}{}{}", &message[..start], shown(v), &message[start + len..]),
        Err(_) => message.to_string(),
    }
}

/// A text file's contents, without a leading byte-order mark.
///
/// # Errors
/// [`Error::Input`] naming the file: as [`regular_file`] (the PLY reader refuses the same),
/// unreadable, or not UTF-8 text, then `not {what}` (a PLY or other binary file given for a configuration,
/// a trajectory, a pose), not the reader's "stream did not contain valid UTF-8".
pub fn read_text(path: &Path, what: &str) -> Result<String> {
    regular_file(path, what)?;
    let text = std::fs::read_to_string(path).map_err(|e| {
        let why = if e.kind() == std::io::ErrorKind::InvalidData {
            format!("not {what} (not UTF-8 text: a PLY or other binary file?)")
        } else {
            format!("cannot read: {e}")
        };
        Error::input(path.display(), why)
    })?;
    // A spreadsheet's or an editor's byte-order mark is no part of the text.
    Ok(match text.strip_prefix('\u{feff}') {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

/// A value for a message: as written for everyday magnitudes, in exponent form beyond them
/// (`1e300`, not three hundred digits).
pub fn shown(v: f64) -> String {
    if everyday(v) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// [`shown`] of `v` rounded to `digits` significant digits: a size of any magnitude in a
/// message, never `0.000`.
pub fn shown_significant(v: f64, digits: usize) -> String {
    let rounded: f64 = format!("{:.*e}", digits.saturating_sub(1), v)
        .parse()
        .unwrap_or(v);
    shown(rounded)
}

/// Whether `v` is written out in full in a message (zero, not finite, or of an everyday
/// magnitude) rather than in exponent form.
fn everyday(v: f64) -> bool {
    v == 0.0 || !v.is_finite() || (1e-4..1e7).contains(&v.abs())
}

/// [`shown`] with `decimals` decimals for everyday magnitudes (a position in metres to the
/// millimetre), in exponent form beyond them.
pub fn shown_to(v: f64, decimals: usize) -> String {
    if everyday(v) {
        format!("{v:.decimals$}")
    } else {
        format!("{v:.3e}")
    }
}

/// A vector `[x, y, z]` for a message, each as [`shown_to`].
pub fn shown_xyz(v: &[f64; 3], decimals: usize) -> String {
    let [x, y, z] = v.map(|c| shown_to(c, decimals));
    format!("[{x}, {y}, {z}]")
}

/// The largest magnitude of a real value in a configuration or model: past any scene, vehicle,
/// sensor, gain or material in SI units (a thousand kilometres, a million tonnes), short of the
/// magnitudes whose products lose all precision or overflow. A value beyond it could only make a
/// run diverge, or a plan overflow, after earlier stages have written their products.
pub const MAX_VALUE: f64 = 1e9;

/// `Ok` if every real number of `value` (serialised as TOML; counts and seeds are integers and
/// left out) is within ±[`MAX_VALUE`], else an input error naming the first beyond by its key
/// under `prefix` (`arm.links[2].mass`, elements counted from 1).
///
/// # Errors
/// [`Error::Input`] naming the key.
pub fn within_range<T: Serialize>(value: &T, prefix: &str) -> Result<()> {
    fn walk(v: &toml::Value, key: &str) -> Option<(String, f64)> {
        match v {
            toml::Value::Float(x) if x.abs() > MAX_VALUE => Some((key.to_string(), *x)),
            toml::Value::Table(t) => t.iter().find_map(|(k, v)| walk(v, &subkey(key, k))),
            toml::Value::Array(a) => a.iter().enumerate().find_map(|(i, v)| walk(v, &element(key, i))),
            _ => None,
        }
    }
    match toml::Value::try_from(value).ok().and_then(|v| walk(&v, "")) {
        Some((key, v)) => within_max(v, || format!("{prefix}{key}")),
        None => Ok(()),
    }
}

/// `Ok` if the real value `v` is within ±[`MAX_VALUE`] (or NaN, left to its own check), else an
/// input error naming `what()` (a key, or a file's line and column; made only then).
///
/// # Errors
/// [`Error::Input`] naming `what()`.
pub fn within_max<D: std::fmt::Display>(v: f64, what: impl FnOnce() -> D) -> Result<()> {
    if v.abs() > MAX_VALUE {
        return Err(Error::input(
            what(),
            format!(
                "{} is beyond any scene, vehicle, sensor or material in SI units (every real value is within ±{MAX_VALUE:.0e})",
                shown(v)
            ),
        ));
    }
    Ok(())
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
    fn an_array_of_the_wrong_length_or_a_wrong_value_is_an_error_naming_its_key() {
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
                "rows[1].inertia[2] has 3 values, 2 expected",
                2,
            ),
            // The line under the key's own table, not the first line setting a key of its name.
            (
                "[inner]\nxyz_m = [1.0, 2.0, 3.0]\n[[rows]]\nxyz_m = [1.0, 2.0, 3.0]\n[[rows]]\nradius_m = 1.0\nxyz_m = [1.0, 2.0, 3.0, 4.0]\n",
                "rows[2].xyz_m has 4 values",
                7,
            ),
            // Too short and of the wrong type or sign: serde's message, with the key.
            (
                "[inner]\nxyz_m = [1.0, 2.0]\n",
                "inner.xyz_m: invalid length 2",
                2,
            ),
            ("seed = -1\n", "seed: invalid value: integer `-1`", 1),
            (
                "[[rows]]\n[[rows]]\nradius_m = \"1\"\n",
                "rows[2].radius_m: invalid type",
                3,
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

    /// A directory or a device given for a text file is refused up front (an endless device
    /// was read until memory ran out; a pipe without a writer never returned).
    #[test]
    fn a_directory_or_a_device_is_not_a_text_file() {
        let dir = tempfile::tempdir().unwrap();
        // A byte-order mark is read past (a trajectory's header was "expected" after it).
        let bom = dir.path().join("bom.csv");
        std::fs::write(&bom, "\u{feff}t_s,x_m\n").unwrap();
        assert_eq!(read_text(&bom, "a CSV file").unwrap(), "t_s,x_m\n");
        let e = read_text(dir.path(), "a TOML file").unwrap_err();
        assert!(e.to_string().ends_with("is a directory, not a TOML file"), "{e}");
        #[cfg(unix)]
        {
            let e = read_text(Path::new("/dev/zero"), "a TOML file").unwrap_err();
            assert_eq!(e.to_string(), "/dev/zero: is not a regular file");
        }
    }

    #[test]
    fn huge_and_tiny_values_are_shown_in_exponent_form() {
        assert_eq!(shown(-1e300), "-1e300");
        assert_eq!(
            (shown_to(1.23456, 3), shown_to(1e300, 3)),
            ("1.235".into(), "1.000e300".into())
        );
        assert_eq!(shown(2.5e-9), "2.5e-9");
        assert_eq!(
            (shown(0.0), shown(3600.5), shown(f64::NAN)),
            ("0".into(), "3600.5".into(), "NaN".into())
        );
        let msg = non_negative("k", -1e300).unwrap_err().to_string();
        assert!(msg.ends_with("got -1e300"), "{msg}");
        // A size of any magnitude to its significant digits, never 0.000.
        assert_eq!(
            [0.000_254_9, 170.33, 2.5e-7, 0.999_96].map(|v| shown_significant(v, 3)),
            ["0.000255", "170", "2.5e-7", "1"]
        );
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
        // A float for an integer is quoted as the other values are, not in 301 digits.
        let err = from_toml_str::<Demo>("seed = 1e300\n", "x.toml").unwrap_err();
        assert_eq!(
            err.to_string(),
            "x.toml line 1: seed: invalid type: floating point `1e300`, expected u64"
        );
        // A syntax error names the text it is at: which key is twice.
        let err = from_toml_str::<Demo>("seed = 3\nseed = 4\n", "x.toml").unwrap_err();
        assert_eq!(err.to_string(), "x.toml line 2: duplicate key (at `seed`)");
    }
}
