//! What an input asks of memory is refused before it is allocated where this process cannot
//! have it, with `--allow-large` too: an allocation that fails aborts the process (a shell's
//! run, a notebook's kernel, a worker), an error does not.

use std::process::Command;

mod common;
use common::program::{scratch, text, MPM};

/// A scene of 3.6·10⁷ particles on 1.6·10⁷ nodes (about 30 GiB by the estimate).
const LARGE: &str = r#"title = "large"
[grid]
origin = [0.0, 0.0]
cell_size = [0.001, 0.001]
cells = [4000, 4000]
[time]
end = 0.001
[[bodies]]
name = "block"
material = { model = "linear_elastic", youngs_modulus = 1e6, poisson_ratio = 0.3 }
density = 1000.0
particles_per_cell = 2
geometry = { rectangle = { min = [0.5, 0.5], max = [3.5, 3.5] } }
"#;

#[test]
fn a_scene_larger_than_the_memory_a_process_may_have_is_refused_with_allow_large_too() {
    let dir = scratch("memory", "ulimit");
    std::fs::write(dir.join("large.toml"), LARGE).unwrap();
    for command in ["check", "run --out o -q"] {
        // 3 GB of address space: the build would abort on its first large array.
        let script = format!("ulimit -v 3000000 && exec \"{MPM}\" {command} large.toml --allow-large");
        let o = Command::new("sh")
            .arg("-c")
            .arg(&script)
            .current_dir(&dir)
            .output()
            .unwrap();
        assert_eq!(
            o.status.code(),
            Some(1),
            "{command}: not a plain error exit: {}",
            text(&o)
        );
        for part in ["would need about", "this process can have", "ulimit -v"] {
            assert!(text(&o).contains(part), "{command}: `{part}` not in: {}", text(&o));
        }
    }
}

#[test]
fn the_memory_bound_refuses_what_no_machine_has_and_passes_what_any_has() {
    if sparse_mpm::limits::available_memory().is_none() {
        eprintln!("this system does not say how much memory a process may have");
        return;
    }
    let refused = sparse_mpm::limits::ensure_memory(1e20, || "a test".into()).unwrap_err();
    let message = refused.to_string();
    assert!(message.starts_with("a test would need about"), "{message}");
    assert!(sparse_mpm::limits::ensure_memory(1024.0, || "a test".into()).is_ok());
}
