//! Integration tests: reliability (README, "Reliability").
//!
//! * The fuzz targets' seed corpus (`fuzz/`): small valid files made by the
//!   tests' own writers, each checked to read back; `HYSTID_FUZZ_SEEDS=DIR`
//!   also writes them to `DIR/<target>/` for `cargo fuzz run`.
//! * The inputs the fuzzing found, minimised, each fed to its reader: a clear
//!   error naming the file and field, never a panic or a huge allocation.
//! * Runs killed with SIGKILL at random moments leave in `--out` only
//!   complete files (or none), and a rerun succeeds; a full disk is a clear
//!   error naming the file with no partial output; two runs on one `--out`
//!   do not mix their files.

use crate::cli::{SMALL_TEST, hystid, simulated, text};
use crate::import::{Storage, Var, mat_bytes};
use crate::record::{
    guid, record_run, run_info, sample_recording, sidecar, virtual_run, wav_bytes,
};
use crate::uff::{Store, bin, dataset58, rec, signal};
use hystid::record::{SampleFormat, read_recording_bytes, read_run_bytes, write_recording};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

// ---------------------------------------------------------------- fixtures

/// One `simulate` and one `identify` of the smallest definition, complete:
/// the input of the kill tests and the source of the `fit.json` seed.
pub(crate) struct Finished {
    _dir: tempfile::TempDir,
    pub(crate) test: PathBuf,
    pub(crate) sim: PathBuf,
    pub(crate) fit: PathBuf,
}

/// The smallest definition that exercises `simulate` and `identify`: two
/// levels (identify needs two), three dwells each.
pub(crate) fn tiny_test() -> String {
    SMALL_TEST.replace("count = 11", "count = 3")
}

pub(crate) fn finished() -> &'static Finished {
    static F: OnceLock<Finished> = OnceLock::new();
    F.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let test = dir.path().join("tiny.toml");
        std::fs::write(&test, tiny_test()).unwrap();
        let sim = dir.path().join("sim");
        simulated(&test, &sim);
        let fit = dir.path().join("fit");
        let o = hystid(&[
            "identify",
            sim.join("recording.wav").to_str().unwrap(),
            "--element",
            "jenkins",
            "--out",
            fit.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(o.status.success(), "{}", text(&o));
        Finished {
            _dir: dir,
            test,
            sim,
            fit,
        }
    })
}

// ---------------------------------------------------------------- seeds

/// The seed files per fuzz target (`fuzz/fuzz_targets/<target>.rs` says how
/// each input is laid out).
fn seeds() -> Vec<(&'static str, String, Vec<u8>)> {
    let mut out = Vec::new();
    let ramp = |n: usize| (0..n).map(|i| (i as f64 * 0.37).sin()).collect::<Vec<_>>();

    // MAT v5: plain and compressed, both byte orders, integer storage, a
    // matrix of two signals.
    let vars = || {
        vec![
            Var::double("force", 1, 48, ramp(48)),
            Var::double("fs", 1, 1, vec![1024.0]),
            Var::double("y", 2, 16, ramp(32)).compressed(),
            Var::double(
                "i",
                16,
                1,
                ramp(16).iter().map(|v| (v * 100.0).round()).collect(),
            )
            .stored(Storage::Int16),
        ]
    };
    out.push(("mat", "le.mat".into(), mat_bytes(&vars(), false)));
    out.push(("mat", "be.mat".into(), mat_bytes(&vars(), true)));

    // Delimited text: the first byte picks the separator (0: detect).
    let csv: String = std::iter::once("# fs = 1024 Hz\ntime,force,x\n".to_string())
        .chain((0..24).map(|i| {
            format!(
                "{},{:.6},{:.6}\n",
                i as f64 / 1024.0,
                (i as f64).sin(),
                (i as f64).cos()
            )
        }))
        .collect();
    out.push((
        "delimited",
        "comma.csv".into(),
        [&[0u8][..], csv.as_bytes()].concat(),
    ));
    let tsv = csv.replace(',', "\t").replace("time\t", "\"time, s\"\t");
    out.push((
        "delimited",
        "tab.tsv".into(),
        [&[4u8][..], tsv.as_bytes()].concat(),
    ));
    let ws = csv
        .replace(',', "  ")
        .replace("# fs = 1024 Hz", "# sample rate: 1 kHz");
    out.push((
        "delimited",
        "blank.txt".into(),
        [&[3u8][..], ws.as_bytes()].concat(),
    ));

    // UFF 58 (ASCII) and 58b (both byte orders and precisions), with another
    // dataset around them.
    let force = rec("force", 4, "N", signal(24, 3.0, 0.0));
    let acc = rec("acc", 12, "m/s^2", signal(24, 0.5, 0.3));
    let mut ascii = dataset58(&force, Store::Ascii, "\n", true);
    ascii.extend(dataset58(&acc, Store::Ascii, "\n", true));
    out.push(("uff", "ascii.uff".into(), ascii));
    let mut binary = dataset58(&force, bin(false, true), "\r\n", false);
    binary.extend(dataset58(&acc, bin(true, false), "\r\n", false));
    out.push(("uff", "binary.uff".into(), binary));

    // Recordings: the sidecar, a NUL, the WAV. One of each encoding the
    // reader accepts, by the tests' own WAV writer and by the library's.
    let two = [
        ("force", "force", "N", 1.0),
        ("x", "displacement", "m", 1e-3),
    ];
    let json = serde_json::to_vec(&sidecar(1000, &two)).unwrap();
    let pcm16: Vec<u8> = (0..64i16).flat_map(|i| (i * 300).to_le_bytes()).collect();
    let pcm24: Vec<u8> = (0..96i32)
        .flat_map(|i| (i * 70000).to_le_bytes()[..3].to_vec())
        .collect();
    let float: Vec<u8> = ramp(64)
        .iter()
        .flat_map(|&v| (v as f32).to_le_bytes())
        .collect();
    for (name, wav) in [
        ("pcm16", wav_bytes(1, 2, 1000, 16, None, false, &pcm16)),
        (
            "pcm24-extensible",
            wav_bytes(0xfffe, 2, 1000, 24, Some(guid(1)), true, &pcm24),
        ),
        ("float", wav_bytes(3, 2, 1000, 32, None, false, &float)),
    ] {
        out.push((
            "recording",
            name.into(),
            [&json[..], &[0], &wav[..]].concat(),
        ));
    }
    let dir = tempfile::tempdir().unwrap();
    let rec = sample_recording(64, 1);
    for (name, format) in [
        ("written-pcm32", SampleFormat::Pcm32),
        ("written-float", SampleFormat::Float32),
    ] {
        let stem = dir.path().join(name);
        write_recording(&stem, &rec, format).unwrap();
        let json = std::fs::read(stem.with_extension("json")).unwrap();
        let wav = std::fs::read(stem.with_extension("wav")).unwrap();
        out.push((
            "recording",
            name.into(),
            [&json[..], &[0], &wav[..]].concat(),
        ));
    }

    // An MCAP run: two dwells, fit iterations, complete; and cut short.
    let path = dir.path().join("run.mcap");
    let run = virtual_run(1000.0, vec![(50.0, 10.0, 40), (60.0, 20.0, 40)], 1);
    record_run(&path, &run_info(1000.0), &run, 2);
    let mcap = std::fs::read(&path).unwrap();
    out.push((
        "mcap_run",
        "cut.mcap".into(),
        mcap[..mcap.len() * 2 / 3].to_vec(),
    ));
    out.push(("mcap_run", "run.mcap".into(), mcap));

    // TOML: definitions and an import spec.
    out.push((
        "test_toml",
        "default.toml".into(),
        hystid::testbench::DEFAULT_TEST.into(),
    ));
    out.push(("test_toml", "small.toml".into(), SMALL_TEST.into()));
    out.push((
        "test_toml",
        "spec.toml".into(),
        b"sample_rate = { time = \"t\" }\ndelimiter = \"tab\"\n[[channels]]\ncolumn = 2\n\
          quantity = \"force\"\nscale = 1e-3\n[excitation]\nkind = \"stepped-sine\"\n"
            .to_vec(),
    ));

    // fit.json, as `identify` writes it.
    out.push((
        "fit_json",
        "fit.json".into(),
        std::fs::read(finished().fit.join("fit.json")).unwrap(),
    ));
    out
}

/// Reads a seed with its target's reader; every seed must be valid.
fn read_seed(target: &str, bytes: &[u8]) -> Result<(), String> {
    let e = |e: hystid::Error| e.to_string();
    match target {
        "mat" => {
            let f = hystid::import::mat::MatFile::from_bytes(Path::new("s.mat"), bytes.to_vec())
                .map_err(e)?;
            for v in f.variables() {
                f.read(&v.name).map_err(e)?;
            }
        }
        "delimited" => {
            let want = [
                hystid::import::Column::Index(1),
                hystid::import::Column::Index(2),
            ];
            hystid::import::delimited::parse_columns(Path::new("s.csv"), &bytes[1..], None, &want)
                .map_err(e)?;
        }
        "uff" => {
            let f = hystid::import::uff::parse(Path::new("s.uff"), bytes).map_err(e)?;
            hystid::import::uff::channels(Path::new("s.uff"), &f).map_err(e)?;
        }
        "recording" => {
            // as the fuzz target splits it: the sidecar, a NUL, the WAV
            let i = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
            let wav = bytes.get(i + 1..).unwrap_or(&[]).to_vec();
            read_recording_bytes(Path::new("s"), &bytes[..i], wav).map_err(e)?;
        }
        "mcap_run" => {
            read_run_bytes(Path::new("s.mcap"), bytes)
                .map_err(e)?
                .to_recording()
                .map_err(e)?;
        }
        "test_toml" => {
            let text = std::str::from_utf8(bytes).unwrap();
            if text.contains("[[channels]]") {
                toml::from_str::<hystid::import::ImportSpec>(text).map_err(|e| e.to_string())?;
            } else {
                hystid::testbench::TestDefinition::from_toml(text, "s.toml").map_err(e)?;
            }
        }
        "fit_json" => {
            hystid::analysis::FitReport::parse(Path::new("fit.json"), bytes).map_err(e)?;
        }
        _ => return Err(format!("no reader for {target}")),
    }
    Ok(())
}

/// Every seed is a valid file of its reader, and small (the fuzzer mutates
/// it thousands of times a second); `HYSTID_FUZZ_SEEDS=DIR` writes them.
#[test]
fn fuzz_seeds_are_valid_small_files() {
    let seeds = seeds();
    let target = std::env::var_os("HYSTID_FUZZ_SEEDS").map(PathBuf::from);
    for (t, name, bytes) in &seeds {
        read_seed(t, bytes).unwrap_or_else(|m| panic!("seed {t}/{name}: {m}"));
        assert!(
            bytes.len() < 128 << 10,
            "seed {t}/{name}: {} bytes",
            bytes.len()
        );
        if let Some(dir) = &target {
            std::fs::create_dir_all(dir.join(t)).unwrap();
            std::fs::write(dir.join(t).join(name), bytes).unwrap();
        }
    }
    for t in [
        "mat",
        "delimited",
        "uff",
        "recording",
        "mcap_run",
        "test_toml",
        "fit_json",
    ] {
        assert!(seeds.iter().any(|s| s.0 == t), "no seed for {t}");
    }
}

// ---------------------------------------------------------------- output checks

/// Why `path`, a file under its final name in an output directory, is not
/// complete and valid (None: it is).
fn incomplete(path: &Path) -> Option<String> {
    let bytes = std::fs::read(path).ok()?;
    let name = path.file_name()?.to_str()?.to_string();
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    let bad = |m: &str| Some(format!("{name}: {m}"));
    match ext {
        "mcap" => match read_run_bytes(path, &bytes) {
            Ok(r) if r.truncated => bad("MCAP without its footer"),
            Ok(_) => None,
            Err(e) => bad(&e.to_string()),
        },
        "json" => serde_json::from_slice::<serde_json::Value>(&bytes)
            .err()
            .and_then(|e| bad(&e.to_string())),
        "wav" => wav_inconsistency(&bytes).and_then(|m| bad(&m)),
        "uff" => hystid::import::uff::parse(path, &bytes)
            .err()
            .and_then(|e| bad(&e.to_string())),
        "png" => {
            let whole =
                bytes.starts_with(b"\x89PNG\r\n\x1a\n") && bytes.ends_with(b"IEND\xaeB`\x82");
            (!whole).then(|| format!("{name}: PNG without its signature or IEND"))
        }
        "svg" => (!String::from_utf8_lossy(&bytes)
            .trim_end()
            .ends_with("</svg>"))
        .then(|| format!("{name}: SVG not closed")),
        "csv" | "md" => (bytes.is_empty() || !bytes.ends_with(b"\n"))
            .then(|| format!("{name}: text not ended by a line end")),
        _ => bad("a file no check knows (add one)"),
    }
}

/// Whether a WAV file's RIFF size and data chunk agree with its length.
fn wav_inconsistency(b: &[u8]) -> Option<String> {
    let u32_at = |i: usize| u32::from_le_bytes(b[i..i + 4].try_into().unwrap()) as usize;
    if b.len() < 12 || &b[..4] != b"RIFF" || &b[8..12] != b"WAVE" {
        return Some("no RIFF/WAVE header".into());
    }
    if u32_at(4) + 8 != b.len() {
        return Some(format!("RIFF size {} for {} bytes", u32_at(4), b.len()));
    }
    let mut at = 12;
    while at + 8 <= b.len() {
        let size = u32_at(at + 4);
        if &b[at..at + 4] == b"data" {
            return (at + 8 + size != b.len())
                .then(|| format!("data chunk of {size} bytes in a {}-byte file", b.len()));
        }
        at += 8 + size + size % 2;
    }
    Some("no data chunk".into())
}

/// The state an output directory may be in after any interruption: every
/// final-named file complete and valid; `*.<pid>.tmp` only of dead
/// processes, and the lock file only unlocked. Returns the problems, and the
/// number of temporaries left.
fn check_out_dir(dir: &Path) -> (Vec<String>, usize) {
    let mut problems = Vec::new();
    let mut temporaries = 0;
    let Ok(entries) = std::fs::read_dir(dir) else {
        return (problems, 0);
    };
    for e in entries {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_str().unwrap().to_string();
        if name == hystid::atomic::LOCK_FILE {
            continue;
        }
        if let Some(pid) = hystid::atomic::temporary_pid(&name) {
            if Path::new("/proc").join(pid.to_string()).exists() {
                problems.push(format!("{name}: a temporary of a live process"));
            }
            temporaries += 1;
            continue;
        }
        problems.extend(incomplete(&p));
    }
    (problems, temporaries)
}

/// Every file name in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .map(|r| {
            r.map(|e| e.unwrap().file_name().into_string().unwrap())
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

// ---------------------------------------------------------------- kills

/// The arguments of each command the kill test interrupts, writing to `out`.
fn command_args(command: &str, out: &Path) -> Vec<String> {
    let f = finished();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let mut a = vec![command.to_string()];
    match command {
        "simulate" | "run" => a.push(s(&f.test)),
        "validate" => {
            a.push(s(&f.fit.join("fit.json")));
            a.push(s(&f.sim.join("recording.wav")));
        }
        _ => {
            a.push(s(&f.sim.join("recording.wav")));
            a.extend(["--element".into(), "jenkins".into()]);
        }
    }
    a.extend(["--out".into(), s(out), "--quiet".into()]);
    a
}

/// Kills `command` with SIGKILL at random moments of its run until 20
/// kills have landed before it finished; after each, `--out` holds only
/// complete files and dead runs' temporaries; a last run then succeeds and
/// leaves neither temporaries nor the lock.
fn kill_at_random_moments(command: &str) {
    use rand::{RngExt, SeedableRng};
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let args = command_args(command, &out);
    let run = || {
        let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_hystid"));
        c.args(&args)
            .env_remove("CI")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped());
        c
    };
    // One whole run gives the span the kill moments are drawn from.
    let t0 = std::time::Instant::now();
    let o = run().output().unwrap();
    assert!(
        o.status.success(),
        "{command}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let span = t0.elapsed().as_secs_f64();
    let complete = names(&out);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(15);
    let (mut landed, mut tries, mut left) = (0, 0, 0);
    while landed < 20 {
        tries += 1;
        assert!(
            tries <= 60,
            "{command}: only {landed} of {tries} kills landed mid-run"
        );
        let mut child = run().spawn().unwrap();
        std::thread::sleep(std::time::Duration::from_secs_f64(
            rng.random_range(0.0..1.1) * span,
        ));
        if child.try_wait().unwrap().is_none() {
            landed += 1;
        }
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        let (problems, temporaries) = check_out_dir(&out);
        assert!(problems.is_empty(), "{command}, kill {tries}: {problems:?}");
        left += temporaries;
    }
    let o = run().output().unwrap();
    assert!(
        o.status.success(),
        "{command} after the kills: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let (problems, temporaries) = check_out_dir(&out);
    assert!(
        problems.is_empty() && temporaries == 0,
        "{command}: {problems:?}, {temporaries} temporaries"
    );
    assert_eq!(names(&out), complete, "{command}: the rerun's files");
    eprintln!(
        "{command}: {landed} SIGKILLs mid-run of {tries} ({span:.2} s a run), {left} stale temporaries seen and removed"
    );
}

#[cfg(unix)]
#[test]
fn killed_simulate_leaves_only_complete_files() {
    kill_at_random_moments("simulate");
}

#[cfg(unix)]
#[test]
fn killed_identify_leaves_only_complete_files() {
    kill_at_random_moments("identify");
}

#[cfg(unix)]
#[test]
fn killed_diagnose_leaves_only_complete_files() {
    kill_at_random_moments("diagnose");
}

#[cfg(unix)]
#[test]
fn killed_validate_leaves_only_complete_files() {
    kill_at_random_moments("validate");
}

/// `run` writes every kind of output of the others (MCAP, WAV, FRFs, fit,
/// diagnosis, figures, report) in one directory.
#[cfg(unix)]
#[test]
fn killed_run_leaves_only_complete_files() {
    kill_at_random_moments("run");
}

// ---------------------------------------------------------------- full disk

/// A tmpfs of `kib` KiB mounted over a fresh directory, unmounted on drop;
/// None (with a message) where mounting is not allowed.
struct SmallDisk {
    dir: tempfile::TempDir,
}

impl SmallDisk {
    fn mount(kib: u64) -> Option<SmallDisk> {
        let dir = tempfile::tempdir().unwrap();
        let ok = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={kib}k"), "tmpfs"])
            .arg(dir.path())
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
        if !ok {
            eprintln!(
                "skipped: cannot mount a {kib} KiB tmpfs here (needs root): the full-disk test did not run"
            );
            return None;
        }
        Some(SmallDisk { dir })
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = std::process::Command::new("umount")
            .arg(self.dir.path())
            .status();
    }
}

/// Each command on a disk too small for its output: exit code 2, a message
/// naming the file it could not write and why, no temporaries, and only
/// complete files. Sizes from the first dwell's signals to the last plot.
#[cfg(unix)]
#[test]
fn a_full_disk_is_a_clear_error_with_no_partial_output() {
    let cases: [(&str, u64); 5] = [
        ("simulate", 64),
        ("simulate", 2048),
        ("simulate", 4608),
        ("identify", 64),
        ("diagnose", 160),
    ];
    let mut failed = 0;
    for (command, kib) in cases {
        let Some(disk) = SmallDisk::mount(kib) else {
            return;
        };
        let out = disk.dir.path().join("out");
        let args = command_args(command, &out);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = hystid(&args);
        let msg = text(&o);
        let (problems, temporaries) = check_out_dir(&out);
        assert!(
            problems.is_empty() && temporaries == 0,
            "{command} on {kib} KiB: {problems:?}, {temporaries} temporaries; {msg}"
        );
        if o.status.success() {
            continue;
        }
        failed += 1;
        assert_eq!(o.status.code(), Some(2), "{command} on {kib} KiB: {msg}");
        assert!(
            msg.contains(out.to_str().unwrap()) && msg.contains("No space left on device"),
            "{command} on {kib} KiB: the message does not name the file and the cause: {msg}"
        );
        assert!(
            !names(&out).contains(&hystid::atomic::LOCK_FILE.to_string()),
            "{command}: lock left"
        );
    }
    assert!(failed >= 4, "only {failed} of the small disks filled up");
}

// ---------------------------------------------------------------- one --out, two runs

/// A directory another run holds is refused at once, with nothing written
/// and a message naming the directory and the holder.
#[test]
fn a_held_output_directory_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let held = hystid::atomic::OutDir::claim(&out).unwrap();
    let before = names(&out);
    for command in ["simulate", "identify"] {
        let args = command_args(command, &out);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = hystid(&args);
        let msg = text(&o);
        assert_eq!(o.status.code(), Some(2), "{command}: {msg}");
        assert!(msg.contains(out.to_str().unwrap()), "{command}: {msg}");
        assert!(
            msg.contains(&std::process::id().to_string()),
            "{command}: {msg}"
        );
        assert_eq!(names(&out), before, "{command} wrote into a held directory");
    }
    drop(held);
    let args = command_args("simulate", &out);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    assert!(hystid(&args).status.success());
}

/// Two `simulate`s of different seeds started together on one `--out`: each
/// either finishes or is refused, and the files left all come from one run.
#[test]
fn two_runs_on_one_out_do_not_mix_their_files() {
    let f = finished();
    let dir = tempfile::tempdir().unwrap();
    let other = dir.path().join("other.toml");
    std::fs::write(&other, tiny_test().replace("seed = 4", "seed = 5")).unwrap();
    // the two runs' files, each written alone
    let mut alone = Vec::new();
    for (k, t) in [&f.test, &other].iter().enumerate() {
        let out = dir.path().join(format!("alone{k}"));
        simulated(t, &out);
        alone.push(out);
    }
    let compared = ["run.mcap", "recording.wav", "frf.csv", "frf.uff"];
    for name in compared {
        assert_ne!(
            std::fs::read(alone[0].join(name)).unwrap(),
            std::fs::read(alone[1].join(name)).unwrap(),
            "{name}: the seeds give the same file, the test could not see a mix"
        );
    }
    let mut refused = 0;
    for round in 0..4 {
        let out = dir.path().join(format!("both{round}"));
        let spawn = |t: &Path| {
            std::process::Command::new(env!("CARGO_BIN_EXE_hystid"))
                .args([
                    "simulate",
                    t.to_str().unwrap(),
                    "--out",
                    out.to_str().unwrap(),
                    "--quiet",
                ])
                .env_remove("CI")
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        };
        let (a, b) = (spawn(&f.test), spawn(&other));
        for o in [a.wait_with_output().unwrap(), b.wait_with_output().unwrap()] {
            if !o.status.success() {
                let msg = String::from_utf8_lossy(&o.stderr);
                assert!(msg.contains("is writing to this output directory"), "{msg}");
                refused += 1;
            }
        }
        let from: Vec<usize> = compared
            .iter()
            .map(|name| {
                let got = std::fs::read(out.join(name)).unwrap();
                (0..2)
                    .find(|&k| std::fs::read(alone[k].join(name)).unwrap() == got)
                    .unwrap_or_else(|| panic!("round {round}: {name} is neither run's"))
            })
            .collect();
        assert!(
            from.iter().all(|&k| k == from[0]),
            "round {round}: files of both runs: {from:?}"
        );
    }
    eprintln!("two runs on one --out: {refused} of 4 rounds refused the second run");
}

// ---------------------------------------------------------------- declared sizes and fuzz findings

/// The error text of reading `bytes` with `read`; panics on success.
fn refused<T>(read: impl FnOnce() -> hystid::Result<T>) -> String {
    match read() {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    }
}

/// A definition's declared sizes are checked before anything is made of
/// them: 2^40 dwell frequencies or periods are an error, not an allocation
/// (found by review; the TOML fuzzing did not reach such a count).
#[test]
fn declared_counts_in_a_definition_are_errors_not_allocations() {
    use hystid::testbench::TestDefinition;
    for (from, to, field) in [
        (
            "count = 11",
            "count = 1099511627776",
            "test.frequencies_hz.count",
        ),
        (
            "seed = 4",
            "seed = 4\nmeasure_periods = 1099511627776",
            "test.measure_periods",
        ),
        (
            "seed = 4",
            "seed = 4\nmax_settle_periods = 1099511627776",
            "test.max_settle_periods",
        ),
    ] {
        let text = SMALL_TEST.replace(from, to);
        let e = refused(|| TestDefinition::from_toml(&text, "huge.toml"));
        assert!(e.contains(field) && e.contains("1099511627776"), "{e}");
    }
}

/// A compressed MAT variable whose header (here 2^20 dimensions, 4 MiB of
/// zeros in 4 KiB) runs past what a header can be: indexing refuses it
/// after at most 1 MiB of inflating, where it once inflated the element
/// whole however large (a zlib bomb).
#[test]
fn mat_header_past_its_limit_is_refused_without_inflating_it_all() {
    let mut v = Var::double("big", 0, 0, vec![]).compressed();
    v.dims = vec![0; 1 << 20];
    let bytes = mat_bytes(&[v], false);
    assert!(bytes.len() < 64 << 10, "{} bytes", bytes.len());
    let e = refused(|| hystid::import::mat::MatFile::from_bytes(Path::new("bomb.mat"), bytes));
    assert!(e.contains("bomb.mat") && e.contains("runs past"), "{e}");
}

/// The largest single allocation made by the calling thread (the fuzz
/// targets' 16x rule, checked in the ordinary tests too).
mod largest {
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::cell::Cell;

    thread_local! {
        static LARGEST: Cell<usize> = const { Cell::new(0) };
    }

    fn note(size: usize) {
        let _ = LARGEST.try_with(|l| l.set(l.get().max(size)));
    }

    pub struct Counting;

    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            note(layout.size());
            unsafe { System.alloc(layout) }
        }
        unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
            note(layout.size());
            unsafe { System.alloc_zeroed(layout) }
        }
        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            unsafe { System.dealloc(ptr, layout) }
        }
        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            note(new_size);
            unsafe { System.realloc(ptr, layout, new_size) }
        }
    }

    /// Runs `f` and returns what it returned with the largest block it
    /// allocated.
    pub fn during<T>(f: impl FnOnce() -> T) -> (T, usize) {
        LARGEST.with(|l| l.set(0));
        let r = f();
        (r, LARGEST.with(|l| l.get()))
    }
}

#[global_allocator]
static ALLOC: largest::Counting = largest::Counting;

/// Every input the fuzzing found (minimised, or rebuilt by hand to the same
/// shape; `tests/fuzz-regressions/<target>/`) gives its reader's clear
/// error, naming the file, with no allocation above 16 times its size (nor
/// 1 MiB, the fuzz targets' floor for fixed buffers).
#[test]
fn fuzz_findings_give_clear_errors() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz-regressions");
    let mut count = 0;
    for target in std::fs::read_dir(&root).unwrap() {
        let target = target.unwrap().path();
        let t = target.file_name().unwrap().to_str().unwrap().to_string();
        for input in std::fs::read_dir(&target).unwrap() {
            let input = input.unwrap().path();
            let name = input.file_name().unwrap().to_str().unwrap().to_string();
            let bytes = std::fs::read(&input).unwrap();
            let (r, big) = largest::during(|| read_seed(&t, &bytes));
            let e = r.err().unwrap_or_else(|| panic!("{t}/{name} was accepted"));
            assert!(e.contains("s."), "{t}/{name}: the error names no file: {e}");
            let limit = (16 * bytes.len()).max(1 << 20);
            assert!(
                big <= limit,
                "{t}/{name}: allocated {big} bytes at once ({} in)",
                bytes.len()
            );
            count += 1;
        }
    }
    assert!(
        count >= 4,
        "only {count} regression inputs found in {}",
        root.display()
    );
}

/// A zstd chunk whose frame declares a 128 MiB window (the `mcap_run`
/// fuzzing's last finding: libzstd allocates the window on the frame header
/// alone, outside Rust's allocator, so `largest::during` cannot see it) is
/// refused by the window bound before anything is allocated for it.
#[test]
fn a_zstd_window_beyond_the_files_share_is_refused() {
    let input = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz-regressions/mcap_run/zstd-window-128MiB");
    let bytes = std::fs::read(&input).unwrap();
    let Err(e) = hystid::record::read_run_bytes(&input, &bytes) else {
        panic!("a 128 MiB window in a 99-byte file was read");
    };
    let e = e.to_string();
    assert!(
        e.contains("zstd-window-128MiB") && e.contains("windows are limited to 512 KiB"),
        "{e}"
    );
}
