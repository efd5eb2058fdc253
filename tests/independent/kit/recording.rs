//! Writes a recording in the v1 format (WAV + JSON sidecar), independently
//! of hystid's writer.

use super::corpus::{Case, JointKind, Recording, SampleFormat, TrueEffect};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// The scale of a channel: PCM peaks at 90 % of full scale; float stores
/// physical values (scale 1).
pub fn channel_scale(format: SampleFormat, v: &[f64]) -> f64 {
    match format {
        SampleFormat::Float32 => 1.0,
        _ => {
            let peak = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            if peak > 0.0 { peak / 0.9 } else { 1.0 }
        }
    }
}

/// The integer code of a physical value.
pub fn quantise(x: f64, scale: f64, bits: u32) -> i32 {
    let full = (1i64 << (bits - 1)) as f64;
    (x / scale * full).round().clamp(-full, full - 1.0) as i32
}

/// The truth, for scoring (hystid must not use it).
pub fn truth_json(case: &Case) -> Value {
    let joint = match case.joint {
        JointKind::Jenkins => json!({"kind": "jenkins", "kd": case.kd, "fd": case.fd}),
        JointKind::Masing { n } => json!({"kind": "masing", "kd": case.kd, "fd": case.fd, "n": n}),
        JointKind::Iwan4 { chi, beta } => {
            json!({"kind": "iwan4", "kt": case.kd, "fs": case.fd, "chi": chi, "beta": beta})
        }
        JointKind::BoucWen { gamma, delta, nu } => json!({
            "kind": "bouc_wen",
            "alpha": case.kd,
            "beta": JointKind::bouc_wen_beta(case.kd, case.fd, gamma, delta, nu),
            "gamma": gamma,
            "delta": delta,
            "nu": nu
        }),
    };
    let effects: Vec<Value> = case
        .effects
        .iter()
        .map(|e| {
            let mut o = serde_json::Map::new();
            o.insert("kind".into(), json!(e.kind().name()));
            for (k, v) in e.parameters() {
                o.insert(k.into(), json!(v));
            }
            if let TrueEffect::SecondMode { modal_mass, .. } = e {
                o.insert("modal_mass".into(), json!(modal_mass));
            }
            Value::Object(o)
        })
        .collect();
    json!({
        "seed": case.seed,
        "system": {"mass": case.mass, "damping": case.damping, "stiffness": case.stiffness,
                   "f_slip_hz": case.f_slip(), "f_stuck_hz": case.f_stuck(), "damping_ratio": case.zeta()},
        "joint": joint,
        "effects": effects,
        "levels": case.levels,
        "frequencies_hz": case.frequencies,
        "sweep": case.sweep.name(),
        "response_noise": case.response_noise,
        "force_noise": case.force_noise,
        "substeps": case.substeps,
        "coil": case.coil.map(|c| json!({"resistance": c.r, "inductance": c.l, "force_factor": c.bl})),
    })
}

/// Writes `DIR/NAME.wav` and `DIR/NAME.json`; returns the JSON's path.
pub fn write_recording(dir: &Path, case: &Case, rec: &Recording) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(dir)?;
    let wav = dir.join(format!("{}.wav", case.name));
    let js = dir.join(format!("{}.json", case.name));
    // the signals in channel order: the reference, a gauge's force after
    // a voltage when asked, the response
    let mut signals = vec![&rec.force];
    if case.gauge && case.coil.is_some() {
        signals.push(&rec.gauge);
    }
    signals.push(&rec.response);
    let scales: Vec<f64> = signals
        .iter()
        .map(|s| channel_scale(case.format, s))
        .collect();
    let (bits, fmt) = match case.format {
        SampleFormat::Float32 => (32, hound::SampleFormat::Float),
        SampleFormat::Pcm16 => (16, hound::SampleFormat::Int),
        SampleFormat::Pcm24 => (24, hound::SampleFormat::Int),
    };
    let spec = hound::WavSpec {
        channels: signals.len() as u16,
        sample_rate: rec.sample_rate,
        bits_per_sample: bits,
        sample_format: fmt,
    };
    let io = |e: hound::Error| std::io::Error::other(e.to_string());
    let mut w = hound::WavWriter::create(&wav, spec).map_err(io)?;
    for i in 0..rec.force.len() {
        for (c, v) in signals.iter().map(|s| s[i]).enumerate() {
            match case.format {
                SampleFormat::Float32 => w.write_sample((v / scales[c]) as f32),
                SampleFormat::Pcm16 => w.write_sample(quantise(v, scales[c], 16) as i16),
                SampleFormat::Pcm24 => w.write_sample(quantise(v, scales[c], 24)),
            }
            .map_err(io)?;
        }
    }
    w.finalize().map_err(io)?;
    let mut excitation = json!({"kind": "stepped-sine"});
    if case.with_steps {
        excitation["steps"] = rec
            .steps
            .iter()
            .map(|&(f, a, s, settle, len)| {
                json!({"frequency_hz": f, "level": a, "start": s, "settle": settle, "length": len})
            })
            .collect::<Vec<_>>()
            .into();
    }
    let mut channels = vec![match case.coil {
        // through a shaker's coil the reference is the voltage
        Some(_) => json!({"name": "drive", "quantity": "voltage", "unit": "V", "scale": scales[0]}),
        None => json!({"name": "force", "quantity": "force", "unit": "N", "scale": scales[0]}),
    }];
    if signals.len() == 3 {
        channels
            .push(json!({"name": "gauge", "quantity": "force", "unit": "N", "scale": scales[1]}));
    }
    channels.push(json!({"name": "response", "quantity": case.quantity.name(), "unit": case.quantity.unit(), "scale": scales[signals.len() - 1]}));
    let doc = json!({
        "format": "hystid.recording.v1",
        "sample_rate_hz": rec.sample_rate,
        "channels": channels,
        "excitation": excitation,
        "description": format!("independent reference simulator (RK4, {} sub-steps per sample): {}", case.substeps, case.summary()),
        "metadata": {"generator": "hystid tests/independent reference simulator", "truth": truth_json(case)},
    });
    std::fs::write(&js, serde_json::to_string_pretty(&doc).unwrap())?;
    Ok(js)
}
