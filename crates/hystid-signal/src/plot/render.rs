//! The shared figure machinery: a figure is plain data (title, panels of
//! shapes, legend entries), drawn by one generic renderer on both the bitmap
//! and the SVG backend, then written atomically.

use super::{FIGURE_HEIGHT, FIGURE_WIDTH};
use crate::atomic::{PendingFile, temporary_path};
use crate::error::{Error, Result};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::io::Write;
use std::path::{Path, PathBuf};

/// A drawing backend's failure, as its message: the backends' error types
/// differ (bitmap, SVG) and the caller names the figure.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub(super) struct DrawError(pub String);

/// Drawing results; see [`DrawError`].
pub(super) type Draw<T> = std::result::Result<T, DrawError>;

fn fail<E: std::fmt::Display>(e: E) -> DrawError {
    DrawError(e.to_string())
}

const FONT: &str = "sans-serif";

/// Something drawn in a panel, in data coordinates. Non-finite points break
/// lines and are skipped as markers (the caller turns unplottable data, such
/// as a zero on a log axis, into NaN).
pub(super) enum Shape {
    /// A polyline; a NaN point leaves a gap.
    Line {
        colour: RGBColor,
        width: u32,
        alpha: f64,
        points: Vec<(f64, f64)>,
    },
    /// A dashed polyline; a NaN point leaves a gap.
    Dashed {
        colour: RGBColor,
        width: u32,
        points: Vec<(f64, f64)>,
    },
    /// One marker per point.
    Markers {
        colour: RGBColor,
        marker: Marker,
        points: Vec<(f64, f64)>,
    },
    /// Vertical error bars `(x, low, high)`, clipped to the panel.
    Bars {
        colour: RGBColor,
        bars: Vec<(f64, f64, f64)>,
    },
    /// A dashed horizontal line across the panel.
    Level { colour: RGBColor, y: f64 },
}

/// How a legend entry's sample is drawn.
#[derive(Clone, Copy)]
pub(super) enum Sample {
    Line,
    /// A thin, pale line.
    Thin,
    Band,
    Marker(Marker),
    Dashed,
}

/// A marker's shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Glyph {
    Circle,
    Square,
    TriangleUp,
    Diamond,
    TriangleDown,
}

/// A marker: an open outline, normal or large (the
/// normal one fits inside the large one of its glyph), so that markers at
/// one point, of any two glyphs or of one glyph in both sizes, all stay
/// visible: outlines of different shapes cross in a few pixels only, and
/// none is filled to hide another.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Marker {
    pub glyph: Glyph,
    pub large: bool,
}

impl Marker {
    /// An open circle.
    pub const CIRCLE: Marker = Marker {
        glyph: Glyph::Circle,
        large: false,
    };

    fn scale(self) -> f64 {
        if self.large { LARGE } else { 1.0 }
    }

    /// The polygon drawn (filled) for the marker, px about its centre (y
    /// down); none for a circle, drawn as one. An outline's ring is the
    /// outline and the outline shrunk by a line width (the hole), joined
    /// along a cut of no width.
    fn polygon(self) -> Vec<(i32, i32)> {
        let s = self.scale();
        let px = |(x, y): (f64, f64), k: f64| ((x * k).round() as i32, (y * k).round() as i32);
        let (outline, inradius): (&[(f64, f64)], f64) = match self.glyph {
            Glyph::Circle => return Vec::new(),
            Glyph::Square => (&[(-4.0, -4.0), (4.0, -4.0), (4.0, 4.0), (-4.0, 4.0)], 4.0),
            Glyph::TriangleUp => (&[(0.0, -6.0), (5.0, 3.0), (-5.0, 3.0)], 3.0),
            Glyph::Diamond => (
                &[(0.0, -6.0), (6.0, 0.0), (0.0, 6.0), (-6.0, 0.0)],
                6.0 * std::f64::consts::FRAC_1_SQRT_2,
            ),
            Glyph::TriangleDown => (&[(0.0, 6.0), (-5.0, -3.0), (5.0, -3.0)], 3.0),
        };
        // the hole: the outline scaled to leave RING px at the sides
        let hole = s * (1.0 - RING / (s * inradius));
        let mut ring: Vec<(i32, i32)> = outline.iter().map(|&p| px(p, s)).collect();
        ring.push(px(outline[0], s));
        ring.push(px(outline[0], hole));
        ring.extend(outline.iter().skip(1).rev().map(|&p| px(p, hole)));
        ring.push(px(outline[0], hole));
        ring
    }
}

/// An outline's line width, px, as drawn: the rasteriser fills a polygon's
/// edge pixels too, which adds about a pixel.
const RING: f64 = 1.0;
/// A large marker's size against a normal one's: its outline clears the
/// normal one's by 2-3 px.
const LARGE: f64 = 1.6;
/// An open circle's line width, px (its stroke is drawn as wide as asked).
const CIRCLE_LINE: u32 = 1;

pub(super) struct LegendEntry {
    pub label: String,
    pub colour: RGBColor,
    pub sample: Sample,
}

/// One set of axes.
pub(super) struct Panel {
    pub heading: Option<String>,
    pub x_label: String,
    pub y_label: String,
    pub x: (f64, f64),
    pub y: (f64, f64),
    pub log_y: bool,
    /// Relative height among the figure's panels.
    pub weight: u32,
    pub shapes: Vec<Shape>,
}

pub(super) struct Figure {
    pub title: String,
    pub panels: Vec<Panel>,
    pub legend: Vec<LegendEntry>,
}

/// An open circle's radius, px.
const MARKER: u32 = 5;
/// Width of a reference band (a measured loop drawn under the fitted one), px.
pub(super) const BAND_WIDTH: u32 = 7;
pub(super) const BAND_ALPHA: f64 = 0.35;
/// A baseline's line: seen over a solid model line and through it.
pub(super) const THIN_ALPHA: f64 = 0.85;
const ERROR_BAR_ALPHA: f64 = 0.6;
pub(super) const GREY: RGBColor = RGBColor(90, 90, 90);

/// Draws `figure` on any backend; `bitmap` selects the workaround for wide
/// lines in the bitmap rasteriser (see [`wide_runs`]).
fn draw_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    figure: &Figure,
    bitmap: bool,
) -> Draw<()> {
    root.fill(&WHITE).map_err(fail)?;
    // the title's size shrinks (to 14 px) until it fits the figure's width
    let (full_width, _) = root.dim_in_pixel();
    let mut size = 26.0;
    let title = loop {
        let font = FontDesc::new(FontFamily::SansSerif, size, FontStyle::Bold);
        let (w, _) = root
            .estimate_text_size(&figure.title, &TextStyle::from(font.clone()))
            .map_err(fail)?;
        if w + 20 <= full_width || size <= 14.0 {
            break font;
        }
        size -= 1.0;
    };
    let body = root
        .margin(10, 0, 0, 0)
        .titled(&figure.title, title)
        .map_err(fail)?;
    let (width, height) = body.dim_in_pixel();
    let legend_width = legend_width(root, &figure.legend)?;
    let (plots, legend) = body.split_horizontally(width.saturating_sub(legend_width) as i32);
    if !figure.legend.is_empty() {
        draw_legend(&legend, &figure.legend)?;
    }
    let total: u32 = figure.panels.iter().map(|p| p.weight.max(1)).sum();
    let mut rest = plots;
    for (i, panel) in figure.panels.iter().enumerate() {
        let last = i + 1 == figure.panels.len();
        let area = if last {
            rest.clone()
        } else {
            let h = (height as u64 * panel.weight.max(1) as u64 / total as u64) as i32;
            let (top, bottom) = rest.split_vertically(h);
            rest = bottom;
            top
        };
        draw_panel(&area, panel, bitmap)?;
    }
    root.present().map_err(fail)
}

fn legend_font() -> TextStyle<'static> {
    (FONT, 15).into_font().into()
}

fn legend_width<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    legend: &[LegendEntry],
) -> Draw<u32> {
    if legend.is_empty() {
        return Ok(0);
    }
    let mut widest = 0;
    for e in legend {
        let (w, _) = root
            .estimate_text_size(&e.label, &legend_font())
            .map_err(fail)?;
        widest = widest.max(w);
    }
    Ok((widest + 64).clamp(140, 360))
}

const LEGEND_ROW: i32 = 22;

fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    legend: &[LegendEntry],
) -> Draw<()> {
    let (_, h) = area.dim_in_pixel();
    let rows = ((h as i32 - 40) / LEGEND_ROW).max(1) as usize;
    let shown = if legend.len() > rows {
        rows - 1
    } else {
        legend.len()
    };
    let style = legend_font().pos(plotters::style::text_anchor::Pos::new(
        plotters::style::text_anchor::HPos::Left,
        plotters::style::text_anchor::VPos::Center,
    ));
    for (i, e) in legend.iter().take(shown).enumerate() {
        let y = 30 + i as i32 * LEGEND_ROW;
        draw_sample(area, e, (8, y))?;
        area.draw_text(&e.label, &style, (44, y)).map_err(fail)?;
    }
    if shown < legend.len() {
        let y = 30 + shown as i32 * LEGEND_ROW;
        let more = format!("… {} more", legend.len() - shown);
        area.draw_text(&more, &style, (44, y)).map_err(fail)?;
    }
    Ok(())
}

/// Legend samples are rectangles, circles and polygons, never polylines, so
/// a series' polylines in the SVG are exactly its line segments.
fn draw_sample<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    e: &LegendEntry,
    (x, y): (i32, i32),
) -> Draw<()> {
    let c = e.colour;
    let bar = |x0: i32, x1: i32, half: i32, style: ShapeStyle| {
        Rectangle::new([(x0, y - half), (x1, y + half)], style)
    };
    match e.sample {
        Sample::Line => area.draw(&bar(x, x + 28, 1, c.filled())),
        Sample::Thin => area.draw(&Rectangle::new(
            [(x, y), (x + 28, y + 1)],
            c.mix(THIN_ALPHA).filled(),
        )),
        Sample::Band => area.draw(&bar(
            x,
            x + 28,
            BAND_WIDTH as i32 / 2,
            c.mix(BAND_ALPHA).filled(),
        )),
        Sample::Dashed => {
            area.draw(&bar(x, x + 8, 1, c.filled())).map_err(fail)?;
            area.draw(&bar(x + 11, x + 17, 1, c.filled()))
                .map_err(fail)?;
            area.draw(&bar(x + 20, x + 28, 1, c.filled()))
        }
        Sample::Marker(m) => return draw_marker(area, (x + 14, y), m, c),
    }
    .map_err(fail)
}

/// Draws marker `m` centred on `at`.
fn draw_marker<DB: DrawingBackend, CT: CoordTranslate>(
    area: &DrawingArea<DB, CT>,
    at: CT::From,
    m: Marker,
    c: RGBColor,
) -> Draw<()> {
    let element = EmptyElement::at(at);
    if m.glyph == Glyph::Circle {
        let r = (f64::from(MARKER) * m.scale()).round() as u32;
        area.draw(&(element + Circle::new((0, 0), r, c.stroke_width(CIRCLE_LINE))))
    } else {
        area.draw(&(element + Polygon::new(m.polygon(), c.filled())))
    }
    .map_err(fail)
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
    bitmap: bool,
) -> Draw<()> {
    let mut builder = ChartBuilder::on(area);
    builder
        .margin(10)
        .margin_right(24)
        .x_label_area_size(46)
        .y_label_area_size(86);
    if let Some(heading) = &panel.heading {
        builder.caption(heading, (FONT, 18));
    }
    let x = panel.x.0..panel.x.1;
    let x_axis = LinearAxis::new(panel.x, &panel.x_label);
    if panel.log_y {
        let (bold, light) = log_ticks(panel.y.0, panel.y.1);
        let y = (panel.y.0..panel.y.1)
            .log_scale()
            .with_key_points(bold)
            .with_light_points(light);
        let mut chart = builder.build_cartesian_2d(x, y).map_err(fail)?;
        let y_format = |v: &f64| decade_label(*v);
        draw_mesh(&mut chart, &x_axis, &panel.y_label, &y_format)?;
        draw_shapes(chart.plotting_area(), panel, bitmap)
    } else {
        let y_axis = LinearAxis::new(panel.y, &panel.y_label);
        let mut chart = builder
            .build_cartesian_2d(x, panel.y.0..panel.y.1)
            .map_err(fail)?;
        let y_format = |v: &f64| y_axis.label(*v);
        draw_mesh(&mut chart, &x_axis, &y_axis.desc, &y_format)?;
        draw_shapes(chart.plotting_area(), panel, bitmap)
    }
}

/// A linear axis whose tick labels share a power of ten when the values are
/// tiny or huge (displacements in metres): `-10 … 10` with `(×10⁻⁶)` in the
/// description instead of `-1.0e-5 … 1.0e-5`.
struct LinearAxis {
    scale: f64,
    span: f64,
    desc: String,
}

impl LinearAxis {
    fn new((lo, hi): (f64, f64), desc: &str) -> Self {
        let largest = lo.abs().max(hi.abs());
        let order = if largest > 0.0 {
            largest.log10().floor()
        } else {
            0.0
        };
        let exponent = if (-2.0..5.0).contains(&order) {
            0
        } else {
            3 * (order / 3.0).floor() as i32
        };
        let scale = 10f64.powi(exponent);
        let desc = if exponent == 0 || desc.is_empty() {
            desc.to_string()
        } else {
            format!("{desc} (×10{})", superscript(exponent))
        };
        LinearAxis {
            scale,
            span: (hi - lo) / scale,
            desc,
        }
    }

    fn label(&self, v: f64) -> String {
        tick_label(v / self.scale, self.span)
    }
}

fn draw_mesh<DB: DrawingBackend, Y>(
    chart: &mut ChartContext<DB, Cartesian2d<RangedCoordf64, Y>>,
    x_axis: &LinearAxis,
    y_desc: &str,
    y_format: &dyn Fn(&f64) -> String,
) -> Draw<()>
where
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let x_format = |v: &f64| x_axis.label(*v);
    chart
        .configure_mesh()
        .x_desc(x_axis.desc.as_str())
        .y_desc(y_desc)
        .x_labels(10)
        .y_labels(8)
        .x_label_formatter(&x_format)
        .y_label_formatter(y_format)
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .bold_line_style(BLACK.mix(0.18))
        .light_line_style(BLACK.mix(0.06))
        .draw()
        .map_err(fail)
}

fn draw_shapes<DB: DrawingBackend, CT: CoordTranslate<From = (f64, f64)>>(
    area: &DrawingArea<DB, CT>,
    panel: &Panel,
    bitmap: bool,
) -> Draw<()> {
    let finite = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
    let clip = |y: f64| y.clamp(panel.y.0, panel.y.1);
    for shape in &panel.shapes {
        match shape {
            Shape::Line {
                colour,
                width,
                alpha,
                points,
            } => {
                let style = colour.mix(*alpha).stroke_width(*width);
                for run in points.split(|p| !finite(p)).filter(|r| !r.is_empty()) {
                    if run.len() == 1 {
                        // An isolated point between gaps would vanish as a line.
                        let dot = colour.mix(*alpha).filled();
                        area.draw(&Circle::new(run[0], (*width).max(2), dot))
                            .map_err(fail)?;
                    } else if bitmap && *width > 1 {
                        for part in wide_runs(area, run) {
                            area.draw(&PathElement::new(part, style)).map_err(fail)?;
                        }
                    } else {
                        area.draw(&PathElement::new(run.to_vec(), style))
                            .map_err(fail)?;
                    }
                }
            }
            Shape::Dashed {
                colour,
                width,
                points,
            } => {
                let style = colour.stroke_width(*width);
                for run in points.split(|p| !finite(p)).filter(|r| r.len() > 1) {
                    area.draw(&plotters::element::DashedPathElement::new(
                        run.to_vec(),
                        6,
                        4,
                        style,
                    ))
                    .map_err(fail)?;
                }
            }
            Shape::Markers {
                colour,
                marker,
                points,
            } => {
                for p in points.iter().filter(|p| finite(p)) {
                    draw_marker(area, *p, *marker, *colour)?;
                }
            }
            Shape::Bars { colour, bars } => {
                let style = colour.mix(ERROR_BAR_ALPHA).stroke_width(1);
                for &(x, lo, hi) in bars {
                    if x.is_finite() && lo.is_finite() && hi.is_finite() && hi > lo {
                        let path = vec![(x, clip(lo)), (x, clip(hi))];
                        area.draw(&PathElement::new(path, style)).map_err(fail)?;
                    }
                }
            }
            Shape::Level { colour, y } => {
                let line = [(panel.x.0, *y), (panel.x.1, *y)];
                let style = colour.stroke_width(2);
                area.draw(&plotters::element::DashedPathElement::new(
                    line, 8, 6, style,
                ))
                .map_err(fail)?;
            }
        }
    }
    Ok(())
}

/// Splits a wide line where the bitmap rasteriser would spoil it. It fills
/// the outline of the whole path, which cancels itself where the path turns
/// back (a hysteresis loop's reversal, a stick branch drawn twice) and
/// frays on repeated pixels; so repeated pixels are dropped and the path is
/// cut at every turn sharper than 90°. (The SVG keeps one polyline: its
/// viewers stroke paths natively.)
fn wide_runs<DB: DrawingBackend, CT: CoordTranslate<From = (f64, f64)>>(
    area: &DrawingArea<DB, CT>,
    run: &[(f64, f64)],
) -> Vec<Vec<(f64, f64)>> {
    let mut parts = Vec::new();
    let mut part: Vec<(f64, f64)> = Vec::new();
    let mut pixels: Vec<(i32, i32)> = Vec::new();
    for &p in run {
        let q = area.map_coordinate(&p);
        if pixels.last() == Some(&q) {
            continue;
        }
        if let (&[.., a, b], Some(&corner)) = (&pixels[..], part.last())
            && (b.0 - a.0) * (q.0 - b.0) + (b.1 - a.1) * (q.1 - b.1) < 0
        {
            parts.push(std::mem::replace(&mut part, vec![corner]));
            pixels = vec![b];
        }
        part.push(p);
        pixels.push(q);
    }
    parts.push(part);
    parts.retain(|p| p.len() > 1);
    parts
}

/// Tick label on a linear axis of the given span: just enough decimals to
/// tell ticks apart, trailing zeros dropped.
pub(super) fn tick_label(v: f64, span: f64) -> String {
    if !v.is_finite() {
        return String::new();
    }
    if v.abs() <= span.abs() * 1e-9 {
        return "0".into();
    }
    let decimals = (-(span.abs() / 20.0).log10().floor()).clamp(0.0, 12.0) as usize;
    let text = format!("{v:.decimals$}");
    let text = if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.')
    } else {
        &text
    };
    if text == "-0" { "0" } else { text }.to_string()
}

fn superscript(k: i32) -> String {
    k.to_string()
        .chars()
        .map(|c| match c {
            '-' => '⁻',
            d => ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'][d as usize - '0' as usize],
        })
        .collect()
}

/// Log-axis tick label: `10⁻⁵` at decades, `2×10⁻⁵` between.
pub(super) fn decade_label(v: f64) -> String {
    if !(v.is_finite() && v > 0.0) {
        return String::new();
    }
    let mut k = v.log10().floor();
    let mut m = v / 10f64.powf(k);
    if m >= 9.9995 {
        k += 1.0;
        m = 1.0;
    }
    let sup = superscript(k as i32);
    if (m - 1.0).abs() < 5e-4 {
        format!("10{sup}")
    } else {
        format!("{}×10{sup}", (m * 10.0).round() / 10.0)
    }
}

/// Labelled and light tick values of a log axis from `lo` to `hi`: the
/// decades (every second one beyond 8), or 1-2-5 steps, or every integer
/// multiple for a short range, so at least two ticks are labelled; light
/// lines at every integer multiple of a decade.
pub(super) fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let (a, b) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let at = |multiples: &[f64]| -> Vec<f64> {
        (a..=b)
            .flat_map(|k| multiples.iter().map(move |m| m * 10f64.powi(k)))
            .filter(|v| *v >= lo * (1.0 - 1e-12) && *v <= hi * (1.0 + 1e-12))
            .collect()
    };
    let all: Vec<f64> = (1..10).map(f64::from).collect();
    let decades = at(&[1.0]);
    let bold = if decades.len() >= 2 {
        let step = decades.len().div_ceil(8);
        decades.into_iter().step_by(step).collect()
    } else {
        let steps = at(&[1.0, 2.0, 5.0]);
        if steps.len() >= 3 { steps } else { at(&all) }
    };
    let light = if b - a <= 12 { at(&all) } else { at(&[1.0]) };
    (bold, light)
}

/// Axis range of the finite values, padded so that nothing sits on the
/// frame; on a log axis only positive values count and the range is
/// widened to whole decades (so the axis always carries decade labels).
pub(super) fn axis_range(values: impl Iterator<Item = f64>, log: bool) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return None;
    }
    if log {
        // Pad by 4 % of the decades shown, and show at least a factor 3.
        let ratio = (hi / lo).max(3.0);
        let centre = (hi * lo).sqrt();
        let pad = ratio.powf(0.04);
        return Some((centre / ratio.sqrt() / pad, centre * ratio.sqrt() * pad));
    }
    if hi - lo <= f64::EPSILON * hi.abs().max(lo.abs()) {
        let d = if lo == 0.0 { 1.0 } else { 0.1 * lo.abs() };
        return Some((lo - d, hi + d));
    }
    let pad = 0.04 * (hi - lo);
    Some((lo - pad, hi + pad))
}

/// The PNG and SVG paths for a stem (see [`super::output_paths`]).
pub(super) fn paths(stem: &Path) -> Result<(PathBuf, PathBuf)> {
    let base = match stem.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("png") || e.eq_ignore_ascii_case("svg") => {
            stem.with_extension("")
        }
        _ => stem.to_path_buf(),
    };
    let name = base.file_name().filter(|n| !n.is_empty()).ok_or_else(|| {
        Error::input(
            format!("figure path `{}`", stem.display()),
            "needs a file name stem",
        )
    })?;
    let with = |ext: &str| {
        let mut n = name.to_os_string();
        n.push(ext);
        base.with_file_name(n)
    };
    let (png, svg) = (with(".png"), with(".svg"));
    let dir = match base.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        let e = std::io::Error::new(std::io::ErrorKind::NotFound, "the directory does not exist");
        return Err(Error::io(dir, e));
    }
    Ok((png, svg))
}

/// Removes a temporary bitmap unless it was renamed into place.
struct TempFile(PathBuf);

impl Drop for TempFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// Draws `figure` into memory twice (bitmap, SVG), then writes both files
/// under temporary names and renames them into place: a failure leaves
/// neither a partial file nor a lone new PNG.
/// `figure` drawn as RGB bytes, row by row, [`FIGURE_WIDTH`] ×
/// [`FIGURE_HEIGHT`] px (the PNG's pixels).
pub(super) fn bitmap(figure: &Figure) -> Result<Vec<u8>> {
    super::ensure_fonts()?;
    let (w, h) = (FIGURE_WIDTH, FIGURE_HEIGHT);
    let mut pixels = vec![255u8; w as usize * h as usize * 3];
    draw_figure(
        &BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area(),
        figure,
        true,
    )
    .map_err(|m| {
        let what = format!("figure `{}`", figure.title);
        Error::input(what, format!("drawing the bitmap failed: {m}"))
    })?;
    Ok(pixels)
}

pub(super) fn write_figure(stem: &Path, figure: &Figure) -> Result<Vec<PathBuf>> {
    super::ensure_fonts()?;
    let (png, svg) = paths(stem)?;
    let what = || format!("figure `{}`", figure.title);
    let (w, h) = (FIGURE_WIDTH, FIGURE_HEIGHT);
    let pixels = bitmap(figure)?;
    let mut text = String::new();
    draw_figure(
        &SVGBackend::with_string(&mut text, (w, h)).into_drawing_area(),
        figure,
        false,
    )
    .map_err(|m| Error::input(what(), format!("drawing the SVG failed: {m}")))?;

    // The bitmap encoder picks the format from the extension, so the
    // temporary bitmap keeps a `.png` ending.
    let mut tmp_name = temporary_path(&png).into_os_string();
    tmp_name.push(".png");
    let tmp_png = TempFile(PathBuf::from(tmp_name));
    encode_png(&tmp_png.0, &pixels, (w, h)).map_err(|m| {
        let e = std::io::Error::other(format!("encoding the PNG failed: {m}"));
        Error::io(&tmp_png.0, e)
    })?;
    let (pending_svg, file) = PendingFile::create(&svg)?;
    let mut out = std::io::BufWriter::new(file);
    out.write_all(text.as_bytes())
        .and_then(|_| out.into_inner().map_err(|e| e.into_error()))
        .and_then(|f| f.sync_all())
        .map_err(|e| Error::io(pending_svg.temporary(), e))?;
    std::fs::rename(&tmp_png.0, &png).map_err(|e| Error::io(&png, e))?;
    if let Err(e) = pending_svg.commit() {
        let _ = std::fs::remove_file(&png);
        return Err(e);
    }
    Ok(vec![png, svg])
}

fn encode_png(path: &Path, pixels: &[u8], size: (u32, u32)) -> Draw<()> {
    let mut backend = BitMapBackend::new(path, size);
    backend.blit_bitmap((0, 0), size, pixels).map_err(fail)?;
    backend.present().map_err(fail)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_ticks_label_at_least_two_values_inside_the_range() {
        for k in -40..40 {
            let lo = 10f64.powf(k as f64 / 7.0);
            for ratio in [3.0, 4.5, 20.0, 1e3, 1e9, 1e15] {
                let hi = lo * ratio;
                let (bold, light) = log_ticks(lo, hi);
                assert!((2..=10).contains(&bold.len()), "{lo}..{hi}: {bold:?}");
                assert!(bold.windows(2).all(|w| w[0] < w[1]));
                for v in bold.iter().chain(&light) {
                    assert!(
                        *v >= lo * (1.0 - 1e-12) && *v <= hi * (1.0 + 1e-12),
                        "{v} outside {lo}..{hi}"
                    );
                }
            }
        }
        assert_eq!(log_ticks(0.9e-6, 2.1e-4).0, [1e-6, 1e-5, 1e-4]);
    }

    #[test]
    fn tick_labels_read_cleanly() {
        assert_eq!(tick_label(0.1 + 0.2, 0.5), "0.3");
        assert_eq!(tick_label(-0.1, 0.5), "-0.1");
        assert_eq!(tick_label(250.0, 120.0), "250");
        assert_eq!(tick_label(1e-17, 0.5), "0");
        assert_eq!(tick_label(2.5, 4.0), "2.5");
        assert_eq!(decade_label(1e-5), "10⁻⁵");
        assert_eq!(decade_label(2e-5 * (1.0 + f64::EPSILON)), "2×10⁻⁵");
        assert_eq!(decade_label(100.0), "10²");
        assert_eq!(decade_label(9.99999e2), "10³");
        let axis = LinearAxis::new((-1.2e-5, 1.2e-5), "x [m]");
        assert_eq!(
            (axis.label(-1e-5), axis.desc.as_str()),
            ("-10".to_string(), "x [m] (×10⁻⁶)")
        );
        assert_eq!(LinearAxis::new((0.0, 360.0), "φ").desc, "φ");
    }

    #[test]
    fn log_axis_range_pads_and_spans_at_least_a_factor_three() {
        let (lo, hi) = axis_range([1e-6, 1e-3, 0.0, -1.0, f64::NAN].into_iter(), true).unwrap();
        let pad = 1e3f64.powf(0.04);
        assert!((lo * pad / 1e-6 - 1.0).abs() < 1e-12 && (hi / pad / 1e-3 - 1.0).abs() < 1e-12);
        let (lo, hi) = axis_range([2.0, 2.0].into_iter(), true).unwrap();
        assert!((hi / lo - 3f64.powf(1.08)).abs() < 1e-9 && ((lo * hi).sqrt() - 2.0).abs() < 1e-12);
        assert_eq!(axis_range([0.0, f64::INFINITY].into_iter(), true), None);
        assert_eq!(axis_range([5.0].into_iter(), false), Some((4.5, 5.5)));
    }
}
