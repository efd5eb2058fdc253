//! The files `identify-points` writes: `points.json`, `points.md` and
//! `points_<response>.png`/`.svg` (each sensor's measured FRF at every
//! level, markers, under the fitted model's, lines).

use super::PointsReport;
use crate::error::Result;
use crate::extract::NonlinearFrf;
use crate::fit::points::PointMeasurement;
use crate::plot::{FrfSeries, SeriesStyle, level_label, write_frf_plot};
use num_complex::Complex64;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Writes every file into `out` and returns their paths, `points.json`
/// last (it lists them all).
pub fn write(
    out: &Path,
    report: &PointsReport,
    frfs: &[Vec<NonlinearFrf>],
    data: &[PointMeasurement],
    predicted: &[Vec<Option<Vec<Complex64>>>],
) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for (m, d) in data.iter().enumerate() {
        let name = &report.responses[m];
        let label = crate::plot::frf_magnitude_label(&frfs[m][0], 1);
        let stem = out.join(format!("points_{}", file_safe(name)));
        let title = format!("{name}: measured (markers) and fitted (lines)");
        files.extend(write_frf_plot(
            &stem,
            &title,
            &label,
            &series(d, m, predicted),
        )?);
    }
    let md = out.join("points.md");
    crate::atomic::write_bytes(&md, markdown(report).as_bytes())?;
    files.push(md);
    let json = out.join("points.json");
    files.push(json.clone());
    let mut listed = report.clone();
    listed.files = files.clone();
    crate::analysis::write_json(&json, &listed)?;
    Ok(files)
}

/// One sensor's measured series and the model's at every level.
fn series(
    d: &PointMeasurement,
    m: usize,
    predicted: &[Vec<Option<Vec<Complex64>>>],
) -> Vec<FrfSeries> {
    let mut out = Vec::new();
    for (l, level) in d.levels.iter().enumerate() {
        let f: Vec<f64> = level.lines.iter().map(|x| x.frequency_hz).collect();
        out.push(FrfSeries {
            label: level_label(level.level, "N"),
            group: l,
            frequency_hz: f.clone(),
            h: level.lines.iter().map(|x| x.h).collect(),
            std_error: None,
            style: SeriesStyle::Measured,
        });
        let solved: Vec<(f64, Complex64)> = (f.iter().zip(&predicted[l]))
            .filter_map(|(f, p)| p.as_ref().map(|h| (*f, h[m])))
            .collect();
        if !solved.is_empty() {
            out.push(FrfSeries {
                label: String::new(),
                group: l,
                frequency_hz: solved.iter().map(|s| s.0).collect(),
                h: solved.iter().map(|s| s.1).collect(),
                std_error: None,
                style: SeriesStyle::Model,
            });
        }
    }
    out
}

/// A channel name as a file name's part.
fn file_safe(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// `points.md`: what ran and what the model is.
fn markdown(r: &PointsReport) -> String {
    let mut s = String::from("# Joint between points\n\n");
    let _ = writeln!(
        s,
        "Recordings: {}. Responses: {}.\n",
        r.recordings
            .iter()
            .map(|p| format!("`{}`", p.display()))
            .collect::<Vec<_>>()
            .join(", "),
        r.responses.join(", ")
    );
    let _ = writeln!(s, "## The joint\n\n{}.\n", r.joint_in_words());
    if !r.fit.at_bounds.is_empty() {
        let _ = writeln!(
            s,
            "At a bound of its range (the law at its limit, or a fit gone astray; not a value found): {}.\n",
            r.fit.at_bounds.join(", ")
        );
    }
    if r.fit.restarted {
        s.push_str("The fit ended with a joint parameter at a bound and was run again with it held there; the better of the two is this one.\n\n");
    }
    s.push_str("## The structure beside the joint\n\n| mode | Hz | damping % |\n|---|---|---|\n");
    for (i, m) in r.structure.modes.iter().enumerate() {
        let _ = writeln!(
            s,
            "| {} | {:.3} | {:.3} |",
            i + 1,
            m.frequency_hz,
            100.0 * m.damping_ratio
        );
    }
    s.push_str(
        "\n## FRF error, % of each level's RMS\n\n| response | level | error % |\n|---|---|---|\n",
    );
    for e in &r.errors {
        let _ = writeln!(
            s,
            "| {} | {} | {:.1} |",
            e.response,
            level_label(e.level, "N"),
            e.frf_error_percent
        );
    }
    for name in &r.responses {
        let _ = writeln!(s, "\n![{name}](points_{}.png)", file_safe(name));
    }
    s
}
