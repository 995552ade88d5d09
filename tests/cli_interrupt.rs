//! A run stopped by a signal: it ends as killed by that signal with one line on stderr, the file
//! it was writing removed, the files it had finished complete, and nothing written after the
//! signal; a signal it was started ignoring (`nohup`) stays ignored.
#![cfg(unix)]

mod common;

use std::fs;
use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use uvms::io::ply::read_ply;

/// The PLY files being written in `dir` (`.NAME.ply.PID.tmp`): megabytes, written for
/// milliseconds.
fn ply_being_written(dir: &Path) -> bool {
    fs::read_dir(dir).is_ok_and(|entries| {
        entries
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .any(|n| n.ends_with(".tmp") && n.contains(".ply."))
    })
}

/// The temporary files (`.NAME.PID.tmp`) in `dir` (none if it is gone: a run stopped before its
/// first product removes the folder it made).
fn temporaries(dir: &Path) -> Vec<String> {
    let Ok(entries) = fs::read_dir(dir) else {
        return Vec::new();
    };
    entries
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.ends_with(".tmp"))
        .collect()
}

/// `uvms synth` (three PLY files of megabytes) into `out`, started by `sh` with `prelude`.
fn synth(out: &Path, prelude: &str) -> Child {
    let script = format!("{prelude} exec \"$0\" synth --scene bottle --quiet --out \"$1\"",);
    Command::new("sh")
        .args(["-c", &script])
        .arg(common::uvms_bin())
        .arg(out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn send(signal: &str, child: &Child) {
    let sent = Command::new("sh")
        .args(["-c", &format!("kill -{signal} {}", child.id())])
        .status()
        .unwrap();
    assert!(sent.success(), "kill -{signal}");
}

/// Waits until `child` writes a PLY file into `out`; false if it ended first.
fn caught_writing(child: &mut Child, out: &Path) -> bool {
    let start = Instant::now();
    while !ply_being_written(out) {
        if child.try_wait().unwrap().is_some() || start.elapsed() > Duration::from_secs(300) {
            return false;
        }
        std::thread::sleep(Duration::from_micros(500));
    }
    true
}

/// Interrupts `uvms synth` with `signal` (its number `number`) while it writes a PLY file and
/// checks what is left. False if the run ended before it could be caught writing.
fn interrupt_while_writing(signal: &str, number: i32) -> bool {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mut child = synth(&out, "");
    if !caught_writing(&mut child, &out) {
        let _ = child.kill();
        let _ = child.wait();
        return false;
    }
    send(signal, &child);
    let output = child.wait_with_output().unwrap();
    if output.status.success() {
        // It finished between the catch and the signal.
        return false;
    }
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(
        output.status.signal(),
        Some(number),
        "{signal}: {:?} {stderr}",
        output.status
    );
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("interrupted by SIG"), "{stderr}");
    assert_eq!(
        temporaries(&out),
        Vec::<String>::new(),
        "{signal}: left half-written"
    );
    // The run's last files are written after its products: none of them can have been.
    assert!(!out.join("summary.json").exists() && !out.join("config.toml").exists());
    // Whatever it had finished is whole.
    for entry in fs::read_dir(&out).into_iter().flatten() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "ply") {
            read_ply(&path).unwrap_or_else(|e| panic!("{signal}: {e}"));
        }
    }
    true
}

#[test]
fn a_signal_stops_the_run_and_removes_the_file_being_written() {
    for (signal, number) in [("INT", 2), ("TERM", 15)] {
        if uvms::output::signal_ignored_at_start(number) {
            eprintln!(
                "note: SIG{signal} is ignored in this test process (a background job?): its case is skipped"
            );
            continue;
        }
        // The writes take milliseconds; the poll catches one nearly every time.
        assert!(
            (0..10).any(|_| interrupt_while_writing(signal, number)),
            "{signal}: no PLY file caught being written in ten runs"
        );
    }
}

/// Started with SIGHUP ignored (as `nohup` starts it), the run goes on through one.
#[test]
fn a_signal_ignored_at_the_start_stays_ignored() {
    let caught = (0..10).any(|_| {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let mut child = synth(&out, "trap '' HUP;");
        let caught = caught_writing(&mut child, &out);
        if caught {
            send("HUP", &child);
        }
        let output = child.wait_with_output().unwrap();
        assert!(
            output.status.success(),
            "{:?} {}",
            output.status,
            String::from_utf8_lossy(&output.stderr)
        );
        assert!(out.join("summary.json").exists());
        caught
    });
    assert!(caught, "no PLY file caught being written in ten runs");
}

/// Stopped before it writes anything, the run removes the folders it made for `--out`: the
/// signal comes as soon as the folder appears, while the scene is still being made.
#[test]
fn a_signal_before_any_file_removes_the_folders_made_for_out() {
    if uvms::output::signal_ignored_at_start(2) {
        eprintln!("note: SIGINT is ignored in this test process (a background job?): skipped");
        return;
    }
    let caught = (0..10).any(|_| {
        let dir = tempfile::tempdir().unwrap();
        let made = dir.path().join("a");
        let out = made.join("b");
        let mut child = synth(&out, "");
        let start = Instant::now();
        while !out.exists() {
            if child.try_wait().unwrap().is_some() || start.elapsed() > Duration::from_secs(300) {
                break;
            }
            std::thread::sleep(Duration::from_micros(200));
        }
        send("INT", &child);
        let output = child.wait_with_output().unwrap();
        // Caught before the first product: nothing is left, not even the folders.
        let wrote = out.exists() && fs::read_dir(&out).unwrap().next().is_some();
        if output.status.success() || wrote {
            return false;
        }
        assert_eq!(output.status.signal(), Some(2), "{output:?}");
        assert!(!made.exists(), "the folders made for --out were left");
        true
    });
    assert!(caught, "no run caught before its first file in ten runs");
}
