//! Helpers shared by the integration tests.
#![allow(dead_code)]

use std::path::PathBuf;

/// The real scans made by others (`../shared/data/real`), found through `UVMS_REAL_DATA`.
///
/// Unset (a user's fresh clone): prints a note and returns `None`, and the caller skips.
/// Set but missing (a broken CI setup): panics, failing the test.
pub fn real_data(file: &str) -> Option<PathBuf> {
    match std::env::var_os("UVMS_REAL_DATA") {
        None => {
            eprintln!("note: UVMS_REAL_DATA is not set; skipping the test on real data {file}");
            None
        }
        Some(dir) => {
            let path = PathBuf::from(dir).join(file);
            assert!(
                path.is_file(),
                "UVMS_REAL_DATA is set but {} does not exist",
                path.display()
            );
            Some(path)
        }
    }
}

/// Path of the `uvms` binary built for the integration tests.
pub fn uvms_bin() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_uvms"))
}
