//! Dataset 58 written as ASCII.

use super::types::{Abscissa, Case, Function, Ordinate};
use crate::atomic::write_atomic;
use crate::{Error, Result};
use std::io::Write;
use std::path::Path;

/// A Fortran `Ew.d` field: `d` digits after the point, a signed exponent of
/// at least two digits, right-aligned in `w` columns.
pub fn fortran_e(x: f64, w: usize, d: usize) -> String {
    if !x.is_finite() {
        let s = if x.is_nan() {
            "NaN"
        } else if x > 0.0 {
            "inf"
        } else {
            "-inf"
        };
        return format!("{s:>w$}");
    }
    let s = format!("{x:.d$e}");
    let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
    let e: i32 = e.parse().unwrap_or(0);
    let sign = if e < 0 { '-' } else { '+' };
    format!("{:>w$}", format!("{m}E{sign}{:02}", e.abs()))
}

/// At most 80 characters of `s` on one line, `NONE` when empty.
pub(super) fn id_text(s: &str) -> String {
    let t: String = s
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .take(80)
        .collect();
    let t = t.trim_end().to_string();
    if t.is_empty() { "NONE".into() } else { t }
}

fn name_field(s: &str, n: usize) -> String {
    let t: String = s
        .chars()
        .filter(|c| !c.is_control())
        .take(n)
        .collect::<String>()
        .trim()
        .to_string();
    if t.is_empty() { "NONE".into() } else { t }
}

/// Writes one dataset 58 as ASCII (LF line ends) in the formats of the UFF
/// specification. The ordinate data type follows `f.precision` and the
/// ordinate's kind; an uneven abscissa must have one value per ordinate
/// value.
pub fn write_ascii(out: &mut impl Write, f: &Function) -> std::io::Result<()> {
    let even = matches!(f.abscissa, Abscissa::Even { .. });
    let case = Case {
        complex: matches!(f.ordinate, Ordinate::Complex(_)),
        precision: f.precision,
        even,
    };
    let n = f.ordinate.len();
    if let Abscissa::Uneven(x) = &f.abscissa
        && x.len() != n
    {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("{} abscissa values for {n} ordinate values", x.len()),
        ));
    }
    writeln!(out, "    -1")?;
    writeln!(out, "    58")?;
    for id in &f.id_lines {
        writeln!(out, "{}", id_text(id))?;
    }
    writeln!(
        out,
        "{:5}{:10}{:5}{:10} {:>10}{:10}{:4} {:>10}{:10}{:4}",
        f.function_type,
        f.function_id,
        f.version,
        f.load_case,
        name_field(&f.response.entity, 10),
        f.response.node,
        f.response.direction,
        name_field(&f.reference.entity, 10),
        f.reference.node,
        f.reference.direction
    )?;
    let (start, increment) = match f.abscissa {
        Abscissa::Even {
            start, increment, ..
        } => (start, increment),
        Abscissa::Uneven(_) => (0.0, 0.0),
    };
    writeln!(
        out,
        "{:10}{:10}{:10}{}{}{}",
        f.ordinate_data_type(),
        n,
        u8::from(even),
        fortran_e(start, 13, 5),
        fortran_e(increment, 13, 5),
        fortran_e(f.z_axis_value, 13, 5)
    )?;
    for a in [
        &f.abscissa_axis,
        &f.ordinate_axis,
        &f.denominator_axis,
        &f.z_axis,
    ] {
        writeln!(
            out,
            "{:10}{:5}{:5}{:5} {:<20} {:<20}",
            a.data_type,
            a.length_exponent,
            a.force_exponent,
            a.temperature_exponent,
            name_field(&a.label, 20),
            name_field(&a.units, 20)
        )?;
    }
    // the numbers in file order, each with its field width
    let widths = case.widths();
    let per_line = widths.len();
    let mut line = String::with_capacity(80);
    let mut k = 0;
    let mut push = |out: &mut dyn Write, v: f64, line: &mut String| -> std::io::Result<()> {
        let w = widths[k % per_line];
        let d = if w == 13 { 5 } else { 12 };
        line.push_str(&fortran_e(v, w, d));
        k += 1;
        if k % per_line == 0 {
            writeln!(out, "{line}")?;
            line.clear();
        }
        Ok(())
    };
    for i in 0..n {
        if let Abscissa::Uneven(x) = &f.abscissa {
            push(out, x[i], &mut line)?;
        }
        match &f.ordinate {
            Ordinate::Real(y) => push(out, y[i], &mut line)?,
            Ordinate::Complex(y) => {
                push(out, y[i].re, &mut line)?;
                push(out, y[i].im, &mut line)?;
            }
        }
    }
    if !line.is_empty() {
        writeln!(out, "{line}")?;
    }
    writeln!(out, "    -1")
}

/// Writes datasets 58 to `path` as one ASCII UFF file, atomically.
pub fn write(path: &Path, functions: &[Function]) -> Result<()> {
    write_atomic(path, |w| {
        for f in functions {
            write_ascii(w, f).map_err(|e| Error::io(path, e))?;
        }
        Ok(())
    })
}
