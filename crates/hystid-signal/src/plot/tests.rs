//! Tests of the figures: markers, labels, unwrapped phases and level colours.

use super::*;

/// Receptance phase of an SDOF oscillator, closed form, degrees in
/// (−180°, 0°].
fn sdof_phase_deg(r: f64, zeta: f64) -> f64 {
    -(2.0 * zeta * r).atan2(1.0 - r * r).to_degrees()
}

/// Seven levels measured at the same three frequencies with the same H
/// (every marker on top of the others): each level's colour is still
/// drawn, exactly, in both panels. With one marker for all (a solid
/// circle), only the last level's would be.
#[test]
fn coincident_markers_of_every_level_stay_visible() {
    let levels = 7;
    let series: Vec<FrfSeries> = (0..levels)
        .map(|g| FrfSeries {
            // no labels: no legend, whose samples would show every colour
            label: String::new(),
            group: g,
            frequency_hz: vec![10.0, 20.0, 30.0],
            h: vec![Complex64::new(1e-6, -1e-6); 3],
            std_error: None,
            style: SeriesStyle::Measured,
        })
        .collect();
    let figure = frf_figure("coincident", "|H1| [m/N]", &series).unwrap();
    let pixels = render::bitmap(&figure).unwrap();
    let palette = Palette::over(0..levels);
    let mut shown = Vec::new();
    for g in 0..levels {
        let c = palette.colour(g);
        let n = pixels
            .chunks_exact(3)
            .filter(|p| p[0] == c.0 && p[1] == c.1 && p[2] == c.2)
            .count();
        shown.push(n);
    }
    // 6 markers a level (3 points, 2 panels), seven outlines within
    // 16 px: the crossings take most of a small one's pixels (and a
    // circle's stroke is antialiased), but each keeps some of its own
    // colour at every point
    assert!(
        shown.iter().all(|&n| n >= 6 * 2),
        "pixels per level {shown:?}"
    );
}

/// Three significant digits, trailing zeros dropped, in the unit given.
#[test]
fn level_labels_are_short() {
    assert_eq!(level_label(57.7418, "N"), "57.7 N");
    assert_eq!(level_label(57.7418, "V"), "57.7 V");
    assert_eq!(level_label(4.824257419730869, "N"), "4.82 N");
    assert_eq!(level_label(0.0123456, "V"), "0.0123 V");
    assert_eq!(level_label(30000.0, "N"), "30000 N");
    assert_eq!(level_label(3046.8, "N"), "3050 N");
    assert_eq!(level_label(0.05, "N"), "0.05 N");
    assert_eq!(level_label(246.048, "N"), "246 N");
    assert_eq!(level_label(999.7, "N"), "1000 N");
}

#[test]
fn phase_is_unwrapped_through_minus_180_degrees() {
    // A 5° lag pushes the phase above resonance past −180°, where arg()
    // alone would jump to +175°.
    let lag = Complex64::from_polar(1.0, -5f64.to_radians());
    let r: Vec<f64> = (0..200).map(|i| 0.1 + 0.015 * i as f64).collect();
    let mut h: Vec<Complex64> = r
        .iter()
        .map(|&r| lag / Complex64::new(1.0 - r * r, 2.0 * 0.01 * r))
        .collect();
    h[50] = Complex64::new(f64::NAN, 0.0);
    let phase = unwrapped_phase_deg(&h);
    assert!(phase[50].is_nan());
    for (i, (&p, &r)) in phase.iter().zip(&r).enumerate().filter(|(i, _)| *i != 50) {
        let expected = sdof_phase_deg(r, 0.01) - 5.0;
        assert!((p - expected).abs() < 1e-9, "point {i}: {p} vs {expected}");
    }
    // Accelerance-like data around +180° is shifted by no turn.
    let up = unwrapped_phase_deg(&[
        Complex64::from_polar(1.0, 3.0),
        Complex64::from_polar(1.0, -3.1),
    ]);
    assert!(
        (up[0] - 3f64.to_degrees()).abs() < 1e-9 && up[1] > 180.0,
        "{up:?}"
    );
}

/// A level whose own mean puts it a turn away from the others (a
/// lightly damped one that spends most of its band past −180°) is drawn
/// on the same turn as they are.
#[test]
fn phases_of_all_levels_are_drawn_on_one_turn() {
    let r: Vec<f64> = (0..60).map(|i| 0.5 + 0.05 * i as f64).collect();
    let lag = Complex64::from_polar(1.0, -100f64.to_radians());
    let series = |lag: Complex64| -> Vec<Complex64> {
        r.iter()
            .map(|&r| lag / Complex64::new(1.0 - r * r, 2.0 * 0.01 * r))
            .collect()
    };
    let (a, b) = (
        unwrapped_phase_deg(&series(Complex64::new(1.0, 0.0))),
        unwrapped_phase_deg(&series(lag)),
    );
    // each alone: the lagging one centred a turn up (+260° instead of
    // −100° against the other)
    assert!((b[0] - a[0]).abs() > 180.0, "{} vs {}", a[0], b[0]);
    let pts = |p: &[f64]| -> Vec<(f64, f64)> { r.iter().copied().zip(p.iter().copied()).collect() };
    let mut traces = vec![((), Vec::new(), pts(&a)), ((), Vec::new(), pts(&b))];
    align_phases(&mut traces);
    assert!((traces[1].2[0].1 - traces[0].2[0].1 + 100.0).abs() < 1.0);
}

/// The level colours run in order from dark to light, and the ends of
/// the map stay put whatever the number of levels.
#[test]
fn level_colours_are_a_sequential_map() {
    let lightness = |[r, g, b]: [u8; 3]| 0.299 * r as f64 + 0.587 * g as f64 + 0.114 * b as f64;
    for n in [2, 7, 12] {
        let l: Vec<f64> = (0..n).map(|g| lightness(level_colour(g, n))).collect();
        assert!(l.windows(2).all(|w| w[1] > w[0]), "{n}: {l:?}");
        assert_eq!(level_colour(0, n), [68, 1, 84]);
        assert_eq!(level_colour(n - 1, n), level_colour(1, 2));
    }
}
