//! The cost of one alternating frequency–time evaluation (ignored; run by
//! hand).

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
