//! A run stopped by a signal: exit 130 with one line on stderr, the file it was writing removed,
//! the files it had finished complete, and nothing written after the signal.

mod common;

use std::fs;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use uvms::io::ply::read_ply;

/// The temporary files (`.NAME.PID.tmp`) in `dir`.
fn temporaries(dir: &Path) -> Vec<String> {
    let Ok(entries) = fs::read_dir(dir) else {
        return Vec::new();
    };
    entries
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

/// Starts `uvms synth` (three PLY files of megabytes), waits until one of its files is being
/// written, sends `signal` and checks what is left. Returns false if the run ended before a
/// file could be caught being written.
fn interrupt_while_writing(signal: &str) -> bool {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut child = Command::new(common::uvms_bin())
        .args(["synth", "--scene", "bottle", "--quiet", "--out"])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if !temporaries(&out).is_empty() {
            break;
        }
        if child.try_wait().unwrap().is_some() || start.elapsed() > Duration::from_secs(300) {
            let _ = child.kill();
            let _ = child.wait();
            return false;
        }
    }
    let killed = Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success(), "kill {signal}");
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(130), "{signal}: {stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    assert_eq!(
        temporaries(&out),
        Vec::<String>::new(),
        "{signal}: left half-written"
    );
    // The run's last files are written after its products: none of them can have been.
    assert!(!out.join("summary.json").exists() && !out.join("config.toml").exists());
    // Whatever it had finished is whole.
    for entry in fs::read_dir(&out).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "ply") {
            read_ply(&path).unwrap_or_else(|e| panic!("{signal}: {e}"));
        }
    }
    true
}

#[test]
fn a_signal_stops_the_run_and_removes_the_file_being_written() {
    for signal in ["-INT", "-TERM"] {
        // The writes take milliseconds; the poll catches one nearly every time.
        assert!(
            (0..10).any(|_| interrupt_while_writing(signal)),
            "{signal}: no file caught being written in ten runs"
        );
    }
}
