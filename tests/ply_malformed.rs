//! The malformed-PLY corpus (`tests/data/malformed/`, made by `make_corpus.py` there): `uvms info`
//! on each file exits with code 2 and prints exactly one line on stderr that names the file and
//! the problem; nothing panics.
//!
//! Every run is made under a 150 MB address-space limit (`ulimit -v`). Two files claim 10^8 and
//! 10^12 vertices in 200 bytes: a reader that sized a buffer by the header's count (2.4 GB and
//! 24 TB as f64 points) would abort under that limit instead of exiting with code 2.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// (file, phrase the one-line message must contain).
const CORPUS: &[(&str, &str)] = &[
    ("empty.ply", "empty file"),
    ("bad_magic.ply", "bad magic"),
    ("binary_garbage.ply", "bad magic"),
    ("missing_end_header.ply", "missing 'end_header'"),
    ("unknown_format.ply", "unknown format 'binary_middle_endian'"),
    ("bad_version.ply", "unsupported format version '2.0'"),
    ("no_format.ply", "no 'format' line"),
    ("unknown_keyword.ply", "unknown header keyword 'propety'"),
    ("unknown_type.ply", "unknown property type 'real'"),
    (
        "bad_element_count.ply",
        "count '-5' is not a non-negative integer",
    ),
    ("duplicate_element.ply", "duplicate element 'vertex'"),
    ("property_before_element.ply", "property before any element"),
    ("no_vertex_element.ply", "no 'vertex' element"),
    ("missing_z.ply", "no 'z' property"),
    ("int_xyz.ply", "unsupported type 'int'"),
    ("truncated_binary.ply", "payload too short"),
    (
        "truncated_ascii.ply",
        "truncated payload: element 'vertex' ends after 2 of 3 records",
    ),
    (
        "truncated_faces_binary.ply",
        "truncated payload: list length 3 in record 1",
    ),
    (
        "truncated_faces_ascii.ply",
        "truncated payload: element 'face' ends after 1 of 2 records",
    ),
    ("bad_ascii_number.ply", "'zero' is not a valid float"),
    ("face_index_out_of_range.ply", "vertex index 7 out of range"),
    ("face_negative_index.ply", "vertex index -1 out of range"),
    (
        "face_two_indices.ply",
        "has 2 vertex indices; a polygon needs at least 3",
    ),
    ("list_length_negative.ply", "impossible list length -3"),
    ("list_length_too_long.ply", "impossible list length 4000000000"),
    ("list_float_count.ply", "non-integer count type 'float'"),
    ("face_float_indices.ply", "must be a list of integers"),
    ("face_before_vertex.ply", "'face' comes before element 'vertex'"),
    ("oversized_faces.ply", "declares 100000000 records"),
    ("oversized_count_ascii.ply", "declares 100000000 records"),
    ("oversized_count_1e8.ply", "declares 100000000 records"),
    ("oversized_count.ply", "declares 1000000000000 records"),
];

fn corpus_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/malformed")
}

/// Runs `uvms info PATH` under a 150 MB address-space limit; returns (exit code, stderr).
fn info(path: &Path) -> (Option<i32>, String) {
    let out = Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 150000 && exec \"$0\" info \"$1\"")
        .arg(common::uvms_bin())
        .arg(path)
        .output()
        .expect("run uvms");
    assert!(out.stdout.is_empty(), "{}: stdout not empty", path.display());
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn assert_one_line_error(path: &Path, phrase: &str) {
    let (code, err) = info(path);
    assert_eq!(code, Some(2), "{}: exit {code:?}, stderr {err}", path.display());
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.lines().count(), 1, "{}: not one line: {err}", path.display());
    let name = path.file_name().unwrap().to_string_lossy();
    assert!(
        err.starts_with("error: ") && err.contains(&*name),
        "file not named: {err}"
    );
    assert!(
        err.contains(phrase),
        "{}: expected '{phrase}' in: {err}",
        path.display()
    );
}

#[test]
fn every_malformed_file_is_one_line_and_exit_2() {
    let dir = corpus_dir();
    for &(file, phrase) in CORPUS {
        assert_one_line_error(&dir.join(file), phrase);
    }
    // Every .ply in the folder is in the list (no file silently untested).
    let on_disk = std::fs::read_dir(&dir)
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "ply"))
        .count();
    assert_eq!(on_disk, CORPUS.len());
}

#[test]
fn oversized_counts_are_checked_against_the_file_size() {
    let path = corpus_dir().join("oversized_count.ply");
    assert_eq!(std::fs::metadata(&path).unwrap().len(), 200);
    assert_one_line_error(&path, "only 73 bytes follow the header");
}

#[test]
fn directory_and_missing_paths() {
    assert_one_line_error(&corpus_dir(), "is a directory");
    assert_one_line_error(&corpus_dir().join("no_such_file.ply"), "no such file");
}

#[test]
fn a_valid_file_still_reads_under_the_same_memory_limit() {
    let (code, err) = info(&corpus_dir().join("../valid_quad.ply"));
    assert_eq!(code, Some(0), "{err}");
    assert!(err.contains("faces        1 (2 triangles"), "{err}");
}

#[cfg(target_os = "linux")]
#[test]
fn a_device_is_not_read() {
    assert_one_line_error(Path::new("/dev/zero"), "is not a regular file");
}
