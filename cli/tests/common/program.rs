//! Helpers of the tests that run the `mpm` program.

use std::path::Path;
use std::process::{Command, Output};

use super::scratch::Scratch;

/// The `mpm` program cargo built for these tests.
pub const MPM: &str = env!("CARGO_BIN_EXE_mpm");

/// Runs `mpm args` in `dir` and returns what it did.
pub fn mpm(args: &[&str], dir: &Path) -> Output {
    Command::new(MPM)
        .args(args)
        .current_dir(dir)
        .output()
        .expect("the mpm binary runs")
}

/// Standard output and standard error, as text.
pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// `o`, after asserting it succeeded (its output in the message otherwise).
pub fn ok(o: Output) -> Output {
    assert!(o.status.success(), "{}", text(&o));
    o
}

/// A fresh folder `<temp>/sparse_mpm_<suite>_<name>_<pid>` for one test, removed when it passes.
pub fn scratch(suite: &str, name: &str) -> Scratch {
    Scratch::new(suite, name)
}
