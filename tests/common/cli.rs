//! Running the `clpt` binary in end-to-end tests (the hostile-input suites and others): a run,
//! a run bounded in time, a scratch folder, and the checks of a refusal.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs clpt with `args`, to its end.
pub fn clpt(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_clpt"))
        .args(args)
        .output()
        .unwrap()
}

/// Runs clpt with `args` in `dir`; fails the test if it has not ended within `limit`.
pub fn clpt_within(dir: &Path, args: &[&str], limit: Duration) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_clpt"))
        .args(args)
        .current_dir(dir)
        .env_remove("CLPT_DEVICE")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > limit {
            child.kill().unwrap();
            let out = child.wait_with_output().unwrap();
            panic!(
                "clpt {args:?} still running after {limit:?}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// An empty folder of this test process for `name`.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("clpt-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The run was refused as a user's error: exit status 1, one `Error` line that contains
/// `reason`, no panic.
pub fn refused(out: &Output, reason: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr:.2000}");
    assert!(
        stderr.contains(reason) && !stderr.contains("panicked"),
        "wanted {reason:?} in: {stderr:.2000}"
    );
    assert_eq!(stderr.matches("Error").count(), 1, "{stderr:.2000}");
}
