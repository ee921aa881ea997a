//! PNG charts for study reports.
//!
//! Charts are drawn with `plotters` into an in-memory RGB buffer and encoded
//! with `png`. Text uses an embedded Noto Sans font (see `assets/fonts/README.md`), so
//! no system font is needed or looked up.

use ab_glyph::{Font, FontRef, ScaleFont};
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle};
use plotters_backend::{BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind};
use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The embedded font (Noto Sans Regular, SIL Open Font License 1.1).
const FONT: &[u8] = include_bytes!("../../assets/fonts/NotoSans-Regular.ttf");
/// Family name under which the embedded font (Noto Sans) is registered; plotters' default family.
pub const FAMILY: &str = "sans-serif";
/// Colour-blind-friendly palette (Okabe & Ito, 2008), yellow left out.
const PALETTE: [RGBColor; 7] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
    RGBColor(0, 0, 0),       // black
];

/// One data series: a label for the legend and its points.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// Legend text; an empty label leaves the series out of the legend.
    pub label: String,
    /// The `(x, y)` data points, drawn in the given order.
    pub points: Vec<(f64, f64)>,
    /// How the points are drawn.
    pub style: SeriesStyle,
}

/// Lines with markers (default), markers only, or a dashed reference line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SeriesStyle {
    /// A solid line through the points, with a filled circle at each point
    /// (at every k-th point only for long series, keeping at most 40 circles).
    #[default]
    LineAndMarkers,
    /// A filled circle at each point, no line.
    Markers,
    /// A dashed line through the points, e.g. a reference slope.
    Dashed,
}

/// A chart: title, axis labels, log axes, series.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Chart {
    /// Caption drawn above the plot.
    pub title: String,
    /// Description of the horizontal axis.
    pub x_label: String,
    /// Description of the vertical axis.
    pub y_label: String,
    /// Use a base-10 logarithmic horizontal axis.
    pub log_x: bool,
    /// Use a base-10 logarithmic vertical axis.
    pub log_y: bool,
    /// The data series, coloured in order from a fixed palette.
    pub series: Vec<Series>,
}

/// Why [`write_png`] failed: the file it was writing and what went wrong.
#[derive(Debug)]
pub struct PlotError {
    path: PathBuf,
    what: String,
}

impl fmt::Display for PlotError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "cannot write plot {}: {}", self.path.display(), self.what)
    }
}

impl std::error::Error for PlotError {}

/// Writes the chart as a PNG of `width × height` pixels. Axis ranges come from the data (with a small margin, and
/// decade-friendly ranges on log axes); non-finite or (on log axes) non-positive points are skipped; an empty chart
/// still writes a PNG saying "no data".
///
/// Points with a coordinate beyond ±1e150 (or, on a log axis, below 1e-150) are skipped too.
///
/// # Errors
/// Fails, naming `path`, if the size is below 100×100 pixels or the file cannot be written.
pub fn write_png(chart: &Chart, path: &Path, width: u32, height: u32) -> Result<(), PlotError> {
    let fail = |what: String| PlotError {
        path: path.to_path_buf(),
        what,
    };
    if width < 100 || height < 100 {
        return Err(fail(format!("image size {width}×{height} is below 100×100")));
    }
    let rgb = draw_rgb(width, height, |root| draw(chart, root)).map_err(fail)?;
    write_rgb_png(path, &rgb, width, height).map_err(fail)
}

/// Writes `charts` one above the other into one PNG of `width × height` pixels (each chart a
/// band of `height / charts.len()` pixels), drawn as [`write_png`] draws one.
///
/// # Errors
/// As [`write_png`]; also when there is no chart or a band is below 100 pixels high.
pub fn write_png_stack(charts: &[Chart], path: &Path, width: u32, height: u32) -> Result<(), PlotError> {
    let fail = |what: String| PlotError {
        path: path.to_path_buf(),
        what,
    };
    if charts.is_empty() || width < 100 || height / (charts.len() as u32).max(1) < 100 {
        return Err(fail(format!(
            "{} chart(s) in {width}×{height} pixels: each needs at least 100×100",
            charts.len()
        )));
    }
    let rgb = draw_rgb(width, height, |root| {
        for (chart, area) in charts.iter().zip(root.split_evenly((charts.len(), 1))) {
            draw(chart, &area)?;
        }
        Ok(())
    })
    .map_err(fail)?;
    write_rgb_png(path, &rgb, width, height).map_err(fail)
}

/// A drawing area of [`draw_rgb`].
pub type Area<'a> = DrawingArea<Canvas<'a>, plotters::coord::Shift>;

/// What drawing on an [`Area`] returns.
pub type DrawResult = Result<(), DrawingAreaErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>>;

/// The RGB pixels (row by row, 3 bytes each) of a white `width × height` canvas after `paint`
/// has drawn on it, with text in the embedded font.
pub fn draw_rgb(width: u32, height: u32, paint: impl FnOnce(&Area<'_>) -> DrawResult) -> Result<Vec<u8>, String> {
    // `Canvas` draws all text, but plotters still measures legend lines with its registered font.
    static FONT_OK: OnceLock<bool> = OnceLock::new();
    if !*FONT_OK.get_or_init(|| register_font(FAMILY, FontStyle::Normal, FONT).is_ok()) {
        return Err("the embedded font could not be parsed".into());
    }
    let font = FontRef::try_from_slice(FONT).map_err(|e| format!("embedded font: {e}"))?;
    let mut rgb = vec![255u8; width as usize * height as usize * 3];
    {
        let root = Canvas(BitMapBackend::with_buffer(&mut rgb, (width, height)), font).into_drawing_area();
        paint(&root)
            .and_then(|()| root.present())
            .map_err(|e| format!("drawing failed: {e}"))?;
    }
    Ok(rgb)
}

/// Writes RGB pixels as an 8-bit PNG, whole or not at all (a temporary file renamed).
pub fn write_rgb_png(path: &Path, rgb: &[u8], width: u32, height: u32) -> Result<(), String> {
    sparse_mpm::io::write_atomically(path, |w| {
        let mut encoder = png::Encoder::new(w, width, height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        encoder
            .write_header()
            .and_then(|mut w| w.write_image_data(rgb).and_then(|()| w.finish()))
            .map_err(std::io::Error::other)
    })
    .map_err(|e| e.to_string())
}

/// `BitMapBackend` with its own text rasterisation. plotters 0.3.7 draws
/// `ab_glyph` text without the glyphs' left side bearings and at whole-pixel
/// pen positions, which spaces letters unevenly; this places each glyph at its
/// exact (sub-pixel) position instead. Shapes go to the bitmap backend (those
/// it does not implement itself fall back to pixel-wise defaults, as there).
pub struct Canvas<'a>(BitMapBackend<'a>, FontRef<'static>);

impl Canvas<'_> {
    /// Glyphs of `text` at `size` pixels, placed from the top-left corner of
    /// its box, with the box's width and height.
    fn layout(&self, text: &str, size: f64) -> (Vec<ab_glyph::Glyph>, f32, f32) {
        let font = self.1.as_scaled(size as f32);
        let (mut pen, mut prev, mut glyphs) = (0.0, None, Vec::new());
        for c in text.chars() {
            let id = font.glyph_id(c);
            pen += prev.map_or(0.0, |p| font.kern(p, id));
            glyphs.push(id.with_scale_and_position(font.scale(), ab_glyph::point(pen, font.ascent())));
            (pen, prev) = (pen + font.h_advance(id), Some(id));
        }
        (glyphs, pen, font.ascent() - font.descent())
    }
}

/// Result type of the [`DrawingBackend`] methods of [`Canvas`].
type BackendResult = Result<(), DrawingErrorKind<<BitMapBackend<'static> as DrawingBackend>::ErrorType>>;

impl DrawingBackend for Canvas<'_> {
    type ErrorType = <BitMapBackend<'static> as DrawingBackend>::ErrorType;
    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }
    fn ensure_prepared(&mut self) -> BackendResult {
        self.0.ensure_prepared()
    }
    fn present(&mut self) -> BackendResult {
        self.0.present()
    }
    fn draw_pixel(&mut self, p: BackendCoord, c: BackendColor) -> BackendResult {
        self.0.draw_pixel(p, c)
    }
    fn draw_line<S: BackendStyle>(&mut self, a: BackendCoord, b: BackendCoord, s: &S) -> BackendResult {
        self.0.draw_line(a, b, s)
    }
    fn draw_rect<S: BackendStyle>(&mut self, a: BackendCoord, b: BackendCoord, s: &S, fill: bool) -> BackendResult {
        self.0.draw_rect(a, b, s, fill)
    }
    fn estimate_text_size<T: BackendTextStyle>(
        &self,
        text: &str,
        style: &T,
    ) -> Result<(u32, u32), DrawingErrorKind<Self::ErrorType>> {
        let (_, width, height) = self.layout(text, style.size());
        let (w, h) = style.transform().transform(width.ceil() as i32, height.ceil() as i32);
        Ok((w.unsigned_abs(), h.unsigned_abs()))
    }
    fn draw_text<T: BackendTextStyle>(&mut self, text: &str, style: &T, pos: BackendCoord) -> BackendResult {
        let (glyphs, pen, height) = self.layout(text, style.size());
        let anchor = style.anchor();
        let dx = match anchor.h_pos {
            HPos::Left => 0.0,
            HPos::Center => -pen / 2.0,
            HPos::Right => -pen,
        };
        let dy = match anchor.v_pos {
            VPos::Top => 0.0,
            VPos::Center => -height / 2.0,
            VPos::Bottom => -height,
        };
        let (colour, turn) = (style.color(), style.transform());
        for mut glyph in glyphs {
            glyph.position.x += dx;
            glyph.position.y += dy;
            let Some(outline) = self.1.outline_glyph(glyph) else {
                continue;
            };
            let origin = outline.px_bounds().min;
            let mut pixels = Vec::new();
            outline.draw(|x, y, cover| pixels.push((x as i32 + origin.x as i32, y as i32 + origin.y as i32, cover)));
            for (x, y, cover) in pixels {
                let (x, y) = turn.transform(x, y);
                let c = BackendColor {
                    alpha: colour.alpha * f64::from(cover.min(1.0)),
                    rgb: colour.rgb,
                };
                self.0.draw_pixel((pos.0 + x, pos.1 + y), c)?;
            }
        }
        Ok(())
    }
}

/// Whether a point can be drawn on the chart's axes: coordinates of magnitude
/// at most 1e150 (and at least 1e-150 on log axes), so that no axis range
/// overflows, which would send plotters' tick search into an endless loop.
fn valid(chart: &Chart, (x, y): (f64, f64)) -> bool {
    let ok = |v: f64, log: bool| v.abs() <= 1e150 && (!log || v >= 1e-150);
    ok(x, chart.log_x) && ok(y, chart.log_y)
}

/// Axis range for the values `v`: 5 % margins (in `log10` on a log axis, which spans at least a
/// factor of 3).
fn axis_range(v: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (lo, hi) = v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
    if log {
        let (a, b) = (lo.log10(), hi.log10());
        let pad = 0.05 * (b - a);
        let (mut a, mut b) = (a - pad, b + pad);
        let least = 3f64.log10();
        if b - a < least {
            let mid = 0.5 * (a + b);
            (a, b) = (mid - 0.5 * least, mid + 0.5 * least);
        }
        (10f64.powf(a), 10f64.powf(b))
    } else {
        let pad = if hi > lo {
            0.05 * (hi - lo)
        } else if lo != 0.0 {
            0.1 * lo.abs()
        } else {
            1.0
        };
        (lo - pad, hi + pad)
    }
}

/// The multiples of each decade that a log axis over `decades` decades labels: fewer decades,
/// more of them.
fn labelled_multiples(decades: f64) -> &'static [u32] {
    if decades <= 1.2 {
        &[1, 2, 3, 4, 5, 6, 8]
    } else if decades <= 2.5 {
        &[1, 2, 3, 5]
    } else {
        &[1, 2, 5]
    }
}

/// The ticks of a log axis over `(lo, hi)`: the labelled multiples of each decade (bold) and
/// every multiple 1 … 9 (light) inside the range. plotters' own log ticks start at the first
/// power of ten, which leaves the part of the axis below it bare.
fn log_ticks((lo, hi): (f64, f64)) -> (Vec<f64>, Vec<f64>) {
    let shown = labelled_multiples((hi / lo).log10());
    let (mut bold, mut light) = (Vec::new(), Vec::new());
    let (first, last) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    for e in first..=last {
        for m in 1..=9u32 {
            // m / 10^-e for negative e: the nearest double to the decimal (0.3, not 0.30…04)
            let v = if e < 0 {
                f64::from(m) / 10f64.powi(-e)
            } else {
                f64::from(m) * 10f64.powi(e)
            };
            if v >= lo && v <= hi {
                light.push(v);
                if shown.contains(&m) {
                    bold.push(v);
                }
            }
        }
    }
    (bold, light)
}

/// Tick label: `1e-3`, `2e-3`, `5e-3` on log axes (plain numbers from 1 to
/// 9999; other multiples stay unlabelled). On linear axes, decimals enough to
/// tell ticks about a tenth of the axis `range` apart, in scientific notation
/// when the largest magnitude on the axis is at least 1e5 or below 1e-3.
fn tick_label(v: f64, log: bool, range: &Range<f64>) -> String {
    if log {
        let e = (v.log10() + 1e-9).floor();
        let m = (v / 10f64.powf(e)).round();
        // Fewer decades on the axis, more of the multiples labelled.
        if !labelled_multiples((range.end / range.start).abs().log10()).contains(&(m as u32)) {
            return String::new();
        }
        return if (0.0..=3.0).contains(&e) {
            format!("{}", m * 10f64.powf(e))
        } else {
            format!("{m}e{e}")
        };
    }
    sparse_mpm::numbers::axis_tick(v, range.clone())
}

/// Draws the whole chart (or a "no data" notice) onto `root`.
fn draw<DB: DrawingBackend>(
    chart: &Chart,
    root: &DrawingArea<DB, plotters::coord::Shift>,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let pts = || {
        chart
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|&p| valid(chart, p))
    };
    if pts().next().is_none() {
        let area = root.titled(&chart.title, (FAMILY, 26))?;
        let (w, h) = area.dim_in_pixel();
        let style = TextStyle::from((FAMILY, 30))
            .color(&RGBColor(110, 110, 110))
            .pos(Pos::new(HPos::Center, VPos::Center));
        return area.draw_text("no data", &style, (w as i32 / 2, h as i32 / 2));
    }
    let x = axis_range(pts().map(|p| p.0), chart.log_x);
    let y = axis_range(pts().map(|p| p.1), chart.log_y);
    let log_axis = |r: (f64, f64)| {
        let (bold, light) = log_ticks(r);
        (r.0..r.1).log_scale().with_key_points(bold).with_light_points(light)
    };
    match (chart.log_x, chart.log_y) {
        (false, false) => draw_on(chart, root, x.0..x.1, y.0..y.1),
        (true, false) => draw_on(chart, root, log_axis(x), y.0..y.1),
        (false, true) => draw_on(chart, root, x.0..x.1, log_axis(y)),
        (true, true) => draw_on(chart, root, log_axis(x), log_axis(y)),
    }
}

/// Draws axes, series and legend with the given (linear or log) axis specs.
fn draw_on<DB, X, Y>(
    chart: &Chart,
    root: &DrawingArea<DB, plotters::coord::Shift>,
    xs: X,
    ys: Y,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>
where
    DB: DrawingBackend,
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let (xs, ys): (X::CoordDescType, Y::CoordDescType) = (xs.into(), ys.into());
    let (xr, yr) = (xs.range(), ys.range());
    // Room for the widest y tick label plus the rotated axis description.
    let label_width = |v: f64| root.estimate_text_size(&tick_label(v, chart.log_y, &yr), &(FAMILY, 17).into());
    let widest = [yr.start, (yr.start + yr.end) / 2.0, yr.end].map(|v| label_width(v).map_or(0, |(w, _)| w));
    let mut ctx = ChartBuilder::on(root)
        .caption(&chart.title, (FAMILY, 26))
        .margin(20)
        .x_label_area_size(55)
        .y_label_area_size(widest.into_iter().max().unwrap_or(0) + 45)
        .build_cartesian_2d(xs, ys)?;
    let xfmt = |v: &f64| tick_label(*v, chart.log_x, &xr);
    let yfmt = |v: &f64| tick_label(*v, chart.log_y, &yr);
    ctx.configure_mesh()
        .x_desc(chart.x_label.as_str())
        .y_desc(chart.y_label.as_str())
        .x_label_formatter(&xfmt)
        .y_label_formatter(&yfmt)
        .label_style((FAMILY, 17))
        .axis_desc_style((FAMILY, 19))
        .bold_line_style(BLACK.mix(0.15))
        .light_line_style(BLACK.mix(0.05))
        .draw()?;

    for (i, s) in chart.series.iter().enumerate() {
        // Colour and marker shape both change from series to series: 7 colours × 4 shapes.
        let colour = PALETTE[i % PALETTE.len()];
        let shape = i % 4;
        let line = Color::stroke_width(&colour, 2);
        let pts: Vec<(f64, f64)> = s.points.iter().copied().filter(|&p| valid(chart, p)).collect();
        let anno = match s.style {
            SeriesStyle::Dashed => {
                let anno = ctx.draw_series(std::iter::once(DashedPathElement::new(pts, 10, 6, line)))?;
                anno.legend(move |(x, y)| DashedPathElement::new(vec![(x, y), (x + 24, y)], 7, 4, line))
            }
            style => {
                if style == SeriesStyle::LineAndMarkers {
                    ctx.draw_series(std::iter::once(PathElement::new(pts.clone(), line)))?;
                }
                // Long series (time histories) get every k-th marker only, ≤ 40 in all.
                let every = (style == SeriesStyle::LineAndMarkers).then(|| pts.len().div_ceil(40));
                let marks = pts.into_iter().step_by(every.unwrap_or(1).max(1));
                let anno = ctx.draw_series(marks.map(|p| EmptyElement::at(p) + marker(shape, colour)))?;
                anno.legend(move |(x, y)| {
                    let dx = if style == SeriesStyle::Markers { 0 } else { 12 };
                    EmptyElement::at((x + 12, y))
                        + PathElement::new(vec![(-dx, 0), (dx, 0)], line)
                        + marker(shape, colour)
                })
            }
        };
        if !s.label.is_empty() {
            anno.label(s.label.as_str());
        }
    }
    if chart.series.iter().any(|s| !s.label.is_empty()) {
        ctx.configure_series_labels()
            .position(legend_corner(chart, &xr, &yr))
            .label_font((FAMILY, 17))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.5))
            .margin(12)
            .draw()?;
    }
    Ok(())
}

/// The marker of shape `k` (filled circle, triangle, square, diamond) in `colour`, centred on
/// its anchor, in pixels.
fn marker<DB: DrawingBackend>(k: usize, colour: RGBColor) -> DynElement<'static, DB, (i32, i32)> {
    let fill = colour.filled();
    match k % 4 {
        0 => Circle::new((0, 0), 4, fill).into_dyn(),
        1 => Polygon::new(vec![(0, -6), (5, 4), (-5, 4)], fill).into_dyn(),
        2 => Rectangle::new([(-4, -4), (4, 4)], fill).into_dyn(),
        _ => Polygon::new(vec![(0, -6), (5, 0), (0, 6), (-5, 0)], fill).into_dyn(),
    }
}

/// The plot corner that the fewest points and line pieces fall into: the
/// legend's place. `x` and `y` are the axis ranges.
fn legend_corner(chart: &Chart, x: &Range<f64>, y: &Range<f64>) -> SeriesLabelPosition {
    let unit = |v: f64, r: &Range<f64>, log: bool| {
        let f = |v: f64| if log { v.log10() } else { v };
        (f(v) - f(r.start)) / (f(r.end) - f(r.start))
    };
    let mut samples = Vec::new();
    for s in &chart.series {
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|&p| valid(chart, p))
            .map(|(a, b)| (unit(a, x, chart.log_x), unit(b, y, chart.log_y)))
            .collect();
        samples.extend_from_slice(&pts);
        if s.style != SeriesStyle::Markers {
            for w in pts.windows(2) {
                let lerp = |t: f64| (w[0].0 + t * (w[1].0 - w[0].0), w[0].1 + t * (w[1].1 - w[0].1));
                samples.extend((1..16).map(|i| lerp(f64::from(i) / 16.0)));
            }
        }
    }
    // Corner boxes span 40 % of the width and 35 % of the height.
    let near = |t: f64, high: bool, size: f64| if high { t > 1.0 - size } else { t < size };
    let count = |right, top| {
        samples
            .iter()
            .filter(|p| near(p.0, right, 0.4) && near(p.1, top, 0.35))
            .count()
    };
    use SeriesLabelPosition::*;
    [
        (UpperRight, true, true),
        (UpperLeft, false, true),
        (LowerRight, true, false),
        (LowerLeft, false, false),
    ]
    .into_iter()
    .min_by_key(|&(_, right, top)| count(right, top))
    .map_or(UpperRight, |c| c.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels() {
        let log = |v| tick_label(v, true, &(1e-4..1.0));
        assert_eq!(
            [log(1e-3), log(2e-3), log(3e-3), log(5e-1), log(1.0), log(200.0)],
            ["1e-3", "2e-3", "", "5e-1", "1", "200"]
        );
        let lin = |v, r: Range<f64>| tick_label(v, false, &r);
        assert_eq!(
            [lin(0.6, -1.0..1.0), lin(-1e-17, -1.0..1.0), lin(3.0, 0.0..40.0)],
            ["0.6", "0.0", "3"]
        );
        assert_eq!(
            [lin(1.05e6, 1e6..1.5e6), lin(-2e5, -3e5..3e5), lin(2.5e-5, 0.0..5e-5)],
            ["1.05e6", "-2e5", "2.5e-5"]
        );
    }

    #[test]
    fn axis_ranges() {
        // log axes: 5 % of the decades as margins, at least a factor of 3
        let (lo, hi) = axis_range([1e-4, 1e-2].into_iter(), true);
        assert!(
            (lo.log10() + 4.1).abs() < 1e-9 && (hi.log10() + 1.9).abs() < 1e-9,
            "{lo} {hi}"
        );
        let (lo, hi) = axis_range([2e-3, 2.2e-3].into_iter(), true);
        assert!((hi / lo - 3.0).abs() < 1e-9 && lo < 2e-3 && hi > 2.2e-3, "{lo} {hi}");
        // ticks below the first power of ten too
        let (bold, light) = log_ticks((0.022, 0.36));
        assert_eq!(bold, [0.03, 0.05, 0.1, 0.2, 0.3]);
        assert_eq!(light.len(), 10);
        assert_eq!(axis_range([1.0, 3.0].into_iter(), false), (0.9, 3.1));
        assert_eq!(axis_range([2.0].into_iter(), false), (1.8, 2.2));
    }
}
