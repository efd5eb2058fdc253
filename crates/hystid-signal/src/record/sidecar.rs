//! The JSON sidecar of recording format v1: parsing with field-by-field
//! checks, and the rules every recording must satisfy.
//!
//! Parsing goes through a `serde_json::Value` first so that a syntax error
//! reports its line and column and a content error names the exact key
//! (`channels[1].unit`), rather than serde's generic "invalid type".

use super::{Channel, FORMAT_V1, RecordingMeta};
use crate::error::{Error, Result};
use crate::harmonics::Quantity;
use serde_json::{Map, Value};
use std::collections::HashSet;
use std::path::Path;

/// Parses and checks a sidecar's text (the checks that need the WAV header
/// are done by the caller).
pub(crate) fn parse(path: &Path, text: &str) -> Result<RecordingMeta> {
    let value: Value = serde_json::from_str(text).map_err(|e| {
        // serde_json's message ends with "at line L column C".
        Error::format(path, "JSON", format!("malformed JSON: {e}"))
    })?;
    let root = value
        .as_object()
        .ok_or_else(|| Error::format(path, "(root)", "expected a JSON object"))?;
    check_types(path, root)?;
    let meta: RecordingMeta = serde_json::from_value(value)
        .map_err(|e| Error::format(path, "(root)", format!("unexpected content: {e}")))?;
    check(path, &meta, None)?;
    Ok(meta)
}

/// Type checks on the raw JSON with precise key paths; serde then only has
/// to map what is known to fit.
fn check_types(path: &Path, root: &Map<String, Value>) -> Result<()> {
    let err = |field: &str, msg: &str| Error::format(path, field, msg);
    match root.get("format") {
        Some(Value::String(_)) => {}
        Some(_) => return Err(err("format", "expected a string")),
        None => return Err(err("format", "missing (expected \"hystid.recording.v1\")")),
    }
    number(path, root, "sample_rate_hz", "sample_rate_hz", true)?;
    let channels = match root.get("channels") {
        Some(Value::Array(a)) => a,
        Some(_) => return Err(err("channels", "expected an array of channel objects")),
        None => return Err(err("channels", "missing (one entry per WAV channel)")),
    };
    for (i, ch) in channels.iter().enumerate() {
        let f = format!("channels[{i}]");
        let obj = ch
            .as_object()
            .ok_or_else(|| err(&f, "expected a channel object"))?;
        for key in ["name", "quantity", "unit"] {
            match obj.get(key) {
                Some(Value::String(_)) => {}
                Some(_) => return Err(err(&format!("{f}.{key}"), "expected a string")),
                None => return Err(err(&format!("{f}.{key}"), "missing")),
            }
        }
        let q = obj["quantity"].as_str().unwrap_or_default();
        if Quantity::from_name(q).is_none() {
            return Err(err(
                &format!("{f}.quantity"),
                &format!(
                    "`{q}` is not one of force, displacement, velocity, acceleration, voltage"
                ),
            ));
        }
        number(path, obj, "scale", &format!("{f}.scale"), false)?;
    }
    if let Some(exc) = root.get("excitation") {
        let exc = exc
            .as_object()
            .ok_or_else(|| err("excitation", "expected an object"))?;
        if let Some(kind) = exc.get("kind") {
            match kind.as_str() {
                Some("stepped-sine" | "swept-sine" | "random" | "multisine" | "unknown") => {}
                _ => {
                    return Err(err(
                        "excitation.kind",
                        "expected \"stepped-sine\", \"swept-sine\", \"random\", \"multisine\" \
                         or \"unknown\"",
                    ));
                }
            }
        }
        if let Some(steps) = exc.get("steps") {
            let steps = steps
                .as_array()
                .ok_or_else(|| err("excitation.steps", "expected an array of steps"))?;
            for (i, s) in steps.iter().enumerate() {
                let f = format!("excitation.steps[{i}]");
                let s = s
                    .as_object()
                    .ok_or_else(|| err(&f, "expected a step object"))?;
                number(path, s, "frequency_hz", &format!("{f}.frequency_hz"), true)?;
                number(path, s, "level", &format!("{f}.level"), true)?;
                frame_index(path, s, "start", &format!("{f}.start"), true)?;
                frame_index(path, s, "settle", &format!("{f}.settle"), false)?;
                frame_index(path, s, "length", &format!("{f}.length"), true)?;
            }
        }
        if let Some(sweep) = exc.get("sweep") {
            let sweep = sweep
                .as_object()
                .ok_or_else(|| err("excitation.sweep", "expected an object"))?;
            number(
                path,
                sweep,
                "f_start_hz",
                "excitation.sweep.f_start_hz",
                true,
            )?;
            number(path, sweep, "f_end_hz", "excitation.sweep.f_end_hz", true)?;
            if !matches!(sweep.get("rate_hz_per_s"), None | Some(Value::Null)) {
                number(
                    path,
                    sweep,
                    "rate_hz_per_s",
                    "excitation.sweep.rate_hz_per_s",
                    true,
                )?;
            }
        }
    }
    if !matches!(root.get("description"), None | Some(Value::String(_))) {
        return Err(err("description", "expected a string"));
    }
    if !matches!(root.get("metadata"), None | Some(Value::Object(_))) {
        return Err(err("metadata", "expected an object"));
    }
    Ok(())
}

fn number(
    path: &Path,
    obj: &Map<String, Value>,
    key: &str,
    field: &str,
    required: bool,
) -> Result<()> {
    match obj.get(key) {
        Some(Value::Number(_)) => Ok(()),
        Some(_) => Err(Error::format(path, field, "expected a number")),
        None if required => Err(Error::format(path, field, "missing")),
        None => Ok(()),
    }
}

fn frame_index(
    path: &Path,
    obj: &Map<String, Value>,
    key: &str,
    field: &str,
    required: bool,
) -> Result<()> {
    match obj.get(key) {
        Some(v) if v.as_u64().is_some_and(|n| usize::try_from(n).is_ok()) => Ok(()),
        Some(v) => Err(Error::format(
            path,
            field,
            format!("expected a frame count (an integer >= 0), got {v}"),
        )),
        None if required => Err(Error::format(path, field, "missing")),
        None => Ok(()),
    }
}

/// The rules of format v1 on a parsed sidecar. `frames`, when known, bounds
/// the steps.
pub(crate) fn check(path: &Path, meta: &RecordingMeta, frames: Option<u64>) -> Result<()> {
    let err = |field: &str, msg: String| Error::format(path, field, msg);
    if meta.format != FORMAT_V1 {
        return Err(err(
            "format",
            format!("expected exactly \"{FORMAT_V1}\", got \"{}\"", meta.format),
        ));
    }
    let fs = meta.sample_rate_hz;
    if !(fs.is_finite() && fs > 0.0) {
        return Err(err(
            "sample_rate_hz",
            format!("expected a finite rate > 0, got {fs}"),
        ));
    }
    if meta.channels.len() < 2 {
        return Err(err(
            "channels",
            format!(
                "expected 2 or more channels (a reference and a response), got {}",
                meta.channels.len()
            ),
        ));
    }
    let mut names = HashSet::new();
    for (i, ch) in meta.channels.iter().enumerate() {
        check_channel(path, &format!("channels[{i}]"), ch)?;
        if !names.insert(ch.name.as_str()) {
            return Err(err(
                &format!("channels[{i}].name"),
                format!(
                    "`{}` is used by an earlier channel; names must be unique",
                    ch.name
                ),
            ));
        }
    }
    check_steps(path, &meta.excitation.steps, frames)?;
    if let Some(sw) = &meta.excitation.sweep {
        for (name, v) in [("f_start_hz", sw.f_start_hz), ("f_end_hz", sw.f_end_hz)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(err(
                    &format!("excitation.sweep.{name}"),
                    format!("expected a finite frequency > 0, got {v}"),
                ));
            }
        }
        if let Some(r) = sw.rate_hz_per_s.filter(|r| !r.is_finite()) {
            return Err(err(
                "excitation.sweep.rate_hz_per_s",
                format!("expected a finite rate, got {r}"),
            ));
        }
    }
    Ok(())
}

/// The stated steps: finite, positive, each settled within its length, in
/// time order and inside the recording's `frames` (when known).
fn check_steps(path: &Path, steps: &[crate::signals::Step], frames: Option<u64>) -> Result<()> {
    let err = |field: &str, msg: String| Error::format(path, field, msg);
    let mut previous_start = 0;
    for (i, s) in steps.iter().enumerate() {
        let f = format!("excitation.steps[{i}]");
        if !(s.frequency_hz.is_finite() && s.frequency_hz > 0.0) {
            return Err(err(
                &format!("{f}.frequency_hz"),
                format!("expected a finite frequency > 0, got {}", s.frequency_hz),
            ));
        }
        if !s.level.is_finite() {
            return Err(err(
                &format!("{f}.level"),
                format!("expected a finite level, got {}", s.level),
            ));
        }
        if s.length == 0 {
            return Err(err(
                &format!("{f}.length"),
                "expected at least 1 frame".into(),
            ));
        }
        if s.settle > s.length {
            return Err(err(
                &format!("{f}.settle"),
                format!(
                    "{} settle frames exceed the step's length of {}",
                    s.settle, s.length
                ),
            ));
        }
        if s.start < previous_start {
            return Err(err(
                &format!("{f}.start"),
                format!(
                    "steps must be in time order; starts at frame {} before the previous step's {previous_start}",
                    s.start
                ),
            ));
        }
        previous_start = s.start;
        if let Some(frames) = frames {
            let end = (s.start as u64).checked_add(s.length as u64);
            if end.is_none_or(|e| e > frames) {
                return Err(err(
                    &f,
                    format!(
                        "frames {}..{} lie outside the recording's {frames} frames",
                        s.start,
                        s.start as u128 + s.length as u128
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// One channel's rules: a name, a unit matching the quantity, a usable scale.
pub(crate) fn check_channel(path: &Path, field: &str, ch: &Channel) -> Result<()> {
    if ch.name.is_empty() {
        return Err(Error::format(
            path,
            format!("{field}.name"),
            "expected a non-empty name",
        ));
    }
    let want = ch.quantity.si_unit();
    if ch.unit != want {
        return Err(Error::format(
            path,
            format!("{field}.unit"),
            format!(
                "`{}` does not match quantity {}: expected `{want}`",
                ch.unit, ch.quantity
            ),
        ));
    }
    if !(ch.scale.is_finite() && ch.scale != 0.0) {
        return Err(Error::format(
            path,
            format!("{field}.scale"),
            format!("expected a finite, non-zero scale, got {}", ch.scale),
        ));
    }
    Ok(())
}
