//! Runs `hystid diagnose` (the CLI binary) on a recording and scores its
//! `diagnosis.json` against the truth. Reads the JSON as `serde_json::Value`.

use super::corpus::{Case, EffectKind, JointKind, TrueEffect};
use serde_json::{Value, json};
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// What one `hystid diagnose` run produced.
#[derive(Clone, Debug)]
pub struct RunOutcome {
    pub exit_code: Option<i32>,
    pub timed_out: bool,
    pub seconds: f64,
    pub stderr_tail: String,
    pub diagnosis: Option<Value>,
    pub out_dir: PathBuf,
    pub command: String,
}

/// `hystid identify REC.json --element E --quiet --out DIR`: its fit.json
/// (panics, with hystid's message, if the command fails).
pub fn run_identify(bin: &Path, recording: &Path, out: &Path, element: &str) -> Value {
    let o = Command::new(bin)
        .arg("identify")
        .arg(recording)
        .args(["--element", element, "--quiet", "--out"])
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&std::fs::read(out.join("fit.json")).unwrap()).unwrap()
}

/// `hystid diagnose REC.json --out DIR --element E --quiet`, with a timeout.
pub fn run_diagnose(
    bin: &Path,
    recording: &Path,
    out_dir: &Path,
    element: &str,
    timeout: Duration,
) -> RunOutcome {
    run_diagnose_with(bin, recording, out_dir, element, &[], timeout)
}

/// [`run_diagnose`] with further arguments (`--candidates all`).
pub fn run_diagnose_with(
    bin: &Path,
    recording: &Path,
    out_dir: &Path,
    element: &str,
    extra: &[&str],
    timeout: Duration,
) -> RunOutcome {
    let _ = std::fs::remove_dir_all(out_dir);
    std::fs::create_dir_all(out_dir).expect("out dir");
    let mut args = vec![
        "diagnose".to_string(),
        recording.display().to_string(),
        "--out".into(),
        out_dir.display().to_string(),
        "--element".into(),
        element.into(),
        "--quiet".into(),
    ];
    args.extend(extra.iter().map(|a| a.to_string()));
    // HYSTID_DIAGNOSE_DOMAIN=time: the final model refitted on the time
    // history too (scored from that model)
    if let Ok(domain) = std::env::var("HYSTID_DIAGNOSE_DOMAIN") {
        args.extend(["--domain".into(), domain]);
    }
    let command = format!("{} {}", bin.display(), args.join(" "));
    let stdout = std::fs::File::create(out_dir.join("stdout.txt")).unwrap();
    let stderr = std::fs::File::create(out_dir.join("stderr.txt")).unwrap();
    let t0 = Instant::now();
    let mut child = match Command::new(bin)
        .args(&args)
        .stdout(stdout)
        .stderr(stderr)
        .stdin(Stdio::null())
        .spawn()
    {
        Ok(c) => c,
        Err(e) => {
            return RunOutcome {
                exit_code: None,
                timed_out: false,
                seconds: 0.0,
                stderr_tail: format!("could not start hystid: {e}"),
                diagnosis: None,
                out_dir: out_dir.into(),
                command,
            };
        }
    };
    let mut timed_out = false;
    let status = loop {
        match child.try_wait() {
            Ok(Some(s)) => break Some(s),
            Ok(None) if t0.elapsed() > timeout => {
                let _ = child.kill();
                let _ = child.wait();
                timed_out = true;
                break None;
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(50)),
            Err(_) => break None,
        }
    };
    let seconds = t0.elapsed().as_secs_f64();
    let err = std::fs::read_to_string(out_dir.join("stderr.txt")).unwrap_or_default();
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    let stderr_tail = lines[lines.len().saturating_sub(4)..].join("\n");
    let diagnosis = std::fs::read_to_string(out_dir.join("diagnosis.json"))
        .ok()
        .and_then(|s| serde_json::from_str(&s).ok());
    RunOutcome {
        exit_code: status.and_then(|s| s.code()),
        timed_out,
        seconds,
        stderr_tail,
        diagnosis,
        out_dir: out_dir.into(),
        command,
    }
}

/// One estimated parameter against its truth.
#[derive(Clone, Debug)]
pub struct ParamError {
    pub effect: String,
    pub name: String,
    pub truth: f64,
    pub estimate: Option<f64>,
    /// Whether it counts toward the 10 % (effects) / 3 % (joint) criterion.
    pub scored: bool,
}

impl ParamError {
    pub fn relative(&self) -> f64 {
        self.estimate
            .map_or(f64::INFINITY, |e| (e - self.truth).abs() / self.truth.abs())
    }
}

/// The score of one case.
#[derive(Clone, Debug)]
pub struct Score {
    pub name: String,
    pub seed: u64,
    pub summary: String,
    pub truth: Vec<String>,
    pub selected: Vec<String>,
    pub aborted: bool,
    pub abort_reason: String,
    pub seconds: f64,
    /// Time the reference took to generate the recording.
    pub gen_seconds: f64,
    pub joint: Vec<ParamError>,
    pub effects: Vec<ParamError>,
    pub chi2_dof: Option<f64>,
    pub baseline_chi2_dof: Option<f64>,
    pub baseline_error: Option<f64>,
    pub final_error: Option<f64>,
    pub failures: Vec<String>,
    pub command: String,
    /// Candidate lines: effect, accepted, Δχ², threshold, note.
    pub candidates: Vec<String>,
    /// Observations that are not failures.
    pub notes: Vec<String>,
}

impl Score {
    pub fn passed(&self) -> bool {
        self.failures.is_empty()
    }
    pub fn is_control(&self) -> bool {
        self.truth.is_empty()
    }
    pub fn effects_right(&self) -> bool {
        !self.aborted && self.truth == self.selected
    }
    pub fn to_json(&self) -> Value {
        let pe = |v: &[ParamError]| -> Vec<Value> {
            v.iter()
                .map(|p| {
                    json!({"effect": p.effect, "name": p.name, "truth": p.truth, "estimate": p.estimate,
                           "relative_error": p.estimate.map(|_| p.relative()), "scored": p.scored})
                })
                .collect()
        };
        json!({
            "name": self.name, "seed": self.seed, "summary": self.summary,
            "truth": self.truth, "selected": self.selected, "aborted": self.aborted,
            "abort_reason": self.abort_reason, "seconds": self.seconds, "gen_seconds": self.gen_seconds,
            "joint": pe(&self.joint), "effects": pe(&self.effects),
            "chi2_per_dof": self.chi2_dof, "baseline_chi2_per_dof": self.baseline_chi2_dof,
            "baseline_error_relative": self.baseline_error, "final_error_relative": self.final_error,
            "passed": self.passed(), "failures": self.failures, "command": self.command,
            "candidates": self.candidates, "notes": self.notes,
        })
    }
}

fn num(v: &Value) -> Option<f64> {
    v.as_f64()
}

/// Scores a run against the case's truth with the criteria.
pub fn score(case: &Case, run: &RunOutcome) -> Score {
    let truth: Vec<String> = case
        .effect_kinds()
        .iter()
        .map(|e| e.name().to_string())
        .collect();
    let mut s = Score {
        name: case.name.clone(),
        seed: case.seed,
        summary: case.summary(),
        truth,
        selected: vec![],
        aborted: false,
        abort_reason: String::new(),
        seconds: run.seconds,
        gen_seconds: 0.0,
        joint: vec![],
        effects: vec![],
        chi2_dof: None,
        baseline_chi2_dof: None,
        baseline_error: None,
        final_error: None,
        failures: vec![],
        command: run.command.clone(),
        candidates: vec![],
        notes: vec![],
    };
    let d = match (&run.diagnosis, run.exit_code) {
        (Some(d), Some(0)) => d,
        _ => {
            s.aborted = true;
            s.abort_reason = if run.timed_out {
                format!("timed out after {:.0} s", run.seconds)
            } else {
                format!("exit {:?}: {}", run.exit_code, run.stderr_tail)
            };
            s.failures.push(format!("aborted: {}", s.abort_reason));
            return s;
        }
    };
    let mut sel: Vec<String> = d["selected"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|e| e["effect"].as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default();
    sel.sort_by_key(|n| EffectKind::from_name(n));
    s.selected = sel;
    s.chi2_dof = num(&d["final"]["chi2_per_dof"]);
    s.baseline_chi2_dof = num(&d["baseline"]["chi2_per_dof"]);
    s.baseline_error = num(&d["baseline"]["error_relative"]);
    s.final_error = num(&d["final"]["error_relative"]);
    for c in d["candidates"].as_array().into_iter().flatten() {
        s.candidates.push(format!(
            "round {} {}: accepted={} delta_chi2={:.4e} threshold={:.4e} chi2/dof={:.4e} params={}{}",
            c["round"],
            c["effect"].as_str().unwrap_or("?"),
            c["accepted"],
            c["delta_chi2"].as_f64().unwrap_or(f64::NAN),
            c["threshold"].as_f64().unwrap_or(f64::NAN),
            c["chi2_per_dof"].as_f64().unwrap_or(f64::NAN),
            c["effect_parameters"],
            c["note"].as_str().map(|n| format!(" note: {n}")).unwrap_or_default()
        ));
    }
    // the time-domain refit's model when `--domain time` made one
    let model = match &d["time_domain"]["refit"]["model"] {
        serde_json::Value::Null => &d["model"],
        m => m,
    };
    // the joint, then the effects (diagnosis.json's model form)
    let elements: Vec<&Value> = std::iter::once(&model["joint"])
        .filter(|j| j.is_object())
        .chain(model["effects"].as_array().into_iter().flatten())
        .collect();
    let joint_kind = case.element();
    // the joint: the element of the kind asked for, else any hysteretic
    // one (a Masing joint with N → ∞ is a Jenkins joint; noted)
    let joint = elements
        .iter()
        .find(|e| e["kind"] == joint_kind)
        .or_else(|| {
            elements
                .iter()
                .find(|e| e["kind"] == "jenkins" || e["kind"] == "masing")
        });
    if let Some(j) = joint
        && j["kind"] != joint_kind
    {
        s.notes.push(format!(
            "asked for a {joint_kind} joint, the final model has {}",
            j
        ));
    }
    // the stick stiffness and slip force, by the law's names
    let names: &[&str] = match case.joint {
        JointKind::Iwan4 { .. } => &["kt", "fs"],
        // its saturation force is no parameter of the law
        JointKind::BoucWen { .. } => &["alpha"],
        _ => &["kd", "fd"],
    };
    for (&name, t) in names.iter().zip([case.kd, case.fd]) {
        s.joint.push(ParamError {
            effect: joint_kind.into(),
            name: name.into(),
            truth: t,
            estimate: joint.and_then(|j| num(&j[name])),
            scored: true,
        });
    }
    if let (JointKind::Masing { n }, Some(j)) = (case.joint, joint) {
        s.joint.push(ParamError {
            effect: "masing".into(),
            name: "n".into(),
            truth: n,
            estimate: num(&j["n"]),
            scored: false,
        });
    }
    // Iwan's shape: χ within 0.05 and β within 20 % (issue 12)
    if let (JointKind::Iwan4 { chi, beta }, Some(j)) = (case.joint, joint) {
        let chi_hat = num(&j["chi"]);
        if !chi_hat.is_some_and(|c| (c - chi).abs() <= 0.05) {
            s.failures
                .push(format!("joint chi {chi_hat:?} against {chi} (within 0.05)"));
        }
        s.joint.push(ParamError {
            effect: "iwan4".into(),
            name: "chi".into(),
            truth: chi,
            estimate: chi_hat,
            scored: false,
        });
        let beta_hat = num(&j["beta"]);
        if !beta_hat.is_some_and(|b| (b - beta).abs() <= 0.2 * beta) {
            s.failures.push(format!(
                "joint beta {beta_hat:?} against {beta} (within 20 %)"
            ));
        }
        s.joint.push(ParamError {
            effect: "iwan4".into(),
            name: "beta".into(),
            truth: beta,
            estimate: beta_hat,
            scored: false,
        });
    }
    // effect parameters, for the true effects that were selected
    let modes: Vec<&Value> = model["linear"]["modes"]
        .as_array()
        .map(|a| a.iter().collect())
        .unwrap_or_default();
    for e in &case.effects {
        let kind = e.kind().name();
        if !s.selected.iter().any(|x| x == kind) {
            // the truth of an effect that was missed, shown but not scored
            // (the miss itself is the failure)
            for (name, t) in e.parameters() {
                s.effects.push(ParamError {
                    effect: kind.into(),
                    name: name.into(),
                    truth: t,
                    estimate: None,
                    scored: false,
                });
            }
            continue;
        }
        match e {
            TrueEffect::SecondMode { frequency_hz, .. } => {
                // the extra mode: of the modes beyond the one nearest the
                // slip resonance, the one nearest the true second mode
                let nearest = |f: f64, skip: Option<usize>| {
                    let d = |m: &Value| {
                        (num(&m["frequency_hz"]).unwrap_or(f64::INFINITY) / f)
                            .ln()
                            .abs()
                    };
                    modes
                        .iter()
                        .enumerate()
                        .filter(|(i, _)| Some(*i) != skip)
                        .min_by(|a, b| d(a.1).total_cmp(&d(b.1)))
                };
                let main = nearest(case.f_slip(), None).map(|x| x.0);
                let m2 = nearest(*frequency_hz, main).map(|x| x.1);
                // a mode outside the measured band shows there only as a
                // residual flexibility (above) or mass line (below): what
                // the data determine, and what is scored, is its receptance
                // at the band's nearer edge; its frequency and modal
                // constant are shown
                let lo = case.frequencies.iter().copied().fold(f64::MAX, f64::min);
                let hi = case.frequencies.iter().copied().fold(0.0, f64::max);
                let edge = if *frequency_hz > hi * 1.05 {
                    Some(hi)
                } else if *frequency_hz * 1.05 < lo {
                    Some(lo)
                } else {
                    None
                };
                for (name, t) in e.parameters() {
                    s.effects.push(ParamError {
                        effect: kind.into(),
                        name: name.into(),
                        truth: t,
                        estimate: m2.and_then(|m| num(&m[name])),
                        scored: name != "damping_ratio" && edge.is_none(),
                    });
                }
                if let Some(fe) = edge {
                    let at_edge = |f: f64, zeta: f64, residue: f64| {
                        let (w, we) = (2.0 * PI * f, 2.0 * PI * fe);
                        residue / ((w * w - we * we).powi(2) + (2.0 * zeta * w * we).powi(2)).sqrt()
                    };
                    let TrueEffect::SecondMode {
                        damping_ratio,
                        modal_mass,
                        ..
                    } = e
                    else {
                        unreachable!()
                    };
                    let estimate = m2.and_then(|m| {
                        Some(at_edge(
                            num(&m["frequency_hz"])?,
                            num(&m["damping_ratio"])?,
                            num(&m["residue"])?,
                        ))
                    });
                    s.effects.push(ParamError {
                        effect: kind.into(),
                        name: "receptance_at_band_edge".into(),
                        truth: at_edge(*frequency_hz, *damping_ratio, 1.0 / modal_mass),
                        estimate,
                        scored: true,
                    });
                }
            }
            _ => {
                let el = elements.iter().find(|x| x["kind"] == kind);
                for (name, t) in e.parameters() {
                    s.effects.push(ParamError {
                        effect: kind.into(),
                        name: name.into(),
                        truth: t,
                        estimate: el.and_then(|x| num(&x[name])),
                        scored: true,
                    });
                }
            }
        }
    }
    // the criteria
    if s.selected != s.truth {
        s.failures.push(format!(
            "selected [{}], truth [{}]",
            s.selected.join(","),
            s.truth.join(",")
        ));
    }
    for p in &s.joint {
        if p.scored && !(p.relative() <= 0.03) {
            s.failures.push(format!(
                "joint {} error {:.2} % (truth {:.5e}, estimate {:?})",
                p.name,
                100.0 * p.relative(),
                p.truth,
                p.estimate
            ));
        }
    }
    for p in &s.effects {
        if p.scored && !(p.relative() <= 0.10) {
            s.failures.push(format!(
                "{}.{} error {:.2} % (truth {:.5e}, estimate {:?})",
                p.effect,
                p.name,
                100.0 * p.relative(),
                p.truth,
                p.estimate
            ));
        }
    }
    if s.is_control() && !(s.chi2_dof.unwrap_or(f64::INFINITY) <= 2.0) {
        s.failures.push(format!(
            "control chi2/dof {:.3}",
            s.chi2_dof.unwrap_or(f64::NAN)
        ));
    }
    s
}

/// The binary under test: the one cargo built, or `HYSTID_BIN` (e.g. a copy,
/// so that a long corpus run is not changed under it by a rebuild).
pub fn hystid_bin() -> PathBuf {
    std::env::var_os("HYSTID_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_hystid")))
}

/// The effects a `diagnosis.json` selected, in order.
pub fn selected_effects(diagnosis: &Value) -> Vec<&str> {
    diagnosis["selected"]
        .as_array()
        .map(|a| a.iter().filter_map(|s| s["effect"].as_str()).collect())
        .unwrap_or_default()
}
