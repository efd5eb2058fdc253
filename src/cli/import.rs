//! `hystid import`: measured data (MAT v5, CSV/TSV, UFF 58, WAV + JSON) into
//! a checked recording, NAME.wav + NAME.json, with its quality report.

use super::args::{ImportArgs, RecordedExcitation, WavFormat};
use super::{EXIT_OK, write_json};
use anyhow::{Context, Result, bail};
use hystid::analysis::import::{ImportRequest, is_recording, output_files};
use hystid::import::{
    ChannelSpec, ImportSpec, QualityReport, SampleRateSource, Severity, check_quality, import,
};
use hystid::record::{ExcitationKind, Recording, SampleFormat, read_recording, write_recording};
use std::path::Path;

/// Exit status: the data hold NaN/Inf or a broken time axis; nothing written.
pub const EXIT_BAD_DATA: u8 = 2;

/// The sample format of a `--format` flag.
pub fn sample_format(f: WavFormat) -> SampleFormat {
    match f {
        WavFormat::Float32 => SampleFormat::Float32,
        WavFormat::Pcm16 => SampleFormat::Pcm16,
        WavFormat::Pcm24 => SampleFormat::Pcm24,
        WavFormat::Pcm32 => SampleFormat::Pcm32,
    }
}

fn excitation_kind(e: RecordedExcitation) -> ExcitationKind {
    match e {
        RecordedExcitation::Stepped => ExcitationKind::SteppedSine,
        RecordedExcitation::Swept => ExcitationKind::SweptSine,
        RecordedExcitation::Random => ExcitationKind::Random,
        RecordedExcitation::Multisine => ExcitationKind::Multisine,
        RecordedExcitation::Unknown => ExcitationKind::Unknown,
    }
}

/// The import spec from `--spec` and the flags (flags win).
fn spec_of(args: &ImportArgs) -> Result<ImportSpec> {
    let mut spec = match &args.spec {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("cannot read the import spec {}", p.display()))?;
            toml::from_str::<ImportSpec>(&text)
                .with_context(|| format!("{}: invalid import spec", p.display()))?
        }
        None => ImportSpec::default(),
    };
    if !args.channels.is_empty() {
        spec.channels = args
            .channels
            .iter()
            .map(|c| {
                c.parse::<ChannelSpec>()
                    .map_err(|e| flag_error("-c/--channel", e))
            })
            .collect::<Result<_>>()?;
    }
    if let Some(r) = &args.rate {
        spec.sample_rate = r
            .parse::<SampleRateSource>()
            .map_err(|e| flag_error("--rate", e))?;
    }
    if let Some(e) = args.excitation {
        spec.excitation.get_or_insert_with(Default::default).kind = excitation_kind(e);
    }
    if let Some(d) = &args.description {
        spec.description = d.clone();
    }
    Ok(spec)
}

/// A flag's value refused by its parser, said as the flag's: the parser
/// names a spec field, which on the command line is the flag.
fn flag_error(flag: &str, e: hystid::Error) -> anyhow::Error {
    match e.root() {
        hystid::Error::InvalidPlan { message, .. } => anyhow::anyhow!("{flag} {message}"),
        _ => anyhow::Error::new(e).context(flag.to_string()),
    }
}

/// Relative distance to a whole number of Hz below which a rate derived
/// from a time column (printed with finite digits) is rounded.
const WHOLE_HZ_TOLERANCE: f64 = 1e-6;

/// The recording with its rate rounded to whole Hz when it is that within
/// [`WHOLE_HZ_TOLERANCE`] (returns the rate it had), an error when it is not
/// (a WAV header holds whole Hz).
fn whole_hz(path: &Path, mut rec: Recording) -> Result<(Recording, Option<f64>)> {
    let fs = rec.meta.sample_rate_hz;
    let whole = fs.round();
    if fs == whole {
        return Ok((rec, None));
    }
    if (fs - whole).abs() > WHOLE_HZ_TOLERANCE * fs || whole < 1.0 {
        bail!(
            "{}: the sample rate is {fs} Hz, but a WAV recording holds a whole number of Hz: \
             resample the data first",
            path.display()
        );
    }
    rec.meta.sample_rate_hz = whole;
    Ok((rec, Some(fs)))
}

/// `hystid import`.
pub fn import_command(args: &ImportArgs, quiet: bool) -> Result<u8> {
    // refused before anything is read or written
    let req = ImportRequest {
        file: args.file.clone(),
        out: args.out.clone(),
        spec: spec_of(args)?,
        channels_or_rate_given: !args.channels.is_empty() || args.rate.is_some(),
        format: sample_format(args.format),
    };
    req.validate().map_err(super::refused)?;
    let (recording, quality): (Recording, QualityReport) =
        if is_recording(&args.file) && !hystid::import::wav::is_plain_wav(&args.file) {
            // already hystid's format: validated by reading, then checked
            let mut rec = read_recording(&args.file)?;
            if let Some(e) = args.excitation {
                rec.meta.excitation.kind = excitation_kind(e);
            }
            if let Some(d) = &args.description {
                rec.meta.description = d.clone();
            }
            let q = check_quality(&rec, &req.spec.quality);
            (rec, q)
        } else {
            let imported = import(&args.file, &req.spec)?;
            if !quiet {
                for n in &imported.notes {
                    eprintln!("note: {n}");
                }
            }
            (imported.recording, imported.quality)
        };
    let (recording, rounded) = whole_hz(&args.file, recording)?;
    let mut quality = quality;
    quality.sample_rate_hz = recording.meta.sample_rate_hz;
    let [wav, json, quality_json] = output_files(&args.out, &args.file);
    if quality.has_errors() {
        eprint!("{quality}");
        eprintln!(
            "error: {}: the data hold errors (see above); nothing written",
            args.file.display()
        );
        return Ok(EXIT_BAD_DATA);
    }
    let dir = json
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let _out = super::create_out_dir(dir)?;
    write_recording(&json, &recording, req.format)?;
    write_json(&quality_json, &quality)?;
    if let Some(fs) = rounded {
        eprintln!(
            "note: sample rate {fs} Hz rounded to {} Hz (a WAV header holds whole Hz)",
            recording.meta.sample_rate_hz
        );
    }
    if !quiet {
        say_part!("{quality}");
        let warnings = quality.with_severity(Severity::Warning).count();
        if warnings > 0 {
            say!("{warnings} warning(s): look at them before identifying");
        }
        for f in [&wav, &json, &quality_json] {
            say!("  wrote {}", f.display());
        }
    } else {
        for f in quality.with_severity(Severity::Warning) {
            eprintln!("warning: {}", f.message);
        }
    }
    Ok(EXIT_OK)
}
