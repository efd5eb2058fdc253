//! Dataset 58 read: its eleven header records and its ordinate values, ASCII
//! or binary.

use super::cursor::{
    BinaryHeader, Cursor, Where, bytes_left, closes_at, cols, is_blank, is_delimiter, parse_int,
    parse_real, resolution, shown, skip_to_delimiter, text,
};
use super::types::{Abscissa, Axis, BinaryLayout, Case, Dof, Function, Ordinate, Precision};
use crate::Result;
use num_complex::Complex64;

const RECORD_NAMES: [&str; 11] = [
    "ID line 1",
    "ID line 2",
    "ID line 3",
    "ID line 4",
    "ID line 5",
    "record 6 (DOF identification)",
    "record 7 (data form)",
    "record 8 (abscissa characteristics)",
    "record 9 (ordinate characteristics)",
    "record 10 (ordinate denominator characteristics)",
    "record 11 (z-axis characteristics)",
];

pub(super) fn read_58(
    cur: &mut Cursor,
    mut w: Where,
    header: Option<BinaryHeader>,
) -> Result<Function> {
    if let Some(h) = &header
        && h.ascii_lines != 11
    {
        return Err(w.err(
            w.line,
            format!(
                "the binary header says {} ASCII lines; dataset 58 has 11",
                h.ascii_lines
            ),
        ));
    }
    let mut lines: Vec<(&[u8], usize)> = Vec::with_capacity(11);
    for name in RECORD_NAMES {
        match cur.next_line() {
            Some(l) => lines.push(l),
            None => {
                return Err(w.err(
                    cur.line.saturating_sub(1).max(w.line),
                    format!("the file ends in the header: expected {name}"),
                ));
            }
        }
    }
    let id_lines: [String; 5] = std::array::from_fn(|k| text(lines[k].0));
    w.id1 = Some(id_lines[0].clone());
    let (response, reference, function_type, function_id, version, load_case) =
        record_6(&w, lines[5])?;
    let (case, n, start, increment, increment_resolution, z_axis_value) = record_7(&w, lines[6])?;
    let axes: Vec<Axis> = (7..11)
        .map(|k| axis_record(&w, lines[k], RECORD_NAMES[k]))
        .collect::<Result<_>>()?;
    let [abscissa_axis, ordinate_axis, denominator_axis, z_axis]: [Axis; 4] =
        axes.try_into().map_err(|_| w.err(w.line, "records 8-11"))?;
    let record_7_line = lines[6].1;
    let (values, binary) = match header {
        Some(h) => {
            let (v, layout) = binary_values(cur, &w, &h, case, n, record_7_line)?;
            (v, Some(layout))
        }
        None => (ascii_values(cur, &w, case, n, record_7_line)?, None),
    };
    let per = case.per_point();
    let (abscissa, ordinate) = {
        let x = if case.even {
            Abscissa::Even {
                start,
                increment,
                increment_resolution,
            }
        } else {
            Abscissa::Uneven(values.iter().step_by(per).copied().collect())
        };
        let skip = usize::from(!case.even);
        let y = if case.complex {
            Ordinate::Complex(
                values
                    .chunks_exact(per)
                    .map(|c| Complex64::new(c[skip], c[skip + 1]))
                    .collect(),
            )
        } else {
            Ordinate::Real(values.chunks_exact(per).map(|c| c[skip]).collect())
        };
        (x, y)
    };
    Ok(Function {
        id_lines,
        function_type,
        function_id,
        version,
        load_case,
        response,
        reference,
        precision: case.precision,
        abscissa,
        z_axis_value,
        abscissa_axis,
        ordinate_axis,
        denominator_axis,
        z_axis,
        ordinate,
        binary,
    })
}

type Record6 = (Dof, Dof, i64, i64, i64, i64);

fn record_6(w: &Where, (line, n): (&[u8], usize)) -> Result<Record6> {
    // Format(2(I5,I10),2(1X,10A1,I10,I4))
    let ints = [
        (0, 5),
        (5, 15),
        (15, 20),
        (20, 30),
        (41, 51),
        (51, 55),
        (66, 76),
        (76, 80),
    ]
    .map(|(a, b)| parse_int(cols(line, a, b)));
    if let [
        Some(ft),
        Some(id),
        Some(ver),
        Some(lc),
        Some(rn),
        Some(rd),
        Some(fn_),
        Some(fd),
    ] = ints
    {
        // a record 6 cut short by a trimming editor has blank reference fields
        let name = |a, b| {
            let t = text(cols(line, a, b));
            if t.is_empty() { "NONE".to_string() } else { t }
        };
        return Ok((
            Dof {
                entity: name(31, 41),
                node: rn,
                direction: rd,
            },
            Dof {
                entity: name(56, 66),
                node: fn_,
                direction: fd,
            },
            ft,
            id,
            ver,
            lc,
        ));
    }
    // written without the fixed columns: ten blank-separated fields
    let t = text(line);
    let f: Vec<&str> = t.split_whitespace().collect();
    let int = |k: usize| f.get(k).and_then(|s| s.parse::<i64>().ok());
    if f.len() == 10
        && let [
            Some(ft),
            Some(id),
            Some(ver),
            Some(lc),
            Some(rn),
            Some(rd),
            Some(fn_),
            Some(fd),
        ] = [0, 1, 2, 3, 5, 6, 8, 9].map(int)
    {
        return Ok((
            Dof {
                entity: f[4].to_string(),
                node: rn,
                direction: rd,
            },
            Dof {
                entity: f[7].to_string(),
                node: fn_,
                direction: fd,
            },
            ft,
            id,
            ver,
            lc,
        ));
    }
    Err(w.err(
        n,
        format!(
            "record 6 (DOF identification) `{}`: expected Format(2(I5,I10),2(1X,10A1,I10,I4)): \
             function type, function ID, version, load case, response entity, node, direction, \
             reference entity, node, direction",
            shown(line)
        ),
    ))
}

type Record7 = (Case, usize, f64, f64, f64, f64);

fn record_7(w: &Where, (line, n): (&[u8], usize)) -> Result<Record7> {
    // Format(3I10,3E13.5); blank-separated fields are accepted too
    let t = text(line);
    let tokens: Vec<&str> = t.split_whitespace().collect();
    let free = (3..=6).contains(&tokens.len())
        && tokens[..3].iter().all(|s| s.parse::<i64>().is_ok())
        && tokens[3..].iter().all(|s| parse_real(s).is_some());
    let fields: Vec<String> = if free {
        tokens.iter().map(|s| s.to_string()).collect()
    } else {
        [(0, 10), (10, 20), (20, 30), (30, 43), (43, 56), (56, 69)]
            .iter()
            .map(|&(a, b)| text(cols(line, a, b)))
            .collect()
    };
    let bad = |what: &str| {
        w.err(
            n,
            format!(
                "record 7 (data form) `{}`: {what}; expected Format(3I10,3E13.5): ordinate data \
                 type (2, 4, 5, 6), number of values, abscissa spacing (0 uneven, 1 even), \
                 abscissa start, increment, z-axis value",
                shown(line)
            ),
        )
    };
    let int = |k: usize| -> Option<i64> {
        match fields.get(k).map(String::as_str) {
            Some("") | None => None,
            Some(s) => s.parse().ok(),
        }
    };
    let real = |k: usize| -> Option<f64> {
        match fields.get(k).map(String::as_str) {
            Some("") | None => Some(0.0),
            Some(s) => parse_real(s),
        }
    };
    let ty = int(0).ok_or_else(|| bad("no ordinate data type"))?;
    let count = int(1).ok_or_else(|| bad("no number of values"))?;
    let spacing = int(2).ok_or_else(|| bad("no abscissa spacing"))?;
    let (complex, precision) = match ty {
        2 => (false, Precision::Single),
        4 => (false, Precision::Double),
        5 => (true, Precision::Single),
        6 => (true, Precision::Double),
        _ => return Err(bad(&format!("ordinate data type {ty} is not 2, 4, 5 or 6"))),
    };
    let even = match spacing {
        0 => false,
        1 => true,
        s => return Err(bad(&format!("abscissa spacing {s} is not 0 or 1"))),
    };
    let count = usize::try_from(count).map_err(|_| bad(&format!("{count} values")))?;
    let start = real(3).ok_or_else(|| bad("the abscissa start is not a number"))?;
    let increment = real(4).ok_or_else(|| bad("the abscissa increment is not a number"))?;
    let z = real(5).ok_or_else(|| bad("the z-axis value is not a number"))?;
    let res = fields.get(4).map_or(f64::INFINITY, |s| resolution(s));
    Ok((
        Case {
            complex,
            precision,
            even,
        },
        count,
        start,
        increment,
        res,
        z,
    ))
}

fn axis_record(w: &Where, (line, n): (&[u8], usize), name: &str) -> Result<Axis> {
    // Format(I10,3I5,2(1X,20A1))
    let fixed = [(0, 10), (10, 15), (15, 20), (20, 25)].map(|(a, b)| parse_int(cols(line, a, b)));
    let label = |a, b| {
        let t = text(cols(line, a, b));
        if t.is_empty() { "NONE".to_string() } else { t }
    };
    if let [Some(ty), Some(l), Some(f), Some(t)] = fixed {
        return Ok(Axis {
            data_type: ty,
            length_exponent: l,
            force_exponent: f,
            temperature_exponent: t,
            label: label(26, 46),
            units: label(47, usize::MAX),
        });
    }
    // the four integers blank-separated without their columns
    let s = text(line);
    let f: Vec<&str> = s.split_whitespace().collect();
    if f.len() >= 4
        && let [Some(ty), Some(l), Some(fe), Some(t)] = [0, 1, 2, 3].map(|k| f[k].parse().ok())
    {
        return Ok(Axis {
            data_type: ty,
            length_exponent: l,
            force_exponent: fe,
            temperature_exponent: t,
            label: f.get(4).map_or("NONE".into(), |s| s.to_string()),
            units: f.get(5).map_or("NONE".into(), |s| s.to_string()),
        });
    }
    Err(w.err(
        n,
        format!(
            "{name} `{}`: expected Format(I10,3I5,2(1X,20A1)): specific data type, length, force \
             and temperature unit exponents, axis label, units label",
            shown(line)
        ),
    ))
}

/// The values of an ASCII record 12, counted from record 7.
fn ascii_values(
    cur: &mut Cursor,
    w: &Where,
    case: Case,
    n: usize,
    record_7_line: usize,
) -> Result<Vec<f64>> {
    let need = n.checked_mul(case.per_point()).ok_or_else(|| {
        w.err(
            record_7_line,
            format!("record 7 declares {n} values: too many"),
        )
    })?;
    // a value takes at least two bytes of text: never reserve beyond the file
    let mut values = Vec::with_capacity(need.min(bytes_left(cur) / 2));
    let mut tokens: Vec<&str> = Vec::new();
    let widths = case.widths();
    let what = || {
        format!(
            "record 7 declares {n} values ({}: {need} numbers in {})",
            case.describe(),
            case.format()
        )
    };
    while values.len() < need {
        let Some((line, k)) = cur.next_line() else {
            return Err(w.err(
                cur.line.saturating_sub(1),
                format!(
                    "the file ends after {} of {need} numbers: {}",
                    values.len(),
                    what()
                ),
            ));
        };
        if is_blank(line) {
            continue;
        }
        if is_delimiter(line) {
            return Err(w.err(
                k,
                format!(
                    "the dataset closes (`-1`) after {} of {need} numbers: {}",
                    values.len(),
                    what()
                ),
            ));
        }
        let s = match std::str::from_utf8(line) {
            Ok(s) => s,
            Err(_) => {
                return Err(w.err(
                    k,
                    format!(
                        "`{}` is not text: expected numbers in {}",
                        shown(line),
                        case.format()
                    ),
                ));
            }
        };
        let before = values.len();
        tokens.clear();
        tokens.extend(s.split_whitespace());
        let bad = tokens.iter().position(|t| parse_real(t).is_none());
        match bad {
            None => values.extend(tokens.iter().filter_map(|t| parse_real(t))),
            Some(i) => match fixed_columns(s.trim_end(), widths) {
                // values run together in their fixed columns
                Some(v) => values.extend(v),
                None => {
                    return Err(w.err(
                        k,
                        format!(
                            "`{}` is not a number (value {} of {need}; expected {} in {})",
                            tokens[i],
                            before + i + 1,
                            case.describe(),
                            case.format()
                        ),
                    ));
                }
            },
        }
        if values.len() > need {
            return Err(w.err(
                k,
                format!(
                    "{} numbers so far, more than the {need} that record 7 declares ({} values, {})",
                    values.len(),
                    n,
                    case.describe()
                ),
            ));
        }
    }
    closing_delimiter(cur, w, || {
        format!(
            "the {need} numbers record 7 declares ({n} values, {})",
            case.describe()
        )
    })?;
    Ok(values)
}

/// The dataset's closing `-1` after its values (`after` says what came
/// before it), blank lines skipped.
fn closing_delimiter(cur: &mut Cursor, w: &Where, after: impl Fn() -> String) -> Result<()> {
    loop {
        match cur.next_line() {
            Some((l, _)) if is_blank(l) => continue,
            Some((l, _)) if is_delimiter(l) => return Ok(()),
            Some((l, k)) => {
                return Err(w.err(
                    k,
                    format!(
                        "expected the closing `    -1` after {}, found `{}`",
                        after(),
                        shown(l)
                    ),
                ));
            }
            None => {
                return Err(w.err(
                    cur.line.saturating_sub(1),
                    "the file ends before the dataset's closing `    -1`",
                ));
            }
        }
    }
}

/// A line of numbers in fixed columns of `widths` (repeated), for values
/// that run together (`-1.23457E-100-2.00000E+00`): `None` unless every
/// field is one number and no column boundary cuts a number (a boundary
/// falls next to a blank, or before the sign of a number that follows a
/// digit).
fn fixed_columns(line: &str, widths: &[usize]) -> Option<Vec<f64>> {
    let b = line.as_bytes();
    let mut out = Vec::new();
    let mut at = 0;
    for &width in widths.iter().cycle() {
        if at >= b.len() {
            return Some(out);
        }
        if at > 0 {
            let (l, r) = (b[at - 1], b[at]);
            let clean = l.is_ascii_whitespace()
                || r.is_ascii_whitespace()
                || ((r == b'+' || r == b'-') && (l.is_ascii_digit() || l == b'.'));
            if !clean {
                return None;
            }
        }
        let end = (at + width).min(b.len());
        let field = std::str::from_utf8(&b[at..end]).ok()?.trim();
        if field.contains(char::is_whitespace) {
            return None;
        }
        out.push(parse_real(field)?);
        at = end;
    }
    Some(out)
}

/// The values of a binary record 12: the layout record 7 implies, with the
/// byte count whose end meets the closing `-1`.
fn binary_values(
    cur: &mut Cursor,
    w: &Where,
    h: &BinaryHeader,
    case: Case,
    n: usize,
    record_7_line: usize,
) -> Result<(Vec<f64>, BinaryLayout)> {
    let start = cur.pos;
    let data_line = cur.line;
    let width = match case.precision {
        Precision::Single => 4usize,
        Precision::Double => 8,
    };
    let y_per = if case.complex { 2 } else { 1 };
    // (bytes per point, abscissa width)
    let mut layouts: Vec<(usize, usize)> = Vec::new();
    if case.even {
        layouts.push((width * y_per, 0));
    } else {
        layouts.push((width * (y_per + 1), width));
        if case.precision == Precision::Double {
            layouts.push((width * y_per + 4, 4));
        }
    }
    let sized: Vec<(usize, usize)> = layouts
        .iter()
        .filter_map(|&(per, xw)| n.checked_mul(per).map(|b| (b, xw)))
        .collect();
    let declared = usize::try_from(h.bytes).unwrap_or(usize::MAX);
    let left = bytes_left(cur);
    let fits = |b: usize| b <= left && closes_at(cur.bytes, start + b);
    let chosen = sized
        .iter()
        .find(|&&(b, _)| b == declared && fits(b))
        .or_else(|| sized.iter().find(|&&(b, _)| fits(b)))
        .copied();
    let Some((bytes, x_width)) = chosen else {
        let expected: Vec<String> = sized.iter().map(|(b, _)| b.to_string()).collect();
        let why = why_unclosed(cur, start, &sized, declared, case, n);
        return Err(w.err(
            data_line,
            format!(
                "binary data (byte offset {start}): record 7 (line {record_7_line}) declares {n} \
                 values ({}), {} bytes, and the 58b line {} bytes, but {why}",
                case.describe(),
                expected.join(" or "),
                h.bytes
            ),
        ));
    };
    let data = &cur.bytes[start..start + bytes];
    let mut values = Vec::with_capacity(n * case.per_point());
    decode_points(
        &mut values,
        data,
        bytes.checked_div(n).unwrap_or(0),
        (x_width, y_per, width),
        h.big_endian,
    );
    cur.skip_bytes(bytes);
    skip_to_delimiter(cur);
    Ok((
        values,
        BinaryLayout {
            big_endian: h.big_endian,
            declared_bytes: h.bytes,
            data_bytes: bytes as u64,
            single_abscissa: x_width == 4 && case.precision == Precision::Double,
        },
    ))
}

/// Why none of the layouts `sized` (bytes, abscissa width) of `n` values
/// starting at `start` is closed by the dataset's `-1`, with a hint where
/// the header's byte count or the other precision would close it.
fn why_unclosed(
    cur: &Cursor,
    start: usize,
    sized: &[(usize, usize)],
    declared: usize,
    case: Case,
    n: usize,
) -> String {
    let left = bytes_left(cur);
    let smallest = sized.iter().map(|s| s.0).min().unwrap_or(usize::MAX);
    if smallest > left {
        format!("the file ends {left} bytes into the data")
    } else {
        let at = start.saturating_add(smallest);
        let after = cur.bytes.get(at..).unwrap_or(&[]);
        // the values in the other precision would close it: say so
        let other = match case.precision {
            Precision::Single => sized.iter().map(|s| s.0.saturating_mul(2)).min(),
            Precision::Double => sized.iter().map(|s| s.0 / 2).min(),
        }
        .filter(|&b| b <= left && closes_at(cur.bytes, start + b));
        let per_point = sized.first().map_or(0, |s| s.0 / n.max(1));
        let by_header = (declared <= left
            && closes_at(cur.bytes, start + declared)
            && per_point > 0
            && declared % per_point == 0)
            .then(|| declared / per_point);
        let hint = match (by_header, other) {
            (Some(count), _) => format!(
                "; it follows the 58b line's {declared} bytes, {count} values of this type: \
                 record 7's number of values does not match the data"
            ),
            (None, Some(b)) => format!(
                "; it follows {b} bytes, these values' size in {} precision: record 7's \
                 data type does not match the data (pyuff 2.5 writes single-precision 58b \
                 this way)",
                match case.precision {
                    Precision::Single => "double",
                    Precision::Double => "single",
                }
            ),
            (None, None) => String::new(),
        };
        format!(
            "no closing `-1` follows them (bytes after the data: {}){hint}",
            hex(&after[..after.len().min(8)])
        )
    }
}

/// The values of binary points of `per` bytes each: an abscissa of
/// `x_width` bytes (none when 0), then `y_per` ordinates of `width` bytes
/// (4: single, 8: double precision).
fn decode_points(
    values: &mut Vec<f64>,
    data: &[u8],
    per: usize,
    (x_width, y_per, width): (usize, usize, usize),
    big_endian: bool,
) {
    let f32_at = |b: &[u8]| -> f64 {
        let a = [b[0], b[1], b[2], b[3]];
        (if big_endian {
            f32::from_be_bytes(a)
        } else {
            f32::from_le_bytes(a)
        }) as f64
    };
    let f64_at = |b: &[u8]| -> f64 {
        let a = [b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]];
        if big_endian {
            f64::from_be_bytes(a)
        } else {
            f64::from_le_bytes(a)
        }
    };
    let read = |b: &[u8], size: usize| if size == 4 { f32_at(b) } else { f64_at(b) };
    if per > 0 {
        for point in data.chunks_exact(per) {
            let mut at = 0;
            if x_width > 0 {
                values.push(read(&point[..x_width], x_width));
                at = x_width;
            }
            for _ in 0..y_per {
                values.push(read(&point[at..at + width], width));
                at += width;
            }
        }
    }
}

fn hex(b: &[u8]) -> String {
    if b.is_empty() {
        return "none, end of file".into();
    }
    b.iter()
        .map(|x| format!("{x:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}
