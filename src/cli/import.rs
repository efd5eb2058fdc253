//! `hystid import`: measured data (MAT v5, CSV/TSV, UFF 58, WAV + JSON) into
//! a checked recording, NAME.wav + NAME.json, with its quality report.

use super::args::{ImportArgs, RecordedExcitation, WavFormat};
use super::{EXIT_OK, write_json};
use anyhow::{Context, Result, bail};
use hystid::import::{
    ChannelSpec, ImportSpec, QualityOptions, QualityReport, SampleRateSource, Severity,
    check_quality, import,
};
use hystid::record::{ExcitationKind, Recording, SampleFormat, read_recording, write_recording};
use std::path::{Path, PathBuf};

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

/// The files `import` writes for `--out NAME` (NAME.wav or NAME.json also
/// mean the stem NAME): NAME.wav, NAME.json, NAME.quality.json.
pub fn output_files(out: &Path, input: &Path) -> [PathBuf; 3] {
    // a folder (existing, or written with a trailing separator) as every
    // other command's `--out`: the recording is named after the input file
    let folder = out.is_dir() || out.as_os_str().to_string_lossy().ends_with(['/', '\\']);
    let out = if folder {
        out.join(
            input
                .file_stem()
                .unwrap_or(std::ffi::OsStr::new("recording")),
        )
    } else {
        out.to_path_buf()
    };
    let stem = match out.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("wav") || e.eq_ignore_ascii_case("json") => {
            out.with_extension("")
        }
        _ => out.to_path_buf(),
    };
    let with = |suffix: &str| {
        let mut s = stem.as_os_str().to_owned();
        s.push(suffix);
        PathBuf::from(s)
    };
    [with(".wav"), with(".json"), with(".quality.json")]
}

fn is_recording(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("wav") || e.eq_ignore_ascii_case("json"))
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

/// What to say of a WAV without its JSON sidecar and no channels chosen:
/// the sidecar is missing, and the `-c` form that imports it anyway.
fn missing_sidecar(file: &Path) -> String {
    let shape = hystid::import::wav::shape(file)
        .map(|s| {
            format!(
                " (it holds {} channel(s) at {} Hz)",
                s.channels, s.sample_rate_hz
            )
        })
        .unwrap_or_default();
    format!(
        "{}: no JSON sidecar ({}) says what its channels are{shape}: name each with \
         -c NAME=#K:QUANTITY[*SCALE], K its channel from 1, e.g. `hystid import {} --out DIR/ \
         -c force=#1:force -c acc=#2:acceleration` (the rate is the WAV header's)",
        file.display(),
        file.with_extension("json").display(),
        file.display()
    )
}

/// `hystid import`.
pub fn import_command(args: &ImportArgs, quiet: bool) -> Result<u8> {
    let spec = spec_of(args)?;
    let plain_wav = hystid::import::wav::is_plain_wav(&args.file);
    if plain_wav && spec.channels.is_empty() {
        bail!("{}", missing_sidecar(&args.file));
    }
    let (recording, quality): (Recording, QualityReport) = if is_recording(&args.file) && !plain_wav
    {
        // already hystid's format: validated by reading, then checked
        let mut rec = read_recording(&args.file)?;
        if let Some(e) = args.excitation {
            rec.meta.excitation.kind = excitation_kind(e);
        }
        if let Some(d) = &args.description {
            rec.meta.description = d.clone();
        }
        if !args.channels.is_empty() || args.rate.is_some() {
            bail!(
                "{}: --channel and --rate do not apply to a WAV + JSON recording (its sidecar \
                 says what the channels are)",
                args.file.display()
            );
        }
        let opts: QualityOptions = spec.quality.clone();
        let q = check_quality(&rec, &opts);
        (rec, q)
    } else {
        if spec.channels.is_empty() && !hystid::import::names_its_channels(&args.file) {
            let listing = match args.file.extension().and_then(|e| e.to_str()) {
                Some(e) if e.eq_ignore_ascii_case("mat") => {
                    hystid::import::mat::MatFile::open(&args.file)
                        .map(|m| format!("; {}", m.listing()))
                        .unwrap_or_default()
                }
                _ => String::new(),
            };
            bail!(
                "{}: no channels chosen: give --channel [NAME=]SOURCE[(ROW)]:QUANTITY[*SCALE] for \
                 each (or a --spec file){listing}",
                args.file.display()
            );
        }
        let imported = import(&args.file, &spec)?;
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
    // a recording checked and rewritten into its own folder would overwrite
    // what it is read from (a hystid recording is a .wav and a .json)
    let mut inputs = vec![args.file.clone()];
    if is_recording(&args.file) {
        inputs.extend([
            args.file.with_extension("wav"),
            args.file.with_extension("json"),
        ]);
    }
    let inputs: Vec<PathBuf> = inputs
        .iter()
        .filter_map(|p| p.canonicalize().ok())
        .collect();
    if [&wav, &json]
        .into_iter()
        .any(|p| p.canonicalize().is_ok_and(|c| inputs.contains(&c)))
    {
        bail!(
            "--out {}: would overwrite the input {} (choose another name or folder)",
            args.out.display(),
            args.file.display()
        );
    }
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
    write_recording(&json, &recording, sample_format(args.format))?;
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
