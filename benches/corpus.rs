//! Issue 10's corpus report: `cargo bench --bench corpus`.
//!
//! Draws N cases (default 60; `HYSTID_CORPUS_CASES`, first seed
//! `HYSTID_CORPUS_SEED`, default 1) from the independent reference
//! simulator in `tests/independent/kit` (no hystid code), writes each as a
//! v1 recording (WAV + JSON), runs `hystid diagnose` on it (at most
//! `HYSTID_CORPUS_JOBS` = 2 at a time, `HYSTID_CORPUS_TIMEOUT_S` = 600 s
//! each) and prints the confusion matrix (true effect set × selected set),
//! the parameter errors, the controls' χ²/dof, the aborts and the time per
//! case. Writes `target/corpus/report.json` (recordings and hystid's output
//! under `target/corpus/`). A failing case is recorded, never a panic.

#[path = "../tests/independent/kit/mod.rs"]
mod kit;

use kit::corpus::{Case, draw_broad, draw_case};
use kit::runner::{describe, run_cases};
use kit::score::Score;
use serde_json::json;
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::time::{Duration, Instant};

fn env_num<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn set_name(v: &[String]) -> String {
    if v.is_empty() {
        "none".into()
    } else {
        v.join("+")
    }
}

fn quantiles(mut v: Vec<f64>) -> (f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((v.len() - 1) as f64 * p).round() as usize];
    (q(0.5), q(0.9), *v.last().unwrap())
}

fn main() {
    let n: u64 = env_num("HYSTID_CORPUS_CASES", 60);
    let seed0: u64 = env_num("HYSTID_CORPUS_SEED", 1);
    let jobs: usize = env_num("HYSTID_CORPUS_JOBS", 2usize).clamp(1, 2);
    let timeout = Duration::from_secs(env_num("HYSTID_CORPUS_TIMEOUT_S", 600));
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target"));
    let dir = target.join("corpus");
    std::fs::create_dir_all(&dir).expect("target/corpus");
    // `broad` (the default): issue 70's ranges; `narrow`: the original
    // corpus's, whose seeds 1-60 the published figures came from
    let draw = std::env::var("HYSTID_CORPUS_DRAW").unwrap_or_else(|_| "broad".into());
    let draw_one: fn(u64) -> Case = match draw.as_str() {
        "narrow" => draw_case,
        "broad" => draw_broad,
        other => panic!("HYSTID_CORPUS_DRAW={other}: expected broad or narrow"),
    };
    if draw == "broad" && seed0 + n > 1000 && seed0 < 1000 {
        eprintln!(
            "corpus: seeds below 1000 are for development, from 1000 up held out: this run mixes both"
        );
    }
    let cases: Vec<Case> = (seed0..seed0 + n).map(draw_one).collect();
    eprintln!(
        "corpus: {n} {draw} cases from seed {seed0}, {jobs} at a time, in {}",
        dir.display()
    );
    let t0 = Instant::now();
    let scores = run_cases(&cases, &dir, jobs, timeout);
    let wall = t0.elapsed().as_secs_f64();

    println!("\n== per case ==");
    for s in &scores {
        println!("{}\n", describe(s));
    }

    // confusion matrix: rows true set, columns selected set (or ABORT)
    let col = |s: &Score| {
        if s.aborted {
            "ABORT".to_string()
        } else {
            set_name(&s.selected)
        }
    };
    let rows: BTreeSet<String> = scores.iter().map(|s| set_name(&s.truth)).collect();
    let cols: BTreeSet<String> = scores.iter().map(col).collect();
    let mut m: BTreeMap<(String, String), usize> = BTreeMap::new();
    for s in &scores {
        *m.entry((set_name(&s.truth), col(s))).or_default() += 1;
    }
    let w0 = rows.iter().map(|r| r.len()).max().unwrap_or(4).max(10);
    println!("== confusion matrix (rows: true effects, columns: selected) ==");
    let cols_v: Vec<&String> = cols.iter().collect();
    print!("{:w0$} |", "true \\ selected");
    for c in &cols_v {
        print!(" {c:>w$}", w = c.len().max(3));
    }
    println!(" | right");
    for r in &rows {
        print!("{r:w0$} |");
        for c in &cols_v {
            let k = m.get(&(r.clone(), (*c).clone())).copied().unwrap_or(0);
            print!(
                " {:>w$}",
                if k == 0 { ".".into() } else { k.to_string() },
                w = c.len().max(3)
            );
        }
        let total = scores.iter().filter(|s| &set_name(&s.truth) == r).count();
        let right = scores
            .iter()
            .filter(|s| &set_name(&s.truth) == r && s.effects_right())
            .count();
        println!(" | {right}/{total}");
    }

    // parameter errors
    println!(
        "\n== parameter errors |estimate/truth − 1| (joint: all runs; effects: when selected) =="
    );
    println!(
        "{:34} {:>4} {:>9} {:>9} {:>9} {:>8}",
        "parameter", "n", "median %", "p90 %", "max %", "within"
    );
    let mut groups: BTreeMap<String, (Vec<f64>, f64, bool)> = BTreeMap::new();
    for s in scores.iter().filter(|s| !s.aborted) {
        for p in &s.joint {
            let g = groups
                .entry(format!("joint {}.{}", p.effect, p.name))
                .or_insert((vec![], 0.03, p.scored));
            g.0.push(p.relative());
        }
        for p in s.effects.iter().filter(|p| p.estimate.is_some()) {
            let g = groups
                .entry(format!("effect {}.{}", p.effect, p.name))
                .or_insert((vec![], 0.10, p.scored));
            g.0.push(p.relative());
        }
    }
    let mut param_stats = serde_json::Map::new();
    for (k, (v, tol, scored)) in &groups {
        let (med, p90, max) = quantiles(v.clone());
        let within = v.iter().filter(|e| **e <= *tol).count();
        let within_s = if *scored {
            format!("{within}/{} ≤{:.0}%", v.len(), tol * 100.0)
        } else {
            "(not scored)".into()
        };
        println!(
            "{k:34} {:>4} {:>9.3} {:>9.3} {:>9.3} {within_s}",
            v.len(),
            100.0 * med,
            100.0 * p90,
            100.0 * max
        );
        param_stats.insert(k.clone(), json!({"n": v.len(), "median": med, "p90": p90, "max": max, "tolerance": tol, "within": within, "scored": scored}));
    }

    // controls
    println!("\n== controls (no effect): final chi2/dof (target ≤ 1.5) ==");
    let controls: Vec<&Score> = scores.iter().filter(|s| s.is_control()).collect();
    for s in &controls {
        println!(
            "{:12} chi2/dof {:>10}  selected [{}]{}",
            s.name,
            s.chi2_dof.map_or("-".into(), |c| format!("{c:.3}")),
            s.selected.join(","),
            if s.aborted { " ABORTED" } else { "" }
        );
    }

    // aborts and time
    let aborts: Vec<&Score> = scores.iter().filter(|s| s.aborted).collect();
    println!("\n== aborts: {} of {} ==", aborts.len(), scores.len());
    for s in &aborts {
        println!(
            "{}: {}\n  {}",
            s.name,
            s.abort_reason.replace('\n', "\n  "),
            s.command
        );
    }
    let (tmed, t90, tmax) = quantiles(scores.iter().map(|s| s.seconds).collect());
    let (gmed, _, gmax) = quantiles(scores.iter().map(|s| s.gen_seconds).collect());
    let passed = scores.iter().filter(|s| s.passed()).count();
    let right = scores.iter().filter(|s| s.effects_right()).count();
    let controls_right = controls.iter().filter(|s| s.effects_right()).count();
    let controls_chi = controls
        .iter()
        .filter(|s| s.chi2_dof.is_some_and(|c| c <= 1.5))
        .count();
    println!("\n== summary ==");
    println!(
        "diagnose time per case: median {tmed:.1} s, p90 {t90:.1} s, max {tmax:.1} s; generation median {gmed:.2} s, max {gmax:.2} s; wall {wall:.0} s"
    );
    println!(
        "right effects: {right}/{} ({:.0} %, target ≥ 95 %); controls right {controls_right}/{} (target all); controls chi2/dof ≤ 1.5: {controls_chi}/{}",
        scores.len(),
        100.0 * right as f64 / scores.len() as f64,
        controls.len(),
        controls.len()
    );
    println!(
        "aborts: {} (target 0); all criteria met: {passed}/{}",
        aborts.len(),
        scores.len()
    );

    let report = json!({
        "cases": n, "first_seed": seed0, "jobs": jobs, "wall_seconds": wall,
        "summary": {"right_effects": right, "passed": passed, "aborts": aborts.len(),
                     "controls": controls.len(), "controls_right": controls_right, "controls_chi2_le_2": controls_chi,
                     "seconds_median": tmed, "seconds_p90": t90, "seconds_max": tmax},
        "confusion": m.iter().map(|((r, c), k)| json!({"truth": r, "selected": c, "count": k})).collect::<Vec<_>>(),
        "parameters": param_stats,
        "scores": scores.iter().map(|s| s.to_json()).collect::<Vec<_>>(),
    });
    let path = dir.join("report.json");
    std::fs::write(&path, serde_json::to_string_pretty(&report).unwrap()).expect("report.json");
    println!("report: {}", path.display());
}
