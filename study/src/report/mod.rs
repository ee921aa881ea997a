//! The Markdown report of a study: one section per part, with the plots it embeds and the
//! tables and fitted orders that state what they show.

use std::path::{Path, PathBuf};

use super::plot::{self, Chart, Series, SeriesStyle};
use super::{Part, StudyRun};
use crate::verification::{fitted_order, Outcome};
use sparse_mpm::error::{MpmError, Result};

mod cantilever;
mod collapse;
mod column;
mod convergence;
mod energy;
mod frequency;
mod implicit;
mod single_point;
mod spectrum;
mod stabilization;
mod time_step;

/// A run that finished, with what it measured.
type Finished<'a> = (&'a StudyRun, &'a Outcome);

/// Finished runs grouped by their choices' label, in first-seen order.
type Groups<'a> = [(String, Vec<Finished<'a>>)];

/// Where a section is written: the report's Markdown so far, the folder the plots go to and
/// the plots written so far.
struct Page<'a> {
    md: &'a mut String,
    out: &'a Path,
    plots: &'a mut Vec<PathBuf>,
}

impl Page<'_> {
    /// Writes `chart` as `out/name.png`, records it, and appends the Markdown that embeds it.
    fn embed(&mut self, chart: &Chart, name: &str) -> Result<()> {
        let markdown = save(chart, self.out, name, self.plots)?;
        self.md.push_str(&markdown);
        Ok(())
    }
}

/// Writes the section of `part` from its runs (`runs`, failed ones included and skipped) into
/// `md`, its plots into `out` (recorded in `plots`).
pub(super) fn section(
    part: Part,
    runs: &[&StudyRun],
    out: &Path,
    md: &mut String,
    plots: &mut Vec<PathBuf>,
) -> Result<()> {
    let ok = ok_runs(runs);
    let mut page = Page { md, out, plots };
    match part {
        Part::Frequency => frequency::write(&ok, &mut page),
        Part::BarEnergy => energy::write_bar(&ok, &mut page),
        Part::Convergence => convergence::write(&ok, &mut page),
        Part::Energy => energy::write_two_disks(&ok, &mut page),
        Part::TimeStep => time_step::write(&ok, &mut page),
        Part::Cantilever => cantilever::write(&ok, &mut page),
        Part::Column => column::write(&ok, &mut page),
        Part::Collapse => collapse::write(&ok, &mut page),
        Part::Implicit => implicit::write(&ok, &mut page),
        Part::SinglePoint => {
            single_point::write(&ok, page.md);
            Ok(())
        }
        Part::Stabilization => {
            stabilization::write(runs, &ok, page.md);
            Ok(())
        }
        Part::Dispersion => spectrum::write_dispersion(&ok, &mut page),
        Part::Waves => spectrum::write_waves(&ok, &mut page),
        Part::TimeOrder => spectrum::write_time_order(&ok, &mut page),
    }
}

/// Writes `chart` as `out/name.png`, records it, and returns the Markdown that embeds it.
fn save(chart: &Chart, out: &Path, name: &str, plots: &mut Vec<PathBuf>) -> Result<String> {
    let path = out.join(format!("{name}.png"));
    plot::write_png(chart, &path, 900, 600).map_err(|e| MpmError::Io {
        path: path.clone(),
        source: std::io::Error::other(e.to_string()),
    })?;
    plots.push(path);
    Ok(format!("![{}]({name}.png)\n", chart.title))
}

/// The runs that finished, with their outcomes, in the order given.
fn ok_runs<'a>(runs: &[&'a StudyRun]) -> Vec<Finished<'a>> {
    runs.iter()
        .filter_map(|r| r.outcome.as_ref().ok().map(|o| (*r, o)))
        .collect()
}

/// Runs grouped by their choices' label, in first-seen order.
fn by_label<'a>(runs: &[Finished<'a>]) -> Vec<(String, Vec<Finished<'a>>)> {
    let mut groups: Vec<(String, Vec<_>)> = Vec::new();
    for &(r, o) in runs {
        let label = r.choices.label();
        match groups.iter_mut().find(|(l, _)| *l == label) {
            Some((_, g)) => g.push((r, o)),
            None => groups.push((label, vec![(r, o)])),
        }
    }
    groups
}

/// A chart without series yet; `log` sets both axes logarithmic.
fn empty_chart(title: &str, x_label: &str, y_label: &str, log: bool) -> Chart {
    Chart {
        title: title.into(),
        x_label: x_label.into(),
        y_label: y_label.into(),
        log_x: log,
        log_y: log,
        series: Vec::new(),
    }
}

/// A series drawn as a line with markers.
fn series(label: String, points: Vec<(f64, f64)>) -> Series {
    Series {
        label,
        points,
        style: SeriesStyle::LineAndMarkers,
    }
}

/// The order fitted to `(size, error)` points with two decimals, or "–" when none fits.
fn fmt_order(points: &[(f64, f64)]) -> String {
    fitted_order(points).map_or("–".into(), |p| format!("{p:.2}"))
}

/// The masses of a run: one label when both solves use the same scheme.
fn mass_label(r: &StudyRun) -> String {
    let m = &r.choices.mass;
    if m.velocity == m.acceleration {
        format!("{:#}", m.velocity)
    } else {
        format!("{:#} / {:#}", m.velocity, m.acceleration)
    }
}

/// "8 cells | 16 cells | …": the table columns of the first group's runs.
fn cells_header(groups: &Groups) -> String {
    groups
        .first()
        .map(|(_, g)| {
            g.iter()
                .map(|(r, _)| format!("{} cells", r.cells))
                .collect::<Vec<_>>()
                .join(" | ")
        })
        .unwrap_or_default()
}

/// The rule under a table header: a label column, one column per run of the first group,
/// and `trailing` more columns.
fn header_rule(groups: &Groups, trailing: usize) -> String {
    let columns = groups.first().map_or(0, |g| g.1.len()) + trailing;
    format!("|---|{}", "---|".repeat(columns))
}
