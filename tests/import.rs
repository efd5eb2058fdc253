//! Integration tests: import (MAT v5, delimited text) and data-quality checks.
//!
//! Round trips write files with independent writers in this file (a tiny
//! MAT v5 writer, `format!` for text) and compare the imported samples bit
//! for bit. Real-data tests read `../shared/datasets` and cross-check the
//! MAT reader against the `matfile` crate and against the data sets' CSV
//! copies.

use crate::common;
use flate2::{Compression, write::ZlibEncoder};
use hystid::harmonics::Quantity;
use hystid::import::mat::MatFile;
use hystid::import::{
    ChannelSpec, Column, Delimiter, FindingKind, ImportSpec, QualityOptions, SampleRateSource,
    Severity, Span, check_quality, import,
};
use hystid::record::{
    Channel, Excitation, ExcitationKind, FORMAT_V1, Recording, RecordingMeta, Step,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::io::Write;
use std::path::{Path, PathBuf};

// ---------------------------------------------------------------------------
// A minimal MAT v5 writer (matfile_format.pdf), independent of the reader.

#[derive(Clone, Copy)]
pub(crate) enum Storage {
    Double,
    Single,
    Int16,
    Uint8,
    Utf16,
}

pub(crate) struct Var {
    pub(crate) name: &'static str,
    pub(crate) class: u8,
    pub(crate) dims: Vec<usize>,
    pub(crate) storage: Storage,
    pub(crate) real: Vec<f64>,
    pub(crate) imag: Option<Vec<f64>>,
    pub(crate) compressed: bool,
}

impl Var {
    pub(crate) fn double(name: &'static str, rows: usize, cols: usize, data: Vec<f64>) -> Var {
        assert_eq!(rows * cols, data.len());
        Var {
            name,
            class: 6,
            dims: vec![rows, cols],
            storage: Storage::Double,
            real: data,
            imag: None,
            compressed: false,
        }
    }
    pub(crate) fn compressed(mut self) -> Var {
        self.compressed = true;
        self
    }
    pub(crate) fn stored(mut self, s: Storage) -> Var {
        self.storage = s;
        self
    }
}

fn put_u32(out: &mut Vec<u8>, v: u32, be: bool) {
    out.extend(if be { v.to_be_bytes() } else { v.to_le_bytes() });
}

/// A data element; the small format when the data fits in 4 bytes.
fn element(ty: u32, data: &[u8], be: bool) -> Vec<u8> {
    let mut out = Vec::new();
    if data.len() <= 4 && ty != 14 {
        put_u32(&mut out, ((data.len() as u32) << 16) | ty, be);
        out.extend(data);
        out.resize(8, 0);
        return out;
    }
    put_u32(&mut out, ty, be);
    put_u32(&mut out, data.len() as u32, be);
    out.extend(data);
    while out.len() % 8 != 0 {
        out.push(0);
    }
    out
}

fn encode(values: &[f64], s: Storage, be: bool) -> (u32, Vec<u8>) {
    let mut out = Vec::new();
    macro_rules! put {
        ($t:ty) => {
            for &v in values {
                let x = v as $t;
                out.extend(if be { x.to_be_bytes() } else { x.to_le_bytes() });
            }
        };
    }
    let ty = match s {
        Storage::Double => {
            put!(f64);
            9
        }
        Storage::Single => {
            put!(f32);
            7
        }
        Storage::Int16 => {
            put!(i16);
            3
        }
        Storage::Uint8 => {
            put!(u8);
            2
        }
        Storage::Utf16 => {
            put!(u16);
            17
        }
    };
    (ty, out)
}

fn matrix(v: &Var, be: bool) -> Vec<u8> {
    let mut content = Vec::new();
    let mut flags = Vec::new();
    let complex = if v.imag.is_some() { 0x0800 } else { 0 };
    put_u32(&mut flags, v.class as u32 | complex, be);
    put_u32(&mut flags, 0, be);
    content.extend(element(6, &flags, be));
    let mut dims = Vec::new();
    for &d in &v.dims {
        put_u32(&mut dims, d as u32, be);
    }
    content.extend(element(5, &dims, be));
    content.extend(element(1, v.name.as_bytes(), be));
    let (ty, data) = encode(&v.real, v.storage, be);
    content.extend(element(ty, &data, be));
    if let Some(im) = &v.imag {
        let (ty, data) = encode(im, v.storage, be);
        content.extend(element(ty, &data, be));
    }
    element(14, &content, be)
}

pub(crate) fn mat_bytes(vars: &[Var], be: bool) -> Vec<u8> {
    let mut out = Vec::new();
    let mut text = b"MATLAB 5.0 MAT-file, written by the hystid import tests".to_vec();
    text.resize(116, b' ');
    out.extend(text);
    out.extend([0u8; 8]);
    if be {
        out.extend(0x0100u16.to_be_bytes());
        out.extend(b"MI");
    } else {
        out.extend(0x0100u16.to_le_bytes());
        out.extend(b"IM");
    }
    for v in vars {
        let m = matrix(v, be);
        if v.compressed {
            let mut z = ZlibEncoder::new(Vec::new(), Compression::default());
            z.write_all(&m).unwrap();
            let zipped = z.finish().unwrap();
            put_u32(&mut out, 15, be);
            put_u32(&mut out, zipped.len() as u32, be);
            out.extend(zipped);
        } else {
            out.extend(m);
        }
    }
    out
}

fn write(path: &Path, bytes: &[u8]) {
    std::fs::write(path, bytes).unwrap();
}

fn noise(seed: u64, n: usize, sigma: f64) -> Vec<f64> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let d = Normal::new(0.0, sigma).unwrap();
    (0..n).map(|_| d.sample(&mut rng)).collect()
}

fn err_text<T: std::fmt::Debug>(r: hystid::Result<T>) -> String {
    match r {
        Ok(v) => panic!("expected an error, got {v:?}"),
        Err(e) => e.to_string(),
    }
}

fn assert_mentions(msg: &str, parts: &[&str]) {
    for p in parts {
        assert!(msg.contains(p), "message `{msg}` should mention `{p}`");
    }
}

/// An F-16-like file: Force 1xN and Acceleration 3xN compressed, Voltage
/// uncompressed, Fs scalar (a 2-byte name in the small element format).
struct F16Like {
    force: Vec<f64>,
    voltage: Vec<f64>,
    acc: Vec<Vec<f64>>,
}

fn f16_like(n: usize) -> F16Like {
    F16Like {
        force: noise(1, n, 3.0),
        voltage: noise(2, n, 0.1),
        acc: (0..3).map(|r| noise(10 + r, n, 0.5)).collect(),
    }
}

fn f16_vars(d: &F16Like) -> Vec<Var> {
    let n = d.force.len();
    // Column-major 3xN: element (i, j) at i + 3 j.
    let mut acc = vec![0.0; 3 * n];
    for j in 0..n {
        for i in 0..3 {
            acc[i + 3 * j] = d.acc[i][j];
        }
    }
    vec![
        Var::double("Voltage", 1, n, d.voltage.clone()),
        Var::double("Force", 1, n, d.force.clone()).compressed(),
        Var::double("Acceleration", 3, n, acc).compressed(),
        Var::double("Fs", 1, 1, vec![400.0]),
    ]
}

fn f16_spec() -> ImportSpec {
    ImportSpec::new(
        vec![
            ChannelSpec::new("Force", Quantity::Force).name("force"),
            ChannelSpec::new("Acceleration", Quantity::Acceleration)
                .row(2)
                .name("acc2"),
        ],
        SampleRateSource::Variable("Fs".into()),
    )
}

fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

// ---------------------------------------------------------------------------
// MAT round trips

#[test]
fn mat_round_trip_compressed_and_plain_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let d = f16_like(5000);
    for be in [false, true] {
        let path = dir.path().join(if be { "big.mat" } else { "little.mat" });
        write(&path, &mat_bytes(&f16_vars(&d), be));
        let mut spec = f16_spec();
        spec.channels.push(
            ChannelSpec::new("Voltage", Quantity::Voltage)
                .name("drive")
                .scale(2.5),
        );
        spec.channels
            .push(ChannelSpec::new("Acceleration", Quantity::Acceleration).row(3));
        let imp = import(&path, &spec).unwrap();
        let rec = &imp.recording;
        assert_eq!(rec.meta.sample_rate_hz, 400.0);
        assert_eq!(rec.meta.format, FORMAT_V1);
        assert!(same_bits(&rec.channels[0], &d.force), "Force (compressed)");
        assert!(same_bits(&rec.channels[1], &d.acc[1]), "Acceleration row 2");
        let scaled: Vec<f64> = d.voltage.iter().map(|v| v * 2.5).collect();
        assert!(same_bits(&rec.channels[2], &scaled), "Voltage x 2.5");
        assert!(same_bits(&rec.channels[3], &d.acc[2]), "Acceleration row 3");
        let names: Vec<&str> = rec.meta.channels.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, ["force", "acc2", "drive", "Acceleration_3"]);
        assert_eq!(rec.meta.channels[1].unit, "m/s^2");
        assert_eq!(rec.meta.channels[2].scale, 2.5);
        assert_eq!(rec.reference_channel(), Some(0));
        // White noise: nothing to report.
        assert!(imp.quality.worst().is_none(), "{}", imp.quality);
    }
}

#[test]
fn mat_storage_types_and_column_signals() {
    let dir = tempfile::tempdir().unwrap();
    let n = 300;
    let small: Vec<f64> = (0..n).map(|k| (k % 200) as f64).collect();
    let signed: Vec<f64> = (0..n).map(|k| k as f64 - 150.0).collect();
    let single: Vec<f64> = noise(3, n, 1.0).iter().map(|&v| v as f32 as f64).collect();
    // An Nx2 matrix: the signals are its columns.
    let cols: Vec<f64> = (0..2 * n).map(|k| k as f64 * 0.5).collect();
    let vars = vec![
        Var::double("u8", n, 1, small.clone()).stored(Storage::Uint8),
        Var::double("i16", 1, n, signed.clone())
            .stored(Storage::Int16)
            .compressed(),
        Var {
            class: 7,
            ..Var::double("f32", 1, n, single.clone()).stored(Storage::Single)
        },
        Var::double("twocols", n, 2, cols.clone()),
    ];
    let path = dir.path().join("types.mat");
    write(&path, &mat_bytes(&vars, false));
    let spec = ImportSpec::new(
        vec![
            ChannelSpec::new("u8", Quantity::Voltage),
            ChannelSpec::new("i16", Quantity::Voltage),
            ChannelSpec::new("f32", Quantity::Voltage),
            ChannelSpec::new("twocols", Quantity::Force).row(2),
        ],
        SampleRateSource::Value(1000.0),
    );
    let rec = import(&path, &spec).unwrap().recording;
    assert!(same_bits(&rec.channels[0], &small));
    assert!(same_bits(&rec.channels[1], &signed));
    assert!(same_bits(&rec.channels[2], &single));
    assert!(same_bits(&rec.channels[3], &cols[n..]));
    let file = MatFile::open(&path).unwrap();
    let list: Vec<String> = file.variables().iter().map(|v| v.describe()).collect();
    assert_eq!(
        list,
        [
            "u8 (300x1 double)",
            "i16 (1x300 double)",
            "f32 (1x300 single)",
            "twocols (300x2 double)"
        ]
    );
}

// ---------------------------------------------------------------------------
// MAT errors: each names the file and the variable

fn f16_file(dir: &Path, name: &str, extra: Vec<Var>) -> PathBuf {
    let mut vars = f16_vars(&f16_like(400));
    vars.extend(extra);
    let path = dir.join(name);
    write(&path, &mat_bytes(&vars, false));
    path
}

#[test]
fn mat_errors_name_file_and_variable() {
    let dir = tempfile::tempdir().unwrap();
    let path = f16_file(
        dir.path(),
        "f16ish.mat",
        vec![
            Var {
                class: 4,
                ..Var::double("label", 1, 3, vec![72.0, 105.0, 33.0]).stored(Storage::Utf16)
            },
            Var {
                imag: Some(vec![1.0; 400]),
                ..Var::double("z", 1, 400, vec![0.5; 400])
            },
            Var::double("short", 1, 399, vec![0.0; 399]),
            Var::double("bad_fs", 1, 1, vec![-400.0]),
            Var::double("two_fs", 1, 2, vec![400.0, 401.0]),
        ],
    );
    let spec_with =
        |channels: Vec<ChannelSpec>, rate: SampleRateSource| ImportSpec::new(channels, rate);
    let fs = || SampleRateSource::Variable("Fs".into());
    // Missing variable: the message lists what is there, with shapes.
    let e = err_text(import(
        &path,
        &spec_with(vec![ChannelSpec::new("Forse", Quantity::Force)], fs()),
    ));
    assert_mentions(
        &e,
        &[
            "f16ish.mat",
            "Forse",
            "no such variable",
            "Force (1x400 double)",
            "Acceleration (3x400 double)",
        ],
    );
    // Row out of range: says the shape.
    let e = err_text(import(
        &path,
        &spec_with(
            vec![ChannelSpec::new("Acceleration", Quantity::Acceleration).row(4)],
            fs(),
        ),
    ));
    assert_mentions(&e, &["f16ish.mat", "Acceleration", "row 4", "3x400"]);
    // A matrix without a row.
    let e = err_text(import(
        &path,
        &spec_with(
            vec![ChannelSpec::new("Acceleration", Quantity::Acceleration)],
            fs(),
        ),
    ));
    assert_mentions(&e, &["Acceleration", "3x400", "1..=3"]);
    // Row on a vector.
    let e = err_text(import(
        &path,
        &spec_with(
            vec![ChannelSpec::new("Force", Quantity::Force).row(2)],
            fs(),
        ),
    ));
    assert_mentions(&e, &["Force", "row 2", "1x400"]);
    // Mismatched lengths.
    let e = err_text(import(
        &path,
        &spec_with(
            vec![
                ChannelSpec::new("Force", Quantity::Force),
                ChannelSpec::new("short", Quantity::Acceleration),
            ],
            fs(),
        ),
    ));
    assert_mentions(&e, &["f16ish.mat", "short", "399", "400", "Force"]);
    // Non-numeric and complex.
    let e = err_text(import(
        &path,
        &spec_with(vec![ChannelSpec::new("label", Quantity::Force)], fs()),
    ));
    assert_mentions(&e, &["f16ish.mat", "label", "char", "not a numeric"]);
    let e = err_text(import(
        &path,
        &spec_with(vec![ChannelSpec::new("z", Quantity::Force)], fs()),
    ));
    assert_mentions(&e, &["f16ish.mat", "`z`", "complex"]);
    // Fs not a positive scalar.
    let force = || vec![ChannelSpec::new("Force", Quantity::Force)];
    let e = err_text(import(
        &path,
        &spec_with(force(), SampleRateSource::Variable("bad_fs".into())),
    ));
    assert_mentions(&e, &["f16ish.mat", "bad_fs", "positive scalar", "-400"]);
    let e = err_text(import(
        &path,
        &spec_with(force(), SampleRateSource::Variable("two_fs".into())),
    ));
    assert_mentions(&e, &["f16ish.mat", "two_fs", "positive scalar", "1x2"]);
    // No rate variable found automatically: the listing helps.
    let path2 = dir.path().join("no_fs.mat");
    write(
        &path2,
        &mat_bytes(&[Var::double("u", 1, 10, vec![1.0; 10])], false),
    );
    let e = err_text(import(
        &path2,
        &spec_with(
            vec![ChannelSpec::new("u", Quantity::Force)],
            SampleRateSource::Auto,
        ),
    ));
    assert_mentions(&e, &["no_fs.mat", "sample rate", "u (1x10 double)"]);
    // Auto finds `Fs`.
    let rec = import(&path, &spec_with(force(), SampleRateSource::Auto))
        .unwrap()
        .recording;
    assert_eq!(rec.meta.sample_rate_hz, 400.0);
    // Variables that cannot be signals are noted in the metadata.
    assert_eq!(
        rec.meta.metadata["import"]["not_numeric"],
        serde_json::json!(["label (1x3 char)", "z (1x400 complex double)"])
    );
}

#[test]
fn mat_rate_from_a_time_vector() {
    let dir = tempfile::tempdir().unwrap();
    let n = 2000;
    let t: Vec<f64> = (0..n).map(|k| 0.5 + k as f64 / 2000.0).collect();
    let x = noise(20, n, 1.0);
    let path = dir.path().join("timed.mat");
    write(
        &path,
        &mat_bytes(
            &[
                Var::double("t", n, 1, t),
                Var::double("x", 1, n, x.clone()).compressed(),
            ],
            false,
        ),
    );
    let spec = ImportSpec::new(
        vec![ChannelSpec::new("x", Quantity::Displacement)],
        SampleRateSource::Time("t".into()),
    );
    let imp = import(&path, &spec).unwrap();
    assert!((imp.recording.meta.sample_rate_hz / 2000.0 - 1.0).abs() < 1e-12);
    assert!(same_bits(&imp.recording.channels[0], &x));
    assert_eq!(imp.quality.time_axis.as_ref().unwrap().column, "t");
    assert!(imp.quality.findings.is_empty(), "{}", imp.quality);
    // A declared rate checked against the time vector: 2 % off.
    let mut spec = ImportSpec::new(
        vec![ChannelSpec::new("x", Quantity::Displacement)],
        SampleRateSource::Value(2040.0),
    );
    spec.time_column = Some("t".into());
    let q = import(&path, &spec).unwrap().quality;
    let f: Vec<_> = q.of_kind(FindingKind::SampleRate).collect();
    assert_eq!(f.len(), 1, "{q}");
    assert_mentions(
        &f[0].message,
        &["2040 Hz", "`t`", "2000.000000 Hz", "-1.9608 %"],
    );
    // A comment rate makes no sense for a MAT-file.
    let spec = ImportSpec::new(
        vec![ChannelSpec::new("x", Quantity::Displacement)],
        SampleRateSource::Comment,
    );
    assert_mentions(
        &err_text(import(&path, &spec)),
        &["sample_rate", "timed.mat"],
    );
}

#[test]
fn mat_truncated_and_corrupted_files_say_where() {
    let dir = tempfile::tempdir().unwrap();
    let good = mat_bytes(&f16_vars(&f16_like(2000)), false);
    let spec = f16_spec();
    // Cut inside the last variable (Fs is 56 bytes, Acceleration before it).
    for cut in [good.len() - 30, good.len() - 100, 600, 130] {
        let path = dir.path().join(format!("cut{cut}.mat"));
        write(&path, &good[..cut]);
        let e = err_text(import(&path, &spec));
        assert_mentions(&e, &[&format!("cut{cut}.mat"), "element at byte", "remain"]);
    }
    let path = dir.path().join("tiny.mat");
    write(&path, &good[..100]);
    assert_mentions(
        &err_text(import(&path, &spec)),
        &["tiny.mat", "header", "128"],
    );
    // Corrupted compressed data. A broken zlib header stops the index: the
    // file and the element's byte offset are named. Corruption late in the
    // stream is found when the variable is read: the variable is named too.
    let big = mat_bytes(&f16_vars(&f16_like(20000)), false);
    let file = MatFile::from_bytes(Path::new("x.mat"), big.clone()).unwrap();
    let force = file.variable("Force").unwrap().clone();
    assert!(force.compressed);
    let zlen =
        u32::from_le_bytes(big[force.offset + 4..force.offset + 8].try_into().unwrap()) as usize;
    assert!(zlen > 100_000, "{zlen}");
    for (name, at, variable) in [("early.mat", 0, false), ("late.mat", zlen - 2000, true)] {
        let mut bad = big.clone();
        for b in &mut bad[force.offset + 8 + at..force.offset + 8 + at + 100] {
            *b ^= 0x5a;
        }
        let path = dir.path().join(name);
        write(&path, &bad);
        let e = err_text(import(&path, &spec));
        let offset = format!("element at byte {}", force.offset);
        assert_mentions(&e, &[name, &offset, "corrupt"]);
        assert_eq!(e.contains("`Force`"), variable, "{e}");
    }
    // Not a MAT v5 file.
    let mut v73 = good.clone();
    v73[..19].copy_from_slice(b"MATLAB 7.3 MAT-file");
    let path = dir.path().join("v73.mat");
    write(&path, &v73);
    assert_mentions(&err_text(import(&path, &spec)), &["v73.mat", "HDF5"]);
    let mut junk = good;
    junk[126..128].copy_from_slice(b"XX");
    let path = dir.path().join("junk.mat");
    write(&path, &junk);
    assert_mentions(
        &err_text(import(&path, &spec)),
        &["junk.mat", "header", "IM"],
    );
}

#[test]
fn mat_damaged_files_never_panic() {
    // Random cuts and byte flips of a mixed (compressed and plain) file: every
    // outcome is data or an error naming the file, never a panic.
    use rand::RngExt;
    let mut vars = f16_vars(&f16_like(300));
    vars.push(Var::double("i16", 1, 300, vec![7.0; 300]).stored(Storage::Int16));
    let good = mat_bytes(&vars, false);
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let (mut ok, mut failed) = (0, 0);
    for trial in 0..400 {
        let mut bytes = good.clone();
        if trial % 2 == 0 {
            bytes.truncate(rng.random_range(0..good.len()));
        } else {
            for _ in 0..rng.random_range(1..4) {
                let i = rng.random_range(0..bytes.len());
                bytes[i] ^= 1 << rng.random_range(0..8);
            }
        }
        match MatFile::from_bytes(Path::new("damaged.mat"), bytes) {
            Err(e) => {
                assert!(e.to_string().contains("damaged.mat"), "{e}");
                failed += 1;
            }
            Ok(f) => {
                for v in f.variables().to_vec() {
                    match f.read(&v.name) {
                        Ok(a) => {
                            let _ = a.signal(Some(1), Path::new("damaged.mat"));
                            ok += 1;
                        }
                        Err(e) => {
                            assert!(e.to_string().contains("damaged.mat"), "{e}");
                            failed += 1;
                        }
                    }
                }
            }
        }
    }
    eprintln!("damaged MAT files: {ok} variables read, {failed} errors");
    assert!(failed >= 200, "every cut file must fail: {failed}");
}

// ---------------------------------------------------------------------------
// Delimited text

/// `{}` of an f64 prints the shortest text that parses back to the same bits.
fn text_table(sep: &str, comments: &[&str], header: &[&str], cols: &[Vec<f64>]) -> String {
    let mut s = String::new();
    for c in comments {
        s.push_str(&format!("# {c}\n"));
    }
    s.push_str(&header.join(sep));
    s.push('\n');
    for k in 0..cols[0].len() {
        let row: Vec<String> = cols.iter().map(|c| format!("{}", c[k])).collect();
        s.push_str(&row.join(sep));
        s.push_str(if k % 2 == 0 { "\n" } else { "\r\n" });
    }
    s
}

#[test]
fn delimited_round_trips_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let n = 2048;
    let fs = 1024.0;
    let t: Vec<f64> = (0..n).map(|k| k as f64 / fs).collect();
    let a = noise(4, n, 0.1);
    let b: Vec<f64> = noise(5, n, 1e-3);
    let cols = vec![t.clone(), a.clone(), b.clone()];
    let cases = [
        ("comma.csv", ",", None),
        ("tabs.tsv", "\t", None),
        ("semi.csv", ";", None),
        ("spaces.txt", "   ", None),
        ("given.txt", "|", Some(Delimiter::Char(b'|'))),
    ];
    for (file, sep, delim) in cases {
        let path = dir.path().join(file);
        let text = text_table(
            sep,
            &["Steady-state sine test", "fs = 1024 Hz, 2 s"],
            &["time_s", "shaker_amp_V", "laser velocity"],
            &cols,
        );
        std::fs::write(&path, text).unwrap();
        let mut spec = ImportSpec::new(
            vec![
                ChannelSpec::new("shaker_amp_V", Quantity::Voltage).name("drive"),
                ChannelSpec::new(3, Quantity::Velocity).scale(1e-3),
            ],
            SampleRateSource::Auto,
        );
        spec.delimiter = delim;
        if sep == "   " {
            // Whitespace-separated: a header name with a blank would split.
            let text = std::fs::read_to_string(&path)
                .unwrap()
                .replace("laser velocity", "laser");
            std::fs::write(&path, text).unwrap();
        }
        let imp = import(&path, &spec).unwrap();
        let rec = &imp.recording;
        assert_eq!(rec.meta.sample_rate_hz, 1024.0, "{file}");
        assert!(same_bits(&rec.channels[0], &a), "{file}: column by name");
        let scaled: Vec<f64> = b.iter().map(|v| v * 1e-3).collect();
        assert!(
            same_bits(&rec.channels[1], &scaled),
            "{file}: column by number"
        );
        assert_eq!(rec.meta.channels[1].name, "column_3");
        // The time column agrees with the comment: no rate finding, no jitter.
        let axis = imp.quality.time_axis.as_ref().expect("time column found");
        assert_eq!(axis.column, "time_s");
        assert!(
            (axis.rate_hz / 1024.0 - 1.0).abs() < 1e-12,
            "{}",
            axis.rate_hz
        );
        assert!(imp.quality.worst().is_none(), "{file}: {}", imp.quality);
    }
}

#[test]
fn delimited_sample_rate_sources() {
    let dir = tempfile::tempdir().unwrap();
    let n = 1000;
    let fs = 750.0;
    let x = noise(6, n, 1.0);
    let t: Vec<f64> = (0..n).map(|k| k as f64 / fs).collect();
    // Rate from the time column only (no comment).
    let path = dir.path().join("timed.csv");
    std::fs::write(
        &path,
        text_table(",", &[], &["t", "force_N"], &[t.clone(), x.clone()]),
    )
    .unwrap();
    let spec = ImportSpec::new(
        vec![ChannelSpec::new("force_N", Quantity::Force)],
        SampleRateSource::Auto,
    );
    let imp = import(&path, &spec).unwrap();
    // k/750 printed to 17 digits: the least-squares rate is exact to ~1e-13.
    assert!((imp.recording.meta.sample_rate_hz / fs - 1.0).abs() < 1e-12);
    // Rate from a comment, Bouc-Wen style, no time column.
    let path = dir.path().join("comment.csv");
    std::fs::write(
        &path,
        text_table(
            ",",
            &["Bouc-Wen test set: fs = 750 Hz (sample k is at t = k/750 s), 40 N"],
            &["force_N"],
            std::slice::from_ref(&x),
        ),
    )
    .unwrap();
    let spec = ImportSpec::new(
        vec![ChannelSpec::new("force_N", Quantity::Force)],
        SampleRateSource::Comment,
    );
    let rec = import(&path, &spec).unwrap().recording;
    assert_eq!(rec.meta.sample_rate_hz, 750.0);
    assert!(same_bits(&rec.channels[0], &x));
    // kHz in a comment.
    std::fs::write(
        &path,
        text_table(
            ",",
            &["sample rate: 2.5 kHz"],
            &["force_N"],
            std::slice::from_ref(&x),
        ),
    )
    .unwrap();
    assert_eq!(
        import(&path, &spec).unwrap().recording.meta.sample_rate_hz,
        2500.0
    );
    // Nothing to go by.
    std::fs::write(
        &path,
        text_table(
            ",",
            &["offset fs-ish words"],
            &["force_N"],
            std::slice::from_ref(&x),
        ),
    )
    .unwrap();
    let auto = ImportSpec::new(
        vec![ChannelSpec::new("force_N", Quantity::Force)],
        SampleRateSource::Auto,
    );
    assert_mentions(
        &err_text(import(&path, &auto)),
        &["comment.csv", "sample rate", "force_N"],
    );
    // Two different rates in comments.
    std::fs::write(
        &path,
        text_table(",", &["fs = 750 Hz", "fs = 1000 Hz"], &["force_N"], &[x]),
    )
    .unwrap();
    assert_mentions(
        &err_text(import(&path, &spec)),
        &["comment.csv", "line 2", "750", "1000"],
    );
}

#[test]
fn time_column_mismatch_jitter_and_gap_are_found_where_injected() {
    let dir = tempfile::tempdir().unwrap();
    let n = 4000;
    let x = noise(7, n, 1.0);
    let opts = QualityOptions::default();
    // 1. Declared 1000 Hz, stamps at 1024 Hz: a 2.4 % mismatch.
    let t: Vec<f64> = (0..n).map(|k| k as f64 / 1024.0).collect();
    let path = dir.path().join("mismatch.csv");
    std::fs::write(&path, text_table(",", &[], &["time", "v"], &[t, x.clone()])).unwrap();
    let spec = ImportSpec::new(
        vec![ChannelSpec::new("v", Quantity::Voltage)],
        SampleRateSource::Value(1000.0),
    );
    let q = import(&path, &spec).unwrap().quality;
    let f: Vec<_> = q.of_kind(FindingKind::SampleRate).collect();
    assert_eq!(f.len(), 1, "{q}");
    assert_eq!(f[0].severity, Severity::Warning);
    assert_mentions(
        &f[0].message,
        &["1000 Hz", "`time`", "1024.000000 Hz", "+2.4000 %"],
    );
    assert_eq!(q.findings.len(), 1, "{q}");
    // 2. One stamp 5 % of a period late at sample 1234 (threshold 1 %).
    let mut t: Vec<f64> = (0..n).map(|k| k as f64 / 1000.0).collect();
    t[1234] += 0.05e-3;
    std::fs::write(&path, text_table(",", &[], &["time", "v"], &[t, x.clone()])).unwrap();
    let q = import(&path, &spec).unwrap().quality;
    let f: Vec<_> = q.of_kind(FindingKind::TimeJitter).collect();
    assert_eq!(f.len(), 1, "{q}");
    assert_eq!(
        f[0].spans,
        [Span {
            start: 1234,
            len: 1
        }]
    );
    let axis = q.time_axis.clone().unwrap();
    // The fitted line barely moves for one outlier: deviation 0.05 periods.
    assert!(
        (axis.jitter_max_periods - 0.05).abs() < 1e-3,
        "{}",
        axis.jitter_max_periods
    );
    assert!(
        q.of_kind(FindingKind::SampleRate).next().is_none(),
        "a 1e-8 rate change is not a mismatch"
    );
    // 3. Three samples missing after sample 2999 (rows dropped).
    let t: Vec<f64> = (0..n)
        .filter(|k| !(3000..3003).contains(k))
        .map(|k| k as f64 / 1000.0)
        .collect();
    let y: Vec<f64> = x[..n - 3].to_vec();
    std::fs::write(&path, text_table(",", &[], &["time", "v"], &[t, y])).unwrap();
    let q = import(&path, &spec).unwrap().quality;
    let f: Vec<_> = q.of_kind(FindingKind::TimeGap).collect();
    assert_eq!(f.len(), 1, "{q}");
    assert_eq!(
        f[0].spans,
        [Span {
            start: 3000,
            len: 1
        }]
    );
    assert_mentions(&f[0].message, &["`time`", "3000"]);
    // 4. A non-increasing time column is an error when the rate comes from it.
    let mut t: Vec<f64> = (0..n).map(|k| k as f64 / 1000.0).collect();
    t[500] = t[499];
    std::fs::write(&path, text_table(",", &[], &["time", "v"], &[t, x])).unwrap();
    let derived = ImportSpec::new(
        vec![ChannelSpec::new("v", Quantity::Voltage)],
        SampleRateSource::Time("time".into()),
    );
    // Header is line 1, so sample k is on line k + 2.
    assert_mentions(
        &err_text(import(&path, &derived)),
        &["mismatch.csv", "line 502", "`time`", "does not increase"],
    );
    // ... and an error finding when a rate was declared.
    let q = import(&path, &spec).unwrap().quality;
    assert!(q.has_errors(), "{q}");
    let _ = opts;
}

#[test]
fn delimited_errors_name_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("data.csv");
    let spec = |src: Column| {
        ImportSpec::new(
            vec![ChannelSpec::new(src, Quantity::Velocity)],
            SampleRateSource::Value(100.0),
        )
    };
    let good = "# comment\ntime_s,shaker_amp_V,laser_velocity_m_per_s\n0,1,2\n0.01,3,4\n";
    std::fs::write(&path, good).unwrap();
    // Wrong column name / number: the header is listed.
    let e = err_text(import(&path, &spec("laser".into())));
    assert_mentions(
        &e,
        &[
            "data.csv",
            "laser",
            "no such column",
            "1 `time_s`",
            "3 `laser_velocity_m_per_s`",
        ],
    );
    let e = err_text(import(&path, &spec(4.into())));
    assert_mentions(&e, &["data.csv", "column 4", "3 columns", "shaker_amp_V"]);
    // Non-numeric and empty cells.
    std::fs::write(&path, good.replace("0.01,3,4", "0.01,3,4.0.1")).unwrap();
    let e = err_text(import(&path, &spec(3.into())));
    assert_mentions(
        &e,
        &[
            "data.csv",
            "line 4",
            "column 3 `laser_velocity_m_per_s`",
            "`4.0.1` is not a number",
        ],
    );
    std::fs::write(&path, good.replace("0,1,2", "0,1,")).unwrap();
    assert_mentions(
        &err_text(import(&path, &spec(3.into()))),
        &["data.csv", "line 3", "empty cell"],
    );
    // Ragged rows.
    std::fs::write(&path, good.replace("0.01,3,4", "0.01,3")).unwrap();
    let e = err_text(import(&path, &spec(3.into())));
    assert_mentions(&e, &["data.csv", "line 4", "ragged", "2 fields", "has 3"]);
    // Empty file, only comments, no header, no data.
    for (text, want) in [
        ("", "empty"),
        ("# just a note\n\n", "only comments"),
        ("1,2,3\n4,5,6\n", "header row"),
        ("a,b,c\n", "no data rows"),
    ] {
        std::fs::write(&path, text).unwrap();
        assert_mentions(
            &err_text(import(&path, &spec(1.into()))),
            &["data.csv", want],
        );
    }
    // `row` makes no sense in a text file.
    std::fs::write(&path, good).unwrap();
    let mut s = spec(2.into());
    s.channels[0].row = Some(1);
    assert_mentions(
        &err_text(import(&path, &s)),
        &["channels[0].row", "data.csv"],
    );
}

#[test]
fn import_dispatch_and_spec_validation() {
    let dir = tempfile::tempdir().unwrap();
    let spec = ImportSpec::new(
        vec![ChannelSpec::new("x", Quantity::Force)],
        SampleRateSource::Value(1.0),
    );
    for f in ["rec.wav", "rec.json"] {
        let e = err_text(import(&dir.path().join(f), &spec));
        assert_mentions(&e, &[f, "record::read_recording"]);
    }
    assert_mentions(
        &err_text(import(&dir.path().join("a.xlsx"), &spec)),
        &["a.xlsx", ".xlsx", ".mat"],
    );
    // Units must be SI; duplicate names; bad scale.
    let mut s = spec.clone();
    s.channels[0].unit = Some("g".into());
    assert_mentions(
        &err_text(import(&dir.path().join("a.csv"), &s)),
        &["channels[0].unit", "`g`", "N", "scale"],
    );
    let mut s = spec.clone();
    s.channels
        .push(ChannelSpec::new("y", Quantity::Force).name("x"));
    assert_mentions(
        &err_text(import(&dir.path().join("a.csv"), &s)),
        &["channels[1].name", "`x`"],
    );
    let mut s = spec;
    s.channels[0].scale = 0.0;
    assert_mentions(
        &err_text(import(&dir.path().join("a.csv"), &s)),
        &["channels[0].scale"],
    );
}

#[test]
fn spec_from_toml_and_report_to_json() {
    let toml_text = r#"
        description = "F-16 level 1"
        sample_rate = { variable = "Fs" }
        delimiter = "tab"
        [[channels]]
        variable = "Force"
        name = "force"
        quantity = "force"
        [[channels]]
        variable = "Acceleration"
        row = 2
        name = "acc2"
        quantity = "acceleration"
        unit = "m/s^2"
        [[channels]]
        column = 3
        quantity = "velocity"
        scale = 1e-3
        [excitation]
        kind = "swept-sine"
        sweep = { f_start_hz = 15.0, f_end_hz = 2.0, rate_hz_per_s = -0.05 }
        [quality]
        clip_min_run = 6
        nominal_excitation_hz = 19.0
    "#;
    let spec: ImportSpec = toml::from_str(toml_text).unwrap();
    assert_eq!(spec.sample_rate, SampleRateSource::Variable("Fs".into()));
    assert_eq!(spec.delimiter, Some(Delimiter::Char(b'\t')));
    assert_eq!(spec.channels[1].source, Column::Name("Acceleration".into()));
    assert_eq!(spec.channels[1].row, Some(2));
    assert_eq!(spec.channels[2].source, Column::Index(3));
    assert_eq!(spec.channels[2].scale, 1e-3);
    assert_eq!(
        spec.excitation.as_ref().unwrap().kind,
        ExcitationKind::SweptSine
    );
    assert_eq!(spec.quality.clip_min_run, 6);
    assert_eq!(
        spec.quality.dropout_min_run,
        QualityOptions::default().dropout_min_run
    );
    for (text, want) in [
        (
            "sample_rate = { value = 750.0 }\nchannels = []",
            SampleRateSource::Value(750.0),
        ),
        (
            "sample_rate = \"comment\"\nchannels = []",
            SampleRateSource::Comment,
        ),
        (
            "sample_rate = { time = \"time_s\" }\nchannels = []",
            SampleRateSource::Time("time_s".into()),
        ),
        ("channels = []", SampleRateSource::Auto),
    ] {
        assert_eq!(
            toml::from_str::<ImportSpec>(text).unwrap().sample_rate,
            want
        );
    }
    // A typo is refused, not ignored.
    assert!(toml::from_str::<ImportSpec>("channels = []\nsample_rte = 3").is_err());
    // The excitation the user gave lands in the recording.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sweep.mat");
    write(&path, &mat_bytes(&f16_vars(&f16_like(100)), false));
    let mut spec = f16_spec();
    spec.excitation = toml::from_str::<ImportSpec>(toml_text).unwrap().excitation;
    let imp = import(&path, &spec).unwrap();
    let sweep = imp.recording.meta.excitation.sweep.unwrap();
    assert_eq!(
        (sweep.f_start_hz, sweep.f_end_hz, sweep.rate_hz_per_s),
        (15.0, 2.0, Some(-0.05))
    );
    assert_eq!(imp.recording.meta.metadata["import"]["source"], "sweep.mat");
    assert_eq!(
        imp.recording.meta.metadata["import"]["channels"]["acc2"],
        "Acceleration(row 2)"
    );
    // The report serialises.
    let mut rec = imp.recording;
    rec.channels[0][3] = f64::NAN;
    let q = check_quality(&rec, &QualityOptions::default());
    let json = serde_json::to_value(&q).unwrap();
    assert_eq!(json["findings"][0]["severity"], "error");
    assert_eq!(json["findings"][0]["kind"], "non-finite");
    assert_eq!(json["findings"][0]["channel"], "force");
    assert_eq!(json["findings"][0]["spans"][0]["start"], 3);
}

#[test]
fn compact_command_line_forms() {
    let c: ChannelSpec = "acc2=Acceleration(2):acceleration".parse().unwrap();
    assert_eq!(
        c,
        ChannelSpec::new("Acceleration", Quantity::Acceleration)
            .row(2)
            .name("acc2")
    );
    let c: ChannelSpec = "laser=#3:velocity*1e-3".parse().unwrap();
    assert_eq!(
        c,
        ChannelSpec::new(3, Quantity::Velocity)
            .name("laser")
            .scale(1e-3)
    );
    let c: ChannelSpec = "Force:force".parse().unwrap();
    assert_eq!(c, ChannelSpec::new("Force", Quantity::Force));
    for (bad, want) in [
        ("Force", "QUANTITY"),
        ("Force:torque", "`torque`"),
        ("a=Acc(x):acceleration", "row `x`"),
        ("a=#k:force", "`k`"),
        ("Force:force*big", "scale `big`"),
    ] {
        let e = bad.parse::<ChannelSpec>().unwrap_err().to_string();
        assert_mentions(&e, &[bad, want]);
    }
    for (text, want) in [
        ("auto", SampleRateSource::Auto),
        ("comment", SampleRateSource::Comment),
        ("400", SampleRateSource::Value(400.0)),
        ("1024 Hz", SampleRateSource::Value(1024.0)),
        ("variable:Fs", SampleRateSource::Variable("Fs".into())),
        ("time:time_s", SampleRateSource::Time("time_s".into())),
        ("time:#1", SampleRateSource::Time(Column::Index(1))),
    ] {
        assert_eq!(text.parse::<SampleRateSource>().unwrap(), want, "{text}");
    }
    assert!("fast".parse::<SampleRateSource>().is_err());
}

// ---------------------------------------------------------------------------
// Quality checks on synthetic recordings

fn recording(fs: f64, channels: Vec<(&str, Quantity, Vec<f64>)>) -> Recording {
    Recording {
        meta: RecordingMeta {
            format: FORMAT_V1.into(),
            sample_rate_hz: fs,
            channels: channels
                .iter()
                .map(|(n, q, _)| Channel {
                    name: n.to_string(),
                    quantity: *q,
                    unit: q.si_unit().into(),
                    scale: 1.0,
                })
                .collect(),
            excitation: Excitation::default(),
            description: String::new(),
            metadata: Default::default(),
            extra: Default::default(),
            chosen_reference: None,
        },
        channels: channels.into_iter().map(|(_, _, x)| x).collect(),
    }
}

/// `amp sin(2π f k / fs)` plus white noise of `sigma`.
fn noisy_sine(n: usize, fs: f64, f: f64, amp: f64, sigma: f64, seed: u64) -> Vec<f64> {
    let e = noise(seed, n, sigma);
    (0..n)
        .map(|k| amp * (2.0 * std::f64::consts::PI * f * k as f64 / fs).sin() + e[k])
        .collect()
}

#[test]
fn clean_noisy_sine_is_not_flagged() {
    // 100 whole periods at 50 samples a period, 1 % noise; also at an
    // awkward frequency (not whole periods), and with a small DC offset of
    // 5 % of the AC RMS (threshold 10 %).
    let fs = 1000.0;
    for (f, offset) in [
        (20.0, 0.0),
        (7.3, 0.0),
        (20.0, 0.05 * std::f64::consts::FRAC_1_SQRT_2),
    ] {
        let x: Vec<f64> = noisy_sine(5000, fs, f, 1.0, 0.01, 8)
            .iter()
            .map(|v| v + offset)
            .collect();
        let v = noisy_sine(5000, fs, f, 2e-3, 1e-5, 9);
        let rec = recording(
            fs,
            vec![
                ("force", Quantity::Force, x),
                ("vel", Quantity::Velocity, v),
            ],
        );
        let opts = QualityOptions {
            nominal_excitation_hz: Some(f),
            ..QualityOptions::default()
        };
        let q = check_quality(&rec, &opts);
        assert!(q.findings.is_empty(), "f = {f}: {q}");
        assert!(
            (q.channels[0].ac_rms - (0.5f64 + 1e-4).sqrt()).abs() < 0.01,
            "{}",
            q.channels[0].ac_rms
        );
    }
}

#[test]
fn injected_nan_and_inf_are_errors_at_their_positions() {
    let mut x = noisy_sine(3000, 1000.0, 20.0, 1.0, 0.01, 10);
    x[100] = f64::NAN;
    x[101] = f64::NAN;
    x[2000] = f64::INFINITY;
    x[2999] = f64::NEG_INFINITY;
    let rec = recording(1000.0, vec![("force", Quantity::Force, x)]);
    let q = check_quality(&rec, &QualityOptions::default());
    assert!(q.has_errors());
    let f: Vec<_> = q.of_kind(FindingKind::NonFinite).collect();
    assert_eq!(f.len(), 1, "{q}");
    assert_eq!(
        f[0].spans,
        [
            Span { start: 100, len: 2 },
            Span {
                start: 2000,
                len: 1
            },
            Span {
                start: 2999,
                len: 1
            }
        ]
    );
    assert_eq!(f[0].samples, 4);
    assert_mentions(
        &f[0].message,
        &["`force`", "2 NaN", "2 infinite", "100-101, 2000, 2999"],
    );
    assert_eq!(q.channels[0].non_finite, 4);
    // Stats use the finite samples only.
    assert!(q.channels[0].ac_rms.is_finite());
    assert_eq!(q.findings.len(), 1, "{q}");
}

#[test]
fn injected_clipping_is_found_per_peak() {
    // 50 samples a period, 100 periods, clipped at 0.8 of the amplitude:
    // each of the 200 peaks sits on the rail while |sin| > 0.8, i.e. for
    // (π - 2 asin 0.8)/π = 40.97 % of the time; noise 1e-3 cannot break
    // a run where the sine is > 0.8 + 3σ... except near the run edges.
    let n = 5000;
    let clean = noisy_sine(n, 1000.0, 20.0, 1.0, 1e-3, 11);
    let x: Vec<f64> = clean.iter().map(|v| v.clamp(-0.8, 0.8)).collect();
    let rec = recording(1000.0, vec![("force", Quantity::Force, x.clone())]);
    let q = check_quality(&rec, &QualityOptions::default());
    let f: Vec<_> = q.of_kind(FindingKind::Clipping).collect();
    assert_eq!(f.len(), 1, "{q}");
    assert_eq!(f[0].severity, Severity::Warning);
    assert_eq!(f[0].span_count, 200, "{}", f[0].message);
    let frac = f[0].samples as f64 / n as f64;
    let expected = (std::f64::consts::PI - 2.0 * 0.8f64.asin()) / std::f64::consts::PI;
    // Noise moves each run edge by about σ/slope = 1e-3/(0.6*2π/50) samples.
    assert!(
        (frac - expected).abs() < 0.02,
        "clipped fraction {frac} vs {expected}"
    );
    // The first peak is at sample 12.5 (a quarter period); its run straddles it.
    let s = f[0].spans[0];
    assert!(s.start < 12 && s.start + s.len > 13, "{s:?}");
    assert_mentions(
        &f[0].message,
        &["`force`", "clipped", "200 runs", "maximum", "minimum"],
    );

    // A declared full scale: the rail is at 1.0 but one spike reaches 1.3, so
    // the extreme-value test alone finds nothing at the rail. The offset
    // keeps the negative peaks (-0.9) inside full scale.
    let mut y: Vec<f64> = noisy_sine(n, 1000.0, 20.0, 1.2, 1e-3, 12)
        .iter()
        .map(|v| (v + 0.3).min(1.0))
        .collect();
    y[4000] = 1.3;
    let rec = recording(1000.0, vec![("acc", Quantity::Acceleration, y)]);
    let q = check_quality(&rec, &QualityOptions::default());
    assert!(q.of_kind(FindingKind::Clipping).next().is_none(), "{q}");
    let mut opts = QualityOptions::default();
    opts.full_scale.insert("acc".into(), 1.0);
    let q = check_quality(&rec, &opts);
    let f: Vec<_> = q.of_kind(FindingKind::Clipping).collect();
    // 100 positive peaks held at 1.0 (the spike sits inside one of them).
    assert_eq!(f[0].span_count, 100, "{q}");
    assert_mentions(&f[0].message, &["full scale ±1"]);
    // The un-clipped signal is clean.
    let rec = recording(1000.0, vec![("force", Quantity::Force, clean)]);
    assert!(
        check_quality(&rec, &QualityOptions::default())
            .findings
            .is_empty()
    );
}

#[test]
fn injected_dropouts_are_found_and_pretrigger_is_only_noted() {
    let n = 10000;
    let mut x = noisy_sine(n, 1000.0, 13.0, 1.0, 0.01, 13);
    // Pre-trigger silence, a zero dropout, a stuck value, a 5-sample hold
    // (shorter than the 10-sample threshold).
    for v in &mut x[..500] {
        *v = 0.0;
    }
    for v in &mut x[3000..3200] {
        *v = 0.0;
    }
    let held = x[6999];
    for v in &mut x[7000..7050] {
        *v = held;
    }
    let held = x[8999];
    for v in &mut x[9000..9004] {
        *v = held;
    }
    let rec = recording(1000.0, vec![("vel", Quantity::Velocity, x)]);
    let q = check_quality(&rec, &QualityOptions::default());
    let f: Vec<_> = q.of_kind(FindingKind::Dropout).collect();
    assert_eq!(f.len(), 1, "{q}");
    assert_eq!(
        f[0].spans,
        [
            Span {
                start: 3000,
                len: 200
            },
            Span {
                start: 6999,
                len: 51
            }
        ]
    );
    assert_mentions(
        &f[0].message,
        &[
            "`vel`",
            "2 dropouts",
            "1 of them zeros",
            "3000-3199",
            "6999-7049",
        ],
    );
    let info: Vec<_> = q.of_kind(FindingKind::ConstantSection).collect();
    assert_eq!(info.len(), 1, "{q}");
    assert_eq!(info[0].severity, Severity::Info);
    assert_eq!(info[0].spans, [Span { start: 0, len: 500 }]);
    assert_eq!(q.worst(), Some(Severity::Warning));
    // A silent channel (all zeros) is constant, not a dropout.
    let rec = recording(1000.0, vec![("vel", Quantity::Velocity, vec![0.0; 100])]);
    let q = check_quality(&rec, &QualityOptions::default());
    assert_eq!(q.findings.len(), 1);
    assert_eq!(q.findings[0].kind, FindingKind::Constant);
}

#[test]
fn dc_offset_is_flagged_above_the_threshold_only() {
    // AC RMS of a unit sine = 1/√2; threshold 10 %.
    let ac = std::f64::consts::FRAC_1_SQRT_2;
    for (ratio, flagged) in [(0.05, false), (0.09, false), (0.12, true), (1.0, true)] {
        let x: Vec<f64> = noisy_sine(5000, 1000.0, 20.0, 1.0, 0.0, 14)
            .iter()
            .map(|v| v + ratio * ac)
            .collect();
        let rec = recording(1000.0, vec![("disp", Quantity::Displacement, x)]);
        let q = check_quality(&rec, &QualityOptions::default());
        let f: Vec<_> = q.of_kind(FindingKind::DcOffset).collect();
        assert_eq!(f.len(), usize::from(flagged), "ratio {ratio}: {q}");
        if flagged {
            assert_mentions(
                &f[0].message,
                &["`disp`", &format!("{:.1} %", 100.0 * ratio)],
            );
        }
    }
}

#[test]
fn sample_rate_mismatch_against_nominal_excitation() {
    // A 19 Hz sine sampled at 1024 Hz but declared as 1000 Hz: its
    // dominant frequency reads 19 * 1000/1024 = 18.55 Hz (2.3 % low).
    let x = noisy_sine(16384, 1024.0, 19.0, 0.09, 1e-3, 15);
    let mut rec = recording(1000.0, vec![("drive", Quantity::Voltage, x.clone())]);
    let opts = QualityOptions {
        nominal_excitation_hz: Some(19.0),
        ..QualityOptions::default()
    };
    let q = check_quality(&rec, &opts);
    let f: Vec<_> = q.of_kind(FindingKind::SampleRate).collect();
    assert_eq!(f.len(), 1, "{q}");
    assert_mentions(&f[0].message, &["`drive`", "18.5", "19 Hz", "1000 Hz"]);
    // The implied rate is in the message: 1024 to within a tenth of a bin.
    let implied: f64 = f[0]
        .message
        .split("would fit ")
        .nth(1)
        .unwrap()
        .split(' ')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    assert!(
        (implied - 1024.0).abs() < 0.1 * 1024.0 / 16384.0 * 1024.0 / 19.0,
        "{implied}"
    );
    rec.meta.sample_rate_hz = 1024.0;
    assert!(check_quality(&rec, &opts).findings.is_empty());
    // Stepped sine: the second dwell was run at 21 Hz instead of 20.
    let fs = 1000.0;
    let mut y = Vec::new();
    for (f, seed) in [(19.0, 16), (21.0, 17), (21.0, 18)] {
        y.extend(noisy_sine(4000, fs, f, 1.0, 0.01, seed));
    }
    let mut rec = recording(fs, vec![("force", Quantity::Force, y)]);
    rec.meta.excitation = Excitation {
        kind: ExcitationKind::SteppedSine,
        steps: [19.0, 20.0, 21.0]
            .iter()
            .enumerate()
            .map(|(k, &f)| Step {
                frequency_hz: f,
                level: 1.0,
                start: 4000 * k,
                settle: 1000,
                length: 4000,
            })
            .collect(),
        sweep: None,
    };
    let q = check_quality(&rec, &QualityOptions::default());
    let f: Vec<_> = q.of_kind(FindingKind::SampleRate).collect();
    assert_eq!(f.len(), 1, "{q}");
    assert_eq!(
        f[0].spans,
        [Span {
            start: 5000,
            len: 3000
        }]
    );
}

// ---------------------------------------------------------------------------
// Real data (skipped when ../shared/datasets is absent)

fn rms(x: &[f64]) -> f64 {
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

#[test]
fn real_f16_level1_mat() {
    let Some(dir) = common::dataset("f16_gvt_benchmark") else {
        return;
    };
    let path = dir.join("BenchmarkData/F16Data_SineSw_Level1.mat");
    let t0 = std::time::Instant::now();
    let imp = import(&path, &f16_spec()).unwrap();
    let took = t0.elapsed();
    let rec = &imp.recording;
    assert_eq!(rec.meta.sample_rate_hz, 400.0);
    assert_eq!(rec.frames(), 108477);
    // A 4.8 N-amplitude sine has RMS 4.8/√2 = 3.394 N. The shaker's force
    // drops near the structure's resonances (force drop-out) and the record
    // ends with a few seconds of constant force, which can only lower the
    // whole-record RMS, by some %; noise and harmonics raise it by less
    // than 2 %. Band: 3.05 .. 3.45 N (-10 % .. +1.7 %).
    let f_rms = rms(&rec.channels[0]);
    let peak = rec.channels[0].iter().fold(0.0f64, |m, v| m.max(v.abs()));
    eprintln!(
        "F-16 L1: force RMS {f_rms:.4} N (sine of 4.8 N: {:.4}), |force| max {peak:.3} N, acc2 RMS {:.4} m/s^2, import {took:?}",
        4.8 / 2f64.sqrt(),
        rms(&rec.channels[1])
    );
    eprintln!("{}", imp.quality);
    assert!((3.05..3.45).contains(&f_rms), "force RMS {f_rms}");
    assert!(!imp.quality.has_errors());
    assert!(took.as_secs_f64() < 1.0, "import took {took:?}");
    // Cross-check against the independent `matfile` crate: same bits.
    let other = matfile::MatFile::parse(std::fs::File::open(&path).unwrap()).unwrap();
    let get = |name: &str| match other.find_by_name(name).unwrap().data() {
        matfile::NumericData::Double { real, .. } => real.clone(),
        _ => panic!("{name} is not double"),
    };
    assert!(same_bits(&rec.channels[0], &get("Force")));
    let acc = get("Acceleration");
    let acc2: Vec<f64> = (0..108477).map(|j| acc[1 + 3 * j]).collect();
    assert!(same_bits(&rec.channels[1], &acc2));
}

#[test]
fn real_boucwen_sweep_mat_matches_its_csv() {
    let Some(dir) = common::dataset("boucwen_benchmark") else {
        return;
    };
    let spec = ImportSpec::new(
        vec![
            ChannelSpec::new("uval_sinesweep", Quantity::Force).name("force"),
            ChannelSpec::new("yval_sinesweep", Quantity::Displacement).name("displacement"),
        ],
        SampleRateSource::Value(750.0),
    );
    let imp = import(&dir.join("bouc-wen.mat"), &spec).unwrap();
    let rec = &imp.recording;
    assert_eq!(rec.frames(), 153000);
    let (u, y) = (&rec.channels[0], &rec.channels[1]);
    let peak = u.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    eprintln!(
        "Bouc-Wen sweep: |u| max {peak:.4} N, u RMS {:.4} N, y RMS {:.4e} m\n{}",
        rms(u),
        rms(y),
        imp.quality
    );
    // The README: 40 N amplitude sweep, so |u| peaks at 40 N and its RMS is
    // 40/√2 = 28.28 N (a constant-amplitude sweep).
    assert!((peak - 40.0).abs() < 0.05, "{peak}");
    assert!(
        (rms(u) / (40.0 / 2f64.sqrt()) - 1.0).abs() < 0.01,
        "{}",
        rms(u)
    );
    // The CSV copy holds the same signals printed to 10 significant digits:
    // an independent route (text) to the same numbers.
    let csv = import(
        &dir.join("csv/val_sinesweep.csv"),
        &ImportSpec::new(
            vec![
                ChannelSpec::new("force_N", Quantity::Force),
                ChannelSpec::new("displacement_m", Quantity::Displacement),
            ],
            SampleRateSource::Comment,
        ),
    )
    .unwrap();
    assert_eq!(csv.recording.meta.sample_rate_hz, 750.0);
    for c in 0..2 {
        let (k, rel) = common::worst_relative(&csv.recording.channels[c], &rec.channels[c]);
        // 10 significant digits: relative rounding at most 5e-10 (tiny
        // values such as the -1e-24 m at t = 0 are printed the same way).
        assert!(rel <= 5.000001e-10, "channel {c}: {rel} at {k}");
    }
}

#[test]
fn real_unesp_sine_19hz_csv() {
    let Some(dir) = common::dataset("bolted_beam_unesp_bert") else {
        return;
    };
    let path = dir.join("csv/sine_19Hz_0p15V_time.csv");
    let mut spec = ImportSpec::new(
        vec![
            ChannelSpec::new("shaker_amp_V", Quantity::Voltage).name("drive"),
            ChannelSpec::new("laser_velocity_m_per_s", Quantity::Velocity).name("laser"),
        ],
        SampleRateSource::Auto,
    );
    spec.quality.nominal_excitation_hz = Some(19.0);
    let t0 = std::time::Instant::now();
    let imp = import(&path, &spec).unwrap();
    let took = t0.elapsed();
    let rec = &imp.recording;
    eprintln!(
        "UNESP 19 Hz: drive RMS {:.5} V (amplitude ~ {:.5} V), laser RMS {:.4} m/s, import {took:?}\n{}",
        rms(&rec.channels[0]),
        rms(&rec.channels[0]) * 2f64.sqrt(),
        rms(&rec.channels[1]),
        imp.quality
    );
    // Rate from the comment `fs = 1024 Hz`, confirmed by the time column.
    assert_eq!(rec.meta.sample_rate_hz, 1024.0);
    assert_eq!(rec.frames(), 65536);
    let axis = imp.quality.time_axis.as_ref().unwrap();
    assert!((axis.rate_hz - 1024.0).abs() < 1e-6, "{}", axis.rate_hz);
    // A naive second reader (split lines and commas) gives the same bits.
    let text = std::fs::read_to_string(&path).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect())
        .collect();
    for c in 0..2 {
        let col: Vec<f64> = rows.iter().map(|r| r[c + 1]).collect();
        assert!(same_bits(&rec.channels[c], &col), "column {}", c + 2);
    }
    // 32 s hold exactly 608 periods of 19 Hz: a plain DFT at 19 Hz gives
    // the fundamentals without leakage. The pinned lists, for the steady
    // state, a drive amplitude of about 0.089-0.0895 V, a laser fundamental
    // of 0.743 m/s and a phase of -73.9 deg; the second half of the record
    // reproduces them to their rounding (over the whole record the drive
    // is higher, 0.119 V, and the phase drifts from -71.4 deg in the first
    // quarter to -78.9 deg in the last).
    let fundamental = |x: &[f64]| {
        let w = 2.0 * std::f64::consts::PI * 19.0 / 1024.0;
        let (c, s) = x.iter().enumerate().fold((0.0, 0.0), |(c, s), (k, v)| {
            (c + v * (w * k as f64).cos(), s + v * (w * k as f64).sin())
        });
        // X = Σ x e^{-jωk} = c - j s.
        (2.0 * c.hypot(s) / x.len() as f64, (-s).atan2(c))
    };
    let (a1, pa) = fundamental(&rec.channels[0][32768..]);
    let (v1, pv) = fundamental(&rec.channels[1][32768..]);
    let ratio = v1 / a1;
    let phase = ((pv - pa).to_degrees() + 540.0) % 360.0 - 180.0;
    eprintln!(
        "UNESP 19 Hz, second half: drive fundamental {a1:.5} V, laser fundamental {v1:.4} m/s, \
         ratio {ratio:.4} (m/s)/V, phase {phase:.3} deg"
    );
    assert!((0.089..0.0895).contains(&a1), "{a1}");
    assert!((v1 - 0.743).abs() <= 0.0005, "{v1}");
    // 0.743/0.0895 .. 0.743/0.089, with ±0.0005 on 0.743.
    assert!((8.296..8.354).contains(&ratio), "{ratio}");
    // The pinned rounds to 0.1 deg.
    assert!((phase + 73.9).abs() < 0.06, "{phase}");
    // 19 Hz is where the data says it is: no rate finding.
    assert!(
        imp.quality
            .of_kind(FindingKind::SampleRate)
            .next()
            .is_none()
    );
    assert!(!imp.quality.has_errors());
}
