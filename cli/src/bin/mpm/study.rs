//! `mpm study`: the whole study in one process, or planned, run in shares and merged.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use sparse_mpm_study::{merge_study, plan_study, run_share, run_study, Part, Share, StudyProgress, StudySpec};

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true)]
pub(crate) struct StudyArgs {
    #[command(subcommand)]
    action: Option<StudyAction>,
    #[command(flatten)]
    spec: SpecArgs,
    /// Output folder [default: out/study].
    #[arg(long, short = 'o', value_name = "DIR")]
    out: Option<PathBuf>,
    /// No progress bar or summary.
    #[arg(long, short = 'q')]
    quiet: bool,
}

/// What a study runs: the spec file, the parts, quick grids.
#[derive(Args, Debug)]
struct SpecArgs {
    /// A TOML file setting any of the study's keys: each key, its type, range and default in
    /// docs/verification.md, "Study spec keys".
    #[arg(long, value_name = "STUDY.toml")]
    spec: Option<PathBuf>,
    /// Comma-separated parts to run [default: all].
    #[arg(long, value_name = "a,b", value_delimiter = ',')]
    parts: Option<Vec<String>>,
    /// Smaller grids: a few seconds.
    #[arg(long)]
    quick: bool,
}

#[derive(Subcommand, Debug)]
enum StudyAction {
    /// Write the study's runs (DIR/plan.json, DIR/plan.csv: one row per run with its id and
    /// parameters) without running them.
    Plan {
        #[command(flatten)]
        spec: SpecArgs,
        /// The study folder (created).
        #[arg(long, short = 'o', value_name = "DIR")]
        out: PathBuf,
        /// No summary.
        #[arg(long, short = 'q')]
        quiet: bool,
    },
    /// Run a share of a planned study (each run into DIR/runs/ID/), skipping runs already
    /// complete: re-submitting a job finishes only what is missing.
    Run {
        /// The study folder `mpm study plan` wrote.
        dir: PathBuf,
        /// Shard K of N (1 ≤ K ≤ N): the runs of plan index i with i mod N = K − 1.
        #[arg(
            long,
            value_name = "K/N",
            conflicts_with = "index",
            required_unless_present = "index",
            value_parser = parse_shard
        )]
        shard: Option<Share>,
        /// The one run of this 0-based plan index.
        #[arg(long, value_name = "I")]
        index: Option<usize>,
        /// No progress bar or summary.
        #[arg(long, short = 'q')]
        quiet: bool,
    },
    /// Gather the complete runs into DIR/runs.csv, the plots and DIR/report.md, listing the runs
    /// missing; exits with status 3 when some are missing, unless --allow-missing.
    Merge {
        /// The study folder.
        dir: PathBuf,
        /// Exit with status 0 even when runs are missing (the report lists them).
        #[arg(long)]
        allow_missing: bool,
        /// No summary.
        #[arg(long, short = 'q')]
        quiet: bool,
    },
}

/// `--shard K/N`, checked while the command line is read (a bad value exits with status 2).
fn parse_shard(text: &str) -> Result<Share, String> {
    Share::parse_shard(text).map_err(|e| match e {
        sparse_mpm::MpmError::InvalidOption { reason, .. } => reason,
        other => other.to_string(),
    })
}

/// The exit status of a command line that asks for what cannot be (as clap's own errors).
const USAGE: u8 = 2;

/// The spec the options describe.
fn spec_of(args: &SpecArgs) -> Result<StudySpec, String> {
    let mut spec = match &args.spec {
        Some(path) => {
            let text = sparse_mpm::io::read_bounded_text(path, sparse_mpm::scene::MAX_SCENE_BYTES, "study spec")
                .map_err(|e| e.to_string())?;
            StudySpec::from_toml_str(&text).map_err(|e| format!("{}: {e}", path.display()))?
        }
        None if args.quick => StudySpec::quick(),
        None => StudySpec::default(),
    };
    if let Some(list) = &args.parts {
        spec.parts = list
            .iter()
            .map(|name| {
                Part::ALL.into_iter().find(|p| p.name() == name.trim()).ok_or_else(|| {
                    let all: Vec<&str> = Part::ALL.iter().map(|p| p.name()).collect();
                    format!("--parts: unknown part `{name}` (parts: {})", all.join(", "))
                })
            })
            .collect::<Result<_, _>>()?;
    }
    Ok(spec)
}

/// A progress bar on a terminal, hidden otherwise or when `quiet`.
fn progress_bar(quiet: bool) -> ProgressBar {
    let bar = if quiet || !std::io::stderr().is_terminal() {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(0)
    };
    bar.set_style(
        ProgressStyle::with_template("[{bar:30}] {pos}/{len} {elapsed}  {wide_msg}")
            .expect("a valid template")
            .progress_chars("#>-"),
    );
    bar
}

fn show(bar: &ProgressBar) -> impl FnMut(&StudyProgress) + '_ {
    move |p| {
        bar.set_length(p.total as u64);
        bar.set_position(p.done as u64);
        bar.set_message(p.current.clone());
    }
}

/// The exit status of a merge with runs missing.
pub(crate) const MISSING_RUNS: u8 = 3;

/// `mpm study`: `Ok(status)` on success, the status 0 or [`MISSING_RUNS`].
pub(crate) fn study(args: &StudyArgs) -> Result<u8, String> {
    let start = Instant::now();
    match &args.action {
        None => {
            let spec = spec_of(&args.spec)?;
            let out = args.out.clone().unwrap_or_else(|| Path::new("out").join("study"));
            let bar = progress_bar(args.quiet);
            let summary = run_study(&spec, &out, show(&bar)).map_err(|e| e.to_string())?;
            bar.finish_and_clear();
            let failed = summary.runs.iter().filter(|r| r.outcome.is_err()).count();
            if !args.quiet {
                println!(
                    "{} runs ({failed} failed) in {:.0} s; report: {}, {} plots, every run: {}",
                    summary.runs.len(),
                    start.elapsed().as_secs_f64(),
                    summary.report.display(),
                    summary.plots.len(),
                    summary.csv.display()
                );
            }
            Ok(0)
        }
        Some(StudyAction::Plan { spec, out, quiet }) => {
            let plan = plan_study(&spec_of(spec)?, out).map_err(|e| e.to_string())?;
            if !quiet {
                println!(
                    "{} runs planned in {} (plan.csv lists them); run shares with `mpm study run {} --shard K/N`",
                    plan.runs.len(),
                    out.display(),
                    out.display()
                );
            }
            Ok(0)
        }
        Some(StudyAction::Run {
            dir,
            shard,
            index,
            quiet,
        }) => {
            let share = match (shard, index) {
                (Some(share), _) => *share,
                (None, Some(i)) => Share::Index(*i),
                (None, None) => unreachable!("clap requires --shard or --index"),
            };
            let bar = progress_bar(*quiet);
            let s = match run_share(dir, share, show(&bar)) {
                Ok(s) => s,
                // An index beyond the plan is a bad command line, told apart from a failed run.
                Err(e @ sparse_mpm::MpmError::InvalidOption { option: "--index", .. }) => {
                    bar.finish_and_clear();
                    eprintln!("error: {e}");
                    return Ok(USAGE);
                }
                Err(e) => return Err(e.to_string()),
            };
            bar.finish_and_clear();
            if !quiet {
                println!(
                    "{} runs in this share: {} run now ({} failed), {} complete before; {:.0} s",
                    s.taken,
                    s.ran,
                    s.failed,
                    s.skipped,
                    start.elapsed().as_secs_f64()
                );
            }
            Ok(0)
        }
        Some(StudyAction::Merge {
            dir,
            allow_missing,
            quiet,
        }) => {
            let m = merge_study(dir).map_err(|e| e.to_string())?;
            let failed = m.study.runs.iter().filter(|r| r.outcome.is_err()).count();
            if !quiet {
                println!(
                    "{} runs merged ({failed} failed), {} missing; report: {}, every run: {}",
                    m.study.runs.len(),
                    m.missing.len(),
                    m.study.report.display(),
                    m.study.csv.display()
                );
            }
            if !m.missing.is_empty() {
                eprintln!(
                    "{} of the plan's runs are missing (also listed in the report):",
                    m.missing.len()
                );
                for r in &m.missing {
                    eprintln!("  {} (runs/{}): {}", r.index, r.id, r.describe());
                }
                if !allow_missing {
                    return Ok(MISSING_RUNS);
                }
            }
            Ok(0)
        }
    }
}
