//! Command-line arguments: clap derive structs, no logic.

use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

/// Testing and identification of friction joints in vibrating structures.
#[derive(Debug, Parser)]
#[command(name = "hystid", version, about, long_about = None)]
pub struct Cli {
    /// The command.
    #[command(subcommand)]
    pub command: Command,
    /// No progress bars and no summary on the terminal (results are still written).
    #[arg(long, short, global = true)]
    pub quiet: bool,
    /// Worker threads (default: all cores). Results do not depend on it.
    #[arg(long, global = true)]
    pub threads: Option<usize>,
}

/// What to do.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run a virtual stepped-sine test and record it (MCAP, WAV + JSON, FRFs, plots).
    Simulate(SimulateArgs),
    /// Fit a hysteresis element to a recording's nonlinear FRFs.
    Identify(IdentifyArgs),
    /// Simulate, identify and diagnose in one go (the paper end to end).
    Run(RunArgs),
    /// Fit, then trace the residual to a missing effect, add it and refit.
    Diagnose(DiagnoseArgs),
}

/// `hystid simulate`.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// Test definition (TOML); the embedded default (the paper's case) when omitted.
    pub test: Option<PathBuf>,
    /// Output directory (created if missing).
    #[arg(long, short)]
    pub out: PathBuf,
    /// Also compute the harmonic-balance prediction at every dwell and report
    /// its difference from the simulated steady state.
    #[arg(long)]
    pub check_hb: bool,
    /// Sample format of recording.wav.
    #[arg(long, value_enum, default_value_t = WavFormat::Float32)]
    pub wav_format: WavFormat,
}

/// WAV sample formats.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum WavFormat {
    /// IEEE float, 32 bit.
    Float32,
    /// Integer PCM, 16 bit.
    Pcm16,
    /// Integer PCM, 24 bit.
    Pcm24,
    /// Integer PCM, 32 bit.
    Pcm32,
}

/// `hystid identify`.
#[derive(Debug, Args)]
pub struct IdentifyArgs {
    /// The recording: a `run.mcap` from `simulate`, or NAME.wav / NAME.json.
    pub recording: PathBuf,
    /// Output directory.
    #[arg(long, short)]
    pub out: PathBuf,
    /// Response channel name (default: the virtual test's response, else the
    /// first channel that is not the reference).
    #[arg(long)]
    pub response: Option<String>,
    /// Fit settings.
    #[command(flatten)]
    pub fit: IdentifyOptionsArgs,
}

/// Fit settings shared by `identify` and `run`.
#[derive(Debug, Args, Clone)]
pub struct IdentifyOptionsArgs {
    /// Element to fit: masing (kd, Fd, N; paper eq. 10) or jenkins (kd, Fd).
    #[arg(long, default_value = "masing")]
    pub element: String,
    /// Harmonics in the cost, e.g. 1 or 1,3,5.
    #[arg(long, value_delimiter = ',', default_value = "1")]
    pub harmonics: Vec<usize>,
    /// Weight the residuals by the measured standard errors.
    #[arg(long)]
    pub weighted: bool,
    /// Linear parameters refined with the element: none, damping, or all
    /// (default: m, c, k; the largest level's estimate carries the joint's
    /// equivalent damping and stiffness).
    #[arg(long, default_value = "all")]
    pub refine_linear: String,
    /// Also run Levenberg-Marquardt and check it agrees with Nelder-Mead.
    #[arg(long)]
    pub lm: bool,
    /// Parametric bootstrap refits for percentile intervals (0: none).
    #[arg(long, default_value_t = 0)]
    pub bootstrap: usize,
    /// Bootstrap seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Frequency band LO:HI in Hz.
    #[arg(long)]
    pub band: Option<String>,
    /// Where the linear part starts: extremes (the paper: m, c, k from the
    /// largest level, k + kd from the smallest) or lowest (real joints that
    /// never slip fully: the smallest level's mode, k refined).
    #[arg(long, default_value = "extremes")]
    pub linear_start: String,
}

/// `hystid diagnose`.
#[derive(Debug, Args)]
pub struct DiagnoseArgs {
    /// The recording: a `run.mcap` from `simulate`, or NAME.wav / NAME.json.
    pub recording: PathBuf,
    /// Output directory.
    #[arg(long, short)]
    pub out: PathBuf,
    /// Response channel name.
    #[arg(long)]
    pub response: Option<String>,
    /// Candidate effects (default: all): second_mode, cubic_stiffness,
    /// bilinear_stiffness, quadratic_damping, clearance.
    #[arg(long, value_delimiter = ',')]
    pub candidates: Vec<String>,
    /// Fit settings for the baseline.
    #[command(flatten)]
    pub fit: IdentifyOptionsArgs,
}

/// `hystid run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Test definition (TOML); the embedded default when omitted.
    pub test: Option<PathBuf>,
    /// Output directory.
    #[arg(long, short)]
    pub out: PathBuf,
    /// Fit settings.
    #[command(flatten)]
    pub fit: IdentifyOptionsArgs,
    /// Skip the diagnosis stage.
    #[arg(long)]
    pub no_diagnose: bool,
}
