//! Shared helpers of the `mpm` program's tests.
#![allow(dead_code)]

pub mod program;
#[path = "../../../tests/common/scratch.rs"]
pub mod scratch;
#[allow(unused_imports)]
pub use scratch::unique_temp_dir;
