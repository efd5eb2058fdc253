//! The shaker between a voltage drive and the structure (issue 12), against
//! references written from the coil's own equations, `L i' + R i + Bl v = e`
//! with the force `Bl i` on the structure: a closed form for a linear
//! structure and an RK4 march of the three states `(x, v, i)` with a cubic
//! spring (smooth, so RK4 converges at its order).
//!
//! The model here declares the shaker by its coil (`r`, `l`, `bl`, as a
//! test definition does), so it is driven by the voltage itself and its
//! forces are newtons; the references never see hystid's combinations
//! (`ce = Bl²/R`, `te = L/R`, gain `Bl/R`). The hysteretic-mode case holds
//! the shaker in the drive's unit (gain 1, driven by the blocked force
//! `(Bl/R) e`), as a model identified from a voltage does.

use hystid::hb::{HbOptions, HbPoint, solve_point};
use hystid::model::{ElementSpec, ModalModel, Model};
use hystid::sim::Simulator;
use num_complex::Complex64;
use std::f64::consts::PI;

const M: f64 = 1.0;
const C: f64 = 2.0;
const K: f64 = 4.0e5;
const R: f64 = 2.0;
const L: f64 = 1.0e-3;
const BL: f64 = 10.0;

fn model(k3: f64) -> Model {
    let coil = format!("kind = \"shaker\"\nr = {R:e}\nl = {L:e}\nbl = {BL:e}");
    let mut elements = vec![toml::from_str::<ElementSpec>(&coil).unwrap()];
    if k3 > 0.0 {
        elements.push(ElementSpec::CubicStiffness { k3 });
    }
    Model::new(ModalModel::sdof(M, C, K).unwrap(), elements).unwrap()
}

/// `X/E` of the linear structure through the coil, from the two equations.
fn closed_form(f: f64) -> Complex64 {
    let w = 2.0 * PI * f;
    let j = Complex64::new(0.0, 1.0);
    let structure = K - M * w * w + j * w * C;
    BL / ((R + j * w * L) * structure + j * w * BL * BL)
}

/// `F/E`: the coil's force `Bl i` on the linear structure, with
/// `i = (E − Bl jω X)/(R + jωL)`.
fn coil_force(f: f64) -> Complex64 {
    let w = 2.0 * PI * f;
    let j = Complex64::new(0.0, 1.0);
    BL * (1.0 - j * w * BL * closed_form(f)) / (R + j * w * L)
}

/// Harmonic `h` (single-sided) of `x` over its last `periods` periods of
/// `p` samples.
pub(crate) fn harmonic(x: &[f64], p: usize, periods: usize, h: usize) -> Complex64 {
    let n = p * periods;
    let start = x.len() - n;
    let mut s = Complex64::new(0.0, 0.0);
    for (i, &xi) in x[start..].iter().enumerate() {
        let th = 2.0 * PI * (h * ((start + i) % p)) as f64 / p as f64;
        s += xi * Complex64::from_polar(1.0, -th);
    }
    s * 2.0 / n as f64
}

/// RK4 of `m x'' + c x' + k x + k3 x³ = Bl i`, `L i' + R i + Bl x' = e`
/// under `e = E cos ωt` from rest, `p` steps a period, for `seconds`.
fn rk4(k3: f64, e: f64, f: f64, p: usize, seconds: f64) -> Vec<f64> {
    let w = 2.0 * PI * f;
    let dt = 1.0 / (f * p as f64);
    let rate = |t: f64, s: [f64; 3]| -> [f64; 3] {
        let [x, v, i] = s;
        [
            v,
            (BL * i - C * v - K * x - k3 * x * x * x) / M,
            (e * (w * t).cos() - R * i - BL * v) / L,
        ]
    };
    let periods = (seconds * f).ceil() as usize;
    march_rk4(rate, dt, periods * p, |s| s[0])
}

/// The classical RK4 of `s' = rate(t, s)` from rest, `steps` steps of `dt`;
/// `output(s)` before each step.
pub(crate) fn march_rk4<const N: usize>(
    rate: impl Fn(f64, [f64; N]) -> [f64; N],
    dt: f64,
    steps: usize,
    output: impl Fn(&[f64; N]) -> f64,
) -> Vec<f64> {
    let mut s = [0.0; N];
    let mut out = Vec::with_capacity(steps);
    for n in 0..steps {
        let t = n as f64 * dt;
        out.push(output(&s));
        let k1 = rate(t, s);
        let at = |k: [f64; N], c: f64| std::array::from_fn(|q| s[q] + c * k[q]);
        let k2 = rate(t + dt / 2.0, at(k1, dt / 2.0));
        let k3 = rate(t + dt / 2.0, at(k2, dt / 2.0));
        let k4 = rate(t + dt, at(k3, dt));
        for q in 0..N {
            s[q] += dt / 6.0 * (k1[q] + 2.0 * k2[q] + 2.0 * k3[q] + k4[q]);
        }
    }
    out
}

/// The digital-filter simulator's response to `e = E cos ωt`.
fn simulated(k3: f64, e: f64, f: f64, p: usize, seconds: f64) -> Vec<f64> {
    driven(&model(k3), e, f, p, seconds)
}

/// `m`'s displacement under the drive `amplitude cos ωt` from rest, `p`
/// samples a period, for `seconds` (a shaker in the drive's unit takes the
/// blocked force `(Bl/R) e`, one declared by its coil the voltage).
pub(crate) fn driven(m: &Model, amplitude: f64, f: f64, p: usize, seconds: f64) -> Vec<f64> {
    let mut sim = Simulator::new(&m.linear, m.element_set().unwrap(), f * p as f64).unwrap();
    let periods = (seconds * f).ceil() as usize;
    let drive: Vec<f64> = (0..periods * p)
        .map(|n| amplitude * (2.0 * PI * (n % p) as f64 / p as f64).cos())
        .collect();
    sim.run(&drive, &hystid::observe::Silent)
        .unwrap()
        .displacement
}

/// `m` balanced at `f` under the drive `amplitude` (as [`driven`] takes it).
pub(crate) fn balanced(m: &Model, f: f64, amplitude: f64, opts: &HbOptions) -> HbPoint {
    solve_point(
        &m.linear,
        &mut m.element_set().unwrap(),
        f,
        amplitude,
        None,
        opts,
    )
    .unwrap()
}

/// Asserts `got`'s `X1` and `X3` each within its relative `tolerance` of
/// the reference's.
pub(crate) fn assert_x1_x3(
    what: &str,
    f: f64,
    got: [Complex64; 2],
    reference: [Complex64; 2],
    tolerance: [f64; 2],
) {
    for (k, ((g, r), t)) in [1, 3]
        .into_iter()
        .zip(got.into_iter().zip(reference).zip(tolerance))
    {
        let e = (g / r - 1.0).norm();
        eprintln!("{what} X{k} at {f} Hz: {e:.1e}");
        assert!(e < t, "{what} X{k} at {f} Hz: {g} vs {r}");
    }
}

/// A linear structure through the coil: harmonic balance exactly, and the
/// simulator within its sampling error, give the closed form's `X/E` below,
/// at and above the resonance, where the back-EMF (50 N s/m against the
/// structure's 2) takes most of the force away.
#[test]
fn a_linear_structure_through_a_shaker_is_the_coils_closed_form() {
    let m = model(0.0);
    let opts = HbOptions::default();
    for f in [80.0, 100.0, 125.0] {
        let exact = closed_form(f);
        let hb = balanced(&m, f, 1.0, &opts).frf(1).unwrap();
        assert!(
            (hb / exact - 1.0).norm() < 1e-9,
            "HB at {f} Hz: {hb} vs {exact}"
        );
        // 400 samples a period: the ramp-invariant filters' sinc² loss is
        // 2e-5 for each of the drive's lag and the structure
        let x = simulated(0.0, 1.0, f, 400, 1.0);
        let sim = harmonic(&x, 400, 20, 1);
        assert!(
            (sim / exact - 1.0).norm() < 2e-4,
            "simulated at {f} Hz: {sim} vs {exact}"
        );
    }
    // the force drop: at resonance the voltage drives 30x less response
    // than the blocked force would without the back-EMF
    let w = 2.0 * PI * 100.66;
    let blocked = BL / R / Complex64::new(K - M * w * w, w * C);
    assert!(closed_form(100.66).norm() < blocked.norm() / 20.0);
}

/// The force the simulator reports the drive applying (what a force gauge
/// between the shaker and the structure reads) is the coil's `Bl i` of the
/// closed form, and shows the force drop: at resonance the coil pushes
/// with a fraction of what it does off it. Measured: within 1.9-2.3e-5 at
/// 400 samples a period (the lag's and the structure's `sinc²` losses,
/// 2e-5 each); at resonance 0.19 N/V of the blocked 5 N/V (3.8 %).
#[test]
fn the_drive_force_is_the_coils_and_drops_at_resonance() {
    let m = model(0.0);
    for f in [80.0, 100.66, 125.0] {
        let p = 400;
        let mut sim = Simulator::new(&m.linear, m.element_set().unwrap(), f * p as f64).unwrap();
        let periods = (1.0 * f).ceil() as usize;
        let drive: Vec<f64> = (0..periods * p)
            .map(|n| (2.0 * PI * (n % p) as f64 / p as f64).cos())
            .collect();
        let got = harmonic(
            &sim.run(&drive, &hystid::observe::Silent)
                .unwrap()
                .drive_force,
            p,
            20,
            1,
        );
        let exact = coil_force(f);
        let e = (got / exact - 1.0).norm();
        eprintln!("drive force at {f} Hz: {got:.4} vs {exact:.4} ({e:.1e})");
        assert!(e < 1e-4, "drive force at {f} Hz: {got} vs {exact}");
    }
    // blocked, the coil would push with Bl/R = 5 N/V; at resonance the
    // back-EMF leaves 3.8 % of it
    let drop = coil_force(100.66).norm() / (BL / R);
    assert!((drop - 0.038).abs() < 0.001, "{drop}");
    assert!(coil_force(80.0).norm() / (BL / R) > 0.8);
}

/// With a cubic spring the back-EMF also acts on the response's third
/// harmonic: harmonic balance and the simulator against RK4 of the coil's
/// equations (1000 steps a period, error ~1e-10), `X1` and `X3` at a level
/// where `k3 x²` is 8 % of `k`. Measured: harmonic balance within 1e-10 of
/// both; the simulator 1.6e-5 / 2.4e-4 at 400 samples a period and 100x
/// closer at 4000 (second order).
#[test]
fn a_cubic_spring_through_a_shaker_is_the_coils_rk4() {
    let k3 = 4.0e12;
    let e = 2.0;
    let opts = HbOptions::with_harmonics(vec![1, 3, 5, 7]);
    let m = model(k3);
    for f in [95.0, 104.0] {
        let p = 1000;
        let reference = rk4(k3, e, f, p, 1.2);
        let x1 = harmonic(&reference, p, 20, 1);
        let x3 = harmonic(&reference, p, 20, 3);
        assert!(
            x1.norm() > 1e-4 && (x3 / x1).norm() > 3e-3,
            "the level should be nonlinear: {x1}, {x3}"
        );
        let pt = balanced(&m, f, e, &opts);
        assert!(pt.converged);
        assert_x1_x3("HB", f, [pt.x[0], pt.x[1]], [x1, x3], [1e-8, 1e-7]);
        let s = simulated(k3, e, f, 400, 1.2);
        let (s1, s3) = (harmonic(&s, 400, 20, 1), harmonic(&s, 400, 20, 3));
        assert_x1_x3("simulated", f, [s1, s3], [x1, x3], [5e-5, 5e-4]);
        let fine = simulated(k3, e, f, 4000, 1.2);
        let f1 = harmonic(&fine, 4000, 20, 1);
        assert!(
            (f1 / x1 - 1.0).norm() < 2e-2 * (s1 / x1 - 1.0).norm().max(1e-6),
            "simulated X1 at 4000 samples a period: {f1} vs {x1}"
        );
    }
}

/// Beside a hysteretic mode (an SDOF of its own with a Jenkins joint) the
/// coil's lag drives every part and the back-EMF answers the point
/// structure: harmonic balance of the parts (`Model::parts`, as the fit's
/// predictor balances them) against the simulator of the whole model, which
/// realise that one model by different means, in H1 at a level where the
/// mode's joint slips.
#[test]
fn beside_a_hysteretic_mode_the_parts_balance_as_the_simulator_runs_them() {
    use hystid::model::Mode;
    let mut hysteretic = Mode::from_modal_mass(130.0, 0.02, 2.0).unwrap();
    hysteretic.joint = Some(ElementSpec::Jenkins {
        kd: 1.3e6,
        fd: 20.0,
    });
    let linear = ModalModel::new(vec![Mode::from_mck(M, C, K).unwrap(), hysteretic]).unwrap();
    let m = Model::new(
        linear,
        vec![ElementSpec::Shaker {
            ce: BL * BL / R,
            te: L / R,
            gain: 1.0,
        }],
    )
    .unwrap();
    let opts = HbOptions {
        harmonics: vec![1, 3, 5, 7, 9],
        samples_per_period: 1024,
        ..HbOptions::default()
    };
    let force = 60.0;
    for f in [100.0, 130.0] {
        let mut hb = Complex64::new(0.0, 0.0);
        for (sign, part) in m.parts() {
            let pt = balanced(&part, f, force, &opts);
            assert!(pt.converged);
            hb += sign * pt.x[0];
        }
        let p = 2000;
        let mut sim = Simulator::new(&m.linear, m.element_set().unwrap(), f * p as f64).unwrap();
        let periods = (2.0 * f) as usize;
        let drive: Vec<f64> = (0..periods * p)
            .map(|n| force * (2.0 * PI * (n % p) as f64 / p as f64).cos())
            .collect();
        let x = sim
            .run(&drive, &hystid::observe::Silent)
            .unwrap()
            .displacement;
        let s = harmonic(&x, p, 20, 1);
        assert!(
            (s / hb - 1.0).norm() < 2e-3,
            "at {f} Hz: simulated {s} vs HB {hb}"
        );
        // the mode's joint slips: held stuck, the response differs by more
        let mut stuck = m.clone();
        stuck.linear.modes[1].joint = Some(ElementSpec::Jenkins { kd: 1.3e6, fd: 1e6 });
        let mut held = Complex64::new(0.0, 0.0);
        for (sign, part) in stuck.parts() {
            held += sign * balanced(&part, f, force, &opts).x[0];
        }
        assert!(
            (held / hb - 1.0).norm() > 0.01,
            "at {f} Hz the joint sticks: {held} vs {hb}"
        );
    }
}

/// The paper's system with its Jenkins joint driven through a shaker
/// (ce 400 N s/m, te 0.5 ms): a virtual test's definition.
pub(crate) const SHAKER_TEST: &str = r#"
[system]
mass = 10.0
damping = 200.0
stiffness = 1.0e7
[joint]
kind = "jenkins"
kd = 2.4e7
fd = 246.048
[[effects]]
kind = "shaker"
ce = 400.0
te = 5e-4
[test]
frequencies_hz = { start = 100.0, stop = 350.0, count = 21 }
levels_n = [50.0, 500.0, 3000.0]
sweep = "up"
noise = 0.10
seed = 1
response = "displacement"
"#;

/// `hystid ARGS...` (the CLI tests' runner), which must succeed.
pub(crate) fn run_ok(args: &[&std::path::Path]) {
    let args: Vec<&str> = args.iter().map(|a| a.to_str().unwrap()).collect();
    let o = crate::cli::hystid(&args);
    assert!(o.status.success(), "{}", crate::cli::text(&o));
}

pub(crate) fn read_json(p: &std::path::Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

/// The shaker's virtual test simulated into `dir/sim` (its folder).
fn simulated_shaker_test(dir: &std::path::Path) -> std::path::PathBuf {
    let toml = crate::cli::write_test(dir, "shaker.toml", SHAKER_TEST);
    let sim = dir.join("sim");
    crate::cli::simulated(&toml, &sim);
    sim
}

fn pinned_line(start: &str) -> Vec<(f64, f64)> {
    crate::common::pinned_figures(start).expect("pinned figures")
}

/// A virtual test declares the shaker as an effect beside the paper's
/// Jenkins joint; with a shaker the bench records its reference as the
/// voltage (at 1 N/V: the model's forces are in the drive's unit).
/// `simulate --check-hb` holds harmonic balance to the bench's simulated
/// steady state within the issue's 0.2 % on H1 at every dwell (measured
/// 1.7e-4 at most, 3.6e-5 median, over 63 dwells).
#[test]
fn a_declared_shaker_is_simulated_by_the_bench_as_harmonic_balance_predicts() {
    let dir = tempfile::tempdir().unwrap();
    let out = checked_against_hb(dir.path(), SHAKER_TEST);
    let recording = read_json(&out.join("recording.json"));
    assert_eq!(recording["channels"][0]["quantity"], "voltage");
    assert_eq!(recording["channels"][0]["unit"], "V");
}

/// `hystid simulate TEST --check-hb` of the test definition `test` into
/// `dir/out`, held to the issue's bound: every one of the 63 dwells
/// balanced, H1 within 0.2 % of the bench's steady state. Returns the
/// output folder.
pub(crate) fn checked_against_hb(dir: &std::path::Path, test: &str) -> std::path::PathBuf {
    let toml = crate::cli::write_test(dir, "test.toml", test);
    let out = dir.join("out");
    let p = std::path::Path::new;
    run_ok(&[
        p("simulate"),
        &toml,
        p("--check-hb"),
        p("-q"),
        p("--out"),
        &out,
    ]);
    let summary = read_json(&out.join("summary.json"));
    let check = &summary["hb_check"];
    assert_eq!(check["dwells"], 63);
    assert_eq!(check["not_converged"], 0);
    let h1 = check["h1_max"].as_f64().unwrap();
    assert!(h1 < 2e-3, "H1 differs by {h1}");
    out
}

/// Undeclared, analysed with the right joint alone: `diagnose --element
/// jenkins` on the run file selects `shaker` alone, finds `te` within 1 %
/// and `ce` within 3 %, and the error in H1 falls at least 3x (the validation pages'
/// line holds the figures).
#[test]
fn an_undeclared_shaker_on_a_virtual_test_is_found() {
    let dir = tempfile::tempdir().unwrap();
    let sim = simulated_shaker_test(dir.path());
    let out = dir.path().join("diag");
    let p = std::path::Path::new;
    run_ok(&[
        p("diagnose"),
        &sim.join("run.mcap"),
        p("--element"),
        p("jenkins"),
        p("-q"),
        p("--out"),
        &out,
    ]);
    let d = read_json(&out.join("diagnosis.json"));
    let selected: Vec<&str> = d["selected"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["effect"].as_str().unwrap())
        .collect();
    assert_eq!(selected, ["shaker"], "{}", d["explanation"]);
    let got = |n: &str| d["selected"][0]["parameters"][n]["value"].as_f64().unwrap();
    let (before, after) = (
        d["baseline"]["error_relative"].as_f64().unwrap(),
        d["final"]["error_relative"].as_f64().unwrap(),
    );
    let chi2 = |at: &str| d[at]["chi2_per_dof"].as_f64().unwrap();
    let figures = [
        ("ce error (%)", 100.0 * (got("ce") / 400.0 - 1.0)),
        ("te error (%)", 100.0 * (got("te") / 5e-4 - 1.0)),
        ("H1 error before (%)", 100.0 * before),
        ("H1 error after (%)", 100.0 * after),
        ("chi2/dof before", chi2("baseline")),
        ("chi2/dof after", chi2("final")),
    ];
    eprintln!("{figures:?}");
    let shown = pinned_line("Shaker on a virtual test:");
    for ((what, value), shown) in figures.iter().zip(shown) {
        crate::common::assert_pinned_figure(what, *value, shown);
    }
    assert!(
        figures[0].1.abs() < 3.0 && figures[1].1.abs() < 1.0,
        "{figures:?}"
    );
    assert!(before >= 3.0 * after, "H1 error {before} -> {after}");
}

/// Declared, the shaker is identified from the nonlinear FRFs: `identify
/// --start` with the structure, the joint and a shaker written down 15-25 %
/// off (ce 300, te 0.3 ms; kd 2e7, fd 200) fits every parameter of the model;
/// the fit.json it writes validates at the test's 10 % noise floor (the
/// README's line holds the figures).
#[test]
fn a_declared_shaker_is_identified_from_the_frfs() {
    let dir = tempfile::tempdir().unwrap();
    let sim = simulated_shaker_test(dir.path());
    let p = std::path::Path::new;
    let start = dir.path().join("start.toml");
    std::fs::write(
        &start,
        "[system]\nmass = 10.0\ndamping = 200.0\nstiffness = 1.0e7\n\
         [joint]\nkind = \"jenkins\"\nkd = 2.0e7\nfd = 200.0\n\
         [[effects]]\nkind = \"shaker\"\nce = 300.0\nte = 3e-4\n",
    )
    .unwrap();
    let fit = dir.path().join("fit");
    run_ok(&[
        p("identify"),
        &sim.join("run.mcap"),
        p("--start"),
        &start,
        p("-q"),
        p("--out"),
        &fit,
    ]);
    let f = read_json(&fit.join("fit.json"));
    let params = &f["frequency_domain"]["parameters"];
    let got = |n: &str| params[n]["value"].as_f64().unwrap();
    let val = dir.path().join("val");
    run_ok(&[
        p("validate"),
        &fit.join("fit.json"),
        &sim.join("recording.json"),
        p("-q"),
        p("--out"),
        &val,
    ]);
    let v = read_json(&val.join("validate.json"));
    let figures = [
        ("ce error (%)", 100.0 * (got("shaker.ce") / 400.0 - 1.0)),
        ("te error (%)", 100.0 * (got("shaker.te") / 5e-4 - 1.0)),
        ("kd error (%)", 100.0 * (got("kd") / 2.4e7 - 1.0)),
        ("fd error (%)", 100.0 * (got("fd") / 246.048 - 1.0)),
        (
            "chi2/dof",
            f["frequency_domain"]["error"]["chi2_per_dof"]
                .as_f64()
                .unwrap(),
        ),
        (
            "validated e_RMS (% of the RMS)",
            100.0 * v["recordings"][0]["whole"]["relative"].as_f64().unwrap(),
        ),
    ];
    eprintln!("{figures:?}");
    let shown = pinned_line("A declared shaker fitted to the FRFs:");
    for ((what, value), shown) in figures.iter().zip(shown) {
        crate::common::assert_pinned_figure(what, *value, shown);
    }
    assert!(
        figures[0].1.abs() < 3.0 && figures[1].1.abs() < 1.0,
        "{figures:?}"
    );
    assert!(
        figures[2].1.abs() < 1.0 && figures[3].1.abs() < 1.0,
        "{figures:?}"
    );
    assert!((figures[5].1 - 10.0).abs() < 1.0, "{figures:?}");
}

/// The shaker's virtual test with the shaker declared by its coil (R 1 ohm,
/// L 0.5 mH, Bl 20 N/A: ce 400 N s/m and te 0.5 ms as above, gain 20 N/V,
/// the levels the same blocked forces) and a force gauge recording the
/// force it applies beside the voltage.
pub(crate) fn gauge_test() -> String {
    SHAKER_TEST
        .replace("ce = 400.0\nte = 5e-4", "r = 1.0\nl = 5e-4\nbl = 20.0")
        .replace("[50.0, 500.0, 3000.0]", "[2.5, 25.0, 150.0]")
        .replace(
            "noise = 0.10",
            "noise = 0.10\nforce_noise = 0.02\nforce_gauge = true",
        )
}

/// With a force gauge the bench records the force the shaker applies as a
/// `force` channel beside the voltage, in the WAV recording and the run
/// file alike, and every other channel is the same, sample for sample, as
/// without the gauge (its noise has streams of its own). The recording's
/// reference is then that force, as the recording format says: `identify
/// --element jenkins` finds the structure and the joint from it with no
/// model of the shaker (kd and fd within 1 %, the mass within 1 % of the
/// 10 kg), where the force drop at resonance would have the voltage
/// mislead a fit without one. The force itself drops at resonance: at the
/// top level to 78 % of what the coil's lagged drive would give (the
/// README's line holds the figures).
#[test]
fn a_force_gauge_beside_the_voltage_gives_the_structure_without_the_shaker() {
    let dir = tempfile::tempdir().unwrap();
    let p = std::path::Path::new;
    let gauge = gauge_test();
    assert!(gauge.contains("bl = 20.0") && gauge.contains("force_gauge = true"));
    let toml = crate::cli::write_test(dir.path(), "gauge.toml", &gauge);
    // harmonic balance of the shaker in newtons (its gain 20 N/V) against
    // the bench's steady state: the issue's 0.2 % on H1 at every dwell
    let sim = checked_against_hb(dir.path(), &gauge);
    let plain = crate::cli::write_test(
        dir.path(),
        "plain.toml",
        &gauge.replace("\nforce_gauge = true", ""),
    );
    let sim_plain = dir.path().join("plain");
    crate::cli::simulated(&plain, &sim_plain);

    let rec_json = sim.join("recording.json");
    let rec = hystid::record::read_recording(&rec_json).unwrap();
    let quantities: Vec<String> = rec
        .meta
        .channels
        .iter()
        .map(|c| format!("{} {} {}", c.name, c.quantity, c.unit))
        .collect();
    assert_eq!(
        quantities,
        [
            "drive voltage V",
            "force force N",
            "displacement displacement m",
            "velocity velocity m/s",
            "acceleration acceleration m/s^2"
        ]
    );
    assert_eq!(rec.reference_channel(), Some(1));
    let without = hystid::record::read_recording(&sim_plain.join("recording.json")).unwrap();
    assert_eq!(without.channels.len(), 4);
    for (c, w) in [0, 2, 3, 4].into_iter().zip(&without.channels) {
        assert!(rec.channels[c] == *w, "channel {c} differs with the gauge");
    }
    // the run file holds the same five channels
    let run = hystid::record::read_run(&sim.join("run.mcap")).unwrap();
    let from_run = run.to_recording().unwrap();
    assert_eq!(from_run.channels, rec.channels);
    let frf = read_json(&sim.join("frf.json"));
    assert_eq!(frf["reference"], "force");
    // a model with the shaker takes the voltage, not the gauge's force:
    // validate and identify --start say so, naming the channel or file
    let model = dir.path().join("model.toml");
    std::fs::write(&model, &gauge).unwrap();
    for args in [
        vec![
            "validate",
            model.to_str().unwrap(),
            rec_json.to_str().unwrap(),
        ],
        vec![
            "identify",
            rec_json.to_str().unwrap(),
            "--start",
            model.to_str().unwrap(),
        ],
    ] {
        let out = dir.path().join("refused");
        let mut args = args.clone();
        args.extend(["-q", "--out", out.to_str().unwrap()]);
        let o = crate::cli::hystid(&args);
        let text = crate::cli::text(&o);
        assert_eq!(o.status.code(), Some(2), "{text}");
        assert!(
            text.contains("is a force, and the model has a shaker")
                && (text.contains("`force`") || text.contains("recording.json: the reference")),
            "{text}"
        );
    }
    // `hystid run`'s report says what was driven and recorded, and gives
    // the coil found against the one simulated
    let run = dir.path().join("run");
    run_ok(&[
        p("run"),
        &toml,
        p("--no-diagnose"),
        p("-q"),
        p("--out"),
        &run,
    ]);
    let described = std::fs::read_to_string(run.join("report.md")).unwrap();
    assert!(
        described.contains("3 levels (2.5, 25, 150 V)")
            && described.contains("the shaker's force recorded by a force gauge (2 % noise)")
            && described.contains("The shaker's coil, from the voltage `drive`, the force `force`")
            && described.contains("against the simulated 20"),
        "{described}"
    );
    let in_run = read_json(&run.join("run.json"))["fit"]["coil"]["bl"]
        .as_f64()
        .unwrap();
    assert!((in_run / 20.0 - 1.0).abs() < 1e-3, "{in_run}");

    // the force drop, from the top level's FRF points: at the resonance
    // (the largest displacement) the force against what the coil would
    // push with its lag alone, `level Bl/R / |1 + jωτ|`
    let top = &frf["levels"][2]["points"];
    let at = |i: usize, key: &str| top[i][key].as_f64().unwrap();
    let displacement = |i: usize| {
        let h = &top[i]["h"][1];
        at(i, "force_amplitude") * h[0].as_f64().unwrap().hypot(h[1].as_f64().unwrap())
    };
    let n = top.as_array().unwrap().len();
    let resonance = (0..n)
        .max_by(|&a, &b| displacement(a).total_cmp(&displacement(b)))
        .unwrap();
    let lagged = |i: usize| 150.0 * 20.0 / (2.0 * PI * at(i, "frequency_hz") * 5e-4).hypot(1.0);
    let drop = at(resonance, "force_amplitude") / lagged(resonance);

    let fit = dir.path().join("fit");
    run_ok(&[
        p("identify"),
        &sim.join("recording.json"),
        p("--element"),
        p("jenkins"),
        p("-q"),
        p("--out"),
        &fit,
    ]);
    let f = read_json(&fit.join("fit.json"));
    let params = &f["parameters"];
    let got = |n: &str| params[n]["value"].as_f64().unwrap();
    let figures = [
        (
            "force at resonance, % of the coil's lagged drive",
            100.0 * drop,
        ),
        ("resonance (Hz)", at(resonance, "frequency_hz")),
        ("kd error (%)", 100.0 * (got("kd") / 2.4e7 - 1.0)),
        ("fd error (%)", 100.0 * (got("fd") / 246.048 - 1.0)),
        ("mass error (%)", 100.0 * (got("mass") / 10.0 - 1.0)),
        ("chi2/dof", f["error"]["chi2_per_dof"].as_f64().unwrap()),
    ];
    eprintln!("{figures:?}");
    let shown = pinned_line("A force gauge beside the voltage:");
    for ((what, value), shown) in figures.iter().zip(shown) {
        crate::common::assert_pinned_figure(what, *value, shown);
    }
    // the back-EMF takes a fifth of the force at the top level's resonance,
    // next to nothing at 100 Hz
    assert!(drop < 0.85, "{figures:?}");
    // and the coil from the voltage, the force and the velocity
    let coil = |n: &str| f["coil"][n].as_f64().unwrap();
    for (name, truth) in [("r", 1.0), ("l", 5e-4), ("bl", 20.0)] {
        let e = coil(name) / truth - 1.0;
        assert!(e.abs() < 1e-3, "coil {name}: {:+.3} %", 100.0 * e);
    }
    assert!(at(0, "force_amplitude") / lagged(0) > 0.97, "{figures:?}");
    assert!(
        figures[2].1.abs() < 1.0 && figures[3].1.abs() < 1.0 && figures[4].1.abs() < 1.0,
        "{figures:?}"
    );
}

/// The same gauge recording with its voltage named as the reference
/// (`--reference drive`): the analysis then sees the whole drive, and
/// `diagnose` finds the shaker on it, undeclared, where with the gauge's
/// force (the format's rule) there is none to find. Two routes through one
/// recording then agree: the coil's time constant from the voltage route
/// is `L/R` within 0.5 %, its back-EMF (in the drive's unit, `Bl` V s/m)
/// within 5 % and its interval holds 20; the structure it finds in volts,
/// times the gain `Bl/R` the gauge route measures (`fit::coil`), is the
/// simulated one within 0.5 % (kd, fd, mass, stiffness). The choice is
/// written to diagnosis.json, and `validate` takes it from there; bad
/// choices are refused with exit 2, naming the channel.
#[test]
fn the_voltage_named_as_the_reference_beside_a_gauge_gives_the_shaker() {
    let dir = tempfile::tempdir().unwrap();
    let p = std::path::Path::new;
    let toml = crate::cli::write_test(dir.path(), "gauge.toml", &gauge_test());
    let sim = dir.path().join("sim");
    crate::cli::simulated(&toml, &sim);
    let rec = sim.join("recording.json");
    let diag = dir.path().join("diag");
    run_ok(&[
        p("diagnose"),
        &rec,
        p("--reference"),
        p("drive"),
        p("-q"),
        p("--out"),
        &diag,
    ]);
    let d = read_json(&diag.join("diagnosis.json"));
    assert_eq!(d["reference_channel"], "drive");
    let selected = crate::independent::kit::score::selected_effects(&d);
    assert!(selected.contains(&"shaker"), "{selected:?}");
    let params = &d["final_model"]["parameters"];
    let got = |n: &str| params[n]["value"].as_f64().unwrap();
    let ci = |n: &str| {
        let c = &params[n]["ci95"];
        (c[0].as_f64().unwrap(), c[1].as_f64().unwrap())
    };
    let te = got("shaker.te") / 5e-4 - 1.0;
    assert!(te.abs() < 5e-3, "te {:+.3} %", 100.0 * te);
    let ce = got("shaker.ce") / 20.0 - 1.0;
    let (lo, hi) = ci("shaker.ce");
    assert!(
        ce.abs() < 0.05 && lo < 20.0 && 20.0 < hi,
        "ce {:+.2} %",
        100.0 * ce
    );
    assert_eq!(params["kd"]["unit"], "V/m");
    // the gauge route's gain turns volts into newtons
    let coil = hystid::analysis::recording::coil_of_path(&rec)
        .unwrap()
        .expect("a coil from voltage, force and motion");
    let mut figures = vec![("te", 100.0 * te), ("ce", 100.0 * ce)];
    for (name, truth) in [
        ("kd", 2.4e7),
        ("fd", 246.048),
        ("mass", 10.0),
        ("stiffness", 1.0e7),
    ] {
        let e = got(name) * coil.gain / truth - 1.0;
        assert!(e.abs() < 5e-3, "{name}: {:+.3} %", 100.0 * e);
        figures.push((name, 100.0 * e));
    }
    eprintln!("{figures:?}");
    let shown = pinned_line("The voltage named as the reference beside the gauge:");
    assert_eq!(shown.len(), figures.len());
    for ((what, value), shown) in figures.iter().zip(shown) {
        crate::common::assert_pinned_figure(what, *value, shown);
    }
    // validate takes the reference from the diagnosis: the error is the
    // response's 10 % noise
    let val = dir.path().join("val");
    run_ok(&[
        p("validate"),
        &diag.join("diagnosis.json"),
        &rec,
        p("-q"),
        p("--out"),
        &val,
    ]);
    let v = read_json(&val.join("validate.json"));
    let relative = v["recordings"][0]["whole"]["relative"].as_f64().unwrap();
    assert!((relative - 0.10).abs() < 0.005, "{relative}");
    // bad choices
    for (choice, says) in [
        (
            "displacement",
            "`channels`: the reference `displacement` is a displacement",
        ),
        (
            "nope",
            "`channels`: no channel `nope` to use as the reference",
        ),
    ] {
        let o = crate::cli::hystid(&[
            "validate",
            diag.join("diagnosis.json").to_str().unwrap(),
            rec.to_str().unwrap(),
            "--reference",
            choice,
            "-q",
            "--out",
            dir.path().join("refused").to_str().unwrap(),
        ]);
        let text = crate::cli::text(&o);
        assert_eq!(o.status.code(), Some(2), "{text}");
        assert!(
            text.contains("recording.json") && text.contains(says),
            "{text}"
        );
    }
}
