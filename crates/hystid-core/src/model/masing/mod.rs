//! The Masing element: the paper's eq. (10) backbone with memory.
//!
//! Eq. (10), `F = kd x / (1 + (kd x/Fd)^N)^(1/N)`, is a backbone (virgin
//! curve). Written with `|x|` it is odd and defined for any real `N > 0` (as
//! printed, `(kd x/Fd)^N` is undefined for `x < 0` and non-integer `N`).
//! Loading and unloading follow the extended Masing rules (Masing 1926;
//! Pyke 1979; Kramer 1996, §6.4), kept with a stack of turning points:
//!
//! 1. first loading follows the backbone `f`;
//! 2. after a reversal at `(x_r, F_r)` the branch is `F_r + 2 f((x − x_r)/2)`;
//! 3. a branch that passes the largest past excursion rejoins the backbone;
//! 4. a branch that meets the branch of an earlier cycle continues along it,
//!    and the inner loop is erased (wipe-out, return-point memory).
//!
//! The backbone is a type parameter: [`PowerBackbone`] is eq. (10);
//! [`PiecewiseLinearBackbone`] gives the exact Masing model of a parallel bank
//! of Jenkins elements (an Iwan model), which the tests use as an independent
//! reference for the stack logic.

use super::element::{
    Description, Domain, Element, ElementForce, FitScale, ImplicitStep, Law, ParameterInfo, Role,
    SLIP_FORCE, SOLVE_TOLERANCE, STICK_STIFFNESS, SensitivityTerms, copy_short, sign,
};
use crate::error::{Error, Result, require_positive};
use num_complex::Complex64;
use std::cell::Cell;
use std::f64::consts::PI;
use std::sync::{Arc, OnceLock};

/// An odd, monotone virgin curve `f(x)` with `f'(0) > 0`.
pub trait Backbone: Clone {
    /// `(f(x), f'(x))`.
    fn eval(&self, x: f64) -> (f64, f64);

    /// `(f(x), f'(x), f''(x))`; the default has no curvature information and
    /// reports 0, which is only right together with `taylor_radius() = 0`.
    fn eval_with_curvature(&self, x: f64) -> (f64, f64, f64) {
        let (f, k) = self.eval(x);
        (f, k, 0.0)
    }

    /// Within this distance of an exactly evaluated point, a second-order
    /// Taylor expansion reproduces the branch to ~1e-13 of the slip force
    /// (0: never expand).
    fn taylor_radius(&self) -> f64 {
        0.0
    }

    /// The radius for an expansion about the backbone argument `x`, at most
    /// [`Backbone::taylor_radius`]: smaller near the origin where the
    /// curvature varies fast (the default: the same everywhere).
    fn taylor_radius_at(&self, _x: f64) -> f64 {
        self.taylor_radius()
    }

    /// The displacement where the backbone bends from stick toward slip
    /// (`Fd/kd` for eq. (10)), where a quadrature of its loop splits its
    /// panels; `None`: no known knee, no quadrature.
    fn knee(&self) -> Option<f64> {
        None
    }
}

/// `r^N` below this is lost in `1 + r^N` (2^-60): the backbone is linear.
const NEGLIGIBLE_LN: f64 = 41.6;

/// Paper eq. (10) made odd: `f(x) = kd x / (1 + |kd x/Fd|^N)^(1/N)`.
///
/// Evaluated without overflow for any `N > 0` (tested up to 1e4): for
/// `r = |kd x/Fd| ≤ 1` as `kd x (1 + r^N)^(-1/N)`, above as
/// `±Fd (1 + r^-N)^(-1/N)`; far from the knee the transcendental functions are
/// skipped because the correction is below f64 resolution.
///
/// [`PowerBackbone::new`] evaluates the formula (four transcendental
/// functions per call); [`PowerBackbone::tabulated`], which the [`Masing`]
/// element uses, evaluates a precomputed piecewise-quintic table of it
/// instead, several times faster and within 4e-15 of it (relative).
#[derive(Clone)]
pub struct PowerBackbone {
    kd: f64,
    fd: f64,
    n: f64,
    kd_over_fd: f64,
    /// Below this `r`, `r^N < 2^-60`.
    r_linear: f64,
    /// Above this `r`, `r^-N < 2^-60`.
    r_saturated: f64,
    /// See [`Backbone::taylor_radius`].
    taylor_radius: f64,
    /// See [`Backbone::taylor_radius_at`]: the radius is at most this
    /// fraction of `|x|` (infinite for `N ≥ 2`).
    taylor_relative: f64,
    /// Shared by clones (an element per thread, one table).
    table: Option<Arc<BackboneTable>>,
}

impl std::fmt::Debug for PowerBackbone {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PowerBackbone")
            .field("kd", &self.kd)
            .field("fd", &self.fd)
            .field("n", &self.n)
            .field("table_cells", &self.table.as_ref().map(|t| t.cells.len()))
            .finish()
    }
}

/// Equal parameters and the same evaluation (the formula, or a table, which
/// is a function of the parameters).
impl PartialEq for PowerBackbone {
    fn eq(&self, o: &Self) -> bool {
        (self.kd, self.fd, self.n) == (o.kd, o.fd, o.n) && self.table.is_some() == o.table.is_some()
    }
}

impl PowerBackbone {
    /// Eq. (10) at `x` (`r = |kd x/Fd|` between the fast paths). The tangent
    /// and curvature follow from `f` without further transcendentals: with
    /// `p = r^N`, `f' = (f/x)/(1 + p)` and `f'' = −(N + 1) f' p / (x (1 + p))`.
    #[inline(never)]
    fn formula(&self, x: f64, r: f64) -> (f64, f64, f64) {
        // ln(1 + p) rather than ln_1p(p): only its absolute accuracy matters
        let n = self.n;
        let ln_r = r.ln();
        if r <= 1.0 {
            let p = (n * ln_r).exp(); // r^N
            let s = (-(1.0 + p).ln() / n).exp();
            let k = self.kd * s / (1.0 + p);
            (self.kd * x * s, k, -(n + 1.0) * k * p / ((1.0 + p) * x))
        } else {
            let q = (-n * ln_r).exp(); // r^-N
            let f = sign(x) * self.fd * (-(1.0 + q).ln() / n).exp();
            let k = f / x * q / (1.0 + q);
            (f, k, -(n + 1.0) * k / ((1.0 + q) * x))
        }
    }

    /// Eq. (10) with stick stiffness `kd`, slip force `fd` and curvature `n`,
    /// evaluated from the formula.
    pub fn new(kd: f64, fd: f64, n: f64) -> Result<PowerBackbone> {
        require_positive("joint.kd", kd)?;
        require_positive("joint.fd", fd)?;
        require_positive("joint.n", n)?;
        Ok(PowerBackbone {
            kd,
            fd,
            n,
            kd_over_fd: kd / fd,
            r_linear: (-NEGLIGIBLE_LN / n).exp(),
            r_saturated: (NEGLIGIBLE_LN / n).exp(),
            // the expansion's error is ~ f''' h³/6 with f''' ~ kd N²/x_c² near
            // the knee: h = 8e-5 x_c N^(-2/3) keeps it below 1e-13 Fd
            taylor_radius: 8e-5 * (fd / kd) / n.max(1.0).powf(2.0 / 3.0),
            // for N < 2, f''' ≈ −(kd/x_c²)(N+1)(N−1) r^(N−2) grows without bound
            // toward the origin (just after a reversal); a radius of 1e-4 |x|
            // keeps (N+1)|N−1| r^(N+1) (1e-4)³/6 below 1e-13 Fd up to where
            // the fixed radius takes over
            taylor_relative: if n < 2.0 { 1e-4 } else { f64::INFINITY },
            table: None,
        })
    }

    /// Eq. (10) evaluated from a table built here (~0.1 ms and ~50 kB for
    /// `n ≥ 1`, shared by clones): the force within 4e-15 of the formula's
    /// (relative), the tangent within ~1e-13 of the secant `f(x)/x`; tangent
    /// and curvature are the table's own derivatives, so Newton and the
    /// Taylor expansion see one smooth (C²) law. For an `n` the table does
    /// not cover (below ~0.15) the formula is used.
    pub fn tabulated(kd: f64, fd: f64, n: f64) -> Result<PowerBackbone> {
        let mut b = PowerBackbone::new(kd, fd, n)?;
        b.table = BackboneTable::shared(n, b.r_linear, b.r_saturated);
        Ok(b)
    }

    /// Whether the backbone is evaluated from a table
    /// ([`PowerBackbone::tabulated`]).
    pub fn is_tabulated(&self) -> bool {
        self.table.is_some()
    }

    /// `(kd, fd, n)`.
    pub fn parameters(&self) -> (f64, f64, f64) {
        (self.kd, self.fd, self.n)
    }
}

impl Backbone for PowerBackbone {
    fn knee(&self) -> Option<f64> {
        Some(self.fd / self.kd)
    }

    #[inline(always)]
    fn eval(&self, x: f64) -> (f64, f64) {
        let (f, k, _) = self.eval_with_curvature(x);
        (f, k)
    }

    /// From the table when there is one ([`PowerBackbone::tabulated`]),
    /// else the formula; the tangent and curvature follow from `f` without
    /// further transcendentals: with `p = r^N`, `f' = (f/x)/(1 + p)` and
    /// `f'' = −(N + 1) f' p / (x (1 + p))`.
    #[inline(always)]
    fn eval_with_curvature(&self, x: f64) -> (f64, f64, f64) {
        let r = (self.kd_over_fd * x).abs();
        if r <= self.r_linear {
            return (self.kd * x, self.kd, 0.0);
        }
        if r >= self.r_saturated {
            // the tangent kd r^-(N+1) (1 + r^-N)^(-(N+1)/N) is below kd 2^-60
            // here; it is returned as 0 (Newton and AFT cannot tell)
            return (sign(x) * self.fd, 0.0, 0.0);
        }
        if let Some((phi, dphi, ddphi)) = self.table.as_ref().and_then(|t| t.eval(r)) {
            let s = sign(x);
            return (
                s * self.fd * phi,
                self.kd * dphi,
                s * self.kd * self.kd_over_fd * ddphi,
            );
        }
        self.formula(x, r)
    }

    fn taylor_radius(&self) -> f64 {
        self.taylor_radius
    }

    #[inline(always)]
    fn taylor_radius_at(&self, x: f64) -> f64 {
        self.taylor_radius.min(self.taylor_relative * x.abs())
    }
}

/// Eq. (10) in the normalised form `φ(r) = r (1 + r^N)^(-1/N)`,
/// `r = |kd x/Fd|` (`f = ±Fd φ`, `f' = kd φ'`, `f'' = ±(kd²/Fd) φ''`),
/// tabulated on `r_linear < r < r_saturated`.
///
/// What is interpolated is the deficit `ψ` from the nearer asymptote,
/// `ψ = r − φ` for `r ≤ 1` and `ψ = 1 − φ` above, computed with `expm1`
/// and `ln1p`: it is small where `φ` is nearly linear or nearly saturated,
/// so its rounding errors are small too and the interpolant's derivative
/// (in effect a difference quotient of node values) stays accurate on
/// short cells.
///
/// Cells are addressed by the bits of `r`, with no logarithm: the exponent
/// and the top `k` mantissa bits pick a segment (`2^k` per octave, `k ≈
/// log₂ N` so that a segment is about as wide as the knee); a segment is
/// split into `2^m` equal cells, `m` chosen per segment by halving until the
/// quintic Hermite interpolant of `(ψ, ψ', ψ'')` meets the tolerances at
/// every cell's midpoint, where its error `∝ (t(1−t))³` peaks (the
/// tangent's error, `∝ d/dt (t(1−t))³`, peaks at ~3.5/h times that).
/// Segments never straddle `r = 1`, a power of two.
#[derive(Clone, PartialEq)]
struct BackboneTable {
    /// `52 − k`: the bits of `r` below a segment's.
    segment_shift: u32,
    /// `bits(r) >> segment_shift` of the first segment.
    first_segment: u64,
    segments: Vec<Segment>,
    /// `ψ(t) = Σ c_i t^i` on each cell, `t ∈ [0, 1)` across it.
    cells: Vec<[f64; 6]>,
}

#[derive(Clone, Copy, PartialEq)]
struct Segment {
    /// Index of the segment's first cell.
    cell: u32,
    /// `segment_shift − m`: the bits of `r` within a cell.
    cell_shift: u32,
    /// 1 on the `r ≤ 1` side (`φ = r − ψ`), 0 above (`φ = 1 − ψ`).
    linear: f64,
    /// 1 / cell width.
    inv_width: f64,
    /// `2^-cell_shift`: a cell's bits to `t`.
    t_scale: f64,
}

/// `φ`, `ψ`, `ψ'`, `ψ''` at one `r`, from the formula.
#[derive(Clone, Copy)]
struct TableNode {
    phi: f64,
    psi: f64,
    dpsi: f64,
    ddpsi: f64,
}

/// Accuracy of `φ`, relative.
const TABLE_TOLERANCE: f64 = 4e-15;
/// Accuracy of `φ'` relative to the secant `φ/r` (interpolation error; a
/// cell whose error is at rounding level is not split further).
const TABLE_TANGENT_TOLERANCE: f64 = 1e-13;
/// Limits past which the formula is used instead (`n` below ~0.15).
const TABLE_MAX_SEGMENTS: u64 = 4096;
const TABLE_MAX_CELLS: usize = 1 << 14;
const TABLE_MAX_SPLIT: u32 = 20;

/// The tables of the exponents used last, newest at the end: a fit builds
/// its model afresh at every evaluation (per series, per Jacobian column),
/// mostly at an exponent it has just used, and a table costs as much as a
/// few balanced points. Keyed by the exponent's bits (the table depends on
/// nothing else); a table that could not be built is remembered too.
type BackboneTables = Vec<(u64, Option<Arc<BackboneTable>>)>;
static BACKBONE_TABLES: std::sync::Mutex<BackboneTables> = std::sync::Mutex::new(Vec::new());
/// Enough for a fit's columns and its parallel candidates; at most
/// `TABLE_MAX_CELLS` cells (0.8 MB) each.
const BACKBONE_TABLES_KEPT: usize = 16;

impl BackboneTable {
    /// [`BackboneTable::build`] for exponent `n`, or the same table built
    /// before (shared).
    fn shared(n: f64, r_linear: f64, r_saturated: f64) -> Option<Arc<BackboneTable>> {
        let key = n.to_bits();
        let lookup = |cache: &mut BackboneTables| {
            let i = cache.iter().position(|(k, _)| *k == key)?;
            let hit = cache.remove(i);
            let table = hit.1.clone();
            cache.push(hit);
            Some(table)
        };
        if let Some(t) = lookup(&mut BACKBONE_TABLES.lock().unwrap_or_else(|e| e.into_inner())) {
            return t;
        }
        // built outside the lock (two threads may build the same table:
        // identical, the later one kept)
        let t = Self::build(n, r_linear, r_saturated).map(Arc::new);
        let mut cache = BACKBONE_TABLES.lock().unwrap_or_else(|e| e.into_inner());
        cache.retain(|(k, _)| *k != key);
        if cache.len() == BACKBONE_TABLES_KEPT {
            cache.remove(0);
        }
        cache.push((key, t.clone()));
        t
    }

    fn node(r: f64, n: f64, above: bool) -> TableNode {
        let ln_r = r.ln();
        if !above {
            let p = (n * ln_r).exp(); // r^N
            let l = p.ln_1p() / n;
            let s = (-l).exp(); // φ/r
            let w = -(-l).exp_m1(); // 1 − φ/r
            let dphi = s / (1.0 + p);
            TableNode {
                phi: r * s,
                psi: r * w,
                // 1 − φ' = (1 + p − s)/(1 + p)
                dpsi: (p + w) / (1.0 + p),
                ddpsi: (n + 1.0) * dphi * p / ((1.0 + p) * r),
            }
        } else {
            let q = (-n * ln_r).exp(); // r^-N
            let l = q.ln_1p() / n;
            let phi = (-l).exp();
            let dphi = phi / r * q / (1.0 + q);
            TableNode {
                phi,
                psi: -(-l).exp_m1(),
                dpsi: -dphi,
                ddpsi: (n + 1.0) * dphi / ((1.0 + q) * r),
            }
        }
    }

    /// The quintic on `t ∈ [0, 1]` matching value, slope and curvature at
    /// both ends of a cell of width `h`.
    fn quintic(a: &TableNode, b: &TableNode, h: f64) -> [f64; 6] {
        let (p0, d0, s0) = (a.psi, a.dpsi * h, a.ddpsi * h * h);
        let (p1, d1, s1) = (b.psi, b.dpsi * h, b.ddpsi * h * h);
        let e0 = p1 - p0 - d0 - 0.5 * s0;
        let e1 = d1 - d0 - s0;
        let e2 = s1 - s0;
        [
            p0,
            d0,
            0.5 * s0,
            10.0 * e0 - 4.0 * e1 + 0.5 * e2,
            -15.0 * e0 + 7.0 * e1 - e2,
            6.0 * e0 - 3.0 * e1 + 0.5 * e2,
        ]
    }

    /// `(ψ, dψ/dt, d²ψ/dt²)`; Estrin's scheme keeps the dependency chain
    /// short (the simulator's per-sample solve waits on it).
    #[inline(always)]
    fn poly(c: &[f64; 6], t: f64) -> (f64, f64, f64) {
        let t2 = t * t;
        let t4 = t2 * t2;
        let p = (c[0] + c[1] * t) + t2 * (c[2] + c[3] * t) + t4 * (c[4] + c[5] * t);
        let d = (c[1] + 2.0 * c[2] * t) + t2 * (3.0 * c[3] + 4.0 * c[4] * t) + t4 * (5.0 * c[5]);
        let s = (2.0 * c[2] + 6.0 * c[3] * t) + t2 * (12.0 * c[4] + 20.0 * c[5] * t);
        (p, d, s)
    }

    /// `None` when `n` needs more than the limits allow.
    fn build(n: f64, r_linear: f64, r_saturated: f64) -> Option<BackboneTable> {
        if !(r_linear >= f64::MIN_POSITIVE && r_saturated < f64::MAX) {
            return None;
        }
        let k = (n.log2().floor() as i64 - 1).clamp(2, 20) as u32;
        let segment_shift = 52 - k;
        let first_segment = r_linear.to_bits() >> segment_shift;
        let last_segment = r_saturated.to_bits() >> segment_shift;
        if last_segment - first_segment >= TABLE_MAX_SEGMENTS {
            return None;
        }
        let mut segments = Vec::with_capacity((last_segment - first_segment + 1) as usize);
        let mut cells: Vec<[f64; 6]> = Vec::new();
        let mut mids = Vec::new();
        for seg in first_segment..=last_segment {
            let a = f64::from_bits(seg << segment_shift);
            let b = f64::from_bits((seg + 1) << segment_shift);
            let above = a >= 1.0;
            let mut nodes = vec![Self::node(a, n, above), Self::node(b, n, above)];
            let mut m = 0;
            loop {
                let count = 1usize << m;
                let h = (b - a) / count as f64;
                mids.clear();
                mids.extend((0..count).map(|i| Self::node(a + (i as f64 + 0.5) * h, n, above)));
                let ok = (0..count).all(|i| {
                    let c = Self::quintic(&nodes[i], &nodes[i + 1], h);
                    let e = &mids[i];
                    let err = (Self::poly(&c, 0.5).0 - e.psi).abs();
                    let r = a + (i as f64 + 0.5) * h;
                    let rounding = 8.0 * f64::EPSILON * (e.psi.abs() + h * e.dpsi.abs());
                    err <= TABLE_TOLERANCE * e.phi
                        && (3.5 * err / h <= TABLE_TANGENT_TOLERANCE * e.phi / r || err <= rounding)
                });
                if ok {
                    if cells.len() + count > TABLE_MAX_CELLS {
                        return None;
                    }
                    segments.push(Segment {
                        cell: cells.len() as u32,
                        cell_shift: segment_shift - m,
                        linear: if above { 0.0 } else { 1.0 },
                        inv_width: 1.0 / h,
                        t_scale: 1.0 / (1u64 << (segment_shift - m)) as f64,
                    });
                    cells.extend((0..count).map(|i| Self::quintic(&nodes[i], &nodes[i + 1], h)));
                    break;
                }
                if m == TABLE_MAX_SPLIT || cells.len() + 2 * count > TABLE_MAX_CELLS {
                    return None;
                }
                // the midpoints become nodes of the next level
                let mut finer = Vec::with_capacity(2 * count + 1);
                for i in 0..count {
                    finer.push(nodes[i]);
                    finer.push(mids[i]);
                }
                finer.push(nodes[count]);
                nodes = finer;
                m += 1;
            }
        }
        Some(BackboneTable {
            segment_shift,
            first_segment,
            segments,
            cells,
        })
    }

    /// `(φ, φ', φ'')` for `r_linear < r < r_saturated` (`None` outside).
    #[inline(always)]
    fn eval(&self, r: f64) -> Option<(f64, f64, f64)> {
        let bits = r.to_bits();
        let index = (bits >> self.segment_shift).wrapping_sub(self.first_segment);
        let seg = self.segments.get(index as usize)?;
        let local = bits & ((1u64 << self.segment_shift) - 1);
        let cell = self
            .cells
            .get(seg.cell as usize + (local >> seg.cell_shift) as usize)?;
        let t = (local & ((1u64 << seg.cell_shift) - 1)) as f64 * seg.t_scale;
        let (p, d, s) = Self::poly(cell, t);
        let w = seg.inv_width;
        Some((
            seg.linear * r + (1.0 - seg.linear) - p,
            seg.linear - d * w,
            -s * w * w,
        ))
    }
}

/// A piecewise-linear backbone `f(x) = Σ_i k_i min(|x|, δ_i) sign(x)`: the
/// virgin curve of a parallel bank of Jenkins elements with stiffnesses `k_i`
/// and slip displacements `δ_i` (Iwan 1966).
#[derive(Clone, Debug, PartialEq)]
pub struct PiecewiseLinearBackbone {
    /// `(δ_i, k_i)`, sorted by `δ_i`.
    pub slips: Vec<(f64, f64)>,
}

impl Backbone for PiecewiseLinearBackbone {
    fn eval(&self, x: f64) -> (f64, f64) {
        let a = x.abs();
        let mut f = 0.0;
        let mut k = 0.0;
        for &(d, ki) in &self.slips {
            if a < d {
                f += ki * a;
                k += ki;
            } else {
                f += ki * d;
            }
        }
        (sign(x) * f, k)
    }
}

/// A hysteresis element following the extended Masing rules around a
/// backbone, with a turning-point stack.
#[derive(Clone, Debug)]
pub struct Masing<B: Backbone = PowerBackbone> {
    backbone: B,
    /// Turning points `(x_r, F_r)` that are still open, oldest first.
    stack: Vec<(f64, f64)>,
    x_prev: f64,
    f_prev: f64,
    /// Tangent at the last committed sample (the implicit solve's start).
    k_prev: f64,
    /// Direction of the last committed move: -1, 0 (virgin, at rest), +1.
    direction: i8,
    /// The last exactly evaluated trial since the last commit: nearby trials
    /// on the same branch (the implicit solve's Newton iterates, then the
    /// commit) expand around it instead of re-evaluating the backbone.
    anchor: Cell<Option<Anchor>>,
    /// Sensitivities carried by [`Element::commit_sensitivity`]: their
    /// length `n`, then `(∂x, ∂F)` of the previous sample (`2n`) and of each
    /// open turning point (`2n` each, in stack order).
    sens_dim: usize,
    prev_sens: Vec<f64>,
    stack_sens: Vec<f64>,
    /// Whether `prev_sens`'s `∂F` is still to be formed from its `∂x`, the
    /// tangent `k_prev` and the branch origin: it is needed only when the
    /// sample becomes a turning point, so the structured march does not
    /// form it at every sample.
    prev_force_sens_pending: bool,
    /// Whether [`Element::commit_sensitivity_terms`] has stated the current
    /// branch origin's sensitivities as its memory terms.
    origin_stated: bool,
}

/// An exact evaluation on a branch: position, branch identity, force, tangent,
/// curvature and the reach of its expansion.
#[derive(Clone, Copy, Debug)]
struct Anchor {
    x: f64,
    at: Located,
    force: f64,
    stiffness: f64,
    curvature: f64,
    /// How far from `x` the expansion holds ([`Backbone::taylor_radius_at`]).
    radius: f64,
}

/// Where a displacement lands: its direction, whether the previous sample
/// becomes a turning point, and how many stack entries stay open.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Located {
    direction: i8,
    push: bool,
    open: usize,
}

impl Masing<PowerBackbone> {
    /// The eq. (10) Masing element with stick stiffness `kd`, slip force `fd`
    /// and curvature `n`; its backbone is [`PowerBackbone::tabulated`].
    pub fn new(kd: f64, fd: f64, n: f64) -> Result<Self> {
        Ok(Masing::with_backbone(PowerBackbone::tabulated(kd, fd, n)?))
    }
}

/// Upper bound of the curvature a fit may give: above it eq. (10) cannot be
/// told from a Jenkins element within measurement noise (the cost is flat as
/// `N → ∞`, so an unbounded `N` only wanders).
pub const N_MAX: f64 = 1000.0;

/// Harmonic balance's samples per period for eq. (10) at these parameters
/// (`kd`, `Fd`, `N`; see [`Description::smooth_samples`]). With the turning
/// points located between samples, what is left is the quadrature of a
/// force whose knee narrows in phase as `N` grows. Against 4096 samples, on
/// the paper's system from stuck to slipping (harmonics {1, 3, 5}, 100-350
/// Hz, 5 N to 3 kN), the worst error of `H1` relative to `|H1|` at 128
/// samples is 2.8e-5, 4.8e-5, 8.2e-5 and 1.1e-4 for `N` = 2, 3, 3.5 and 4;
/// the default 256 leave 8.0e-5 at the paper's 22.55. Up to `N = 3.5`, 128
/// samples are as close as the default is for the sharp knees, at half the
/// march (`hb::a_smooth_masing_knee_is_balanced_at_128_samples_as_a_sharp_one_at_256`).
fn smooth_samples(values: &[f64]) -> usize {
    if values[2] <= 3.5 { 128 } else { 256 }
}

impl Law for Masing<PowerBackbone> {
    const DESCRIPTION: Description = Description {
        name: "masing",
        summary: "the eq. (10) backbone kd x / (1 + |kd x/Fd|^N)^(1/N) with Masing's rules",
        parameters: &[
            STICK_STIFFNESS,
            SLIP_FORCE,
            ParameterInfo {
                name: "n",
                unit: "1",
                meaning: "curvature of the stick-to-slip transition",
                domain: Domain::Positive,
                scale: FitScale::Reciprocal {
                    min: 0.5,
                    max: N_MAX,
                },
                role: Role::Other,
                start: 10.0,
            },
        ],
        memory: true,
        odd: true,
        samples_per_period: 0,
        smooth_samples: Some(smooth_samples),
        example: &[2.4e7, 246.048, 22.55],
    };

    fn from_parameters(values: &[f64]) -> Result<Self> {
        Masing::new(values[0], values[1], values[2])
    }
}

/// The describing function of a Masing loop on backbone `b` at `amplitude`,
/// by Gauss–Legendre quadrature with `panels` graded panels each side of the
/// `knee` (paper eq. 10's loop: `Re N = −(4/(πa)) ∫₀^π f(a sin²(θ/2)) cos θ dθ`,
/// `Im N = W/(πa²)` with the loop's area `W = 8∫₀^a f − 4a f(a)`, Masing's
/// rules giving the branches as `F_r ± 2 f((x ∓ x_r)/2)`).
pub fn loop_describing_function<B: Backbone>(
    b: &B,
    knee: f64,
    amplitude: f64,
    panels: usize,
) -> Complex64 {
    let a = amplitude.abs();
    if a == 0.0 {
        return Complex64::new(b.eval(0.0).1, 0.0);
    }
    let xc = knee;
    // Re N: θ in [0, π], knee where a sin²(θ/2) = xc
    let re_integrand = |th: f64| b.eval(a * (0.5 * th).sin().powi(2)).0 * th.cos();
    let (re_int, w_int) = if a > xc {
        let th_c = 2.0 * (xc / a).sqrt().asin();
        (
            // the second panel set runs from the far end toward the knee
            graded(&re_integrand, 0.0, th_c, panels) - graded(&re_integrand, PI, th_c, panels),
            graded(&|u| b.eval(u).0, 0.0, xc, panels) - graded(&|u| b.eval(u).0, a, xc, panels),
        )
    } else {
        (
            graded(&re_integrand, 0.0, PI, panels),
            graded(&|u| b.eval(u).0, 0.0, a, panels),
        )
    };
    let re = -4.0 / (PI * a) * re_int;
    let w = 8.0 * w_int - 4.0 * a * b.eval(a).0;
    Complex64::new(re, w / (PI * a * a))
}

/// `∫` from `from` to `to` (either order) with panels shrinking
/// geometrically (ratio 1/3) toward `to`, 16-point Gauss–Legendre on each.
fn graded(f: &dyn Fn(f64) -> f64, from: f64, to: f64, panels: usize) -> f64 {
    let (nodes, weights) = gauss_legendre_16();
    let total = to - from;
    // widths w, w/3, w/9, ... summing to |total|
    let ratio: f64 = 1.0 / 3.0;
    let first = total * (1.0 - ratio) / (1.0 - ratio.powi(panels as i32));
    let mut sum = 0.0;
    let mut lo = from;
    let mut width = first;
    for p in 0..panels {
        let hi = if p + 1 == panels { to } else { lo + width };
        let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let mut s = 0.0;
        for (x, w) in nodes.iter().zip(weights) {
            s += w * f(mid + half * x);
        }
        sum += s * half;
        lo = hi;
        width *= ratio;
    }
    sum
}

/// 16-point Gauss–Legendre nodes and weights on [−1, 1] (Newton on the
/// Legendre recurrence, computed once).
fn gauss_legendre_16() -> &'static ([f64; 16], [f64; 16]) {
    static TABLE: OnceLock<([f64; 16], [f64; 16])> = OnceLock::new();
    TABLE.get_or_init(|| {
        const N: usize = 16;
        let mut x = [0.0; N];
        let mut w = [0.0; N];
        for i in 0..N {
            let mut z = (PI * (i as f64 + 0.75) / (N as f64 + 0.5)).cos();
            let mut dp = 1.0;
            for _ in 0..100 {
                let (mut p0, mut p1) = (1.0, z);
                for k in 2..=N {
                    let k = k as f64;
                    let p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
                    p0 = p1;
                    p1 = p2;
                }
                dp = N as f64 * (z * p1 - p0) / (z * z - 1.0);
                let dz = p1 / dp;
                z -= dz;
                if dz.abs() < 1e-16 {
                    break;
                }
            }
            x[i] = z;
            w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
        }
        (x, w)
    })
}

impl<B: Backbone> Masing<B> {
    /// A virgin element around any backbone.
    pub fn with_backbone(backbone: B) -> Self {
        let k_prev = backbone.eval(0.0).1;
        Masing {
            backbone,
            stack: Vec::with_capacity(16),
            x_prev: 0.0,
            f_prev: 0.0,
            k_prev,
            direction: 0,
            anchor: Cell::new(None),
            sens_dim: 0,
            prev_sens: Vec::new(),
            prev_force_sens_pending: false,
            origin_stated: false,
            stack_sens: Vec::new(),
        }
    }

    /// The backbone.
    pub fn backbone(&self) -> &B {
        &self.backbone
    }

    /// Open turning points, oldest first.
    pub fn turning_points(&self) -> &[(f64, f64)] {
        &self.stack
    }

    #[inline]
    fn point(&self, i: usize) -> (f64, f64) {
        if i < self.stack.len() {
            self.stack[i]
        } else {
            (self.x_prev, self.f_prev)
        }
    }

    #[inline]
    fn locate(&self, x: f64) -> Located {
        let mut direction = self.direction;
        let mut push = false;
        if x != self.x_prev {
            let d = if x > self.x_prev { 1 } else { -1 };
            push = direction != 0 && d != direction;
            direction = d;
        }
        let mut open = self.stack.len() + push as usize;
        while open > 0 {
            // a branch from the only turning point meets the backbone at the
            // mirror point; otherwise it meets the branch it departed from at
            // that branch's own origin
            let target = if open == 1 {
                -self.point(0).0
            } else {
                self.point(open - 2).0
            };
            let closed = if direction > 0 {
                x >= target
            } else {
                x <= target
            };
            if !closed {
                break;
            }
            open -= if open == 1 { 1 } else { 2 };
        }
        Located {
            direction,
            push,
            open,
        }
    }

    /// The branch's force at `x`, from the anchor when it is close and on
    /// the same branch, else exactly (and then it becomes the anchor if
    /// `remember`: a commit, which clears the anchor, does not need it).
    #[inline]
    fn force_at(&self, x: f64, at: Located, remember: bool) -> ElementForce {
        let (force, stiffness, _) = self.branch_at(x, at, remember);
        ElementForce {
            force,
            stiffness,
            damping: 0.0,
        }
    }

    /// `(force, tangent, curvature)` of the branch `at` at `x` (see
    /// [`Masing::force_at`]); the curvature only when `remember` (0 else:
    /// only the anchor needs it).
    #[inline(always)]
    fn branch_at(&self, x: f64, at: Located, remember: bool) -> (f64, f64, f64) {
        if let Some(a) = self.anchor.get() {
            let h = x - a.x;
            if a.at == at && h.abs() <= a.radius {
                return (
                    a.force + h * (a.stiffness + 0.5 * h * a.curvature),
                    a.stiffness + h * a.curvature,
                    a.curvature,
                );
            }
        }
        // on a branch from (x_r, F_r): F_r + 2 f((x − x_r)/2), tangent f'(·),
        // curvature f''(·)/2; the expansion in x errs by f'''·h³/24, a
        // quarter of the backbone's at its argument's step h/2, so the
        // backbone's radius is safe
        let (arg, origin, scale) = if at.open == 0 {
            (x, 0.0, 1.0)
        } else {
            let (xr, fr) = self.point(at.open - 1);
            (0.5 * (x - xr), fr, 2.0)
        };
        if !remember {
            let (f, k) = self.backbone.eval(arg);
            return (origin + scale * f, k, 0.0);
        }
        let (f, k, c) = self.backbone.eval_with_curvature(arg);
        let (force, stiffness, curvature) = (origin + scale * f, k, c / scale);
        self.anchor.set(Some(Anchor {
            x,
            at,
            force,
            stiffness,
            curvature,
            radius: self.backbone.taylor_radius_at(arg),
        }));
        (force, stiffness, curvature)
    }
}

impl<B: Backbone> Masing<B> {
    /// Whether a trial at `x` would be the expansion about the anchor (the
    /// same quadratic as the anchor's nearby trials).
    #[inline]
    fn expands(&self, x: f64) -> bool {
        self.anchor
            .get()
            .is_some_and(|a| (x - a.x).abs() <= a.radius && self.locate(x) == a.at)
    }
}

/// Newton steps before handing over to the simulator's safeguarded solve.
const SOLVE_STEPS: usize = 4;

impl<B: Backbone> Masing<B> {
    /// The previous sample's `∂F = ∂F_r + k (∂x − ∂x_r)` on its branch from
    /// the origin `r` (the stack's top, unchanged since), `k ∂x` on the
    /// backbone, into `prev_sens` if not formed yet.
    fn form_prev_force_sensitivity(&mut self) {
        if !self.prev_force_sens_pending {
            return;
        }
        self.prev_force_sens_pending = false;
        let (n, k, open) = (self.sens_dim, self.k_prev, self.stack.len());
        let (dx, df) = self.prev_sens.split_at_mut(n);
        if open == 0 {
            for (p, &d) in df.iter_mut().zip(&*dx) {
                *p = k * d;
            }
        } else {
            let r = &self.stack_sens[2 * n * (open - 1)..2 * n * open];
            for i in 0..n {
                df[i] = r[n + i] + k * (dx[i] - r[i]);
            }
        }
    }

    /// Commits `x` and carries the sensitivities through the history:
    /// `prev_sens` holds this sample's `∂x` after it, and its `∂F` once
    /// [`Masing::form_prev_force_sensitivity`] has formed it. Also whether
    /// the branch's origin (the stack's top) changed at this sample.
    fn carry_sensitivity(&mut self, x: f64, dx: &[f64]) -> (ElementForce, bool) {
        let n = dx.len();
        if self.sens_dim != n {
            // first use since reset (or a new size): the history so far is
            // taken as independent of p
            self.sens_dim = n;
            self.prev_sens.clear();
            self.prev_sens.resize(2 * n, 0.0);
            self.stack_sens.clear();
            self.stack_sens.resize(2 * n * self.stack.len(), 0.0);
            self.origin_stated = false;
            self.prev_force_sens_pending = false;
        }
        let at = self.locate(x);
        let f = self.force_at(x, at, false);
        let before = self.stack.len();
        let changed = if at.push && at.open > before {
            self.form_prev_force_sensitivity();
            self.stack.push((self.x_prev, self.f_prev));
            self.stack_sens.extend_from_slice(&self.prev_sens);
            true
        } else {
            self.stack.truncate(at.open);
            self.stack_sens.truncate(2 * n * at.open);
            at.open != before
        };
        copy_short(&mut self.prev_sens[..n], dx);
        self.prev_force_sens_pending = true;
        self.direction = at.direction;
        self.x_prev = x;
        self.f_prev = f.force;
        self.k_prev = f.stiffness;
        self.anchor.set(None);
        (f, changed)
    }
}

impl<B: Backbone> Element for Masing<B> {
    #[inline]
    fn trial(&self, x: f64, _v: f64) -> ElementForce {
        self.force_at(x, self.locate(x), true)
    }

    #[inline]
    fn commit(&mut self, x: f64, _v: f64) -> ElementForce {
        let at = self.locate(x);
        let f = self.force_at(x, at, false);
        if at.push && at.open > self.stack.len() {
            self.stack.push((self.x_prev, self.f_prev));
        } else {
            self.stack.truncate(at.open);
        }
        self.direction = at.direction;
        self.x_prev = x;
        self.f_prev = f.force;
        self.k_prev = f.stiffness;
        // branch identities are relative to the state just changed
        self.anchor.set(None);
        f
    }

    fn reset(&mut self) {
        self.stack.clear();
        self.x_prev = 0.0;
        self.f_prev = 0.0;
        self.k_prev = self.backbone.eval(0.0).1;
        self.direction = 0;
        self.anchor.set(None);
        self.sens_dim = 0;
        self.prev_sens.clear();
        self.prev_force_sens_pending = false;
        self.stack_sens.clear();
    }

    /// On the backbone `∂F = f'(x) ∂x`; on a branch from the turning point
    /// `(x_r, F_r)`, `∂F = ∂F_r + f'((x − x_r)/2) (∂x − ∂x_r)` (the chain
    /// rule through the branch law). Each turning point keeps the `(∂x, ∂F)`
    /// of the sample it was.
    fn commit_sensitivity(
        &mut self,
        x: f64,
        _v: f64,
        dx: &[f64],
        _dv: &[f64],
        df: &mut [f64],
    ) -> ElementForce {
        let n = dx.len();
        let (f, _) = self.carry_sensitivity(x, dx);
        self.form_prev_force_sensitivity();
        for (d, &p) in df.iter_mut().zip(&self.prev_sens[n..]) {
            *d += p;
        }
        f
    }

    fn memory_terms(&self) -> Option<usize> {
        Some(2)
    }

    /// [`Element::commit_sensitivity`]'s `∂F_r + k (∂x − ∂x_r)` on a branch:
    /// the tangent `k` and two memory terms, `1 · ∂F_r` and `−k · ∂x_r`,
    /// whose vectors change when the branch's origin does.
    fn commit_sensitivity_terms(
        &mut self,
        x: f64,
        _v: f64,
        dx: &[f64],
        _dv: &[f64],
        terms: &mut SensitivityTerms,
    ) -> ElementForce {
        let n = dx.len();
        let (f, origin_changed) = self.carry_sensitivity(x, dx);
        let open = self.stack.len();
        terms.tangent(f.stiffness, 0.0);
        if open > 0 {
            if origin_changed || !self.origin_stated {
                let r = &self.stack_sens[2 * n * (open - 1)..2 * n * open];
                terms.replace(0, &r[n..]);
                terms.replace(1, &r[..n]);
                self.origin_stated = true;
            }
            terms.coefficient(0, 1.0);
            terms.coefficient(1, -f.stiffness);
        }
        f
    }

    fn has_memory(&self) -> bool {
        true
    }

    fn odd_law(&self) -> bool {
        true
    }

    /// The loop integral by a cheap quadrature (2 graded panels a side of
    /// the knee, ~1e-5 relative): a starting point, not a prediction.
    fn describing_function(&mut self, amplitude: f64, omega: f64, samples: usize) -> Complex64 {
        match self.backbone.knee() {
            Some(knee) => loop_describing_function(&self.backbone, knee, amplitude, 2),
            None => super::element::loop_fundamental(self, amplitude, omega, samples),
        }
    }

    /// Newton on `R(u) = u − F + g(x_p + bx u)` (see [`ImplicitStep`]) from
    /// the element linearised at its last sample, with what only the
    /// element knows: after a step `δ` from an exact evaluation, on the same
    /// branch and within the Taylor radius, the residual is the expansion's
    /// quadratic term `f'' (bx δ)²/2` alone, so when that is below half the
    /// tolerance the step is accepted without evaluating again (the
    /// simulator's generic solve would spend a second trial to find the
    /// same). `None` after a few steps: the simulator's safeguarded solve
    /// takes over.
    #[inline]
    fn solve_implicit(&self, s: &ImplicitStep) -> Option<f64> {
        // the reciprocal first: it does not wait for this sample's x_pred
        let k0 = self.k_prev;
        let inv = 1.0 / (1.0 + s.bx * k0);
        let mut u = (s.force - self.f_prev - k0 * (s.x_pred - self.x_prev)) * inv;
        for _ in 0..SOLVE_STEPS {
            let x = s.x_pred + s.bx * u;
            let at = self.locate(x);
            let (g, k, c) = self.branch_at(x, at, true);
            let r = u - s.force + g;
            let tol = SOLVE_TOLERANCE * (s.force.abs() + g.abs() + u.abs()) + f64::MIN_POSITIVE;
            if r.abs() <= tol {
                return Some(u);
            }
            let dr = 1.0 + s.bx * k;
            if !(dr > 0.0 && dr.is_finite()) {
                return None;
            }
            let step = r / dr;
            let next = u - step;
            let h = s.bx * step;
            if (0.5 * c * h * h).abs() <= 0.5 * tol && self.expands(s.x_pred + s.bx * next) {
                return Some(next);
            }
            u = next;
        }
        None
    }
}

/// Checks an `n` for the Masing element (used by configuration code).
pub fn validate_curvature(field: &str, n: f64) -> Result<()> {
    if n.is_finite() && n > 0.0 {
        Ok(())
    } else {
        Err(Error::model(
            field,
            format!("must be a finite number > 0, got {n}"),
        ))
    }
}

#[cfg(test)]
mod tests;
