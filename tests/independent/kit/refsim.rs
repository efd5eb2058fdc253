//! The reference simulator: classical RK4 on the continuous equation of
//! motion of a modal structure seen at one point, with a hysteretic joint
//! by operator splitting (or, for Bouc-Wen, its differential equation in
//! time integrated with the structure). Shares no code with hystid (no
//! `use hystid`).

/// A linear mode: `q'' + 2 ζ ω q' + ω² q = R (F − F_nl)`.
#[derive(Clone, Copy, Debug)]
pub struct RefMode {
    pub omega: f64,
    pub zeta: f64,
    /// `1/m_r`, 1/kg.
    pub residue: f64,
}

impl RefMode {
    /// The mode of an SDOF (m, c, k).
    pub fn from_mck(m: f64, c: f64, k: f64) -> RefMode {
        RefMode {
            omega: (k / m).sqrt(),
            zeta: c / (2.0 * (k * m).sqrt()),
            residue: 1.0 / m,
        }
    }
    /// From frequency (Hz), damping ratio and modal mass.
    pub fn from_hz(f_hz: f64, zeta: f64, modal_mass: f64) -> RefMode {
        RefMode {
            omega: 2.0 * std::f64::consts::PI * f_hz,
            zeta,
            residue: 1.0 / modal_mass,
        }
    }
}

/// The hysteretic joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RefJoint {
    None,
    Jenkins {
        kd: f64,
        fd: f64,
    },
    Masing {
        kd: f64,
        fd: f64,
        n: f64,
    },
    /// Segalman's four-parameter Iwan joint, simulated as what it is: a
    /// parallel bank of Jenkins sliders (see [`IwanBank`]).
    Iwan4 {
        fs: f64,
        kt: f64,
        chi: f64,
        beta: f64,
    },
    /// The Bouc-Wen hysteresis as the nonlinearbenchmark.org benchmark
    /// writes it, a differential equation in time,
    /// `z' = α y' − β (γ |y'| |z|^(ν−1) z + δ y' |z|^ν)`, integrated by the
    /// same RK4 as the structure (one more state), not by splitting.
    BoucWen {
        alpha: f64,
        beta: f64,
        gamma: f64,
        delta: f64,
        nu: f64,
    },
}

impl RefJoint {
    /// `z'` of a Bouc-Wen joint at force `z` and velocity `v` (zero for
    /// every other joint, whose state moves by splitting).
    #[inline]
    pub fn rate(&self, z: f64, v: f64) -> f64 {
        match *self {
            RefJoint::BoucWen {
                alpha,
                beta,
                gamma,
                delta,
                nu,
            } => {
                let za = z.abs();
                let zn = if nu == 1.0 { za } else { za.powf(nu) };
                // |z|^(ν−1) z = |z|^ν sign(z)
                alpha * v - beta * (gamma * v.abs() * zn * z.signum() + delta * v * zn)
            }
            _ => 0.0,
        }
    }

    fn is_differential(&self) -> bool {
        matches!(self, RefJoint::BoucWen { .. })
    }

    /// `|∂z'/∂z|` of a Bouc-Wen joint at `z` and `v` (an upper bound): the
    /// rate at which `z` relaxes, which an explicit step must resolve.
    fn stiffness_rate(&self, z: f64, v: f64) -> f64 {
        match *self {
            RefJoint::BoucWen {
                beta,
                gamma,
                delta,
                nu,
                ..
            } => beta * nu * z.abs().powf(nu - 1.0) * v.abs() * (gamma.abs() + delta.abs()),
            _ => 0.0,
        }
    }
}

/// Sliders in the bank's continuum (the spike is one more).
pub const IWAN_SLIDERS: usize = 1000;

/// A parallel bank of Jenkins sliders drawn from Segalman's density
/// `ρ(φ) = R φ^χ (0 < φ < φ_max) + S δ(φ − φ_max)` over slip displacement
/// `φ` (each slider a spring of stiffness `ρ dφ` that slips `φ` from its
/// anchor). Written from the paper's definitions: the stiffness
/// `K_T = ∫ρ`, the slip force `F_S = ∫ρ φ`, the spike's share
/// `β = S / ∫R φ^χ`. The continuum is cut into slices of equal stiffness
/// `(K_T − S)/n`, each slider at its slice's stiffness-weighted mean `φ`,
/// so the bank's `K_T` and `F_S` are exact.
#[derive(Clone, Debug)]
pub struct IwanBank {
    /// Each slider's stiffness, N/m.
    pub stiffness: Vec<f64>,
    /// Each slider's slip displacement, m.
    pub slip: Vec<f64>,
}

impl IwanBank {
    pub fn new(fs: f64, kt: f64, chi: f64, beta: f64, n: usize) -> IwanBank {
        let (c1, c2) = (chi + 1.0, chi + 2.0);
        // continuum stiffness A = K_T/(1+β), spike S = β A; F_S = A φ_max
        // ((χ+1)/(χ+2) + β)
        let a = kt / (1.0 + beta);
        let phi_max = fs / (a * (c1 / c2 + beta));
        let edge = |j: usize| phi_max * (j as f64 / n as f64).powf(1.0 / c1);
        let mut stiffness = vec![a / n as f64; n];
        let mut slip: Vec<f64> = (0..n)
            .map(|j| {
                let (lo, hi) = (edge(j), edge(j + 1));
                c1 / c2 * (hi.powf(c2) - lo.powf(c2)) / (hi.powf(c1) - lo.powf(c1))
            })
            .collect();
        if beta > 0.0 {
            stiffness.push(beta * a);
            slip.push(phi_max);
        }
        IwanBank { stiffness, slip }
    }

    /// The bank's force with its sliders' anchors at `anchor`.
    #[inline]
    pub fn force(&self, anchor: &[f64], x: f64) -> f64 {
        self.stiffness
            .iter()
            .zip(&self.slip)
            .zip(anchor)
            .map(|((k, p), s)| k * (x - s).clamp(-p, *p))
            .sum()
    }

    /// Moves the anchors with `x`: a slider slips where its spring would
    /// carry more than its slip displacement.
    #[inline]
    pub fn slide(&self, anchor: &mut [f64], x: f64) {
        for (s, p) in anchor.iter_mut().zip(&self.slip) {
            *s = s.clamp(x - p, x + p);
        }
    }
}

/// A smooth (memoryless) effect, in the exact forms hystid uses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RefEffect {
    /// `k3 x³`
    Cubic { k3: f64 },
    /// `c2 |v| v`
    QuadDamping { c2: f64 },
    /// `kb x` for `x > 0`
    Bilinear { kb: f64 },
    /// `k (|x| − gap) sign x` for `|x| > gap`
    Clearance { k: f64, gap: f64 },
}

impl RefEffect {
    #[inline]
    pub fn force(&self, x: f64, v: f64) -> f64 {
        match *self {
            RefEffect::Cubic { k3 } => k3 * x * x * x,
            RefEffect::QuadDamping { c2 } => c2 * v.abs() * v,
            RefEffect::Bilinear { kb } => {
                if x > 0.0 {
                    kb * x
                } else {
                    0.0
                }
            }
            RefEffect::Clearance { k, gap } => {
                if x.abs() > gap {
                    k * (x.abs() - gap) * x.signum()
                } else {
                    0.0
                }
            }
        }
    }
}

/// The eq. (10) backbone `kd x / (1 + |kd x/Fd|^N)^(1/N)`.
#[inline]
pub fn masing_backbone(kd: f64, fd: f64, n: f64, x: f64) -> f64 {
    let u = (kd * x / fd).abs();
    if u == 0.0 {
        return 0.0;
    }
    // (1 + u^N)^(1/N), computed without overflow for large u
    let den = if u > 1.0 {
        u * (1.0 + u.powf(-n)).powf(1.0 / n)
    } else {
        (1.0 + u.powf(n)).powf(1.0 / n)
    };
    kd * x / den
}

/// Hysteresis state: a Jenkins slider or a Masing turning-point stack.
#[derive(Clone, Debug)]
pub struct Hysteresis {
    joint: RefJoint,
    /// Jenkins: slider position.
    xs: f64,
    /// Masing: turning points (x, F), oldest first.
    tps: Vec<(f64, f64)>,
    /// Masing: last position, force and direction of motion (0 = none yet).
    x: f64,
    f: f64,
    dir: f64,
    /// Iwan: the bank and its sliders' anchors.
    bank: Option<IwanBank>,
    anchors: Vec<f64>,
}

impl Hysteresis {
    pub fn new(joint: RefJoint) -> Hysteresis {
        let bank = match joint {
            RefJoint::Iwan4 { fs, kt, chi, beta } => {
                Some(IwanBank::new(fs, kt, chi, beta, IWAN_SLIDERS))
            }
            _ => None,
        };
        Hysteresis {
            anchors: vec![0.0; bank.as_ref().map_or(0, |b| b.slip.len())],
            bank,
            joint,
            xs: 0.0,
            tps: Vec::with_capacity(16),
            x: 0.0,
            f: 0.0,
            dir: 0.0,
        }
    }

    /// The force at `x` with the state held (no update): used in RK4 stages.
    #[inline]
    pub fn force_at(&self, x: f64) -> f64 {
        match self.joint {
            RefJoint::None => 0.0,
            RefJoint::Jenkins { kd, fd } => (kd * (x - self.xs)).clamp(-fd, fd),
            RefJoint::Masing { kd, fd, n } => self.masing_eval(kd, fd, n, x).0,
            RefJoint::Iwan4 { .. } => self.bank.as_ref().unwrap().force(&self.anchors, x),
            // its force is the simulator's state, not a function of x
            RefJoint::BoucWen { .. } => self.f,
        }
    }

    /// The force of the current state.
    pub fn force(&self) -> f64 {
        match self.joint {
            RefJoint::None => 0.0,
            RefJoint::Jenkins { .. } | RefJoint::Iwan4 { .. } => self.force_at(self.x),
            RefJoint::Masing { .. } | RefJoint::BoucWen { .. } => self.f,
        }
    }

    /// Moves the joint to `x` (end of a sub-step) and returns its force.
    pub fn update(&mut self, x: f64) -> f64 {
        match self.joint {
            RefJoint::None => 0.0,
            RefJoint::Jenkins { kd, fd } => {
                let f = kd * (x - self.xs);
                if f > fd {
                    self.xs = x - fd / kd;
                } else if f < -fd {
                    self.xs = x + fd / kd;
                }
                self.x = x;
                f.clamp(-fd, fd)
            }
            RefJoint::Masing { kd, fd, n } => {
                let (f, keep, dir, reversal) = self.masing_eval(kd, fd, n, x);
                if dir != 0.0 {
                    if reversal {
                        self.tps.push((self.x, self.f));
                    }
                    self.tps.truncate(keep);
                    self.dir = dir;
                    self.x = x;
                    self.f = f;
                }
                self.f
            }
            RefJoint::Iwan4 { .. } => {
                let bank = self.bank.as_ref().unwrap();
                bank.slide(&mut self.anchors, x);
                self.x = x;
                bank.force(&self.anchors, x)
            }
            // moved by the simulator's RK4 (see `RefJoint::rate`)
            RefJoint::BoucWen { .. } => self.f,
        }
    }

    /// Masing rules with wipe-out, read-only. Returns the force, how many
    /// turning points stay (of the stack with the reversal point pushed),
    /// the direction and whether this motion is a reversal.
    #[inline]
    fn masing_eval(&self, kd: f64, fd: f64, n: f64, x: f64) -> (f64, usize, f64, bool) {
        let d = x - self.x;
        if d == 0.0 {
            return (self.f, self.tps.len(), 0.0, false);
        }
        let dir = d.signum();
        let reversal = self.dir != 0.0 && dir != self.dir;
        let len = self.tps.len() + reversal as usize;
        let get = |i: usize| {
            if i < self.tps.len() {
                self.tps[i]
            } else {
                (self.x, self.f)
            }
        };
        let mut k = len;
        loop {
            if k == 0 {
                return (masing_backbone(kd, fd, n, x), 0, dir, reversal);
            }
            let (xr, fr) = get(k - 1);
            // the branch from the last turning point closes at the one
            // before it, or (the first one, on the backbone) at its mirror
            let target = if k >= 2 { get(k - 2).0 } else { -xr };
            if dir * (x - target) > 0.0 {
                k = k.saturating_sub(2);
                continue;
            }
            return (
                fr + 2.0 * masing_backbone(kd, fd, n, 0.5 * (x - xr)),
                k,
                dir,
                reversal,
            );
        }
    }
}

/// One dwell of a phase-continuous stepped sine.
#[derive(Clone, Copy, Debug)]
pub struct Dwell {
    pub frequency_hz: f64,
    pub amplitude: f64,
    /// Start time, s (a force zero crossing).
    pub t0: f64,
    /// Whole periods in the dwell.
    pub periods: u64,
    /// Settle time from `t0`, s.
    pub settle_s: f64,
}

impl Dwell {
    pub fn t_end(&self) -> f64 {
        self.t0 + self.periods as f64 / self.frequency_hz
    }
}

/// The force of a stepped sine, evaluated analytically.
#[derive(Clone, Debug)]
pub struct SteppedSine {
    pub dwells: Vec<Dwell>,
}

impl SteppedSine {
    /// Consecutive dwells from `t_start`, each ending at a zero crossing.
    pub fn new(t_start: f64, spec: &[(f64, f64, u64, f64)]) -> SteppedSine {
        let mut t = t_start;
        let mut dwells = Vec::with_capacity(spec.len());
        for &(f, a, periods, settle_s) in spec {
            let d = Dwell {
                frequency_hz: f,
                amplitude: a,
                t0: t,
                periods,
                settle_s,
            };
            t = d.t_end();
            dwells.push(d);
        }
        SteppedSine { dwells }
    }

    pub fn t_end(&self) -> f64 {
        self.dwells.last().map_or(0.0, |d| d.t_end())
    }
}

/// What drives the reference simulator: the force (or voltage) at any
/// time, for RK4's intermediate stages.
pub trait Drive {
    /// The drive at `t`; `hint` is the caller's cursor for a drive of
    /// pieces.
    fn force(&self, t: f64, hint: &mut usize) -> f64;
}

/// A multisine: `Σ a_l sin(2π f_l t + φ_l)` from `t = 0`, for ever.
#[derive(Clone, Debug)]
pub struct Multisine {
    /// `(f_l` Hz, `a_l`, `φ_l` rad`)`.
    pub lines: Vec<(f64, f64, f64)>,
}

impl Drive for Multisine {
    fn force(&self, t: f64, _hint: &mut usize) -> f64 {
        self.lines
            .iter()
            .map(|&(f, a, p)| a * (2.0 * std::f64::consts::PI * f * t + p).sin())
            .sum()
    }
}

impl Drive for SteppedSine {
    /// The dwell index at `t` (hint-accelerated).
    #[inline]
    fn force(&self, t: f64, hint: &mut usize) -> f64 {
        let ds = &self.dwells;
        if ds.is_empty() || t < ds[0].t0 {
            return 0.0;
        }
        let mut i = (*hint).min(ds.len() - 1);
        while i > 0 && t < ds[i].t0 {
            i -= 1;
        }
        while i + 1 < ds.len() && t >= ds[i + 1].t0 {
            i += 1;
        }
        *hint = i;
        let d = &ds[i];
        if t >= d.t_end() {
            return 0.0;
        }
        d.amplitude * (2.0 * std::f64::consts::PI * d.frequency_hz * (t - d.t0)).sin()
    }
}

/// An electrodynamic shaker's coil between the drive and the structure:
/// `L i' + R i + Bl x' = e`, the structure pushed by `Bl i`. The drive `e`
/// (V) is then what the recording's reference holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RefCoil {
    /// Resistance, ohm.
    pub r: f64,
    /// Inductance, H.
    pub l: f64,
    /// Force factor, N/A.
    pub bl: f64,
}

/// The system: modes, joint and smooth effects at one point, driven by a
/// force or, through a coil, by a voltage.
#[derive(Clone, Debug)]
pub struct RefSystem {
    pub modes: Vec<RefMode>,
    pub joint: RefJoint,
    pub effects: Vec<RefEffect>,
    pub coil: Option<RefCoil>,
}

/// What the simulation records per sample.
#[derive(Clone, Debug, Default)]
pub struct RefOutput {
    pub force: Vec<f64>,
    pub displacement: Vec<f64>,
    pub velocity: Vec<f64>,
    pub acceleration: Vec<f64>,
    /// The joint's force (for checks).
    pub joint_force: Vec<f64>,
    /// The force the drive applies: the force itself, or through a coil
    /// `Bl i` (what a force gauge reads).
    pub drive_force: Vec<f64>,
}

const MAXM: usize = 4;

impl RefSystem {
    #[inline]
    fn smooth(&self, x: f64, v: f64) -> f64 {
        self.effects.iter().map(|e| e.force(x, v)).sum()
    }

    /// Derivatives of (q, q') given the total external force minus the
    /// hysteretic force already evaluated.
    #[inline]
    fn deriv(
        &self,
        q: &[f64; MAXM],
        p: &[f64; MAXM],
        f_net: f64,
        dq: &mut [f64; MAXM],
        dp: &mut [f64; MAXM],
    ) {
        for (r, m) in self.modes.iter().enumerate() {
            dq[r] = p[r];
            dp[r] = m.residue * f_net - 2.0 * m.zeta * m.omega * p[r] - m.omega * m.omega * q[r];
        }
    }

    /// Point-sampled response to `force` over `n` samples at `fs`, with
    /// `substeps` RK4 steps per sample, from rest.
    pub fn simulate(&self, force: &impl Drive, fs: f64, n: usize, substeps: usize) -> RefOutput {
        let nm = self.modes.len();
        assert!((1..=MAXM).contains(&nm));
        let mut hyst = Hysteresis::new(self.joint);
        let mut q = [0.0; MAXM];
        let mut p = [0.0; MAXM];
        let (mut k1q, mut k1p, mut k2q, mut k2p) =
            ([0.0; MAXM], [0.0; MAXM], [0.0; MAXM], [0.0; MAXM]);
        let (mut k3q, mut k3p, mut k4q, mut k4p) =
            ([0.0; MAXM], [0.0; MAXM], [0.0; MAXM], [0.0; MAXM]);
        let mut tq = [0.0; MAXM];
        let mut tp = [0.0; MAXM];
        let dt = 1.0 / fs;
        let mut hint = 0usize;
        let mut out = RefOutput {
            force: Vec::with_capacity(n),
            displacement: Vec::with_capacity(n),
            velocity: Vec::with_capacity(n),
            acceleration: Vec::with_capacity(n),
            joint_force: Vec::with_capacity(n),
            drive_force: Vec::with_capacity(n),
        };
        let sum = |a: &[f64; MAXM]| a[..nm].iter().sum::<f64>();
        let mut fh = 0.0;
        // a differential joint's force, integrated with the structure
        let differential = self.joint.is_differential();
        let mut z = 0.0;
        // the coil's current (a further state, integrated with the rest)
        let mut current = 0.0;
        let coil = self.coil;
        // the force on the structure from the drive `e` and the current
        let pushed = |e: f64, ii: f64| coil.map_or(e, |c| c.bl * ii);
        let current_rate =
            |e: f64, ii: f64, v: f64| coil.map_or(0.0, |c| (e - c.r * ii - c.bl * v) / c.l);
        for i in 0..n {
            // record the state at the sample instant
            let t = i as f64 * dt;
            let f = force.force(t, &mut hint);
            let x = sum(&q);
            let v = sum(&p);
            let fnl = fh + self.smooth(x, v);
            let mut a = 0.0;
            for (r, m) in self.modes.iter().enumerate() {
                a += m.residue * (pushed(f, current) - fnl)
                    - 2.0 * m.zeta * m.omega * p[r]
                    - m.omega * m.omega * q[r];
            }
            out.force.push(f);
            out.displacement.push(x);
            out.velocity.push(v);
            out.acceleration.push(a);
            out.joint_force.push(fh);
            out.drive_force.push(pushed(f, current));
            if i + 1 == n {
                break;
            }
            // advance to the next sample
            // a Bouc-Wen force relaxes at `β |y'|` per second: far faster
            // than the structure moves at large amplitudes, so the step is
            // shortened until it resolves that (λh <= 0.1, twice the rate
            // the sample starts with: RK4's error then ~1e-7 per step)
            // the coil's own rate R/L too
            let lambda =
                (2.0 * self.joint.stiffness_rate(fh, v)).max(coil.map_or(0.0, |c| c.r / c.l));
            let nsub = substeps.max(((lambda * dt / 0.1).ceil() as usize).min(1 << 16));
            let h = dt / nsub as f64;
            for s in 0..nsub {
                let ts = t + s as f64 * h;
                // one RK4 stage: (q', p') and the differential joint's z'
                let stage = |q: &[f64; MAXM],
                             p: &[f64; MAXM],
                             zz: f64,
                             ii: f64,
                             tt: f64,
                             hint: &mut usize,
                             dq: &mut [f64; MAXM],
                             dp: &mut [f64; MAXM]|
                 -> (f64, f64) {
                    let x = q[..nm].iter().sum::<f64>();
                    let v = p[..nm].iter().sum::<f64>();
                    let fj = if differential { zz } else { hyst.force_at(x) };
                    let e = force.force(tt, hint);
                    let fnet = pushed(e, ii) - fj - self.smooth(x, v);
                    self.deriv(q, p, fnet, dq, dp);
                    (self.joint.rate(zz, v), current_rate(e, ii, v))
                };
                let (k1z, k1i) = stage(&q, &p, z, current, ts, &mut hint, &mut k1q, &mut k1p);
                for r in 0..nm {
                    tq[r] = q[r] + 0.5 * h * k1q[r];
                    tp[r] = p[r] + 0.5 * h * k1p[r];
                }
                let (k2z, k2i) = stage(
                    &tq,
                    &tp,
                    z + 0.5 * h * k1z,
                    current + 0.5 * h * k1i,
                    ts + 0.5 * h,
                    &mut hint,
                    &mut k2q,
                    &mut k2p,
                );
                for r in 0..nm {
                    tq[r] = q[r] + 0.5 * h * k2q[r];
                    tp[r] = p[r] + 0.5 * h * k2p[r];
                }
                let (k3z, k3i) = stage(
                    &tq,
                    &tp,
                    z + 0.5 * h * k2z,
                    current + 0.5 * h * k2i,
                    ts + 0.5 * h,
                    &mut hint,
                    &mut k3q,
                    &mut k3p,
                );
                for r in 0..nm {
                    tq[r] = q[r] + h * k3q[r];
                    tp[r] = p[r] + h * k3p[r];
                }
                let (k4z, k4i) = stage(
                    &tq,
                    &tp,
                    z + h * k3z,
                    current + h * k3i,
                    ts + h,
                    &mut hint,
                    &mut k4q,
                    &mut k4p,
                );
                current += h / 6.0 * (k1i + 2.0 * k2i + 2.0 * k3i + k4i);
                for r in 0..nm {
                    q[r] += h / 6.0 * (k1q[r] + 2.0 * k2q[r] + 2.0 * k3q[r] + k4q[r]);
                    p[r] += h / 6.0 * (k1p[r] + 2.0 * k2p[r] + 2.0 * k3p[r] + k4p[r]);
                }
                fh = if differential {
                    z += h / 6.0 * (k1z + 2.0 * k2z + 2.0 * k3z + k4z);
                    z
                } else {
                    // operator splitting: the hysteretic state moves with the new x
                    hyst.update(sum(&q))
                };
            }
        }
        out
    }
}
