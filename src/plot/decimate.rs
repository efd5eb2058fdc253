//! Min/max decimation of long signals for drawing.
//!
//! A 1e6-sample record on a 900-pixel-wide axis is drawn from the smallest
//! and largest sample of each pixel column, in the order they occur: the
//! drawn envelope is then exactly what drawing every sample would have
//! covered, at the cost of two points per column (the classic oscilloscope
//! "peak detect" display).

/// The extreme finite samples of one column of a signal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColumnExtremes {
    /// Index of the smallest finite sample (the first, if tied).
    pub min_index: usize,
    /// The smallest finite sample.
    pub min: f64,
    /// Index of the largest finite sample (the first, if tied).
    pub max_index: usize,
    /// The largest finite sample.
    pub max: f64,
}

/// Splits `values` into `columns` consecutive columns (fewer when there are
/// fewer samples) and returns each column's extremes, `None` for a column
/// without a finite sample. Sample `i` of `n` belongs to column
/// `⌊i·columns/n⌋`, so every column holds `⌊n/columns⌋` or `⌈n/columns⌉`
/// samples.
pub fn min_max_columns(values: &[f64], columns: usize) -> Vec<Option<ColumnExtremes>> {
    let n = values.len();
    let m = columns.min(n);
    (0..m)
        .map(|c| {
            let (start, end) = (column_start(c, n, m), column_start(c + 1, n, m));
            extremes(&values[start..end], start)
        })
        .collect()
}

/// First sample of column `c` of `m` over `n` samples: `⌈c·n/m⌉` (in u128,
/// so no product overflows).
fn column_start(c: usize, n: usize, m: usize) -> usize {
    (c as u128 * n as u128).div_ceil(m as u128) as usize
}

fn extremes(column: &[f64], offset: usize) -> Option<ColumnExtremes> {
    let mut best: Option<ColumnExtremes> = None;
    for (i, &v) in column.iter().enumerate() {
        if !v.is_finite() {
            continue;
        }
        let i = i + offset;
        match &mut best {
            None => {
                best = Some(ColumnExtremes {
                    min_index: i,
                    min: v,
                    max_index: i,
                    max: v,
                })
            }
            Some(b) => {
                if v < b.min {
                    b.min = v;
                    b.min_index = i;
                }
                if v > b.max {
                    b.max = v;
                    b.max_index = i;
                }
            }
        }
    }
    best
}

/// The points to draw for a uniformly sampled signal: every sample when there
/// are at most two per column, else each column's minimum and maximum, in
/// time order, both at the column's mid-time. Drawing them at one time makes
/// every column a vertical stroke covering its whole extent (at their own
/// times a pixel column could be crossed only by half-height diagonals and
/// show a white streak); the shift is under one column. A NaN point marks a
/// gap (a non-finite sample, or a column without any finite sample).
pub(super) fn signal_points(
    values: &[f64],
    start_s: f64,
    sample_rate_hz: f64,
    columns: usize,
) -> Vec<(f64, f64)> {
    let t = |i: usize| start_s + i as f64 / sample_rate_hz;
    let gap = (f64::NAN, f64::NAN);
    if values.len() <= 2 * columns {
        return values
            .iter()
            .enumerate()
            .map(|(i, &v)| if v.is_finite() { (t(i), v) } else { gap })
            .collect();
    }
    let n = values.len();
    let mut points = Vec::with_capacity(2 * columns);
    for (c, column) in min_max_columns(values, columns).into_iter().enumerate() {
        let Some(e) = column else {
            points.push(gap);
            continue;
        };
        let mid = 0.5 * (t(column_start(c, n, columns)) + t(column_start(c + 1, n, columns) - 1));
        let (first, second) = if e.min_index <= e.max_index {
            (e.min, e.max)
        } else {
            (e.max, e.min)
        };
        points.push((mid, first));
        if e.min_index != e.max_index {
            points.push((mid, second));
        }
    }
    points
}
