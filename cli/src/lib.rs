//! # sparse-mpm-cli
//!
//! The applications of [`sparse_mpm`] behind the `mpm` program: a scene run to a folder
//! ([`run`]: VTK snapshots, a ParaView time series, `report.csv`, checkpoints and resumption),
//! the VTK XML files themselves ([`vtk`]: written and read back), pictures of a run without
//! ParaView ([`render`]: PNG frames, an animated GIF, plots of the report) and the timing of the
//! peers' benchmark problem ([`mod@bench`]). The study and the verification problems are in
//! `sparse-mpm-study`.
#![deny(missing_docs)]

pub mod bench;
pub mod render;
pub mod run;
pub mod vtk;
