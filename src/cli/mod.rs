//! The command-line layer: arguments in, one library call per stage, results
//! and a short summary out. Only the binary sees clap, anyhow and indicatif.

/// `say!` that ignores a closed stdout (`hystid … | head`): the
/// results are in the output files, the terminal summary is a courtesy.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

/// `print!` that ignores a closed stdout, as [`say!`].
macro_rules! say_part {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($arg)*);
    }};
}

pub mod args;
pub mod diagnose;
pub mod identify;
pub mod import;
pub mod points;
pub mod progress;
pub mod run;
pub mod simulate;
pub mod validate;

use anyhow::{Context, Result};
use args::{ExcitationArg, ReductionArgs};
use hystid::analysis::{ReductionOptions, SineTest};
use std::path::Path;

/// Exit status: everything worked.
pub const EXIT_OK: u8 = 0;
/// Exit status: finished, but some points are not trustworthy (unsettled
/// dwells, non-converged solves); the results say which.
pub const EXIT_DEGRADED: u8 = 1;

/// The exit status a fit's status gives: degraded when model points failed
/// at the optimum. An optimiser that stopped at its iteration limit still
/// returns its best point, which the intervals and notes qualify.
pub fn fit_exit_code(status: hystid::fit::FitStatus) -> u8 {
    use hystid::fit::FitStatus;
    match status {
        FitStatus::ModelNotConverged => EXIT_DEGRADED,
        FitStatus::Converged
        | FitStatus::IterationLimit
        | FitStatus::Stopped
        | FitStatus::Abandoned
        | FitStatus::Unknown => EXIT_OK,
    }
}

/// Exit status: stopped by Ctrl-C (128 + SIGINT, as a shell reports it).
pub const EXIT_INTERRUPTED: u8 = 130;

/// Set by the first Ctrl-C. Every stage asks its observer
/// ([`progress::BarObserver`]) whether to stop and returns `Cancelled` at its
/// next check; unwinding that error drops the pending files and the output
/// directory's claim, which remove the temporaries and the lock.
pub static INTERRUPTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Catches Ctrl-C (SIGINT) into [`INTERRUPTED`]; a second one stops the
/// process at once, as it would have without this.
pub fn catch_interrupt() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: the handler only stores an atomic and calls `write` and
    // `signal`, which are async-signal-safe
    unsafe {
        libc::signal(
            libc::SIGINT,
            on_interrupt as extern "C" fn(libc::c_int) as libc::sighandler_t,
        );
    }
}

#[cfg(all(target_os = "linux", target_env = "gnu"))]
extern "C" fn on_interrupt(_: libc::c_int) {
    INTERRUPTED.store(true, std::sync::atomic::Ordering::SeqCst);
    const SAY: &[u8] =
        b"\ninterrupted: stopping and removing the temporaries (Ctrl-C again to stop at once)\n";
    // SAFETY: async-signal-safe calls on a static buffer
    unsafe {
        libc::write(2, SAY.as_ptr().cast(), SAY.len());
        libc::signal(libc::SIGINT, libc::SIG_DFL);
    }
}

/// The flag the command line writes for a request's field.
fn flag(option: &str) -> String {
    match option {
        "band_hz" => "--band".to_string(),
        "window_s" => "--window".to_string(),
        o => format!("--{}", o.replace('_', "-")),
    }
}

/// A request's refusal in the command line's words: the option named by
/// its flag (`each_alone` is `--each-alone`).
pub fn refused(e: hystid::Error) -> anyhow::Error {
    match e {
        hystid::Error::InvalidOption { option, message } if !option.is_empty() => {
            anyhow::anyhow!("{}: {message}", flag(&option))
        }
        e => e.into(),
    }
}

/// Creates the output directory and claims it for this run: locked against
/// other runs while the returned value lives, cleared of dead runs'
/// temporaries (`hystid::atomic::OutDir`). Keep it until the last file is
/// written.
#[must_use = "the directory is locked only while the value lives"]
pub fn create_out_dir(dir: &Path) -> Result<hystid::atomic::OutDir> {
    Ok(hystid::atomic::OutDir::claim(dir)?)
}

/// Checks the paths a command is given before it does any work: no
/// directory where files are read, an output folder that can be one.
pub fn check_paths(command: &args::Command) -> Result<()> {
    use args::Command;
    let (name, inputs, reads, model, out, given) = match command {
        Command::Simulate(a) => (
            "simulate",
            &[][..],
            Reads::Recordings,
            None,
            a.out.clone(),
            &a.out,
        ),
        Command::Run(a) => (
            "run",
            &[][..],
            Reads::Recordings,
            None,
            a.out.clone(),
            &a.out,
        ),
        Command::Identify(a) => (
            "identify",
            &a.recordings[..],
            Reads::Recordings,
            a.start.as_deref(),
            a.out.clone(),
            &a.out,
        ),
        Command::Diagnose(a) => (
            "diagnose",
            &a.recordings[..],
            Reads::Recordings,
            None,
            a.out.clone(),
            &a.out,
        ),
        Command::Validate(a) => (
            "validate",
            &a.recordings[..],
            Reads::Recordings,
            Some(a.fit.as_path()),
            a.out.clone(),
            &a.out,
        ),
        Command::IdentifyPoints(a) => (
            "identify-points",
            &a.recordings[..],
            Reads::Recordings,
            None,
            a.out.clone(),
            &a.out,
        ),
        Command::Import(a) => {
            refuse_directory_input(&a.file, "import", Reads::Imports)?;
            let [_, json, _] = hystid::analysis::import::output_files(&a.out, &a.file);
            let dir = json
                .parent()
                .filter(|d| !d.as_os_str().is_empty())
                .unwrap_or(Path::new("."))
                .to_path_buf();
            ("import", &[][..], Reads::Imports, None, dir, &a.out)
        }
    };
    if let Some(m) = model {
        refuse_directory_input(m, name, Reads::Model)?;
    }
    for p in inputs {
        refuse_directory_input(p, name, reads)?;
        if hystid::import::wav::is_plain_wav(p) {
            anyhow::bail!(
                "{}: a WAV without its JSON sidecar ({}), which says what its channels are: \
                 import it first, e.g. `hystid import {} --out recordings/ -c force=#1:force \
                 -c acc=#2:acceleration`, then give the recording it writes",
                p.display(),
                p.with_extension("json").display(),
                p.display()
            );
        }
    }
    check_out_dir(&out, given)
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
        anyhow::bail!(
            "--out {}: {what}: give a folder (created if missing) for the outputs",
            given.display()
        );
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
fn listing(dir: &Path, keep: impl Fn(&Path) -> bool) -> (Vec<std::path::PathBuf>, String) {
    const SHOWN: usize = 8;
    let mut found: Vec<std::path::PathBuf> = std::fs::read_dir(dir)
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
        || (has_extension(p, &["wav"]) && !hystid::import::wav::is_plain_wav(p))
}

/// Refuses a directory where `command` reads files, saying which files in
/// it would do.
pub fn refuse_directory_input(path: &Path, command: &str, reads: Reads) -> Result<()> {
    if !path.is_dir() {
        return Ok(());
    }
    let d = path.display();
    let imported = |p: &Path| hystid::import::reads(p) && !is_recording_file(p);
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
            let (found, text) = listing(path, hystid::import::reads);
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
    anyhow::bail!("{message}")
}

/// Reads a test definition file, or the embedded default; returns it with
/// its text (recorded with the run).
pub fn read_test(path: Option<&Path>) -> Result<(hystid::testbench::TestDefinition, String)> {
    use hystid::testbench::{DEFAULT_TEST, TestDefinition};
    Ok(match path {
        None => (TestDefinition::embedded_default(), DEFAULT_TEST.to_string()),
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("cannot read the test definition {}", p.display()))?;
            (
                TestDefinition::from_toml(&text, &p.display().to_string())?,
                text,
            )
        }
    })
}

/// Writes a value as pretty JSON, atomically.
pub fn write_json(path: &Path, value: &impl serde::Serialize) -> Result<()> {
    Ok(hystid::analysis::write_json(path, value)?)
}

/// Blocks of 4 MiB and more are mapped on their own and returned to the
/// system when freed; for the commands that replay long recordings (a time
/// fit's residual vectors and Jacobian, a replay's channels). glibc's
/// default threshold rises to 32 MiB after the first such block is freed,
/// and blocks below it freed and allocated again fragment the heap: a time
/// fit of the default test's recording peaks 25-30 MB above what it holds
/// at any moment (identify 274 MB, 249 MB with this; diagnose 308 MB, 278
/// MB). Not for `simulate`, whose batches the default reuses better (95-100
/// MB, 113-137 MB with a fixed threshold).
pub(crate) fn return_large_blocks() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: `mallopt` only sets a threshold (glibc takes its own lock)
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 4 << 20);
    }
}

/// The library's reduction options from the flags.
pub fn reduction_options(r: &ReductionArgs) -> Result<ReductionOptions> {
    let compensation = r.compensation.parse().map_err(refused)?;
    Ok(ReductionOptions {
        excitation: match r.excitation {
            ExcitationArg::Stepped => Some(SineTest::Stepped),
            ExcitationArg::Swept => Some(SineTest::Swept),
            ExcitationArg::Auto => None,
        },
        max_harmonic: r.max_harmonic,
        compensation,
        hop_periods: r.hop_periods,
        window_periods: r.window_periods,
    })
}
