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

/// The points to draw for a uniformly sampled signal of known length,
/// handed on a stretch at a time (a replay that is never held whole): every
/// sample when there are at most two per column, else each column's
/// minimum and maximum, in time order, both at the column's mid-time.
/// Drawing them at one time makes each column a vertical stroke, the
/// envelope every sample would cover. A column without a finite sample,
/// and a non-finite sample drawn as is, break the line (a NaN point).
#[derive(Clone, Debug)]
pub struct SignalTrace {
    n: usize,
    start_s: f64,
    sample_rate_hz: f64,
    columns: usize,
    /// Samples pushed so far.
    seen: usize,
    /// The column being filled, its first sample and the first of the next.
    column: usize,
    column_start: usize,
    column_end: usize,
    best: Option<ColumnExtremes>,
    points: Vec<(f64, f64)>,
}

impl SignalTrace {
    /// A trace of `n` samples from `start_s` at `sample_rate_hz` on
    /// `columns` columns.
    pub fn new(n: usize, start_s: f64, sample_rate_hz: f64, columns: usize) -> SignalTrace {
        let every = n <= 2 * columns;
        SignalTrace {
            n,
            start_s,
            sample_rate_hz,
            columns,
            seen: 0,
            column: 0,
            column_start: 0,
            column_end: if every {
                n
            } else {
                column_start(1, n, columns)
            },
            best: None,
            points: Vec::with_capacity(if every { n } else { 2 * columns }),
        }
    }

    fn t(&self, i: usize) -> f64 {
        self.start_s + i as f64 / self.sample_rate_hz
    }

    /// Appends the next samples (those past the `n` announced are ignored).
    pub fn push(&mut self, values: &[f64]) {
        let values = &values[..values.len().min(self.n - self.seen)];
        if self.n <= 2 * self.columns {
            for &v in values {
                let t = self.t(self.seen);
                self.points.push(if v.is_finite() {
                    (t, v)
                } else {
                    (f64::NAN, f64::NAN)
                });
                self.seen += 1;
            }
            return;
        }
        let mut rest = values;
        while !rest.is_empty() {
            let take = (self.column_end - self.seen).min(rest.len());
            let found = extremes(&rest[..take], self.seen);
            self.best = match (self.best, found) {
                (None, f) => f,
                (b, None) => b,
                // the first of ties, as one pass over the column keeps it
                (Some(mut b), Some(f)) => {
                    if f.min < b.min {
                        (b.min, b.min_index) = (f.min, f.min_index);
                    }
                    if f.max > b.max {
                        (b.max, b.max_index) = (f.max, f.max_index);
                    }
                    Some(b)
                }
            };
            self.seen += take;
            rest = &rest[take..];
            if self.seen == self.column_end {
                self.close_column();
            }
        }
    }

    fn close_column(&mut self) {
        let gap = (f64::NAN, f64::NAN);
        let mid = 0.5 * (self.t(self.column_start) + self.t(self.column_end - 1));
        match self.best.take() {
            None => self.points.push(gap),
            Some(e) => {
                let (first, second) = if e.min_index <= e.max_index {
                    (e.min, e.max)
                } else {
                    (e.max, e.min)
                };
                self.points.push((mid, first));
                if e.min_index != e.max_index {
                    self.points.push((mid, second));
                }
            }
        }
        self.column += 1;
        self.column_start = self.column_end;
        self.column_end = column_start(self.column + 1, self.n, self.columns);
    }

    /// The points to draw. Panics where fewer samples than announced were
    /// pushed (a caller's bug).
    pub fn finish(self) -> Vec<(f64, f64)> {
        assert_eq!(
            self.seen, self.n,
            "a trace was handed fewer samples than announced"
        );
        self.points
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The points of the whole signal at once, column by column from
    /// [`min_max_columns`] (the reference the trace was written from).
    fn whole_points(values: &[f64], start_s: f64, fs: f64, columns: usize) -> Vec<(f64, f64)> {
        let t = |i: usize| start_s + i as f64 / fs;
        let gap = (f64::NAN, f64::NAN);
        if values.len() <= 2 * columns {
            return values
                .iter()
                .enumerate()
                .map(|(i, &v)| if v.is_finite() { (t(i), v) } else { gap })
                .collect();
        }
        let n = values.len();
        let mut points = Vec::new();
        for (c, column) in min_max_columns(values, columns).into_iter().enumerate() {
            let Some(e) = column else {
                points.push(gap);
                continue;
            };
            let mid =
                0.5 * (t(column_start(c, n, columns)) + t(column_start(c + 1, n, columns) - 1));
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

    /// A trace handed its signal in uneven stretches (one sample, a few,
    /// more than a column, the rest) draws the points of the whole signal
    /// column by column, to the bit: short signals sample by sample, long
    /// ones with ties (a clipped stretch), a column with no finite sample
    /// and non-finite samples among finite ones.
    #[test]
    fn a_trace_made_a_stretch_at_a_time_draws_the_whole_signals_points() {
        let same = |a: &[(f64, f64)], b: &[(f64, f64)]| {
            a.len() == b.len()
                && a.iter()
                    .zip(b)
                    .all(|(x, y)| x.0.to_bits() == y.0.to_bits() && x.1.to_bits() == y.1.to_bits())
        };
        for n in [0, 1, 7, 40, 41, 1000, 12_345] {
            let mut values: Vec<f64> = (0..n)
                .map(|i| (0.37 * i as f64).sin().clamp(-0.8, 0.8) + 1e-3 * (i % 5) as f64)
                .collect();
            if n > 1000 {
                values[600..1300].fill(f64::NAN);
                values[3000] = f64::INFINITY;
            }
            let columns = 20;
            let want = whole_points(&values, 0.25, 1000.0, columns);
            let mut trace = SignalTrace::new(n, 0.25, 1000.0, columns);
            let mut at = 0;
            for step in [1, 3, 900, usize::MAX].into_iter().cycle() {
                if at >= n {
                    break;
                }
                let end = at.saturating_add(step).min(n);
                trace.push(&values[at..end]);
                at = end;
            }
            assert!(same(&trace.finish(), &want), "{n} samples");
        }
    }
}
