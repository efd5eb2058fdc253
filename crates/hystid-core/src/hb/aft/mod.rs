//! Alternating frequency–time (AFT) evaluation of the element force.
//!
//! From the displacement harmonics `X_h` (Cameron & Griffin 1989):
//!
//! 1. `x_j = X_0 + Re Σ_h X_h e^{jhθ_j}`, `θ_j = 2πj/N` (an inverse real FFT),
//!    and `v_j` likewise with `jhω X_h` when an element uses velocity;
//! 2. the element is marched through the samples of one period, so that the
//!    forces `g_j` lie on a closed, periodic loop ([`PeriodicLoop`]);
//! 3. `G_h = (2/N) Σ_j g_j e^{−jhθ_j}` (`1/N` for `h = 0`), a forward real
//!    FFT, in the convention of [`crate::harmonics`].
//!
//! The Jacobian `∂G/∂X` is carried through the same march (the chain rule
//! through the turning-point history; NLvib's `HB_residual.m` does the same
//! for its Jenkins element). A law that states its sensitivity as tangents
//! plus memory terms ([`Element::commit_sensitivity_terms`]: Jenkins, Masing
//! and Iwan, every memoryless law) is projected in that form: the tangent
//! part `Σ_j k_j w_j ⊗ b_j` from one FFT of the tangents `k_j` (each entry a
//! harmonic `a ± b` of `k`), each memory term as its coefficients' weighted
//! sum of the analysis rows times its vector, `O(N log N + N n)` in all.
//! Any other law ([`Element::commit_sensitivity`], dense rows) has each of
//! the `n` columns transformed, `O(n N log N)`. The march without
//! sensitivities commits the samples between two turning points in one
//! [`Element::commit_run`]. Nothing here allocates after construction.
//!
//! The unknowns are real: `X_0` for the static harmonic, then `Re X_h`,
//! `Im X_h` for each `h ≥ 1`, in the order of the harmonic set.

use super::PeriodicLoop;

/// Largest distance of a gradually settling law's memory from periodic at the
/// close of a marched period ([`Element::close_period`]), relative to the
/// force's peak over it, at which its loop counts as periodic (the kept
/// period's forces are off by about as much).
const SETTLED: f64 = 1e-12;
/// ... or, once the Newton steps on the period map no longer halve that
/// distance (rounding in a long march), this much.
const SETTLED_AT_ROUNDING: f64 = 1e-9;
use crate::model::{Element, SensitivityTerms};
use num_complex::Complex64;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use std::f64::consts::PI;
use std::sync::Arc;

/// Why the harmonic-balance residual could not be evaluated at a point.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub(crate) enum EvalError {
    /// The AFT march met a non-finite element force.
    #[error(
        "element force is not finite at time sample {sample} of {samples} (x = {x:e} m, v = {v:e} m/s)"
    )]
    ElementForce {
        /// The time sample.
        sample: usize,
        /// Time samples per period.
        samples: usize,
        /// Displacement there, m.
        x: f64,
        /// Velocity there, m/s.
        v: f64,
    },
    /// A law whose memory fades gradually did not reach a periodic loop.
    #[error(
        "the element's loop did not repeat within {periods} periods (last off by {change:.1e} of its peak)"
    )]
    NotSettled {
        /// Periods marched.
        periods: usize,
        /// How far the last period's memory was from periodic, relative to
        /// the force's peak.
        change: f64,
    },
    /// A residual component is not finite (an overflowing receptance or force).
    #[error("the residual is not finite (component {component})")]
    Residual {
        /// The real unknown's index.
        component: usize,
    },
}

/// Where each harmonic's real unknowns sit.
#[derive(Clone, Debug)]
pub(crate) struct Layout {
    /// The harmonic set, increasing.
    pub harmonics: Vec<usize>,
    /// First unknown of each harmonic.
    pub slots: Vec<usize>,
    /// Number of real unknowns.
    pub len: usize,
}

impl Layout {
    pub fn new(harmonics: &[usize]) -> Layout {
        let mut slots = Vec::with_capacity(harmonics.len());
        let mut len = 0;
        for &h in harmonics {
            slots.push(len);
            len += if h == 0 { 1 } else { 2 };
        }
        Layout {
            harmonics: harmonics.to_vec(),
            slots,
            len,
        }
    }

    /// Complex harmonics (one per harmonic) into real unknowns.
    pub fn pack(&self, z: &[Complex64], x: &mut [f64]) {
        for (i, &h) in self.harmonics.iter().enumerate() {
            let s = self.slots[i];
            x[s] = z[i].re;
            if h != 0 {
                x[s + 1] = z[i].im;
            }
        }
    }

    /// Real unknowns into complex harmonics.
    pub fn unpack(&self, x: &[f64]) -> Vec<Complex64> {
        self.harmonics
            .iter()
            .zip(&self.slots)
            .map(|(&h, &s)| {
                if h == 0 {
                    Complex64::new(x[s], 0.0)
                } else {
                    Complex64::new(x[s], x[s + 1])
                }
            })
            .collect()
    }

    /// The fundamental `X_1` (the set always holds harmonic 1).
    pub fn fundamental(&self, x: &[f64]) -> Complex64 {
        let i = self.harmonics.iter().position(|&h| h == 1).unwrap_or(0);
        let s = self.slots[i];
        Complex64::new(x[s], x[s + 1])
    }
}

/// The AFT workspace: FFT plans, basis tables and buffers for one harmonic
/// set and one number of samples per period.
pub(crate) struct Aft {
    pub layout: Layout,
    samples: usize,
    /// The plans and tables every workspace of this harmonic set and
    /// sample count shares (read only).
    tables: Arc<Tables>,
    spectrum: Vec<Complex64>,
    scratch_r2c: Vec<Complex64>,
    scratch_c2r: Vec<Complex64>,
    /// Displacement, velocity and force samples.
    pub x: Vec<f64>,
    pub v: Vec<f64>,
    pub g: Vec<f64>,
    /// FFT input copy (realfft uses its input as scratch).
    buf: Vec<f64>,
    /// Per-sample scratch: `∂v/∂p` at the current ω, `∂g/∂p`.
    dv: Vec<f64>,
    dg_sample: Vec<f64>,
    /// `∂g_j/∂p_k`, sample-major (`n` per sample): each sample's
    /// sensitivities are written where they are computed, one contiguous
    /// row (column-major rows `N` apart put every write of a sample in the
    /// same cache set at `N` = 512).
    dg_rows: Vec<f64>,
    /// `dx/dθ` at the samples.
    xp: Vec<f64>,
    /// Turning points between samples, in sample order.
    extrema: Vec<Extremum>,
    /// For each sample interval `(θ_j, θ_{j+1})`, its extremum or `NONE`.
    extremum_at: Vec<usize>,
    /// `∂x/∂p`, `∂v/∂p` at an extremum.
    dx_extremum: Vec<f64>,
    dv_extremum: Vec<f64>,
    /// Whether this evaluation carries its sensitivities in structured form
    /// ([`SensitivityTerms`]) rather than as dense rows.
    structured: bool,
    /// Carry dense rows always (the reference the structured form is
    /// tested against).
    #[cfg(test)]
    dense_only: bool,
    terms: SensitivityTerms,
    /// The tangents `∂g/∂x`, `∂g/∂v` at the samples (structured form).
    tangent_x: Vec<f64>,
    tangent_v: Vec<f64>,
    tangent_spectrum: Vec<Complex64>,
    /// `S(q)`, `q = −2h_max..=2h_max`, of the tangent being projected.
    harmonic_sums: Vec<Complex64>,
}

/// The half period marched from sample `start` and its mirror half a
/// period on, `(j, j + N/2)` with both wrapping at `ns` samples: by
/// increments (a remainder per sample was most of the mirror's time).
fn mirror_pairs(start: usize, ns: usize) -> impl Iterator<Item = (usize, usize)> {
    let half = ns / 2;
    let wrap = move |i: usize| if i + 1 == ns { 0 } else { i + 1 };
    (0..half).scan((start % ns, (start + half) % ns), move |at, _| {
        let pair = *at;
        *at = (wrap(at.0), wrap(at.1));
        Some(pair)
    })
}

/// A displacement extremum between two samples: a turning point.
#[derive(Clone, Copy, Debug)]
struct Extremum {
    /// The sample interval it lies in.
    interval: usize,
    theta: f64,
    x: f64,
}

const NONE: usize = usize::MAX;

/// Which sample buffer a synthesis fills.
#[derive(Clone, Copy)]
enum Target {
    Displacement,
    Velocity,
    Slope,
}

/// What every AFT workspace of one harmonic set and sample count shares:
/// the FFT plans and the basis and analysis tables. Built once per process
/// (a fit builds a solver per series per model evaluation, and the tables'
/// `samples × n` sines and cosines cost as much as a few balanced points).
pub(crate) struct Tables {
    odd_only: bool,
    r2c: Arc<dyn RealToComplex<f64>>,
    c2r: Arc<dyn ComplexToReal<f64>>,
    /// `∂x_j/∂p_k`, sample-major (`n` per sample).
    basis_x: Vec<f64>,
    /// `∂v_j/∂p_k` per unit ω, sample-major.
    basis_v: Vec<f64>,
    /// The analysis rows `w_j` (`G = Σ_j w_j g_j`), sample-major.
    analysis: Vec<f64>,
    /// Each unknown's harmonic and unit `u` (its basis is `Re(u e^{ihθ})`).
    units: Vec<(usize, Complex64)>,
}

/// Harmonic sets and sample counts seen so far; few in any run (the cache is
/// emptied if a caller cycles through so many that their tables pass
/// [`TABLES_KEPT_BYTES`]).
type TableCache = std::collections::HashMap<(Vec<usize>, usize), Arc<Tables>>;
static TABLES: std::sync::Mutex<Option<TableCache>> = std::sync::Mutex::new(None);
const TABLES_KEPT_BYTES: usize = 64 << 20;

impl Tables {
    /// The shared tables of `layout` at `samples` per period.
    fn of(layout: &Layout, samples: usize) -> Arc<Tables> {
        let key = (layout.harmonics.clone(), samples);
        if let Some(t) = TABLES
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get_or_insert_with(Default::default)
            .get(&key)
        {
            return t.clone();
        }
        // built outside the lock (two threads may both build the same
        // tables: identical, one is kept)
        let t = Arc::new(Tables::new(layout, samples));
        let mut cache = TABLES.lock().unwrap_or_else(|e| e.into_inner());
        let cache = cache.get_or_insert_with(Default::default);
        let bytes: usize = cache.values().map(|t| t.bytes()).sum();
        if bytes + t.bytes() > TABLES_KEPT_BYTES {
            cache.clear();
        }
        cache.entry(key).or_insert(t).clone()
    }

    /// The tables' size (the plans aside).
    fn bytes(&self) -> usize {
        8 * (self.basis_x.len() + self.basis_v.len() + self.analysis.len())
    }

    fn new(layout: &Layout, samples: usize) -> Tables {
        let n = layout.len;
        let mut planner = RealFftPlanner::<f64>::new();
        let r2c = planner.plan_fft_forward(samples);
        let c2r = planner.plan_fft_inverse(samples);
        let mut basis_x = vec![0.0; samples * n];
        let mut basis_v = vec![0.0; samples * n];
        for j in 0..samples {
            let theta = 2.0 * PI * j as f64 / samples as f64;
            for (i, &h) in layout.harmonics.iter().enumerate() {
                let s = layout.slots[i];
                if h == 0 {
                    basis_x[j * n + s] = 1.0;
                } else {
                    let hf = h as f64;
                    let (sn, cs) = (hf * theta).sin_cos();
                    // x = Re(X e^{jhθ}): ∂/∂Re X = cos, ∂/∂Im X = −sin
                    basis_x[j * n + s] = cs;
                    basis_x[j * n + s + 1] = -sn;
                    // v = Re(jhω X e^{jhθ}): per unit ω, −h sin and −h cos
                    basis_v[j * n + s] = -hf * sn;
                    basis_v[j * n + s + 1] = -hf * cs;
                }
            }
        }
        let odd_only =
            samples.is_multiple_of(2) && layout.harmonics.iter().all(|h| !h.is_multiple_of(2));
        let mut units = Vec::with_capacity(n);
        let mut weight = vec![0.0; n];
        for (i, &h) in layout.harmonics.iter().enumerate() {
            let s = layout.slots[i];
            weight[s] = if h == 0 { 1.0 } else { 2.0 } / samples as f64;
            units.push((h, Complex64::new(1.0, 0.0)));
            if h != 0 {
                weight[s + 1] = weight[s];
                units.push((h, Complex64::new(0.0, 1.0)));
            }
        }
        // the analysis of `g` is the synthesis basis, scaled: `Re(u e^{ihθ})`
        // is cos for the real part and −sin for the imaginary
        let analysis = basis_x
            .chunks_exact(n)
            .flat_map(|row| row.iter().zip(&weight).map(|(b, w)| b * w))
            .collect();
        Tables {
            odd_only,
            r2c,
            c2r,
            basis_x,
            basis_v,
            analysis,
            units,
        }
    }
}

impl Aft {
    /// A workspace. `samples` must exceed twice the highest harmonic (checked
    /// by [`super::HbOptions::validate`]).
    pub fn new(harmonics: &[usize], samples: usize) -> Aft {
        let layout = Layout::new(harmonics);
        let n = layout.len;
        let tables = Tables::of(&layout, samples);
        let spectrum = tables.r2c.make_output_vec();
        let scratch_r2c = tables.r2c.make_scratch_vec();
        let scratch_c2r = tables.c2r.make_scratch_vec();
        Aft {
            layout,
            samples,
            tables,
            spectrum,
            scratch_r2c,
            scratch_c2r,
            x: vec![0.0; samples],
            v: vec![0.0; samples],
            g: vec![0.0; samples],
            buf: vec![0.0; samples],
            dv: vec![0.0; n],
            dg_sample: vec![0.0; n],
            dg_rows: vec![0.0; samples * n],
            xp: vec![0.0; samples],
            extrema: Vec::with_capacity(samples),
            extremum_at: vec![NONE; samples],
            dx_extremum: vec![0.0; n],
            dv_extremum: vec![0.0; n],
            structured: false,
            #[cfg(test)]
            dense_only: false,
            terms: SensitivityTerms::default(),
            tangent_x: vec![0.0; samples],
            tangent_v: vec![0.0; samples],
            tangent_spectrum: vec![Complex64::new(0.0, 0.0); samples / 2 + 1],
            harmonic_sums: Vec::with_capacity(4 * harmonics.last().copied().unwrap_or(0) + 1),
        }
    }

    /// Inverse transform of the unknowns into a sample buffer: `x`, `v` at
    /// `omega`, or `dx/dθ`.
    fn synthesize(&mut self, xs: &[f64], omega: f64, target: Target) {
        self.spectrum.fill(Complex64::new(0.0, 0.0));
        let factor = match target {
            Target::Displacement => None,
            Target::Velocity => Some(omega),
            Target::Slope => Some(1.0),
        };
        for (i, &h) in self.layout.harmonics.iter().enumerate() {
            let s = self.layout.slots[i];
            if h == 0 {
                if factor.is_none() {
                    self.spectrum[0] = Complex64::new(xs[s], 0.0);
                }
            } else {
                let z = Complex64::new(0.5 * xs[s], 0.5 * xs[s + 1]);
                self.spectrum[h] = match factor {
                    None => z,
                    Some(w) => z * Complex64::new(0.0, h as f64 * w),
                };
            }
        }
        let out = match target {
            Target::Displacement => &mut self.x,
            Target::Velocity => &mut self.v,
            Target::Slope => &mut self.xp,
        };
        // lengths and the zero imaginary DC/Nyquist parts hold by construction
        self.tables
            .c2r
            .process_with_scratch(&mut self.spectrum, out, &mut self.scratch_c2r)
            .expect("inverse real FFT on buffers of the planned length");
    }

    /// `x(θ)`, `x'(θ)`, `x''(θ)` by direct sums.
    fn at_phase(&self, xs: &[f64], theta: f64) -> (f64, f64, f64) {
        let (mut x, mut d1, mut d2) = (0.0, 0.0, 0.0);
        // `e^{jhθ}` by powers of `e^{jθ}` (one `sin_cos`; the harmonics
        // increase): rounding grows as `h ε`, far below the tolerances here
        let step = Complex64::from_polar(1.0, theta);
        let (mut power, mut at) = (Complex64::new(1.0, 0.0), 0);
        for (i, &h) in self.layout.harmonics.iter().enumerate() {
            let s = self.layout.slots[i];
            if h == 0 {
                x += xs[s];
            } else {
                let hf = h as f64;
                while at < h {
                    power *= step;
                    at += 1;
                }
                let (sn, cs) = (power.im, power.re);
                // Re and Im of X e^{jhθ}
                let c = xs[s] * cs - xs[s + 1] * sn;
                let d = xs[s] * sn + xs[s + 1] * cs;
                x += c;
                d1 -= hf * d;
                d2 -= hf * hf * c;
            }
        }
        (x, d1, d2)
    }

    /// Locates every turning point of `x(θ)` between samples (a sign change
    /// of `dx/dθ`), refined by safeguarded Newton on `dx/dθ = 0`.
    ///
    /// Why: a hysteresis element reverses where `x` does. Reversing at the
    /// sample nearest the true extremum cuts the loop tip short by
    /// `≈ a(π/N)²/2` and costs ~1e-4 in `H_1` at 256 samples; committing the
    /// true extremum too (its force is not sampled) leaves only the
    /// quadrature error of the sampled forces.
    fn find_extrema(&mut self, xs: &[f64]) {
        let ns = self.samples;
        self.synthesize(xs, 1.0, Target::Slope);
        self.extrema.clear();
        self.extremum_at.fill(NONE);
        let step = 2.0 * PI / ns as f64;
        for j in 0..ns {
            let a = self.xp[j];
            let b = self.xp[if j + 1 == ns { 0 } else { j + 1 }];
            if a * b >= 0.0 {
                continue;
            }
            let (mut lo, mut hi) = (j as f64 * step, (j + 1) as f64 * step);
            let mut t = lo + step * a / (a - b);
            for _ in 0..12 {
                let (_, d1, d2) = self.at_phase(xs, t);
                if d1 == 0.0 {
                    break;
                }
                let newton_step = d1 / d2;
                if newton_step.abs() <= 1e-14 * (1.0 + t) {
                    t -= newton_step;
                    break;
                }
                if (d1 > 0.0) == (a > 0.0) {
                    lo = t;
                } else {
                    hi = t;
                }
                let newton = t - newton_step;
                t = if newton > lo && newton < hi {
                    newton
                } else {
                    0.5 * (lo + hi)
                };
            }
            self.extremum_at[j] = self.extrema.len();
            self.extrema.push(Extremum {
                interval: j,
                theta: t,
                x: self.at_phase(xs, t).0,
            });
        }
    }

    /// Forward transform of `buf` into harmonic rows of `out` (`n` reals,
    /// stride `stride`, column offset `col`).
    fn analyse_buf(&mut self, out: &mut [f64], stride: usize, col: usize) {
        self.tables
            .r2c
            .process_with_scratch(&mut self.buf, &mut self.spectrum, &mut self.scratch_r2c)
            .expect("forward real FFT on buffers of the planned length");
        let inv = 1.0 / self.samples as f64;
        for (i, &h) in self.layout.harmonics.iter().enumerate() {
            let s = self.layout.slots[i];
            if h == 0 {
                out[s * stride + col] = self.spectrum[0].re * inv;
            } else {
                out[s * stride + col] = 2.0 * inv * self.spectrum[h].re;
                out[(s + 1) * stride + col] = 2.0 * inv * self.spectrum[h].im;
            }
        }
    }

    /// The element-force harmonics `G` (real layout) for unknowns `xs` at
    /// `omega`, and `∂G/∂X` (row-major, `n × n`) when `dg` is given.
    ///
    /// `odd_law`: the caller vouches that the element law is odd (`g(−x,
    /// −v) = −g(x, v)` with mirrored history, as for Masing-type loops). With
    /// odd harmonics only, `x(θ + π) = −x(θ)`, so the periodic force obeys
    /// `g(θ + π) = −g(θ)`: half a period is marched (from the loop tip to
    /// the opposite tip, where the Masing rules close the loop) and mirrored.
    /// Not with [`PeriodicLoop::TwoPeriods`], which stays the plain check.
    ///
    /// Errors (with the reason) when an element force is not finite.
    #[allow(clippy::too_many_arguments)]
    pub fn evaluate<E: Element>(
        &mut self,
        xs: &[f64],
        omega: f64,
        elements: &mut E,
        method: PeriodicLoop,
        odd_law: bool,
        g_out: &mut [f64],
        dg: Option<&mut [f64]>,
    ) -> Result<(), EvalError> {
        let n = self.layout.len;
        let ns = self.samples;
        self.synthesize(xs, omega, Target::Displacement);
        let velocity = elements.uses_velocity();
        if velocity {
            self.synthesize(xs, omega, Target::Velocity);
        } else {
            self.v.fill(0.0);
        }
        let memory = elements.has_memory();
        if memory {
            self.find_extrema(xs);
        }
        let want = dg.is_some();
        if want && !velocity {
            self.dv.fill(0.0);
            self.dv_extremum.fill(0.0);
        }
        // the march: an optional virgin ramp (to a sample or to the largest
        // turning point), then `count` samples from `first`, with the
        // turning points between them
        let mut ramp_sample = None;
        let mut ramp_extremum = None;
        // a law whose memory fades gradually is marched period after period
        // (half period after half period when the loop's half-wave symmetry
        // holds) until its memory repeats, with a Newton step on the period
        // map after each (`Element::close_period`)
        let settle = if memory {
            elements.periods_to_settle()
        } else {
            0
        };
        let mut half =
            odd_law && self.tables.odd_only && !(memory && method == PeriodicLoop::TwoPeriods);
        let (first, count) = if !memory {
            (0, if half { ns / 2 } else { ns })
        } else {
            match method {
                PeriodicLoop::MaxAmplitude => {
                    if self.extrema.is_empty() {
                        let mut js = 0;
                        for j in 1..ns {
                            if self.x[j].abs() > self.x[js].abs() {
                                js = j;
                            }
                        }
                        ramp_sample = Some(js);
                        (js + 1, ns)
                    } else {
                        let mut e = 0;
                        for (i, ex) in self.extrema.iter().enumerate() {
                            if ex.x.abs() > self.extrema[e].x.abs() {
                                e = i;
                            }
                        }
                        ramp_extremum = Some(e);
                        (self.extrema[e].interval + 1, ns)
                    }
                }
                PeriodicLoop::TwoPeriods => (0, 2 * ns),
            }
        };
        // a settling law's half period must end on the mirrored turning
        // point, where the mirrored memory is compared with the first
        if half && settle > 0 {
            let tip = ramp_extremum.map(|e| self.extrema[e].interval);
            half = tip.is_some_and(|i| self.extremum_at[(i + ns / 2) % ns] != NONE);
        }
        let count = if half && memory { ns / 2 } else { count };
        // the structured form needs each kept sample committed once
        #[cfg(test)]
        let want_structured = want && !self.dense_only;
        #[cfg(not(test))]
        let want_structured = want;
        self.structured = want_structured
            && settle == 0
            && !(memory && method == PeriodicLoop::TwoPeriods)
            && match elements.memory_terms() {
                Some(slots) => {
                    self.terms.start(n, slots);
                    true
                }
                None => false,
            };
        elements.reset();
        if let Some(j) = ramp_sample {
            self.commit_sample(elements, j, omega, velocity, want, false);
        }
        if let Some(e) = ramp_extremum {
            self.commit_extremum(elements, e, omega, velocity, want);
            // a settling law's memory starts on the loop its half cycles
            // would close if monotone: often periodic from the first pass
            if half && settle > 0 {
                elements.start_symmetric_loop(self.extrema[e].x);
            }
        }
        // where the last pass started (a half pass alternates halves)
        let mut start = first;
        let mut last_residual = f64::INFINITY;
        for pass in 0..=settle {
            start = (first + pass * count) % ns;
            if settle > 0 {
                elements.open_period();
            }
            self.march(
                elements,
                start,
                count,
                memory,
                settle > 0,
                omega,
                velocity,
                want,
            );
            if settle > 0 {
                let residual = elements.close_period(half);
                // the pass's samples: every sample, or a stretch that wraps
                // at most once; a maximum does not depend on the order
                let (head, tail) = if count >= ns {
                    (&self.g[..], &self.g[..0])
                } else if start + count <= ns {
                    (&self.g[start..start + count], &self.g[..0])
                } else {
                    (&self.g[start..], &self.g[..start + count - ns])
                };
                let scale = head.iter().chain(tail).fold(0.0f64, |m, g| m.max(g.abs()));
                // a law run away: its non-finite force is reported below
                let stalled = residual > 0.5 * last_residual;
                if residual <= SETTLED * scale
                    || (stalled && residual <= SETTLED_AT_ROUNDING * scale)
                    || !residual.is_finite()
                {
                    break;
                }
                last_residual = residual;
                if pass == settle {
                    return Err(EvalError::NotSettled {
                        periods: settle,
                        change: residual / scale.max(f64::MIN_POSITIVE),
                    });
                }
            }
        }
        if half {
            for (j, jm) in mirror_pairs(start, ns) {
                self.g[jm] = -self.g[j];
                if self.structured {
                    self.tangent_x[jm] = self.tangent_x[j];
                    self.tangent_v[jm] = self.tangent_v[j];
                } else if want {
                    self.dg_rows.copy_within(j * n..(j + 1) * n, jm * n);
                    self.dg_rows[jm * n..(jm + 1) * n]
                        .iter_mut()
                        .for_each(|d| *d = -*d);
                }
            }
        }
        if let Some(j) = self.g.iter().position(|g| !g.is_finite()) {
            return Err(EvalError::ElementForce {
                sample: j,
                samples: ns,
                x: self.x[j],
                v: self.v[j],
            });
        }
        self.buf.copy_from_slice(&self.g);
        self.analyse_buf(g_out, 1, 0);
        if let Some(dg) = dg {
            if self.structured {
                // the mirrored half's memory terms project as the marched
                // half's (odd harmonics: `w_{j+N/2} = −w_j`, `∂g` mirrored)
                self.project_structured(omega, velocity, if half { 2.0 } else { 1.0 }, dg);
                return Ok(());
            }
            for k in 0..n {
                for (b, row) in self.buf.iter_mut().zip(self.dg_rows.chunks_exact(n)) {
                    *b = row[k];
                }
                self.analyse_buf(dg, n, k);
            }
        }
        Ok(())
    }

    /// The march: `count` samples from `start`, each followed by the
    /// turning point after it, if any. With sensitivities sample by sample;
    /// without, in runs that end at a turning point or at the period's wrap,
    /// each run one [`Element::commit_run`].
    #[allow(clippy::too_many_arguments)]
    fn march<E: Element>(
        &mut self,
        elements: &mut E,
        start: usize,
        count: usize,
        memory: bool,
        periods_follow: bool,
        omega: f64,
        velocity: bool,
        sensitivities: bool,
    ) {
        let ns = self.samples;
        if sensitivities {
            let mut j = start;
            for s in 0..count {
                self.commit_sample(elements, j, omega, velocity, true, true);
                // a turning point after the last sample changes nothing
                // stored (with the ramp, it is the ramp's own point closing
                // the loop); when periods follow, the one closing the period
                // counts
                if memory && (s + 1 < count || periods_follow) {
                    let e = self.extremum_at[j];
                    if e != NONE {
                        self.commit_extremum(elements, e, omega, velocity, true);
                    }
                }
                j = if j + 1 == ns { 0 } else { j + 1 };
            }
            return;
        }
        let (mut done, mut j) = (0, start);
        while done < count {
            let mut end = j;
            loop {
                end += 1;
                let last = end - 1;
                if done + (end - j) == count
                    || end == ns
                    || (memory && self.extremum_at[last] != NONE)
                {
                    break;
                }
            }
            self.g[j..end].fill(0.0);
            elements.commit_run(&self.x[j..end], &self.v[j..end], &mut self.g[j..end]);
            done += end - j;
            // as above
            let e = self.extremum_at[end - 1];
            if memory && e != NONE && (done < count || periods_follow) {
                self.commit_extremum(elements, e, omega, velocity, false);
            }
            j = if end == ns { 0 } else { end };
        }
    }

    /// Commits sample `j` (storing its force and sensitivities if `store`).
    #[inline]
    fn commit_sample<E: Element>(
        &mut self,
        elements: &mut E,
        j: usize,
        omega: f64,
        velocity: bool,
        sensitivity: bool,
        store: bool,
    ) {
        let n = self.layout.len;
        if !sensitivity {
            let f = elements.commit(self.x[j], self.v[j]).force;
            if store {
                self.g[j] = f;
            }
            return;
        }
        if velocity {
            for (d, &b) in self
                .dv
                .iter_mut()
                .zip(&self.tables.basis_v[j * n..(j + 1) * n])
            {
                *d = omega * b;
            }
        }
        if self.structured {
            let f = elements.commit_sensitivity_terms(
                self.x[j],
                self.v[j],
                &self.tables.basis_x[j * n..(j + 1) * n],
                &self.dv,
                &mut self.terms,
            );
            let w = store.then(|| &self.tables.analysis[j * n..(j + 1) * n]);
            let (k, c) = self.terms.end_sample(w);
            if store {
                self.g[j] = f.force;
                self.tangent_x[j] = k;
                self.tangent_v[j] = c;
            }
            return;
        }
        let dg = if store {
            &mut self.dg_rows[j * n..(j + 1) * n]
        } else {
            &mut self.dg_sample[..]
        };
        dg.fill(0.0);
        let f = elements.commit_sensitivity(
            self.x[j],
            self.v[j],
            &self.tables.basis_x[j * n..(j + 1) * n],
            &self.dv,
            dg,
        );
        if store {
            self.g[j] = f.force;
        }
    }

    /// Commits turning point `e` (`v = 0` there). Its sensitivity is the
    /// basis at `θ*`: `x'(θ*) = 0`, so the shift of `θ*` does not count.
    fn commit_extremum<E: Element>(
        &mut self,
        elements: &mut E,
        e: usize,
        omega: f64,
        velocity: bool,
        sensitivity: bool,
    ) {
        let Extremum { theta, x, .. } = self.extrema[e];
        if !sensitivity {
            elements.commit(x, 0.0);
            return;
        }
        for (i, &h) in self.layout.harmonics.iter().enumerate() {
            let s = self.layout.slots[i];
            if h == 0 {
                self.dx_extremum[s] = 1.0;
            } else {
                let hf = h as f64;
                let (sn, cs) = (hf * theta).sin_cos();
                self.dx_extremum[s] = cs;
                self.dx_extremum[s + 1] = -sn;
                if velocity {
                    self.dv_extremum[s] = -omega * hf * sn;
                    self.dv_extremum[s + 1] = -omega * hf * cs;
                }
            }
        }
        if self.structured {
            elements.commit_sensitivity_terms(
                x,
                0.0,
                &self.dx_extremum,
                &self.dv_extremum,
                &mut self.terms,
            );
            self.terms.end_sample(None);
            return;
        }
        self.dg_sample.fill(0.0);
        elements.commit_sensitivity(
            x,
            0.0,
            &self.dx_extremum,
            &self.dv_extremum,
            &mut self.dg_sample,
        );
    }

    /// `∂G/∂X` from the structured sensitivities: the tangents' part
    /// `Σ_j k_j w_j ⊗ b_j` from one FFT of `k` (with `w`, `b` of the form
    /// `Re(u e^{ihθ})`, `Re A Re B = ½ Re(AB + AB̄)`, so each entry is a
    /// harmonic `a ± b` of `k`), the same for `c` and the velocity basis,
    /// and the memory terms' projection (`memory_scale` times it).
    fn project_structured(
        &mut self,
        omega: f64,
        velocity: bool,
        memory_scale: f64,
        dg: &mut [f64],
    ) {
        let n = self.layout.len;
        let ns = self.samples;
        dg.fill(0.0);
        self.terms.finish(memory_scale, dg);
        let parts: &[(bool, f64)] = if velocity {
            &[(false, 0.0), (true, omega)]
        } else {
            &[(false, 0.0)]
        };
        for &(of_velocity, omega) in parts {
            let tangent = if of_velocity {
                &self.tangent_v
            } else {
                &self.tangent_x
            };
            if tangent.iter().all(|&t| t == 0.0) {
                continue;
            }
            self.buf.copy_from_slice(tangent);
            self.tables
                .r2c
                .process_with_scratch(
                    &mut self.buf,
                    &mut self.tangent_spectrum,
                    &mut self.scratch_r2c,
                )
                .expect("forward real FFT on buffers of the planned length");
            // `S(q) = Σ_j k_j e^{iqθ_j}` for `|q| ≤ 2 h_max` from the
            // spectrum `Σ_j k_j e^{−iqθ_j}` (periodic in `q` over `N`)
            let top = 2 * self.tables.units.last().map_or(0, |u| u.0) as i64;
            self.harmonic_sums.clear();
            for q in -top..=top {
                let m = q.rem_euclid(ns as i64) as usize;
                self.harmonic_sums.push(if m <= ns / 2 {
                    self.tangent_spectrum[m].conj()
                } else {
                    self.tangent_spectrum[ns - m]
                });
            }
            let sums = &self.harmonic_sums;
            let s_at = |q: i64| sums[(q + top) as usize];
            for (r, &(a, v)) in self.tables.units.iter().enumerate() {
                let scale = if a == 0 { 1.0 } else { 2.0 } / ns as f64;
                for (t, &(b, u)) in self.tables.units.iter().enumerate() {
                    // the velocity basis: `∂v/∂p = Re(u jbω e^{ibθ})`
                    let u = if of_velocity {
                        u * Complex64::new(0.0, b as f64 * omega)
                    } else {
                        u
                    };
                    let (a, b) = (a as i64, b as i64);
                    let z = v * u * s_at(a + b) + v * u.conj() * s_at(a - b);
                    dg[r * n + t] += scale * 0.5 * z.re;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod timing;
