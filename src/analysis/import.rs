//! `import`'s request: the file, where its recording goes, what to import
//! from it, and the rules that refuse an import that cannot be done as
//! asked, before anything is read.

use crate::error::{Error, Result};
use crate::import::ImportSpec;
use crate::record::SampleFormat;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// How `import` is asked to convert a file (`hystid import`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ImportRequest {
    /// The file imported.
    pub file: PathBuf,
    /// Where the recording goes: a stem NAME, or a folder (see
    /// [`output_files`]).
    pub out: PathBuf,
    /// What to import: a spec file's, with the options given in place of
    /// its fields.
    pub spec: ImportSpec,
    /// Channels or a sample rate were given as options, not from a spec
    /// file (a WAV + JSON recording's sidecar says them).
    pub channels_or_rate_given: bool,
    /// Sample format of NAME.wav.
    pub format: SampleFormat,
}

impl ImportRequest {
    /// Refuses what cannot be done as asked: a plain WAV or a file that
    /// does not name its channels with none chosen, channels or a rate
    /// given for a WAV + JSON recording, an output over the input.
    pub fn validate(&self) -> Result<()> {
        let file = &self.file;
        let plain_wav = crate::import::wav::is_plain_wav(file);
        let no_channels = self.spec.channels.is_empty();
        if plain_wav && no_channels {
            return Err(Error::option("", missing_sidecar(file)));
        }
        if is_recording(file) && !plain_wav {
            if self.channels_or_rate_given {
                return Err(Error::option(
                    "",
                    format!(
                        "{}: --channel and --rate do not apply to a WAV + JSON recording (its \
                         sidecar says what the channels are)",
                        file.display()
                    ),
                ));
            }
        } else if no_channels && !crate::import::names_its_channels(file) {
            return Err(Error::option("", no_channels_chosen(file)));
        }
        self.refuse_overwriting_the_input()
    }

    /// A recording checked and rewritten into its own folder would
    /// overwrite what it is read from (a hystid recording is a .wav and a
    /// .json).
    fn refuse_overwriting_the_input(&self) -> Result<()> {
        let [wav, json, _] = output_files(&self.out, &self.file);
        let mut inputs = vec![self.file.clone()];
        if is_recording(&self.file) {
            inputs.extend([
                self.file.with_extension("wav"),
                self.file.with_extension("json"),
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
            return Err(Error::option(
                "",
                format!(
                    "--out {}: would overwrite the input {} (choose another name or folder)",
                    self.out.display(),
                    self.file.display()
                ),
            ));
        }
        Ok(())
    }
}

/// A hystid recording: NAME.wav or NAME.json.
pub fn is_recording(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("wav") || e.eq_ignore_ascii_case("json"))
}

/// The folder `import` writes its files into for `out` (the current
/// folder for a bare stem).
pub fn output_folder(out: &Path, input: &Path) -> PathBuf {
    let [_, json, _] = output_files(out, input);
    json.parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."))
        .to_path_buf()
}

/// The files `import` writes for `out` (NAME.wav or NAME.json also mean
/// the stem NAME): NAME.wav, NAME.json, NAME.quality.json.
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

/// What to say of a WAV without its JSON sidecar and no channels chosen:
/// the sidecar is missing, and the `-c` form that imports it anyway.
fn missing_sidecar(file: &Path) -> String {
    let shape = crate::import::wav::shape(file)
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

/// What to say of a file that does not name its channels, none chosen: a
/// MAT file's variables are listed.
fn no_channels_chosen(file: &Path) -> String {
    let listing = match file.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case("mat") => crate::import::mat::MatFile::open(file)
            .map(|m| format!("; {}", m.listing()))
            .unwrap_or_default(),
        _ => String::new(),
    };
    format!(
        "{}: no channels chosen: give --channel [NAME=]SOURCE[(ROW)]:QUANTITY[*SCALE] for \
         each (or a --spec file){listing}",
        file.display()
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::ChannelSpec;

    fn request(dir: &Path, file: &str) -> ImportRequest {
        ImportRequest {
            file: dir.join(file),
            out: dir.join("out/"),
            spec: ImportSpec::default(),
            channels_or_rate_given: false,
            format: SampleFormat::Float32,
        }
    }

    fn refused(r: &ImportRequest) -> String {
        r.validate().expect_err("refused").to_string()
    }

    fn with_channel(mut r: ImportRequest) -> ImportRequest {
        r.spec.channels = vec!["force=#1:force".parse::<ChannelSpec>().unwrap()];
        r
    }

    #[test]
    fn a_file_with_its_channels_chosen_passes() {
        let dir = tempfile::tempdir().unwrap();
        with_channel(request(dir.path(), "data.csv"))
            .validate()
            .unwrap();
    }

    #[test]
    fn channels_are_chosen_where_the_file_does_not_name_them() {
        let dir = tempfile::tempdir().unwrap();
        let r = request(dir.path(), "data.csv");
        assert_eq!(
            refused(&r),
            format!(
                "{}: no channels chosen: give --channel [NAME=]SOURCE[(ROW)]:QUANTITY[*SCALE] \
                 for each (or a --spec file)",
                r.file.display()
            )
        );
    }

    #[test]
    fn a_plain_wav_needs_its_channels_named() {
        let dir = tempfile::tempdir().unwrap();
        let r = request(dir.path(), "plain.wav");
        std::fs::write(&r.file, b"not read here").unwrap();
        assert!(
            refused(&r).contains(": no JSON sidecar ("),
            "{}",
            refused(&r)
        );
    }

    #[test]
    fn a_recording_says_its_own_channels() {
        let dir = tempfile::tempdir().unwrap();
        let mut r = request(dir.path(), "rec.json");
        std::fs::write(dir.path().join("rec.wav"), b"").unwrap();
        std::fs::write(&r.file, b"{}").unwrap();
        r.channels_or_rate_given = true;
        assert_eq!(
            refused(&r),
            format!(
                "{}: --channel and --rate do not apply to a WAV + JSON recording (its sidecar \
                 says what the channels are)",
                r.file.display()
            )
        );
    }

    #[test]
    fn the_output_is_not_the_input() {
        let dir = tempfile::tempdir().unwrap();
        let mut r = with_channel(request(dir.path(), "data.csv"));
        std::fs::write(&r.file, b"").unwrap();
        std::fs::write(dir.path().join("data.wav"), b"").unwrap();
        r.out = dir.path().join("data");
        // data.wav exists, but it is not the input: refused only when it is
        r.validate().unwrap();
        let mut r = request(dir.path(), "rec.json");
        std::fs::write(dir.path().join("rec.wav"), b"").unwrap();
        std::fs::write(&r.file, b"{}").unwrap();
        r.out = dir.path().to_path_buf();
        assert_eq!(
            refused(&r),
            format!(
                "--out {}: would overwrite the input {} (choose another name or folder)",
                r.out.display(),
                r.file.display()
            )
        );
    }
}
