//! Integration tests: the digital-filter simulator against independent
//! references (issue 2).

use hystid::harmonics::{Quantity, omega, sinc};
use hystid::model::{
    AnyElement, Element, ElementSet, ElementSpec, Jenkins, ModalModel, Mode, NoElement,
};
use hystid::sim::{ModeFilter, Simulator};
use num_complex::Complex64;
use std::f64::consts::PI;

const M: f64 = 10.0;
const C: f64 = 200.0;
const K: f64 = 1.0e7;
const KD: f64 = 2.4e7;
const FD: f64 = 246.048;

/// Fundamental (single-sided complex amplitude) of `x` over whole periods of
/// `p` samples by a direct sum, the last `periods` periods.
fn fundamental(x: &[f64], p: usize, periods: usize) -> Complex64 {
    let n = p * periods;
    let start = x.len() - n;
    let mut s = Complex64::new(0.0, 0.0);
    for (i, &xi) in x[start..].iter().enumerate() {
        let th = 2.0 * PI * ((start + i) % p) as f64 / p as f64;
        s += xi * Complex64::from_polar(1.0, -th);
    }
    s * 2.0 / n as f64
}

/// Steady-state response to `cos(2π f t)` sampled at `fs = p f`.
fn linear_steady_state(p: usize, f: f64) -> [Complex64; 3] {
    let fs = p as f64 * f;
    let model = ModalModel::sdof(M, C, K).unwrap();
    let mut sim = Simulator::new(&model, NoElement, fs).unwrap();
    // transients decay as e^{-c/(2m) t} = e^{-10 t}: 3 s leaves 1e-13
    let n = ((3.0 * fs) as usize / p + 4) * p;
    let force: Vec<f64> = (0..n)
        .map(|i| (2.0 * PI * (i % p) as f64 / p as f64).cos())
        .collect();
    let r = sim.run(&force, &hystid::observe::Silent).unwrap();
    [
        fundamental(&r.displacement, p, 4),
        fundamental(&r.velocity, p, 4),
        fundamental(&r.acceleration, p, 4),
    ]
}

/// The exact response of a ramp-invariant filter: the continuous FRF's
/// sinc²-weighted alias sum `Σ_k H(f + k fs) sinc²(f/fs + k)`. The accelerance's
/// direct term `1/m` passes unweighted (`Σ_k sinc²(u + k) = 1`), so only the
/// strictly proper rest is summed.
fn alias_sum(h_rest: impl Fn(f64) -> Complex64, direct: f64, f: f64, fs: f64) -> Complex64 {
    let mut s = Complex64::new(direct, 0.0);
    for k in -4000i32..=4000 {
        let fk = f + k as f64 * fs;
        s += h_rest(omega(fk)) * sinc(fk / fs).powi(2);
    }
    s
}

#[test]
fn linear_steady_state_is_the_receptance_times_sinc_squared() {
    // fs = 51.2 kHz, 322 samples per natural period
    let fs = 51200.0;
    let model = ModalModel::sdof(M, C, K).unwrap();
    let mut worst: f64 = 0.0;
    for p in [2560usize, 512, 322, 320, 200, 100] {
        let f = fs / p as f64;
        let w = omega(f);
        let got = linear_steady_state(p, f);
        let bias = sinc(f / fs).powi(2);
        // displacement and velocity: H·sinc² (their aliases are below 1e-6 here)
        for (i, q) in [Quantity::Displacement, Quantity::Velocity]
            .into_iter()
            .enumerate()
        {
            let expected = model.frf(q, w) * bias;
            let rel = (got[i] / expected - 1.0).norm();
            worst = worst.max(rel);
            assert!(
                rel < 1e-4,
                "{q} at {f:.2} Hz: {} vs {} (rel {rel:.2e})",
                got[i],
                expected
            );
        }
        // acceleration: the mass line 1/m is a direct term that the ramp-invariant
        // transform passes exactly (no sinc² factor); with it the alias sum is the reference
        let rest = |w: f64| model.frf(Quantity::Acceleration, w) - 1.0 / M;
        let expected = alias_sum(rest, 1.0 / M, f, fs);
        let rel = (got[2] / expected - 1.0).norm();
        worst = worst.max(rel);
        assert!(
            rel < 1e-4,
            "acceleration at {f:.2} Hz: {} vs {} (rel {rel:.2e})",
            got[2],
            expected
        );
    }
    eprintln!("linear steady state: worst relative error {worst:.2e} (limit 1e-4)");
}

#[test]
fn static_gain_is_exactly_one_over_k() {
    let model = ModalModel::sdof(M, C, K).unwrap();
    let mut sim = Simulator::new(&model, NoElement, 30000.0).unwrap();
    let r = sim
        .run(&vec![1000.0; 120_000], &hystid::observe::Silent)
        .unwrap();
    let x = *r.displacement.last().unwrap();
    assert!(
        (x * K / 1000.0 - 1.0).abs() < 1e-10,
        "x k / F = {}",
        x * K / 1000.0
    );
    let f = ModeFilter::new(&Mode::from_mck(M, C, K).unwrap(), 1.0 / 30000.0);
    assert!((f.displacement.static_gain() * K - 1.0).abs() < 1e-12);
}

/// Simulates the paper-like SDOF with a Jenkins element under `F0 cos(2π f t)`
/// at `p` samples per excitation period, to steady state.
fn jenkins_run(f0: f64, f: f64, p: usize, seconds: f64) -> hystid::sim::Response {
    jenkins_run_with(f0, f, p, seconds, false)
}

/// [`jenkins_run`], with the slip transitions `located` inside their samples
/// or not.
fn jenkins_run_with(
    f0: f64,
    f: f64,
    p: usize,
    seconds: f64,
    located: bool,
) -> hystid::sim::Response {
    let fs = p as f64 * f;
    let model = ModalModel::sdof(M, C, K).unwrap();
    let mut sim = Simulator::new(&model, Jenkins::new(KD, FD).unwrap(), fs).unwrap();
    if located {
        sim = sim.with_transitions_located();
    }
    let n = ((seconds * fs) as usize / p + 1) * p;
    sim.run_generator(
        n,
        |i| f0 * (2.0 * PI * (i % p) as f64 / p as f64).cos(),
        &mut Default::default(),
    )
    .unwrap();
    let mut out = hystid::sim::Response::default();
    sim.run_generator(
        4 * p,
        |i| f0 * (2.0 * PI * (i % p) as f64 / p as f64).cos(),
        &mut out,
    )
    .unwrap();
    out
}

#[test]
fn jenkins_loop_in_the_simulation_has_the_closed_form_energy_and_slopes() {
    // transition regime: 500 N at 250 Hz
    let p = 400;
    let r = jenkins_run(500.0, 250.0, p, 2.0);
    let x = &r.displacement[..p + 1];
    let g = &r.element_force[..p + 1];
    let a = (x.iter().cloned().fold(f64::MIN, f64::max)
        - x.iter().cloned().fold(f64::MAX, f64::min))
        / 2.0;
    assert!(a > 2.0 * FD / KD, "the element must slip: a = {a:e}");
    let mut w = 0.0;
    for i in 0..p {
        w += 0.5 * (g[i] + g[i + 1]) * (x[i + 1] - x[i]);
    }
    let exact = 4.0 * FD * (a - FD / KD);
    let rel = w / exact - 1.0;
    eprintln!(
        "Jenkins energy per cycle {w:.6e} J vs 4 Fd (a - Fd/kd) = {exact:.6e} J ({:+.3} %)",
        100.0 * rel
    );
    assert!(rel.abs() < 0.005);
    // slopes: kd while sticking, 0 (|g| = Fd) while slipping
    for i in 0..p {
        let dx = x[i + 1] - x[i];
        let dg = g[i + 1] - g[i];
        if g[i].abs() < 0.99 * FD && g[i + 1].abs() < 0.99 * FD {
            assert!((dg / dx / KD - 1.0).abs() < 1e-6, "stick slope at {i}");
        }
        if g[i].abs() == FD && g[i + 1].abs() == FD {
            assert_eq!(dg, 0.0, "slip slope at {i}");
        }
    }
}

/// Event-located RK4 reference for `m x'' + c x' + k x + g = F0 cos(ωt)` with
/// a Jenkins element (stick: g = kd (x − x_s); slip: g = ±Fd until the
/// velocity reverses). Returns x at the instants `t0 + n/fs`.
struct Rk4Jenkins {
    f0: f64,
    w: f64,
    t: f64,
    x: f64,
    v: f64,
    stick: bool,
    slider: f64,
    slip_sign: f64,
}

impl Rk4Jenkins {
    fn g(&self, x: f64) -> f64 {
        if self.stick {
            KD * (x - self.slider)
        } else {
            self.slip_sign * FD
        }
    }
    fn accel(&self, t: f64, x: f64, v: f64) -> f64 {
        (self.f0 * (self.w * t).cos() - C * v - K * x - self.g(x)) / M
    }
    fn rk4(&self, h: f64) -> (f64, f64) {
        let (t, x, v) = (self.t, self.x, self.v);
        let k1x = v;
        let k1v = self.accel(t, x, v);
        let k2x = v + 0.5 * h * k1v;
        let k2v = self.accel(t + 0.5 * h, x + 0.5 * h * k1x, k2x);
        let k3x = v + 0.5 * h * k2v;
        let k3v = self.accel(t + 0.5 * h, x + 0.5 * h * k2x, k3x);
        let k4x = v + h * k3v;
        let k4v = self.accel(t + h, x + h * k3x, k4x);
        (
            x + h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x),
            v + h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v),
        )
    }
    /// Event function: crosses below zero when the mode must switch.
    fn event(&self, x: f64, v: f64) -> f64 {
        if self.stick {
            FD - (KD * (x - self.slider)).abs()
        } else {
            self.slip_sign * v
        }
    }
    fn advance(&mut self, mut h: f64) {
        while h > 0.0 {
            let (x1, v1) = self.rk4(h);
            if self.event(x1, v1) >= 0.0 {
                (self.t, self.x, self.v) = (self.t + h, x1, v1);
                return;
            }
            // locate the switch by bisection on the step
            let (mut lo, mut hi) = (0.0, h);
            while hi - lo > 1e-15 {
                let mid = 0.5 * (lo + hi);
                let (xm, vm) = self.rk4(mid);
                if self.event(xm, vm) >= 0.0 {
                    lo = mid
                } else {
                    hi = mid
                }
            }
            let (xe, ve) = self.rk4(hi);
            (self.t, self.x, self.v) = (self.t + hi, xe, ve);
            if self.stick {
                self.slip_sign = if KD * (xe - self.slider) > 0.0 {
                    1.0
                } else {
                    -1.0
                };
                self.stick = false;
            } else {
                self.slider = xe - self.slip_sign * FD / KD;
                self.stick = true;
            }
            h -= hi;
        }
    }
}

/// The reference fundamental of x at steady state (400 instants a period,
/// 20 RK4 steps each: h = 1/(8000 f) = 0.5 µs at 250 Hz).
fn rk4_fundamental(f0: f64, f: f64, seconds: f64) -> Complex64 {
    fundamental(&rk4_history(f0, f, seconds, 400, 20, 4), 400, 4)
}

#[test]
fn jenkins_system_matches_an_event_located_rk4_reference() {
    // stick (50 N), transition (300 N), slip dominated (3000 N) at 250 Hz;
    // stick natural frequency 293.4 Hz
    let f = 250.0;
    let f_stick = ((K + KD) / M).sqrt() / (2.0 * PI);
    for f0 in [50.0, 300.0, 3000.0] {
        let reference = rk4_fundamental(f0, f, 2.0);
        for (per_stick_period, limit) in [(50.0, 3e-3), (200.0, 5e-4)] {
            let p = (per_stick_period * f_stick / f).round() as usize;
            let r = jenkins_run(f0, f, p, 2.0);
            let got = fundamental(&r.displacement, p, 4);
            let rel = (got / reference - 1.0).norm();
            eprintln!(
                "F0 = {f0} N, {:.1} samples per stick period: |X1| {:.6e} vs RK4 {:.6e}, rel. error {rel:.2e} (limit {limit:.0e})",
                p as f64 * f / f_stick,
                got.norm(),
                reference.norm()
            );
            assert!(rel < limit);
        }
    }
}

#[test]
fn one_sample_delay_feedback_is_much_worse_than_the_implicit_solve() {
    // the design choice in sim's module docs: explicit u[n] = F[n] − g[n−1]
    // acts as negative damping ≈ kd T
    let f = 250.0;
    let p = 100usize;
    let fs = p as f64 * f;
    let reference = rk4_fundamental(200.0, f, 2.0);
    let implicit = fundamental(&jenkins_run(200.0, f, p, 2.0).displacement, p, 4);
    let filt = ModeFilter::new(&Mode::from_mck(M, C, K).unwrap(), 1.0 / fs).displacement;
    let mut j = Jenkins::new(KD, FD).unwrap();
    let (mut x1, mut x2, mut u1, mut u2, mut g_prev) = (0.0, 0.0, 0.0, 0.0, 0.0);
    let n = (2.0 * fs) as usize / p * p + 4 * p;
    let mut xs = Vec::with_capacity(n);
    for i in 0..n {
        let u = 200.0 * (2.0 * PI * (i % p) as f64 / p as f64).cos() - g_prev;
        let x = filt.b[0] * u + filt.b[1] * u1 + filt.b[2] * u2 - filt.a[0] * x1 - filt.a[1] * x2;
        g_prev = j.commit(x, 0.0).force;
        (x2, x1, u2, u1) = (x1, x, u1, u);
        xs.push(x);
    }
    let explicit = fundamental(&xs, p, 4);
    let e_imp = (implicit / reference - 1.0).norm();
    let e_exp = (explicit / reference - 1.0).norm();
    eprintln!(
        "at {p} samples/period: implicit error {e_imp:.2e}, one-sample delay error {e_exp:.2e}"
    );
    assert!(e_exp > 20.0 * e_imp);
}

#[test]
fn masing_with_large_n_simulates_like_jenkins() {
    let fs = 250.0 * 200.0;
    let model = ModalModel::sdof(M, C, K).unwrap();
    let run = |spec: ElementSpec| {
        let mut sim =
            Simulator::new(&model, ElementSet::new(vec![spec.build().unwrap()]), fs).unwrap();
        let force: Vec<f64> = (0..(fs as usize))
            .map(|i| 400.0 * (2.0 * PI * 250.0 * i as f64 / fs).cos())
            .collect();
        sim.run(&force, &hystid::observe::Silent).unwrap()
    };
    let a = run(ElementSpec::Jenkins { kd: KD, fd: FD });
    let b = run(ElementSpec::Masing {
        kd: KD,
        fd: FD,
        n: 1000.0,
    });
    let worst = a
        .element_force
        .iter()
        .zip(&b.element_force)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(worst < 0.01 * FD, "element forces differ by {worst} N");
}

#[test]
fn state_carries_from_one_call_to_the_next() {
    let fs = 20000.0;
    let model = ModalModel::sdof(M, C, K).unwrap();
    let el = || ElementSet::new(vec![AnyElement::Jenkins(Jenkins::new(KD, FD).unwrap())]);
    let force: Vec<f64> = (0..4000)
        .map(|i| 300.0 * (2.0 * PI * 230.0 * i as f64 / fs).sin())
        .collect();
    let mut one = Simulator::new(&model, el(), fs).unwrap();
    let whole = one.run(&force, &hystid::observe::Silent).unwrap();
    let mut two = Simulator::new(&model, el(), fs).unwrap();
    let mut parts = two.run(&force[..1234], &hystid::observe::Silent).unwrap();
    two.run_into(&force[1234..], &mut parts).unwrap();
    assert_eq!(whole, parts);
    assert!(one.elements().has_memory());
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let model = ModalModel::sdof(M, C, K).unwrap();
    let mut sim = Simulator::new(&model, NoElement, 10000.0).unwrap();
    let e = sim
        .run(&[1.0, f64::NAN, 2.0], &hystid::observe::Silent)
        .unwrap_err()
        .to_string();
    assert!(e.contains("force sample 1") && e.contains("finite"), "{e}");
    let e = Simulator::new(&model, NoElement, 300.0)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("sample_rate_hz") && e.contains("twice the highest mode"),
        "{e}"
    );
    for (m, c, k, field) in [
        (-1.0, C, K, "mass"),
        (0.0, C, K, "mass"),
        (M, -5.0, K, "damping"),
        (M, C, 0.0, "stiffness"),
    ] {
        let e = ModalModel::sdof(m, c, k).unwrap_err().to_string();
        assert!(e.contains(field), "{e}");
    }
    let e = ElementSpec::Masing {
        kd: KD,
        fd: FD,
        n: f64::NAN,
    }
    .build()
    .unwrap_err()
    .to_string();
    assert!(e.contains(".n"), "{e}");
}

/// The reference displacement at `p_out` instants a period over the last
/// `periods` periods after `seconds` (event-located RK4, `sub` steps per
/// instant).
fn rk4_history(
    f0: f64,
    f: f64,
    seconds: f64,
    p_out: usize,
    sub: usize,
    periods: usize,
) -> Vec<f64> {
    let mut s = Rk4Jenkins {
        f0,
        w: omega(f),
        t: 0.0,
        x: 0.0,
        v: 0.0,
        stick: true,
        slider: 0.0,
        slip_sign: 1.0,
    };
    let h = 1.0 / (f * (p_out * sub) as f64);
    let settle = (seconds * f) as usize;
    let mut xs = Vec::with_capacity(periods * p_out);
    for period in 0..settle + periods {
        for _ in 0..p_out {
            if period >= settle {
                xs.push(s.x);
            }
            for _ in 0..sub {
                s.advance(h);
            }
        }
    }
    xs
}

/// Issue 16's reference case: the paper's SDOF with its Jenkins joint under
/// 300 N at 250 Hz (sticking and slipping every half period), sampled at 32
/// to 512 kHz, against the event-located RK4 reference at the same instants.
/// Sampling alone puts a slip transition anywhere inside a sample: the
/// slider then stops at the sampled extremum, and the filters see the stick
/// force's kink as a straight line, errors of `O(h²)` whose size depends on
/// where the event falls. Placed inside the sample (`Element::kink_impulse`,
/// the slider at the extremum), what is left is the ramp-invariant filters'
/// own `h²` (their `sinc²(f/fs)`), and the error falls 4x per halving.
/// Before: 2.2e-4, 1.0e-4, 1.1e-5, 7.8e-6, 8.0e-7 (ratios 2.1, 9.5, 1.4, 9.7).
#[test]
fn jenkins_error_converges_at_second_order_through_slip_transitions() {
    let (f0, f) = (300.0, 250.0);
    let finest = 2048; // 512 kHz
    // RK4 at 0.49 us, events located to 1e-15 s: its own error is ~1e-11
    let reference = rk4_history(f0, f, 2.0, finest, 4, 4);
    let peak = reference.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let mut errors = Vec::new();
    let mut sampled = Vec::new();
    for p in [128usize, 256, 512, 1024, 2048] {
        let r = jenkins_run_with(f0, f, p, 2.0, true);
        let stride = finest / p;
        let error = |x: &[f64]| {
            x.iter()
                .enumerate()
                .map(|(i, xi)| (xi - reference[i * stride]).abs())
                .fold(0.0f64, f64::max)
                / peak
        };
        let plain = jenkins_run_with(f0, f, p, 2.0, false);
        sampled.push(error(
            &plain.displacement[plain.displacement.len() - 4 * p..],
        ));
        let x = &r.displacement[r.displacement.len() - 4 * p..];
        let e = error(x);
        eprintln!(
            "{:>4} kHz: max |x - x_RK4| = {e:.3e} of the peak (transitions sampled: {:.3e})",
            p as f64 * f / 1000.0,
            sampled.last().unwrap()
        );
        errors.push(e);
    }
    // sampled, the error jumps about as the events move in the sample: two
    // of the four halvings gain less than 2.5x
    let erratic = sampled.windows(2).filter(|w| w[0] / w[1] < 2.5).count();
    assert!(erratic >= 2, "{sampled:?}");
    for w in errors.windows(2) {
        let ratio = w[0] / w[1];
        eprintln!("per halving of the sample interval: {ratio:.2}x");
        // second order is 4x; 3.5 is the floor
        assert!((3.5..4.6).contains(&ratio), "{errors:?}");
    }
    // its size is the sampled force's sinc² deficit, (π f/fs)²/3 = 2.0e-4 at
    // 32 kHz, near resonance: no more than twice it
    assert!(errors[0] < 2.0 * (PI / 128.0).powi(2) / 3.0, "{errors:?}");
}

/// A hysteretic mode whose joint never slips is its bare mode held by the
/// stiffness `kd` (fed back sample by sample, so the filter's `sinc²` acts
/// inside the loop: `s²H/(1 + kd s²H)` with `H = |R|/(ω_r² − ω² + 2jζω_rω)`),
/// and one whose joint always slips is the bare mode (`s²H`); beside the
/// paper's SDOF (`s²H_point`) the contributions add, a transfer mode's
/// (`R < 0`) turned over. The simulator's steady state is that closed form.
#[test]
fn a_hysteretic_mode_stuck_or_slipping_is_the_closed_form_receptance() {
    use hystid::model::Model;
    let fs = 51200.0;
    let point = Mode::from_mck(M, C, K).unwrap();
    let (kd, r2) = (4.0e7, 0.02);
    for (sign, stuck) in [(1.0, true), (-1.0, true), (1.0, false)] {
        let mode = Mode {
            joint: Some(ElementSpec::Jenkins {
                kd,
                fd: if stuck { 1e12 } else { 1e-9 },
            }),
            ..Mode::from_modal_mass(230.0, 0.02, sign / r2).unwrap()
        };
        let model =
            Model::with_joint(ModalModel::new(vec![point, mode]).unwrap(), None, vec![]).unwrap();
        let own = mode.own_sdof().1;
        for p in [400usize, 256, 160] {
            let f = fs / p as f64;
            let (w, s2) = (omega(f), sinc(f / fs).powi(2));
            let n = (3 * fs as usize) / p * p + 4 * p;
            let force: Vec<f64> = (0..n)
                .map(|i| (2.0 * PI * (i % p) as f64 / p as f64).cos())
                .collect();
            let x = hystid::sim::simulate(
                &model,
                &force,
                fs,
                hystid::sim::Output::Displacement,
                &hystid::observe::Silent,
            )
            .unwrap();
            let got = fundamental(&x, p, 4);
            let h = s2 * own.receptance(w);
            let held = if stuck { h / (1.0 + kd * h) } else { h };
            let expected = s2 * point.receptance(w) + sign * held;
            let rel = (got / expected - 1.0).norm();
            eprintln!(
                "R {:+}, stuck {stuck}, {f:.1} Hz: rel. error {rel:.1e}",
                sign * r2
            );
            // what is left is the aliases, H(f + k fs) sinc²(f/fs + k)
            assert!(
                rel < 1e-7,
                "R {}, stuck {stuck}, {f} Hz: {got} vs {expected}",
                sign * r2
            );
        }
    }
}

/// The element force's `sinc²` loss compensated
/// (`Simulator::with_element_force_compensated`), on the paper's SDOF with
/// its Jenkins joint stuck (a slip force never reached): the loop is then
/// linear and its discrete steady state has a closed form. The drive is
/// pre-emphasised as a measured force is (`[−1/12, 7/6, −1/12]`, gain `P =
/// 1 + (1 − cos ωT)/6`); the filter is the ramp-invariant receptance `H_d`
/// (the continuous one's `sinc²`-weighted alias sum) with direct terms `b0`,
/// `b1`, `a1`. The joint's force `g = kd x` is pre-emphasised alike, one
/// sample late: the filters' input at `n − 1` corrected by `δ = −(P − 1) g`
/// once `g_n` is known, the states by what that makes of them, while the
/// displacement already given at `n − 1` and `n` lacks `E δ`, `E = b0 +
/// (b1 − a1 b0) e^{−jωT}`. So `X/F = P H_d / (1 + kd (P H_d − (P − 1) E))`
/// compensated and `P H_d / (1 + kd H_d)` plain. The simulator is that to
/// 1e-7 both ways, and compensated it is many times closer to the
/// continuous model `1/(k + kd − mω² + jcω)` near the stuck resonance (293
/// Hz), where the plain loop's stiffness deficit `kd (ωT)²/12` moves the
/// peak.
#[test]
fn the_element_forces_sinc_squared_loss_compensated_is_the_closed_form() {
    for (f, p) in [(250.0, 40usize), (285.0, 40), (285.0, 20)] {
        let fs = p as f64 * f;
        let wt = 2.0 * PI / p as f64;
        let w = omega(f);
        let model = ModalModel::sdof(M, C, K).unwrap();
        let h_d = alias_sum(|w| model.frf(Quantity::Displacement, w), 0.0, f, fs);
        let gain = 1.0 + (1.0 - wt.cos()) / 6.0;
        let z1 = Complex64::from_polar(1.0, -wt);
        let d = ModeFilter::new(&Mode::from_mck(M, C, K).unwrap(), 1.0 / fs).displacement;
        let e = d.b[0] + (d.b[1] - d.a[0] * d.b[0]) * z1;
        let continuous = 1.0 / Complex64::new(K + KD - M * w * w, C * w);
        let mut errors = Vec::new();
        for compensated in [false, true] {
            let closed = if compensated {
                gain * h_d / (1.0 + KD * (gain * h_d - (gain - 1.0) * e))
            } else {
                gain * h_d / (1.0 + KD * h_d)
            };
            let mut sim = Simulator::new(&model, Jenkins::new(KD, 1e12).unwrap(), fs).unwrap();
            if compensated {
                sim = sim.with_element_force_compensated();
            }
            let c = |k: usize| (2.0 * PI * (k % p) as f64 / p as f64).cos();
            let n = ((3.0 * fs) as usize / p + 4) * p;
            // the pre-emphasised cosine, whole periods (k − 1 taken a period on)
            let force: Vec<f64> = (0..n)
                .map(|i| c(i) + (2.0 * c(i) - c(i + p - 1) - c(i + 1)) / 12.0)
                .collect();
            let x = sim
                .run(&force, &hystid::observe::Silent)
                .unwrap()
                .displacement;
            let got = fundamental(&x, p, 4);
            let exact = (got / closed - 1.0).norm();
            let error = (got / continuous - 1.0).norm();
            eprintln!(
                "{f} Hz, {p} samples per period, compensated {compensated}: against the closed form {exact:.1e}, against the continuous model {error:.2e}"
            );
            assert!(exact < 1e-7, "{got} vs {closed}");
            errors.push(error);
        }
        assert!(errors[1] < errors[0] / 10.0, "{errors:?}");
    }
}

/// Issue 16's reference case (300 N at 250 Hz, sticking and slipping every
/// half period) with the drive pre-emphasised as a measured force is, its
/// slip transitions located and the element force's `sinc²` loss
/// compensated too: what the located simulator has left at 32 and 64 kHz is
/// that loss (see `jenkins_error_converges_at_second_order_through_slip_transitions`),
/// and with it compensated the error against the event-located RK4
/// reference falls at least tenfold (measured 16x and 43x: 1.3e-5 and
/// 1.2e-6 of the peak, against 2.1e-4 and 5.2e-5). Without the transitions
/// located the compensation does not help (the sampled transitions' errors
/// then dominate and no longer partly cancel the loss; measured 1.4x worse
/// at 32 kHz), which is why it skips a kink and is asked for, not implied.
#[test]
fn located_transitions_with_the_element_force_compensated_gain_tenfold() {
    let (f0, f) = (300.0, 250.0);
    let finest = 2048; // 512 kHz
    let reference = rk4_history(f0, f, 2.0, finest, 4, 4);
    let peak = reference.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let error = |p: usize, compensated: bool| {
        let fs = p as f64 * f;
        let model = ModalModel::sdof(M, C, K).unwrap();
        let mut sim = Simulator::new(&model, Jenkins::new(KD, FD).unwrap(), fs)
            .unwrap()
            .with_transitions_located();
        if compensated {
            sim = sim.with_element_force_compensated();
        }
        let c = |k: usize| f0 * (2.0 * PI * (k % p) as f64 / p as f64).cos();
        let drive = |i: usize| c(i) + (2.0 * c(i) - c(i + p - 1) - c(i + 1)) / 12.0;
        let n = ((2.0 * fs) as usize / p + 1) * p;
        sim.run_generator(n, drive, &mut Default::default())
            .unwrap();
        let mut out = hystid::sim::Response::default();
        sim.run_generator(4 * p, |i| drive(n + i), &mut out)
            .unwrap();
        let stride = finest / p;
        out.displacement
            .iter()
            .enumerate()
            .map(|(i, x)| (x - reference[i * stride]).abs())
            .fold(0.0f64, f64::max)
            / peak
    };
    let mut figures = Vec::new();
    for p in [128usize, 256] {
        let (located, both) = (error(p, false), error(p, true));
        let khz = p as f64 * f / 1000.0;
        eprintln!(
            "{khz} kHz: located {located:.2e}, located and compensated {both:.2e} ({:.1}x)",
            located / both
        );
        assert!(both < 0.1 * located, "{both} vs {located}");
        figures.extend([
            ("kHz", khz),
            ("compensated", both),
            ("located alone", located),
        ]);
    }
    let shown =
        crate::common::pinned_figures("Located transitions with the element force compensated:")
            .expect("pinned figures");
    assert_eq!(shown.len(), figures.len(), "{shown:?}");
    for ((what, value), shown) in figures.iter().zip(shown) {
        crate::common::assert_pinned_figure(what, *value, shown);
    }
}
