//! Figures: nonlinear FRF overlays, hysteresis loops, residuals, time
//! overlays and optimiser convergence, each written as a PNG and an SVG.
//!
//! The figures follow the paper's: measured against estimated FRFs at
//! several force levels (Figs. 3.4 right, 4.2, 4.4), reference against
//! estimated hysteresis loops (Figs. 3.2, 3.4 left, 4.3) and measured
//! against simulated time responses (Fig. 4.5). Inputs are plain data
//! structs defined here, so this module depends on no later stage; the
//! one bridge is [`frf_series_from`] for [`crate::extract::NonlinearFrf`].
//!
//! Conventions shared by every `write_*` function:
//!
//! * **Files.** `stem` names both outputs: `stem.png` (bitmap,
//!   [`FIGURE_WIDTH`] × [`FIGURE_HEIGHT`] px) and `stem.svg`; a stem ending
//!   in `.png` or `.svg` has that extension replaced, any other ending is
//!   kept (`fit.v2` gives `fit.v2.png`), see [`output_paths`]. The paths are
//!   returned as `[png, svg]`. Both are drawn in memory first, then written
//!   under temporary names and renamed into place ([`crate::atomic`]): an
//!   error leaves no partial file.
//! * **Bad data.** An empty series list, a series without points, mismatched
//!   lengths or a series with nothing plottable is an `Err` naming the
//!   series. Individual NaN/±Inf points (and zeros on a log axis) are
//!   skipped: markers are omitted and lines are broken at them.
//! * **Colour.** Each series carries a `group` (an excitation level, say):
//!   measured markers and model lines of one group share its colour. The
//!   figures over levels (FRFs, loops, residuals) take it from a sequential
//!   colour map ([`level_colour`], viridis from dark to light green, lowest
//!   level darkest), so that 7 or more levels stay in order and readable;
//!   the others (time overlays, convergence) from a 10-colour palette
//!   ([`group_colour`]). Measured markers differ by group as well: open
//!   circle, square, triangle, diamond, inverted triangle, then the same
//!   five larger (see `marker_of`), so that levels measured
//!   at the same frequencies stay visible where their points coincide. Series
//!   with an empty label stay out of the legend.
//! * **Fonts.** Text is rendered with the DejaVu Sans faces compiled into the
//!   binary ([`ensure_fonts`]), so no system font library is needed (and
//!   the same text renders the same on every machine).

mod decimate;
mod render;

use decimate::SignalTrace;
pub use decimate::{ColumnExtremes, min_max_columns};

use crate::error::{Error, Result};
use crate::extract::{Direction, NonlinearFrf};
use num_complex::Complex64;
use plotters::style::RGBColor;
use render::{Figure, GREY, Glyph, LegendEntry, Marker, Panel, Sample, Shape, axis_range};
use std::path::{Path, PathBuf};

/// Width of every figure, px (the SVG uses the same user units).
pub const FIGURE_WIDTH: u32 = 1000;
/// Height of every figure, px.
pub const FIGURE_HEIGHT: u32 = 700;

/// Registers the DejaVu Sans regular and bold faces as the `sans-serif`
/// family used by every figure. Runs once per process; later calls return
/// the first outcome.
pub fn ensure_fonts() -> Result<()> {
    use plotters::style::{FontStyle, register_font};
    static FONTS: std::sync::OnceLock<render::Draw<()>> = std::sync::OnceLock::new();
    FONTS
        .get_or_init(|| {
            let faces = [
                (FontStyle::Normal, dejavu::sans::regular()),
                (FontStyle::Bold, dejavu::sans::bold()),
            ];
            for (style, bytes) in faces {
                register_font("sans-serif", style, bytes).map_err(|_| {
                    render::DrawError(format!(
                        "the DejaVu Sans {} face is invalid",
                        style.as_str()
                    ))
                })?;
            }
            Ok(())
        })
        .clone()
        .map_err(|m| Error::input("plot fonts", m.0))
}

/// The `[png, svg]` paths a `write_*` function writes for `stem` (see the
/// module docs); an error if the directory does not exist or there is no
/// file name.
pub fn output_paths(stem: &Path) -> Result<[PathBuf; 2]> {
    let (png, svg) = render::paths(stem)?;
    Ok([png, svg])
}

/// The colour of a group as RGB bytes (the palette of matplotlib's
/// "tab10", chosen to stay distinguishable on white for 10 levels).
pub fn group_colour(group: usize) -> [u8; 3] {
    const PALETTE: [[u8; 3]; 10] = [
        [31, 119, 180],
        [255, 127, 14],
        [44, 160, 44],
        [214, 39, 40],
        [148, 103, 189],
        [140, 86, 75],
        [227, 119, 194],
        [127, 127, 127],
        [188, 189, 34],
        [23, 190, 207],
    ];
    PALETTE[group % PALETTE.len()]
}

fn colour(group: usize) -> RGBColor {
    let [r, g, b] = group_colour(group);
    RGBColor(r, g, b)
}

/// The colour of group `group` of `groups` ordered ones (levels, lowest
/// first) as RGB bytes: viridis sampled evenly from 0 (dark purple) to 0.85
/// (green; its pale yellow end is left out, which reads poorly on white).
pub fn level_colour(group: usize, groups: usize) -> [u8; 3] {
    const VIRIDIS: [[f64; 3]; 9] = [
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
    let t = if groups <= 1 {
        0.0
    } else {
        0.85 * (group.min(groups - 1) as f64) / ((groups - 1) as f64)
    };
    let x = t * (VIRIDIS.len() - 1) as f64;
    let i = (x.floor() as usize).min(VIRIDIS.len() - 2);
    let w = x - i as f64;
    let mut rgb = [0u8; 3];
    for (k, c) in rgb.iter_mut().enumerate() {
        *c = (VIRIDIS[i][k] * (1.0 - w) + VIRIDIS[i + 1][k] * w).round() as u8;
    }
    rgb
}

/// The colours of a figure over ordered groups: [`level_colour`] over this
/// many groups.
#[derive(Clone, Copy, Debug)]
struct Palette(usize);

impl Palette {
    /// A sequential map over the groups of `groups`.
    fn over(groups: impl Iterator<Item = usize>) -> Palette {
        Palette(groups.max().map_or(1, |g| g + 1))
    }

    fn colour(self, group: usize) -> RGBColor {
        let [r, g, b] = level_colour(group, self.0);
        RGBColor(r, g, b)
    }
}

/// The marker of group `group`: five glyphs, then the same five larger
/// (groups 5–9), repeated. Levels measured at the same frequencies put
/// their markers on top of each other; colour alone would leave only the
/// last one drawn, while open outlines of different shapes, and a normal
/// one inside a large one, all stay visible.
fn marker_of(group: usize) -> Marker {
    const GLYPHS: [Glyph; 5] = [
        Glyph::Circle,
        Glyph::Square,
        Glyph::TriangleUp,
        Glyph::Diamond,
        Glyph::TriangleDown,
    ];
    Marker {
        glyph: GLYPHS[group % GLYPHS.len()],
        large: !(group / GLYPHS.len()).is_multiple_of(2),
    }
}

/// Whether a series is data or a model's prediction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SeriesStyle {
    /// Measured (or reference) data: FRF markers with optional error bars,
    /// a wide translucent band for a loop.
    #[default]
    Measured,
    /// A model's prediction: a solid line.
    Model,
    /// A model's unstable solution (a fold's middle branch, which no test
    /// reaches): a dashed line.
    Unstable,
    /// A model another is compared with (a diagnosis's baseline): a thin
    /// grey line over the other's solid one, a thread along it where the
    /// two agree, apart where they differ.
    Baseline,
}

/// One FRF curve: `H` at each excitation frequency.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrfSeries {
    /// Legend text, e.g. `2 N`; empty keeps it out of the legend.
    pub label: String,
    /// Colour group, e.g. the level's index.
    pub group: usize,
    /// Excitation frequencies, Hz.
    pub frequency_hz: Vec<f64>,
    /// The FRF at each frequency.
    pub h: Vec<Complex64>,
    /// Standard error of each `H` as in [`crate::extract::FrfPoint`] (the
    /// RMS of the complex error). Drawn for measured series as bars of
    /// ±σ/√2 in magnitude and ±asin(σ/(√2|H|)) in phase: the radial and
    /// tangential parts of a circular complex error of total RMS σ.
    pub std_error: Option<Vec<f64>>,
    /// Markers or line.
    pub style: SeriesStyle,
}

fn series_name(kind: &str, index: usize, label: &str) -> String {
    if label.is_empty() {
        format!("{kind} series {index}")
    } else {
        format!("{kind} series {index} `{label}`")
    }
}

fn check_lengths(name: &str, pairs: &[(&str, usize)]) -> Result<()> {
    let (first, n) = pairs[0];
    if n == 0 {
        return Err(Error::input(name, format!("`{first}` has no points")));
    }
    for &(field, m) in &pairs[1..] {
        if m != n {
            return Err(Error::input(
                name,
                format!("`{field}` has {m} values but `{first}` has {n}"),
            ));
        }
    }
    Ok(())
}

/// An error unless some point is plottable.
fn require_plottable(name: &str, points: &[(f64, f64)], what: &str) -> Result<()> {
    if points.iter().any(|p| p.0.is_finite() && p.1.is_finite()) {
        Ok(())
    } else {
        Err(Error::input(
            name,
            format!("no plottable point: every point is NaN/Inf{what}"),
        ))
    }
}

fn require_series(title: &str, count: usize) -> Result<()> {
    if count == 0 {
        Err(Error::input(
            format!("figure `{title}`"),
            "no series to plot",
        ))
    } else {
        Ok(())
    }
}

/// The non-finite point that breaks a line.
const GAP: (f64, f64) = (f64::NAN, f64::NAN);

fn legend_entry(label: &str, colour: RGBColor, sample: Sample) -> Option<LegendEntry> {
    (!label.is_empty()).then(|| LegendEntry {
        label: label.to_string(),
        colour,
        sample,
    })
}

fn range_of(panels: &[&[(f64, f64)]], pick: fn(&(f64, f64)) -> f64, log: bool) -> (f64, f64) {
    let values = panels.iter().flat_map(|p| p.iter().map(pick));
    // Validation guarantees a finite point, so the fallback is never used.
    axis_range(values, log).unwrap_or((1.0, 10.0))
}

/// Phase in degrees, unwrapped along the series (across gaps) and shifted by
/// a whole number of turns so its mean lies in [-180°, 180°]: receptance
/// then runs 0 → −180° through resonance without a jump.
fn unwrapped_phase_deg(h: &[Complex64]) -> Vec<f64> {
    let mut previous: Option<f64> = None;
    let mut phase: Vec<f64> = h
        .iter()
        .map(|z| {
            if !(z.re.is_finite() && z.im.is_finite()) || z.norm() == 0.0 {
                return f64::NAN;
            }
            let mut p = z.arg().to_degrees();
            if let Some(q) = previous {
                p += 360.0 * ((q - p) / 360.0).round();
            }
            previous = Some(p);
            p
        })
        .collect();
    let finite: Vec<f64> = phase.iter().copied().filter(|p| p.is_finite()).collect();
    if !finite.is_empty() {
        let mean = finite.iter().sum::<f64>() / finite.len() as f64;
        let shift = 360.0 * (mean / 360.0).round();
        phase.iter_mut().for_each(|p| *p -= shift);
    }
    phase
}

/// A series with its magnitude and phase points.
type PhaseTrace<T> = (T, Vec<(f64, f64)>, Vec<(f64, f64)>);

/// Shifts each series' unwrapped phase by whole turns so that, where it
/// starts (its lowest frequency), it lies within half a turn of the first
/// series' phase there: the levels of one test, measured and modelled,
/// are then drawn on the same turn (each series alone is centred on its own
/// mean, which can put one level a turn away from the others).
fn align_phases<T>(traces: &mut [PhaseTrace<T>]) {
    let start = |phase: &[(f64, f64)]| -> Option<f64> {
        phase
            .iter()
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|p| p.1)
    };
    let Some(reference) = traces.iter().find_map(|t| start(&t.2)) else {
        return;
    };
    for t in traces.iter_mut() {
        if let Some(p0) = start(&t.2) {
            let shift = 360.0 * ((reference - p0) / 360.0).round();
            t.2.iter_mut().for_each(|p| p.1 += shift);
        }
    }
}

/// Writes the FRF overlay: |H| on a log axis (labelled `magnitude_label`,
/// e.g. `|H1| [m/N]`) above the phase in degrees, over frequency. Model
/// lines are drawn under measured markers. Returns `[png, svg]`.
pub fn write_frf_plot(
    stem: &Path,
    title: &str,
    magnitude_label: &str,
    series: &[FrfSeries],
) -> Result<Vec<PathBuf>> {
    render::write_figure(stem, &frf_figure(title, magnitude_label, series)?)
}

fn frf_figure(title: &str, magnitude_label: &str, series: &[FrfSeries]) -> Result<Figure> {
    require_series(title, series.len())?;
    let mut traces = Vec::with_capacity(series.len());
    for (i, s) in series.iter().enumerate() {
        let name = series_name("FRF", i, &s.label);
        let errors = s.std_error.as_ref().map_or(s.h.len(), Vec::len);
        check_lengths(
            &name,
            &[
                ("frequency_hz", s.frequency_hz.len()),
                ("h", s.h.len()),
                ("std_error", errors),
            ],
        )?;
        let magnitude: Vec<(f64, f64)> = s
            .frequency_hz
            .iter()
            .zip(&s.h)
            .map(|(&f, z)| (f, z.norm()))
            .map(|(f, m)| {
                if f.is_finite() && m.is_finite() && m > 0.0 {
                    (f, m)
                } else {
                    GAP
                }
            })
            .collect();
        require_plottable(&name, &magnitude, " or |H| = 0")?;
        let phase: Vec<(f64, f64)> = magnitude
            .iter()
            .zip(unwrapped_phase_deg(&s.h))
            .map(|(&(f, _), p)| (f, p))
            .collect();
        traces.push((s, magnitude, phase));
    }
    align_phases(&mut traces);
    let mags: Vec<&[(f64, f64)]> = traces.iter().map(|t| t.1.as_slice()).collect();
    let palette = Palette::over(series.iter().map(|s| s.group));
    let phases: Vec<&[(f64, f64)]> = traces.iter().map(|t| t.2.as_slice()).collect();
    let x = range_of(&mags, |p| p.0, false);
    let mut top = panel(magnitude_label, x, range_of(&mags, |p| p.1, true), true, 3);
    let mut bottom = panel("phase [°]", x, range_of(&phases, |p| p.1, false), false, 2);
    top.x_label = String::new();
    bottom.x_label = "frequency [Hz]".into();
    for pass in [
        SeriesStyle::Unstable,
        SeriesStyle::Model,
        SeriesStyle::Baseline,
        SeriesStyle::Measured,
    ] {
        for (s, magnitude, phase) in traces.iter().filter(|t| t.0.style == pass) {
            let (c, mark) = (palette.colour(s.group), marker_of(s.group));
            if pass == SeriesStyle::Baseline {
                top.shapes.push(thin(GREY, magnitude.clone()));
                bottom.shapes.push(thin(GREY, phase.clone()));
                continue;
            }
            if pass == SeriesStyle::Model {
                top.shapes.push(line(c, 2, magnitude.clone()));
                bottom.shapes.push(line(c, 2, phase.clone()));
                continue;
            }
            if pass == SeriesStyle::Unstable {
                top.shapes.push(dashed(c, 2, magnitude.clone()));
                bottom.shapes.push(dashed(c, 2, phase.clone()));
                continue;
            }
            if let Some(sigma) = &s.std_error {
                let (m_bars, p_bars) = frf_error_bars(magnitude, phase, sigma);
                top.shapes.push(Shape::Bars {
                    colour: c,
                    bars: m_bars,
                });
                bottom.shapes.push(Shape::Bars {
                    colour: c,
                    bars: p_bars,
                });
            }
            top.shapes.push(markers(c, mark, magnitude.clone()));
            bottom.shapes.push(markers(c, mark, phase.clone()));
        }
    }
    let mut legend: Vec<LegendEntry> = series
        .iter()
        .filter_map(|s| legend_entry(&s.label, palette.colour(s.group), sample(s.style, s.group)))
        .collect();
    legend.extend(style_entries(series));
    if series.iter().any(|s| s.style == SeriesStyle::Unstable) {
        legend.push(LegendEntry {
            label: "unstable".into(),
            colour: GREY,
            sample: Sample::Dashed,
        });
    }
    Ok(Figure {
        title: title.into(),
        panels: vec![top, bottom],
        legend,
    })
}

/// The legend's grey entries naming the line styles once: model lines left
/// out of the legend (one entry per level, the level's colour) are named
/// with what the markers are, a baseline's beside the final model's.
fn style_entries(series: &[FrfSeries]) -> Vec<LegendEntry> {
    let unlabelled = |style| {
        series
            .iter()
            .any(|s| s.style == style && s.label.is_empty())
    };
    let baseline = unlabelled(SeriesStyle::Baseline);
    let mut out = Vec::new();
    if !(unlabelled(SeriesStyle::Model) || baseline) {
        return out;
    }
    let grey = |label: &str, sample| LegendEntry {
        label: label.into(),
        colour: GREY,
        sample,
    };
    if series.iter().any(|s| s.style == SeriesStyle::Measured) {
        out.push(grey("measured", Sample::Marker(Marker::CIRCLE)));
    }
    if baseline {
        out.push(grey("baseline model", Sample::Thin));
        out.push(grey("final model", Sample::Line));
    } else {
        out.push(grey("model", Sample::Line));
    }
    out
}

/// `(frequency, low, high)`.
type ErrorBar = (f64, f64, f64);

fn frf_error_bars(
    magnitude: &[(f64, f64)],
    phase: &[(f64, f64)],
    sigma: &[f64],
) -> (Vec<ErrorBar>, Vec<ErrorBar>) {
    let half = std::f64::consts::FRAC_1_SQRT_2;
    magnitude
        .iter()
        .zip(phase)
        .zip(sigma)
        .map(|((&(f, m), &(_, p)), &s)| {
            let dm = s * half;
            let dp = (dm / m).min(1.0).asin().to_degrees();
            ((f, m - dm, m + dm), (f, p - dp, p + dp))
        })
        .unzip()
}

fn sample(style: SeriesStyle, group: usize) -> Sample {
    match style {
        SeriesStyle::Measured => Sample::Marker(marker_of(group)),
        SeriesStyle::Model => Sample::Line,
        SeriesStyle::Unstable => Sample::Dashed,
        SeriesStyle::Baseline => Sample::Thin,
    }
}

fn panel(y_label: &str, x: (f64, f64), y: (f64, f64), log_y: bool, weight: u32) -> Panel {
    Panel {
        heading: None,
        x_label: String::new(),
        y_label: y_label.into(),
        x,
        y,
        log_y,
        weight,
        shapes: Vec::new(),
    }
}

fn line(colour: RGBColor, width: u32, points: Vec<(f64, f64)>) -> Shape {
    Shape::Line {
        colour,
        width,
        alpha: 1.0,
        points,
    }
}

/// A baseline's line: one pixel wide (see [`SeriesStyle::Baseline`]).
fn thin(colour: RGBColor, points: Vec<(f64, f64)>) -> Shape {
    Shape::Line {
        colour,
        width: 1,
        alpha: render::THIN_ALPHA,
        points,
    }
}

fn dashed(colour: RGBColor, width: u32, points: Vec<(f64, f64)>) -> Shape {
    Shape::Dashed {
        colour,
        width,
        points,
    }
}

fn markers(colour: RGBColor, marker: Marker, points: Vec<(f64, f64)>) -> Shape {
    Shape::Markers {
        colour,
        marker,
        points,
    }
}

/// A level for a legend, in the drive's `unit`: 3 significant digits, no
/// trailing zeros (a measured 57.7418 N reads `57.7 N`), enough to tell a
/// test's levels apart, which are steps of a few per cent or more; a level
/// of 1000 or more is written whole (`3050 N`).
pub fn level_label(level: f64, unit: &str) -> String {
    if !level.is_finite() || level == 0.0 {
        return format!("{level} {unit}");
    }
    let digits = 3 - 1 - level.abs().log10().floor() as i32;
    let rounded = if digits < 0 {
        let step = 10f64.powi(-digits);
        (level / step).round() * step
    } else {
        level
    };
    let decimals = digits.max(0) as usize;
    let mut t = format!("{rounded:.decimals$}");
    if t.contains('.') {
        t = t.trim_end_matches('0').trim_end_matches('.').to_string();
    }
    format!("{t} {unit}")
}

/// The FRF of harmonic `harmonic` of every level of `frf`, one series per
/// level (in file order), coloured by nominal level: an up and a down sweep
/// at the same level share a group. Labels read `2 N`, `2 N up`/`2 N down`
/// when both directions occur, with ` (model)` appended for
/// [`SeriesStyle::Model`]. Measured series carry the standard errors; a
/// point without that harmonic gives NaN (skipped when drawn).
pub fn frf_series_from(
    frf: &NonlinearFrf,
    harmonic: usize,
    style: SeriesStyle,
) -> Result<Vec<FrfSeries>> {
    if harmonic > frf.max_harmonic {
        return Err(Error::input(
            "nonlinear FRF",
            format!(
                "harmonic {harmonic} requested but the FRF holds harmonics 0..={}",
                frf.max_harmonic
            ),
        ));
    }
    let unit = frf.reference.si_unit();
    let both = frf.levels.iter().any(|l| l.direction == Direction::Down)
        && frf.levels.iter().any(|l| l.direction == Direction::Up);
    let mut levels: Vec<f64> = Vec::new();
    let nan = Complex64::new(f64::NAN, f64::NAN);
    let series = frf.levels.iter().map(|level| {
        let group = match levels.iter().position(|&l| l == level.level) {
            Some(g) => g,
            None => {
                levels.push(level.level);
                levels.len() - 1
            }
        };
        let mut label = level_label(level.level, unit);
        if both {
            label += if level.direction == Direction::Up {
                " up"
            } else {
                " down"
            };
        }
        if style == SeriesStyle::Model {
            label += " (model)";
        }
        let pts = &level.points;
        let std_error = (style == SeriesStyle::Measured).then(|| {
            pts.iter()
                .map(|p| p.std_error.get(harmonic).copied().unwrap_or(f64::NAN))
                .collect()
        });
        FrfSeries {
            label,
            group,
            frequency_hz: pts.iter().map(|p| p.frequency_hz).collect(),
            h: pts
                .iter()
                .map(|p| p.h.get(harmonic).copied().unwrap_or(nan))
                .collect(),
            std_error,
            style,
        }
    });
    Ok(series.collect())
}

/// The magnitude axis label for harmonic `harmonic` of `frf`, e.g.
/// `|H1| [m/N]` or `|H3| [(m/s²)/N]`.
pub fn frf_magnitude_label(frf: &NonlinearFrf, harmonic: usize) -> String {
    let response = frf.response.si_unit().replace("^2", "²");
    let reference = frf.reference.si_unit();
    if response.contains('/') {
        format!("|H{harmonic}| [({response})/{reference}]")
    } else {
        format!("|H{harmonic}| [{response}/{reference}]")
    }
}

/// One hysteresis loop: the element force against the relative displacement
/// over (at least) one period.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoopSeries {
    /// Legend text, e.g. `reference, 4 N`; empty keeps it out of the legend.
    pub label: String,
    /// Colour group, e.g. the amplitude's index.
    pub group: usize,
    /// Displacement across the joint.
    pub displacement: Vec<f64>,
    /// Force transmitted by the joint, one per displacement.
    pub force: Vec<f64>,
    /// [`SeriesStyle::Measured`]: a reference loop, drawn as a wide
    /// translucent band under the [`SeriesStyle::Model`] (fitted) lines.
    pub style: SeriesStyle,
}

/// Writes hysteresis loops, force against displacement, for several
/// amplitudes: references as translucent bands, fitted loops as lines on
/// top. Returns `[png, svg]`.
pub fn write_loop_plot(
    stem: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[LoopSeries],
) -> Result<Vec<PathBuf>> {
    require_series(title, series.len())?;
    let mut traces = Vec::with_capacity(series.len());
    for (i, s) in series.iter().enumerate() {
        let name = series_name("loop", i, &s.label);
        check_lengths(
            &name,
            &[
                ("displacement", s.displacement.len()),
                ("force", s.force.len()),
            ],
        )?;
        let points = finite_pairs(&s.displacement, &s.force);
        require_plottable(&name, &points, "")?;
        traces.push((s, points));
    }
    let all: Vec<&[(f64, f64)]> = traces.iter().map(|t| t.1.as_slice()).collect();
    let mut p = panel(
        y_label,
        range_of(&all, |p| p.0, false),
        range_of(&all, |p| p.1, false),
        false,
        1,
    );
    p.x_label = x_label.into();
    let palette = Palette::over(series.iter().map(|s| s.group));
    for pass in [
        SeriesStyle::Measured,
        SeriesStyle::Baseline,
        SeriesStyle::Unstable,
        SeriesStyle::Model,
    ] {
        for (s, points) in traces.iter().filter(|t| t.0.style == pass) {
            let (c, points) = (palette.colour(s.group), points.clone());
            p.shapes.push(match pass {
                SeriesStyle::Measured => Shape::Line {
                    colour: c,
                    width: render::BAND_WIDTH,
                    alpha: render::BAND_ALPHA,
                    points,
                },
                SeriesStyle::Model => line(c, 2, points),
                SeriesStyle::Unstable => dashed(c, 2, points),
                SeriesStyle::Baseline => thin(c, points),
            });
        }
    }
    let legend = series.iter().filter_map(|s| {
        let sample = match s.style {
            SeriesStyle::Measured => Sample::Band,
            SeriesStyle::Model => Sample::Line,
            SeriesStyle::Unstable => Sample::Dashed,
            SeriesStyle::Baseline => Sample::Thin,
        };
        legend_entry(&s.label, palette.colour(s.group), sample)
    });
    let figure = Figure {
        title: title.into(),
        panels: vec![p],
        legend: legend.collect(),
    };
    render::write_figure(stem, &figure)
}

/// `(x, y)` pairs, a gap wherever either is not finite.
fn finite_pairs(x: &[f64], y: &[f64]) -> Vec<(f64, f64)> {
    x.iter()
        .zip(y)
        .map(|(&a, &b)| {
            if a.is_finite() && b.is_finite() {
                (a, b)
            } else {
                GAP
            }
        })
        .collect()
}

/// A residual per frequency: `|H_meas − H_model|`, possibly divided by the
/// measurement's standard error.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ResidualSeries {
    /// Legend text; empty keeps it out of the legend.
    pub label: String,
    /// Colour group (the level's index, as in the FRF plot).
    pub group: usize,
    /// Excitation frequencies, Hz.
    pub frequency_hz: Vec<f64>,
    /// The residual at each frequency (plotted on a log axis: zeros are
    /// skipped).
    pub residual: Vec<f64>,
}

/// The residual of a model against a measurement at the same frequencies:
/// `|H_meas − H_model|`, or with `normalise` that divided by the
/// measurement's standard error σ (for a correct model and a circular
/// complex Gaussian error, (|ΔH|/σ)² averages 1 and |ΔH|/σ exceeds 2 with
/// probability e⁻⁴ ≈ 1.8 %). Points whose σ is not a finite positive
/// number give NaN. An error if the frequencies differ (relative 1e-9), or
/// `normalise` is asked for without standard errors.
pub fn residual_series(
    label: &str,
    group: usize,
    measured: &FrfSeries,
    model: &FrfSeries,
    normalise: bool,
) -> Result<ResidualSeries> {
    let name = series_name("residual", group, label);
    let n = measured.h.len();
    check_lengths(
        &name,
        &[
            ("measured.h", n),
            ("measured.frequency_hz", measured.frequency_hz.len()),
            ("model.h", model.h.len()),
            ("model.frequency_hz", model.frequency_hz.len()),
        ],
    )?;
    let sigma = match (&measured.std_error, normalise) {
        (Some(s), true) if s.len() == n => Some(s),
        (_, true) => {
            return Err(Error::input(
                name,
                format!("normalising needs measured.std_error with {n} values"),
            ));
        }
        (_, false) => None,
    };
    let mut residual = Vec::with_capacity(n);
    for i in 0..n {
        let (fa, fb) = (measured.frequency_hz[i], model.frequency_hz[i]);
        if (fa - fb).abs() > 1e-9 * fa.abs().max(fb.abs()) {
            return Err(Error::input(
                name,
                format!("frequency {i} differs: measured {fa} Hz, model {fb} Hz"),
            ));
        }
        let r = (measured.h[i] - model.h[i]).norm();
        residual.push(match sigma {
            Some(s) if s[i].is_finite() && s[i] > 0.0 => r / s[i],
            Some(_) => f64::NAN,
            None => r,
        });
    }
    Ok(ResidualSeries {
        label: label.into(),
        group,
        frequency_hz: measured.frequency_hz.clone(),
        residual,
    })
}

/// One panel of a residual plot, e.g. `before: Masing` or `after: Masing +
/// cubic stiffness`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ResidualPanel {
    /// The panel's heading.
    pub heading: String,
    /// The residuals, one series per level.
    pub series: Vec<ResidualSeries>,
}

/// A horizontal reference line in a residual plot, e.g. `2` labelled
/// `2σ noise level` for normalised residuals.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NoiseLevel {
    /// The level, in the residual's unit.
    pub value: f64,
    /// Legend text.
    pub label: String,
}

/// Writes residuals against frequency, one panel per entry of `panels`
/// (e.g. before and after a model change, stacked, on one shared log axis so
/// they compare honestly), with an optional dashed noise level in every
/// panel. Returns `[png, svg]`.
pub fn write_residual_plot(
    stem: &Path,
    title: &str,
    y_label: &str,
    panels: &[ResidualPanel],
    noise: Option<&NoiseLevel>,
) -> Result<Vec<PathBuf>> {
    require_series(title, panels.iter().map(|p| p.series.len()).sum())?;
    if let Some(level) = noise
        && !(level.value.is_finite() && level.value > 0.0)
    {
        let what = format!("noise level `{}`", level.label);
        return Err(Error::input(
            what,
            format!("must be finite and > 0 (log axis), got {}", level.value),
        ));
    }
    let mut traces = Vec::new();
    for p in panels {
        let mut lines = Vec::new();
        for (i, s) in p.series.iter().enumerate() {
            let name = series_name(&format!("`{}` residual", p.heading), i, &s.label);
            check_lengths(
                &name,
                &[
                    ("frequency_hz", s.frequency_hz.len()),
                    ("residual", s.residual.len()),
                ],
            )?;
            let mut points = finite_pairs(&s.frequency_hz, &s.residual);
            points
                .iter_mut()
                .filter(|p| p.1 <= 0.0)
                .for_each(|p| *p = GAP);
            require_plottable(&name, &points, " or ≤ 0")?;
            lines.push((s, points));
        }
        traces.push(lines);
    }
    let all: Vec<&[(f64, f64)]> = traces.iter().flatten().map(|t| t.1.as_slice()).collect();
    let x = range_of(&all, |p| p.0, false);
    let noise_y = noise.map(|n| n.value);
    let ys = all
        .iter()
        .flat_map(|p| p.iter().map(|q| q.1))
        .chain(noise_y);
    let y = axis_range(ys, true).unwrap_or((1.0, 10.0));
    let palette = Palette::over(panels.iter().flat_map(|p| &p.series).map(|s| s.group));
    let mut figure_panels = Vec::new();
    for (i, (p, lines)) in panels.iter().zip(&traces).enumerate() {
        let mut fp = panel(y_label, x, y, true, 1);
        fp.heading = Some(p.heading.clone());
        if i + 1 == panels.len() {
            fp.x_label = "frequency [Hz]".into();
        }
        for (s, points) in lines {
            let c = palette.colour(s.group);
            fp.shapes.push(line(c, 1, points.clone()));
            fp.shapes
                .push(markers(c, marker_of(s.group), points.clone()));
        }
        if let Some(level) = noise_y {
            fp.shapes.push(Shape::Level {
                colour: GREY,
                y: level,
            });
        }
        figure_panels.push(fp);
    }
    let mut legend: Vec<LegendEntry> = Vec::new();
    for s in panels.iter().flat_map(|p| &p.series) {
        let duplicate = legend
            .iter()
            .any(|e| e.label == s.label && e.colour == palette.colour(s.group));
        if let Some(e) = legend_entry(
            &s.label,
            palette.colour(s.group),
            sample(SeriesStyle::Measured, s.group),
        ) && !duplicate
        {
            legend.push(e);
        }
    }
    if let Some(n) = noise {
        legend.push(LegendEntry {
            label: n.label.clone(),
            colour: GREY,
            sample: Sample::Dashed,
        });
    }
    let figure = Figure {
        title: title.into(),
        panels: figure_panels,
        legend,
    };
    render::write_figure(stem, &figure)
}

/// A uniformly sampled signal.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TimeSignal {
    /// Legend text, e.g. `measured`.
    pub label: String,
    /// Time of the first sample, s.
    pub start_s: f64,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The samples.
    pub values: Vec<f64>,
}

/// Decimation columns for a time trace: at least one per pixel of the plot
/// area (which is narrower than the figure), so each pixel column's drawn
/// extent is exactly that of its samples.
const TIME_COLUMNS: usize = FIGURE_WIDTH as usize;

/// A uniformly sampled signal as it is drawn: the points of its trace
/// (every sample, or each pixel column's extremes; see [`TimeTraceBuilder`]).
#[derive(Clone, Debug, PartialEq)]
pub struct TimeTrace {
    /// Legend text, e.g. `measured`.
    pub label: String,
    /// `(time s, value)`, NaN where the line breaks.
    pub points: Vec<(f64, f64)>,
}

/// A [`TimeTrace`] made from a signal handed on a stretch at a time, its
/// length known beforehand (a replay that is never held whole): the points
/// [`write_time_overlay`] draws for the whole signal.
#[derive(Clone, Debug)]
pub struct TimeTraceBuilder {
    label: String,
    trace: SignalTrace,
}

impl TimeTraceBuilder {
    /// A trace labelled `label` of `samples` samples from `start_s` at
    /// `sample_rate_hz`.
    pub fn new(
        label: impl Into<String>,
        samples: usize,
        start_s: f64,
        sample_rate_hz: f64,
    ) -> TimeTraceBuilder {
        TimeTraceBuilder {
            label: label.into(),
            trace: SignalTrace::new(samples, start_s, sample_rate_hz, TIME_COLUMNS),
        }
    }

    /// Appends the next samples.
    pub fn push(&mut self, values: &[f64]) {
        self.trace.push(values);
    }

    /// The trace. Panics where fewer samples than announced were pushed.
    pub fn finish(self) -> TimeTrace {
        TimeTrace {
            label: self.label,
            points: self.trace.finish(),
        }
    }
}

/// Writes measured against simulated response over time (top) and their
/// difference, measured − simulated (bottom), for validation (paper Fig.
/// 4.5). Long signals are drawn from per-column minima and maxima
/// ([`min_max_columns`]), so a 1e6-sample record renders quickly and
/// faithfully. The signals must share sample rate and start time; the
/// difference covers their common length. Returns `[png, svg]`.
pub fn write_time_overlay(
    stem: &Path,
    title: &str,
    y_label: &str,
    measured: &TimeSignal,
    simulated: &TimeSignal,
) -> Result<Vec<PathBuf>> {
    for (i, s) in [measured, simulated].into_iter().enumerate() {
        let name = series_name("time", i, &s.label);
        check_lengths(&name, &[("values", s.values.len())])?;
        if !(s.sample_rate_hz.is_finite() && s.sample_rate_hz > 0.0 && s.start_s.is_finite()) {
            let msg = format!(
                "needs a finite start time and a sample rate > 0, got {} s and {} Hz",
                s.start_s, s.sample_rate_hz
            );
            return Err(Error::input(name, msg));
        }
    }
    let fs = measured.sample_rate_hz;
    if (simulated.sample_rate_hz - fs).abs() > 1e-9 * fs
        || (simulated.start_s - measured.start_s).abs() > 1e-3 / fs
    {
        let msg = format!(
            "`{}` starts at {} s sampled at {} Hz but `{}` at {} s, {} Hz; they must match",
            measured.label,
            measured.start_s,
            fs,
            simulated.label,
            simulated.start_s,
            simulated.sample_rate_hz
        );
        return Err(Error::input(format!("figure `{title}`"), msg));
    }
    let difference: Vec<f64> = measured
        .values
        .iter()
        .zip(&simulated.values)
        .map(|(a, b)| a - b)
        .collect();
    let trace = |label: &str, v: &[f64]| {
        let mut t = TimeTraceBuilder::new(label, v.len(), measured.start_s, fs);
        t.push(v);
        t.finish()
    };
    write_time_overlay_traced(
        stem,
        title,
        y_label,
        [
            &trace(&measured.label, &measured.values),
            &trace(&simulated.label, &simulated.values),
            &trace("difference", &difference),
        ],
    )
}

/// [`write_time_overlay`] of the traces of the measured and simulated
/// responses and of their difference (its label is the legend's).
///
/// Errors: a measured or simulated trace with no finite point.
pub fn write_time_overlay_traced(
    stem: &Path,
    title: &str,
    y_label: &str,
    [measured, simulated, difference]: [&TimeTrace; 3],
) -> Result<Vec<PathBuf>> {
    for (i, s) in [measured, simulated].into_iter().enumerate() {
        if !s.points.iter().any(|p| p.1.is_finite()) {
            return Err(Error::input(
                series_name("time", i, &s.label),
                "no plottable point: every sample is NaN/Inf",
            ));
        }
    }
    let (m, s, d) = (
        measured.points.clone(),
        simulated.points.clone(),
        difference.points.clone(),
    );
    let x = range_of(&[&m, &s], |p| p.0, false);
    let mut top = panel(y_label, x, range_of(&[&m, &s], |p| p.1, false), false, 3);
    top.shapes = vec![line(colour(0), 1, m), line(colour(1), 1, s)];
    let diff_y = axis_range(d.iter().map(|p| p.1), false).unwrap_or((-1.0, 1.0));
    let mut bottom = panel(y_label, x, diff_y, false, 2);
    bottom.heading = Some(format!(
        "{}: {} − {}",
        difference.label, measured.label, simulated.label
    ));
    bottom.x_label = "time [s]".into();
    bottom.shapes = vec![line(colour(3), 1, d)];
    let legend = [(&measured.label, 0), (&simulated.label, 1)]
        .into_iter()
        .filter_map(|(l, g)| legend_entry(l, colour(g), Sample::Line))
        .chain(legend_entry(&difference.label, colour(3), Sample::Line));
    let figure = Figure {
        title: title.into(),
        panels: vec![top, bottom],
        legend: legend.collect(),
    };
    render::write_figure(stem, &figure)
}

/// An optimiser's cost per evaluation (index 0 is the initial guess).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ConvergenceSeries {
    /// Legend text, e.g. `Nelder–Mead, start 2`; empty keeps it out of the
    /// legend.
    pub label: String,
    /// Colour group.
    pub group: usize,
    /// Cost of each evaluation (plotted on a log axis: zeros are skipped).
    pub cost: Vec<f64>,
}

/// Writes cost against evaluation on a log axis, one line per run. Returns
/// `[png, svg]`.
pub fn write_convergence_plot(
    stem: &Path,
    title: &str,
    y_label: &str,
    series: &[ConvergenceSeries],
) -> Result<Vec<PathBuf>> {
    require_series(title, series.len())?;
    let mut traces = Vec::with_capacity(series.len());
    for (i, s) in series.iter().enumerate() {
        let name = series_name("convergence", i, &s.label);
        check_lengths(&name, &[("cost", s.cost.len())])?;
        let points: Vec<(f64, f64)> = s
            .cost
            .iter()
            .enumerate()
            .map(|(k, &c)| {
                if c.is_finite() && c > 0.0 {
                    (k as f64, c)
                } else {
                    GAP
                }
            })
            .collect();
        require_plottable(&name, &points, " or ≤ 0")?;
        traces.push((s, points));
    }
    let all: Vec<&[(f64, f64)]> = traces.iter().map(|t| t.1.as_slice()).collect();
    let last = series.iter().map(|s| s.cost.len()).max().unwrap_or(1) as f64 - 1.0;
    let mut p = panel(
        y_label,
        (0.0, last.max(1.0)),
        range_of(&all, |p| p.1, true),
        true,
        1,
    );
    p.x_label = "evaluation".into();
    p.shapes = traces
        .iter()
        .map(|(s, pts)| line(colour(s.group), 2, pts.clone()))
        .collect();
    let legend = series
        .iter()
        .filter_map(|s| legend_entry(&s.label, colour(s.group), Sample::Line));
    let figure = Figure {
        title: title.into(),
        panels: vec![p],
        legend: legend.collect(),
    };
    render::write_figure(stem, &figure)
}

#[cfg(test)]
mod tests;
