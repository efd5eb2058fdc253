//! Generates, writes and diagnoses cases, a few at a time, recording a
//! failure instead of panicking.

use super::corpus::{Case, generate};
use super::recording::write_recording;
use super::score::{Score, hystid_bin, run_diagnose, score};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Generates, writes and diagnoses `cases`, `jobs` at a time.
pub fn run_cases(
    cases: &[Case],
    dir: &std::path::Path,
    jobs: usize,
    timeout: Duration,
) -> Vec<Score> {
    let next = Mutex::new(0usize);
    let results = Mutex::new(vec![None; cases.len()]);
    std::thread::scope(|s| {
        for _ in 0..jobs.max(1) {
            s.spawn(|| {
                loop {
                    let i = {
                        let mut n = next.lock().unwrap();
                        *n += 1;
                        *n - 1
                    };
                    let Some(case) = cases.get(i) else { break };
                    let t = Instant::now();
                    let rec = generate(case);
                    let gen_seconds = t.elapsed().as_secs_f64();
                    // the reference's own checks: a finite response, every
                    // dwell it was asked for
                    assert!(
                        rec.response.iter().all(|x| x.is_finite()),
                        "{}: the reference diverged",
                        case.name
                    );
                    assert_eq!(
                        rec.steps.len(),
                        case.levels.len() * case.frequencies.len(),
                        "{}: dwells generated",
                        case.name
                    );
                    let js = match write_recording(&dir.join("recordings"), case, &rec) {
                        Ok(js) => js,
                        Err(e) => panic!("cannot write {}: {e}", case.name),
                    };
                    drop(rec);
                    let run = run_diagnose(
                        &hystid_bin(),
                        &js,
                        &dir.join("out").join(&case.name),
                        case.element(),
                        timeout,
                    );
                    let mut sc = score(case, &run);
                    sc.gen_seconds = gen_seconds;
                    eprintln!(
                        "[{}/{}] {}: {} (generated in {:.1} s, diagnosed in {:.1} s){}",
                        i + 1,
                        cases.len(),
                        case.name,
                        if sc.passed() { "PASS" } else { "FAIL" },
                        gen_seconds,
                        sc.seconds,
                        if sc.passed() {
                            String::new()
                        } else {
                            format!(": {}", sc.failures.join("; "))
                        }
                    );
                    results.lock().unwrap()[i] = Some(sc);
                }
            });
        }
    });
    results
        .into_inner()
        .unwrap()
        .into_iter()
        .map(|s| s.unwrap())
        .collect()
}

pub fn describe(s: &Score) -> String {
    let mut t = format!(
        "{}\n  {}\n  truth [{}] selected [{}]",
        s.summary,
        s.command,
        s.truth.join(","),
        s.selected.join(",")
    );
    if let (Some(b), Some(f)) = (s.baseline_error, s.final_error) {
        t += &format!(
            "\n  H1 error baseline {:.2} % final {:.2} %, chi2/dof baseline {:.3} final {:.3}, {:.1} s",
            100.0 * b,
            100.0 * f,
            s.baseline_chi2_dof.unwrap_or(f64::NAN),
            s.chi2_dof.unwrap_or(f64::NAN),
            s.seconds
        );
    }
    for p in s.joint.iter().chain(&s.effects) {
        t += &format!(
            "\n  {}.{}: truth {:.6e} estimate {:?} ({:.2} %)",
            p.effect,
            p.name,
            p.truth,
            p.estimate,
            100.0 * p.relative()
        );
    }
    for c in &s.candidates {
        t += &format!("\n  {c}");
    }
    for n in &s.notes {
        t += &format!("\n  note: {n}");
    }
    for f in &s.failures {
        t += &format!("\n  FAIL: {f}");
    }
    t
}
