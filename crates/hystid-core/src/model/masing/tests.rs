//! Tests of the Masing element: its backbone, its tables, its implicit solve
//! and its equivalence to an Iwan bank.

use super::*;
use crate::model::Jenkins;
use crate::model::element::check::check_element;
use proptest::prelude::*;
use std::f64::consts::PI;

const KD: f64 = 2.4e7;
const FD: f64 = 246.048;

#[test]
fn passes_the_element_checker() {
    for n in [1.0, 3.0, 22.55, 1000.0] {
        check_element(Masing::new(KD, FD, n).unwrap(), 2e-5, FD);
    }
}

#[test]
fn backbone_is_overflow_safe_and_smooth_across_its_fast_paths() {
    for n in [0.5, 2.0, 22.55, 1e3, 1e4] {
        let b = PowerBackbone::new(KD, FD, n).unwrap();
        for k in -400..=400 {
            let x = FD / KD * 10f64.powf(k as f64 / 100.0);
            let (f, df) = b.eval(x);
            assert!(f.is_finite() && df.is_finite() && df >= 0.0);
            // reference in extended precision-free form, valid where r^N is representable
            let r: f64 = KD * x / FD;
            if (n * r.ln()).abs() < 600.0 {
                let exact = KD * x / (1.0 + r.powf(n)).powf(1.0 / n);
                assert!(
                    (f - exact).abs() <= 1e-12 * exact.abs(),
                    "n={n} x={x}: {f} vs {exact}"
                );
                let exact_df = KD * (1.0 + r.powf(n)).powf(-(n + 1.0) / n);
                assert!(
                    (df - exact_df).abs() <= 1e-12 * KD,
                    "n={n} x={x}: {df} vs {exact_df}"
                );
            }
            let (fm, _) = b.eval(-x);
            assert_eq!(fm, -f);
        }
    }
}

#[test]
fn curvature_matches_a_finite_difference_of_the_tangent() {
    for n in [1.5, 3.0, 22.55, 200.0] {
        let b = PowerBackbone::new(KD, FD, n).unwrap();
        for k in -100..=100 {
            let x = FD / KD * 10f64.powf(k as f64 / 100.0);
            let (_, _, c) = b.eval_with_curvature(x);
            let h = 1e-6 * x;
            let fd = (b.eval(x + h).1 - b.eval(x - h).1) / (2.0 * h);
            assert!(
                (c - fd).abs() <= 1e-5 * fd.abs() + 1e-9 * KD * KD / FD,
                "n={n} x={x}: {c} vs {fd}"
            );
        }
    }
}

#[test]
fn taylor_expansion_stays_within_1e_13_of_the_slip_force() {
    // trials near an exact one reuse it; they must agree with a fresh element
    for n in [1.5, 3.0, 22.55, 1000.0] {
        let hist: Vec<f64> = (1..=30).map(|i| i as f64 * 0.05 * FD / KD).collect();
        let fresh = || {
            let mut m = Masing::new(KD, FD, n).unwrap();
            for &x in &hist {
                m.commit(x, 0.0);
            }
            m
        };
        let a = fresh();
        let x0 = 1.6 * FD / KD;
        a.trial(x0, 0.0);
        let r = a.backbone().taylor_radius();
        for frac in [0.1, 0.5, 1.0, -1.0] {
            let x = x0 + frac * r;
            let got = a.trial(x, 0.0).force;
            let exact = fresh().trial(x, 0.0).force;
            assert!((got - exact).abs() < 1e-13 * FD, "n={n}: {got} vs {exact}");
        }
    }
}

#[test]
fn large_n_matches_jenkins_within_half_a_percent_of_fd() {
    let mut m = Masing::new(KD, FD, 1000.0).unwrap();
    let mut j = Jenkins::new(KD, FD).unwrap();
    let xs = crate::model::element::check::history(3.0 * FD / KD);
    let mut worst: f64 = 0.0;
    for &x in &xs {
        let a = m.commit(x, 0.0).force;
        let b = j.commit(x, 0.0).force;
        worst = worst.max((a - b).abs());
    }
    assert!(worst < 0.005 * FD, "worst difference {worst} N");
}

/// The formula's `(f, f', f'')` (the reference for the table).
fn formula(n: f64) -> PowerBackbone {
    PowerBackbone::new(KD, FD, n).unwrap()
}

#[test]
fn backbones_of_one_exponent_share_the_table_built_for_the_first() {
    // exponents no other test uses, so that the first call builds
    let (a, b) = (
        PowerBackbone::tabulated(KD, FD, 5.4321).unwrap(),
        PowerBackbone::tabulated(2.0 * KD, 0.5 * FD, 5.4321).unwrap(),
    );
    let (ta, tb) = (a.table.as_ref().unwrap(), b.table.as_ref().unwrap());
    assert!(Arc::ptr_eq(ta, tb), "one exponent, one table");
    let fresh = BackboneTable::build(5.4321, a.r_linear, a.r_saturated).unwrap();
    assert!(**ta == fresh, "the shared table is the one built afresh");
    let other = PowerBackbone::tabulated(KD, FD, 5.4322).unwrap();
    assert!(!Arc::ptr_eq(ta, other.table.as_ref().unwrap()));
    // more exponents than are kept: the first is built again, the same
    for i in 0..=BACKBONE_TABLES_KEPT {
        PowerBackbone::tabulated(KD, FD, 6.0 + 0.001 * i as f64).unwrap();
    }
    let again = PowerBackbone::tabulated(KD, FD, 5.4321).unwrap();
    assert!(**again.table.as_ref().unwrap() == fresh);
    // a table the exponent does not allow is remembered as none
    assert!(
        !PowerBackbone::tabulated(KD, FD, 0.05)
            .unwrap()
            .is_tabulated()
    );
    assert!(
        !PowerBackbone::tabulated(KD, FD, 0.05)
            .unwrap()
            .is_tabulated()
    );
}

#[test]
fn table_matches_the_formula_over_the_whole_range() {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(10);
    for n in [0.5, 0.8, 1.0, 1.5, 3.0, 7.0, 22.55, 100.0, 1000.0, 1e4] {
        let t = PowerBackbone::tabulated(KD, FD, n).unwrap();
        assert!(t.is_tabulated(), "n={n}");
        let e = formula(n);
        // beyond both fast-path limits, log-uniform, plus the knee densely
        let (lo, hi) = ((e.r_linear / 4.0).ln(), (e.r_saturated * 4.0).ln());
        let mut worst = [0.0f64; 3];
        for i in 0..40_000 {
            let r: f64 = if i % 2 == 0 {
                (lo + (hi - lo) * rng.random::<f64>()).exp()
            } else {
                1.0 + (rng.random::<f64>() - 0.5) * 8.0 / n.max(1.0)
            };
            let x = if i % 3 == 0 { -r } else { r } * FD / KD;
            let (f, k, c) = t.eval_with_curvature(x);
            let (fe, ke, ce) = e.eval_with_curvature(x);
            // the secant f/x bounds the tangent of a concave backbone
            let secant = fe / x;
            worst[0] = worst[0].max((f - fe).abs() / fe.abs());
            worst[1] = worst[1].max((k - ke).abs() / secant);
            worst[2] = worst[2].max((c - ce).abs() / (ce.abs() + 1e-6 * secant * KD / FD));
        }
        // the table is built to 4e-15 and 1e-13; the formula's own
        // rounding is a few ulp. The curvature only feeds the Taylor
        // expansion, so a loose bound on it serves
        assert!(worst[0] < 1e-14, "n={n}: force {:e}", worst[0]);
        assert!(worst[1] < 2e-12, "n={n}: tangent {:e}", worst[1]);
        assert!(worst[2] < 1e-3, "n={n}: curvature {:e}", worst[2]);
    }
}

#[test]
fn table_is_odd_continuous_at_cell_edges_and_falls_back_for_tiny_n() {
    for n in [0.7, 3.0, 22.55, 5000.0] {
        let b = PowerBackbone::tabulated(KD, FD, n).unwrap();
        let table = b.table.as_ref().unwrap();
        let mut edges = 0;
        for (i, seg) in table.segments.iter().enumerate() {
            let end = table
                .segments
                .get(i + 1)
                .map_or(table.cells.len(), |s| s.cell as usize);
            let first = (table.first_segment + i as u64) << table.segment_shift;
            for j in 0..(end - seg.cell as usize) as u64 {
                // a cell's first r and the float just below it, in the
                // previous cell (or segment)
                let r = f64::from_bits(first + (j << seg.cell_shift));
                let (Some(right), Some(left)) = (table.eval(r), table.eval(r.next_down())) else {
                    continue; // outside the tabulated range
                };
                edges += 1;
                // C²: value, slope, curvature agree (beside the one-ulp
                // step in r)
                let slope = right.1.abs() + right.0 / r;
                assert!((right.0 - left.0).abs() <= 1e-15 * right.0, "n={n} r={r}");
                assert!((right.1 - left.1).abs() <= 1e-12 * slope, "n={n} r={r}");
                assert!(
                    (right.2 - left.2).abs() <= 1e-6 * (right.2.abs() + slope / r),
                    "n={n} r={r}"
                );
            }
        }
        assert!(edges > 100, "n={n}: {edges} edges");
        for k in -300..=300 {
            let x = FD / KD * 10f64.powf(k as f64 / 100.0);
            let (f, df, c) = b.eval_with_curvature(x);
            let (fm, dfm, cm) = b.eval_with_curvature(-x);
            assert!(fm == -f && dfm == df && cm == -c, "n={n} x={x}");
        }
    }
    // below the table's range the formula is used
    let tiny = PowerBackbone::tabulated(KD, FD, 0.05).unwrap();
    assert!(!tiny.is_tabulated());
    let x = 3.0 * FD / KD;
    assert_eq!(tiny.eval(x), formula(0.05).eval(x));
}

/// A Masing element without its own implicit solve: the simulator's
/// generic Newton (the path before the element had one).
#[derive(Clone)]
struct Generic(Masing);

impl Element for Generic {
    fn trial(&self, x: f64, v: f64) -> ElementForce {
        self.0.trial(x, v)
    }
    fn commit(&mut self, x: f64, v: f64) -> ElementForce {
        self.0.commit(x, v)
    }
    fn reset(&mut self) {
        self.0.reset()
    }
    fn has_memory(&self) -> bool {
        true
    }
}

#[test]
fn own_implicit_solve_meets_the_tolerance_and_simulates_like_the_formula() {
    use crate::model::ModalModel;
    use crate::sim::Simulator;
    let model = ModalModel::sdof(10.0, 200.0, 1e7).unwrap();
    let fs = 51200.0;
    for n in [1.5, 3.0, 22.55, 1000.0] {
        // a growing 250 Hz drive, then a decaying one: virgin loading,
        // growing and shrinking loops, inner loops
        let drive: Vec<f64> = (0..40_000)
            .map(|i| {
                let t = i as f64 / fs;
                let env = 600.0 * (t / 0.4).min(1.0) * if t > 0.5 { 0.3 } else { 1.0 };
                env * (2.0 * PI * 250.0 * t).cos() + 80.0 * (2.0 * PI * 710.0 * t).sin()
            })
            .collect();
        let mut fast = Simulator::new(&model, Masing::new(KD, FD, n).unwrap(), fs).unwrap();
        let reference = Masing::with_backbone(formula(n));
        let mut slow = Simulator::new(&model, Generic(reference), fs).unwrap();
        let a = fast.run(&drive, &crate::observe::Silent).unwrap();
        let b = slow.run(&drive, &crate::observe::Silent).unwrap();
        assert_eq!(fast.stats().bracketed, 0);
        let peak = b.displacement.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(peak > 3.0 * FD / KD, "n={n}: the joint must slip");
        let worst = a
            .displacement
            .iter()
            .zip(&b.displacement)
            .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
        // both solve each sample to 1e-11 of the forces (~1e-11 of the
        // peak displacement); the table differs from the formula by
        // 4e-15: what remains is their accumulation in a damped system
        assert!(worst < 1e-9 * peak, "n={n}: {worst:e} of {peak:e}");
        let gworst = a
            .element_force
            .iter()
            .zip(&b.element_force)
            .fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
        assert!(gworst < 1e-9 * FD, "n={n}: element force {gworst:e} N");
    }
}

#[test]
fn own_implicit_solve_returns_a_root_of_the_sample_equation() {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let xc = FD / KD;
    for n in [1.5, 3.0, 22.55, 1000.0] {
        let mut m = Masing::new(KD, FD, n).unwrap();
        for &x in &crate::model::element::check::history(2.0 * xc) {
            m.commit(x, 0.0);
        }
        let mut solved = 0;
        for _ in 0..2000 {
            let x_prev = m.x_prev;
            // the filter's direct term of the paper system at 51.2 kHz
            // is ~6e-12 m/N; a wider range tests the steps' guards
            let bx = 10f64.powf(rng.random_range(-13.0..-9.0));
            let force = rng.random_range(-800.0..800.0);
            let x_pred = x_prev + rng.random_range(-0.3..0.3) * xc - bx * force;
            let s = ImplicitStep {
                x_pred,
                v_pred: 0.0,
                bx,
                bv: 1e-8,
                force,
            };
            if let Some(u) = m.solve_implicit(&s) {
                solved += 1;
                // evaluated afresh (no anchor): the residual is within
                // the simulator's tolerance
                let g = m.clone().commit(x_pred + bx * u, 0.0).force;
                let r = u - force + g;
                let tol = 1e-11 * (force.abs() + g.abs() + u.abs());
                assert!(r.abs() <= tol, "n={n}: residual {r:e} > {tol:e}");
            }
            // move on along a plausible path
            let x_next = x_prev + rng.random_range(-0.05..0.05) * xc;
            m.commit(x_next, 0.0);
        }
        assert!(solved > 1900, "n={n}: only {solved} of 2000 solved");
    }
}

#[test]
fn taylor_expansion_holds_near_the_branch_origin_for_any_n() {
    // just after a reversal the backbone's argument is small; for N < 2
    // its third derivative grows like r^(N−2) there
    let xc = FD / KD;
    for n in [0.5, 0.8, 1.0, 1.5, 1.9, 2.0, 3.0, 22.55, 1000.0] {
        for b in [formula(n), PowerBackbone::tabulated(KD, FD, n).unwrap()] {
            let mut worst: f64 = 0.0;
            for k in -80..=10 {
                let x0 = xc * 10f64.powf(k as f64 / 10.0);
                let (f0, k0, c0) = b.eval_with_curvature(x0);
                for frac in [1.0, 0.1, 0.01, -0.01, -0.1, -1.0] {
                    let h = frac * b.taylor_radius_at(x0);
                    let expanded = f0 + h * (k0 + 0.5 * h * c0);
                    worst = worst.max((expanded - b.eval(x0 + h).0).abs());
                }
            }
            assert!(worst < 1e-13 * FD, "n={n}: {:e} Fd", worst / FD);
        }
    }
}

/// An Iwan bank of Jenkins elements, the independent reference.
fn iwan_bank(slips: &[(f64, f64)]) -> Vec<Jenkins> {
    slips
        .iter()
        .map(|&(d, k)| Jenkins::new(k, k * d).unwrap())
        .collect()
}

fn history_from(turns: &[f64]) -> Vec<f64> {
    let mut xs = Vec::new();
    let mut last = 0.0;
    for &t in turns {
        for i in 1..=7 {
            xs.push(last + (t - last) * i as f64 / 7.0);
        }
        last = t;
    }
    xs
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// The turning-point stack reproduces an Iwan bank exactly: loops
    /// close, inner loops are wiped out, the backbone is rejoined.
    #[test]
    fn stack_equals_an_iwan_bank_on_random_histories(
        turns in prop::collection::vec(-3.0f64..3.0, 1..25),
        ks in prop::collection::vec(0.1f64..1.0, 3..6),
    ) {
        let slips: Vec<(f64, f64)> = ks.iter().enumerate()
            .map(|(i, &k)| (0.3 * (i + 1) as f64, k)).collect();
        let mut masing = Masing::with_backbone(PiecewiseLinearBackbone { slips: slips.clone() });
        let mut bank = iwan_bank(&slips);
        for x in history_from(&turns) {
            let a = masing.commit(x, 0.0).force;
            let b: f64 = bank.iter_mut().map(|j| j.commit(x, 0.0).force).sum();
            prop_assert!((a - b).abs() < 1e-9, "x={} masing {} bank {}", x, a, b);
        }
    }

    /// Rules 3 and 4 stated directly for eq. (10): after an excursion past
    /// every earlier one the force is on the backbone; returning to a
    /// turning point gives that point's force.
    #[test]
    fn returns_to_turning_points_and_rejoins_the_backbone(
        turns in prop::collection::vec(-2.0f64..2.0, 2..15), n in 1.5f64..50.0,
    ) {
        let xc = FD / KD;
        let mut m = Masing::new(KD, FD, n).unwrap();
        let xs = history_from(&turns.iter().map(|t| t * xc).collect::<Vec<_>>());
        for &x in &xs { m.commit(x, 0.0); }
        let peak = xs.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        // return to the last open turning point, if any
        if let Some(&(xr, fr)) = m.turning_points().last() {
            let f = m.commit(xr, 0.0).force;
            prop_assert!((f - fr).abs() < 1e-9 * FD, "return point {} vs {}", f, fr);
        }
        // then go beyond everything: backbone
        let far = 1.2 * peak + 0.1 * xc;
        let steps = 50;
        let start = xs.last().copied().unwrap_or(0.0);
        let mut f = 0.0;
        // (the last point is `far` up to rounding; committing `far` again
        // could be a 1-ulp reversal and open a turning point)
        for i in 1..=steps { f = m.commit(start + (far - start) * i as f64 / steps as f64, 0.0).force; }
        let (fb, _) = m.backbone().eval(far);
        prop_assert!((f - fb).abs() < 1e-9 * FD, "backbone {} vs {}", f, fb);
        prop_assert!(m.turning_points().is_empty());
    }
}
