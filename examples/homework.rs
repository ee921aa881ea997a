//! The seed assignment (ME 7953 Project II): every question 1(A)–4(F) answered through the
//! library's matrix-form API, in the assignment's order.
//!
//! ```text
//! cargo run --release --example homework            # readable answers
//! cargo run --release --example homework -- --json  # one JSON object with every quantity
//! ```
//!
//! The computation is `sparse_mpm_study::homework::solve` (src/homework.rs), written top-down as the
//! assignment reads; docs/homework.md maps each question to the functions it calls.

use std::io::Write;

fn main() {
    let json = std::env::args().skip(1).any(|a| a == "--json");
    let answers = match sparse_mpm_study::homework::solve() {
        Ok(answers) => answers,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let text = if json {
        serde_json::to_string_pretty(&answers.to_json()).expect("JSON values always serialize") + "\n"
    } else {
        answers.report()
    };
    // A closed pipe (`| head`) is not an error worth a panic.
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
}
