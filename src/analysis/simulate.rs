//! A virtual stepped-sine test run into its files: the MCAP run file, the
//! WAV + JSON recording, the FRFs (`frf.json`, `frf.csv`, `frf.uff`, figure) and, on
//! request, the harmonic-balance cross-check; with the run's summary.

use super::write_json;
use crate::error::{Error, Result};
use crate::extract::NonlinearFrf;
use crate::hb::{self, HbCheck, SteadyDwell};
use crate::observe::Observer;
use crate::record::{
    Excitation, ExcitationKind, FORMAT_V1, McapRecorder, RecordingMeta, RecordingWriter, RunInfo,
    SampleFormat, Step,
};
use crate::testbench::{self, BenchRun, BenchSink, DwellRecord, LevelOutput, TestDefinition};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The `/hystid/dwell` message: flat, with what a reader needs to rebuild
/// the recording's steps.
#[derive(Serialize)]
struct DwellMessage<'a> {
    step: usize,
    level_index: usize,
    level: f64,
    direction: crate::extract::Direction,
    frequency_hz: f64,
    requested_frequency_hz: f64,
    start: u64,
    settle: usize,
    length: usize,
    settle_periods: usize,
    settled: bool,
    force_amplitude: f64,
    h: &'a [num_complex::Complex64],
    std_error: &'a [f64],
    clean_h: &'a [num_complex::Complex64],
    noise_ratio: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    hb_check: Option<&'a HbCheck>,
}

impl<'a> DwellMessage<'a> {
    fn of(d: &'a DwellRecord) -> Self {
        DwellMessage {
            step: d.index,
            level_index: d.level_index,
            level: d.level,
            direction: d.direction,
            frequency_hz: d.design.frequency_hz,
            requested_frequency_hz: d.design.requested_hz,
            start: d.start,
            settle: d.settle,
            length: d.length,
            settle_periods: d.settle_periods,
            settled: d.settled,
            force_amplitude: d.measured.force[1].norm(),
            h: &d.measured.h,
            std_error: &d.measured.std_error,
            clean_h: &d.clean_h,
            noise_ratio: d.noise_ratio,
            hb_check: None,
        }
    }
}

fn tool_version() -> String {
    format!("hystid {}", super::VERSION)
}

/// The sidecar (`recording.json`) of a virtual test of `def` (its TOML
/// `toml_text`) sampled at `fs`, before its steps are known.
pub fn recording_meta(def: &TestDefinition, toml_text: &str, fs: f64) -> RecordingMeta {
    RecordingMeta {
        format: FORMAT_V1.into(),
        sample_rate_hz: fs,
        channels: crate::testbench::test_channels(def).unwrap_or_else(|_| {
            crate::testbench::recorded_channels(crate::harmonics::Quantity::Force)
        }),
        excitation: Excitation {
            kind: ExcitationKind::SteppedSine,
            steps: Vec::new(),
            sweep: None,
        },
        description: "hystid virtual stepped-sine test".into(),
        metadata: serde_json::Map::from_iter([
            ("tool".to_string(), serde_json::json!(tool_version())),
            ("seed".to_string(), serde_json::json!(def.test.seed)),
            ("test_definition".to_string(), serde_json::json!(toml_text)),
            (
                "response".to_string(),
                serde_json::json!(def.test.response.quantity().name()),
            ),
        ]),
        extra: Default::default(),
        chosen_reference: None,
    }
}

/// The recording's step of a dwell.
fn step_of(d: &DwellRecord) -> Step {
    Step {
        frequency_hz: d.design.frequency_hz,
        level: d.level,
        start: d.start as usize,
        settle: d.settle,
        length: d.length,
    }
}

/// The harmonic-balance check of a level's dwells (none without a check).
fn level_checks(
    check: &Option<(crate::model::Model, f64, usize, Vec<HbCheck>)>,
    out: &LevelOutput,
) -> Result<Vec<HbCheck>> {
    match check {
        Some((model, fs, k, _)) => {
            let steady: Vec<SteadyDwell> = (out.dwells.iter())
                .map(|d| SteadyDwell {
                    index: d.index,
                    frequency_hz: d.design.frequency_hz,
                    receptance: &d.clean_receptance,
                })
                .collect();
            let level = out.dwells.first().map_or(0.0, |d| d.level);
            hb::check_hb(model, *fs, level, &steady, *k)
        }
        None => Ok(Vec::new()),
    }
}

/// The check `simulate --check-hb` makes, for `def`.
fn hb_check_of(def: &TestDefinition) -> Result<(crate::model::Model, f64, usize, Vec<HbCheck>)> {
    Ok((
        def.model()?,
        def.sample_rate_hz()? * def.oversample()? as f64,
        def.test.max_harmonic,
        Vec::new(),
    ))
}

/// Streams each level to the MCAP run file and the WAV recording.
pub struct FileSink {
    /// The MCAP recorder.
    pub mcap: McapRecorder,
    /// The WAV recording.
    pub wav: RecordingWriter,
    steps: Vec<Step>,
    dwells_written: usize,
    /// With `--check-hb`: the model, sample rate, K, and the checks so far.
    pub check: Option<(crate::model::Model, f64, usize, Vec<HbCheck>)>,
    /// Called after each level.
    pub on_level: Box<dyn FnMut(&LevelOutput)>,
}

impl FileSink {
    /// Opens both files (under temporary names).
    pub fn create(dir: &Path, def: &TestDefinition, toml_text: &str, fs: f64) -> Result<FileSink> {
        let meta = recording_meta(def, toml_text, fs);
        let info = RunInfo {
            tool_version: tool_version(),
            test_definition: toml_text.to_string(),
            seed: def.test.seed,
            sample_rate_hz: fs,
            channels: meta.channels.clone(),
            metadata: BTreeMap::from([(
                "response".to_string(),
                def.test.response.quantity().name().to_string(),
            )]),
        };
        let mcap = McapRecorder::create(&dir.join("run.mcap"), &info)?;
        let wav = RecordingWriter::create(&dir.join("recording"), meta)?;
        Ok(FileSink {
            mcap,
            wav,
            steps: Vec::new(),
            dwells_written: 0,
            check: None,
            on_level: Box::new(|_| {}),
        })
    }

    /// The MCAP recorder (still open, e.g. for the fit's channel) and the
    /// WAV writer with its steps filled in.
    pub fn into_parts(mut self) -> (McapRecorder, RecordingWriter) {
        self.wav.meta_mut().excitation.steps = std::mem::take(&mut self.steps);
        (self.mcap, self.wav)
    }
}

impl BenchSink for FileSink {
    fn level(&mut self, out: &LevelOutput, first_frame: u64) -> Result<()> {
        let f64s = |v: &[f32]| v.iter().map(|&x| x as f64).collect::<Vec<f64>>();
        let checks = level_checks(&self.check, out)?;
        for (i, d) in out.dwells.iter().enumerate() {
            let a = (d.start - first_frame) as usize;
            let b = a + d.length;
            let step = self.dwells_written as u32;
            let dwell: Vec<Vec<f64>> = out.channels().iter().map(|c| f64s(&c[a..b])).collect();
            let dwell: Vec<&[f64]> = dwell.iter().map(Vec::as_slice).collect();
            self.mcap.write_channels(step, d.start, &dwell)?;
            let mut msg = DwellMessage::of(d);
            msg.step = self.dwells_written;
            msg.hb_check = checks.get(i);
            self.mcap.write_dwell(d.start + d.length as u64, &msg)?;
            self.steps.push(step_of(d));
            self.dwells_written += 1;
        }
        self.wav.write_frames(&out.channels())?;
        if let Some((_, _, _, all)) = &mut self.check {
            all.extend(checks);
        }
        (self.on_level)(out);
        Ok(())
    }
}

/// Writes `frf.json`, `frf.csv`, `frf.uff` (UFF datasets 58, see
/// [`super::frf_uff`]) and the FRF figure.
pub fn write_frf_files(dir: &Path, frf: &NonlinearFrf, title: &str) -> Result<Vec<PathBuf>> {
    let mut files = vec![
        dir.join("frf.json"),
        dir.join("frf.csv"),
        dir.join("frf.uff"),
    ];
    write_json(&files[0], frf)?;
    super::frf_uff::write_frf_uff(&files[2], frf)?;
    let mut csv = String::from(
        "level,direction,frequency_hz,force_amplitude,harmonic,re,im,magnitude,phase_deg,std_error\n",
    );
    for l in &frf.levels {
        for p in &l.points {
            for (k, h) in p.h.iter().enumerate() {
                csv.push_str(&format!(
                    "{},{:?},{},{},{},{:e},{:e},{:e},{},{:e}\n",
                    l.level,
                    l.direction,
                    p.frequency_hz,
                    p.force_amplitude,
                    k,
                    h.re,
                    h.im,
                    h.norm(),
                    h.arg().to_degrees(),
                    p.std_error[k]
                ));
            }
        }
    }
    crate::atomic::write_bytes(&files[1], csv.as_bytes())?;
    let series = crate::plot::frf_series_from(frf, 1, crate::plot::SeriesStyle::Measured)?;
    files.extend(crate::plot::write_frf_plot(
        &dir.join("frf"),
        title,
        &crate::plot::frf_magnitude_label(frf, 1),
        &series,
    )?);
    Ok(files)
}

/// The machine-readable result of `simulate`.
#[derive(Serialize)]
pub struct SimulateSummary {
    /// `simulate`.
    pub command: &'static str,
    /// Tool version.
    pub version: &'static str,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Levels.
    pub levels: usize,
    /// Dwells.
    pub dwells: usize,
    /// Frames recorded.
    pub frames: u64,
    /// Dwells that hit the settling cap (level, frequency).
    pub unsettled: Vec<(f64, f64)>,
    /// Mean settling periods.
    pub mean_settle_periods: f64,
    /// Mean measured noise ratio of the response channel.
    pub mean_noise_ratio: f64,
    /// Wall time, s.
    pub seconds: f64,
    /// With `--check-hb`: the harmonic-balance cross-check.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hb_check: Option<HbCheckSummary>,
    /// Files written.
    pub files: Vec<PathBuf>,
}

impl SimulateSummary {
    /// The summary of `run`, a virtual test of `def` that took `seconds`.
    pub fn of(
        def: &TestDefinition,
        run: &BenchRun,
        seconds: f64,
        hb_check: Option<HbCheckSummary>,
        files: Vec<PathBuf>,
    ) -> SimulateSummary {
        let n = run.dwells.len().max(1) as f64;
        SimulateSummary {
            command: "simulate",
            version: super::VERSION,
            sample_rate_hz: run.sample_rate_hz,
            levels: def.test.levels_n.len(),
            dwells: run.dwells.len(),
            frames: run.frames,
            unsettled: run
                .unsettled()
                .map(|d| (d.level, d.design.frequency_hz))
                .collect(),
            mean_settle_periods: run
                .dwells
                .iter()
                .map(|d| d.settle_periods as f64)
                .sum::<f64>()
                / n,
            mean_noise_ratio: run.dwells.iter().map(|d| d.noise_ratio).sum::<f64>() / n,
            seconds,
            hb_check,
            files,
        }
    }
}

/// The cross-check of the two solvers over all dwells.
#[derive(Serialize)]
pub struct HbCheckSummary {
    /// Dwells compared.
    pub dwells: usize,
    /// Harmonic-balance points that did not converge.
    pub not_converged: usize,
    /// Largest `|H1_sim − H1_hb|/|H1_hb|`.
    pub h1_max: f64,
    /// Median of the same.
    pub h1_median: f64,
    /// Largest higher-harmonic difference relative to `|H1|`, per harmonic.
    pub higher_max: Vec<(usize, f64)>,
}

/// The cross-check summed up over all dwells.
pub fn summarise_checks(checks: &[HbCheck]) -> HbCheckSummary {
    let mut h1: Vec<f64> = checks
        .iter()
        .filter(|c| c.converged)
        .map(|c| c.h1_relative_difference)
        .collect();
    h1.sort_by(f64::total_cmp);
    let mut higher: std::collections::BTreeMap<usize, f64> = Default::default();
    for c in checks.iter().filter(|c| c.converged) {
        for &(k, d) in &c.higher {
            let e = higher.entry(k).or_insert(0.0);
            *e = e.max(d);
        }
    }
    HbCheckSummary {
        dwells: checks.len(),
        not_converged: checks.iter().filter(|c| !c.converged).count(),
        h1_max: h1.last().copied().unwrap_or(f64::NAN),
        h1_median: h1.get(h1.len() / 2).copied().unwrap_or(f64::NAN),
        higher_max: higher.into_iter().collect(),
    }
}

/// How `simulate` is asked to run (`hystid simulate`; the Python package's
/// `virtual_test` gives the definition's text instead of its file).
#[derive(Clone, Debug)]
pub struct SimulateRequest {
    /// The test definition's file; `None`: the embedded default.
    pub test: Option<PathBuf>,
    /// The time histories: written in this sample format, or skipped.
    pub recording: TimeHistories,
    /// Whether harmonic balance is also solved at every dwell and compared.
    pub check_hb: bool,
}

impl SimulateRequest {
    /// The test definition it runs and its text (recorded with the run):
    /// refused, naming the file and the field, when it cannot be read or
    /// does not hold a valid test.
    pub fn validate(&self) -> Result<(TestDefinition, String)> {
        read_test(self.test.as_deref())
    }
}

/// The test definition in `path` with its text, or the embedded default.
pub fn read_test(path: Option<&Path>) -> Result<(TestDefinition, String)> {
    let Some(p) = path else {
        return Ok((
            TestDefinition::embedded_default(),
            testbench::DEFAULT_TEST.to_string(),
        ));
    };
    let text = std::fs::read_to_string(p).map_err(|e| {
        Error::context(
            format!("cannot read the test definition {}", p.display()),
            Error::io(p, e),
        )
    })?;
    let def = TestDefinition::from_toml(&text, &p.display().to_string())?;
    Ok((def, text))
}

/// Whether a virtual test keeps its time histories on disk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeHistories {
    /// `run.mcap` and `recording.wav` + `recording.json` (in the format
    /// given).
    Written(SampleFormat),
    /// No time histories (`--no-recording`): the FRFs and everything
    /// derived from them are the same, byte for byte.
    Skipped,
}

/// The harmonic-balance check alone, where no recording is kept.
struct CheckSink(Option<(crate::model::Model, f64, usize, Vec<HbCheck>)>);

impl BenchSink for CheckSink {
    fn level(&mut self, out: &LevelOutput, _first_frame: u64) -> Result<()> {
        let checks = level_checks(&self.0, out)?;
        if let Some((_, _, _, all)) = &mut self.0 {
            all.extend(checks);
        }
        Ok(())
    }
}

/// Runs the bench into `dir` (created if missing) and writes its files;
/// the time histories as `recording` says, `hb_check.json` with `check_hb`.
///
/// `observer` is told of every dwell. `after_bench` runs with the MCAP
/// recorder still open when there is one (e.g. to add the fit's iterations
/// to the run file).
pub fn simulate_into(
    def: &TestDefinition,
    toml_text: &str,
    dir: &Path,
    recording: TimeHistories,
    check_hb: bool,
    observer: &dyn Observer,
    after_bench: &mut dyn FnMut(&BenchRun, Option<&mut McapRecorder>) -> Result<()>,
) -> Result<(BenchRun, SimulateSummary)> {
    let t0 = std::time::Instant::now();
    let fs = def.sample_rate_hz()?;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let check = if check_hb {
        Some(hb_check_of(def)?)
    } else {
        None
    };
    let mut files = Vec::new();
    let (run, checks, bench_seconds) = match recording {
        TimeHistories::Written(wav_format) => {
            let mut sink = FileSink::create(dir, def, toml_text, fs)?;
            sink.check = check;
            let run = testbench::run(def, &mut sink, observer)?;
            let checks = sink.check.take().map(|c| c.3);
            let (mut mcap, wav) = sink.into_parts();
            wav.finish()?;
            let bench_seconds = t0.elapsed().as_secs_f64();
            after_bench(&run, Some(&mut mcap))?;
            mcap.finish()?;
            files.extend([
                dir.join("run.mcap"),
                dir.join("recording.wav"),
                dir.join("recording.json"),
            ]);
            if wav_format != SampleFormat::Float32 {
                let rec = crate::record::read_recording(&dir.join("recording.wav"))?;
                crate::record::write_recording(&dir.join("recording"), &rec, wav_format)
                    .map_err(|e| Error::context("rewriting the recording as PCM", e))?;
            }
            (run, checks, bench_seconds)
        }
        TimeHistories::Skipped => {
            let mut sink = CheckSink(check);
            let run = testbench::run(def, &mut sink, observer)?;
            let bench_seconds = t0.elapsed().as_secs_f64();
            after_bench(&run, None)?;
            (run, sink.0.map(|c| c.3), bench_seconds)
        }
    };
    files.extend(write_frf_files(
        dir,
        &run.frf,
        "Nonlinear FRFs (virtual stepped-sine test)",
    )?);
    let mut hb_summary = None;
    if let Some(checks) = checks {
        let path = dir.join("hb_check.json");
        write_json(&path, &checks)?;
        files.push(path);
        hb_summary = Some(summarise_checks(&checks));
    }
    let summary = SimulateSummary::of(def, &run, bench_seconds, hb_summary, files);
    Ok((run, summary))
}

/// Keeps a virtual test's recording in memory: its channels as
/// `recording.wav` holds them (32-bit floats) and its steps.
#[derive(Default)]
pub struct MemorySink {
    /// With a harmonic-balance check: the model, sample rate, K, and the
    /// checks so far.
    pub check: Option<(crate::model::Model, f64, usize, Vec<HbCheck>)>,
    /// The steps so far.
    pub steps: Vec<Step>,
    /// The channels of [`crate::testbench::test_channels`], in order.
    pub channels: Vec<Vec<f32>>,
}

impl BenchSink for MemorySink {
    fn level(&mut self, out: &LevelOutput, _first_frame: u64) -> Result<()> {
        let checks = level_checks(&self.check, out)?;
        self.steps.extend(out.dwells.iter().map(step_of));
        let signals = out.channels();
        self.channels.resize_with(signals.len(), Vec::new);
        for (c, v) in self.channels.iter_mut().zip(signals) {
            c.extend_from_slice(v);
        }
        if let Some((_, _, _, all)) = &mut self.check {
            all.extend(checks);
        }
        Ok(())
    }
}

/// A virtual test run in memory: what `simulate` writes, without files.
pub struct VirtualTest {
    /// The bench's run (FRFs: `frf.json`; dwells).
    pub run: BenchRun,
    /// The recording's sidecar (`recording.json`), its steps filled in.
    pub meta: RecordingMeta,
    /// The recording's channels in `meta.channels`' order, as
    /// `recording.wav` holds them.
    pub channels: Vec<Vec<f32>>,
    /// With a harmonic-balance check: every dwell's (`hb_check.json`).
    pub hb_checks: Option<Vec<HbCheck>>,
    /// `summary.json` (no files).
    pub summary: SimulateSummary,
}

/// Runs the bench of `def` (its TOML `toml_text`) in memory, with the
/// harmonic-balance cross-check when `check_hb`; `observer` is told of every
/// dwell. The same run as [`simulate_into`] (the same samples, FRFs and
/// summary), without its files.
pub fn simulate_in_memory(
    def: &TestDefinition,
    toml_text: &str,
    check_hb: bool,
    observer: &dyn Observer,
) -> Result<VirtualTest> {
    let t0 = std::time::Instant::now();
    let fs = def.sample_rate_hz()?;
    let mut sink = MemorySink::default();
    if check_hb {
        sink.check = Some(hb_check_of(def)?);
    }
    let run = testbench::run(def, &mut sink, observer)?;
    let seconds = t0.elapsed().as_secs_f64();
    let hb_checks = sink.check.take().map(|c| c.3);
    let mut meta = recording_meta(def, toml_text, fs);
    meta.excitation.steps = std::mem::take(&mut sink.steps);
    let summary = SimulateSummary::of(
        def,
        &run,
        seconds,
        hb_checks.as_deref().map(summarise_checks),
        Vec::new(),
    );
    Ok(VirtualTest {
        run,
        meta,
        channels: sink.channels,
        hb_checks,
        summary,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The virtual test in memory is `simulate`'s: the same samples as
    /// recording.wav, the same sidecar, FRFs and summary.
    #[test]
    fn the_test_in_memory_is_the_one_on_disk() {
        let text = r#"
[system]
mass = 10.0
damping = 200.0
stiffness = 1.0e7
[joint]
kind = "jenkins"
kd = 2.4e7
fd = 246.048
[test]
frequencies_hz = [150.0, 250.0]
levels_n = [10.0, 1000.0]
seed = 5
"#;
        let def = TestDefinition::from_toml(text, "t.toml").unwrap();
        let dir = tempfile::tempdir().unwrap();
        let (run, summary) = simulate_into(
            &def,
            text,
            dir.path(),
            TimeHistories::Written(SampleFormat::Float32),
            true,
            &crate::observe::Silent,
            &mut |_, _| Ok(()),
        )
        .unwrap();
        let mem = simulate_in_memory(&def, text, true, &crate::observe::Silent).unwrap();
        assert_eq!(mem.run, run);
        let rec = crate::record::read_recording(&dir.path().join("recording.wav")).unwrap();
        assert_eq!(mem.meta, rec.meta);
        assert_eq!(mem.channels.len(), rec.channels.len());
        for (m, r) in mem.channels.iter().zip(&rec.channels) {
            let m: Vec<f64> = m.iter().map(|&x| x as f64).collect();
            assert_eq!(&m, r);
        }
        let json = |v: &SimulateSummary| {
            let mut v = serde_json::to_value(v).unwrap();
            let o = v.as_object_mut().unwrap();
            o.remove("seconds");
            o.remove("files");
            v
        };
        assert_eq!(json(&mem.summary), json(&summary));
        assert!(mem.summary.hb_check.is_some() && mem.summary.files.is_empty());
        let on_disk: Vec<HbCheck> =
            serde_json::from_slice(&std::fs::read(dir.path().join("hb_check.json")).unwrap())
                .unwrap();
        assert_eq!(
            serde_json::to_value(mem.hb_checks.unwrap()).unwrap(),
            serde_json::to_value(on_disk).unwrap()
        );
    }

    /// A request without a file runs the embedded default; a file that
    /// cannot be read, or holds a field out of range, is refused naming the
    /// file (and the field).
    #[test]
    fn a_request_reads_its_definition_or_says_why_not() {
        let request = |test: Option<PathBuf>| SimulateRequest {
            test,
            recording: TimeHistories::Skipped,
            check_hb: false,
        };
        let (def, text) = request(None).validate().unwrap();
        assert_eq!(text, testbench::DEFAULT_TEST);
        assert_eq!(
            def.test.levels_n,
            TestDefinition::embedded_default().test.levels_n
        );
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("absent.toml");
        let e = crate::error::one_line(&request(Some(missing.clone())).validate().unwrap_err());
        assert!(
            e.contains("cannot read the test definition") && e.contains("absent.toml"),
            "{e}"
        );
        let bad = dir.path().join("bad.toml");
        let text = testbench::DEFAULT_TEST.replacen("mass = 10.0", "mass = -1.0", 1);
        assert_ne!(text, testbench::DEFAULT_TEST);
        std::fs::write(&bad, text).unwrap();
        let e = crate::error::one_line(&request(Some(bad)).validate().unwrap_err());
        assert!(e.contains("bad.toml") && e.contains("system.mass"), "{e}");
    }
}
