//! The nonlinear FRFs as Universal File Format datasets 58 (`frf.uff`), so
//! that modal software (Testlab, ME'scope, pyuff, sdypy) opens them.
//!
//! One dataset per level (and sweep direction) and harmonic `h = 0..K`:
//! function type 4 (frequency response function), complex double ordinate
//! `H_h = Y_h/(F_1 u^(h-1))` (as in `frf.json`), the dwell frequencies as an
//! uneven abscissa in increasing order (ASCII `E13.5`: six digits;
//! `frf.json` keeps them whole), the level as the z-axis value (record 11:
//! the reference quantity). ID line 1 says `H3 at level 200 N (up)`, line 4
//! the level and line 5 the harmonic; record 6 carries the harmonic as the
//! version number and a running function number, response and reference at
//! node 1, +Z (the structure is seen at one point). ID line 3, the date by
//! convention, is `NONE`, so the same FRFs give the same bytes.

use crate::error::Result;
use crate::extract::{Direction, NonlinearFrf};
use crate::harmonics::Quantity;
use crate::import::uff::{self, Abscissa, Axis, Dof, Function, Ordinate, Precision};
use std::path::Path;

/// Record 8-11 characteristics of a quantity: specific data type, label,
/// units label.
fn axis_of(q: Quantity, label: &str) -> Axis {
    let (code, unit) = match q {
        Quantity::Force => (13, "N"),
        Quantity::Displacement => (8, "m"),
        Quantity::Velocity => (11, "m/s"),
        Quantity::Acceleration => (12, "m/s2"),
        // a general data type, its units in the label
        Quantity::Voltage => (1, "V"),
    };
    Axis::new(code, label, unit)
}

fn capitalised(s: &str) -> String {
    let mut c = s.chars();
    c.next()
        .map(|f| f.to_uppercase().chain(c).collect())
        .unwrap_or_default()
}

/// The datasets of `frf`, in the order level, then harmonic.
pub fn frf_functions(frf: &NonlinearFrf) -> Vec<Function> {
    let unit = frf.reference.si_unit();
    let driving_point = Dof {
        entity: "NONE".into(),
        node: 1,
        direction: 3,
    };
    let mut out = Vec::new();
    for l in &frf.levels {
        let mut points: Vec<_> = l.points.iter().collect();
        points.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
        let harmonics = points.iter().map(|p| p.h.len()).min().unwrap_or(0);
        let dir = match l.direction {
            Direction::Up => "up",
            Direction::Down => "down",
        };
        for h in 0..harmonics {
            out.push(Function {
                id_lines: [
                    format!("H{h} at level {} {unit} ({dir})", l.level),
                    format!(
                        "hystid {} nonlinear FRF H_h = Y_h/(F_1 u^(h-1)), u = F_1/|F_1|",
                        super::VERSION
                    ),
                    "NONE".into(),
                    format!("level {} {unit}, sweep {dir}", l.level),
                    format!("harmonic {h}"),
                ],
                function_type: 4,
                function_id: out.len() as i64 + 1,
                version: h as i64,
                load_case: 0,
                response: driving_point.clone(),
                reference: driving_point.clone(),
                precision: Precision::Double,
                abscissa: Abscissa::Uneven(points.iter().map(|p| p.frequency_hz).collect()),
                z_axis_value: l.level,
                abscissa_axis: Axis::new(18, "Frequency", "Hz"),
                ordinate_axis: axis_of(frf.response, &capitalised(frf.response.name())),
                denominator_axis: axis_of(frf.reference, &capitalised(frf.reference.name())),
                z_axis: axis_of(frf.reference, "Level"),
                ordinate: Ordinate::Complex(points.iter().map(|p| p.h[h]).collect()),
                binary: None,
            });
        }
    }
    out
}

/// Writes `frf.uff` (or any `path`): [`frf_functions`] as ASCII UFF,
/// atomically.
pub fn write_frf_uff(path: &Path, frf: &NonlinearFrf) -> Result<()> {
    uff::write(path, &frf_functions(frf))
}
