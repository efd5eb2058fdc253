//! The shaker's coil, identified from a stepped recording that holds its
//! voltage `e`, the force `F` it applies (a force gauge between the shaker
//! and the structure) and the drive point's motion.
//!
//! The coil (resistance `R`, inductance `L`, force factor `Bl`) obeys
//! `L i' + R i + Bl v = e` and pushes with `F = Bl i`, so at each dwell's
//! fundamental (see [`crate::model::Shaker`])
//!
//! ```text
//! F (1 + jωτ) = g e − ce v,      g = Bl/R,  ce = Bl²/R,  τ = L/R
//! ```
//!
//! Divided by `F`, with `E = e/F` and `V = v/F`, each dwell gives two real
//! equations linear in `(g, ce, τ)`:
//!
//! ```text
//! g Re E − ce Re V        = 1
//! g Im E − ce Im V − ω τ  = 0
//! ```
//!
//! solved by least squares over the dwells; then `Bl = ce/g`, `R = Bl/g`,
//! `L = τ R`. A voltage alone cannot give these (the structure's scale
//! trades with `g`, see the shaker's model); with the force beside it they
//! are determined, the structure not needed. The motion is taken at the
//! drive point: the velocity channel, else the displacement times `jω`,
//! else the acceleration over `jω`.

use crate::error::{Error, Result};
use crate::harmonics::Quantity;
use crate::signals::FrameSource;
use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The coil found.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CoilFit {
    /// Coil resistance `R`, Ω.
    pub r: f64,
    /// Coil inductance `L`, H.
    pub l: f64,
    /// Force factor `Bl`, N/A.
    pub bl: f64,
    /// The shaker model's terms: back-EMF damping `Bl²/R`, N s/m.
    pub ce: f64,
    /// Electrical time constant `L/R`, s.
    pub te: f64,
    /// Blocked force per volt `Bl/R`, N/V.
    pub gain: f64,
    /// Dwells used.
    pub dwells: usize,
    /// RMS of the equations' residuals (each relative to the force, so a
    /// fraction of it).
    pub residual: f64,
    /// The channels used: voltage, force, motion.
    pub channels: [String; 3],
}

/// The first channel of `quantity`.
fn first(source: &impl FrameSource, quantity: Quantity) -> Option<usize> {
    source
        .meta()
        .channels
        .iter()
        .position(|c| c.quantity == quantity)
}

/// The fundamental of `x` at `omega` (rad per sample) by least squares on a
/// mean, a cosine and a sine.
fn fundamental(x: &[f64], omega: f64) -> Option<Complex64> {
    // the normal equations, summed sample by sample (no matrix per dwell)
    let mut ata = nalgebra::Matrix3::<f64>::zeros();
    let mut atb = nalgebra::Vector3::<f64>::zeros();
    for (n, &xn) in x.iter().enumerate() {
        let (s, c) = (omega * n as f64).sin_cos();
        let row = nalgebra::Vector3::new(1.0, c, s);
        ata += row * row.transpose();
        atb += row * xn;
    }
    let sol = ata.lu().solve(&atb)?;
    // x = C cos + S sin = Re[(C − jS) e^{jωn}]
    Some(Complex64::new(sol[1], -sol[2]))
}

/// The coil of `source`'s shaker, when it holds a voltage, a force, a
/// motion channel and stated steps (else `None`). Reads one dwell at a time.
///
/// Errors: a read fails, or the dwells do not determine the coil (fewer
/// than two usable, or a coil that cannot be: `R`, `Bl` not positive).
pub fn fit_coil(source: &mut impl FrameSource) -> Result<Option<CoilFit>> {
    let meta = source.meta().clone();
    let (Some(e), Some(f)) = (
        first(source, Quantity::Voltage),
        first(source, Quantity::Force),
    ) else {
        return Ok(None);
    };
    let motion = [
        Quantity::Velocity,
        Quantity::Displacement,
        Quantity::Acceleration,
    ]
    .into_iter()
    .find_map(|q| first(source, q).map(|c| (c, q)));
    let Some((m, quantity)) = motion else {
        return Ok(None);
    };
    if meta.excitation.steps.is_empty() {
        return Ok(None);
    }
    let fs = meta.sample_rate_hz;
    let mut rows: Vec<[f64; 4]> = Vec::new();
    let mut buf = vec![Vec::new(); meta.channels.len()];
    for step in &meta.excitation.steps {
        let start = step.start + step.settle;
        let count = step.length.saturating_sub(step.settle);
        let w = 2.0 * PI * step.frequency_hz;
        if count < 16 || w.is_nan() || w <= 0.0 {
            continue;
        }
        let got = source.read_at(start, count, &mut buf)?;
        let omega = w / fs;
        let (Some(ev), Some(fv), Some(mv)) = (
            fundamental(&buf[e][..got], omega),
            fundamental(&buf[f][..got], omega),
            fundamental(&buf[m][..got], omega),
        ) else {
            continue;
        };
        let jw = Complex64::new(0.0, w);
        let v = match quantity {
            Quantity::Displacement => mv * jw,
            Quantity::Acceleration => mv / jw,
            _ => mv,
        };
        if fv.norm() == 0.0 {
            continue;
        }
        let (ee, vv) = (ev / fv, v / fv);
        rows.push([ee.re, -vv.re, 0.0, 1.0]);
        rows.push([ee.im, -vv.im, -w, 0.0]);
    }
    let what = || format!("{}: the shaker's coil", source.source_name());
    if rows.len() < 4 {
        return Err(Error::input(
            what(),
            "fewer than two dwells with a voltage, force and motion to fit it to",
        ));
    }
    let a = DMatrix::from_fn(rows.len(), 3, |i, j| rows[i][j]);
    let b = DVector::from_fn(rows.len(), |i, _| rows[i][3]);
    let x = a
        .clone()
        .svd(true, true)
        .solve(&b, 1e-12)
        .map_err(|m| Error::input(what(), m))?;
    let (gain, ce, te) = (x[0], x[1], x[2]);
    if !(gain > 0.0 && ce > 0.0 && gain.is_finite() && ce.is_finite()) {
        return Err(Error::input(
            what(),
            format!(
                "the dwells give no coil (Bl/R = {gain:.4e} N/V, Bl²/R = {ce:.4e} N s/m): \
                 is the force the shaker's, and the motion the drive point's?"
            ),
        ));
    }
    let residual = ((&a * &x - &b).norm_squared() / (rows.len() / 2) as f64).sqrt();
    let bl = ce / gain;
    let r = bl / gain;
    let name = |c: usize| meta.channels[c].name.clone();
    Ok(Some(CoilFit {
        r,
        l: te * r,
        bl,
        ce,
        te,
        gain,
        dwells: rows.len() / 2,
        residual,
        channels: [name(e), name(f), name(m)],
    }))
}

/// [`fit_coil`] of signals in memory: the voltage, the force the shaker
/// applies and the drive point's motion (`motion_quantity`), sampled
/// together at `sample_rate_hz`, with the dwells in `excitation.steps` (what
/// a binding hands over).
///
/// Errors: a rate that is not positive, a motion quantity that is not one,
/// lengths that differ, a non-finite sample (named), no steps, and those of
/// [`fit_coil`].
pub fn fit_coil_of_signals(
    voltage: Vec<f64>,
    force: Vec<f64>,
    motion: Vec<f64>,
    motion_quantity: Quantity,
    sample_rate_hz: f64,
    excitation: crate::signals::Excitation,
) -> Result<CoilFit> {
    if !(sample_rate_hz.is_finite() && sample_rate_hz > 0.0) {
        return Err(Error::input(
            "sample_rate_hz",
            format!("must be finite and > 0, got {sample_rate_hz}"),
        ));
    }
    if !motion_quantity.is_motion() {
        return Err(Error::input(
            "motion_quantity",
            format!(
                "must be a displacement, a velocity or an acceleration, not a {motion_quantity}"
            ),
        ));
    }
    if voltage.len() != force.len() || voltage.len() != motion.len() {
        return Err(Error::input(
            "signals",
            format!(
                "the voltage, the force and the motion must be sampled together; got {}, {} and \
                 {} samples",
                voltage.len(),
                force.len(),
                motion.len()
            ),
        ));
    }
    for (name, x) in [
        ("voltage", &voltage),
        ("force", &force),
        ("motion", &motion),
    ] {
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(Error::input(
                format!("{name}[{i}]"),
                format!("is {}: samples must be finite", x[i]),
            ));
        }
    }
    if excitation.steps.is_empty() {
        return Err(Error::input(
            "steps",
            "the coil is fitted dwell by dwell: the dwells' steps are needed",
        ));
    }
    let channel = |name: &str, quantity: Quantity| crate::signals::Channel {
        name: name.into(),
        quantity,
        unit: quantity.si_unit().into(),
        scale: 1.0,
    };
    let recording = crate::signals::Recording {
        meta: crate::signals::RecordingMeta {
            format: crate::record::FORMAT_V1.into(),
            sample_rate_hz,
            channels: vec![
                channel("voltage", Quantity::Voltage),
                channel("force", Quantity::Force),
                channel("motion", motion_quantity),
            ],
            excitation,
            description: String::new(),
            metadata: Default::default(),
            extra: Default::default(),
            chosen_reference: None,
        },
        channels: vec![voltage, force, motion],
    };
    let mut source = crate::signals::InMemoryFrames::new(&recording, "signals");
    fit_coil(&mut source)?.ok_or_else(|| {
        Error::input(
            "signals",
            "hold no voltage, force and motion at stated steps to fit a coil to",
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::{Channel, Excitation, ExcitationKind, Recording, RecordingMeta, Step};

    /// Dwells of a coil (R 1.5 ohm, L 0.2 mH, Bl 12 N/A) on a structure of
    /// mobility `Y = jω/(k − mω² + jωc)`, written from the coil's own
    /// equations: `v = Y F`, `e = F (R + jωL)/Bl + Bl v`.
    fn dwells(frequencies: &[f64]) -> Recording {
        let (r, l, bl) = (1.5, 2e-4, 12.0);
        let (m, c, k) = (2.0, 30.0, 4e6);
        let fs = 20_000.0;
        let mut channels = vec![Vec::new(); 3];
        let mut steps = Vec::new();
        for &f in frequencies {
            let w = 2.0 * PI * f;
            let jw = Complex64::new(0.0, w);
            let force = Complex64::new(40.0, 0.0);
            let v = force * jw / (k - m * w * w + jw * c);
            let e = force * (r + jw * l) / bl + bl * v;
            let n = 2000;
            steps.push(Step {
                frequency_hz: f,
                level: e.norm(),
                start: channels[0].len(),
                settle: 0,
                length: n,
            });
            for i in 0..n {
                let rot = Complex64::from_polar(1.0, w * i as f64 / fs);
                for (ch, z) in channels.iter_mut().zip([e, force, v]) {
                    ch.push((z * rot).re);
                }
            }
        }
        let channel = |name: &str, quantity: Quantity| Channel {
            name: name.into(),
            quantity,
            unit: quantity.si_unit().into(),
            scale: 1.0,
        };
        Recording {
            meta: RecordingMeta::new(
                fs,
                vec![
                    channel("drive", Quantity::Voltage),
                    channel("force", Quantity::Force),
                    channel("velocity", Quantity::Velocity),
                ],
                Excitation {
                    kind: ExcitationKind::SteppedSine,
                    steps,
                    sweep: None,
                },
            ),
            channels,
        }
    }

    fn fitted(rec: &Recording) -> Result<Option<CoilFit>> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("coil.json");
        crate::record::write_recording(&path, rec, crate::record::SampleFormat::Float32)?;
        fit_coil(&mut crate::record::RecordingReader::open(&path)?)
    }

    /// From dwells written by the coil's equations the fit gives the coil
    /// back (to the samples' f32 rounding); one dwell cannot give three
    /// unknowns, and a recording without a force is not a coil's.
    #[test]
    fn the_coils_own_dwells_give_it_back() {
        let got = fitted(&dwells(&[150.0, 250.0, 400.0, 700.0]))
            .unwrap()
            .unwrap();
        for (name, value, truth) in [("R", got.r, 1.5), ("L", got.l, 2e-4), ("Bl", got.bl, 12.0)] {
            assert!(
                (value / truth - 1.0).abs() < 1e-5,
                "{name}: {value} vs {truth}"
            );
        }
        assert_eq!(got.dwells, 4);
        assert!(got.residual < 1e-5, "{}", got.residual);
        let one = fitted(&dwells(&[250.0])).unwrap_err().to_string();
        assert!(one.contains("fewer than two dwells"), "{one}");
        let mut no_force = dwells(&[150.0, 250.0]);
        no_force.meta.channels[1] = Channel {
            name: "accel".into(),
            quantity: Quantity::Acceleration,
            unit: "m/s^2".into(),
            scale: 1.0,
        };
        assert_eq!(fitted(&no_force).unwrap(), None);
    }

    /// The same dwells handed over as arrays (no file: no f32 rounding)
    /// give the coil to 1e-9, and the same as the file to its f32 rounding;
    /// arrays without steps are refused naming them.
    #[test]
    fn the_coils_dwells_as_arrays_give_it_back() {
        let rec = dwells(&[150.0, 250.0, 400.0, 700.0]);
        let mut channels = rec.channels.clone().into_iter();
        let mut next = || channels.next().unwrap();
        let (e, f, v) = (next(), next(), next());
        let got = fit_coil_of_signals(
            e.clone(),
            f.clone(),
            v.clone(),
            Quantity::Velocity,
            rec.meta.sample_rate_hz,
            rec.meta.excitation.clone(),
        )
        .unwrap();
        for (name, value, truth) in [("R", got.r, 1.5), ("L", got.l, 2e-4), ("Bl", got.bl, 12.0)] {
            assert!(
                (value / truth - 1.0).abs() < 1e-9,
                "{name}: {value} vs {truth}"
            );
        }
        let file = fitted(&rec).unwrap().unwrap();
        assert!((got.bl / file.bl - 1.0).abs() < 1e-5);
        let no_steps = Excitation {
            kind: ExcitationKind::SteppedSine,
            steps: Vec::new(),
            sweep: None,
        };
        let err = fit_coil_of_signals(e, f, v, Quantity::Velocity, 20_000.0, no_steps)
            .unwrap_err()
            .to_string();
        assert!(err.contains("steps"), "{err}");
    }
}
