//! Time-domain simulation by the digital-filter method.
//!
//! The structure is the paper's eq. (1), `x = H * (F − g)`: the underlying
//! linear modes as ramp-invariant IIR sections ([`filter`]), the element force
//! `g` fed back every sample (Ahlin, Magnevall & Josefsson, ISMA 2006; the
//! paper's ref. \[1\]).
//!
//! The displacement filter has a direct term `b0 ≠ 0`, so the current sample's
//! displacement depends on the current element force. Each sample is therefore
//! solved implicitly for the net input `u = F − g(x, v)` (the sources do not
//! say how they break this loop): a safeguarded Newton iteration on the scalar
//! residual, with the element evaluated as a *trial* from its last committed
//! state, then *committed* once. A one-sample-delay shortcut
//! `u[n] = F[n] − g[n−1]` would be simpler but acts as a negative viscous
//! damping `≈ kd·T`: at 20 samples per stick period it errs by 53 % in H1
//! against 1.5 % for the implicit solve (the paper's Jenkins element on
//! `m = 10 kg`, `c = 200 N s/m`, `k = 1e7 N/m`, 200 N at 250 Hz;
//! `tests/sim.rs` re-checks the comparison).
//!
//! The simulator keeps its state between calls, so a stepped-sine test
//! continues each dwell from where the last one ended.

pub mod filter;
pub mod points;

pub use filter::{ModeFilter, Section};
pub use points::{PointResponse, PointSimulator};

use crate::error::{Error, Result};
use crate::model::element::SOLVE_TOLERANCE;
use crate::model::shaker::Lag;
use crate::model::{
    AnyElement, Attachment, Element, ElementForce, ImplicitStep, ModalModel, Model,
};
use crate::observe::Observer;

/// One output sample.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample {
    /// Displacement, m.
    pub displacement: f64,
    /// Velocity, m/s.
    pub velocity: f64,
    /// Acceleration, m/s².
    pub acceleration: f64,
    /// Total element force `g`, N.
    pub element_force: f64,
    /// The force the drive applies at the drive point, N: the input itself,
    /// or with a shaker the coil's force, its lagged drive less its
    /// back-EMF (what a force gauge between the shaker and the structure
    /// reads; an armature sits behind the gauge).
    pub drive_force: f64,
}

/// Time histories of a run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Response {
    /// Displacement, m.
    pub displacement: Vec<f64>,
    /// Velocity, m/s.
    pub velocity: Vec<f64>,
    /// Acceleration, m/s².
    pub acceleration: Vec<f64>,
    /// Element force, N.
    pub element_force: Vec<f64>,
    /// The force the drive applies (see [`Sample::drive_force`]), N.
    pub drive_force: Vec<f64>,
}

impl Response {
    /// Empties the buffers, keeping their capacity.
    pub fn clear(&mut self) {
        self.displacement.clear();
        self.velocity.clear();
        self.acceleration.clear();
        self.element_force.clear();
        self.drive_force.clear();
    }

    fn push(&mut self, s: Sample) {
        self.displacement.push(s.displacement);
        self.velocity.push(s.velocity);
        self.acceleration.push(s.acceleration);
        self.element_force.push(s.element_force);
        self.drive_force.push(s.drive_force);
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.displacement.len()
    }

    /// Whether there are no samples.
    pub fn is_empty(&self) -> bool {
        self.displacement.is_empty()
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct ModeState {
    x: [f64; 2],
    v: [f64; 2],
    a: [f64; 2],
    /// This sample's part fixed by the past (scratch).
    pred: [f64; 3],
}

impl ModeState {
    /// The part of this sample's displacement, velocity and acceleration
    /// fixed by the past: every term of the three sections but `b0 u[n]`.
    #[inline(always)]
    fn predicted(&self, f: &ModeFilter, u1: f64, u2: f64) -> [f64; 3] {
        [
            f.displacement.b[1] * u1 + f.displacement.b[2] * u2
                - f.displacement.a[0] * self.x[0]
                - f.displacement.a[1] * self.x[1],
            f.velocity.b[1] * u1 + f.velocity.b[2] * u2
                - f.velocity.a[0] * self.v[0]
                - f.velocity.a[1] * self.v[1],
            f.acceleration.b[1] * u1 + f.acceleration.b[2] * u2
                - f.acceleration.a[0] * self.a[0]
                - f.acceleration.a[1] * self.a[1],
        ]
    }
}

/// Statistics of the implicit solves so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SolveStats {
    /// Samples simulated.
    pub samples: u64,
    /// Element trial evaluations in the iterative solves.
    pub trials: u64,
    /// Samples that needed the bracketing fallback.
    pub bracketed: u64,
}

/// The digital-filter simulator of a modal structure with elements `E`.
#[derive(Clone, Debug)]
pub struct Simulator<E: Element> {
    filters: Vec<ModeFilter>,
    state: Vec<ModeState>,
    /// Net input `u` at n−1 and n−2.
    u: [f64; 2],
    /// Summed direct terms.
    b0: [f64; 3],
    elements: E,
    sample_rate: f64,
    stats: SolveStats,
    /// The hysteretic modes, each its own SDOF with its joint, driven by the
    /// same force, and the sign its contribution takes at the point (see
    /// [`crate::model::modal`]).
    hysteretic: Vec<(f64, Simulator<AnyElement>)>,
    /// The drive's lag between the reference and the structure (a shaker's
    /// coil, [`Element::drive_load`]); off without one.
    drive_lag: Lag,
    /// The drive's blocked force per unit of reference (a shaker's `Bl/R`).
    drive_gain: f64,
    /// What is attached at the drive point (an armature,
    /// [`Element::attachment`]), solved inside each sample; `None`: nothing.
    attached: Option<AttachedSolve>,
    /// The element force's `sinc²` loss compensated
    /// ([`Simulator::with_element_force_compensated`]).
    compensated: bool,
    /// The committed element force at n−1 and n−2 (for the compensation).
    history: [ElementForce; 2],
}

/// An attachment's force `ma a + cs v + ks x` is affine in the sample's net
/// input `u`, as the filters' outputs are: with `s = 1 + ma ba + cs bv +
/// ks bx` (the summed direct terms), `u' = s u` solves the joint's own
/// implicit equation with the direct terms divided by `s` and the
/// attachment's predicted force taken from the drive. `s` and the divided
/// terms are the filters' constants, computed once.
#[derive(Clone, Copy, Debug)]
struct AttachedSolve {
    attachment: Attachment,
    /// `s`.
    scale: f64,
    /// `bx/s`, `bv/s`.
    bx: f64,
    bv: f64,
}

impl AttachedSolve {
    fn new(attachment: Attachment, b0: [f64; 3]) -> AttachedSolve {
        let scale = 1.0
            + attachment.mass * b0[2]
            + attachment.damping * b0[1]
            + attachment.stiffness * b0[0];
        AttachedSolve {
            attachment,
            scale,
            bx: b0[0] / scale,
            bv: b0[1] / scale,
        }
    }

    /// The attachment's force from the filters' past `[x, v, a]`.
    fn predicted_force(&self, pred: [f64; 3]) -> f64 {
        let at = self.attachment;
        at.mass * pred[2] + at.damping * pred[1] + at.stiffness * pred[0]
    }
}

const MAX_NEWTON: usize = 8;
const MAX_BRACKETED: usize = 200;

impl<E: Element> Simulator<E> {
    /// A simulator at rest.
    ///
    /// Errors if the sample rate is not finite and above twice the highest
    /// mode (the filters would alias the modes themselves).
    pub fn new(linear: &ModalModel, elements: E, sample_rate_hz: f64) -> Result<Self> {
        Simulator::with_quasi_static_above(linear, elements, sample_rate_hz, f64::INFINITY)
    }

    /// A simulator at rest whose linear modes above `quasi_static_above_hz`
    /// are taken quasi-static, their flexibility alone
    /// ([`ModeFilter::quasi_static`]): how a replay of a recording carries a
    /// mode the recording cannot show, at any rate (see
    /// [`crate::validate::QUASI_STATIC_ABOVE_RATE`]). The rate must exceed
    /// twice every other mode.
    pub fn with_quasi_static_above(
        linear: &ModalModel,
        mut elements: E,
        sample_rate_hz: f64,
        quasi_static_above_hz: f64,
    ) -> Result<Self> {
        linear.validate()?;
        let quasi_static = |m: &crate::model::Mode| m.is_quasi_static_above(quasi_static_above_hz);
        let top = linear
            .modes
            .iter()
            .filter(|m| !quasi_static(m))
            .map(|m| m.frequency_hz)
            .fold(0.0, f64::max);
        check_rate(sample_rate_hz, top)?;
        let t = 1.0 / sample_rate_hz;
        elements.set_time_step(t);
        let (drive_lag, drive_gain) = match elements.drive_load() {
            Some(load) => (Lag::new(load.time_constant, t), load.gain),
            None => (Lag::default(), 1.0),
        };
        let attached = elements.attachment();
        if attached.is_some() && linear.modes.iter().any(|m| m.is_hysteretic()) {
            return Err(Error::model(
                "armature",
                crate::model::armature::BESIDE_A_HYSTERETIC_MODE,
            ));
        }
        // `elements` act on the point structure; each hysteretic mode is
        // simulated apart with its own joint
        let mut hysteretic = Vec::new();
        for (i, m) in linear.modes.iter().enumerate() {
            if let Some(joint) = &m.joint {
                let (sign, own) = m.own_sdof();
                let element = joint
                    .build()
                    .map_err(|e| Error::model(format!("modes[{i}].joint"), e.to_string()))?;
                hysteretic.push((sign, Simulator::new(&own, element, sample_rate_hz)?));
            }
        }
        let filters: Vec<ModeFilter> = linear
            .modes
            .iter()
            .filter(|m| !m.is_hysteretic())
            .map(|m| {
                if quasi_static(m) {
                    ModeFilter::quasi_static(m, t)
                } else {
                    ModeFilter::new(m, t)
                }
            })
            .collect();
        let b0 = filters.iter().fold([0.0; 3], |acc, f| {
            [
                acc[0] + f.displacement.b[0],
                acc[1] + f.velocity.b[0],
                acc[2] + f.acceleration.b[0],
            ]
        });
        Ok(Simulator {
            state: vec![ModeState::default(); filters.len()],
            filters,
            u: [0.0; 2],
            b0,
            elements,
            sample_rate: sample_rate_hz,
            stats: SolveStats::default(),
            hysteretic,
            drive_lag,
            drive_gain,
            attached: attached.map(|a| AttachedSolve::new(a, b0)),
            compensated: false,
            history: Default::default(),
        })
    }

    /// Places each slip transition inside its sample (the elements that
    /// have one: see [`Element::kink_impulse`]), so that the error against
    /// the continuous model falls as `h²` however the events fall between
    /// samples (4x per halving of the interval on the Jenkins reference case,
    /// `tests/sim.rs`). Off by default: the sampled law's own transition
    /// errors, of either sign by where the event falls, there partly cancel
    /// the filters' `sinc²(f/fs)` loss of the element force, which nothing
    /// compensates yet, so at the bench's rates the default is as close to
    /// the continuous model and the virtual tests keep their figures.
    pub fn with_transitions_located(mut self) -> Self {
        self.elements.set_sample_interval(1.0 / self.sample_rate);
        self.hysteretic = std::mem::take(&mut self.hysteretic)
            .into_iter()
            .map(|(sign, s)| (sign, s.with_transitions_located()))
            .collect();
        self
    }

    /// Compensates the filters' `sinc²(f/fs)` loss of the element force.
    ///
    /// The ramp-invariant filters are exact for an input that runs straight
    /// between samples; the fundamental of a sampled sine so drawn is
    /// `sinc²(f/fs) ≈ 1 − ω²/12` (`ω = 2πf/fs`) of the sine's. A measured
    /// drive is pre-emphasised for it before the run (the zero-phase FIR
    /// `[−1/12, 7/6, −1/12]`, see [`crate::validate::DriveInput`]). The
    /// element force is made inside the loop, so its sample `n − 1` is
    /// pre-emphasised once sample `n` is known: the input the filters took at
    /// `n − 1` is corrected by `−(2 g_{n−1} − g_{n−2} − g_n)/12`, and the
    /// filters' states at `n − 1` and `n` by what that input change makes
    /// of them (`b0 δ` and `(b1 − a1 b0) δ`: they are linear). The outputs
    /// already given for those two samples keep their part of it, `O(h⁴)`;
    /// the recursion carries the rest, which is the loss. A stuck joint then
    /// keeps its whole stiffness in the loop (without it, `kd (ωT)²/12` is
    /// lost: 0.2 % at 40 samples per period, enough to move a lightly
    /// damped resonance by a fraction of its half-power width).
    ///
    /// The pre-emphasis is the band-limited signal's; across a kink of the
    /// element law (a reversal, a slip), where the force is not that, the
    /// sample is left as it is: where the element's tangent stiffness or
    /// damping moves by more than a tenth of its size over the three
    /// samples (beside an attachment, or with a transition located in the
    /// sample, likewise).
    pub fn with_element_force_compensated(mut self) -> Self {
        self.compensated = true;
        self.hysteretic = std::mem::take(&mut self.hysteretic)
            .into_iter()
            .map(|(sign, s)| (sign, s.with_element_force_compensated()))
            .collect();
        self
    }

    /// The pre-emphasis of sample `n − 1`'s element force, applied to the
    /// filters' states once sample `n` (`now`) is committed (see
    /// [`Simulator::with_element_force_compensated`]).
    fn compensate_last(&mut self, now: ElementForce, allowed: bool) {
        let [last, before] = self.history;
        self.history = [now, last];
        let smooth = |a: f64, b: f64, c: f64| {
            let size = a.abs().max(b.abs()).max(c.abs());
            (a - b).abs().max((b - c).abs()) <= 0.1 * size
        };
        if !(allowed
            && self.stats.samples >= 2
            && smooth(now.stiffness, last.stiffness, before.stiffness)
            && smooth(now.damping, last.damping, before.damping))
        {
            return;
        }
        let delta = -(2.0 * last.force - before.force - now.force) / 12.0;
        if delta == 0.0 || !delta.is_finite() {
            return;
        }
        for (f, s) in self.filters.iter().zip(self.state.iter_mut()) {
            for (section, y) in [
                (&f.displacement, &mut s.x),
                (&f.velocity, &mut s.v),
                (&f.acceleration, &mut s.a),
            ] {
                y[1] += section.b[0] * delta;
                y[0] += (section.b[1] - section.a[0] * section.b[0]) * delta;
            }
        }
        self.u[1] += delta;
    }

    /// Sample rate, Hz.
    pub fn sample_rate(&self) -> f64 {
        self.sample_rate
    }

    /// The elements (with their current state).
    pub fn elements(&self) -> &E {
        &self.elements
    }

    /// Solve statistics so far (the point structure's; a hysteretic mode's
    /// own solves are its sub-simulator's).
    pub fn stats(&self) -> SolveStats {
        self.stats
    }

    /// Back to rest: filter states zero, elements virgin.
    pub fn reset(&mut self) {
        self.state
            .iter_mut()
            .for_each(|s| *s = ModeState::default());
        self.u = [0.0; 2];
        self.history = Default::default();
        self.elements.reset();
        self.drive_lag.reset();
        self.hysteretic.iter_mut().for_each(|(_, s)| s.reset());
    }

    /// Advances one sample under external force `force` (N).
    #[inline]
    pub fn step(&mut self, force: f64) -> Result<Sample> {
        let mut out = Sample::default();
        self.drive(1, |_| force, |_, s| out = s)?;
        Ok(out)
    }

    #[cold]
    fn bad_force(&self, force: f64) -> Error {
        Error::input(
            format!("force sample {}", self.stats.samples),
            format!("must be finite, got {force}"),
        )
    }

    /// Several modes: outputs are sums over the modes' own sections.
    fn step_modal(&mut self, force: f64) -> Result<Sample> {
        if !force.is_finite() {
            return Err(self.bad_force(force));
        }
        let applied = force;
        let (u1, u2) = (self.u[0], self.u[1]);
        let mut pred = [0.0; 3];
        for (f, s) in self.filters.iter().zip(self.state.iter_mut()) {
            s.pred = s.predicted(f, u1, u2);
            pred[0] += s.pred[0];
            pred[1] += s.pred[1];
            pred[2] += s.pred[2];
        }
        // an attachment is solved with the joint (see `AttachedSolve`)
        let (force, bx, bv, scale) = match &self.attached {
            Some(at) => (force - at.predicted_force(pred), at.bx, at.bv, at.scale),
            None => (force, self.b0[0], self.b0[1], 1.0),
        };
        let step = ImplicitStep {
            x_pred: pred[0],
            v_pred: pred[1],
            bx,
            bv,
            force,
        };
        let u_scaled = match self.elements.solve_implicit(&step) {
            Some(u) => u,
            None => solve_iteratively(
                &self.elements,
                &mut self.stats,
                &step,
                scale * (2.0 * u1 - u2),
            )?,
        };
        let x = step.x_pred + step.bx * u_scaled;
        let v = step.v_pred + step.bv * u_scaled;
        let committed = self.elements.commit(x, v);
        let g = committed.force;
        // the filters carry a kink inside the sample as a hat of its area
        // (the outputs at the sample are those of the sampled input)
        let kink = self.elements.kink_impulse() * self.sample_rate;
        let (u, uf) = match self.attached {
            Some(_) => (u_scaled / scale, (u_scaled - kink) / scale),
            None => (u_scaled, u_scaled - kink),
        };
        let a = pred[2] + self.b0[2] * u;
        for (f, s) in self.filters.iter().zip(self.state.iter_mut()) {
            s.x = [s.pred[0] + f.displacement.b[0] * uf, s.x[0]];
            s.v = [s.pred[1] + f.velocity.b[0] * uf, s.v[0]];
            s.a = [s.pred[2] + f.acceleration.b[0] * uf, s.a[0]];
        }
        self.u = [uf, u1];
        if self.compensated {
            self.compensate_last(committed, kink == 0.0 && self.attached.is_none());
        }
        self.stats.samples += 1;
        Ok(Sample {
            displacement: x,
            velocity: v,
            acceleration: a,
            element_force: g,
            drive_force: applied - self.elements.drive_reaction(),
        })
    }

    /// Drives `n` samples from `input(i)` into `sink(i, sample)`. The SDOF
    /// case keeps the filter state in locals for the whole block (a store and
    /// reload through memory each sample would sit on the recursion's
    /// critical path).
    #[inline(always)]
    fn drive(
        &mut self,
        n: usize,
        mut input: impl FnMut(usize) -> f64,
        mut sink: impl FnMut(usize, Sample),
    ) -> Result<()> {
        if self.drive_lag.is_on() || !self.hysteretic.is_empty() {
            // (an attachment is solved in `step_modal`, the path below)
            // the point structure and every hysteretic mode, sample by
            // sample: their motions add, and so do their joints' forces;
            // all are driven through the drive's lag, if any (a shaker's,
            // whose back-EMF is the point structure's element: `Shaker`)
            for i in 0..n {
                let mut force = input(i);
                if self.drive_lag.is_on() {
                    if !force.is_finite() {
                        return Err(self.bad_force(force));
                    }
                    force = self.drive_gain * self.drive_lag.commit(force);
                }
                let mut s = self.step_modal(force)?;
                for (sign, mode) in &mut self.hysteretic {
                    let m = mode.step(force)?;
                    s.displacement += *sign * m.displacement;
                    s.velocity += *sign * m.velocity;
                    s.acceleration += *sign * m.acceleration;
                    s.element_force += m.element_force;
                }
                sink(i, s);
            }
            return Ok(());
        }
        // (the element force's compensation lives in the general path: a
        // first form of it written into this loop gave other results at
        // opt-level 3 than at 0 with rustc 1.95, a cause not found)
        if self.filters.len() != 1 || self.attached.is_some() || self.compensated {
            for i in 0..n {
                let s = self.step_modal(input(i))?;
                sink(i, s);
            }
            return Ok(());
        }
        let f = self.filters[0];
        let mut st = self.state[0];
        let [mut u1, mut u2] = self.u;
        let b0 = self.b0;
        let fs = self.sample_rate;
        let mut result = Ok(());
        for i in 0..n {
            let force = input(i);
            if !force.is_finite() {
                result = Err(self.bad_force(force));
                break;
            }
            let pred = st.predicted(&f, u1, u2);
            let step = ImplicitStep {
                x_pred: pred[0],
                v_pred: pred[1],
                bx: b0[0],
                bv: b0[1],
                force,
            };
            let u = match self.elements.solve_implicit(&step) {
                Some(u) => u,
                None => {
                    match solve_iteratively(&self.elements, &mut self.stats, &step, 2.0 * u1 - u2) {
                        Ok(u) => u,
                        Err(e) => {
                            result = Err(e);
                            break;
                        }
                    }
                }
            };
            let x = step.x_pred + step.bx * u;
            let v = step.v_pred + step.bv * u;
            let g = self.elements.commit(x, v).force;
            let a = pred[2] + b0[2] * u;
            let kink = self.elements.kink_impulse();
            if kink == 0.0 {
                st.x = [x, st.x[0]];
                st.v = [v, st.v[0]];
                st.a = [a, st.a[0]];
                (u2, u1) = (u1, u);
            } else {
                // the filter carries a kink inside the sample as a hat of
                // its area; the outputs at the sample are the sampled input's
                let uf = u - kink * fs;
                st.x = [pred[0] + b0[0] * uf, st.x[0]];
                st.v = [pred[1] + b0[1] * uf, st.v[0]];
                st.a = [pred[2] + b0[2] * uf, st.a[0]];
                (u2, u1) = (u1, uf);
            }
            self.stats.samples += 1;
            sink(
                i,
                Sample {
                    displacement: x,
                    velocity: v,
                    acceleration: a,
                    element_force: g,
                    drive_force: force,
                },
            );
        }
        self.state[0] = st;
        self.u = [u1, u2];
        result
    }

    /// Runs a block of force samples, appending to `out`.
    pub fn run_into(&mut self, force: &[f64], out: &mut Response) -> Result<()> {
        out.displacement.reserve(force.len());
        out.velocity.reserve(force.len());
        out.acceleration.reserve(force.len());
        out.element_force.reserve(force.len());
        self.drive(force.len(), |i| force[i], |_, s| out.push(s))
    }

    /// Runs a block of force samples a stretch of
    /// [`SAMPLES_PER_REPORT`](crate::observe::SAMPLES_PER_REPORT) at a time,
    /// telling `observer` after each and stopping there if it asks (the
    /// state then stands where the last stretch left it); the same bits as
    /// one stretch.
    pub fn run(&mut self, force: &[f64], observer: &dyn Observer) -> Result<Response> {
        let mut out = Response::default();
        in_stretches(force.len(), observer, |range| {
            self.run_into(&force[range], &mut out)
        })?;
        Ok(out)
    }

    /// Runs `n` samples of a force generator `force(i)` (i counts from 0 in
    /// this call), appending to `out`.
    pub fn run_generator(
        &mut self,
        n: usize,
        force: impl FnMut(usize) -> f64,
        out: &mut Response,
    ) -> Result<()> {
        self.drive(n, force, |_, s| out.push(s))
    }

    /// Runs a block writing displacement only into `x` (the fast path for
    /// benchmarks and long runs that need one output).
    ///
    /// # Panics
    /// If `x.len() != force.len()`.
    pub fn run_displacement(&mut self, force: &[f64], x: &mut [f64]) -> Result<()> {
        assert_eq!(
            force.len(),
            x.len(),
            "output length must equal input length"
        );
        self.drive(force.len(), |i| force[i], |i, s| x[i] = s.displacement)
    }

    /// Runs a block writing one output into `out` (no allocation), a
    /// stretch at a time, reporting `simulating` progress to `observer` and
    /// stopping if it asks (the same bits as one stretch).
    ///
    /// # Panics
    /// If `out.len() != force.len()`.
    pub fn run_output(
        &mut self,
        force: &[f64],
        output: Output,
        out: &mut [f64],
        observer: &dyn Observer,
    ) -> Result<()> {
        assert_eq!(
            force.len(),
            out.len(),
            "output length must equal input length"
        );
        in_stretches(force.len(), observer, |range| {
            self.run_output_stretch(&force[range.clone()], output, &mut out[range])
        })
    }

    /// One stretch of [`Simulator::run_output`].
    fn run_output_stretch(&mut self, force: &[f64], output: Output, out: &mut [f64]) -> Result<()> {
        let n = force.len();
        match output {
            Output::Displacement => self.drive(n, |i| force[i], |i, s| out[i] = s.displacement),
            Output::Velocity => self.drive(n, |i| force[i], |i, s| out[i] = s.velocity),
            Output::Acceleration => self.drive(n, |i| force[i], |i, s| out[i] = s.acceleration),
            Output::ElementForce => self.drive(n, |i| force[i], |i, s| out[i] = s.element_force),
        }
    }

    /// Runs a block into caller-provided slices (no allocation).
    ///
    /// # Panics
    /// If any output's length differs from `force.len()`.
    pub fn run_slices(&mut self, force: &[f64], out: SliceOutputs<'_>) -> Result<()> {
        let n = force.len();
        assert!(
            out.displacement.len() == n
                && out.velocity.len() == n
                && out.acceleration.len() == n
                && out.element_force.len() == n,
            "output lengths must equal the input length"
        );
        self.drive(
            n,
            |i| force[i],
            |i, s| {
                out.displacement[i] = s.displacement;
                out.velocity[i] = s.velocity;
                out.acceleration[i] = s.acceleration;
                out.element_force[i] = s.element_force;
            },
        )
    }
}

/// One time history of a run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Output {
    /// Displacement, m.
    Displacement,
    /// Velocity, m/s.
    Velocity,
    /// Acceleration, m/s².
    Acceleration,
    /// Total element force `g`, N.
    ElementForce,
}

impl Output {
    /// Every output, in [`Sample`]'s order.
    pub const ALL: [Output; 4] = [
        Output::Displacement,
        Output::Velocity,
        Output::Acceleration,
        Output::ElementForce,
    ];

    /// The name of the output (as [`Response`]'s field).
    pub fn name(self) -> &'static str {
        match self {
            Output::Displacement => "displacement",
            Output::Velocity => "velocity",
            Output::Acceleration => "acceleration",
            Output::ElementForce => "element_force",
        }
    }

    /// The output of a name.
    pub fn from_name(name: &str) -> Option<Output> {
        Output::ALL.into_iter().find(|o| o.name() == name)
    }
}

/// `model` driven from rest by `force` sampled at `sample_rate_hz`: one
/// output, sample for sample (the whole run in one call, as a script
/// drives it), reporting `simulating` progress to `observer` every
/// [`SAMPLES_PER_REPORT`](crate::observe::SAMPLES_PER_REPORT) samples and
/// stopping there if it asks ([`crate::Error::Cancelled`]). The same bits
/// as one call: the simulator carries its state from stretch to stretch.
///
/// Errors: the model's and the sample rate's (see [`Simulator::new`]), and
/// a sample whose implicit solve fails.
pub fn simulate(
    model: &Model,
    force: &[f64],
    sample_rate_hz: f64,
    output: Output,
    observer: &dyn Observer,
) -> Result<Vec<f64>> {
    model.validate()?;
    let mut sim = Simulator::new(&model.linear, model.element_set()?, sample_rate_hz)?;
    let mut out = vec![0.0; force.len()];
    sim.run_output(force, output, &mut out, observer)?;
    Ok(out)
}

/// `model` driven from rest by `force` sampled at `sample_rate_hz`: every
/// output ([`simulate`] for one), observed as [`simulate`] is.
pub fn simulate_all(
    model: &Model,
    force: &[f64],
    sample_rate_hz: f64,
    observer: &dyn Observer,
) -> Result<Response> {
    model.validate()?;
    Simulator::new(&model.linear, model.element_set()?, sample_rate_hz)?.run(force, observer)
}

/// Runs `stretch` over `0..n` in stretches of
/// [`SAMPLES_PER_REPORT`](crate::observe::SAMPLES_PER_REPORT), telling
/// `observer` after each and stopping there if it asks.
fn in_stretches(
    n: usize,
    observer: &dyn Observer,
    mut stretch: impl FnMut(std::ops::Range<usize>) -> Result<()>,
) -> Result<()> {
    let mut done = 0;
    while done < n {
        let end = (done + crate::observe::SAMPLES_PER_REPORT).min(n);
        stretch(done..end)?;
        done = end;
        crate::observe::progress(observer, "simulating", done as u64, n as u64)?;
    }
    Ok(())
}

/// Caller-owned output slices for [`Simulator::run_slices`].
#[derive(Debug)]
pub struct SliceOutputs<'a> {
    /// Displacement, m.
    pub displacement: &'a mut [f64],
    /// Velocity, m/s.
    pub velocity: &'a mut [f64],
    /// Acceleration, m/s².
    pub acceleration: &'a mut [f64],
    /// Element force, N.
    pub element_force: &'a mut [f64],
}

/// Newton on `R(u) = u − F + g(x_p + bx u, v_p + bv u)`, started from
/// `guess` (the linear extrapolation of the last two inputs); falls back to a
/// bracketed Newton–bisection when Newton does not settle (kinks, softening).
/// An error unless `sample_rate_hz` exceeds twice the highest mode `top`
/// (the filters would alias the modes themselves).
fn check_rate(sample_rate_hz: f64, top: f64) -> Result<()> {
    if sample_rate_hz.is_finite() && sample_rate_hz > 2.0 * top {
        return Ok(());
    }
    Err(Error::model(
        "sample_rate_hz",
        format!(
            "must exceed twice the highest mode ({top:.6} Hz), got {sample_rate_hz} Hz; use at \
             least 10x (50x and more for stiff joints)"
        ),
    ))
}

fn solve_iteratively<E: Element>(
    e: &E,
    stats: &mut SolveStats,
    s: &ImplicitStep,
    guess: f64,
) -> Result<f64> {
    let mut u = guess;
    for _ in 0..MAX_NEWTON {
        let g = e.trial(s.x_pred + s.bx * u, s.v_pred + s.bv * u);
        stats.trials += 1;
        let r = u - s.force + g.force;
        let tol = SOLVE_TOLERANCE * (s.force.abs() + g.force.abs() + u.abs()) + f64::MIN_POSITIVE;
        if r.abs() <= tol {
            return Ok(u);
        }
        let dr = 1.0 + s.bx * g.stiffness + s.bv * g.damping;
        if !(dr > 0.0 && dr.is_finite()) {
            break;
        }
        u -= r / dr;
    }
    stats.bracketed += 1;
    solve_bracketed(e, stats.samples, s, u)
}

fn solve_bracketed<E: Element>(e: &E, sample: u64, s: &ImplicitStep, u0: f64) -> Result<f64> {
    let res = |u: f64| {
        let g = e.trial(s.x_pred + s.bx * u, s.v_pred + s.bv * u);
        (
            u - s.force + g.force,
            1.0 + s.bx * g.stiffness + s.bv * g.damping,
            g.force,
        )
    };
    let (r0, _, _) = res(u0);
    if r0 == 0.0 {
        return Ok(u0);
    }
    // expand until the sign changes
    let mut width = r0.abs().max(1e-12 * (s.force.abs() + u0.abs()) + 1e-300);
    let (mut lo, mut hi) = (u0, u0);
    let mut found = false;
    for _ in 0..200 {
        let other = if r0 > 0.0 { u0 - width } else { u0 + width };
        let (r, _, _) = res(other);
        if r.is_nan() {
            break;
        }
        if (r > 0.0) != (r0 > 0.0) || r == 0.0 {
            (lo, hi) = if r0 > 0.0 { (other, u0) } else { (u0, other) };
            found = true;
            break;
        }
        width *= 2.0;
    }
    if !found {
        return Err(Error::NotConverged {
            stage: "implicit sample solve",
            reason: format!(
                "no sign change of the element feedback residual near u = {u0:e} N at sample {sample} \
                 (the element force may decrease faster than the structure can follow)"
            ),
        });
    }
    let mut u = 0.5 * (lo + hi);
    for _ in 0..MAX_BRACKETED {
        let (r, dr, g) = res(u);
        let tol = SOLVE_TOLERANCE * (s.force.abs() + g.abs() + u.abs()) + f64::MIN_POSITIVE;
        if r.abs() <= tol || (hi - lo) <= tol {
            return Ok(u);
        }
        if r > 0.0 {
            hi = u;
        } else {
            lo = u;
        }
        let newton = u - r / dr;
        u = if dr > 0.0 && newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
    }
    Err(Error::NotConverged {
        stage: "implicit sample solve",
        reason: format!("bracket [{lo:e}, {hi:e}] N did not shrink at sample {sample}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ElementSpec;
    use crate::observe::Silent;

    /// The paper's SDOF with a Jenkins joint.
    fn paper_jenkins() -> Model {
        Model::new(
            ModalModel::sdof(10.0, 200.0, 1e7).unwrap(),
            vec![ElementSpec::Jenkins {
                kd: 2.4e7,
                fd: 246.048,
            }],
        )
        .unwrap()
    }

    /// [`simulate`] is the simulator's run, one output at a time.
    #[test]
    fn simulate_gives_each_output_of_a_run() {
        let model = paper_jenkins();
        let fs = 50_000.0;
        let force: Vec<f64> = (0..20_000)
            .map(|i| 400.0 * (2.0 * std::f64::consts::PI * 150.0 * i as f64 / fs).sin())
            .collect();
        let all = simulate_all(&model, &force, fs, &Silent).unwrap();
        let mut sim = Simulator::new(&model.linear, model.element_set().unwrap(), fs).unwrap();
        assert_eq!(sim.run(&force, &Silent).unwrap(), all);
        for (o, expected) in Output::ALL.into_iter().zip([
            &all.displacement,
            &all.velocity,
            &all.acceleration,
            &all.element_force,
        ]) {
            assert_eq!(
                &simulate(&model, &force, fs, o, &Silent).unwrap(),
                expected,
                "{o:?}"
            );
            assert_eq!(Output::from_name(o.name()), Some(o));
        }
        // the joint slips: its force reaches Fd and no further
        let peak = all.element_force.iter().fold(0.0f64, |m, g| m.max(g.abs()));
        assert!((peak / 246.048 - 1.0).abs() < 1e-9, "{peak}");
        let e = simulate(&model, &force, 100.0, Output::Displacement, &Silent).unwrap_err();
        assert!(
            e.to_string().contains("must exceed twice the highest mode"),
            "{e}"
        );
    }

    /// A run in stretches (as an observed simulation makes it) is the same
    /// bits as one run, with the element force compensated and the slip
    /// transitions located too (both carry state from sample to sample);
    /// progress is told after each stretch, and an observer that asks stops
    /// the run at the next.
    #[test]
    fn an_observed_run_is_one_run_told_in_stretches() {
        use crate::observe::{Event, Observer, SAMPLES_PER_REPORT};
        use std::sync::Mutex;
        struct Told(Mutex<Vec<(u64, u64)>>, usize);
        impl Observer for Told {
            fn observe(&self, e: Event<'_>) {
                if let Event::Progress { task, done, total } = e {
                    assert_eq!(task, "simulating");
                    self.0.lock().unwrap().push((done, total));
                }
            }
            fn cancelled(&self) -> bool {
                self.0.lock().unwrap().len() >= self.1
            }
        }
        let model = paper_jenkins();
        let fs = 50_000.0;
        // two whole stretches and a part: the joint slips in every one
        let n = 2 * SAMPLES_PER_REPORT + 1234;
        let force: Vec<f64> = (0..n)
            .map(|i| 400.0 * (2.0 * std::f64::consts::PI * 150.0 * i as f64 / fs).sin())
            .collect();
        let fresh = || Simulator::new(&model.linear, model.element_set().unwrap(), fs).unwrap();
        let build = |variant: usize| match variant {
            0 => fresh(),
            1 => fresh().with_element_force_compensated(),
            _ => fresh().with_transitions_located(),
        };
        for (variant, name) in ["plain", "compensated", "located"].iter().enumerate() {
            let mut whole = vec![0.0; n];
            build(variant)
                .run_output_stretch(&force, Output::Velocity, &mut whole)
                .unwrap();
            let told = Told(Mutex::new(Vec::new()), usize::MAX);
            let mut parts = vec![0.0; n];
            build(variant)
                .run_output(&force, Output::Velocity, &mut parts, &told)
                .unwrap();
            assert!(
                whole
                    .iter()
                    .zip(&parts)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{name}"
            );
            let s = SAMPLES_PER_REPORT as u64;
            let n = n as u64;
            assert_eq!(*told.0.lock().unwrap(), [(s, n), (2 * s, n), (n, n)]);
        }
        let mut all = Response::default();
        fresh().run_into(&force, &mut all).unwrap();
        let told = Told(Mutex::new(Vec::new()), usize::MAX);
        assert_eq!(simulate_all(&model, &force, fs, &told).unwrap(), all);
        assert_eq!(told.0.lock().unwrap().len(), 3);
        // asked to stop after the first stretch: the second is not run
        let stop = Told(Mutex::new(Vec::new()), 1);
        let e = simulate(&model, &force, fs, Output::Displacement, &stop).unwrap_err();
        assert!(matches!(e, crate::Error::Cancelled), "{e}");
        assert_eq!(stop.0.lock().unwrap().len(), 1);
    }
}
