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
pub mod progress;
pub mod run;
pub mod simulate;
pub mod validate;

use anyhow::{Context, Result, bail};
use args::{ExcitationArg, ReductionArgs};
use hystid::analysis::{Compensation, Excitation, ReductionOptions};
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

/// Creates the output directory and claims it for this run: locked against
/// other runs while the returned value lives, cleared of dead runs'
/// temporaries (`hystid::atomic::OutDir`). Keep it until the last file is
/// written.
#[must_use = "the directory is locked only while the value lives"]
pub fn create_out_dir(dir: &Path) -> Result<hystid::atomic::OutDir> {
    Ok(hystid::atomic::OutDir::claim(dir)?)
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
/// fit of the default test's recording peaked 25-30 MB above what it held
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
    let compensation = match r.compensation.trim() {
        "auto" => Compensation::Auto,
        text => {
            let s: f64 = text.parse().with_context(|| {
                format!("--compensation: expected auto, 0 or seconds, got `{text}`")
            })?;
            if !(s.is_finite() && s >= 0.0) {
                bail!("--compensation: must be auto or seconds >= 0, got {s}");
            }
            if s > 0.0 {
                Compensation::Seconds(s)
            } else {
                Compensation::Off
            }
        }
    };
    Ok(ReductionOptions {
        excitation: match r.excitation {
            ExcitationArg::Stepped => Some(Excitation::Stepped),
            ExcitationArg::Swept => Some(Excitation::Swept),
            ExcitationArg::Auto | ExcitationArg::Unknown => None,
        },
        max_harmonic: r.max_harmonic,
        compensation,
        hop_periods: r.hop_periods,
        window_periods: r.window_periods,
    })
}
