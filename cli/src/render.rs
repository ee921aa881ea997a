//! Pictures of a run without ParaView: PNG frames and an animated GIF of the particles coloured
//! by a field ([`render_run`], `mpm render`), and the energies and momenta of `report.csv`
//! ([`plot_report`], `mpm plot`).
//!
//! Both read only what a run folder holds: the `.pvd` series and its `.vtp` snapshots
//! ([`crate::vtk::read_pvd`], [`crate::vtk::read_vtp`]), `scene.toml` for the grid
//! (optional), `report.csv`. They draw with the same plotting stack as the study's report
//! (plotters into a pixel buffer, text in the embedded font, no system font looked up) and
//! write every file whole or not at all.
//!
//! ```no_run
//! use std::path::Path;
//! use sparse_mpm_cli::render::{plot_report, render_run, RenderOptions};
//!
//! let run = Path::new("out/two_disks");
//! let rendered = render_run(run, &RenderOptions { field: "velocity".into(), ..RenderOptions::default() })?;
//! println!("{} frames, {}", rendered.frames.len(), rendered.gif.unwrap().display());
//! plot_report(run, None)?;
//! # Ok::<(), sparse_mpm::MpmError>(())
//! ```

use std::path::{Path, PathBuf};

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use crate::vtk::{read_pvd, read_vtp, Snapshot};
use sparse_mpm::error::{MpmError, Result};
use sparse_mpm_study::plot::{
    draw_rgb, write_png_stack, write_rgb_png, Area, Chart, DrawResult, Series, SeriesStyle, FAMILY,
};

/// What [`render_run`] draws and where.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderOptions {
    /// The colouring field: an array of the snapshots (`pressure`, `J`, `mass`, …); a vector
    /// array (`velocity`, `displacement`) by its length; a component by `array:component`
    /// (`velocity:x`, `stress:xy`, `strain:yy`, or `array:k` by index). A tensor needs a component.
    pub field: String,
    /// Image width in pixels (the height follows the domain's aspect ratio).
    pub width: u32,
    /// Draw the background grid's cell lines (from `scene.toml` in the run folder).
    pub grid_lines: bool,
    /// The colour scale's `[min, max]`; `None`: the range of the field over every frame drawn.
    pub range: Option<[f64; 2]>,
    /// Draw every `every`-th snapshot (1: all); the last one is always drawn.
    pub every: usize,
    /// Frames per second of the GIF.
    pub fps: f64,
    /// Write the animated GIF (besides the PNG frames).
    pub gif: bool,
    /// The folder the pictures go to; `None`: the run folder.
    pub out: Option<PathBuf>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            field: "velocity".into(),
            width: 640,
            grid_lines: false,
            range: None,
            every: 1,
            fps: 10.0,
            gif: true,
            out: None,
        }
    }
}

/// What [`render_run`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct Rendered {
    /// The PNG frames, in time order (`<out>/frames_<field>/frame_NNNNNN.png`).
    pub frames: Vec<PathBuf>,
    /// The animated GIF (`<out>/<field>.gif`), when asked for.
    pub gif: Option<PathBuf>,
    /// The colour scale used.
    pub range: [f64; 2],
    /// The image size in pixels.
    pub size: [u32; 2],
}

/// The largest image side drawn (pixels).
pub const MAX_IMAGE_SIDE: u32 = 4096;

/// Draws the particles of every snapshot of the run in `run_dir` (its `particles.pvd`, or the
/// only `.pvd` there) coloured by `options.field`, with a colour bar, the time and the domain,
/// into PNG frames and an animated GIF.
///
/// The view is the grid of `run_dir/scene.toml` when it is there, else the particles' bounding
/// box over every frame; a particle is a disk of its `radius` array (`√V/2`), at least a pixel.
/// The colour scale (viridis) is fixed over the animation: `options.range` or the field's
/// range over every frame drawn (non-finite values are drawn grey).
///
/// # Errors
/// [`MpmError::InvalidOption`] for an unknown field (naming the arrays there), a tensor without
/// a component, a size or rate out of range; [`MpmError::Snapshot`] or [`MpmError::Io`] naming a
/// file that cannot be read or written.
pub fn render_run(run_dir: &Path, options: &RenderOptions) -> Result<Rendered> {
    let option = |option: &'static str, reason: String| MpmError::InvalidOption { option, reason };
    if !(64..=MAX_IMAGE_SIDE).contains(&options.width) {
        return Err(option(
            "width",
            format!("{} pixels: give 64 to {MAX_IMAGE_SIDE}", options.width),
        ));
    }
    if options.every == 0 {
        return Err(option("every", "0: give 1 to draw every snapshot".into()));
    }
    if !(options.fps.is_finite() && (0.1..=100.0).contains(&options.fps)) {
        return Err(option(
            "fps",
            format!("{}: give 0.1 to 100 frames per second", options.fps),
        ));
    }
    if let Some([lo, hi]) = options.range {
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(option("range", format!("[{lo}, {hi}]: give finite min < max")));
        }
    }
    let series = read_pvd(&find_series(run_dir)?)?;
    if series.is_empty() {
        return Err(MpmError::Snapshot {
            path: find_series(run_dir)?,
            reason: "the series lists no snapshot".into(),
        });
    }
    let mut chosen: Vec<&(f64, PathBuf)> = series.iter().step_by(options.every).collect();
    if chosen.last().map(|e| &e.1) != series.last().map(|e| &e.1) {
        chosen.push(series.last().unwrap());
    }
    let grid = std::fs::metadata(run_dir.join("scene.toml"))
        .ok()
        .and_then(|_| sparse_mpm::scene::Scene::load(&run_dir.join("scene.toml")).ok())
        .and_then(|scene| scene.grid().ok());

    // First pass: the field's range and the particles' extent over every frame drawn.
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let mut extent = [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
    for (_, file) in &chosen {
        let snapshot = read_vtp(file)?;
        for v in field_values(&snapshot, &options.field, file)?
            .into_iter()
            .filter(|v| v.is_finite())
        {
            (lo, hi) = (lo.min(v), hi.max(v));
        }
        for (&x, &y) in snapshot
            .x
            .iter()
            .zip(&snapshot.y)
            .filter(|(x, y)| x.is_finite() && y.is_finite())
        {
            extent = [extent[0].min(x), extent[1].max(x), extent[2].min(y), extent[3].max(y)];
        }
    }
    let range = options.range.unwrap_or_else(|| widen(lo, hi));
    // A vector drawn by its length says so.
    let first = read_vtp(&chosen[0].1)?;
    let title = match first.array(&options.field) {
        Some(a) if a.components == 3 => format!("|{}|", options.field),
        _ => options.field.clone(),
    };
    let view = match &grid {
        Some(g) => g.bounds(),
        None if extent[0] <= extent[1] => {
            let pad = 0.05 * (extent[1] - extent[0]).max(extent[3] - extent[2]).max(1e-300);
            [extent[0] - pad, extent[1] + pad, extent[2] - pad, extent[3] + pad]
        }
        None => [0.0, 1.0, 0.0, 1.0],
    };
    let layout = Layout::new(options.width, view);
    let size = [layout.width, layout.height];

    let out = options.out.clone().unwrap_or_else(|| run_dir.to_path_buf());
    let label = options.field.replace([':', '/', '\\'], "_");
    let frames_dir = out.join(format!("frames_{label}"));
    std::fs::create_dir_all(&frames_dir).map_err(|source| MpmError::Io {
        path: frames_dir.clone(),
        source,
    })?;
    let gif_path = out.join(format!("{label}.gif"));
    let mut gif = if options.gif {
        let mut encoder = gif::Encoder::new(Vec::new(), layout.width as u16, layout.height as u16, &[])
            .map_err(|e| gif_error(&gif_path, e))?;
        encoder
            .set_repeat(gif::Repeat::Infinite)
            .map_err(|e| gif_error(&gif_path, e))?;
        Some(encoder)
    } else {
        None
    };
    let delay = (100.0 / options.fps).round().clamp(1.0, 65535.0) as u16;
    let mut frames = Vec::new();
    for (k, (time, file)) in chosen.iter().enumerate() {
        let snapshot = read_vtp(file)?;
        let values = field_values(&snapshot, &options.field, file)?;
        let radius = snapshot
            .array("radius")
            .filter(|a| a.components == 1)
            .map(|a| a.values.clone())
            .or_else(|| {
                snapshot
                    .array("volume")
                    .filter(|a| a.components == 1)
                    .map(|a| a.values.iter().map(|v| 0.5 * v.sqrt()).collect())
            });
        let frame = Frame {
            snapshot: &snapshot,
            values: &values,
            radius: radius.as_deref(),
            time: *time,
            field: &title,
            range,
            grid: grid.as_ref().filter(|_| options.grid_lines),
        };
        let rgb = draw_rgb(layout.width, layout.height, |area| frame.draw(area, &layout)).map_err(|reason| {
            MpmError::Snapshot {
                path: file.clone(),
                reason: format!("cannot draw: {reason}"),
            }
        })?;
        let png = frames_dir.join(format!("frame_{k:06}.png"));
        write_rgb_png(&png, &rgb, layout.width, layout.height).map_err(|reason| MpmError::Snapshot {
            path: png.clone(),
            reason,
        })?;
        frames.push(png);
        if let Some(encoder) = gif.as_mut() {
            let mut frame = gif::Frame::from_rgb_speed(layout.width as u16, layout.height as u16, &rgb, 10);
            frame.delay = if k + 1 == chosen.len() {
                delay.saturating_mul(10)
            } else {
                delay
            };
            encoder.write_frame(&frame).map_err(|e| gif_error(&gif_path, e))?;
        }
    }
    let gif = match gif {
        Some(encoder) => {
            let bytes = encoder.into_inner().map_err(|e| gif_error(&gif_path, e))?;
            sparse_mpm::io::write_atomically(&gif_path, |w| std::io::Write::write_all(w, &bytes))?;
            Some(gif_path)
        }
        None => None,
    };
    Ok(Rendered {
        frames,
        gif,
        range,
        size,
    })
}

fn gif_error(path: &Path, e: impl std::fmt::Display) -> MpmError {
    MpmError::Snapshot {
        path: path.to_path_buf(),
        reason: format!("GIF encoding failed: {e}"),
    }
}

/// `run_dir/particles.pvd`, or the only `.pvd` in `run_dir`.
fn find_series(run_dir: &Path) -> Result<PathBuf> {
    let default = run_dir.join("particles.pvd");
    if default.is_file() {
        return Ok(default);
    }
    let entries = std::fs::read_dir(run_dir).map_err(|source| MpmError::Io {
        path: run_dir.to_path_buf(),
        source,
    })?;
    let mut found: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "pvd"))
        .collect();
    match found.len() {
        1 => Ok(found.remove(0)),
        n => Err(MpmError::Snapshot {
            path: run_dir.to_path_buf(),
            reason: format!(
                "{} .pvd series here: give the folder of a run (it holds particles.pvd)",
                if n == 0 { "no".to_string() } else { format!("{n}") }
            ),
        }),
    }
}

/// A colour scale that shows something for a constant field.
fn widen(lo: f64, hi: f64) -> [f64; 2] {
    if lo.partial_cmp(&hi).is_none_or(|o| o == std::cmp::Ordering::Greater) {
        return [0.0, 1.0];
    }
    if hi > lo {
        return [lo, hi];
    }
    let pad = if lo == 0.0 { 1.0 } else { 0.01 * lo.abs() };
    [lo - pad, hi + pad]
}

/// The value of `field` (see [`RenderOptions::field`]) at every particle of `snapshot`.
///
/// # Errors
/// [`MpmError::InvalidOption`] (`field`) naming the arrays of `file` when `field` is not one, a
/// component that the array does not have, or a tensor without a component.
pub fn field_values(snapshot: &Snapshot, field: &str, file: &Path) -> Result<Vec<f64>> {
    let (name, component) = match field.split_once(':') {
        Some((n, c)) => (n, Some(c)),
        None => (field, None),
    };
    let bad = |reason: String| MpmError::InvalidOption {
        option: "field",
        reason: format!("`{field}` in {}: {reason}", file.display()),
    };
    let Some(array) = snapshot.array(name) else {
        let names: Vec<&str> = snapshot.arrays.iter().map(|a| a.name.as_str()).collect();
        return Err(bad(format!("no such array; the arrays are {}", names.join(", "))));
    };
    match (component, array.components) {
        (None, 1) => Ok(array.values.clone()),
        (None, 3) => Ok(array.magnitude()),
        (None, _) => Err(bad(format!(
            "a {}-component array: give a component, e.g. `{name}:{}`",
            array.components,
            array
                .component_names
                .get(1)
                .filter(|c| !c.is_empty())
                .map_or("1", |c| c.as_str())
        ))),
        (Some(c), n) => {
            let index = array
                .component_names
                .iter()
                .position(|name| !name.is_empty() && name == c)
                .or_else(|| c.parse::<usize>().ok().filter(|&k| k < n))
                .ok_or_else(|| {
                    let names: Vec<&str> = array
                        .component_names
                        .iter()
                        .map(String::as_str)
                        .filter(|s| !s.is_empty())
                        .collect();
                    bad(format!(
                        "no component `{c}`; give {}",
                        if names.is_empty() {
                            format!("0 to {}", n - 1)
                        } else {
                            names.join(", ")
                        }
                    ))
                })?;
            Ok(array.component(index).unwrap_or_default())
        }
    }
}

/// Where things go in a frame (pixels).
struct Layout {
    width: u32,
    height: u32,
    /// The plot's box `[left, top, right, bottom]`.
    plot: [i32; 4],
    /// The colour bar's `[top, bottom]`.
    bar: [i32; 2],
    view: [f64; 4],
    scale: f64,
}

impl Layout {
    const TOP: i32 = 44;
    const MARGIN: i32 = 16;
    const BAR: i32 = 120;
    const MIN_BAR: i32 = 160;

    fn new(width: u32, view: [f64; 4]) -> Layout {
        let (w, h) = ((view[1] - view[0]).max(1e-300), (view[3] - view[2]).max(1e-300));
        let plot_width = (width as i32 - 2 * Self::MARGIN - Self::BAR).max(16);
        let scale = f64::from(plot_width) / w;
        let plot_height = ((h * scale).round() as i32).clamp(16, MAX_IMAGE_SIDE as i32 - Self::TOP - Self::MARGIN);
        let scale = scale.min(f64::from(plot_height) / h);
        // The colour bar keeps a readable height beside a flat domain (a bar, a beam).
        let bar_height = plot_height.max(Self::MIN_BAR);
        let height = (Self::TOP + bar_height + Self::MARGIN) as u32;
        let plot = [
            Self::MARGIN,
            Self::TOP,
            Self::MARGIN + plot_width,
            Self::TOP + plot_height,
        ];
        Layout {
            width,
            height,
            plot,
            bar: [Self::TOP, Self::TOP + bar_height],
            view,
            scale,
        }
    }

    /// The pixel of the point `(x, y)` (y up).
    fn pixel(&self, x: f64, y: f64) -> (i32, i32) {
        let px = f64::from(self.plot[0]) + (x - self.view[0]) * self.scale;
        let py = f64::from(self.plot[3]) - (y - self.view[2]) * self.scale;
        (px.round().clamp(-1e6, 1e6) as i32, py.round().clamp(-1e6, 1e6) as i32)
    }
}

/// One frame's data.
struct Frame<'a> {
    snapshot: &'a Snapshot,
    values: &'a [f64],
    radius: Option<&'a [f64]>,
    time: f64,
    field: &'a str,
    range: [f64; 2],
    grid: Option<&'a sparse_mpm::grid::Grid>,
}

impl Frame<'_> {
    fn draw(&self, area: &Area<'_>, layout: &Layout) -> DrawResult {
        let grey = RGBColor(200, 200, 200);
        if let Some(grid) = self.grid {
            let [x0, y0] = grid.origin();
            let [hx, hy] = grid.cell_size();
            let [nx, ny] = grid.cells();
            let [_, x1, _, y1] = grid.bounds();
            for i in 0..=nx {
                let x = x0 + i as f64 * hx;
                area.draw(&PathElement::new(vec![layout.pixel(x, y0), layout.pixel(x, y1)], grey))?;
            }
            for j in 0..=ny {
                let y = y0 + j as f64 * hy;
                area.draw(&PathElement::new(vec![layout.pixel(x0, y), layout.pixel(x1, y)], grey))?;
            }
        }
        let [lo, hi] = self.range;
        for (k, (&x, &y)) in self.snapshot.x.iter().zip(&self.snapshot.y).enumerate() {
            if !(x.is_finite() && y.is_finite()) {
                continue;
            }
            let v = self.values[k];
            let colour = if v.is_finite() {
                viridis((v - lo) / (hi - lo))
            } else {
                RGBColor(150, 150, 150)
            };
            let r = self.radius.map_or(0.0, |r| r[k]) * layout.scale;
            let r = if r.is_finite() {
                r.round().clamp(1.0, 200.0) as i32
            } else {
                1
            };
            area.draw(&Circle::new(layout.pixel(x, y), r, colour.filled()))?;
        }
        let [l, t, r, b] = layout.plot;
        area.draw(&Rectangle::new([(l, t), (r, b)], BLACK.stroke_width(1)))?;
        // Title: the field and the time.
        let title = TextStyle::from((FAMILY, 22)).pos(Pos::new(HPos::Left, VPos::Center));
        area.draw_text(
            &format!("{}    t = {}", self.field, short(self.time)),
            &title,
            (Layout::MARGIN, Layout::TOP / 2),
        )?;
        // Colour bar.
        let (bx, bw) = (r + 24, 22);
        let [bt, bb] = layout.bar;
        let steps = (bb - bt).max(1);
        for s in 0..steps {
            let c = viridis(1.0 - f64::from(s) / f64::from(steps - 1).max(1.0));
            area.draw(&Rectangle::new([(bx, bt + s), (bx + bw, bt + s + 1)], c.filled()))?;
        }
        area.draw(&Rectangle::new([(bx, bt), (bx + bw, bb)], BLACK.stroke_width(1)))?;
        let label = TextStyle::from((FAMILY, 14)).pos(Pos::new(HPos::Left, VPos::Center));
        for k in 0..=4 {
            let f = f64::from(k) / 4.0;
            let py = bb - (f * f64::from(bb - bt)).round() as i32;
            area.draw(&PathElement::new(vec![(bx + bw, py), (bx + bw + 4, py)], BLACK))?;
            area.draw_text(&short(lo + f * (hi - lo)), &label, (bx + bw + 7, py))?;
        }
        Ok(())
    }
}

/// A number in at most about 9 characters.
fn short(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if (1e-3..1e5).contains(&v.abs()) {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.3e}")
    }
}

/// The viridis colour map at `f` in `[0, 1]` (clamped): linear between nine samples of the map
/// (van der Walt & Smith's, as matplotlib ships it).
pub fn viridis(f: f64) -> RGBColor {
    const SAMPLES: [[f64; 3]; 9] = [
        [68.0, 1.0, 84.0],
        [71.0, 44.0, 122.0],
        [59.0, 81.0, 139.0],
        [44.0, 113.0, 142.0],
        [33.0, 144.0, 141.0],
        [39.0, 173.0, 129.0],
        [92.0, 200.0, 99.0],
        [170.0, 220.0, 50.0],
        [253.0, 231.0, 37.0],
    ];
    let f = if f.is_nan() { 0.0 } else { f.clamp(0.0, 1.0) } * 8.0;
    let k = (f.floor() as usize).min(7);
    let t = f - k as f64;
    let c = |i: usize| (SAMPLES[k][i] + t * (SAMPLES[k + 1][i] - SAMPLES[k][i])).round() as u8;
    RGBColor(c(0), c(1), c(2))
}

/// The columns of `report.csv` that [`plot_report`] draws, by panel.
pub const REPORT_PLOT_COLUMNS: [&[&str]; 2] = [
    &["kinetic_energy", "strain_energy", "potential_energy", "total_energy"],
    &["momentum_x", "momentum_y", "angular_momentum"],
];

/// Draws the energies (kinetic, strain, potential, total) and the momenta (x, y, angular) of
/// `run_dir/report.csv` against time into one PNG, `out` or `run_dir/report.png`, and returns
/// its path.
///
/// # Errors
/// The errors of [`sparse_mpm::io::csv::read_csv`] for the report (a value that is not a number
/// among them); [`MpmError::Snapshot`] naming it when it has no `time` column, or naming the
/// PNG when it cannot be written.
pub fn plot_report(run_dir: &Path, out: Option<&Path>) -> Result<PathBuf> {
    let path = run_dir.join("report.csv");
    let bad = |reason: String| MpmError::Snapshot {
        path: path.clone(),
        reason,
    };
    let (header, rows) = sparse_mpm::io::csv::read_csv(&path)?;
    let column = |name: &str| header.iter().position(|h| h == name);
    let time = column("time").ok_or_else(|| bad("no `time` column".into()))?;
    let charts: Vec<Chart> = [("Energies", "energy"), ("Momenta", "momentum")]
        .into_iter()
        .zip(REPORT_PLOT_COLUMNS)
        .map(|((title, y_label), names)| Chart {
            title: title.into(),
            x_label: "time".into(),
            y_label: y_label.into(),
            series: names
                .iter()
                .filter_map(|&name| {
                    let c = column(name)?;
                    Some(Series {
                        label: name.replace('_', " "),
                        points: rows
                            .iter()
                            .filter(|row| row.len() > time.max(c))
                            .map(|row| (row[time], row[c]))
                            .collect(),
                        style: SeriesStyle::LineAndMarkers,
                    })
                })
                .collect(),
            ..Chart::default()
        })
        .collect();
    let png = out.map_or_else(|| run_dir.join("report.png"), Path::to_path_buf);
    write_png_stack(&charts, &png, 900, 1000).map_err(|e| MpmError::Snapshot {
        path: png.clone(),
        reason: e.to_string(),
    })?;
    Ok(png)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn viridis_runs_from_purple_to_yellow_and_clamps() {
        assert_eq!(viridis(0.0), RGBColor(68, 1, 84));
        assert_eq!(viridis(1.0), RGBColor(253, 231, 37));
        assert_eq!(viridis(-3.0), viridis(0.0));
        assert_eq!(viridis(7.0), viridis(1.0));
        assert_eq!(viridis(0.5), RGBColor(33, 144, 141));
    }

    #[test]
    fn a_constant_field_gets_a_scale_around_it() {
        assert_eq!(widen(2.0, 5.0), [2.0, 5.0]);
        assert_eq!(widen(0.0, 0.0), [-1.0, 1.0]);
        assert_eq!(widen(100.0, 100.0), [99.0, 101.0]);
        assert_eq!(widen(f64::INFINITY, f64::NEG_INFINITY), [0.0, 1.0]);
    }

    #[test]
    fn fields_are_picked_by_name_and_component() {
        use crate::vtk::SnapshotArray;
        let array = |name: &str, components: usize, names: &[&str], values: Vec<f64>| SnapshotArray {
            name: name.into(),
            components,
            component_names: names.iter().map(|s| s.to_string()).collect(),
            values,
        };
        let snapshot = Snapshot {
            x: vec![0.0, 1.0],
            y: vec![0.0, 1.0],
            arrays: vec![
                array("J", 1, &[], vec![1.0, 0.5]),
                array("velocity", 3, &["x", "y", "z"], vec![3.0, 4.0, 0.0, 0.0, -1.0, 0.0]),
                array(
                    "stress",
                    9,
                    &["xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"],
                    (0..18).map(f64::from).collect(),
                ),
            ],
        };
        let f = Path::new("s.vtp");
        assert_eq!(field_values(&snapshot, "J", f).unwrap(), [1.0, 0.5]);
        assert_eq!(field_values(&snapshot, "velocity", f).unwrap(), [5.0, 1.0]);
        assert_eq!(field_values(&snapshot, "velocity:y", f).unwrap(), [4.0, -1.0]);
        assert_eq!(field_values(&snapshot, "stress:xy", f).unwrap(), [1.0, 10.0]);
        assert_eq!(field_values(&snapshot, "stress:4", f).unwrap(), [4.0, 13.0]);
        let err = |field: &str| field_values(&snapshot, field, f).unwrap_err().to_string();
        assert!(
            err("speed").contains("the arrays are J, velocity, stress"),
            "{}",
            err("speed")
        );
        assert!(
            err("stress").contains("give a component, e.g. `stress:xy`"),
            "{}",
            err("stress")
        );
        assert!(err("velocity:w").contains("give x, y, z"), "{}", err("velocity:w"));
    }
}
