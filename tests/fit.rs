//! Integration tests: identification, the paper end to end (issue 5).

use hystid::fit::{FitOptions, FitResult, HbPredictor, identify};
use hystid::model::ElementKind;
use hystid::testbench::{self, NoSink, TestDefinition};

fn bench(def: &TestDefinition) -> hystid::testbench::BenchRun {
    testbench::run(def, &mut NoSink, &hystid::observe::Silent).unwrap()
}

fn fit(run: &hystid::testbench::BenchRun, options: &FitOptions) -> FitResult {
    identify(&run.frf, options, &HbPredictor::default(), None).unwrap()
}

fn report(tag: &str, f: &FitResult, kd: f64, fd: f64) -> (f64, f64, bool, bool) {
    let (ekd, efd) = (&f.parameters["kd"], &f.parameters["fd"]);
    let (rkd, rfd) = (ekd.value / kd - 1.0, efd.value / fd - 1.0);
    let (ckd, cfd) = (
        ekd.ci95[0] <= kd && kd <= ekd.ci95[1],
        efd.ci95[0] <= fd && fd <= efd.ci95[1],
    );
    eprintln!(
        "{tag}: kd {:+.3} % (ci95 {:?}, covers {ckd}), Fd {:+.3} % (ci95 {:?}, covers {cfd}), N {:.4} {:?}, error {:.4}, chi2/dof {:.3}, {} evaluations, {:.2} s",
        100.0 * rkd,
        ekd.ci95,
        100.0 * rfd,
        efd.ci95,
        f.parameters.get("n").map_or(f64::NAN, |e| e.value),
        f.parameters.get("n").map(|e| e.ci95),
        f.error.relative,
        f.error.chi2_per_dof,
        f.effort.evaluations,
        f.effort.seconds
    );
    (rkd, rfd, ckd, cfd)
}

/// The paper's reference (Jenkins kd = 2.4e7, Fd = 246.048, 10 % noise)
/// fitted with the eq. (10) Masing element: the paper reached −2.9 % and
/// −1.6 %; we require 1 %, covered intervals, and N reported as not
/// identifiable.
#[test]
fn the_paper_case_is_reproduced_within_one_percent() {
    let def = TestDefinition::embedded_default();
    let run = bench(&def);
    let f = fit(
        &run,
        &FitOptions {
            second_optimiser: true,
            ..FitOptions::default()
        },
    );
    let (rkd, rfd, ckd, cfd) = report("paper case", &f, 2.4e7, 246.048);
    assert!(rkd.abs() < 0.01 && rfd.abs() < 0.01);
    assert!(ckd && cfd);
    // the validation pages' Table 3.1 row and sentence are this fit (`run`'s first
    // fit of the embedded default: the same FRFs, the same options)
    let row = crate::common::pinned_figures("| hystid, first fit |").expect("pinned figures");
    let (kd, fd) = (&f.parameters["kd"], &f.parameters["fd"]);
    let pct = |e: &hystid::fit::Estimate, truth: f64| 100.0 * (e.value / truth - 1.0);
    for (what, value, at) in [
        ("Fd", fd.value, 0),
        ("Fd's error [%]", pct(fd, 246.048), 1),
        ("Fd's CI low", fd.ci95[0], 3),
        ("Fd's CI high", fd.ci95[1], 4),
        ("kd", kd.value, 5),
        ("kd's error [%]", pct(kd, 2.4e7), 6),
        ("kd's CI low", kd.ci95[0], 7),
        ("kd's CI high", kd.ci95[1], 8),
    ] {
        crate::common::assert_pinned_figure(what, value, row[at]);
    }
    let error = crate::common::pinned_figures("The first fit's relative FRF error is")
        .expect("pinned figures");
    crate::common::assert_pinned_figure(
        "the first fit's error [%]",
        100.0 * f.error.relative,
        error[0],
    );
    crate::common::assert_pinned_figure("its chi2/dof", f.error.chi2_per_dof, error[1]);
    let n = &f.parameters["n"];
    assert!(
        !n.identifiable && n.ci95[1].is_infinite() && n.ci95[0] > 20.0,
        "N: {n:?}"
    );
    // Nelder–Mead and Levenberg–Marquardt agree within the 95 % intervals
    let (lm, agrees) = f.second_optimiser.as_ref().unwrap();
    eprintln!("LM: {} ({} evaluations)", lm.termination, lm.evaluations);
    assert!(agrees);
    // the final model's row: `run`'s diagnosis of the same fit (its default
    // options) adds nothing, and the model refitted on H1-H3 with the
    // measured standard errors is reported with its intervals
    let predictor = HbPredictor::default();
    let options = FitOptions::default();
    let d = hystid::diagnose::diagnose(
        &run.frf,
        &f,
        &hystid::diagnose::DiagnoseOptions {
            fit: options.clone(),
            ..Default::default()
        },
        &predictor,
        &hystid::observe::Silent,
    )
    .unwrap();
    assert!(d.selected.is_empty(), "{}", d.explanation);
    let truth = def.model().unwrap();
    let last = hystid::analysis::run::FinalModel::of(
        &run.frf,
        &f,
        &options.harmonics,
        None,
        Some(&d),
        Some(&truth),
        &predictor,
    )
    .unwrap();
    let (kd, fd, n) = (
        &last.parameters["kd"].estimate,
        &last.parameters["fd"].estimate,
        &last.parameters["n"],
    );
    eprintln!(
        "final model: kd {kd:?}, fd {fd:?}, n {n:?}, error {:?}, before {:?}",
        last.error,
        last.before.as_ref().map(|b| &b.error)
    );
    assert!(!n.flags.is_empty(), "N at its bound is flagged");
    let row = crate::common::pinned_figures(
        "| hystid, final model (the diagnosis added nothing; refitted with the standard errors on H1-H3) |",
    )
    .expect("pinned figures");
    for (what, value, at) in [
        ("final Fd", fd.value, 0),
        ("final Fd's error [%]", pct(fd, 246.048), 1),
        ("final Fd's CI low", fd.ci95[0], 2),
        ("final Fd's CI high", fd.ci95[1], 3),
        ("final kd", kd.value, 4),
        ("final kd's error [%]", pct(kd, 2.4e7), 5),
        ("final kd's CI low", kd.ci95[0], 6),
        ("final kd's CI high", kd.ci95[1], 7),
        ("N's lower bound", n.estimate.ci95[0], 8),
    ] {
        crate::common::assert_pinned_figure(what, value, row[at]);
    }
    let error = crate::common::pinned_figures("The final model's relative FRF error is")
        .expect("pinned figures");
    let before = last.before.as_ref().expect("the first fit as before");
    for (what, value, at) in [
        (
            "the final model's error [%]",
            100.0 * last.error.relative,
            0,
        ),
        (
            "the first fit's chi2/dof over H1-H3",
            before.error.chi2_per_dof,
            1,
        ),
        ("the final model's chi2/dof", last.error.chi2_per_dof, 2),
    ] {
        crate::common::assert_pinned_figure(what, value, error[at]);
    }
}

/// Over 10 seeds the intervals cover the reference at least 8 times. The
/// paper's test at a third of its frequencies (17 per level, 119 dwells):
/// coverage is a property of the intervals, not of the test's size, and the
/// study costs a third; the pinned figures are these, pinned.
#[test]
fn intervals_cover_the_reference_in_at_least_8_of_10_seeds() {
    let (mut kd_hits, mut fd_hits) = (0, 0);
    let (mut kd_worst, mut fd_worst): (f64, f64) = (0.0, 0.0);
    for seed in 1..=10 {
        let mut def = TestDefinition::embedded_default();
        def.test.seed = seed;
        let hystid::testbench::plan::FrequencyList::Range(r) = &mut def.test.frequencies_hz else {
            unreachable!("the default test's frequencies are a range")
        };
        r.count = 17;
        let f = fit(&bench(&def), &FitOptions::default());
        let (rkd, rfd, ckd, cfd) = report(&format!("seed {seed}"), &f, 2.4e7, 246.048);
        kd_hits += ckd as usize;
        fd_hits += cfd as usize;
        kd_worst = kd_worst.max(rkd.abs());
        fd_worst = fd_worst.max(rfd.abs());
    }
    eprintln!(
        "over 10 seeds: kd within {:.2} %, Fd within {:.2} %, coverage kd {kd_hits}/10, Fd {fd_hits}/10",
        100.0 * kd_worst,
        100.0 * fd_worst
    );
    let shown = crate::common::pinned_figures(
        "| identification (paper case at 17 frequencies per level; 10 seeds) | the reference |",
    )
    .expect("pinned figures");
    for (what, value, at) in [
        ("kd's worst error [%]", 100.0 * kd_worst, 0),
        ("Fd's worst error [%]", 100.0 * fd_worst, 1),
        ("kd's coverage", kd_hits as f64, 2),
        ("Fd's coverage", fd_hits as f64, 4),
    ] {
        crate::common::assert_pinned_figure(what, value, shown[at]);
    }
    assert!(kd_hits >= 8 && fd_hits >= 8);
}

/// A Masing reference with N = 3 is recovered: kd, Fd within 1 %, N within 10 %.
#[test]
fn a_masing_reference_with_n_3_is_recovered() {
    let text = hystid::testbench::DEFAULT_TEST
        .replace("\nkind = \"jenkins\"\n", "\nkind = \"masing\"\nn = 3.0\n");
    let def = TestDefinition::from_toml(&text, "masing3.toml").unwrap();
    let f = fit(&bench(&def), &FitOptions::default());
    let (rkd, rfd, _, _) = report("masing N=3", &f, 2.4e7, 246.048);
    let n = &f.parameters["n"];
    assert!(rkd.abs() < 0.01 && rfd.abs() < 0.01);
    assert!(
        (n.value / 3.0 - 1.0).abs() < 0.10 && n.identifiable,
        "N: {n:?}"
    );
}

/// A Jenkins element fitted to Jenkins data: two parameters, no N.
#[test]
fn a_jenkins_fit_needs_no_curvature() {
    let mut def = TestDefinition::embedded_default();
    def.test.seed = 3;
    let f = fit(
        &bench(&def),
        &FitOptions {
            element: ElementKind::Jenkins,
            ..FitOptions::default()
        },
    );
    let (rkd, rfd, ckd, cfd) = report("jenkins fit", &f, 2.4e7, 246.048);
    assert!(!f.parameters.contains_key("n"));
    assert!(rkd.abs() < 0.01 && rfd.abs() < 0.01 && ckd && cfd);
}

/// A joint law added by one file and one registry line is identified like
/// the others: Segalman's four-parameter Iwan joint, simulated on the
/// paper's system (10 % noise, six levels from stick to macroslip), fitted
/// with `element = iwan4`, every parameter recovered and covered by its
/// interval. Data from hystid's own simulator: the test of the law and the
/// fit together, not of their generality.
#[test]
fn an_iwan4_joint_is_identified() {
    let def = TestDefinition::from_toml(
        r#"
[system]
mass = 10.0
damping = 200.0
stiffness = 1.0e7
[joint]
kind = "iwan4"
fs = 246.048
kt = 2.4e7
chi = -0.5
beta = 0.5
[test]
frequencies_hz = { start = 100.0, stop = 350.0, count = 26 }
levels_n = [5.0, 100.0, 200.0, 400.0, 1000.0, 30000.0]
noise = 0.10
seed = 1
"#,
        "iwan4 case",
    )
    .unwrap();
    let f = fit(
        &bench(&def),
        &FitOptions {
            element: ElementKind::Iwan4,
            ..FitOptions::default()
        },
    );
    for (name, truth, tol) in [
        ("fs", 246.048, 0.005),
        ("kt", 2.4e7, 0.005),
        ("chi", -0.5, 0.02),
        ("beta", 0.5, 0.02),
    ] {
        let e = &f.parameters[name];
        eprintln!(
            "iwan4 {name}: {:.5e} ({:+.3} %), ci95 {:?}",
            e.value,
            100.0 * (e.value / truth - 1.0),
            e.ci95
        );
        assert!((e.value / truth - 1.0).abs() < tol, "{name}: {}", e.value);
        let [lo, hi] = e.ci95;
        assert!(
            lo <= truth && truth <= hi,
            "{name}: {truth} outside {lo}..{hi}"
        );
    }
    assert!(
        f.error.chi2_per_dof < 1.5,
        "chi2/dof {}",
        f.error.chi2_per_dof
    );
}
