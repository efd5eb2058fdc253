//! Issue 12: a voltage-driven test through a shaker's coil, on a recording of
//! the reference simulator (RK4 of the structure, its Jenkins joint and the
//! coil's current, `L i' + R i + Bl x' = e`, which hystid's simulator shares
//! no code with). The reference is the voltage. Undeclared, `diagnose` must
//! find the shaker by name and its coil's time constant `L/R`.

use super::kit::corpus::{
    CaseOptions, JointKind, Quantity, SampleFormat, Sweep, case_with, generate,
};
use super::kit::recording::write_recording;
use super::kit::refsim::RefCoil;
use super::kit::score::{hystid_bin, run_diagnose_with, run_identify, selected_effects};
use std::f64::consts::PI;
use std::path::PathBuf;
use std::time::Duration;

/// The case's structure (a random mass, stiffness and Jenkins joint, 10 %
/// response noise, 0.5 % noise on the voltage) driven through a coil of
/// 2 ohm whose lag is 17 degrees at the slipping resonance (`ω L/R = 0.3`)
/// and whose back-EMF damping `Bl²/R` equals the structure's own; the
/// voltages give the case's forces as blocked forces `(Bl/R) e`, doubled
/// for the force the back-EMF takes at resonance. `diagnose --element
/// jenkins` (its default candidates) selects `shaker` alone, finds the
/// coil's time constant and its back-EMF damping (in the drive's unit,
/// `Bl`) within 3 %, and the error in H1 falls at least 3x; the validation pages'
/// row holds the figures.
#[test]
fn a_shaker_from_the_independent_simulator_is_found() {
    let o = CaseOptions {
        levels: Some(5),
        frequencies: Some(24),
        format: Some(SampleFormat::Pcm24),
        quantity: Some(Quantity::Velocity),
        sweep: Some(Sweep::Up),
        with_steps: Some(true),
        broad: false,
    };
    let mut case = case_with(232, JointKind::Jenkins, &[], &o);
    case.name = "shaker-232".into();
    let w = 2.0 * PI * case.f_slip();
    let r = 2.0;
    let coil = RefCoil {
        r,
        l: 0.3 * r / w,
        bl: (case.damping * r).sqrt(),
    };
    case.levels = case.levels.iter().map(|f| 2.0 * f * r / coil.bl).collect();
    case.coil = Some(coil);
    let te = coil.l / coil.r;
    eprintln!(
        "{} through a coil: R {r} ohm, L {:.4e} H (te {te:.4e} s), Bl {:.4e} N/A",
        case.summary(),
        coil.l,
        coil.bl
    );
    let rec = generate(&case);
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("independent-shaker");
    let js = write_recording(&dir.join("recordings"), &case, &rec).unwrap();
    // the same run with the force the coil applies beside its voltage
    let mut gauged = case.clone();
    gauged.gauge = true;
    gauged.name = format!("{}-gauge", case.name);
    let js_gauge = write_recording(&dir.join("recordings"), &gauged, &rec).unwrap();
    drop(rec);
    let run = run_diagnose_with(
        &hystid_bin(),
        &js,
        &dir.join("out"),
        "jenkins",
        &[],
        Duration::from_secs(900),
    );
    let d = run
        .diagnosis
        .unwrap_or_else(|| panic!("diagnose failed: {}", run.stderr_tail));
    let selected = selected_effects(&d);
    let (before, after) = (
        d["baseline"]["error_relative"].as_f64().unwrap(),
        d["final"]["error_relative"].as_f64().unwrap(),
    );
    let chi2 = |at: &str| d[at]["chi2_per_dof"].as_f64().unwrap();
    eprintln!(
        "selected {selected:?}: H1 error {:.2} % -> {:.2} % ({:.1}x), chi2/dof {:.1} -> {:.2}, {:.0} s\n{}",
        100.0 * before,
        100.0 * after,
        before / after,
        chi2("baseline"),
        chi2("final"),
        run.seconds,
        d["explanation"]
    );
    assert_eq!(selected, ["shaker"], "{}", d["explanation"]);
    let got = |n: &str| {
        d["selected"][0]["parameters"][n]["value"]
            .as_f64()
            .unwrap_or(f64::NAN)
    };
    // in the drive's unit the force is F R/Bl, so ce = Bl²/R becomes Bl
    let errors = [
        ("te", 100.0 * (got("te") / te - 1.0)),
        ("ce", 100.0 * (got("ce") / coil.bl - 1.0)),
    ];
    eprintln!("  te {:+.2} %, ce {:+.2} %", errors[0].1, errors[1].1);
    let shown = crate::common::pinned_figures(&format!("| {} |", case.name))
        .unwrap_or_else(|| panic!("no pinned row for {}", case.name));
    for (i, (what, value)) in errors
        .into_iter()
        .chain([
            ("H1 error before", 100.0 * before),
            ("H1 error after", 100.0 * after),
            ("chi2/dof before", chi2("baseline")),
            ("chi2/dof after", chi2("final")),
        ])
        .enumerate()
    {
        crate::common::assert_pinned_figure(&format!("{}: {what}", case.name), value, shown[i]);
    }
    for (what, e) in errors {
        assert!(e.abs() < 3.0, "{what}: {e:+.2} %");
    }
    assert!(before >= 3.0 * after, "H1 error {before} -> {after}");

    // with the gauge's force as the reference, `identify` needs no model of
    // the shaker, and finds its coil from the voltage, the force and the
    // velocity: R, L and Bl each within 1 %
    let fit = run_identify(&hystid_bin(), &js_gauge, &dir.join("out-gauge"), "jenkins");
    assert_eq!(
        fit["coil"]["channels"],
        serde_json::json!(["drive", "gauge", "response"])
    );
    let c = |n: &str| fit["coil"][n].as_f64().unwrap();
    let p = |n: &str| fit["parameters"][n]["value"].as_f64().unwrap();
    let gauge = [
        ("R", 100.0 * (c("r") / coil.r - 1.0)),
        ("L", 100.0 * (c("l") / coil.l - 1.0)),
        ("Bl", 100.0 * (c("bl") / coil.bl - 1.0)),
        ("kd", 100.0 * (p("kd") / case.kd - 1.0)),
        ("fd", 100.0 * (p("fd") / case.fd - 1.0)),
    ];
    eprintln!("with the gauge: {gauge:?}");
    let shown = crate::common::pinned_figures(&format!("| {}-gauge |", case.name))
        .unwrap_or_else(|| panic!("no pinned row for {}-gauge", case.name));
    for (i, (what, value)) in gauge.iter().enumerate() {
        crate::common::assert_pinned_figure(
            &format!("{}-gauge: {what}", case.name),
            *value,
            shown[i],
        );
    }
    for (what, e) in &gauge[..3] {
        assert!(e.abs() < 1.0, "{what}: {e:+.2} %");
    }
    for (what, e) in &gauge[3..] {
        assert!(e.abs() < 3.0, "{what}: {e:+.2} %");
    }

    // the diagnosed model, shaker and all, replayed on the gauged recording
    // with its voltage named as the reference is the same replay as on the
    // recording without the gauge (the same voltage and velocity samples);
    // with the format's rule (the gauge's force) it is refused, pointing at
    // `--reference`
    let diagnosis = dir.join("out").join("diagnosis.json");
    let validate = |rec: &std::path::Path, extra: &[&str], out: &str| {
        let mut args = vec![
            "validate".to_string(),
            diagnosis.display().to_string(),
            rec.display().to_string(),
            "-q".into(),
            "--no-frf".into(),
            "--out".into(),
            dir.join(out).display().to_string(),
        ];
        args.extend(extra.iter().map(|a| a.to_string()));
        std::process::Command::new(hystid_bin())
            .args(&args)
            .output()
            .unwrap()
    };
    let e_rms = |out: &str| {
        let v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join(out).join("validate.json")).unwrap())
                .unwrap();
        v["recordings"][0]["whole"]["e_rms"].as_f64().unwrap()
    };
    assert!(validate(&js, &[], "val").status.success());
    assert!(
        validate(&js_gauge, &["--reference", "drive"], "val-gauge")
            .status
            .success()
    );
    assert_eq!(e_rms("val"), e_rms("val-gauge"));
    let refused = validate(&js_gauge, &[], "val-refused");
    let text = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(2), "{text}");
    assert!(
        text.contains("`gauge`") && text.contains("--reference"),
        "{text}"
    );
}
