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
mod tests {
    use super::*;
    use crate::model::{ElementKind, ElementSet, ElementSpec};

    /// A naive reference: direct sums for synthesis and analysis, the
    /// element marched the same way.
    fn naive_g<E: Element>(
        harmonics: &[usize],
        xs: &[f64],
        ns: usize,
        omega: f64,
        e: &mut E,
    ) -> Vec<f64> {
        let lay = Layout::new(harmonics);
        let z = lay.unpack(xs);
        let mut x = vec![0.0; ns];
        let mut v = vec![0.0; ns];
        for j in 0..ns {
            let th = 2.0 * PI * j as f64 / ns as f64;
            for (i, &h) in harmonics.iter().enumerate() {
                let e = Complex64::from_polar(1.0, h as f64 * th);
                x[j] += (z[i] * e).re;
                v[j] += (z[i] * e * Complex64::new(0.0, h as f64 * omega)).re;
            }
        }
        // turning points between samples, by bisection on the slope
        let slope = |th: f64| -> f64 {
            harmonics
                .iter()
                .enumerate()
                .map(|(i, &h)| {
                    (z[i]
                        * Complex64::new(0.0, h as f64)
                        * Complex64::from_polar(1.0, h as f64 * th))
                    .re
                })
                .sum()
        };
        let value = |th: f64| -> f64 {
            harmonics
                .iter()
                .enumerate()
                .map(|(i, &h)| (z[i] * Complex64::from_polar(1.0, h as f64 * th)).re)
                .sum()
        };
        let dt = 2.0 * PI / ns as f64;
        let mut turning = vec![None; ns];
        for (j, t) in turning.iter_mut().enumerate() {
            let (mut lo, mut hi) = (j as f64 * dt, (j + 1) as f64 * dt);
            let (a, b) = (slope(lo), slope(hi));
            if a * b < 0.0 {
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if (slope(mid) > 0.0) == (a > 0.0) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                *t = Some(value(0.5 * (lo + hi)));
            }
        }
        // two periods from virgin, keep the second; a gradually settling
        // law: periods until the force repeats to rounding (plain
        // repetition, no Newton step)
        e.reset();
        let mut g = vec![0.0; ns];
        let passes = if e.periods_to_settle() > 0 { 5000 } else { 2 };
        for pass in 0..passes {
            let mut change = 0.0f64;
            for j in 0..ns {
                let f = e.commit(x[j], v[j]).force;
                if pass > 0 {
                    change = change.max((g[j] - f).abs());
                }
                g[j] = f;
                if let (true, Some(xt)) = (e.has_memory(), turning[j]) {
                    e.commit(xt, 0.0);
                }
            }
            if pass > 0 && change <= 1e-14 * g.iter().fold(0.0f64, |m, x| m.max(x.abs())) {
                break;
            }
        }
        let mut out = vec![0.0; lay.len];
        for (i, &h) in harmonics.iter().enumerate() {
            let mut acc = Complex64::new(0.0, 0.0);
            for (j, gj) in g.iter().enumerate() {
                acc +=
                    gj * Complex64::from_polar(1.0, -(h as f64) * 2.0 * PI * j as f64 / ns as f64);
            }
            let s = lay.slots[i];
            if h == 0 {
                out[s] = acc.re / ns as f64;
            } else {
                out[s] = 2.0 * acc.re / ns as f64;
                out[s + 1] = 2.0 * acc.im / ns as f64;
            }
        }
        out
    }

    /// Every registered law at its description's example, and the Masing
    /// element at a soft curvature too.
    fn all_specs() -> Vec<ElementSpec> {
        let mut specs: Vec<ElementSpec> = ElementKind::ALL
            .iter()
            .map(|&k| ElementSpec::from_values(k, k.description().example))
            .collect();
        specs.push(ElementSpec::Masing {
            kd: 2.4e7,
            fd: 246.048,
            n: 3.0,
        });
        specs
    }

    /// A response with DC, even and odd harmonics, inner loops.
    fn test_x(lay: &Layout) -> Vec<f64> {
        let mut xs = vec![0.0; lay.len];
        for (k, x) in xs.iter_mut().enumerate() {
            *x = 1e-5 * ((k as f64 * 1.7).sin() + 0.3) / (1.0 + k as f64);
        }
        xs
    }

    /// The structured projection of the sensitivities (tangents by one FFT,
    /// memory terms by weighted sums) equals the dense one (every column
    /// transformed) for every element, a set mixing memory and memoryless
    /// laws, both periodic-loop methods, and the half-wave march.
    #[test]
    fn structured_jacobian_equals_the_dense_one() {
        let omega = 2.0 * PI * 200.0;
        let mut sets: Vec<(String, ElementSet<crate::model::AnyElement>)> = all_specs()
            .into_iter()
            .map(|spec| {
                (
                    format!("{spec:?}"),
                    ElementSet::new(vec![spec.build().unwrap()]),
                )
            })
            .collect();
        let mixed = [
            ElementSpec::Jenkins {
                kd: 2.4e7,
                fd: 246.048,
            },
            ElementSpec::Masing {
                kd: 1.2e7,
                fd: 120.0,
                n: 3.0,
            },
            ElementSpec::from_values(
                ElementKind::CubicStiffness,
                ElementKind::CubicStiffness.description().example,
            ),
            ElementSpec::from_values(
                ElementKind::ViscousDamping,
                ElementKind::ViscousDamping.description().example,
            ),
        ];
        sets.push((
            "Jenkins + Masing + cubic + viscous".into(),
            ElementSet::new(mixed.iter().map(|s| s.build().unwrap()).collect()),
        ));
        for (harmonics, ns, odd) in [
            (&[0, 1, 2, 3, 5][..], 128, false),
            (&[1, 3, 5, 7][..], 128, true),
        ] {
            let mut aft = Aft::new(harmonics, ns);
            let n = aft.layout.len;
            let xs = test_x(&aft.layout);
            for (name, e) in &mut sets {
                let odd = odd && e.odd_law();
                for method in [PeriodicLoop::MaxAmplitude, PeriodicLoop::TwoPeriods] {
                    let (mut g, mut dg) = (vec![0.0; n], vec![0.0; n * n]);
                    aft.dense_only = false;
                    aft.evaluate(&xs, omega, e, method, odd, &mut g, Some(&mut dg))
                        .unwrap();
                    // every law but a gradually settling one takes the
                    // structured form in the usual march
                    if method == PeriodicLoop::MaxAmplitude && e.periods_to_settle() == 0 {
                        assert!(aft.structured, "{name}: dense");
                    }
                    let (mut g_dense, mut dg_dense) = (vec![0.0; n], vec![0.0; n * n]);
                    aft.dense_only = true;
                    aft.evaluate(
                        &xs,
                        omega,
                        e,
                        method,
                        odd,
                        &mut g_dense,
                        Some(&mut dg_dense),
                    )
                    .unwrap();
                    assert_eq!(g, g_dense, "{name}: the forces differ");
                    let scale = dg_dense.iter().fold(0.0f64, |m, d| m.max(d.abs()));
                    for (i, (a, b)) in dg.iter().zip(&dg_dense).enumerate() {
                        assert!(
                            (a - b).abs() <= 1e-12 * scale,
                            "{name} {method:?} odd {odd} ∂G[{}]/∂X[{}]: {a} vs {b}",
                            i / n,
                            i % n
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn fft_aft_equals_the_naive_direct_sums_for_every_element() {
        let harmonics = [0, 1, 2, 3, 5];
        let ns = 64;
        let omega = 2.0 * PI * 200.0;
        let mut aft = Aft::new(&harmonics, ns);
        let xs = test_x(&aft.layout);
        for spec in all_specs() {
            let mut e = spec.build().unwrap();
            let mut g = vec![0.0; aft.layout.len];
            for method in [PeriodicLoop::MaxAmplitude, PeriodicLoop::TwoPeriods] {
                aft.evaluate(&xs, omega, &mut e, method, false, &mut g, None)
                    .unwrap();
                let reference = naive_g(&harmonics, &xs, ns, omega, &mut e);
                for (a, b) in g.iter().zip(&reference) {
                    let scale = reference.iter().fold(0.0f64, |m, r| m.max(r.abs()));
                    assert!(
                        (a - b).abs() <= 1e-12 * scale,
                        "{spec:?} {method:?}: {a} vs {b}"
                    );
                }
            }
        }
    }

    /// `commit_sensitivity` through the whole march (every element, the
    /// turning-point histories included) equals central differences of the
    /// AFT force harmonics.
    #[test]
    fn analytic_jacobian_equals_finite_differences_for_every_element() {
        let harmonics = [0, 1, 2, 3, 5];
        let ns = 128;
        let omega = 2.0 * PI * 200.0;
        let mut aft = Aft::new(&harmonics, ns);
        let n = aft.layout.len;
        let xs = test_x(&aft.layout);
        for spec in all_specs() {
            for method in [PeriodicLoop::MaxAmplitude, PeriodicLoop::TwoPeriods] {
                let mut e = ElementSet::new(vec![spec.build().unwrap()]);
                let mut g = vec![0.0; n];
                let mut dg = vec![0.0; n * n];
                aft.evaluate(&xs, omega, &mut e, method, false, &mut g, Some(&mut dg))
                    .unwrap();
                let mut g_plain = vec![0.0; n];
                aft.evaluate(&xs, omega, &mut e, method, false, &mut g_plain, None)
                    .unwrap();
                assert_eq!(
                    g, g_plain,
                    "{spec:?}: the sensitivity march changed the forces"
                );
                let scale = dg.iter().fold(0.0f64, |m, d| m.max(d.abs()));
                for k in 0..n {
                    // a step far below the samples' spacing from any kink,
                    // large enough for round-off (forces ~1e2 N, x ~1e-5 m):
                    // the differences agree to ~2e-8 of the largest entry
                    let step = 1e-13;
                    let mut xp = xs.clone();
                    xp[k] += step;
                    let mut gp = vec![0.0; n];
                    aft.evaluate(&xp, omega, &mut e, method, false, &mut gp, None)
                        .unwrap();
                    let mut xm = xs.clone();
                    xm[k] -= step;
                    let mut gm = vec![0.0; n];
                    aft.evaluate(&xm, omega, &mut e, method, false, &mut gm, None)
                        .unwrap();
                    for r in 0..n {
                        let fd = (gp[r] - gm[r]) / (2.0 * step);
                        assert!(
                            (fd - dg[r * n + k]).abs() <= 1e-6 * scale,
                            "{spec:?} {method:?} ∂G[{r}]/∂X[{k}]: fd {fd} vs {}",
                            dg[r * n + k]
                        );
                    }
                }
            }
        }
    }

    /// Half a period mirrored equals the whole period, forces and
    /// Jacobian, for every odd element (odd harmonics, inner loops).
    #[test]
    fn half_wave_march_equals_the_full_period() {
        let harmonics = [1, 3, 5, 7];
        let ns = 128;
        let omega = 2.0 * PI * 200.0;
        let mut aft = Aft::new(&harmonics, ns);
        let n = aft.layout.len;
        let xs = test_x(&aft.layout);
        for spec in all_specs() {
            if matches!(spec, ElementSpec::BilinearStiffness { .. }) {
                continue;
            }
            let mut e = spec.build().unwrap();
            let (mut g1, mut d1) = (vec![0.0; n], vec![0.0; n * n]);
            let (mut g2, mut d2) = (vec![0.0; n], vec![0.0; n * n]);
            let m = PeriodicLoop::MaxAmplitude;
            aft.evaluate(&xs, omega, &mut e, m, false, &mut g1, Some(&mut d1))
                .unwrap();
            aft.evaluate(&xs, omega, &mut e, m, true, &mut g2, Some(&mut d2))
                .unwrap();
            let gs = g1.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let ds = d1.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            for (a, b) in g1.iter().zip(&g2) {
                assert!((a - b).abs() <= 1e-12 * gs, "{spec:?}: {a} vs {b}");
            }
            // a settling law's sensitivities are carried from the Newton
            // step on the period map before the kept period, which used that
            // step's own march: consistent to ~4e-8 (the half march starts
            // on the symmetric loop, which inner loops move it off by a
            // little, the whole one from the virgin ramp), far inside what
            // Newton's iteration needs (the forces agree to rounding)
            let tol = if e.periods_to_settle() > 0 {
                1e-7
            } else {
                1e-10
            };
            for (a, b) in d1.iter().zip(&d2) {
                assert!((a - b).abs() <= tol * ds, "{spec:?}: {a} vs {b}");
            }
        }
    }

    /// A Bouc-Wen loop far below its saturation force is nearly elastic:
    /// a half period leaves almost all of its memory (`g` within 1e-6 of
    /// 1, where a whole period's Newton step is not taken). The half-period
    /// march still settles, and the force is `α x` to the loop's relative
    /// size, ~`β (γ + δ) |z|/α` = 1e-7.
    #[test]
    fn a_nearly_elastic_bouc_wen_loop_settles_by_half_periods() {
        let harmonics = [1, 3, 5];
        let ns = 256;
        let mut aft = Aft::new(&harmonics, ns);
        let n = aft.layout.len;
        let (alpha, beta) = (2.4e7, 1e5);
        let mut e = ElementSpec::BoucWen {
            alpha,
            beta,
            gamma: 0.5,
            delta: 0.5,
            nu: 1.0,
        }
        .build()
        .unwrap();
        // 1e-7 of the saturation force's displacement α/(β α) = 1e-5 m
        let mut xs = vec![0.0; n];
        xs[0] = 1e-12;
        xs[2] = 2e-13;
        let mut g = vec![0.0; n];
        let mut dg = vec![0.0; n * n];
        aft.evaluate(
            &xs,
            1000.0,
            &mut e,
            PeriodicLoop::MaxAmplitude,
            true,
            &mut g,
            Some(&mut dg),
        )
        .unwrap();
        for k in 0..n {
            assert!(
                (g[k] - alpha * xs[k]).abs() <= 1e-6 * alpha * xs[0],
                "G[{k}] = {} vs α X = {}",
                g[k],
                alpha * xs[k]
            );
        }
    }

    /// A Masing joint (N = 5) balanced by `aft` at `xs` (ω = 1, odd law,
    /// with its Jacobian), the outputs filled with `init` beforehand.
    fn masing_evaluated(aft: &mut Aft, xs: &[f64], init: f64) -> (Vec<f64>, Vec<f64>) {
        let mut e = ElementSpec::Masing {
            kd: 2.4e7,
            fd: 246.048,
            n: 5.0,
        }
        .build()
        .unwrap();
        let n = aft.layout.len;
        let (mut g, mut d) = (vec![init; n], vec![init; n * n]);
        aft.evaluate(
            xs,
            1.0,
            &mut e,
            PeriodicLoop::MaxAmplitude,
            true,
            &mut g,
            Some(&mut d),
        )
        .unwrap();
        (g, d)
    }

    #[test]
    fn workspace_results_do_not_depend_on_dirty_buffers() {
        let mut aft = Aft::new(&[1, 3, 5], 32);
        let xs = test_x(&aft.layout);
        let first = masing_evaluated(&mut aft, &xs, 0.0);
        for b in [
            &mut aft.x,
            &mut aft.v,
            &mut aft.g,
            &mut aft.buf,
            &mut aft.dg_rows,
            &mut aft.dv,
        ] {
            b.fill(f64::NAN);
        }
        aft.spectrum.fill(Complex64::new(f64::NAN, f64::NAN));
        assert_eq!(first, masing_evaluated(&mut aft, &xs, f64::NAN));
    }

    /// Workspaces of one harmonic set and sample count share one set of
    /// tables, built once and never written: a workspace made after another
    /// has evaluated gives the same bits, and the shared tables are those
    /// built afresh.
    #[test]
    fn workspaces_share_tables_that_evaluations_leave_as_built() {
        let harmonics = [1, 3, 5, 7];
        let mut first = Aft::new(&harmonics, 48);
        let xs = test_x(&first.layout);
        let a = masing_evaluated(&mut first, &xs, 0.0);
        let mut second = Aft::new(&harmonics, 48);
        assert!(Arc::ptr_eq(&first.tables, &second.tables));
        assert!(!Arc::ptr_eq(
            &first.tables,
            &Aft::new(&harmonics, 64).tables
        ));
        assert!(!Arc::ptr_eq(&first.tables, &Aft::new(&[1, 3], 48).tables));
        assert_eq!(a, masing_evaluated(&mut second, &xs, f64::NAN));
        let fresh = Tables::new(&first.layout, 48);
        let shared = &second.tables;
        assert_eq!(fresh.basis_x, shared.basis_x);
        assert_eq!(fresh.basis_v, shared.basis_v);
        assert_eq!(fresh.analysis, shared.analysis);
        assert_eq!(fresh.units, shared.units);
        assert_eq!(fresh.odd_only, shared.odd_only);
    }
}

#[cfg(test)]
mod timing {
    use super::*;
    use crate::model::ElementSpec;

    /// Cost of one evaluation (run with `--ignored --nocapture`).
    #[test]
    #[ignore]
    fn aft_evaluation_cost() {
        let harmonics = [1, 3, 5];
        let mut aft = Aft::new(&harmonics, 256);
        let n = aft.layout.len;
        let xs = [2e-5, 1e-5, 3e-7, -2e-7, 1e-8, 5e-9];
        let mut e = ElementSpec::Masing {
            kd: 2.4e7,
            fd: 246.048,
            n: 22.55,
        }
        .build()
        .unwrap();
        let (mut g, mut dg) = (vec![0.0; n], vec![0.0; n * n]);
        for (half, jac) in [(false, false), (false, true), (true, false), (true, true)] {
            let mut best = f64::INFINITY;
            for _ in 0..20 {
                let t = std::time::Instant::now();
                for _ in 0..200 {
                    let d = if jac { Some(&mut dg[..]) } else { None };
                    aft.evaluate(
                        &xs,
                        1000.0,
                        &mut e,
                        PeriodicLoop::MaxAmplitude,
                        half,
                        &mut g,
                        d,
                    )
                    .unwrap();
                }
                best = best.min(t.elapsed().as_secs_f64() / 200.0);
            }
            eprintln!("half-wave {half}, jacobian {jac}: {:.2} us", best * 1e6);
        }
    }
}
