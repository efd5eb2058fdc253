//! `hystid diagnose` on a fixed sample of the independent corpus, judged
//! by issue 10's criteria.

use super::kit::corpus::{
    Case, CaseOptions, EffectKind, JointKind, Quantity, SampleFormat, Sweep, case_with, generate,
};
use super::kit::recording::write_recording;
use super::kit::score::{Score, hystid_bin, run_diagnose, score};
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Duration;

/// The sample: a control, cubic, quadratic damping, bilinear, second
/// mode, and a Masing recording without `steps`; 4 levels × 12
/// frequencies each.
pub fn sample_cases() -> Vec<Case> {
    let o = |format, quantity, sweep, with_steps| CaseOptions {
        levels: Some(4),
        frequencies: Some(12),
        format: Some(format),
        quantity: Some(quantity),
        sweep: Some(sweep),
        with_steps: Some(with_steps),
    };
    use EffectKind::*;
    use Quantity::*;
    use SampleFormat::*;
    let mut v = vec![
        ("control", case_with(101, JointKind::Jenkins, &[], &o(Float32, Displacement, Sweep::Up, true))),
        ("cubic", case_with(102, JointKind::Masing { n: 2.0 }, &[CubicStiffness], &o(Pcm24, Velocity, Sweep::Down, true))),
        ("quadratic_damping", case_with(103, JointKind::Jenkins, &[QuadraticDamping], &o(Pcm16, Displacement, Sweep::Up, true))),
        ("bilinear", case_with(104, JointKind::Masing { n: 5.0 }, &[BilinearStiffness], &o(Float32, Acceleration, Sweep::Alternate, true))),
        ("second_mode", case_with(105, JointKind::Jenkins, &[SecondMode], &o(Pcm24, Displacement, Sweep::Up, true))),
        ("masing_no_steps", case_with(106, JointKind::Masing { n: 3.0 }, &[], &o(Pcm24, Displacement, Sweep::Up, false))),
    ];
    for (name, c) in &mut v {
        c.name = format!("{name}-{}", c.seed);
    }
    v.into_iter().map(|x| x.1).collect()
}

/// Generates, writes and diagnoses `cases`, `jobs` at a time.
pub fn run_cases(cases: &[Case], dir: &std::path::Path, jobs: usize, timeout: Duration) -> Vec<Score> {
    let next = Mutex::new(0usize);
    let results = Mutex::new(vec![None; cases.len()]);
    std::thread::scope(|s| {
        for _ in 0..jobs.max(1) {
            s.spawn(|| loop {
                let i = {
                    let mut n = next.lock().unwrap();
                    *n += 1;
                    *n - 1
                };
                let Some(case) = cases.get(i) else { break };
                let rec = generate(case);
                let js = write_recording(&dir.join("recordings"), case, &rec).expect("write recording");
                let run = run_diagnose(&hystid_bin(), &js, &dir.join("out").join(&case.name), case.element(), timeout);
                let sc = score(case, &run);
                eprintln!("{}: {} in {:.1} s", case.name, if sc.passed() { "PASS" } else { "FAIL" }, sc.seconds);
                results.lock().unwrap()[i] = Some(sc);
            });
        }
    });
    results.into_inner().unwrap().into_iter().map(|s| s.unwrap()).collect()
}

pub fn describe(s: &Score) -> String {
    let mut t = format!("{}\n  {}\n  truth [{}] selected [{}]", s.summary, s.command, s.truth.join(","), s.selected.join(","));
    if let (Some(b), Some(f)) = (s.baseline_error, s.final_error) {
        t += &format!("\n  H1 error baseline {:.2} % final {:.2} %, chi2/dof baseline {:.3} final {:.3}, {:.1} s",
            100.0 * b, 100.0 * f, s.baseline_chi2_dof.unwrap_or(f64::NAN), s.chi2_dof.unwrap_or(f64::NAN), s.seconds);
    }
    for p in s.joint.iter().chain(&s.effects) {
        t += &format!("\n  {}.{}: truth {:.6e} estimate {:?} ({:.2} %)", p.effect, p.name, p.truth, p.estimate, 100.0 * p.relative());
    }
    for c in &s.candidates {
        t += &format!("\n  {c}");
    }
    for f in &s.failures {
        t += &format!("\n  FAIL: {f}");
    }
    t
}

#[test]
#[ignore = "issue 10: hystid diagnose is not yet robust on recordings it did not make (run with --ignored)"]
fn independent_corpus_sample() {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("independent-sample");
    let cases = sample_cases();
    let scores = run_cases(&cases, &dir, 2, Duration::from_secs(900));
    let mut failed = Vec::new();
    for s in &scores {
        eprintln!("{}\n", describe(s));
        if !s.passed() {
            failed.push(format!("{}: {}", s.name, s.failures.join("; ")));
        }
    }
    assert!(failed.is_empty(), "{} of {} cases fail issue 10's criteria:\n{}", failed.len(), scores.len(), failed.join("\n"));
}

/// The sample's recordings are generated quickly (the reference is not
/// the bottleneck) and carry the truth.
#[test]
fn independent_sample_generates() {
    for case in sample_cases() {
        let t = std::time::Instant::now();
        let rec = generate(&case);
        let secs = t.elapsed().as_secs_f64();
        eprintln!("{}: {} samples ({:.1} s of signal) in {:.2} s", case.summary(), rec.force.len(), rec.force.len() as f64 / case.sample_rate as f64, secs);
        assert!(rec.response.iter().all(|x| x.is_finite()));
        assert_eq!(rec.steps.len(), case.levels.len() * case.frequencies.len());
    }
}
