//! Shared by the bench files: a per-thread CPU-time measurement, the paper
//! system, and the data-set locator.
#![allow(dead_code)]

use criterion::Throughput;
use criterion::measurement::{Measurement, ValueFormatter};
use hystid::model::{ModalModel, Model};
use hystid::record::{McapRecorder, RunInfo};
use hystid::testbench::{self, BenchSink, LevelOutput, TestDefinition};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The paper system (section 3): m 10 kg, c 200 N s/m, k 1e7 N/m.
pub const M: f64 = 10.0;
/// N s/m.
pub const C: f64 = 200.0;
/// N/m.
pub const K: f64 = 1e7;
/// The paper's Table 3.1 joint: stick stiffness, N/m.
pub const KD: f64 = 2.4e7;
/// Slip force, N.
pub const FD: f64 = 246.048;

/// The paper's SDOF.
pub fn sdof() -> ModalModel {
    ModalModel::sdof(M, C, K).unwrap()
}

/// The paper's SDOF with an eq. (10) Masing joint of curvature `n`.
pub fn masing_model(n: f64) -> Model {
    Model::new(
        sdof(),
        vec![hystid::model::ElementSpec::Masing { kd: KD, fd: FD, n }],
    )
    .unwrap()
}

/// The paper's SDOF with a Bouc-Wen joint at the law's example shape
/// (`α = kd`, softening to 240 N) with the exponent `nu`.
pub fn bouc_wen_model(nu: f64) -> Model {
    Model::new(
        sdof(),
        vec![hystid::model::ElementSpec::BoucWen {
            alpha: KD,
            beta: KD / 240f64.powf(nu),
            gamma: 0.5,
            delta: 0.5,
            nu,
        }],
    )
    .unwrap()
}

/// The paper's SDOF with Segalman's Iwan joint at the paper's stiffness and
/// slip force (`χ = −0.5`, `β = 0.5`).
pub fn iwan4_model() -> Model {
    Model::new(
        sdof(),
        vec![hystid::model::ElementSpec::Iwan4 {
            fs: FD,
            kt: KD,
            chi: -0.5,
            beta: 0.5,
        }],
    )
    .unwrap()
}

/// The shared data sets folder (`$HYSTID_DATASETS`, else
/// `../shared/datasets` beside the crate), or `None` after saying why the
/// bench is skipped.
pub fn dataset(name: &str) -> Option<PathBuf> {
    let dir = std::env::var_os("HYSTID_DATASETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/datasets"))
        .join(name);
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("SKIPPED: data set `{name}` not found at {}", dir.display());
        None
    }
}

/// Whether a benchmark group is selected by the command line's filters
/// (criterion's positional arguments, `|`-separated alternatives): lets a
/// bench skip an expensive setup whose cases would all be filtered out. A
/// rough test, erring on the side of running the setup.
pub fn wanted(group: &str) -> bool {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut filters = Vec::new();
    let mut skip_value = false;
    for a in &args {
        if skip_value {
            skip_value = false;
            continue;
        }
        if a.starts_with("--") {
            // options with a value
            skip_value = !a.contains('=')
                && [
                    "--warm-up-time",
                    "--measurement-time",
                    "--sample-size",
                    "--profile-time",
                    "--save-baseline",
                    "--baseline",
                    "--load-baseline",
                    "--output-format",
                    "--color",
                    "--nresamples",
                    "--noise-threshold",
                    "--confidence-level",
                    "--significance-level",
                    "--plotting-backend",
                    "--format",
                ]
                .contains(&a.as_str());
            continue;
        }
        if !a.starts_with('-') {
            filters.extend(a.split('|').map(str::to_string));
        }
    }
    filters.is_empty()
        || filters.iter().any(|f| {
            let f = f.trim_start_matches('^');
            f.starts_with(group) || group.starts_with(f.split('/').next().unwrap_or(""))
        })
}

/// Keeps the level with the most frames.
struct Longest(Option<LevelOutput>);

impl BenchSink for Longest {
    fn level(&mut self, out: &LevelOutput, _first: u64) -> hystid::Result<()> {
        if self
            .0
            .as_ref()
            .is_none_or(|k| k.force.len() < out.force.len())
        {
            self.0 = Some(out.clone());
        }
        Ok(())
    }
}

/// The longest level of the embedded default test, as recorded, and the
/// sample rate.
pub fn default_level() -> (LevelOutput, f64) {
    let def = TestDefinition::embedded_default();
    let mut keep = Longest(None);
    testbench::run(&def, &mut keep, &hystid::observe::Silent).unwrap();
    (keep.0.unwrap(), def.sample_rate_hz().unwrap())
}

/// A level's dwells as the simulate command hands them to the MCAP
/// recorder: `(first frame, [force, displacement, velocity, acceleration])`,
/// the f32 recording widened to f64.
pub fn dwell_signals(level: &LevelOutput) -> Vec<(u64, [Vec<f64>; 4])> {
    let f64s = |v: &[f32]| v.iter().map(|&x| x as f64).collect::<Vec<f64>>();
    let first = level.dwells[0].start;
    level
        .dwells
        .iter()
        .map(|d| {
            let a = (d.start - first) as usize;
            let r = a..a + d.length;
            (
                d.start - first,
                [
                    f64s(&level.force[r.clone()]),
                    f64s(&level.displacement[r.clone()]),
                    f64s(&level.velocity[r.clone()]),
                    f64s(&level.acceleration[r]),
                ],
            )
        })
        .collect()
}

/// Writes the dwells to a run file at `path`, as the simulate command does.
pub fn write_mcap(path: &Path, fs: f64, dwells: &[(u64, [Vec<f64>; 4])]) {
    let info = RunInfo {
        tool_version: "bench".into(),
        test_definition: testbench::DEFAULT_TEST.into(),
        seed: 1,
        sample_rate_hz: fs,
        channels: testbench::recorded_channels(hystid::harmonics::Quantity::Force),
        metadata: BTreeMap::new(),
    };
    let mut m = McapRecorder::create(path, &info).unwrap();
    for (i, (start, s)) in dwells.iter().enumerate() {
        m.write_signals(i as u32, *start, &s[0], &s[1], &s[2], &s[3])
            .unwrap();
    }
    m.finish().unwrap();
}

/// Peak resident set size of this process so far (`VmHWM`), bytes.
pub fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

#[repr(C)]
struct Timespec {
    sec: i64,
    nsec: i64,
}

unsafe extern "C" {
    fn clock_gettime(clock: i32, out: *mut Timespec) -> i32;
}

/// `CLOCK_THREAD_CPUTIME_ID` (Linux).
const THREAD_CPU: i32 = 3;

pub fn thread_cpu_ns() -> u64 {
    let mut t = Timespec { sec: 0, nsec: 0 };
    // SAFETY: `t` is a valid out-pointer; the clock id is a Linux constant.
    let rc = unsafe { clock_gettime(THREAD_CPU, &mut t) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    t.sec as u64 * 1_000_000_000 + t.nsec as u64
}

/// CPU time of the measuring thread, ns: what one core spends, whatever
/// else runs on the machine (time waiting for the core is not counted).
/// Only for single-threaded work.
pub struct ThreadCpu;

impl Measurement for ThreadCpu {
    type Intermediate = u64;
    type Value = u64;
    fn start(&self) -> u64 {
        thread_cpu_ns()
    }
    fn end(&self, start: u64) -> u64 {
        thread_cpu_ns() - start
    }
    fn add(&self, a: &u64, b: &u64) -> u64 {
        a + b
    }
    fn zero(&self) -> u64 {
        0
    }
    fn to_f64(&self, v: &u64) -> f64 {
        *v as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        &NsFormatter
    }
}

/// Nanoseconds shown like criterion's wall time, throughput per second.
struct NsFormatter;

fn per_second(
    count: f64,
    typical_ns: f64,
    values: &mut [f64],
    units: [&'static str; 4],
    base: f64,
) -> &'static str {
    let rate = count * 1e9 / typical_ns;
    let (div, unit) = if rate < base {
        (1.0, units[0])
    } else if rate < base * base {
        (base, units[1])
    } else if rate < base * base * base {
        (base * base, units[2])
    } else {
        (base * base * base, units[3])
    };
    for v in values {
        *v = count * 1e9 / *v / div;
    }
    unit
}

impl ValueFormatter for NsFormatter {
    fn scale_values(&self, ns: f64, values: &mut [f64]) -> &'static str {
        let (factor, unit) = if ns < 1.0 {
            (1e3, "ps")
        } else if ns < 1e3 {
            (1.0, "ns")
        } else if ns < 1e6 {
            (1e-3, "µs")
        } else if ns < 1e9 {
            (1e-6, "ms")
        } else {
            (1e-9, "s")
        };
        values.iter_mut().for_each(|v| *v *= factor);
        unit
    }

    fn scale_throughputs(&self, ns: f64, t: &Throughput, values: &mut [f64]) -> &'static str {
        match *t {
            Throughput::Bytes(b) | Throughput::BytesDecimal(b) => per_second(
                b as f64,
                ns,
                values,
                ["  B/s", "KB/s", "MB/s", "GB/s"],
                1000.0,
            ),
            Throughput::Bits(b) => per_second(
                b as f64,
                ns,
                values,
                ["b/s", "Kb/s", "Mb/s", "Gb/s"],
                1000.0,
            ),
            Throughput::Elements(e) | Throughput::ElementsAndBytes { elements: e, .. } => {
                per_second(
                    e as f64,
                    ns,
                    values,
                    [" elem/s", "Kelem/s", "Melem/s", "Gelem/s"],
                    1000.0,
                )
            }
        }
    }

    fn scale_for_machines(&self, _values: &mut [f64]) -> &'static str {
        "ns"
    }
}
