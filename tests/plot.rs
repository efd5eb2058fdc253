//! Integration tests: plot.
//!
//! Every figure is checked through its files: the PNG's signature, IHDR
//! (size, CRC) and IEND, parsed by hand; the SVG's title, legend labels and
//! the number of polylines / circles drawn in each series' colour (legend
//! samples are rectangles and circles, so a series' polylines are exactly
//! its line segments). Set `HYSTID_PLOT_OUT=dir` to keep the figures.

use hystid::extract::{Direction, FrfLevel, FrfPoint, NonlinearFrf};
use hystid::harmonics::Quantity;
use hystid::plot::*;
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A scratch directory, or `$HYSTID_PLOT_OUT/<name>` to keep the output.
fn out_dir(name: &str) -> (Option<tempfile::TempDir>, PathBuf) {
    match std::env::var_os("HYSTID_PLOT_OUT") {
        Some(d) => {
            let p = PathBuf::from(d).join(name);
            std::fs::create_dir_all(&p).unwrap();
            (None, p)
        }
        None => {
            let t = tempfile::tempdir().unwrap();
            let p = t.path().to_path_buf();
            (Some(t), p)
        }
    }
}

/// CRC-32 (IEEE, reflected), bit by bit: the PNG chunk checksum.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// Checks the PNG structure by hand and returns (width, height).
fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(
        &b[..8],
        b"\x89PNG\r\n\x1a\n",
        "PNG signature of {}",
        path.display()
    );
    let be = |i: usize| u32::from_be_bytes(b[i..i + 4].try_into().unwrap());
    assert_eq!(be(8), 13, "IHDR length");
    assert_eq!(&b[12..16], b"IHDR");
    assert_eq!(crc32(&b[12..29]), be(29), "IHDR CRC");
    assert_eq!(b[24], 8, "bit depth");
    assert_eq!(&b[b.len() - 8..b.len() - 4], b"IEND", "file ends with IEND");
    (be(16), be(20))
}

fn hex(group: usize) -> String {
    let [r, g, b] = group_colour(group);
    format!("#{r:02X}{g:02X}{b:02X}")
}

/// The colour of level `group` of `groups` (the figures over levels).
fn lhex(group: usize, groups: usize) -> String {
    let [r, g, b] = level_colour(group, groups);
    format!("#{r:02X}{g:02X}{b:02X}")
}

/// The opening tags `<tag ...>` of an SVG.
fn tags<'a>(svg: &'a str, tag: &str) -> Vec<&'a str> {
    let open = format!("<{tag} ");
    svg.match_indices(&open)
        .map(|(i, _)| &svg[i..i + svg[i..].find('>').unwrap()])
        .collect()
}

/// Count of `<tag>` elements carrying every attribute in `attrs`.
fn count(svg: &str, tag: &str, attrs: &[(&str, &str)]) -> usize {
    tags(svg, tag)
        .iter()
        .filter(|t| {
            attrs
                .iter()
                .all(|(k, v)| t.contains(&format!("{k}=\"{v}\"")))
        })
        .count()
}

/// Every polyline vertex lies on the canvas (no garbage from NaN points).
fn assert_points_on_canvas(svg: &str) {
    for t in tags(svg, "polyline") {
        let pts = t
            .split("points=\"")
            .nth(1)
            .unwrap()
            .split('"')
            .next()
            .unwrap();
        for xy in pts.split_whitespace() {
            let (x, y) = xy.split_once(',').unwrap();
            let (x, y): (i64, i64) = (x.parse().unwrap(), y.parse().unwrap());
            assert!(
                (0..=FIGURE_WIDTH as i64).contains(&x) && (0..=FIGURE_HEIGHT as i64).contains(&y),
                "vertex {x},{y} off the canvas"
            );
        }
    }
}

fn check_files(files: &[PathBuf], stem: &Path) -> String {
    assert_eq!(files.len(), 2);
    assert_eq!(files[0], stem.with_extension("png"));
    assert_eq!(files[1], stem.with_extension("svg"));
    assert_eq!(png_size(&files[0]), (FIGURE_WIDTH, FIGURE_HEIGHT));
    assert!(std::fs::metadata(&files[0]).unwrap().len() > 10_000);
    let svg = std::fs::read_to_string(&files[1]).unwrap();
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert_points_on_canvas(&svg);
    svg
}

/// SDOF receptance `1/(k − m ω² + j c ω)` scaled by a softening with level
/// (a stand-in for a joint), m.
fn receptance(f: f64, level: usize) -> Complex64 {
    let (m, k, c) = (
        1.0,
        4.0e6 * (1.0 - 0.1 * level as f64),
        60.0 + 40.0 * level as f64,
    );
    let w = 2.0 * std::f64::consts::PI * f;
    1.0 / Complex64::new(k - m * w * w, c * w)
}

fn frf_fixture() -> Vec<FrfSeries> {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let noise = Normal::new(0.0, 1.0).unwrap();
    let mut series = Vec::new();
    for level in 0..3 {
        let f: Vec<f64> = (0..41).map(|i| 250.0 + 3.0 * i as f64).collect();
        let model: Vec<Complex64> = f.iter().map(|&f| receptance(f, level)).collect();
        let sigma: Vec<f64> = model.iter().map(|h| 0.05 * h.norm()).collect();
        let measured: Vec<Complex64> = model
            .iter()
            .zip(&sigma)
            .map(|(h, s)| {
                h + Complex64::new(noise.sample(&mut rng), noise.sample(&mut rng))
                    * (s / 2f64.sqrt())
            })
            .collect();
        series.push(FrfSeries {
            label: format!("{} N", [1, 4, 16][level]),
            group: level,
            frequency_hz: f.clone(),
            h: measured,
            std_error: Some(sigma),
            style: SeriesStyle::Measured,
        });
        series.push(FrfSeries {
            label: format!("{} N (model)", [1, 4, 16][level]),
            group: level,
            frequency_hz: f,
            h: model,
            std_error: None,
            style: SeriesStyle::Model,
        });
    }
    series
}

#[test]
fn frf_plot_draws_every_finite_point_and_breaks_lines_at_nan() {
    let (_keep, dir) = out_dir("frf");
    let mut series = frf_fixture();
    series[0].h[3] = Complex64::new(f64::NAN, 0.0); // measured, level 0
    series[0].frequency_hz[7] = f64::INFINITY;
    series[1].h[10] = Complex64::new(f64::INFINITY, 0.0); // model, level 0
    let stem = dir.join("frf");
    let files = write_frf_plot(&stem, "Receptance at three levels", "|H1| [m/N]", &series).unwrap();
    let svg = check_files(&files, &stem);
    for text in [
        "Receptance at three levels",
        "|H1| [m/N]",
        "phase [°]",
        "frequency [Hz]",
    ] {
        assert!(svg.contains(text), "SVG lacks `{text}`");
    }
    for s in &series {
        assert!(
            svg.contains(&format!(">\n{}\n<", s.label)),
            "legend lacks `{}`",
            s.label
        );
    }
    // Level 0 (open circles): 41 − 2 skipped measured points in each panel,
    // plus the legend marker.
    let c0 = lhex(0, 3);
    assert_eq!(count(&svg, "circle", &[("stroke", &c0)]), 2 * 39 + 1);
    // ... the model line broken once in each panel ...
    assert_eq!(
        count(&svg, "polyline", &[("stroke", &c0), ("opacity", "1")]),
        2 * 2
    );
    // ... and one error bar per drawn point and panel.
    assert_eq!(
        count(&svg, "polyline", &[("stroke", &c0), ("opacity", "0.6")]),
        2 * 39
    );
    for g in 1..3 {
        let c = lhex(g, 3);
        // levels 1 and 2: open squares and triangles, polygons
        assert_eq!(
            count(&svg, "polygon", &[("fill", &c)]),
            2 * 41 + 1,
            "group {g}"
        );
        assert_eq!(
            count(&svg, "polyline", &[("stroke", &c), ("opacity", "1")]),
            2,
            "group {g}"
        );
    }
}

#[test]
fn same_figure_gives_identical_bytes() {
    let series = frf_fixture();
    let (a, b) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let fa = write_frf_plot(&a.path().join("x.svg"), "t", "|H1| [m/N]", &series).unwrap();
    let fb = write_frf_plot(&b.path().join("x"), "t", "|H1| [m/N]", &series).unwrap();
    for (p, q) in fa.iter().zip(&fb) {
        assert_eq!(
            std::fs::read(p).unwrap(),
            std::fs::read(q).unwrap(),
            "{}",
            p.display()
        );
    }
}

#[test]
fn all_nan_series_is_an_error_naming_it_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let mut series = frf_fixture();
    series[3].label = "broken level".into();
    series[3]
        .h
        .iter_mut()
        .for_each(|h| *h = Complex64::new(f64::NAN, f64::NAN));
    let err = write_frf_plot(&dir.path().join("f"), "t", "|H1|", &series).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("broken level") && msg.contains("NaN"), "{msg}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);

    let short = LoopSeries {
        label: "short".into(),
        displacement: vec![0.0; 5],
        force: vec![0.0; 4],
        ..Default::default()
    };
    let msg = write_loop_plot(&dir.path().join("l"), "t", "x", "y", &[short])
        .unwrap_err()
        .to_string();
    assert!(msg.contains("short") && msg.contains("4 values"), "{msg}");
    let msg = write_convergence_plot(&dir.path().join("c"), "empty", "cost", &[])
        .unwrap_err()
        .to_string();
    assert!(msg.contains("empty") && msg.contains("no series"), "{msg}");
    let zero = ConvergenceSeries {
        label: "flat".into(),
        group: 0,
        cost: vec![0.0, -1.0, f64::NAN],
    };
    let msg = write_convergence_plot(&dir.path().join("c"), "t", "cost", &[zero])
        .unwrap_err()
        .to_string();
    assert!(msg.contains("flat"), "{msg}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn unwritable_paths_give_errors_and_leave_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let series = frf_fixture();
    let missing = dir.path().join("no/such/dir/fig");
    let msg = write_frf_plot(&missing, "t", "|H|", &series)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("no/such/dir"), "{msg}");

    // A regular file where the directory should be.
    std::fs::write(dir.path().join("file"), b"x").unwrap();
    assert!(write_frf_plot(&dir.path().join("file/fig"), "t", "|H|", &series).is_err());

    // The SVG's name is taken by a non-empty directory: the rename fails
    // after both temporaries were written; neither they nor the PNG remain.
    std::fs::create_dir_all(dir.path().join("fig.svg/inner")).unwrap();
    let stem = dir.path().join("fig");
    assert!(write_frf_plot(&stem, "t", "|H|", &series).is_err());
    let mut left: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["fig.svg", "file"]);
}

#[test]
fn output_paths_replace_only_png_or_svg_extensions() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    assert_eq!(
        output_paths(&d.join("a.PNG")).unwrap(),
        [d.join("a.png"), d.join("a.svg")]
    );
    assert_eq!(
        output_paths(&d.join("fit.v2")).unwrap(),
        [d.join("fit.v2.png"), d.join("fit.v2.svg")]
    );
    assert!(output_paths(&d.join("missing/a")).is_err());
}

fn nonlinear_frf() -> NonlinearFrf {
    let point = |f: f64, level: usize| FrfPoint {
        frequency_hz: f,
        force_amplitude: 1.0,
        h: vec![
            Complex64::new(0.0, 0.0),
            receptance(f, level),
            receptance(f, level) * 0.01,
        ],
        std_error: vec![0.0, 1e-8, 1e-9],
        force_distortion: vec![],
        blocks: 4,
        settle_periods: 10,
        settled: true,
        subharmonic: None,
    };
    let level = |value: f64, direction, idx| FrfLevel {
        level: value,
        direction,
        points: (0..5).map(|i| point(300.0 + i as f64, idx)).collect(),
    };
    NonlinearFrf {
        response: Quantity::Displacement,
        reference: Quantity::Force,
        max_harmonic: 2,
        levels: vec![
            level(2.0, Direction::Up, 0),
            level(2.0, Direction::Down, 1),
            level(8.0, Direction::Up, 2),
        ],
    }
}

#[test]
fn frf_series_from_groups_levels_and_picks_the_harmonic() {
    let frf = nonlinear_frf();
    let measured = frf_series_from(&frf, 1, SeriesStyle::Measured).unwrap();
    let labels: Vec<&str> = measured.iter().map(|s| s.label.as_str()).collect();
    assert_eq!(labels, ["2 N up", "2 N down", "8 N up"]);
    assert_eq!(
        measured.iter().map(|s| s.group).collect::<Vec<_>>(),
        [0, 0, 1]
    );
    for (s, level) in measured.iter().zip(&frf.levels) {
        for (i, p) in level.points.iter().enumerate() {
            assert_eq!((s.frequency_hz[i], s.h[i]), (p.frequency_hz, p.h[1]));
            assert_eq!(s.std_error.as_ref().unwrap()[i], p.std_error[1]);
        }
    }
    let model = frf_series_from(&frf, 2, SeriesStyle::Model).unwrap();
    assert_eq!(model[2].label, "8 N up (model)");
    assert!(model[0].std_error.is_none());
    assert_eq!(model[1].h[3], frf.levels[1].points[3].h[2]);
    let msg = frf_series_from(&frf, 3, SeriesStyle::Model)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("harmonic 3") && msg.contains("0..=2"), "{msg}");

    assert_eq!(frf_magnitude_label(&frf, 1), "|H1| [m/N]");
    let acc = NonlinearFrf {
        response: Quantity::Acceleration,
        ..frf.clone()
    };
    assert_eq!(frf_magnitude_label(&acc, 3), "|H3| [(m/s²)/N]");

    let (_keep, dir) = out_dir("frf_from");
    let mut all = model;
    all.extend(measured);
    let stem = dir.join("levels");
    let files = write_frf_plot(
        &stem,
        "From a NonlinearFrf",
        &frf_magnitude_label(&frf, 1),
        &all,
    )
    .unwrap();
    let svg = check_files(&files, &stem);
    // Two series (up and down) share group 0: 2 × 5 markers per panel + 1 legend marker each.
    assert_eq!(
        count(&svg, "circle", &[("stroke", &lhex(0, 2))]),
        2 * 2 * 5 + 2
    );
}

/// Masing loop of a Jenkins element (stiffness k, slip force fs) at
/// amplitude a, closed-form branches.
fn jenkins_loop(a: f64, k: f64, fs: f64, n: usize) -> (Vec<f64>, Vec<f64>) {
    let backbone = |x: f64| (k * x).clamp(-fs, fs);
    let (mut x, mut f) = (Vec::new(), Vec::new());
    for i in 0..n {
        let phase = 2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64;
        let d = a * phase.cos();
        // Descending branch for the first half, ascending for the second.
        let force = if phase <= std::f64::consts::PI {
            backbone(a) - 2.0 * backbone((a - d) / 2.0)
        } else {
            -backbone(a) + 2.0 * backbone((a + d) / 2.0)
        };
        x.push(d);
        f.push(force);
    }
    (x, f)
}

#[test]
fn loop_plot_draws_reference_bands_under_fitted_lines() {
    let (_keep, dir) = out_dir("loops");
    let mut series = Vec::new();
    for (g, a) in [2e-6, 5e-6, 1e-5].into_iter().enumerate() {
        let (x, f) = jenkins_loop(a, 1e6, 3.0, 201);
        let (xf, ff) = jenkins_loop(a, 1.1e6, 2.8, 201);
        series.push(LoopSeries {
            label: format!("reference, {} μm", a * 1e6),
            group: g,
            displacement: x,
            force: f,
            style: SeriesStyle::Measured,
        });
        series.push(LoopSeries {
            label: format!("fitted, {} μm", a * 1e6),
            group: g,
            displacement: xf,
            force: ff,
            style: SeriesStyle::Model,
        });
    }
    series[5].force[100] = f64::NAN; // fitted loop at the largest amplitude: one gap
    let stem = dir.join("loops");
    let files = write_loop_plot(
        &stem,
        "Joint hysteresis",
        "relative displacement [m]",
        "joint force [N]",
        &series,
    )
    .unwrap();
    let svg = check_files(&files, &stem);
    for t in [
        "Joint hysteresis",
        "relative displacement [m]",
        "joint force [N]",
        "reference, 5 μm",
        "fitted, 10 μm",
    ] {
        assert!(svg.contains(t), "SVG lacks `{t}`");
    }
    for g in 0..3 {
        let c = lhex(g, 3);
        assert_eq!(
            count(&svg, "polyline", &[("stroke", &c), ("opacity", "0.35")]),
            1,
            "band {g}"
        );
        let lines = if g == 2 { 2 } else { 1 };
        assert_eq!(
            count(&svg, "polyline", &[("stroke", &c), ("opacity", "1")]),
            lines,
            "line {g}"
        );
    }
    // Bands are drawn first, so the fitted lines lie on top.
    let first_line = svg
        .find(&format!("opacity=\"1\" stroke=\"{}\"", lhex(0, 3)))
        .unwrap();
    let last_band = svg.rfind("opacity=\"0.35\"").unwrap();
    assert!(last_band < first_line);
}

#[test]
fn residual_plot_compares_panels_against_the_noise_level() {
    let series = frf_fixture();
    // Normalised residual against a closed-form check at one point.
    let r = residual_series("1 N", 0, &series[0], &series[1], true).unwrap();
    let i = 17;
    let by_hand =
        (series[0].h[i] - series[1].h[i]).norm() / series[0].std_error.as_ref().unwrap()[i];
    assert!((r.residual[i] - by_hand).abs() <= 1e-12 * by_hand);
    // The fixture's noise is a circular complex Gaussian with E|e|² = σ²:
    // the mean of (|ΔH|/σ)² over 41 points is 1 within ~4 standard errors (1/√41).
    let mean_sq = r.residual.iter().map(|x| x * x).sum::<f64>() / r.residual.len() as f64;
    assert!(
        (mean_sq - 1.0).abs() < 4.0 / 41f64.sqrt(),
        "mean (|ΔH|/σ)² = {mean_sq}"
    );
    let mut shifted = series[1].clone();
    shifted.frequency_hz[5] += 0.01;
    let msg = residual_series("x", 0, &series[0], &shifted, false)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("frequency 5"), "{msg}");
    assert!(
        residual_series("x", 0, &series[1], &series[0], true).is_err(),
        "model has no σ"
    );

    // "Before": the model of the wrong level (a large residual); "after": the right one.
    let mut before = Vec::new();
    let mut after = Vec::new();
    for g in 0..3 {
        let (m, right) = (&series[2 * g], &series[2 * g + 1]);
        let wrong = FrfSeries {
            frequency_hz: right.frequency_hz.clone(),
            h: series[2 * ((g + 1) % 3) + 1].h.clone(),
            ..right.clone()
        };
        before.push(residual_series(&m.label, g, m, &wrong, true).unwrap());
        after.push(residual_series(&m.label, g, m, right, true).unwrap());
    }
    after[1].residual[4] = 0.0; // not plottable on the log axis: skipped
    let panels = [
        ResidualPanel {
            heading: "before: wrong level".into(),
            series: before,
        },
        ResidualPanel {
            heading: "after: matching level".into(),
            series: after,
        },
    ];
    let noise = NoiseLevel {
        value: 2.0,
        label: "2σ noise level".into(),
    };
    let (_keep, dir) = out_dir("residuals");
    let stem = dir.join("residuals");
    let files = write_residual_plot(
        &stem,
        "Normalised residuals",
        "|ΔH|/σ",
        &panels,
        Some(&noise),
    )
    .unwrap();
    let svg = check_files(&files, &stem);
    for t in [
        "Normalised residuals",
        "before: wrong level",
        "after: matching level",
        "2σ noise level",
        "16 N",
    ] {
        assert!(svg.contains(t), "SVG lacks `{t}`");
    }
    // One line per level and panel; the zero breaks level 1's "after" line.
    assert_eq!(
        count(
            &svg,
            "polyline",
            &[("stroke", &lhex(0, 3)), ("opacity", "1")]
        ),
        2
    );
    assert_eq!(
        count(
            &svg,
            "polyline",
            &[("stroke", &lhex(1, 3)), ("opacity", "1")]
        ),
        3
    );
    assert_eq!(
        count(&svg, "polygon", &[("fill", &lhex(1, 3))]),
        41 + 40 + 1
    );
    // The legend lists each level once although it appears in both panels.
    assert_eq!(svg.matches(">\n4 N\n<").count(), 1);
    assert!(
        count(&svg, "polyline", &[("stroke", "#5A5A5A")]) > 10,
        "dashed noise lines"
    );
}

#[test]
fn convergence_plot_skips_non_positive_costs() {
    let (_keep, dir) = out_dir("convergence");
    let run = |rate: f64, n: usize| {
        (0..n)
            .map(|k| 10.0 * rate.powi(k as i32) + 1e-4)
            .collect::<Vec<f64>>()
    };
    let mut broken = run(0.7, 40);
    broken[12] = 0.0;
    let series = [
        ConvergenceSeries {
            label: "Nelder–Mead".into(),
            group: 0,
            cost: run(0.85, 60),
        },
        ConvergenceSeries {
            label: "Levenberg–Marquardt".into(),
            group: 1,
            cost: broken,
        },
    ];
    let stem = dir.join("convergence");
    let files =
        write_convergence_plot(&stem, "Optimiser convergence", "cost (eq. 9)", &series).unwrap();
    let svg = check_files(&files, &stem);
    for t in [
        "Optimiser convergence",
        "cost (eq. 9)",
        "evaluation",
        "Nelder–Mead",
        "Levenberg–Marquardt",
    ] {
        assert!(svg.contains(t), "SVG lacks `{t}`");
    }
    assert_eq!(count(&svg, "polyline", &[("stroke", &hex(0))]), 1);
    assert_eq!(count(&svg, "polyline", &[("stroke", &hex(1))]), 2);
}

/// Per-column extremes the slow way: each sample's column from
/// `⌊i·m/n⌋`, first index on ties.
fn slow_columns(v: &[f64], m: usize) -> Vec<Option<(usize, f64, usize, f64)>> {
    let n = v.len();
    let mut out: Vec<Option<(usize, f64, usize, f64)>> = vec![None; m];
    for (i, &x) in v.iter().enumerate() {
        if !x.is_finite() {
            continue;
        }
        let c = (i as u128 * m as u128 / n as u128) as usize;
        out[c] = Some(match out[c] {
            None => (i, x, i, x),
            Some((a, lo, b, hi)) => {
                let (a, lo) = if x < lo { (i, x) } else { (a, lo) };
                let (b, hi) = if x > hi { (i, x) } else { (b, hi) };
                (a, lo, b, hi)
            }
        });
    }
    out
}

fn noisy_sine(n: usize, fs: f64, seed: u64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let noise = Normal::new(0.0, 0.05).unwrap();
    (0..n)
        .map(|i| (2.0 * std::f64::consts::PI * 37.0 * i as f64 / fs).sin() + noise.sample(&mut rng))
        .collect()
}

#[test]
fn min_max_columns_match_a_slow_reference_and_keep_the_extremes() {
    let n = 1_000_000;
    let mut v = noisy_sine(n, 50_000.0, 3);
    v[123_456] = 7.5; // a lone spike must survive
    v[654_321] = -6.25;
    v[200_000..203_000].iter_mut().for_each(|x| *x = f64::NAN);
    v[500] = f64::INFINITY;
    for m in [997, 1000, 7] {
        let t = Instant::now();
        let fast = min_max_columns(&v, m);
        let elapsed = t.elapsed();
        let slow = slow_columns(&v, m);
        assert_eq!(fast.len(), m);
        for (c, (a, b)) in fast.iter().zip(&slow).enumerate() {
            let a = a.map(|e| (e.min_index, e.min, e.max_index, e.max));
            assert_eq!(a, *b, "column {c} of {m}");
        }
        let lo = fast
            .iter()
            .flatten()
            .map(|e| e.min)
            .fold(f64::INFINITY, f64::min);
        let hi = fast
            .iter()
            .flatten()
            .map(|e| e.max)
            .fold(f64::NEG_INFINITY, f64::max);
        assert_eq!((lo, hi), (-6.25, 7.5));
        println!("min_max_columns: 1e6 samples into {m} columns in {elapsed:?}");
    }
    // Columns wholly inside the NaN block are gaps (1000 samples/column).
    assert_eq!(min_max_columns(&v, 1000)[201], None);
    // Fewer samples than columns: one column per sample.
    assert_eq!(min_max_columns(&[1.0, 2.0], 10).len(), 2);
    assert!(min_max_columns(&[], 10).is_empty());
}

#[test]
fn time_overlay_of_a_million_samples_renders_quickly() {
    let (n, fs) = (1_000_000, 50_000.0);
    let mut measured = noisy_sine(n, fs, 1);
    measured[400_000..420_000]
        .iter_mut()
        .for_each(|x| *x = f64::NAN);
    let simulated: Vec<f64> = (0..n)
        .map(|i| 0.97 * (2.0 * std::f64::consts::PI * 37.0 * i as f64 / fs - 0.05).sin())
        .collect();
    let m = TimeSignal {
        label: "measured".into(),
        start_s: 0.0,
        sample_rate_hz: fs,
        values: measured,
    };
    let s = TimeSignal {
        label: "simulated".into(),
        values: simulated,
        ..m.clone()
    };
    let (_keep, dir) = out_dir("time");
    let stem = dir.join("time");
    let t = Instant::now();
    let files =
        write_time_overlay(&stem, "Validation at 16 N", "displacement [m]", &m, &s).unwrap();
    println!(
        "write_time_overlay: 2 × 1e6 samples, PNG + SVG in {:?}",
        t.elapsed()
    );
    let svg = check_files(&files, &stem);
    for t in [
        "Validation at 16 N",
        "displacement [m]",
        "time [s]",
        "measured",
        "simulated",
        "difference",
    ] {
        assert!(svg.contains(t), "SVG lacks `{t}`");
    }
    // The NaN block (20 whole columns) breaks the measured line and the difference.
    let lines = |g| {
        tags(&svg, "polyline")
            .into_iter()
            .filter(|t| t.contains(&format!("stroke=\"{}\"", hex(g))))
            .collect::<Vec<_>>()
    };
    assert_eq!((lines(0).len(), lines(1).len(), lines(3).len()), (2, 1, 2));
    // Decimated: at most two points per column.
    let vertices: usize = lines(1).iter().map(|t| t.matches(',').count()).sum();
    assert!(vertices <= 2 * 1000, "{vertices} vertices");

    let other = TimeSignal {
        sample_rate_hz: 48_000.0,
        ..s.clone()
    };
    let msg = write_time_overlay(&dir.join("bad"), "t", "y", &m, &other)
        .unwrap_err()
        .to_string();
    assert!(msg.contains("48000") && msg.contains("must match"), "{msg}");
}
