//! The `Element` abstraction: a nonlinear force acting at the joint point.
//!
//! An element exerts the force `g` in the equation of motion
//! `m x'' + c x' + k x = F − g` (paper eq. 1, `g = F_nlf`). Both stages that
//! solve the structure use this one trait, so no element law is written twice:
//!
//! * the time-domain simulator (`sim`) evaluates `trial` inside its per-sample
//!   implicit solve, then `commit`s the accepted sample;
//! * harmonic balance (`hb`) `reset`s the element and `commit`s the samples of
//!   one period in order (a virgin ramp to the displacement maximum first:
//!   every inner loop then closes within the period, so one period is
//!   already periodic).
//!
//! `trial` takes `&self`: the compiler guarantees that evaluating a candidate
//! leaves no trace in the element's memory (turning points, slider position).

use crate::error::Result;
use num_complex::Complex64;

/// An element's force and its tangents at one `(x, v)`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ElementForce {
    /// Force `g`, N (acting against the structure, as `F_nl` in eq. 1).
    pub force: f64,
    /// Tangent stiffness `∂g/∂x`, N/m.
    pub stiffness: f64,
    /// Tangent damping `∂g/∂v`, N s/m.
    pub damping: f64,
}

impl std::ops::Add for ElementForce {
    type Output = ElementForce;
    fn add(self, o: ElementForce) -> ElementForce {
        ElementForce {
            force: self.force + o.force,
            stiffness: self.stiffness + o.stiffness,
            damping: self.damping + o.damping,
        }
    }
}

/// The per-sample implicit equation of the digital-filter simulator.
///
/// The filters give `x = x_pred + bx·u` and `v = v_pred + bv·u` for the net
/// input `u = F − g(x, v)` of the current sample (`bx`, `bv` are the summed
/// direct terms `b0`, both > 0). The root `u` of
/// `u − F + g(x_pred + bx u, v_pred + bv u) = 0` is the sample's input.
#[derive(Clone, Copy, Debug)]
pub struct ImplicitStep {
    /// Displacement from the filters' past, m.
    pub x_pred: f64,
    /// Velocity from the filters' past, m/s.
    pub v_pred: f64,
    /// Displacement direct term, m/N.
    pub bx: f64,
    /// Velocity direct term, m/(N s).
    pub bv: f64,
    /// External force of this sample, N.
    pub force: f64,
}

/// A mass, spring and damper moving with the drive point (an armature,
/// [`crate::model::Armature`]): the dynamic stiffness
/// `Z_a(ω) = stiffness − mass ω² + jω damping` it adds there.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Attachment {
    /// Mass, kg (in the model's force unit per m/s²).
    pub mass: f64,
    /// Stiffness to the ground, N/m.
    pub stiffness: f64,
    /// Damping to the ground, N s/m.
    pub damping: f64,
}

impl Attachment {
    /// `Z_a(ω)`.
    pub fn impedance(&self, omega: f64) -> Complex64 {
        Complex64::new(
            self.stiffness - self.mass * omega * omega,
            omega * self.damping,
        )
    }

    /// Two attachments at the same point: their parameters add.
    pub fn plus(self, o: Attachment) -> Attachment {
        Attachment {
            mass: self.mass + o.mass,
            stiffness: self.stiffness + o.stiffness,
            damping: self.damping + o.damping,
        }
    }
}

/// How a drive model between the reference and the structure (a shaker)
/// loads the structure, per harmonic: the reference reaches the drive point
/// as `D(ω) F`, `D = g/(1 + jωτ)`, and the drive adds the dynamic stiffness
/// `Z(ω) = jω c/(1 + jωτ)` there (see [`crate::model::Shaker`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveLoad {
    /// Back-EMF damping `c`, N s/m (in the model's force unit).
    pub back_emf: f64,
    /// Lag time constant `τ`, s.
    pub time_constant: f64,
    /// The blocked force `g` per unit of drive (1 when the model's forces
    /// are in the drive's unit).
    pub gain: f64,
}

impl DriveLoad {
    /// `1/(1 + jωτ)`: the lag.
    fn lag(&self, omega: f64) -> Complex64 {
        1.0 / Complex64::new(1.0, omega * self.time_constant)
    }

    /// `D(ω) = g/(1 + jωτ)`: the drive as it reaches the structure.
    pub fn drive(&self, omega: f64) -> Complex64 {
        self.gain * self.lag(omega)
    }

    /// `Z(ω) = jω c/(1 + jωτ)`: the dynamic stiffness the drive adds.
    pub fn impedance(&self, omega: f64) -> Complex64 {
        Complex64::new(0.0, omega * self.back_emf) * self.lag(omega)
    }
}

/// Relative tolerance of the per-sample implicit equation's root `u` (see
/// [`ImplicitStep`]), whoever solves it: an element's own
/// [`Element::solve_implicit`] or the simulator's safeguarded solve. Far
/// below the simulator's discretisation error (≥ 1e-5 at 200 samples per
/// period).
pub(crate) const SOLVE_TOLERANCE: f64 = 1e-11;

/// A nonlinear force law, with or without memory.
pub trait Element {
    /// The force at `(x, v)` if this sample were accepted, evaluated from the
    /// last committed state. Has no effect on the element's history; an
    /// element may cache its last exact evaluation to expand nearby trials
    /// around it (the Masing element does, to within 1e-13 of its slip
    /// force), so the same sequence of calls always gives the same bits.
    fn trial(&self, x: f64, v: f64) -> ElementForce;

    /// Accepts `(x, v)` as the next sample of the element's history and
    /// returns its force (the same as `trial(x, v)` would).
    fn commit(&mut self, x: f64, v: f64) -> ElementForce;

    /// Back to the virgin state (no load history).
    fn reset(&mut self);

    /// Whether the force depends on the history (hysteresis).
    fn has_memory(&self) -> bool;

    /// Whether the force depends on velocity.
    fn uses_velocity(&self) -> bool {
        false
    }

    /// Whether the law is odd, `g(−x, −v) = −g(x, v)` (for an element with
    /// memory: with its history mirrored too). Then symmetric forcing gives a
    /// response with half-wave symmetry, odd harmonics only, and harmonic
    /// balance may solve for those alone. `false` (every harmonic) unless the
    /// element says so.
    fn odd_law(&self) -> bool {
        false
    }

    /// The describing function `N(a, ω)`: the fundamental of the force under
    /// `x = a cos θ`, divided by `a` (`Re N`: equivalent stiffness, `Im N`:
    /// equivalent damping times ω). An element overrides it with a closed
    /// form or a quadrature cheaper than the default, [`loop_fundamental`]
    /// over one marched loop of `samples` points. Leaves the element reset.
    fn describing_function(&mut self, amplitude: f64, omega: f64, samples: usize) -> Complex64 {
        loop_fundamental(self, amplitude, omega, samples)
    }

    /// How many periods harmonic balance may march before the force repeats
    /// (it stops as soon as it does). 0: the loop closes within the first
    /// period after a virgin ramp to the displacement maximum, as every
    /// Masing-type loop does; a law whose memory fades only gradually (the
    /// Bouc-Wen hysteresis) gives its cap.
    fn periods_to_settle(&self) -> usize {
        0
    }

    /// Harmonic balance starts marching a period (only for a law with
    /// [`Element::periods_to_settle`] > 0): the element notes its memory.
    fn open_period(&mut self) {}

    /// Harmonic balance has marched a whole period since
    /// [`Element::open_period`] (`mirror`: half a period of a displacement
    /// with `x(θ + π) = −x(θ)`, whose periodic force then obeys `g(θ + π) =
    /// −g(θ)`). Returns how far the memory is from periodic: `|z_close −
    /// z_open|` (`|z_close + z_open|` for `mirror`), in the force's unit. A
    /// law whose memory fades gradually then moves its memory (and the
    /// sensitivities it carries) to the periodic state the period predicts,
    /// a Newton step on the period map, so that the next period is the
    /// periodic one. Default: 0, nothing to move (a Masing-type loop repeats
    /// from its first period).
    fn close_period(&mut self, _mirror: bool) -> f64 {
        0.0
    }

    /// Harmonic balance is about to march half periods of a half-wave
    /// symmetric displacement (`x(θ + π) = −x(θ)`) from its turning point
    /// `x`, which the element has just reached by the virgin ramp: the
    /// element may take the memory (and its sensitivities) of the periodic
    /// loop between `±x` whose half cycles are monotone, exact when they are
    /// and otherwise a start for the period map's fixed point, which the
    /// march still finds. A gradually settling law then repeats from its
    /// first half period instead of its third. Default: nothing (a
    /// Masing-type loop repeats from its first period anyway).
    fn start_symmetric_loop(&mut self, _x: f64) {}

    /// The root `u` of the per-sample implicit equation in closed form, when
    /// the element has one (the Jenkins element does). `None`: the simulator
    /// solves it iteratively with [`Element::trial`].
    fn solve_implicit(&self, _step: &ImplicitStep) -> Option<f64> {
        None
    }

    /// The simulator's sample interval `h` (s), given once before the first
    /// sample. A law with a slip transition uses it to place the transition
    /// inside the sample (see [`Element::kink_impulse`]); 0 (the default
    /// state, and harmonic balance's) leaves the law sampled as is.
    fn set_sample_interval(&mut self, _h: f64) {}

    /// The time between the samples the simulator commits (s), given once
    /// before the first. A law with dynamics of its own (a lag) needs it;
    /// harmonic balance never gives one, so such a law must be linear and
    /// give its effect there through [`Element::drive_load`].
    fn set_time_step(&mut self, _h: f64) {}

    /// The drive model the element stands for, if it is one (a shaker):
    /// harmonic balance applies it to the drive and the receptance, the
    /// simulator lags its drive by it.
    fn drive_load(&self) -> Option<DriveLoad> {
        None
    }

    /// The mass, spring and damper the element stands for, if it is one (an
    /// armature): harmonic balance adds its dynamic stiffness to the
    /// receptance, the simulator solves it inside each sample.
    fn attachment(&self) -> Option<Attachment> {
        None
    }

    /// The part of its last committed force that the drive itself loses (a
    /// shaker's back-EMF: the coil's force is the lagged drive less it), so
    /// that the simulator can report the force the drive applies, what a
    /// force gauge between the shaker and the structure reads. Default: 0.
    fn drive_reaction(&self) -> f64 {
        0.0
    }

    /// The impulse (N s) by which the element force's path inside the sample
    /// just committed exceeds the straight line between its two samples,
    /// which is what the ramp-invariant filters assume: a kink inside the
    /// sample (stick turning to slip at `τ`) leaves a triangle of area
    /// `h Δg (1 − τ)/2`. The simulator feeds it to the filters as a hat of the
    /// same area, so that the transition's error is `O(h³)` per event and the
    /// run's error falls as `h²` whatever the events' phase in the sample.
    /// Default: 0 (no kink, or [`Element::set_sample_interval`] not given).
    fn kink_impulse(&self) -> f64 {
        0.0
    }

    /// Commits like [`Element::commit`] and carries first-order sensitivities
    /// through the element's memory: when the committed samples depend on
    /// parameters `p` (harmonic balance's unknowns), `dx[k] = ∂x/∂p_k` and
    /// `dv[k] = ∂v/∂p_k` for this sample, this **adds** `∂g/∂p_k` to `df[k]`
    /// (adding lets an [`ElementSet`] sum its members without scratch).
    ///
    /// The derivative includes the dependence of the force on earlier samples
    /// through the history (a turning point, the slider position), which the
    /// element keeps alongside its state. It is exact for the samples
    /// committed through this method since the last [`Element::reset`]; plain
    /// `commit`s in between leave the carried sensitivities stale.
    ///
    /// The default, `∂g/∂p = k ∂x/∂p + c ∂v/∂p` from the tangents, is exact
    /// for memoryless elements; an element with memory must override it
    /// (harmonic balance's Newton step otherwise sees an approximate
    /// Jacobian).
    ///
    /// # Panics
    /// May panic if `dx`, `dv` and `df` differ in length.
    fn commit_sensitivity(
        &mut self,
        x: f64,
        v: f64,
        dx: &[f64],
        dv: &[f64],
        df: &mut [f64],
    ) -> ElementForce {
        let f = self.commit(x, v);
        for ((d, &a), &b) in df.iter_mut().zip(dx).zip(dv) {
            *d += f.stiffness * a + f.damping * b;
        }
        f
    }

    /// Commits the samples `(x[i], v[i])` in order, adding each force to
    /// `g[i]`: harmonic balance's march between two turning points in one
    /// call, so that a set or the element enum dispatches once per run of
    /// samples rather than once per sample.
    fn commit_run(&mut self, x: &[f64], v: &[f64], g: &mut [f64]) {
        for ((&x, &v), g) in x.iter().zip(v).zip(g) {
            *g += self.commit(x, v).force;
        }
    }

    /// How many memory terms [`Element::commit_sensitivity_terms`] writes,
    /// or `None` when the law carries its sensitivities only densely
    /// ([`Element::commit_sensitivity`]). The default: none for a memoryless
    /// law (its tangents are all there is), dense for one with memory.
    fn memory_terms(&self) -> Option<usize> {
        if self.has_memory() { None } else { Some(0) }
    }

    /// [`Element::commit_sensitivity`] in structured form, for harmonic
    /// balance's projection of the sensitivities onto the harmonics: the
    /// same `∂g/∂p`, written as the law's tangents times `∂x/∂p`, `∂v/∂p`
    /// ([`SensitivityTerms::tangent`]) plus memory terms, each a
    /// per-sample coefficient times a vector that changes only at events
    /// (a turning point, a slider that stuck): a Jenkins slider's
    /// `−kd ∂x_s`, a Masing branch's origin. Only called when
    /// [`Element::memory_terms`] is `Some`; the default, for a memoryless
    /// law, states its tangents.
    fn commit_sensitivity_terms(
        &mut self,
        x: f64,
        v: f64,
        _dx: &[f64],
        _dv: &[f64],
        terms: &mut SensitivityTerms,
    ) -> ElementForce {
        let f = self.commit(x, v);
        terms.tangent(f.stiffness, f.damping);
        f
    }
}

/// `to ← from` for a sensitivity row of a few unknowns, copied once per
/// sample by the laws with memory: inline moves, not the library call (and
/// its set-up) that `copy_from_slice` becomes for a length not known at
/// compile time (15 % of harmonic balance's time on a Jenkins joint).
#[inline]
pub(crate) fn copy_short(to: &mut [f64], from: &[f64]) {
    let mut to = to.chunks_exact_mut(4);
    let mut from = from.chunks_exact(4);
    for (t, f) in (&mut to).zip(&mut from) {
        let f: [f64; 4] = f.try_into().expect("chunks of 4");
        t.copy_from_slice(&f);
    }
    for (t, &f) in to.into_remainder().iter_mut().zip(from.remainder()) {
        *t = f;
    }
}

/// One sample's force sensitivity `∂g/∂p` in the form harmonic balance
/// projects cheaply:
///
/// ```text
/// ∂g_j = k_j ∂x_j + c_j ∂v_j + Σ_t a_{t,j} m_t
/// ```
///
/// with the tangents `k_j`, `c_j`, and memory vectors `m_t` that stay the
/// same over many samples (a Jenkins slider's `−∂x_s` while it sticks, a
/// Masing branch's origin). Projected onto the harmonics, the tangent part
/// is one FFT of `k` (a product of two harmonics is a harmonic of their sum
/// or difference), and each memory term the weighted sum of the analysis
/// basis over the samples it lasted, times its vector: `O(N log N + N n)`
/// in all instead of the `O(n N log N)` of transforming each of the `n`
/// columns of `∂g/∂p` (`n` unknowns, `N` samples).
#[derive(Clone, Debug, Default)]
pub struct SensitivityTerms {
    n: usize,
    /// The first slot of the element being committed (a set's members
    /// take consecutive slots).
    base: usize,
    /// This sample's tangents.
    stiffness: f64,
    damping: f64,
    /// This sample's coefficient per slot.
    coefficients: Vec<f64>,
    /// Each slot's current vector (`n` values).
    vectors: Vec<f64>,
    /// Each slot's weighted sum of the analysis rows since its vector was
    /// set (`n` values), and whether any weight was added.
    sums: Vec<f64>,
    summed: Vec<bool>,
    /// `Σ_t (Σ_j a_{t,j} w_j) ⊗ m_t` of the vectors replaced so far,
    /// row-major `n × n` (row: the harmonic, column: the unknown).
    projected: Vec<f64>,
}

impl SensitivityTerms {
    /// The tangents `∂g/∂x`, `∂g/∂v` of this sample (added: a set's
    /// members each state theirs).
    #[inline]
    pub fn tangent(&mut self, stiffness: f64, damping: f64) {
        self.stiffness += stiffness;
        self.damping += damping;
    }

    /// Memory term `slot`'s coefficient at this sample (of the element
    /// being committed; set once per sample).
    #[inline]
    pub fn coefficient(&mut self, slot: usize, a: f64) {
        self.coefficients[self.base + slot] = a;
    }

    /// Replaces memory term `slot`'s vector from this sample on: what the
    /// samples before summed is projected with the vector they had.
    pub fn replace(&mut self, slot: usize, vector: &[f64]) {
        let t = self.base + slot;
        self.flush(t);
        self.vectors[t * self.n..(t + 1) * self.n].copy_from_slice(vector);
    }

    /// Projects slot `t`'s sum with its vector and clears the sum.
    fn flush(&mut self, t: usize) {
        let n = self.n;
        if self.summed[t] {
            let (sum, m) = (
                &self.sums[t * n..(t + 1) * n],
                &self.vectors[t * n..(t + 1) * n],
            );
            for (row, &w) in self.projected.chunks_exact_mut(n).zip(sum) {
                for (p, &mk) in row.iter_mut().zip(m) {
                    *p += w * mk;
                }
            }
            self.sums[t * n..(t + 1) * n].fill(0.0);
            self.summed[t] = false;
        }
    }

    /// Empty, for `slots` memory terms of `n` unknowns (every vector zero).
    pub(crate) fn start(&mut self, n: usize, slots: usize) {
        self.n = n;
        self.base = 0;
        self.stiffness = 0.0;
        self.damping = 0.0;
        self.coefficients.clear();
        self.coefficients.resize(slots, 0.0);
        self.vectors.clear();
        self.vectors.resize(slots * n, 0.0);
        self.sums.clear();
        self.sums.resize(slots * n, 0.0);
        self.summed.clear();
        self.summed.resize(slots, false);
        self.projected.clear();
        self.projected.resize(n * n, 0.0);
    }

    /// The first slot of the next member of a set.
    pub(crate) fn set_base(&mut self, base: usize) {
        self.base = base;
    }

    /// Ends a sample: adds `a_t w` to each slot's sum when the sample is
    /// kept (`w`: its analysis row), and returns its tangents; every
    /// coefficient and tangent back to zero.
    #[inline]
    pub(crate) fn end_sample(&mut self, w: Option<&[f64]>) -> (f64, f64) {
        let n = self.n;
        for t in 0..self.coefficients.len() {
            let a = std::mem::take(&mut self.coefficients[t]);
            if let (Some(w), true) = (w, a != 0.0) {
                for (s, &wk) in self.sums[t * n..(t + 1) * n].iter_mut().zip(w) {
                    *s += a * wk;
                }
                self.summed[t] = true;
            }
        }
        self.base = 0;
        (
            std::mem::take(&mut self.stiffness),
            std::mem::take(&mut self.damping),
        )
    }

    /// Projects what is left and adds `scale` times the memory terms'
    /// projection to `out` (row-major `n × n`).
    pub(crate) fn finish(&mut self, scale: f64, out: &mut [f64]) {
        for t in 0..self.coefficients.len() {
            self.flush(t);
        }
        for (o, &p) in out.iter_mut().zip(&self.projected) {
            *o += scale * p;
        }
    }
}

/// A set of elements acting at the same point: their forces add.
#[derive(Clone, Debug, Default)]
pub struct ElementSet<E> {
    /// The elements.
    pub elements: Vec<E>,
}

impl<E: Element> ElementSet<E> {
    /// A set from elements.
    pub fn new(elements: Vec<E>) -> Self {
        ElementSet { elements }
    }
}

impl<E: Element> Element for ElementSet<E> {
    #[inline]
    fn trial(&self, x: f64, v: f64) -> ElementForce {
        self.elements
            .iter()
            .fold(ElementForce::default(), |acc, e| acc + e.trial(x, v))
    }
    #[inline]
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        self.elements
            .iter_mut()
            .fold(ElementForce::default(), |acc, e| acc + e.commit(x, v))
    }
    fn reset(&mut self) {
        self.elements.iter_mut().for_each(Element::reset);
    }
    fn has_memory(&self) -> bool {
        self.elements.iter().any(Element::has_memory)
    }
    fn uses_velocity(&self) -> bool {
        self.elements.iter().any(Element::uses_velocity)
    }
    fn odd_law(&self) -> bool {
        self.elements.iter().all(Element::odd_law)
    }
    fn periods_to_settle(&self) -> usize {
        self.elements
            .iter()
            .map(Element::periods_to_settle)
            .max()
            .unwrap_or(0)
    }
    fn open_period(&mut self) {
        self.elements.iter_mut().for_each(Element::open_period);
    }
    fn start_symmetric_loop(&mut self, x: f64) {
        self.elements
            .iter_mut()
            .for_each(|e| e.start_symmetric_loop(x));
    }
    fn close_period(&mut self, mirror: bool) -> f64 {
        self.elements
            .iter_mut()
            .map(|e| e.close_period(mirror))
            // NaN (a law run away) propagates: never "settled"
            .fold(0.0, |m: f64, r| {
                if m.is_nan() || r.is_nan() {
                    f64::NAN
                } else {
                    m.max(r)
                }
            })
    }
    fn describing_function(&mut self, amplitude: f64, omega: f64, samples: usize) -> Complex64 {
        self.elements
            .iter_mut()
            .map(|e| e.describing_function(amplitude, omega, samples))
            .sum()
    }
    #[inline]
    fn commit_sensitivity(
        &mut self,
        x: f64,
        v: f64,
        dx: &[f64],
        dv: &[f64],
        df: &mut [f64],
    ) -> ElementForce {
        self.elements
            .iter_mut()
            .fold(ElementForce::default(), |acc, e| {
                acc + e.commit_sensitivity(x, v, dx, dv, df)
            })
    }
    /// Each member over the whole run in turn (their histories are their
    /// own; the forces add in the order [`Element::commit`] adds them).
    fn commit_run(&mut self, x: &[f64], v: &[f64], g: &mut [f64]) {
        for e in &mut self.elements {
            e.commit_run(x, v, g);
        }
    }
    /// The members' in turn (`None` if any member's is).
    fn memory_terms(&self) -> Option<usize> {
        self.elements.iter().map(Element::memory_terms).sum()
    }
    #[inline]
    fn commit_sensitivity_terms(
        &mut self,
        x: f64,
        v: f64,
        dx: &[f64],
        dv: &[f64],
        terms: &mut SensitivityTerms,
    ) -> ElementForce {
        let mut base = 0;
        let mut f = ElementForce::default();
        for e in &mut self.elements {
            terms.set_base(base);
            f = f + e.commit_sensitivity_terms(x, v, dx, dv, terms);
            base += e.memory_terms().unwrap_or(0);
        }
        terms.set_base(0);
        f
    }
    fn set_sample_interval(&mut self, h: f64) {
        self.elements
            .iter_mut()
            .for_each(|e| e.set_sample_interval(h));
    }
    #[inline]
    fn kink_impulse(&self) -> f64 {
        self.elements.iter().map(Element::kink_impulse).sum()
    }
    fn set_time_step(&mut self, h: f64) {
        self.elements.iter_mut().for_each(|e| e.set_time_step(h));
    }
    /// The members' together (attached at one point, they add).
    fn attachment(&self) -> Option<Attachment> {
        self.elements
            .iter()
            .filter_map(Element::attachment)
            .reduce(Attachment::plus)
    }
    /// The members' together.
    fn drive_reaction(&self) -> f64 {
        self.elements.iter().map(Element::drive_reaction).sum()
    }
    /// The first member's (a model has at most one drive).
    fn drive_load(&self) -> Option<DriveLoad> {
        self.elements.iter().find_map(Element::drive_load)
    }
    #[inline]
    fn solve_implicit(&self, step: &ImplicitStep) -> Option<f64> {
        match self.elements.as_slice() {
            [] => Some(step.force),
            [one] => one.solve_implicit(step),
            _ => None,
        }
    }
}

/// No element: the linear structure alone.
#[derive(Clone, Copy, Debug, Default)]
pub struct NoElement;

impl Element for NoElement {
    #[inline]
    fn trial(&self, _x: f64, _v: f64) -> ElementForce {
        ElementForce::default()
    }
    #[inline]
    fn commit(&mut self, _x: f64, _v: f64) -> ElementForce {
        ElementForce::default()
    }
    fn reset(&mut self) {}
    fn has_memory(&self) -> bool {
        false
    }
    fn odd_law(&self) -> bool {
        true
    }
    fn describing_function(&mut self, _amplitude: f64, _omega: f64, _samples: usize) -> Complex64 {
        Complex64::new(0.0, 0.0)
    }
    #[inline]
    fn solve_implicit(&self, step: &ImplicitStep) -> Option<f64> {
        Some(step.force)
    }
}

/// The describing function of any element from one periodic loop of
/// `samples` points: `x_j = a cos θ_j`, `v_j = −aω sin θ_j`, marched from the
/// displacement maximum after a virgin ramp (so the loop closes within the one
/// period), and the fundamental `(2/N) Σ g_j e^{−jθ_j}` divided by `a`. The
/// element is left reset.
pub fn loop_fundamental<E: Element + ?Sized>(
    element: &mut E,
    amplitude: f64,
    omega: f64,
    samples: usize,
) -> Complex64 {
    let a = amplitude;
    let ns = samples.max(4);
    element.reset();
    element.commit(a, 0.0);
    let mut acc = Complex64::new(0.0, 0.0);
    for s in 1..=ns {
        let j = s % ns;
        let th = 2.0 * std::f64::consts::PI * j as f64 / ns as f64;
        let (sn, cs) = th.sin_cos();
        let g = element.commit(a * cs, -a * omega * sn).force;
        acc += Complex64::new(g * cs, -g * sn);
    }
    element.reset();
    acc * (2.0 / ns as f64) / a
}

/// The sign of `x` as ±1 (0 maps to +1).
#[inline]
pub(crate) fn sign(x: f64) -> f64 {
    if x < 0.0 { -1.0 } else { 1.0 }
}

/// What values a parameter may take (what a model's check enforces).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Domain {
    /// Finite and `> 0`.
    Positive,
    /// Finite and `≥ 0`.
    NonNegative,
    /// Finite, either sign.
    Signed,
    /// Strictly between `min` and `max`.
    Range {
        /// Lower end (excluded).
        min: f64,
        /// Upper end (excluded).
        max: f64,
    },
}

/// The coordinate a fit moves a parameter in (see `fit::params`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FitScale {
    /// Its logarithm, six decades either side of the start: a positive
    /// quantity whose plausible values span decades (a stiffness, a force).
    Log,
    /// The value itself divided by its start, bounded by its domain: a size
    /// that may be zero (or of either sign for [`Domain::Signed`]).
    Linear,
    /// Its reciprocal, within `[min, max]`: a shape exponent whose large
    /// values all look alike (the fit's cost flattens as it grows).
    Reciprocal {
        /// Smallest value.
        min: f64,
        /// Largest value.
        max: f64,
    },
}

/// What a parameter means to the rest of the pipeline, beyond its value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// The stiffness a joint adds while it sticks (`kd`): the low-level
    /// stiffness is shared between it and the structure.
    StickStiffness,
    /// The force at which a joint slips (`Fd`): bounded by the force levels
    /// tested.
    SlipForce,
    /// A gauge: a parameter the force determines only together with others
    /// (Bouc-Wen's `β`, which trades with `γ` and `δ`: `(cβ, γ/c, δ/c)` is
    /// the same law). A fit holds it at its start, the stick stiffness over
    /// the slip force (the reciprocal of the displacement at which the joint
    /// slips), and the others take its scale.
    Gauge,
    /// Anything else (a shape, a size, a gap).
    Other,
}

/// One parameter of an element law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParameterInfo {
    /// Its name in files and reports.
    pub name: &'static str,
    /// Its SI unit.
    pub unit: &'static str,
    /// What it is, in a few words.
    pub meaning: &'static str,
    /// The values it may take.
    pub domain: Domain,
    /// How a fit moves it.
    pub scale: FitScale,
    /// What it means to the pipeline.
    pub role: Role,
    /// Its start in a fit where the data give none (joints get `kd`, `Fd`
    /// from the data; see `fit::identify`).
    pub start: f64,
}

/// A joint's stick stiffness `kd`, as the Jenkins and Masing laws name it.
pub const STICK_STIFFNESS: ParameterInfo = ParameterInfo {
    name: "kd",
    unit: "N/m",
    meaning: "stick stiffness",
    domain: Domain::Positive,
    scale: FitScale::Log,
    role: Role::StickStiffness,
    start: 1.0,
};

/// A joint's slip force `fd`, as the Jenkins and Masing laws name it.
pub const SLIP_FORCE: ParameterInfo = ParameterInfo {
    name: "fd",
    unit: "N",
    meaning: "slip force",
    domain: Domain::Positive,
    scale: FitScale::Log,
    role: Role::SlipForce,
    start: 1.0,
};

/// Everything the pipeline knows about an element law, besides its force.
///
/// Harmonic balance reads the symmetry and the samples a period needs, the
/// fit reads the parameters (domain, scale, role, start), the diagnosis reads
/// what the law is, the test definition reads the parameter names: no stage
/// matches on an element's type.
#[derive(Clone, Copy, Debug)]
pub struct Description {
    /// Its name in files and reports (snake case).
    pub name: &'static str,
    /// What it is, in a sentence.
    pub summary: &'static str,
    /// Its parameters, in the order of `ElementSpec::parameters`.
    pub parameters: &'static [ParameterInfo],
    /// Whether the force depends on the history (hysteresis).
    pub memory: bool,
    /// Whether the law is odd (see [`Element::odd_law`]).
    pub odd: bool,
    /// Samples per period harmonic balance needs at least to resolve the
    /// law's kinks (0: no own need).
    pub samples_per_period: usize,
    /// For a law smooth enough that a fit's harmonic balance needs fewer
    /// samples than its default count: the count these parameter values
    /// need (0: none beyond what the harmonics ask). `None`: the default
    /// count, or `samples_per_period` if more. A model's fits take the
    /// smaller count only when every law it holds states one
    /// ([`crate::model::Model::smooth_samples_per_period`]).
    pub smooth_samples: Option<fn(&[f64]) -> usize>,
    /// Parameter values at the paper's system's scale (displacements ~10 µm,
    /// forces ~100 N): what the element checks run every law with.
    pub example: &'static [f64],
}

impl Description {
    /// Whether this is a joint: a hysteresis law with a stick stiffness
    /// (a model's `joint`).
    pub fn is_joint(&self) -> bool {
        self.memory && self.index_of(Role::StickStiffness).is_some()
    }

    /// Whether `identify` fits it: a joint with a slip force too, or a
    /// gauge started from one, so that the fit starts it from the stiffness
    /// and force the data show.
    pub fn is_fitted_joint(&self) -> bool {
        self.is_joint()
            && (self.index_of(Role::SlipForce).is_some() || self.index_of(Role::Gauge).is_some())
    }

    /// The position of the parameter with `role`.
    pub fn index_of(&self, role: Role) -> Option<usize> {
        self.parameters.iter().position(|p| p.role == role)
    }
}

/// An element law the registry knows: its description and how it is built
/// from parameter values (checked against their domains beforehand).
pub trait Law: Element + Sized {
    /// What the pipeline knows about it.
    const DESCRIPTION: Description;

    /// The virgin element with `values` in the order of
    /// [`Description::parameters`].
    fn from_parameters(values: &[f64]) -> Result<Self>;

    /// Rewrites a declaration's fields (a test definition's table, a JSON
    /// object; `kind` included) into the law's own parameters before they
    /// are read: where a law may be declared in other terms (a shaker by
    /// its coil's `r`, `l`, `bl`) or a parameter has a default. An error
    /// says what is wrong with the fields. Default: as written.
    fn declared(_fields: &mut serde_json::Map<String, serde_json::Value>) -> Result<()> {
        Ok(())
    }
}

#[cfg(test)]
pub(crate) mod check {
    //! One checker run over every element (design lesson 5).
    use super::*;

    /// A displacement history with reversals of several sizes, including
    /// nested inner loops.
    pub fn history(scale: f64) -> Vec<f64> {
        let turning = [0.0, 1.0, -0.4, 0.6, -1.3, 0.2, -0.1, 1.5, -1.5, 0.3, 1.5];
        let mut xs = Vec::new();
        for w in turning.windows(2) {
            for i in 1..=40 {
                xs.push(scale * (w[0] + (w[1] - w[0]) * i as f64 / 40.0));
            }
        }
        xs
    }

    /// `trial` has no side effect and predicts `commit`; the tangent matches
    /// a one-sided finite difference in the direction of motion; `reset`
    /// restores the virgin response.
    pub fn check_element<E: Element + Clone>(mut e: E, scale: f64, force_scale: f64) {
        let xs = history(scale);
        let mut first = Vec::new();
        let mut prev = 0.0;
        for (i, &x) in xs.iter().enumerate() {
            let v = (x - prev) * 1000.0;
            let a = e.trial(x, v);
            let b = e.trial(x, v);
            assert_eq!(a, b, "trial changed the state at sample {i}");
            // tangent against a small step in the direction of motion (on a
            // clone: an element may cache its last exact trial)
            let dx = (x - prev) * 1e-4;
            if dx != 0.0 {
                let e = e.clone();
                let c = e.trial(x + dx, v);
                let fd = (c.force - a.force) / dx;
                let tol = 1e-3 * a.stiffness.abs().max(force_scale / scale) + 1e-9;
                // skip samples that straddle a kink (switch of branch)
                let d = e.trial(x + 2.0 * dx, v);
                let fd2 = (d.force - c.force) / dx;
                let b = e.trial(x - dx, v);
                let back = (a.force - b.force) / dx;
                if (fd2 - fd).abs() < tol && (back - fd).abs() < tol {
                    assert!(
                        (fd - a.stiffness).abs() < tol,
                        "tangent at {i}: fd {fd} vs {}",
                        a.stiffness
                    );
                }
            }
            let c = e.commit(x, v);
            assert_eq!(a, c, "commit differs from trial at sample {i}");
            first.push(c.force);
            prev = x;
        }
        e.reset();
        prev = 0.0;
        for (i, &x) in xs.iter().enumerate() {
            let v = (x - prev) * 1000.0;
            let c = e.commit(x, v);
            assert_eq!(
                c.force, first[i],
                "reset did not restore the virgin state at {i}"
            );
            prev = x;
        }
        // harmonic balance's march: runs of samples (some repeated, as a
        // turning point between samples can be) committed by `commit_run`
        // in a period, bit for bit as `commit` sample by sample
        let mut xs2 = Vec::with_capacity(xs.len() + xs.len() / 13);
        for (i, &x) in xs.iter().enumerate() {
            xs2.push(x);
            if i % 13 == 5 {
                xs2.push(x);
            }
        }
        let vs: Vec<f64> = xs2
            .iter()
            .scan(0.0, |p, &x| {
                let v = (x - *p) * 1000.0 + if x == *p { 1.0 } else { 0.0 };
                *p = x;
                Some(v)
            })
            .collect();
        let (mut by_run, mut by_sample) = (e.clone(), e.clone());
        by_run.reset();
        by_sample.reset();
        by_run.open_period();
        by_sample.open_period();
        // −0 + f is f to the bit (a zero force keeps its sign)
        let mut g_run = vec![-0.0; xs2.len()];
        let mut start = 0;
        for (k, len) in [1usize, 7, 40, 3, 81].iter().cycle().enumerate() {
            let end = (start + len + k % 2).min(xs2.len());
            by_run.commit_run(&xs2[start..end], &vs[start..end], &mut g_run[start..end]);
            start = end;
            if start == xs2.len() {
                break;
            }
        }
        for (i, (&x, &v)) in xs2.iter().zip(&vs).enumerate() {
            let f = by_sample.commit(x, v).force;
            assert_eq!(
                f.to_bits(),
                g_run[i].to_bits(),
                "commit_run differs from commit at sample {i}"
            );
        }
        assert_eq!(
            by_run.close_period(false).to_bits(),
            by_sample.close_period(false).to_bits(),
            "commit_run left another state than commit"
        );
        // the period's closing used what the run carried (a settling law's
        // memory gain): the next sample shows it
        let x = 0.5 * scale;
        assert_eq!(
            by_run.commit(x, 1.0).force.to_bits(),
            by_sample.commit(x, 1.0).force.to_bits(),
            "commit_run carried another period state than commit"
        );
    }
}
