//! The paths a command is given, checked before it reads or writes
//! anything: a command would otherwise reduce or fit for minutes and fail
//! at its first read or write. Each refusal names the path and what would
//! do instead (the recordings or models in a folder given as a file).

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// Refuses what `command` cannot read among `inputs` (recordings) and
/// `model` (a fitted or written-down model): a folder, or a WAV without the
/// JSON sidecar that says what its channels are.
pub fn check_inputs(command: &str, inputs: &[PathBuf], model: Option<&Path>) -> Result<()> {
    if let Some(m) = model {
        refuse_directory(m, command, Reads::Model)?;
    }
    for p in inputs {
        refuse_directory(p, command, Reads::Recordings)?;
        if crate::import::wav::is_plain_wav(p) {
            return Err(Error::option(
                "",
                format!(
                    "{}: a WAV without its JSON sidecar ({}), which says what its channels are: \
                     import it first, e.g. `hystid import {} --out recordings/ -c force=#1:force \
                     -c acc=#2:acceleration`, then give the recording it writes",
                    p.display(),
                    p.with_extension("json").display(),
                    p.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Refuses an output location that cannot be a folder (an existing file, or
/// a path under one), before any work: a command would otherwise reduce or
/// fit for minutes and fail at its first write.
pub fn check_out_dir(dir: &Path, given: &Path) -> Result<()> {
    // the nearest part of the path that exists must be a folder
    let existing = dir
        .ancestors()
        .filter(|a| !a.as_os_str().is_empty())
        .find(|a| a.symlink_metadata().is_ok());
    if let Some(a) = existing
        && !a.is_dir()
    {
        let what = if a == given {
            "is a file, not a folder".to_string()
        } else {
            format!("{} is a file, not a folder", a.display())
        };
        return Err(Error::option(
            "out",
            format!(
                "{}: {what}: give a folder (created if missing) for the outputs",
                given.display()
            ),
        ));
    }
    Ok(())
}

/// What a command reads from the paths it is given, for the message that
/// refuses a directory among them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reads {
    /// Recordings: NAME.wav with its NAME.json, or a run.mcap.
    Recordings,
    /// A file `import` converts.
    Imports,
    /// A fitted or written-down model (fit.json, diagnosis.json, *.toml).
    Model,
}

/// Names the entries of `dir` that `keep` accepts, at most a few, for a
/// message (`a.wav, b.wav and 3 more`); none: empty.
fn listing(dir: &Path, keep: impl Fn(&Path) -> bool) -> (Vec<PathBuf>, String) {
    const SHOWN: usize = 8;
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|r| {
            r.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file() && keep(p))
                .collect()
        })
        .unwrap_or_default();
    found.sort();
    let mut text: Vec<String> = found
        .iter()
        .take(SHOWN)
        .map(|p| p.display().to_string())
        .collect();
    if found.len() > SHOWN {
        text.push(format!("and {} more", found.len() - SHOWN));
    }
    let text = text.join(", ");
    (found, text)
}

fn has_extension(p: &Path, exts: &[&str]) -> bool {
    p.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| exts.iter().any(|x| e.eq_ignore_ascii_case(x)))
}

/// A recording a command reads as it is: a run.mcap, or NAME.wav beside
/// its NAME.json.
fn is_recording_file(p: &Path) -> bool {
    has_extension(p, &["mcap"])
        || (has_extension(p, &["wav"]) && !crate::import::wav::is_plain_wav(p))
}

/// Refuses a directory where `command` reads files, saying which files in
/// it would do.
pub fn refuse_directory(path: &Path, command: &str, reads: Reads) -> Result<()> {
    if !path.is_dir() {
        return Ok(());
    }
    let d = path.display();
    let imported = |p: &Path| crate::import::reads(p) && !is_recording_file(p);
    let message = match reads {
        Reads::Recordings => {
            let (found, text) = listing(path, is_recording_file);
            if let Some(first) = found.first() {
                format!(
                    "{d}: is a directory: name the recording files to read, e.g. `hystid \
                     {command} {} --out ...`; recordings in it: {text}",
                    first.display()
                )
            } else {
                let (found, text) = listing(path, imported);
                match found.first() {
                    Some(first) => format!(
                        "{d}: is a directory, and holds no recording (NAME.wav with its \
                         NAME.json, or run.mcap): import its files first, one at a time \
                         (e.g. `hystid import {} --out recordings/ -c NAME=SOURCE:QUANTITY`), \
                         then name the recordings; files in it that import reads: {text}",
                        first.display()
                    ),
                    None => format!(
                        "{d}: is a directory, and holds no recording (NAME.wav with its \
                         NAME.json, or run.mcap) and no file that `hystid import` reads"
                    ),
                }
            }
        }
        Reads::Imports => {
            let (found, text) = listing(path, crate::import::reads);
            match found.first() {
                Some(first) => format!(
                    "{d}: is a directory: import one file at a time, e.g. `hystid import {} \
                     --out recordings/ -c NAME=SOURCE:QUANTITY`; files in it that import \
                     reads: {text}",
                    first.display()
                ),
                None => format!(
                    "{d}: is a directory, and holds no file that import reads (.mat, .csv, \
                     .tsv, .txt, .dat, .wav, UFF): name a file"
                ),
            }
        }
        Reads::Model => {
            let (found, text) = listing(path, |p| {
                p.file_name()
                    .is_some_and(|n| n == "fit.json" || n == "diagnosis.json")
                    || has_extension(p, &["toml"])
            });
            match found.first() {
                Some(first) => format!(
                    "{d}: is a directory: name the model file, e.g. {}; models in it: {text}",
                    first.display()
                ),
                None => format!(
                    "{d}: is a directory: name the model file (a fit.json, a \
                     diagnosis.json or a *.toml)"
                ),
            }
        }
    };
    Err(Error::option("", message))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A folder given as a model names the models in it; an output under a
    /// file is refused as the `out` option, whose path it names.
    #[test]
    fn a_folder_read_as_a_file_and_a_file_written_as_a_folder_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("fit.json"), "{}").unwrap();
        let e = check_inputs("validate", &[], Some(dir.path())).unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains("is a directory") && text.contains("fit.json"),
            "{text}"
        );
        let file = dir.path().join("fit.json");
        let under = file.join("out");
        match check_out_dir(&under, &under).unwrap_err() {
            Error::InvalidOption { option, message } => {
                assert_eq!(option, "out");
                assert!(
                    message.contains("fit.json is a file, not a folder"),
                    "{message}"
                );
            }
            e => panic!("{e}"),
        }
        assert!(check_out_dir(&dir.path().join("new"), &dir.path().join("new")).is_ok());
        assert!(check_inputs("identify", &[file], None).is_ok());
    }
}
