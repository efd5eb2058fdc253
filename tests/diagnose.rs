//! Integration tests: the diagnosis closes the loop (issue 7).
//!
//! Each case is a seeded virtual test of the paper-like system (Jenkins
//! joint) plus an effect at a clearly visible size, analysed with the effect
//! NOT declared: the baseline fit is the eq. (10) Masing joint alone.

use hystid::diagnose::{DiagnoseOptions, Diagnosis, Effect, diagnose};
use hystid::fit::{FitOptions, HbPredictor, identify};
use hystid::testbench::{self, NoSink, TestDefinition};

fn case(effects: &str, seed: u64) -> Diagnosis {
    case_run(effects, seed).diagnosis
}

/// A case's test, fit and diagnosis.
struct CaseRun {
    def: TestDefinition,
    frf: hystid::extract::NonlinearFrf,
    fit: hystid::fit::FitResult,
    diagnosis: Diagnosis,
}

fn case_run(effects: &str, seed: u64) -> CaseRun {
    let text = format!(
        r#"
[system]
mass = 10.0
damping = 200.0
stiffness = 1.0e7
[joint]
kind = "jenkins"
kd = 2.4e7
fd = 246.048
{effects}
[test]
frequencies_hz = {{ start = 100.0, stop = 350.0, count = 21 }}
levels_n = [5.0, 200.0, 1000.0, 30000.0]
noise = 0.10
seed = {seed}
measure_periods = 16
"#
    );
    let def = TestDefinition::from_toml(&text, "diagnose case").unwrap();
    let run = testbench::run(&def, &mut NoSink, &hystid::observe::Silent).unwrap();
    let p = HbPredictor::default();
    let fit = identify(&run.frf, &FitOptions::default(), &p, None).unwrap();
    let diagnosis = diagnose(
        &run.frf,
        &fit,
        &DiagnoseOptions::default(),
        &p,
        &hystid::observe::Silent,
    )
    .unwrap();
    CaseRun {
        def,
        frf: run.frf,
        fit,
        diagnosis,
    }
}

/// The final model `run` would report of a case (the first fit as "before").
fn final_model(c: &CaseRun) -> hystid::analysis::run::FinalModel {
    let truth = c.def.model().unwrap();
    hystid::analysis::run::FinalModel::of(
        &c.frf,
        &c.fit,
        &FitOptions::default().harmonics,
        None,
        Some(&c.diagnosis),
        Some(&truth),
        &HbPredictor::default(),
    )
    .unwrap()
}

/// The seeds a case runs: one per case in the suite (each case its own, so
/// that the suite still sees three noise draws), or every seed of
/// `HYSTID_DIAGNOSE_SEEDS` (`1-5`: the validation pages' table).
fn seeds(own: u64) -> std::ops::RangeInclusive<u64> {
    match std::env::var("HYSTID_DIAGNOSE_SEEDS") {
        Ok(text) => {
            let (a, b) = text.split_once('-').unwrap_or((&text, &text));
            let parse = |x: &str| -> u64 {
                x.trim().parse().unwrap_or_else(|_| {
                    panic!("HYSTID_DIAGNOSE_SEEDS: expected N or N-M, got `{text}`")
                })
            };
            parse(a)..=parse(b)
        }
        Err(_) => own..=own,
    }
}

fn selected(d: &Diagnosis) -> Vec<Effect> {
    let mut v: Vec<Effect> = d.selected.iter().map(|s| s.effect).collect();
    v.sort();
    v
}

fn param(d: &Diagnosis, effect: Effect, name: &str) -> f64 {
    d.selected
        .iter()
        .find(|s| s.effect == effect)
        .unwrap()
        .parameters[name]
        .value
}

fn summary(tag: &str, seed: u64, d: &Diagnosis) {
    eprintln!(
        "{tag} seed {seed}: selected {:?}; error H1 {:.3} % -> {:.3} %, per harmonic {:?} -> {:?}; chi2/dof {:.2} -> {:.2}",
        selected(d),
        100.0 * d.baseline.error_relative,
        100.0 * d.final_fit.error_relative,
        d.baseline.error_relative_per_harmonic,
        d.final_fit.error_relative_per_harmonic,
        d.baseline.chi2_per_dof,
        d.final_fit.chi2_per_dof
    );
}

/// A check of a case's final model against the validation pages (see
/// [`pin_the_cubic_runs_figures`]).
type Pin<'a> = &'a dyn Fn(&CaseRun);

/// One undeclared effect, at seed `own` (see [`seeds`]): exactly it is selected, its
/// parameter is within 10 %, the error on the harmonic `judged` falls at
/// least 3 times, and the final fit is consistent with the noise (χ²/dof
/// below 2, and the diagnosis says so), or, for the one-sided contact, below
/// 2.5: its engagement depends on the static offset the joint's history left,
/// which no periodic model knows (README, "Known wart"; 1.75-2.18 over
/// seeds 1-5 here).
fn check_single(
    tag: &str,
    effects: &str,
    effect: Effect,
    truth: &[(&str, f64)],
    judged: usize,
    own: u64,
    pin: Option<Pin<'_>>,
) {
    let chi2_max = if effect == Effect::BilinearStiffness {
        2.5
    } else {
        2.0
    };
    for seed in seeds(own) {
        let c = case_run(effects, seed);
        let d = &c.diagnosis;
        summary(tag, seed, d);
        if let (Some(pin), true) = (pin, seed == own) {
            pin(&c);
        }
        assert_eq!(
            selected(d),
            vec![effect],
            "{tag} seed {seed}: {}",
            d.explanation
        );
        for (name, value) in truth {
            let got = param(d, effect, name);
            eprintln!(
                "  {name} = {got:.6e} (true {value:e}, {:+.2} %)",
                100.0 * (got / value - 1.0)
            );
            assert!(
                (got / value - 1.0).abs() < 0.10,
                "{tag} seed {seed}: {name} = {got} vs {value}"
            );
        }
        let before = d.baseline.error_relative_per_harmonic[&judged];
        let after = d.final_fit.error_relative_per_harmonic[&judged];
        assert!(
            before >= 3.0 * after,
            "{tag} seed {seed}: H{judged} error {before} -> {after}"
        );
        assert!(
            d.final_fit.chi2_per_dof < chi2_max
                && (d.consistent_with_noise || effect == Effect::BilinearStiffness),
            "{tag} seed {seed}: chi2/dof {}",
            d.final_fit.chi2_per_dof
        );
    }
}

#[test]
fn an_undeclared_cubic_stiffness_is_found() {
    check_single(
        "cubic",
        "[[effects]]\nkind = \"cubic_stiffness\"\nk3 = 1.0e7",
        Effect::CubicStiffness,
        &[("k3", 1.0e7)],
        1,
        1,
        Some(&|c| pin_the_cubic_runs_figures(&c.diagnosis, &final_model(c))),
    );
}

/// The validation pages' larger cubic example is this case at seed 1 (`run` on it
/// reports the same final model): its figures, as printed there.
fn pin_the_cubic_runs_figures(d: &Diagnosis, last: &hystid::analysis::run::FinalModel) {
    let k3 = &last.parameters["cubic_stiffness.k3"].estimate;
    let pct = |name: &str, truth: f64| 100.0 * (last.parameters[name].estimate.value / truth - 1.0);
    let before = last.before.as_ref().expect("the first fit as before");
    let figures = [
        ("k3", k3.value),
        ("k3's CI low", k3.ci95[0]),
        ("k3's CI high", k3.ci95[1]),
        ("k3's error [%]", 100.0 * (k3.value / 1e7 - 1.0)),
        ("kd's error [%]", pct("kd", 2.4e7)),
        ("Fd's error [%]", pct("fd", 246.048)),
        (
            "the first fit's H1 error [%]",
            100.0 * before.error.relative,
        ),
        (
            "the baseline's H1 error [%]",
            100.0 * d.baseline.error_relative,
        ),
        ("the final H1 error [%]", 100.0 * last.error.relative),
        ("the first fit's chi2/dof", before.error.chi2_per_dof),
        ("the baseline's chi2/dof", d.baseline.chi2_per_dof),
        ("the final chi2/dof", last.error.chi2_per_dof),
    ];
    eprintln!("pinned cubic run: {figures:?}");
    let shown =
        crate::common::pinned_figures("Figures of the larger run:").expect("pinned figures");
    assert_eq!(shown.len(), figures.len(), "pinned cubic run: {shown:?}");
    for ((what, value), shown) in figures.into_iter().zip(shown) {
        crate::common::assert_pinned_figure(what, value, shown);
    }
}

#[test]
fn an_undeclared_quadratic_damping_is_found() {
    check_single(
        "quadratic damping",
        "[[effects]]\nkind = \"quadratic_damping\"\nc2 = 0.2",
        Effect::QuadraticDamping,
        &[("c2", 0.2)],
        1,
        2,
        None,
    );
}

#[test]
fn an_undeclared_one_sided_contact_is_found_in_the_even_harmonics() {
    check_single(
        "bilinear",
        "[[effects]]\nkind = \"bilinear_stiffness\"\nkb = 2.0e6",
        Effect::BilinearStiffness,
        &[("kb", 2.0e6)],
        2,
        3,
        None,
    );
}

#[test]
fn an_undeclared_second_mode_is_found() {
    check_single(
        "second mode",
        "[[effects]]\nkind = \"second_mode\"\nfrequency_hz = 420.0\ndamping_ratio = 0.01\nmodal_mass = 50.0",
        Effect::SecondMode,
        &[
            ("frequency_hz", 420.0),
            ("damping_ratio", 0.01),
            ("modal_mass", 50.0),
        ],
        1,
        2,
        Some(&the_same_on_one_thread),
    );
}

/// The diagnosis does not depend on the thread count: `c`'s (made in the
/// default pool, two threads on the 2-core machines the suite runs on) is
/// made again on one. The further mode's candidate has several starts:
/// they are screened side by side, then polished one after the other, each
/// later one racing the best so far and given up by evaluation counts
/// (never by which thread finished first); the identification afresh its
/// starts read is made before the candidates.
fn the_same_on_one_thread(c: &CaseRun) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let one = pool.install(|| {
        diagnose(
            &c.frf,
            &c.fit,
            &DiagnoseOptions::default(),
            &HbPredictor::default(),
            &hystid::observe::Silent,
        )
        .unwrap()
    });
    assert_eq!(
        serde_json::to_string(&one).unwrap(),
        serde_json::to_string(&c.diagnosis).unwrap()
    );
}

#[test]
fn nothing_is_selected_when_nothing_is_missing() {
    for seed in seeds(3) {
        let d = case("", seed);
        summary("none", seed, &d);
        assert!(d.selected.is_empty(), "seed {seed}: {}", d.explanation);
        assert!(
            d.explanation.contains("No significant missing effect"),
            "{}",
            d.explanation
        );
    }
}

#[test]
fn two_effects_at_once_are_both_found() {
    for seed in seeds(1) {
        let d = case(
            "[[effects]]\nkind = \"second_mode\"\nfrequency_hz = 420.0\ndamping_ratio = 0.01\nmodal_mass = 50.0\n\
             [[effects]]\nkind = \"cubic_stiffness\"\nk3 = 1.0e7",
            seed,
        );
        summary("two", seed, &d);
        assert_eq!(
            selected(&d),
            vec![Effect::SecondMode, Effect::CubicStiffness],
            "seed {seed}: {}",
            d.explanation
        );
        assert!((param(&d, Effect::CubicStiffness, "k3") / 1e7 - 1.0).abs() < 0.10);
        assert!((param(&d, Effect::SecondMode, "frequency_hz") / 420.0 - 1.0).abs() < 0.01);
        assert!(d.baseline.error_relative >= 3.0 * d.final_fit.error_relative);
        assert!(d.final_fit.chi2_per_dof < 2.0);
    }
}

/// A diagnosis whose figures cannot be drawn (here its model made
/// unplottable: a mode at a frequency that is not a number) is written
/// whole, saying why in place of the figures, and is never an error.
#[test]
fn a_figure_that_cannot_be_drawn_is_said_and_the_diagnosis_stands() {
    let c = case_run("", 1);
    let mut d = c.diagnosis.clone();
    d.model.linear.modes[0].frequency_hz = f64::NAN;
    let dir = tempfile::tempdir().unwrap();
    let written = hystid::analysis::diagnose::write_diagnosis(
        dir.path(),
        &c.frf,
        &d,
        &HbPredictor::default(),
        1.0,
    )
    .expect("the diagnosis is written without its figures");
    assert_eq!(written.notes.len(), 1, "{:?}", written.notes);
    assert!(
        written.notes[0].contains("were not drawn"),
        "{}",
        written.notes[0]
    );
    assert!(!dir.path().join("residual.png").exists());
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("diagnosis.json")).unwrap()).unwrap();
    assert_eq!(
        json["figures_not_drawn"].as_str(),
        Some(written.notes[0].as_str())
    );
    let md = std::fs::read_to_string(dir.path().join("diagnosis.md")).unwrap();
    assert!(
        md.contains("were not drawn") && !md.contains("residual.png"),
        "{md}"
    );
    // the same diagnosis, drawable, has its figures and no note
    let drawn = hystid::analysis::diagnose::write_diagnosis(
        dir.path(),
        &c.frf,
        &c.diagnosis,
        &HbPredictor::default(),
        1.0,
    )
    .unwrap();
    assert!(drawn.notes.is_empty());
    assert!(dir.path().join("residual.png").exists());
}
