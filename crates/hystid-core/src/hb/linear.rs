//! The underlying linear part as harmonic balance sees it: a point receptance.
//!
//! Harmonic balance needs the underlying linear structure only through its
//! receptance `H(ω) = X/F` at the drive/joint/response point, evaluated at
//! every harmonic `hω` (the paper's eq. 8 uses its inverse, the impedance
//! `Z_h`). Two sources implement [`LinearPart`]:
//!
//! * [`ModalModel`]: `H(ω) = Σ_r R_r/(ω_r² − ω² + 2jζ_r ω_r ω)`, exact;
//! * [`TabulatedFrf`]: a measured or estimated receptance over a frequency
//!   table (e.g. the paper's large-force estimate of the underlying linear
//!   system), interpolated, and an error outside its range.

use crate::error::{Error, Result};
use crate::model::{Attachment, DriveLoad, Element, ModalModel};
use num_complex::Complex64;
use std::f64::consts::PI;

/// The linear structure at the joint point, seen through its receptance.
pub trait LinearPart {
    /// The receptance `X/F` (m/N) at angular frequency `omega` (rad/s, ≥ 0).
    ///
    /// An `Err` where the receptance is not known (outside a table's range).
    fn receptance(&self, omega: f64) -> Result<Complex64>;

    /// How the reference reaches the structure at `omega`: the force at the
    /// drive point is `D(ω)` times the reference's (1: the reference is the
    /// force; see [`Driven`]).
    fn drive(&self, _omega: f64) -> Complex64 {
        Complex64::new(1.0, 0.0)
    }
}

/// A linear part driven through a drive model (a shaker, [`DriveLoad`]) and
/// loaded by what is attached at the drive point (an armature,
/// [`Attachment`]): the receptance with their dynamic stiffnesses `Z`
/// attached, `H/(1 + H Z)`, and the drive `D(ω)`. Exact, harmonic by
/// harmonic, since both are linear: with a voltage reference `e` the drive
/// point obeys `X = H (D E − Z X − G)`, which is `X = H/(1 + HZ) · (D E − G)`.
#[derive(Clone, Copy, Debug)]
pub struct Driven<'a, L> {
    /// The structure.
    pub linear: &'a L,
    /// The drive model; `None` passes the structure through.
    pub load: Option<DriveLoad>,
    /// What is attached at the drive point; `None`: nothing.
    pub attachment: Option<Attachment>,
}

impl<'a, L> Driven<'a, L> {
    /// `linear` driven as `elements` say (their shaker and armature, if any).
    pub fn of<E: Element>(linear: &'a L, elements: &E) -> Driven<'a, L> {
        Driven {
            linear,
            load: elements.drive_load(),
            attachment: elements.attachment(),
        }
    }
}

impl<L: LinearPart> LinearPart for Driven<'_, L> {
    #[inline]
    fn receptance(&self, omega: f64) -> Result<Complex64> {
        let h = self.linear.receptance(omega)?;
        let z = self.load.map(|l| l.impedance(omega)).unwrap_or_default()
            + self
                .attachment
                .map(|a| a.impedance(omega))
                .unwrap_or_default();
        Ok(if self.load.is_some() || self.attachment.is_some() {
            h / (1.0 + h * z)
        } else {
            h
        })
    }
    #[inline]
    fn drive(&self, omega: f64) -> Complex64 {
        match self.load {
            Some(load) => load.drive(omega) * self.linear.drive(omega),
            None => self.linear.drive(omega),
        }
    }
}

impl LinearPart for ModalModel {
    #[inline]
    fn receptance(&self, omega: f64) -> Result<Complex64> {
        Ok(ModalModel::receptance(self, omega))
    }
}

/// A linear part as a ramp-invariant digital filter sees it: the receptance
/// times `sinc²(f/fs)`, the transform's known amplitude factor. Harmonic
/// balance on it predicts the digital-filter simulator's steady state exactly
/// up to the (sinc²-weighted) aliases, which is how `--check-hb` compares the
/// two solvers on one model.
#[derive(Clone, Debug)]
pub struct SampledReceptance<'a, L> {
    /// The continuous linear part.
    pub linear: &'a L,
    /// The simulator's sample rate, Hz.
    pub sample_rate_hz: f64,
}

impl<L: LinearPart> LinearPart for SampledReceptance<'_, L> {
    fn receptance(&self, omega: f64) -> Result<Complex64> {
        let u = omega / (2.0 * PI * self.sample_rate_hz);
        Ok(self.linear.receptance(omega)? * crate::harmonics::sinc(u).powi(2))
    }
    fn drive(&self, omega: f64) -> Complex64 {
        self.linear.drive(omega)
    }
}

/// A tabulated receptance, interpolated between its frequencies.
///
/// The interpolant is a piecewise-cubic Hermite curve through the dynamic
/// stiffness `1/H` (real and imaginary parts separately) with three-point
/// slopes. For one mode, `1/H = k − mω² + jcω` is a quadratic in frequency,
/// which this interpolant reproduces exactly, so a tabulated SDOF equals the
/// modal one to round-off at any spacing. With several modes `1/H` has poles
/// at the antiresonances: tabulate finely there.
///
/// Outside `[first, last]` frequency the receptance is an error: harmonic
/// balance at `f` with harmonics up to `K` needs the table up to `K·f` (and
/// from 0 Hz when the static harmonic 0 is balanced).
#[derive(Clone, Debug, PartialEq)]
pub struct TabulatedFrf {
    frequencies_hz: Vec<f64>,
    receptance: Vec<Complex64>,
    /// `1/H` at the table points.
    stiffness: Vec<Complex64>,
    /// `d(1/H)/df` at the table points.
    slopes: Vec<Complex64>,
}

impl TabulatedFrf {
    /// A table of receptances `X/F` (m/N) at strictly increasing frequencies
    /// (Hz, ≥ 0). At least two points; all values finite and non-zero.
    pub fn new(frequencies_hz: Vec<f64>, receptance: Vec<Complex64>) -> Result<TabulatedFrf> {
        const WHAT: &str = "tabulated receptance";
        if frequencies_hz.len() != receptance.len() {
            return Err(Error::input(
                WHAT,
                format!(
                    "{} frequencies but {} receptance values",
                    frequencies_hz.len(),
                    receptance.len()
                ),
            ));
        }
        if frequencies_hz.len() < 2 {
            return Err(Error::input(WHAT, "at least two frequencies are needed"));
        }
        for (i, &f) in frequencies_hz.iter().enumerate() {
            if !(f.is_finite() && f >= 0.0) {
                return Err(Error::input(
                    format!("{WHAT}: frequency[{i}]"),
                    format!("must be finite and >= 0 Hz, got {f}"),
                ));
            }
            if i > 0 && f <= frequencies_hz[i - 1] {
                return Err(Error::input(
                    format!("{WHAT}: frequency[{i}]"),
                    format!(
                        "frequencies must increase strictly, got {} then {f} Hz",
                        frequencies_hz[i - 1]
                    ),
                ));
            }
        }
        for (i, h) in receptance.iter().enumerate() {
            if !(h.re.is_finite() && h.im.is_finite()) || h.norm() == 0.0 {
                return Err(Error::input(
                    format!("{WHAT}: receptance[{i}]"),
                    format!("must be finite and non-zero, got {h}"),
                ));
            }
        }
        let stiffness: Vec<Complex64> = receptance.iter().map(|h| h.inv()).collect();
        let slopes = three_point_slopes(&frequencies_hz, &stiffness);
        Ok(TabulatedFrf {
            frequencies_hz,
            receptance,
            stiffness,
            slopes,
        })
    }

    /// Samples any linear part at the given frequencies.
    pub fn sample<L: LinearPart>(linear: &L, frequencies_hz: &[f64]) -> Result<TabulatedFrf> {
        let h = frequencies_hz
            .iter()
            .map(|&f| linear.receptance(2.0 * PI * f))
            .collect::<Result<Vec<_>>>()?;
        TabulatedFrf::new(frequencies_hz.to_vec(), h)
    }

    /// `(first, last)` tabulated frequency, Hz.
    pub fn range_hz(&self) -> (f64, f64) {
        (
            self.frequencies_hz[0],
            self.frequencies_hz[self.frequencies_hz.len() - 1],
        )
    }

    /// The tabulated frequencies, Hz.
    pub fn frequencies_hz(&self) -> &[f64] {
        &self.frequencies_hz
    }

    /// The tabulated receptances, m/N.
    pub fn values(&self) -> &[Complex64] {
        &self.receptance
    }
}

impl LinearPart for TabulatedFrf {
    fn receptance(&self, omega: f64) -> Result<Complex64> {
        let f = omega / (2.0 * PI);
        let (lo, hi) = self.range_hz();
        // a relative slack of a few ulps so that h·ω round-off at the ends
        // is not an error
        let slack = 1e-12 * hi.abs().max(1.0);
        if !(f.is_finite() && f >= lo - slack && f <= hi + slack) {
            return Err(Error::input(
                "tabulated receptance",
                format!("{f} Hz is outside the table's range [{lo}, {hi}] Hz"),
            ));
        }
        let f = f.clamp(lo, hi);
        let fs = &self.frequencies_hz;
        let i = fs.partition_point(|&x| x <= f).clamp(1, fs.len() - 1) - 1;
        let (f0, f1) = (fs[i], fs[i + 1]);
        let w = f1 - f0;
        let t = (f - f0) / w;
        // cubic Hermite basis
        let t2 = t * t;
        let t3 = t2 * t;
        let h00 = 2.0 * t3 - 3.0 * t2 + 1.0;
        let h10 = t3 - 2.0 * t2 + t;
        let h01 = -2.0 * t3 + 3.0 * t2;
        let h11 = t3 - t2;
        let z = self.stiffness[i] * h00
            + self.slopes[i] * (h10 * w)
            + self.stiffness[i + 1] * h01
            + self.slopes[i + 1] * (h11 * w);
        Ok(z.inv())
    }
}

/// Slopes from the three-point (non-uniform) difference formulas, which are
/// exact for quadratics; two points give the chord.
fn three_point_slopes(x: &[f64], y: &[Complex64]) -> Vec<Complex64> {
    let n = x.len();
    if n == 2 {
        let s = (y[1] - y[0]) / (x[1] - x[0]);
        return vec![s, s];
    }
    let mut d = vec![Complex64::new(0.0, 0.0); n];
    for i in 0..n {
        // the three points used: centred inside, one-sided at the ends
        let j = i.clamp(1, n - 2);
        let (xa, xb, xc) = (x[j - 1], x[j], x[j + 1]);
        let (ya, yb, yc) = (y[j - 1], y[j], y[j + 1]);
        let xi = x[i];
        // derivative of the Lagrange quadratic through a, b, c at xi
        let la = ((xi - xb) + (xi - xc)) / ((xa - xb) * (xa - xc));
        let lb = ((xi - xa) + (xi - xc)) / ((xb - xa) * (xb - xc));
        let lc = ((xi - xa) + (xi - xb)) / ((xc - xa) * (xc - xb));
        d[i] = ya * la + yb * lb + yc * lc;
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tabulated_sdof_equals_the_modal_receptance_between_points() {
        let model = ModalModel::sdof(10.0, 200.0, 1e7).unwrap();
        // coarse, uneven table: the 1/H interpolant is exact for one mode
        let freqs: Vec<f64> = (0..30)
            .map(|i| 10.0 + 7.3 * i as f64 + 0.01 * (i * i) as f64)
            .collect();
        let t = TabulatedFrf::sample(&model, &freqs).unwrap();
        for k in 0..500 {
            let f = 10.0 + (freqs[29] - 10.0) * k as f64 / 499.0;
            let w = 2.0 * PI * f;
            let a = LinearPart::receptance(&t, w).unwrap();
            let b = ModalModel::receptance(&model, w);
            assert!((a - b).norm() <= 1e-10 * b.norm(), "f={f}: {a} vs {b}");
        }
    }

    #[test]
    fn outside_the_range_is_an_error_naming_the_range() {
        let model = ModalModel::sdof(10.0, 200.0, 1e7).unwrap();
        let t = TabulatedFrf::sample(&model, &[100.0, 200.0, 300.0]).unwrap();
        let e = t.receptance(2.0 * PI * 301.0).unwrap_err().to_string();
        assert!(e.contains("301") && e.contains("[100, 300]"), "{e}");
        assert!(t.receptance(2.0 * PI * 99.0).is_err());
        assert!(t.receptance(2.0 * PI * 300.0).is_ok());
        assert!(t.receptance(f64::NAN).is_err());
    }

    #[test]
    fn bad_tables_are_errors() {
        let one = Complex64::new(1e-6, 0.0);
        assert!(TabulatedFrf::new(vec![1.0, 1.0], vec![one, one]).is_err());
        assert!(TabulatedFrf::new(vec![1.0, 2.0], vec![one]).is_err());
        assert!(TabulatedFrf::new(vec![1.0], vec![one]).is_err());
        assert!(
            TabulatedFrf::new(vec![1.0, 2.0], vec![one, Complex64::new(f64::NAN, 0.0)]).is_err()
        );
        assert!(TabulatedFrf::new(vec![1.0, 2.0], vec![one, Complex64::new(0.0, 0.0)]).is_err());
        assert!(TabulatedFrf::new(vec![-1.0, 2.0], vec![one, one]).is_err());
    }
}
