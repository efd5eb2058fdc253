//! Shared by the bench files: a per-thread CPU-time measurement, the paper
//! system, and the data-set locator.
#![allow(dead_code)]

use criterion::Throughput;
use criterion::measurement::{Measurement, ValueFormatter};
use hystid::model::{ModalModel, Model};
use std::path::PathBuf;

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

fn thread_cpu_ns() -> u64 {
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
