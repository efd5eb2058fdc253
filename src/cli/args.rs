//! Command-line arguments: clap derive structs, no logic.

use clap::{Args, Parser, Subcommand, ValueEnum};
use hystid::analysis::ChannelChoice;
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
    /// Convert measured data (MAT v5, CSV/TSV, WAV + JSON) into a checked recording.
    Import(ImportArgs),
    /// Drive a fitted model with a recording's measured force and compare responses.
    Validate(ValidateArgs),
    /// Fit a structure seen at several sensors and one joint between points
    /// (or at a coordinate of its own) to every sensor's FRFs at once.
    IdentifyPoints(IdentifyPointsArgs),
}

/// `hystid identify-points`.
#[derive(Debug, Args)]
pub struct IdentifyPointsArgs {
    /// The recordings, each holding the force and every response channel
    /// (one level per swept file; a stepped file's levels as recorded).
    #[arg(required = true, num_args = 1..)]
    pub recordings: Vec<PathBuf>,
    /// Output directory.
    #[arg(long, short)]
    pub out: PathBuf,
    /// The response channels, one per sensor, comma-separated.
    #[arg(long, value_delimiter = ',', required = true)]
    pub responses: Vec<String>,
    /// The response at the drive point (default: the first response).
    #[arg(long)]
    pub drive: Option<String>,
    /// Where the joint acts: `A:B` between two responses, `A:ground`, or
    /// `own`, a coordinate no sensor reads (the joint several modes share,
    /// when the sensors beside it do not read the motion across it).
    #[arg(long, default_value = "own")]
    pub joint: String,
    /// The joint's law: jenkins, masing, iwan4, ...
    #[arg(long, default_value = "masing")]
    pub law: String,
    /// Band fitted, LO:HI in Hz (default: every line).
    #[arg(long)]
    pub band: Option<String>,
    /// Modes at the band's peaks.
    #[arg(long, default_value_t = 3)]
    pub modes: usize,
    /// Modes held outside the band, Hz, comma-separated: the rest of the
    /// structure (e.g. `3,9.3,14`).
    #[arg(long, value_delimiter = ',')]
    pub outside_hz: Vec<f64>,
    /// How the recordings are reduced.
    #[command(flatten)]
    pub reduction: ReductionArgs,
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
    /// Write no time histories (run.mcap, recording.wav/.json: about 250 MB
    /// for the default test); the FRFs and results are the same.
    #[arg(long, conflicts_with = "wav_format")]
    pub no_recording: bool,
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
    /// The recordings: a `run.mcap` from `simulate`, or NAME.wav / NAME.json;
    /// several are combined into one FRF set (one level per swept or
    /// multi-dwell file; single-dwell files merged by level).
    #[arg(required = true, num_args = 1..)]
    pub recordings: Vec<PathBuf>,
    /// Output directory.
    #[arg(long, short)]
    pub out: PathBuf,
    /// Response channel name (default: the virtual test's response, else the
    /// first channel that is not the reference).
    #[arg(long)]
    pub response: Option<String>,
    /// Reference channel name, in place of the recording format's rule
    /// (the first force, else the first voltage): e.g. the amplifier's
    /// voltage beside a force gauge, to fit the shaker and the structure
    /// together (a model with a `shaker` effect).
    #[arg(long)]
    pub reference: Option<String>,
    /// How the recordings are reduced.
    #[command(flatten)]
    pub reduction: ReductionArgs,
    /// Fit settings.
    #[command(flatten)]
    pub fit: IdentifyOptionsArgs,
    /// What the model is fitted to: `frf` (the nonlinear FRFs by harmonic
    /// balance) or `time` (that fit, then refined on the recorded time
    /// histories themselves: the model driven by the measured force, its
    /// response matched sample by sample). Recordings of a multisine played
    /// several times (excitation not stated, a repeated reference with at
    /// least 3 excited lines), which no FRF reduction reads, start instead
    /// from their linear FRF at the excited lines, each judged over its
    /// periods after the first.
    #[arg(long, value_enum, default_value_t = DomainArg::Frf)]
    pub domain: DomainArg,
    /// Fit a model given instead of identifying the joint law: written down
    /// (`*.toml`: modes, joint and effects, e.g. a shaker or a hysteretic
    /// mode; `response_sign = -1` for a transfer), a fit.json, or a
    /// diagnosis.json (its final model). Every parameter of it is fitted to
    /// the nonlinear FRFs, or with `--domain time` to the time histories
    /// (for records an FRF fit cannot read: multisines, transients).
    #[arg(long)]
    pub start: Option<PathBuf>,
    /// With `--start` or a multisine's start: parameters held at the
    /// start's values, comma separated (e.g. `beta,nu`).
    #[arg(long, value_delimiter = ',')]
    pub fix: Vec<String>,
    /// With `--start`: the time window T0:T1 in seconds judged in every
    /// recording (e.g. after the transient).
    #[arg(long)]
    pub window: Option<String>,
    /// With `--start` or a multisine's start: fewest samples per period of
    /// the model's highest linearised frequency before the replay is
    /// upsampled.
    #[arg(long, default_value_t = 40.0)]
    pub min_samples_per_period: f64,
    /// With `--domain time`: how the model is replayed (see `Replay`).
    #[arg(long, value_enum, default_value_t = ReplayArg::BandLimited)]
    pub replay: ReplayArg,
    /// With `--domain time`: descend from N starts, the given one and N-1
    /// spread about it (each parameter moved by up to a factor 1.5, or 15 %
    /// on a linear scale, the same on every run), and keep the one with the
    /// lowest misfit (the cost without the bounds' penalty).
    /// A fit over several modes, a joint and a shaker has more than one
    /// basin. Each start costs about as much as the fit.
    #[arg(long, default_value_t = 1)]
    pub starts: usize,
    /// With `--domain time`: most samples the fit judges over all the
    /// recordings (its Jacobian holds a row per sample judged); a fit that
    /// would judge more judges the responses low-passed at a lower rate, never
    /// below 8 samples a period of the model's highest frequency. The errors
    /// reported are over every sample.
    #[arg(long, default_value_t = hystid::fit::time::MAX_JUDGED_SAMPLES)]
    pub max_judged_samples: usize,
    /// With `--domain time`: the recorded response's decimation, put
    /// through by every replay (a `--start` model file's `[acquisition]`
    /// otherwise; fit.json keeps it for `validate`).
    #[command(flatten)]
    pub acquisition: AcquisitionArgs,
    /// With `--domain time` and several recordings: after the fit, refit
    /// each recording alone from the fitted model (the same free
    /// parameters) and say how much closer each comes (fit.json
    /// `time_domain.each_alone`). A model that reaches each level alone but
    /// not all at once lacks what changes between them (its joint law's
    /// dependence on level), not a shape they share. Costs a fit per
    /// recording.
    #[arg(long)]
    pub each_alone: bool,
}

/// How the recorded response was decimated to the recording's rate
/// (`validate`, `identify --domain time`).
#[derive(Args, Debug, Clone)]
pub struct AcquisitionArgs {
    /// How the recorded response was decimated to the recording's rate,
    /// put through by the replay too: the stages' factors, fastest first
    /// (e.g. 20, or 2,2,5), each a Hamming-windowed-sinc FIR as MATLAB's
    /// `decimate(y, r, 'fir')` makes it; in place of a model file's
    /// `[acquisition]`.
    #[arg(long, value_delimiter = ',')]
    pub acquisition: Option<Vec<usize>>,
    /// Taps of each `--acquisition` stage's FIR (odd).
    #[arg(long, default_value_t = hystid::validate::acquisition::DEFAULT_TAPS, requires = "acquisition")]
    pub acquisition_taps: usize,
}

impl AcquisitionArgs {
    /// The chain asked for, as given (`None`: not asked for); the request
    /// it goes into checks it.
    pub fn given(&self) -> Option<hystid::validate::acquisition::Acquisition> {
        self.acquisition
            .as_ref()
            .map(|stages| hystid::validate::acquisition::Acquisition {
                decimated_by: stages.clone(),
                taps: self.acquisition_taps,
            })
    }
}

/// How a model is replayed on a measured reference.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ReplayArg {
    /// The reference as the band-limited signal its samples stand for; the
    /// joint's force as the ramp-invariant filters take it.
    BandLimited,
    /// The joint's force taken as band-limited too (its sinc² loss inside
    /// the loop compensated): closer to the continuous model.
    Continuous,
}

impl From<ReplayArg> for hystid::validate::DriveInput {
    fn from(r: ReplayArg) -> Self {
        match r {
            ReplayArg::BandLimited => hystid::validate::DriveInput::BandLimited,
            ReplayArg::Continuous => hystid::validate::DriveInput::Continuous,
        }
    }
}

/// What `identify` fits to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DomainArg {
    /// The nonlinear FRFs.
    Frf,
    /// The FRFs, then the time histories.
    Time,
}

impl From<DomainArg> for hystid::analysis::request::FitDomain {
    fn from(d: DomainArg) -> Self {
        match d {
            DomainArg::Frf => Self::Frf,
            DomainArg::Time => Self::Time,
        }
    }
}

/// Reduction of recordings into nonlinear FRFs (`identify`, `validate`).
#[derive(Debug, Args, Clone)]
pub struct ReductionArgs {
    /// Excitation: auto (the recording's `excitation.kind`; stepped when
    /// unknown), stepped or swept.
    #[arg(long, value_enum, default_value_t = ExcitationArg::Auto)]
    pub excitation: ExcitationArg,
    /// Highest harmonic reduced (default: 7 for stepped sine, 3 for swept).
    #[arg(long)]
    pub max_harmonic: Option<usize>,
    /// Swept sine: sweep-distortion compensation, the Gaussian window's
    /// standard deviation in seconds; `auto` (4 time constants of the
    /// plain reduction's resonance, at most a sixth of the sweep) or 0 (off).
    #[arg(long, default_value = "auto")]
    pub compensation: String,
    /// Swept sine: hop between analysis windows, periods of the sweep.
    #[arg(long, default_value_t = 1.0)]
    pub hop_periods: f64,
    /// Swept sine: analysis window, whole periods.
    #[arg(long, default_value_t = 4)]
    pub window_periods: usize,
}

/// Excitation kinds on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ExcitationArg {
    /// From the recording.
    Auto,
    /// Stepped (or single) sine dwells.
    Stepped,
    /// A continuous sweep.
    Swept,
}

/// What drove the structure, as `import` records it (`excitation.kind`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RecordedExcitation {
    /// Stepped (or single) sine dwells.
    Stepped,
    /// A continuous sweep.
    Swept,
    /// Broadband random: validated in the time domain and by H1.
    Random,
    /// A period of several sines played repeatedly.
    Multisine,
    /// Not stated.
    Unknown,
}

/// `hystid import`.
#[derive(Debug, Args)]
pub struct ImportArgs {
    /// The file: .mat (MATLAB v5), .csv/.tsv/.txt/.dat (header row after `#`
    /// comments), UFF dataset 58 time records, ASCII or binary (.uff, .unv,
    /// .58: channels, units and rate from the file) or a hystid NAME.wav /
    /// NAME.json (checked and rewritten).
    pub file: PathBuf,
    /// Output: a stem NAME (writes NAME.wav, NAME.json and
    /// NAME.quality.json), or a folder (existing, or ending in `/`), where
    /// the recording is named after the input file.
    #[arg(long, short)]
    pub out: PathBuf,
    /// A channel, `[NAME=]SOURCE[(ROW)]:QUANTITY[*SCALE]`, e.g.
    /// `force=Force:force` or `acc2=Acceleration(2):acceleration`; `#K` is
    /// column K (from 1), in a UFF file dataset K. Repeat for each channel;
    /// replaces the spec's (and a UFF file's own units: value × SCALE).
    #[arg(long = "channel", short = 'c')]
    pub channels: Vec<String>,
    /// Sample rate: auto, comment, a number of Hz, variable:NAME or
    /// time:COLUMN.
    #[arg(long)]
    pub rate: Option<String>,
    /// What drove the structure (kept in the recording): stepped, swept,
    /// random, multisine or unknown (the default when the file does not say).
    #[arg(long, value_enum)]
    pub excitation: Option<RecordedExcitation>,
    /// An import spec (TOML: `[[channels]]`, `sample_rate`, `[quality]`, ...);
    /// flags override its fields.
    #[arg(long)]
    pub spec: Option<PathBuf>,
    /// Free text for the recording.
    #[arg(long)]
    pub description: Option<String>,
    /// Sample format of NAME.wav.
    #[arg(long, value_enum, default_value_t = WavFormat::Float32)]
    pub format: WavFormat,
}

/// `hystid validate`.
#[derive(Debug, Args)]
pub struct ValidateArgs {
    /// The model: a `fit.json` from `identify` or `run`, or a model written
    /// down as a test definition or structure (`*.toml`: `[system]` or
    /// `[[modes]]`, `[joint]`, `[[effects]]`).
    pub fit: PathBuf,
    /// The recordings to validate on (NAME.wav / NAME.json or run.mcap).
    #[arg(required = true, num_args = 1..)]
    pub recordings: Vec<PathBuf>,
    /// Output directory.
    #[arg(long, short)]
    pub out: PathBuf,
    /// Response channel name (default: the fit's response channel, else the
    /// first channel that is not the reference).
    #[arg(long)]
    pub response: Option<String>,
    /// Reference channel name (default: the one the fit was made with when
    /// it was named, else the recording format's rule: the first force,
    /// else the first voltage): e.g. the amplifier's
    /// voltage beside a force gauge, to fit the shaker and the structure
    /// together (a model with a `shaker` effect).
    #[arg(long)]
    pub reference: Option<String>,
    /// Validate the fit's linear model instead: the smallest level's SDOF
    /// (`linear.stick` of fit.json), no element; the baseline the joint
    /// element must beat.
    #[arg(long)]
    pub linear: bool,
    /// Frequency band LO:HI in Hz for the FRF comparison, for a sweep the
    /// time window of the second error figure, and where each error figure
    /// is split by frequency (below, in the band, up to twice its top, and
    /// beyond).
    #[arg(long)]
    pub band: Option<String>,
    /// Time window T0:T1 in seconds for the second error figure.
    #[arg(long)]
    pub window: Option<String>,
    /// Fewest samples per period of the model's highest linearised
    /// frequency before the simulation is upsampled.
    #[arg(long, default_value_t = 20.0)]
    pub min_samples_per_period: f64,
    /// How the model is replayed (see `Replay`).
    #[arg(long, value_enum, default_value_t = ReplayArg::BandLimited)]
    pub replay: ReplayArg,
    /// Each recording is one period of a periodic steady state (a multisine
    /// test set): the model is driven by it repeated until its slowest mode
    /// has settled, and the last period is compared (no FRF comparison).
    #[arg(long)]
    pub periodic: bool,
    /// Skip the FRF comparison (time-domain figures only).
    #[arg(long)]
    pub no_frf: bool,
    /// The recorded response's decimation.
    #[command(flatten)]
    pub acquisition: AcquisitionArgs,
    /// How both signals are reduced for the FRF comparison.
    #[command(flatten)]
    pub reduction: ReductionArgs,
}

/// Fit settings shared by `identify` and `run`.
#[derive(Debug, Args, Clone)]
pub struct IdentifyOptionsArgs {
    /// Joint law to fit: masing (kd, fd, n; paper eq. 10), jenkins (kd, fd),
    /// iwan4 (fs, kt, chi, beta; Segalman's four-parameter Iwan) or
    /// bouc_wen (alpha, gamma, delta, nu; beta held, as only its products
    /// with gamma and delta count).
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
    /// Seed of the bootstrap's resampling (not of the test's noise, which
    /// the test definition sets).
    #[arg(long = "bootstrap-seed", default_value_t = 1)]
    pub seed: u64,
    /// Frequency band LO:HI in Hz.
    #[arg(long)]
    pub band: Option<String>,
    /// Where the linear part starts: extremes (the paper: m, c, k from the
    /// largest level, k + kd from the smallest) or lowest (real joints that
    /// never slip fully: the smallest level's mode, k refined).
    #[arg(long, default_value = "extremes")]
    pub linear_start: String,
    /// Modes of the linear part: 1 (the paper's SDOF) or more, located in
    /// the residual of the SDOF fits of the largest and smallest levels (of
    /// the multisine's excited lines, for a time-domain fit of multisines).
    #[arg(long, default_value_t = 1)]
    pub modes: usize,
    /// The response is not at the driving point (a transfer FRF): a mode's
    /// modal constant may take either sign, so a further mode of negative
    /// modal constant is not rejected or flagged as non-physical. Implied
    /// when the first mode's modal constant is negative.
    #[arg(long)]
    pub transfer: bool,
}

/// `hystid diagnose`.
#[derive(Debug, Args)]
pub struct DiagnoseArgs {
    /// The recordings: `run.mcap` files from `simulate`, or NAME.wav /
    /// NAME.json (several: one or more levels each, combined).
    #[arg(required = true)]
    pub recordings: Vec<PathBuf>,
    /// Output directory.
    #[arg(long, short)]
    pub out: PathBuf,
    /// Response channel name.
    #[arg(long)]
    pub response: Option<String>,
    /// Reference channel name, in place of the recording format's rule
    /// (the first force, else the first voltage): e.g. the amplifier's
    /// voltage beside a force gauge, to fit the shaker and the structure
    /// together (a model with a `shaker` effect).
    #[arg(long)]
    pub reference: Option<String>,
    // the list is the diagnosis's registry's
    #[arg(long, value_delimiter = ',', help = hystid::diagnose::Effect::help_list())]
    pub candidates: Vec<String>,
    /// How recordings are reduced.
    #[command(flatten)]
    pub reduction: ReductionArgs,
    /// Fit settings for the baseline.
    #[command(flatten)]
    pub fit: IdentifyOptionsArgs,
    /// `frf` (the diagnosis on the nonlinear FRFs) or `time` (that, then its
    /// final model refitted on the recorded time histories; multisines,
    /// which no FRF is read from, are diagnosed on the time histories
    /// alone, their residual read at the lines of the period).
    #[arg(long, value_enum, default_value_t = DomainArg::Frf)]
    pub domain: DomainArg,
    /// With `--domain time`: trace every candidate in the refitted model's
    /// time residual (its replay reduced as the recordings were) and put the
    /// N that explain the most of it to the recorded time histories, each
    /// added to the final model and refitted in time; the best that lowers
    /// the misfit by more than a confirmation asks (0.5 %) is added. Each
    /// candidate traced costs an FRF refit, each proposal a refit on the
    /// whole recordings. On multisines: the candidates refitted per round,
    /// those that explain the most of the residual per line first (0: 3).
    #[arg(long, default_value_t = 0)]
    pub time_proposals: usize,
    /// With `--domain time`: how every model is replayed on the recordings
    /// (its refit, its checks and proposals, its time residual), as
    /// `identify --replay` takes it.
    #[arg(long, value_enum, default_value_t = ReplayArg::BandLimited)]
    pub replay: ReplayArg,
    /// With `--domain time`: fewest samples per period of the model's
    /// highest linearised frequency before the replay is upsampled (as
    /// `identify --domain time` takes it).
    #[arg(long, default_value_t = 40.0)]
    pub min_samples_per_period: f64,
    /// With `--domain time`: the first time-domain fit (a multisine's
    /// baseline, or the refit of the FRF diagnosis's model) descends from N
    /// starts, the given one and N-1 spread about it, as `identify --domain
    /// time --starts` does; every later fit starts from a fitted model.
    #[arg(long, default_value_t = 1)]
    pub starts: usize,
    /// With `--domain time`: most samples a time-domain fit judges (as
    /// `identify --domain time --max-judged-samples` takes it).
    #[arg(long, default_value_t = hystid::fit::time::MAX_JUDGED_SAMPLES)]
    pub max_judged_samples: usize,
    /// With `--domain time`: the recorded response's decimation, put
    /// through by every replay of the time-domain refits (as `identify
    /// --domain time --acquisition` takes it).
    #[command(flatten)]
    pub acquisition: AcquisitionArgs,
    /// With `--domain time` and several swept or stepped recordings: the
    /// final refit's recordings each refitted alone from its model, as
    /// `identify --domain time --each-alone` does (diagnosis.json
    /// `time_domain.refit.each_alone`, and a table in diagnosis.md): whether
    /// what the final model still lacks is shared by every level or changes
    /// from one to the next. Costs a fit per recording.
    #[arg(long)]
    pub each_alone: bool,
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
    /// The diagnosis's candidate effects, as `diagnose --candidates` takes
    /// them (e.g. `default,bouc_wen_joint`; default: the default set).
    #[arg(long, value_delimiter = ',')]
    pub candidates: Vec<String>,
    /// Write no time histories (run.mcap, recording.wav/.json: about 250 MB
    /// for the default test); the FRFs, fit, diagnosis and report are the same.
    #[arg(long)]
    pub no_recording: bool,
}

impl IdentifyArgs {
    /// The channels named.
    pub fn channels(&self) -> ChannelChoice<'_> {
        ChannelChoice {
            response: self.response.as_deref(),
            reference: self.reference.as_deref(),
        }
    }
}

impl DiagnoseArgs {
    /// The channels named.
    pub fn channels(&self) -> ChannelChoice<'_> {
        ChannelChoice {
            response: self.response.as_deref(),
            reference: self.reference.as_deref(),
        }
    }
}
