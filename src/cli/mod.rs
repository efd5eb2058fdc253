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

use anyhow::Result;
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
        hystid::Error::TimeDomainOnly { option, why } => {
            anyhow::anyhow!("{}: {why}; add --domain time", flag(&option))
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

/// Checks the paths a command is given before it does any work (the rules
/// are the library's, [`hystid::analysis::paths`]): which of its arguments
/// are files read, which a model, and where its outputs go.
pub fn check_paths(command: &args::Command) -> Result<()> {
    use args::Command;
    use hystid::analysis::paths::{self, Reads};
    let (name, inputs, model, out) = match command {
        Command::Simulate(a) => ("simulate", &[][..], None, &a.out),
        Command::Run(a) => ("run", &[][..], None, &a.out),
        Command::Identify(a) => ("identify", &a.recordings[..], a.start.as_deref(), &a.out),
        Command::Diagnose(a) => ("diagnose", &a.recordings[..], None, &a.out),
        Command::Validate(a) => ("validate", &a.recordings[..], Some(a.fit.as_path()), &a.out),
        Command::IdentifyPoints(a) => ("identify-points", &a.recordings[..], None, &a.out),
        Command::Import(a) => {
            paths::refuse_directory(&a.file, "import", Reads::Imports).map_err(refused)?;
            let dir = hystid::analysis::import::output_folder(&a.out, &a.file);
            return paths::check_out_dir(&dir, &a.out).map_err(refused);
        }
    };
    paths::check_inputs(name, inputs, model).map_err(refused)?;
    paths::check_out_dir(out, out).map_err(refused)
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
