//! The seeded corpus: cases drawn over what users have, turned into
//! recordings by the reference simulator.

use super::refsim::{RefCoil, RefEffect, RefJoint, RefMode, RefSystem, SteppedSine};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use std::f64::consts::PI;

/// Which joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum JointKind {
    Jenkins,
    Masing {
        n: f64,
    },
    /// Segalman's four-parameter Iwan joint: `kd` is its `K_T`, `fd` its
    /// `F_S`.
    Iwan4 {
        chi: f64,
        beta: f64,
    },
    /// A softening Bouc-Wen joint (`γ + δ > 0`): `kd` is its `α`, `fd` the
    /// force it saturates at, `(α / (β (γ + δ)))^(1/ν)`, which sets `β`.
    BoucWen {
        gamma: f64,
        delta: f64,
        nu: f64,
    },
}

impl JointKind {
    /// Bouc-Wen's `β` for stiffness `kd` and saturation force `fd`.
    pub fn bouc_wen_beta(kd: f64, fd: f64, gamma: f64, delta: f64, nu: f64) -> f64 {
        kd / ((gamma + delta) * fd.powf(nu))
    }
}

/// An effect name, as hystid's candidates are named.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum EffectKind {
    SecondMode,
    CubicStiffness,
    BilinearStiffness,
    QuadraticDamping,
    Clearance,
}

impl EffectKind {
    pub const ALL: [EffectKind; 5] = [
        EffectKind::SecondMode,
        EffectKind::CubicStiffness,
        EffectKind::BilinearStiffness,
        EffectKind::QuadraticDamping,
        EffectKind::Clearance,
    ];
    pub fn name(self) -> &'static str {
        match self {
            EffectKind::SecondMode => "second_mode",
            EffectKind::CubicStiffness => "cubic_stiffness",
            EffectKind::BilinearStiffness => "bilinear_stiffness",
            EffectKind::QuadraticDamping => "quadratic_damping",
            EffectKind::Clearance => "clearance",
        }
    }
    pub fn from_name(s: &str) -> Option<EffectKind> {
        Self::ALL.into_iter().find(|e| e.name() == s)
    }
}

/// A true effect with its parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TrueEffect {
    SecondMode {
        frequency_hz: f64,
        damping_ratio: f64,
        modal_mass: f64,
    },
    Cubic {
        k3: f64,
    },
    Bilinear {
        kb: f64,
    },
    QuadDamping {
        c2: f64,
    },
    Clearance {
        k: f64,
        gap: f64,
    },
}

impl TrueEffect {
    pub fn kind(&self) -> EffectKind {
        match self {
            TrueEffect::SecondMode { .. } => EffectKind::SecondMode,
            TrueEffect::Cubic { .. } => EffectKind::CubicStiffness,
            TrueEffect::Bilinear { .. } => EffectKind::BilinearStiffness,
            TrueEffect::QuadDamping { .. } => EffectKind::QuadraticDamping,
            TrueEffect::Clearance { .. } => EffectKind::Clearance,
        }
    }
    /// Parameters, named as in hystid's model elements / modes.
    pub fn parameters(&self) -> Vec<(&'static str, f64)> {
        match *self {
            TrueEffect::SecondMode {
                frequency_hz,
                damping_ratio,
                modal_mass,
            } => vec![
                ("frequency_hz", frequency_hz),
                ("damping_ratio", damping_ratio),
                ("residue", 1.0 / modal_mass),
            ],
            TrueEffect::Cubic { k3 } => vec![("k3", k3)],
            TrueEffect::Bilinear { kb } => vec![("kb", kb)],
            TrueEffect::QuadDamping { c2 } => vec![("c2", c2)],
            TrueEffect::Clearance { k, gap } => vec![("k", k), ("gap", gap)],
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SampleFormat {
    Float32,
    Pcm16,
    Pcm24,
}

impl SampleFormat {
    pub fn name(self) -> &'static str {
        match self {
            SampleFormat::Float32 => "float32",
            SampleFormat::Pcm16 => "pcm16",
            SampleFormat::Pcm24 => "pcm24",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Quantity {
    Displacement,
    Velocity,
    Acceleration,
}

impl Quantity {
    pub fn name(self) -> &'static str {
        match self {
            Quantity::Displacement => "displacement",
            Quantity::Velocity => "velocity",
            Quantity::Acceleration => "acceleration",
        }
    }
    pub fn unit(self) -> &'static str {
        match self {
            Quantity::Displacement => "m",
            Quantity::Velocity => "m/s",
            Quantity::Acceleration => "m/s^2",
        }
    }
}

/// Frequency order within a level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sweep {
    Up,
    Down,
    /// Up on even levels, down on odd ones.
    Alternate,
}

impl Sweep {
    pub fn name(self) -> &'static str {
        match self {
            Sweep::Up => "up",
            Sweep::Down => "down",
            Sweep::Alternate => "alternate",
        }
    }
}

/// Everything that defines one recording.
#[derive(Clone, Debug)]
pub struct Case {
    pub seed: u64,
    pub name: String,
    pub mass: f64,
    pub stiffness: f64,
    pub damping: f64,
    pub joint: JointKind,
    pub kd: f64,
    pub fd: f64,
    pub effects: Vec<TrueEffect>,
    /// Force amplitudes, N, ascending.
    pub levels: Vec<f64>,
    /// Test frequencies, Hz, ascending.
    pub frequencies: Vec<f64>,
    pub sweep: Sweep,
    pub sample_rate: u32,
    pub format: SampleFormat,
    pub quantity: Quantity,
    pub with_steps: bool,
    /// Response noise RMS / clean response RMS per dwell.
    pub response_noise: f64,
    /// Force noise RMS / clean force RMS per dwell.
    pub force_noise: f64,
    /// Analysis periods per dwell.
    pub analysis_periods: u64,
    /// Sub-steps of RK4 per sample.
    pub substeps: usize,
    /// A shaker's coil between the drive and the structure: the levels are
    /// then volts and the reference is the voltage.
    pub coil: Option<RefCoil>,
    /// With a coil: the recording also holds the force it applies (a force
    /// gauge's, noise `force_noise`), after the voltage.
    pub gauge: bool,
}

impl Case {
    pub fn f_slip(&self) -> f64 {
        (self.stiffness / self.mass).sqrt() / (2.0 * PI)
    }
    pub fn f_stuck(&self) -> f64 {
        ((self.stiffness + self.kd) / self.mass).sqrt() / (2.0 * PI)
    }
    pub fn zeta(&self) -> f64 {
        self.damping / (2.0 * (self.stiffness * self.mass).sqrt())
    }
    pub fn effect_kinds(&self) -> Vec<EffectKind> {
        let mut v: Vec<_> = self.effects.iter().map(|e| e.kind()).collect();
        v.sort();
        v
    }
    /// The hystid element name of the joint.
    pub fn element(&self) -> &'static str {
        match self.joint {
            JointKind::Jenkins => "jenkins",
            JointKind::Masing { .. } => "masing",
            JointKind::Iwan4 { .. } => "iwan4",
            JointKind::BoucWen { .. } => "bouc_wen",
        }
    }
    pub fn system(&self) -> RefSystem {
        let mut modes = vec![RefMode::from_mck(self.mass, self.damping, self.stiffness)];
        let mut effects = Vec::new();
        for e in &self.effects {
            match *e {
                TrueEffect::SecondMode {
                    frequency_hz,
                    damping_ratio,
                    modal_mass,
                } => modes.push(RefMode::from_hz(frequency_hz, damping_ratio, modal_mass)),
                TrueEffect::Cubic { k3 } => effects.push(RefEffect::Cubic { k3 }),
                TrueEffect::Bilinear { kb } => effects.push(RefEffect::Bilinear { kb }),
                TrueEffect::QuadDamping { c2 } => effects.push(RefEffect::QuadDamping { c2 }),
                TrueEffect::Clearance { k, gap } => effects.push(RefEffect::Clearance { k, gap }),
            }
        }
        let joint = match self.joint {
            JointKind::Jenkins => RefJoint::Jenkins {
                kd: self.kd,
                fd: self.fd,
            },
            JointKind::Masing { n } => RefJoint::Masing {
                kd: self.kd,
                fd: self.fd,
                n,
            },
            JointKind::Iwan4 { chi, beta } => RefJoint::Iwan4 {
                fs: self.fd,
                kt: self.kd,
                chi,
                beta,
            },
            JointKind::BoucWen { gamma, delta, nu } => RefJoint::BoucWen {
                alpha: self.kd,
                beta: JointKind::bouc_wen_beta(self.kd, self.fd, gamma, delta, nu),
                gamma,
                delta,
                nu,
            },
        };
        RefSystem {
            modes,
            joint,
            effects,
            coil: self.coil,
        }
    }
    /// The modes' slowest decay time 1/(ζω), s.
    pub fn slowest_tau(&self) -> f64 {
        self.system()
            .modes
            .iter()
            .map(|m| 1.0 / (m.zeta * m.omega))
            .fold(0.0, f64::max)
    }
    /// Dwell order: (level index, frequency index).
    pub fn order(&self) -> Vec<(usize, usize)> {
        let nf = self.frequencies.len();
        let mut o = Vec::new();
        for l in 0..self.levels.len() {
            let up = match self.sweep {
                Sweep::Up => true,
                Sweep::Down => false,
                Sweep::Alternate => l % 2 == 0,
            };
            for j in 0..nf {
                o.push((l, if up { j } else { nf - 1 - j }));
            }
        }
        o
    }
    /// Response amplitude at the slip resonance at the top level (the
    /// joint slipping, viscous damping only), m: what sizes the effects.
    pub fn top_amplitude(&self) -> f64 {
        let a = *self.levels.last().unwrap();
        let drive = (a - 4.0 * self.fd / PI).max(0.1 * a);
        drive / (2.0 * self.zeta() * self.stiffness)
    }
    pub fn summary(&self) -> String {
        let joint = match self.joint {
            JointKind::Jenkins => "jenkins".to_string(),
            JointKind::Masing { n } => format!("masing N={n:.2}"),
            JointKind::Iwan4 { chi, beta } => format!("iwan4 chi={chi:.3} beta={beta:.3}"),
            JointKind::BoucWen { gamma, delta, nu } => {
                format!("bouc_wen gamma={gamma:.3} delta={delta:.3} nu={nu:.2}")
            }
        };
        let eff: Vec<_> = self.effect_kinds().iter().map(|e| e.name()).collect();
        format!(
            "{} seed={} {} effects=[{}] m={:.3e} f_slip={:.4e} Hz kd/k={:.3} zeta={:.4} levels={} freqs={} fs={} {} {} sweep={} steps={}",
            self.name,
            self.seed,
            joint,
            eff.join(","),
            self.mass,
            self.f_slip(),
            self.kd / self.stiffness,
            self.zeta(),
            self.levels.len(),
            self.frequencies.len(),
            self.sample_rate,
            self.format.name(),
            self.quantity.name(),
            self.sweep.name(),
            self.with_steps
        )
    }
}

fn log_uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    (rng.random_range(lo.ln()..hi.ln())).exp()
}

const RATES: [u32; 16] = [
    2048, 2560, 4096, 5120, 8192, 10240, 12800, 16384, 25600, 32768, 44100, 48000, 51200, 65536,
    102400, 204800,
];

/// Options of [`case_with`]; `None` = drawn from the seed.
#[derive(Clone, Debug, Default)]
pub struct CaseOptions {
    pub levels: Option<usize>,
    pub frequencies: Option<usize>,
    pub format: Option<SampleFormat>,
    pub quantity: Option<Quantity>,
    pub sweep: Option<Sweep>,
    pub with_steps: Option<bool>,
    /// Draw over the broad ranges of [`draw_broad`] (bands that may cut a
    /// resonance, effects up to dominant, further modes anywhere, noise
    /// 0.3-10 %) instead of the original corpus's.
    pub broad: bool,
}

/// The draws [`CaseOptions::broad`] adds, from a stream of their own, so
/// that the original corpus's cases stay the same.
struct Broad {
    rng: ChaCha8Rng,
}

impl Broad {
    fn new(seed: u64) -> Broad {
        Broad {
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0xb40a_d000_0000_0001),
        }
    }
    /// The band's ends as multiples of the slip and stuck frequencies: a
    /// fifth of the cases start above the slipping resonance or end inside
    /// the stuck one (the band cuts a resonance).
    fn band(&mut self) -> (f64, f64) {
        let lo = if self.rng.random_range(0.0..1.0) < 0.2 {
            self.rng.random_range(0.97..1.05)
        } else {
            self.rng.random_range(0.4..0.9)
        };
        let hi = if self.rng.random_range(0.0..1.0) < 0.2 {
            self.rng.random_range(0.96..1.03)
        } else {
            self.rng.random_range(1.1..1.8)
        };
        (lo, hi)
    }
    /// Response noise, RMS relative to the clean response: 0.3-10 %.
    fn noise(&mut self) -> f64 {
        log_uniform(&mut self.rng, 0.003, 0.10)
    }
    /// An effect's size from just resolvable to dominant (jumps and folds
    /// at the top levels): a factor over `[lo, hi]`, log-uniform.
    fn size(&mut self, lo: f64, hi: f64) -> f64 {
        log_uniform(&mut self.rng, lo, hi)
    }
    /// A further mode anywhere from below the band to above it: below,
    /// at the bottom edge, inside (away from the joint's resonances), at
    /// the top edge, above.
    fn further_mode(&mut self, flo: f64, fhi: f64, avoid: [f64; 2]) -> f64 {
        match self.rng.random_range(0..5usize) {
            0 => flo * self.rng.random_range(0.25..0.85),
            1 => flo * self.rng.random_range(0.9..1.1),
            2 => {
                // inside, away from the joint's resonances where the band
                // leaves room (a few tries, then wherever the draw fell)
                let (lo, hi) = (flo * 1.1, fhi / 1.1);
                if lo >= hi {
                    return (flo * fhi).sqrt();
                }
                let mut f = log_uniform(&mut self.rng, lo, hi);
                for _ in 0..20 {
                    if avoid.iter().all(|a| (f / a).ln().abs() > 0.12) {
                        break;
                    }
                    f = log_uniform(&mut self.rng, lo, hi);
                }
                f
            }
            3 => fhi * self.rng.random_range(0.9..1.1),
            _ => fhi * self.rng.random_range(1.15..3.0),
        }
    }
}

/// A specific case, deterministic in `seed`: the structure, sizes and
/// settings drawn from the seed, the joint and effects as given.
pub fn case_with(seed: u64, joint: JointKind, effects: &[EffectKind], o: &CaseOptions) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x1d_c0ffee);
    let mass = log_uniform(&mut rng, 0.1, 100.0);
    let f_slip = log_uniform(&mut rng, 20.0, 2000.0);
    let w = 2.0 * PI * f_slip;
    let stiffness = mass * w * w;
    let kd = stiffness * log_uniform(&mut rng, 0.3, 5.0);
    let zeta = rng.random_range(0.005..0.03);
    let damping = 2.0 * zeta * (stiffness * mass).sqrt();
    // slip displacement Fd/kd between 1 µm and 100 µm
    let fd = kd * log_uniform(&mut rng, 1e-6, 1e-4);
    let nl = o.levels.unwrap_or_else(|| rng.random_range(4..=7usize));
    let (lo, hi) = (0.02 * fd, 60.0 * fd);
    let levels: Vec<f64> = (0..nl)
        .map(|i| lo * (hi / lo).powf(i as f64 / (nl - 1) as f64))
        .collect();
    let nf = o
        .frequencies
        .unwrap_or_else(|| rng.random_range(12..=20usize));
    let f_stuck = ((stiffness + kd) / mass).sqrt() / (2.0 * PI);
    let mut broad = o.broad.then(|| Broad::new(seed));
    let (flo, fhi) = match broad.as_mut().map(Broad::band) {
        Some((lo, hi)) => (lo * f_slip, (hi * f_stuck).max(1.2 * lo * f_slip)),
        None => (0.6 * f_slip, 1.4 * f_stuck),
    };
    // a log grid over the band plus points around both resonances
    let n_near = (nf / 5).max(1);
    let n_grid = nf - 2 * n_near;
    let mut frequencies: Vec<f64> = (0..n_grid)
        .map(|i| flo * (fhi / flo).powf(i as f64 / (n_grid - 1).max(1) as f64))
        .collect();
    for &fr in &[f_slip, f_stuck] {
        // a band that cuts a resonance holds no points beyond its ends
        let inside = |f: f64| !o.broad || (f >= flo && f <= fhi);
        for i in 0..n_near {
            let u = if n_near == 1 {
                0.0
            } else {
                i as f64 / (n_near - 1) as f64 * 2.0 - 1.0
            };
            // within the half-power band, where damping shows
            let f = fr * (1.0 + 1.5 * zeta * u + rng.random_range(-0.3..0.3) * zeta);
            if inside(f) {
                frequencies.push(f);
            }
        }
    }
    // off any round value: a small random detuning
    for f in &mut frequencies {
        *f *= 1.0 + rng.random_range(-2e-3..2e-3);
    }
    frequencies.sort_by(f64::total_cmp);
    frequencies.dedup_by(|a, b| (*a / *b - 1.0).abs() < 1e-3);
    let ftop = *frequencies.last().unwrap();
    let ok: Vec<u32> = RATES
        .iter()
        .copied()
        .filter(|&r| r as f64 >= 20.0 * ftop)
        .collect();
    let sample_rate = ok[0];
    let format = o.format.unwrap_or_else(|| {
        [
            SampleFormat::Float32,
            SampleFormat::Pcm16,
            SampleFormat::Pcm24,
        ][rng.random_range(0..3usize)]
    });
    let quantity = o.quantity.unwrap_or_else(|| {
        [
            Quantity::Displacement,
            Quantity::Velocity,
            Quantity::Acceleration,
        ][rng.random_range(0..3usize)]
    });
    let sweep = o
        .sweep
        .unwrap_or_else(|| [Sweep::Up, Sweep::Down, Sweep::Alternate][rng.random_range(0..3usize)]);
    let with_steps = o
        .with_steps
        .unwrap_or_else(|| rng.random_range(0.0..1.0) < 0.7);
    let mut case = Case {
        seed,
        name: format!("case-{seed}"),
        mass,
        stiffness,
        damping,
        joint,
        kd,
        fd,
        effects: Vec::new(),
        levels,
        frequencies,
        sweep,
        sample_rate,
        format,
        quantity,
        with_steps,
        response_noise: broad.as_mut().map_or(0.10, Broad::noise),
        force_noise: 0.005,
        analysis_periods: rng.random_range(16..=32u64),
        substeps: 16,
        coil: None,
        gauge: false,
    };
    let x_top = case.top_amplitude();
    let mut kinds = effects.to_vec();
    kinds.sort();
    for kind in kinds {
        let e = match kind {
            EffectKind::CubicStiffness => {
                // 3/4 k3 X² = ±(3–12 %) of k at the top level's resonance
                let delta = broad
                    .as_mut()
                    .map(|b| b.size(0.03, 0.6))
                    .unwrap_or_else(|| rng.random_range(0.03..0.12))
                    * if rng.random_range(0.0..1.0) < 0.5 {
                        -1.0
                    } else {
                        1.0
                    };
                TrueEffect::Cubic {
                    k3: delta * stiffness / (0.75 * x_top * x_top),
                }
            }
            EffectKind::QuadraticDamping => {
                // 8/(3π) c2 ω X = (15–45 %) of c at the top level's resonance
                let delta = broad
                    .as_mut()
                    .map(|b| b.size(0.15, 3.0))
                    .unwrap_or_else(|| rng.random_range(0.15..0.45));
                TrueEffect::QuadDamping {
                    c2: delta * damping / (8.0 / (3.0 * PI) * w * x_top),
                }
            }
            EffectKind::BilinearStiffness => {
                // one-sided contact, kb = 0.4–1.0 k: H2 ~ 0.07 kb/k of H1
                TrueEffect::Bilinear {
                    kb: broad
                        .as_mut()
                        .map(|b| b.size(0.4, 4.0))
                        .unwrap_or_else(|| rng.random_range(0.4..1.0))
                        * stiffness,
                }
            }
            EffectKind::Clearance => {
                // gap at 30–60 % of the top amplitude, effective stiffness
                // 5–15 % of k there
                let g: f64 = rng.random_range(0.3..0.6);
                let frac = 1.0 - 2.0 / PI * (g.asin() + g * (1.0 - g * g).sqrt());
                let delta = broad
                    .as_mut()
                    .map(|b| b.size(0.05, 0.8))
                    .unwrap_or_else(|| rng.random_range(0.05..0.15));
                TrueEffect::Clearance {
                    k: delta * stiffness / frac,
                    gap: g * x_top,
                }
            }
            EffectKind::SecondMode => {
                let f2 = if rng.random_range(0.0..1.0) < 0.75 {
                    ftop * rng.random_range(1.6..3.0)
                } else {
                    flo * rng.random_range(0.3..0.5)
                };
                let f2 = match broad.as_mut() {
                    Some(b) => b.further_mode(flo, ftop, [f_slip, f_stuck]),
                    None => f2,
                };
                TrueEffect::SecondMode {
                    frequency_hz: f2,
                    damping_ratio: rng.random_range(0.01..0.03),
                    modal_mass: mass * log_uniform(&mut rng, 0.5, 2.0),
                }
            }
        };
        case.effects.push(e);
    }
    // the second mode may need a faster sample rate
    if let Some(f2) = case.effects.iter().find_map(|e| match e {
        TrueEffect::SecondMode { frequency_hz, .. } => Some(*frequency_hz),
        _ => None,
    }) && (case.sample_rate as f64) < 8.0 * f2
    {
        case.sample_rate = RATES
            .iter()
            .copied()
            .find(|&r| r as f64 >= 8.0 * f2)
            .unwrap_or(204800);
    }
    case
}

/// A case drawn over what users have: joint, effects and everything else
/// from the seed.
pub fn draw_case(seed: u64) -> Case {
    draw_case_with(seed, false)
}

fn draw_case_with(seed: u64, broad: bool) -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ 7);
    let joint = if rng.random_range(0.0..1.0) < 0.4 {
        JointKind::Jenkins
    } else {
        JointKind::Masing {
            n: (rng.random_range(0.0f64..20f64.ln())).exp().max(1.0),
        }
    };
    let u: f64 = rng.random_range(0.0..1.0);
    let all = EffectKind::ALL;
    let effects: Vec<EffectKind> = if u < 0.25 {
        vec![] // the control
    } else if u < 0.85 {
        vec![all[rng.random_range(0..5usize)]]
    } else {
        let a = rng.random_range(0..5usize);
        let b = (a + rng.random_range(1..5usize)) % 5;
        vec![all[a], all[b]]
    };
    let o = CaseOptions {
        broad,
        ..CaseOptions::default()
    };
    case_with(seed, joint, &effects, &o)
}

/// A case drawn over the broad ranges (issue 70): everything
/// [`draw_case`] draws, and bands that cut a resonance, effects from just
/// resolvable to dominant, a further mode anywhere from below the band to
/// above it, noise 0.3-10 %. Seeds below 1000 are for development; seeds
/// from 1000 up are the held-out test set.
pub fn draw_broad(seed: u64) -> Case {
    let mut case = draw_case_with(seed, true);
    case.name = format!("broad-{seed}");
    case
}

/// A generated recording: per-sample channels and the dwells' sample
/// ranges.
#[derive(Clone, Debug)]
pub struct Recording {
    pub sample_rate: u32,
    pub force: Vec<f64>,
    pub response: Vec<f64>,
    /// (frequency, level, start, settle, length) per dwell, in time order.
    pub steps: Vec<(f64, f64, usize, usize, usize)>,
    /// The clean (noise-free) response, for checks.
    pub clean_response: Vec<f64>,
    pub clean_force: Vec<f64>,
    /// With a coil, the force it applies with the force's noise (its own
    /// random stream: the other channels are the same with it or without).
    pub gauge: Vec<f64>,
}

/// Simulates the case and adds the seeded noise.
pub fn generate(case: &Case) -> Recording {
    generate_with(case, &[])
}

/// [`generate`], with further systems `parts` driven by the same force and
/// their motions added to the case's: a mode with a joint of its own is an
/// SDOF of its own, uncoupled from the rest (the sidecar does not describe
/// them).
pub fn generate_with(case: &Case, parts: &[RefSystem]) -> Recording {
    let fs = case.sample_rate as f64;
    let tau = case.slowest_tau();
    let mut spec = Vec::new();
    for (l, j) in case.order() {
        let f = case.frequencies[j];
        let a = case.levels[l];
        // settle: 5 slowest time constants, at least 20 periods, at most 250
        let settle_periods = ((5.0 * tau * f).ceil() as u64).clamp(20, 250);
        let periods = settle_periods + case.analysis_periods;
        spec.push((f, a, periods, settle_periods as f64 / f));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(case.seed ^ 0x5eed_0000_0001);
    // the first switch lies between samples, not on the grid
    let t_start = rng.random_range(0.1..0.9) / fs + 4.0 / fs;
    let sine = SteppedSine::new(t_start, &spec);
    let n = (sine.t_end() * fs).floor() as usize + 1;
    let sys = case.system();
    let mut out = sys.simulate(&sine, fs, n, case.substeps);
    for part in parts {
        let o = part.simulate(&sine, fs, n, case.substeps);
        for (a, b) in [
            (&mut out.displacement, &o.displacement),
            (&mut out.velocity, &o.velocity),
            (&mut out.acceleration, &o.acceleration),
        ] {
            a.iter_mut().zip(b).for_each(|(a, b)| *a += b);
        }
    }
    let clean_response = match case.quantity {
        Quantity::Displacement => out.displacement,
        Quantity::Velocity => out.velocity,
        Quantity::Acceleration => out.acceleration,
    };
    let first_at = |t: f64| ((t * fs).ceil() as usize).min(n);
    let mut steps = Vec::new();
    for d in &sine.dwells {
        let s = first_at(d.t0);
        let e = first_at(d.t_end());
        let settle = first_at(d.t0 + d.settle_s) - s;
        steps.push((d.frequency_hz, d.amplitude, s, settle, e - s));
    }
    // noise: RMS relative to each dwell's clean RMS (over the dwell)
    let mut force = out.force.clone();
    let mut response = clean_response.clone();
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
    let mut covered = 0;
    for &(_, _, s, _, len) in &steps {
        let (r_rms, f_rms) = (
            rms(&clean_response[s..s + len]),
            rms(&out.force[s..s + len]),
        );
        for i in covered.max(s)..s + len {
            let a: f64 = StandardNormal.sample(&mut rng);
            let b: f64 = StandardNormal.sample(&mut rng);
            response[i] += case.response_noise * r_rms * a;
            force[i] += case.force_noise * f_rms * b;
        }
        covered = s + len;
    }
    // the few samples before the first dwell carry the first dwell's noise
    if let Some(&(_, _, s, _, len)) = steps.first() {
        let (r_rms, f_rms) = (
            rms(&clean_response[s..s + len]),
            rms(&out.force[s..s + len]),
        );
        for i in 0..s {
            let a: f64 = StandardNormal.sample(&mut rng);
            let b: f64 = StandardNormal.sample(&mut rng);
            response[i] += case.response_noise * r_rms * a;
            force[i] += case.force_noise * f_rms * b;
        }
    }
    let mut gauge = Vec::new();
    if case.coil.is_some() {
        let mut rng = ChaCha8Rng::seed_from_u64(case.seed ^ 0x5eed_0000_0002);
        gauge = out.drive_force.clone();
        for &(_, _, s, _, len) in &steps {
            let g_rms = rms(&out.drive_force[s..s + len]);
            for g in &mut gauge[s..s + len] {
                let z: f64 = StandardNormal.sample(&mut rng);
                *g += case.force_noise * g_rms * z;
            }
        }
    }
    Recording {
        sample_rate: case.sample_rate,
        force,
        response,
        steps,
        clean_response,
        clean_force: out.force,
        gauge,
    }
}
