//! Integration tests: UFF dataset 58 / 58b import and the `frf.uff` export.
//!
//! Fixtures are built byte by byte by a writer in this file (not the
//! library's): big- and little-endian 58b in both precisions, and the
//! exporters' quirks (CRLF / LF / CR line ends, a line end before the closing
//! `-1`, header byte counts that disagree with record 7, a 4-byte uneven
//! abscissa, trailing blanks, blank lines, other datasets around). The
//! reference Python implementation, pyuff (pinned in `.ci/run`), writes files
//! hystid must read as pyuff reads them, and reads hystid's FRF export
//! (`tests/interop/uff_pyuff_*.py`); without pyuff those two tests say so and
//! pass, except under CI.

use crate::cli::{hystid, text};
use hystid::extract::{Direction, FrfLevel, FrfPoint, NonlinearFrf};
use hystid::harmonics::Quantity;
use hystid::import::uff::{Abscissa, Ordinate, UffFile, parse};
use hystid::import::{ChannelSpec, Column, ImportSpec, SampleRateSource, import};
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::path::{Path, PathBuf};
use std::process::Command;

// ---------------------------------------------------------------------------
// A UFF writer of the test's own

/// One time record to write.
#[derive(Clone)]
pub(crate) struct Rec {
    id1: &'static str,
    function_type: i64,
    node: i64,
    dir: i64,
    data_type: i64,
    units: &'static str,
    dt: &'static str,
    values: Vec<f64>,
    /// An uneven abscissa (stored beside the values).
    x: Option<Vec<f64>>,
}

/// How the values are stored.
#[derive(Clone, Copy)]
pub(crate) enum Store {
    /// ASCII, double precision, shortest round-trip text, blank-separated.
    Ascii,
    /// 58b.
    Binary {
        big: bool,
        single: bool,
        /// The 58b line's byte count (None: the right one).
        declared: Option<u64>,
        /// An uneven abscissa as 4-byte floats beside 8-byte values.
        x_single: bool,
        /// Bytes between the data and the closing `    -1`.
        before_close: &'static [u8],
    },
}

const LE_SINGLE: Store = Store::Binary {
    big: false,
    single: true,
    declared: None,
    x_single: false,
    before_close: b"",
};

pub(crate) fn bin(big: bool, single: bool) -> Store {
    Store::Binary {
        big,
        single,
        declared: None,
        x_single: false,
        before_close: b"",
    }
}

pub(crate) fn rec(id1: &'static str, data_type: i64, units: &'static str, values: Vec<f64>) -> Rec {
    Rec {
        id1,
        function_type: 1,
        node: 1,
        dir: 3,
        data_type,
        units,
        dt: "3.12500E-04",
        values,
        x: None,
    }
}

/// Lines padded with blanks to 80 columns (as Testlab writes them) when
/// `pad`, joined by `eol`.
fn lines(ls: &[String], eol: &str, pad: bool) -> Vec<u8> {
    let mut out = Vec::new();
    for l in ls {
        out.extend(l.as_bytes());
        if pad {
            out.extend(std::iter::repeat_n(b' ', 80usize.saturating_sub(l.len())));
        }
        out.extend(eol.as_bytes());
    }
    out
}

pub(crate) fn dataset58(r: &Rec, store: Store, eol: &str, pad: bool) -> Vec<u8> {
    let n = r.values.len();
    let (ord, width, per_x) = match store {
        Store::Ascii => (4, 8, 8),
        Store::Binary {
            single, x_single, ..
        } => {
            let w = if single { 4 } else { 8 };
            (if single { 2 } else { 4 }, w, if x_single { 4 } else { w })
        }
    };
    let per = width + if r.x.is_some() { per_x } else { 0 };
    let mut head = vec!["    -1".to_string()];
    match store {
        Store::Ascii => head.push("    58".into()),
        Store::Binary { big, declared, .. } => head.push(format!(
            "{:6}b{:6}{:6}{:12}{:12}{:6}{:6}{:12}{:12}",
            58,
            if big { 2 } else { 1 },
            2,
            11,
            declared.unwrap_or((n * per) as u64),
            0,
            0,
            0,
            0
        )),
    }
    head.extend([r.id1, "NONE", "NONE", "NONE", "NONE"].map(String::from));
    head.push(format!(
        "{:5}{:10}{:5}{:10} {:>10}{:10}{:4} {:>10}{:10}{:4}",
        r.function_type, 1, 0, 0, r.id1, r.node, r.dir, "NONE", 0, 0
    ));
    let even = r.x.is_none();
    head.push(format!(
        "{:10}{:10}{:10}{:>13}{:>13}{:>13}",
        ord,
        n,
        u8::from(even),
        if even { "0.00000E+00" } else { "0.0" },
        if even { r.dt } else { "0.0" },
        "0.00000E+00"
    ));
    for (t, label, units) in [
        (17, "Time", "s"),
        (r.data_type, r.id1, r.units),
        (0, "NONE", "NONE"),
        (0, "NONE", "NONE"),
    ] {
        head.push(format!(
            "{:10}{:5}{:5}{:5} {:<20} {:<20}",
            t, 0, 0, 0, label, units
        ));
    }
    let mut out = lines(&head, eol, pad);
    match store {
        Store::Ascii => {
            let mut ls = Vec::new();
            for (k, v) in r.values.iter().enumerate() {
                match &r.x {
                    Some(x) => ls.push(format!("{:>24e} {:>24e}", x[k], v)),
                    None => ls.push(format!("{v:>24e}")),
                }
            }
            // three values a line, the last line short
            let joined: Vec<String> = ls.chunks(3).map(|c| c.concat()).collect();
            out.extend(lines(&joined, eol, false));
            out.extend(format!("    -1{eol}").as_bytes());
        }
        Store::Binary {
            big,
            single,
            x_single,
            before_close,
            ..
        } => {
            let put = |out: &mut Vec<u8>, v: f64, four: bool| {
                if four {
                    let b = v as f32;
                    out.extend(if big {
                        b.to_be_bytes()
                    } else {
                        b.to_le_bytes()
                    });
                } else {
                    out.extend(if big {
                        v.to_be_bytes()
                    } else {
                        v.to_le_bytes()
                    });
                }
            };
            for (k, &v) in r.values.iter().enumerate() {
                if let Some(x) = &r.x {
                    put(&mut out, x[k], single || x_single);
                }
                put(&mut out, v, single);
            }
            out.extend(before_close);
            out.extend(format!("    -1{eol}").as_bytes());
        }
    }
    out
}

fn other_dataset(number: &str, body: &[&str], eol: &str) -> Vec<u8> {
    let mut ls = vec!["    -1".to_string(), number.to_string()];
    ls.extend(body.iter().map(|s| s.to_string()));
    ls.push("    -1".into());
    lines(&ls, eol, false)
}

/// A test signal whose f32 and f64 bytes hold line feeds and `-1` lookalikes.
pub(crate) fn signal(n: usize, amp: f64, phase: f64) -> Vec<f64> {
    let mut v: Vec<f64> = (0..n)
        .map(|k| amp * (2.0 * std::f64::consts::PI * 50.0 * k as f64 / 3200.0 + phase).sin())
        .collect();
    // a double whose little-endian bytes read "    -1\n@", a float "\n -1"
    v[5] = f64::from_le_bytes(*b"    -1\n@");
    v[6] = f32::from_le_bytes(*b"\n -1") as f64;
    v[7] = f64::from_be_bytes(*b"\r\n    -1");
    v
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn err_text<T: std::fmt::Debug>(r: hystid::Result<T>) -> String {
    let e = r.expect_err("expected an error");
    let mut s = e.to_string();
    let mut src = std::error::Error::source(&e);
    while let Some(c) = src {
        s.push_str(&format!(": {c}"));
        src = c.source();
    }
    s
}

fn assert_mentions(msg: &str, parts: &[&str]) {
    for p in parts {
        assert!(msg.contains(p), "`{p}` not in: {msg}");
    }
}

/// `bytes` with the first `count` occurrences of `from` replaced (the
/// binary data stays as it is).
fn replace_bytes(bytes: &[u8], from: &[u8], to: &[u8], count: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(bytes.len());
    let (mut i, mut done) = (0, 0);
    while i < bytes.len() {
        if done < count && bytes[i..].starts_with(from) {
            out.extend(to);
            i += from.len();
            done += 1;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    assert!(done > 0, "nothing replaced");
    out
}

fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

fn real(o: &Ordinate) -> &[f64] {
    match o {
        Ordinate::Real(v) => v,
        Ordinate::Complex(_) => panic!("complex"),
    }
}

/// Force (big-endian double), acceleration in g (big-endian single),
/// velocity (little-endian double), displacement in mm (little-endian
/// single), after a dataset 151; CRLF, lines padded to 80 columns, a line
/// end before two of the closing `-1`s (Testlab).
fn mixed_binary_file() -> (Vec<u8>, [Vec<f64>; 4]) {
    let n = 640;
    let s = [
        signal(n, 120.0, 0.0),
        signal(n, 3.5, 0.4),
        signal(n, 0.02, 0.9),
        signal(n, 1.5, 1.3),
    ];
    let mut f = other_dataset(
        "   151",
        &[
            "model",
            "description",
            "app",
            "01-Jan-26 00:00:00",
            "x",
            "y",
            "z",
        ],
        "\r\n",
    );
    let quirky = |big, single| Store::Binary {
        big,
        single,
        declared: None,
        x_single: false,
        before_close: b"\r\n",
    };
    let mut a = rec("Acc", 12, "g", s[1].clone());
    a.node = 2;
    a.dir = -1;
    let mut v = rec("Vel", 11, "m/s", s[2].clone());
    v.node = 3;
    v.dir = 2;
    let mut d = rec("Disp", 8, "mm", s[3].clone());
    d.node = 4;
    f.extend(dataset58(
        &rec("Force", 13, "N", s[0].clone()),
        quirky(true, false),
        "\r\n",
        true,
    ));
    f.extend(dataset58(&a, bin(true, true), "\r\n", true));
    f.extend(dataset58(&v, quirky(false, false), "\r\n", true));
    f.extend(dataset58(&d, bin(false, true), "\r\n", true));
    (f, s)
}

fn f32s(v: &[f64]) -> Vec<f64> {
    v.iter().map(|&x| x as f32 as f64).collect()
}

#[test]
fn binary_58b_big_and_little_endian_both_precisions_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    let (bytes, s) = mixed_binary_file();
    let path = write(dir.path(), "mixed.uff", &bytes);
    let file = UffFile::open(&path).unwrap();
    assert_eq!(
        file.datasets.iter().map(|d| d.number).collect::<Vec<_>>(),
        [151, 58, 58, 58, 58]
    );
    let expect = [s[0].clone(), f32s(&s[1]), s[2].clone(), f32s(&s[3])];
    for ((d, f), (want, big)) in file
        .functions()
        .zip(expect.iter().zip([true, true, false, false]))
    {
        assert!(d.binary);
        assert!(same_bits(real(&f.ordinate), want), "{}", d.describe());
        assert_eq!(f.binary.unwrap().big_endian, big);
    }
    let imported = import(&path, &ImportSpec::default()).unwrap();
    let rec = &imported.recording;
    assert_eq!(rec.meta.sample_rate_hz, 3200.0);
    let names: Vec<&str> = rec.meta.channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "force_1+Z",
            "acceleration_2-X",
            "velocity_3+Y",
            "displacement_4+Z"
        ]
    );
    let quantities: Vec<Quantity> = rec.meta.channels.iter().map(|c| c.quantity).collect();
    assert_eq!(
        quantities,
        [
            Quantity::Force,
            Quantity::Acceleration,
            Quantity::Velocity,
            Quantity::Displacement
        ]
    );
    // SI: the file's values times the unit's factor, exactly as computed
    let scaled = |v: &[f64], k: f64| v.iter().map(|x| x * k).collect::<Vec<_>>();
    assert!(same_bits(&rec.channels[0], &expect[0]));
    assert!(same_bits(&rec.channels[1], &scaled(&expect[1], 9.80665)));
    assert!(same_bits(&rec.channels[2], &expect[2]));
    assert!(same_bits(&rec.channels[3], &scaled(&expect[3], 1e-3)));
    assert_eq!(imported.notes.len(), 1, "{:?}", imported.notes);
    assert_mentions(&imported.notes[0], &["dataset 1", "151", "skipped"]);
    let meta = &rec.meta.metadata["import"];
    assert_eq!(meta["datasets"]["acceleration_2-X"]["units_label"], "g");
    assert_eq!(meta["datasets"]["acceleration_2-X"]["dataset"], 3);
    assert_eq!(
        meta["datasets"]["force_1+Z"]["storage"],
        "58b big-endian double"
    );
    assert_eq!(meta["channels"]["velocity_3+Y"], "dataset 4 (3+Y)");
}

#[test]
fn testlab_and_pyuff_quirks_read_the_same_values() {
    let dir = tempfile::tempdir().unwrap();
    let y = signal(500, 2.0, 0.3);
    let want = f32s(&y);
    let r = rec("Force", 13, "N", y.clone());
    let with = |declared: Option<u64>, before_close: &'static [u8]| Store::Binary {
        big: false,
        single: true,
        declared,
        x_single: false,
        before_close,
    };
    let cases: Vec<(&str, Vec<u8>)> = vec![
        // Testlab (pyuff issues 61, 88, 103): CRLF, `\r\n` before `-1`
        (
            "crlf_before_close",
            dataset58(&r, with(None, b"\r\n"), "\r\n", true),
        ),
        // pyuff issue 38: a lone `\n` after the data
        (
            "lf_before_close",
            dataset58(&r, with(None, b"\n"), "\n", false),
        ),
        // header byte counts that disagree with record 7
        (
            "declared_zero",
            dataset58(&r, with(Some(0), b""), "\n", false),
        ),
        (
            "declared_double",
            dataset58(&r, with(Some(4000), b""), "\r\n", false),
        ),
        // old Mac line ends, blank lines and blanks after the file
        ("cr_only", {
            let mut b = b"\r\r".to_vec();
            b.extend(dataset58(&r, LE_SINGLE, "\r", true));
            b.extend(b"\r  \r\t\r");
            b
        }),
    ];
    for (name, bytes) in &cases {
        let f = parse(Path::new(name), bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
        let g = f.datasets[0].function.as_ref().unwrap();
        assert!(same_bits(real(&g.ordinate), &want), "{name}");
        assert_eq!(g.binary.unwrap().data_bytes, 2000, "{name}");
        assert_eq!(g.ordinate_axis.units, "N", "{name}");
    }
    // two datasets back to back, the second after blank lines and a stray
    // `-1` (fix_58b's case in pyuff)
    let mut two = cases[0].1.clone();
    two.extend(b"\r\n    -1\r\n\r\n");
    two.extend(&cases[2].1);
    let f = parse(Path::new("two"), &two).unwrap();
    assert_eq!(f.functions().count(), 2);
    // an uneven abscissa: double values beside 4-byte or 8-byte times (the
    // header's byte count says which)
    let x: Vec<f64> = (0..500).map(|k| k as f64 / 3200.0 + 1e-3).collect();
    for (x_single, declared) in [(true, 12 * 500), (false, 16 * 500)] {
        let mut r = rec("Acc", 12, "m/s2", y.clone());
        r.x = Some(x.clone());
        let bytes = dataset58(
            &r,
            Store::Binary {
                big: true,
                single: false,
                declared: Some(declared),
                x_single,
                before_close: b"",
            },
            "\n",
            false,
        );
        let f = parse(Path::new("uneven"), &bytes).unwrap();
        let g = f.datasets[0].function.as_ref().unwrap();
        assert!(same_bits(real(&g.ordinate), &y));
        let Abscissa::Uneven(gx) = &g.abscissa else {
            panic!("even")
        };
        let want_x = if x_single { f32s(&x) } else { x.clone() };
        assert!(same_bits(gx, &want_x));
        assert_eq!(g.binary.unwrap().single_abscissa, x_single);
        // and the import takes the rate from it (least squares)
        let p = write(dir.path(), "uneven.uff", &bytes);
        let rec = import(&p, &ImportSpec::default()).unwrap().recording;
        let fs = rec.meta.sample_rate_hz;
        // 4-byte times carry 24 bits: the fitted spacing within 1e-7
        assert!((fs - 3200.0).abs() < 3200.0 * 1e-7, "{fs}");
    }
}

#[test]
fn ascii_files_with_other_datasets_and_an_frf_beside_the_time_records() {
    let dir = tempfile::tempdir().unwrap();
    let f = signal(301, 40.0, 0.1);
    let a = signal(301, 0.7, 0.8);
    for eol in ["\n", "\r\n"] {
        let mut bytes = other_dataset(
            "   164",
            &["         1SI", "    1.0  1.0  1.0", "  273.15"],
            eol,
        );
        let mut acc = rec("accel", 0, "m/s^2", a.clone());
        acc.node = 0;
        acc.dir = 0;
        acc.dt = "3.125e-4";
        bytes.extend(dataset58(&acc, Store::Ascii, eol, false));
        bytes.extend(b"\n\n");
        bytes.extend(other_dataset(
            "  2411",
            &["         1         1         1        11", "  0.0 0.0 0.0"],
            eol,
        ));
        // an FRF (function type 4): not a channel
        let mut frf = rec("FRF", 12, "m/s2", a.clone());
        frf.function_type = 4;
        bytes.extend(dataset58(&frf, Store::Ascii, eol, false));
        bytes.extend(dataset58(
            &rec("drive", 13, "kN", f.clone()),
            Store::Ascii,
            eol,
            true,
        ));
        let path = write(dir.path(), "ascii.unv", &bytes);
        let imp = import(&path, &ImportSpec::default()).unwrap();
        let r = &imp.recording;
        // the force first (the reference), then the acceleration (a general
        // data type, its quantity from the units label)
        assert_eq!(r.meta.channels[0].name, "force_1+Z");
        assert_eq!(r.meta.channels[1].name, "accel");
        assert_eq!(r.meta.channels[1].quantity, Quantity::Acceleration);
        let k: Vec<f64> = f.iter().map(|v| v * 1e3).collect();
        assert!(same_bits(&r.channels[0], &k));
        assert!(same_bits(&r.channels[1], &a));
        assert_eq!(r.meta.sample_rate_hz, 3200.0);
        let notes = imp.notes.join("\n");
        assert_mentions(
            &notes,
            &[
                "dataset 1 (164",
                "dataset 3 (2411",
                "dataset 4 (58",
                "function type 4 (frequency response function)",
            ],
        );
        // chosen by number or name; the FRF refused by name
        let spec = |c: Vec<ChannelSpec>| ImportSpec::new(c, SampleRateSource::Auto);
        let r = import(
            &path,
            &spec(vec![
                ChannelSpec::new(Column::Index(5), Quantity::Force).name("f"),
                ChannelSpec::new("accel", Quantity::Acceleration).scale(2.0),
            ]),
        )
        .unwrap()
        .recording;
        // an override's scale applies to the file's values (kN not applied)
        assert!(same_bits(&r.channels[0], &f));
        assert!(same_bits(
            &r.channels[1],
            &a.iter().map(|v| v * 2.0).collect::<Vec<_>>()
        ));
        let e = err_text(import(
            &path,
            &spec(vec![ChannelSpec::new("#4", Quantity::Force)]),
        ));
        assert_mentions(&e, &["#4", "no dataset 58", "#K"]);
        let e = err_text(import(
            &path,
            &spec(vec![ChannelSpec::new(Column::Index(4), Quantity::Force)]),
        ));
        assert_mentions(
            &e,
            &[
                "ascii.unv",
                "dataset 4 (58",
                "\"FRF\"",
                "not a time response",
            ],
        );
        let e = err_text(import(
            &path,
            &spec(vec![ChannelSpec::new(Column::Index(1), Quantity::Force)]),
        ));
        assert_mentions(&e, &["dataset 1 (164", "not a dataset 58"]);
    }
}

#[test]
fn malformed_files_are_errors_naming_the_dataset_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let (good, _) = mixed_binary_file();
    let y: Vec<f64> = (0..10).map(|k| k as f64 * 0.25 - 1.0).collect();
    let ascii = String::from_utf8(dataset58(
        &rec("Force", 13, "N", y.clone()),
        Store::Ascii,
        "\n",
        false,
    ))
    .unwrap();
    // lines: 1 -1, 2 58, 3-7 ID lines, 8 record 6, 9 record 7, 10-13
    // records 8-11, 14-17 the values (3 a line), 18 -1
    let line_15 = ascii.lines().nth(14).unwrap().to_string();
    let cases: Vec<(&str, Vec<u8>, Vec<&str>)> = vec![
        (
            "truncated binary",
            good[..good.len() - 700].to_vec(),
            vec![
                "dataset 5 (58b at line",
                "\"Disp\"",
                "line",
                "the file ends",
                "bytes into the data",
            ],
        ),
        (
            "wrong record length",
            replace_bytes(
                &good,
                b"       640         1",
                b"       700         1",
                usize::MAX,
            ),
            vec![],
        ),
        (
            "bad number",
            ascii
                .replace(&line_15, &line_15.replacen('.', ".5.", 1))
                .into_bytes(),
            vec![
                "dataset 1 (58 at line 2, \"Force\")",
                "line 15",
                "is not a number",
                "value 4 of 10",
            ],
        ),
        (
            "too few values",
            ascii
                .replace("        10         1", "        12         1")
                .into_bytes(),
            vec![
                "line 18",
                "closes (`-1`) after 10 of 12 numbers",
                "real double, even abscissa",
            ],
        ),
        (
            "too many values",
            ascii
                .replace("        10         1", "         8         1")
                .into_bytes(),
            vec!["line 16", "more than the 8"],
        ),
        (
            "no closing -1",
            ascii.strip_suffix("    -1\n").unwrap().as_bytes().to_vec(),
            vec![
                "dataset 1 (58 at line 2",
                "line 17",
                "ends before the dataset's closing",
            ],
        ),
        (
            "cut in the header",
            ascii.as_bytes()[..300].to_vec(),
            vec!["dataset 1", "the file ends in the header: expected record"],
        ),
        (
            "bad record 7",
            ascii
                .replace("         4        10", "         3        10")
                .into_bytes(),
            vec!["line 9", "ordinate data type 3 is not 2, 4, 5 or 6"],
        ),
        (
            "bad record 6",
            ascii
                .replace("    1         1", "    x         1")
                .into_bytes(),
            vec!["line 8", "record 6", "Format(2(I5,I10)"],
        ),
        (
            "IBM floats",
            replace_bytes(
                &good,
                b"     2     2          11",
                b"     2     3          11",
                1,
            ),
            vec![
                "dataset 2 (58b at line",
                "floating-point format 3 (IBM 5/370) is not supported",
            ],
        ),
        (
            "not a UFF file",
            b"time,force\n0,1\n".to_vec(),
            vec!["dataset 1", "line 1", "expected `    -1`"],
        ),
    ];
    for (what, bytes, want) in cases {
        let e = err_text(parse(Path::new("bad.uff"), &bytes));
        assert_mentions(&e, &["bad.uff"]);
        if what == "wrong record length" {
            // record 7 of every binary dataset says 700: each one's data
            // ends short of its closing -1
            assert_mentions(
                &e,
                &[
                    "dataset 2 (58b at line",
                    "declares 700 values",
                    "no closing `-1`",
                    "it follows the 58b line's 5120 bytes, 640 values",
                ],
            );
        }
        assert_mentions(&e, &want);
        eprintln!("{what}: {e}");
    }
    // channels that are not sampled together
    let mut two = dataset58(&rec("Force", 13, "N", y.clone()), Store::Ascii, "\n", false);
    let mut short = rec("Acc", 12, "m/s2", y[..8].to_vec());
    short.node = 2;
    two.extend(dataset58(&short, Store::Ascii, "\n", false));
    let mut slow = rec("Vel", 11, "m/s", y.clone());
    slow.dt = "6.25000E-04";
    slow.node = 3;
    let mut three = dataset58(&rec("Force", 13, "N", y.clone()), Store::Ascii, "\n", false);
    three.extend(dataset58(&slow, Store::Ascii, "\n", false));
    for (name, bytes, want) in [
        ("len.uff", two, "8 values, but dataset 1"),
        (
            "rate.uff",
            three,
            "sample spacing 0.000625 s, but dataset 1",
        ),
    ] {
        let p = write(dir.path(), name, &bytes);
        let e = err_text(import(&p, &ImportSpec::default()));
        assert_mentions(&e, &[name, "dataset 2", want]);
    }
    // the command line: exit 2, the file and the dataset named, nothing written
    let p = write(dir.path(), "broken.uff", &good[..good.len() - 700]);
    let out = dir.path().join("o");
    let o = hystid(&[
        "import",
        p.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert_mentions(&text(&o), &["broken.uff", "dataset 5", "line"]);
    assert!(!dir.path().join("o.json").exists());
}

#[test]
fn no_byte_sequence_makes_the_reader_panic() {
    // every truncation of a binary + ASCII file, then random damage: each
    // outcome is a file or an error naming it, never a panic
    let (mut bytes, _) = mixed_binary_file();
    bytes.extend(dataset58(
        &rec("Force", 13, "N", vec![1.0, -2.0, 3.0, 4.5]),
        Store::Ascii,
        "\n",
        false,
    ));
    let name = Path::new("damaged.uff");
    let (mut ok, mut failed) = (0, 0);
    for cut in 0..bytes.len() {
        match parse(name, &bytes[..cut]) {
            Ok(f) => {
                // only whole datasets (and blanks after them) read
                assert!(f.datasets.len() < 6 || cut + 1 >= bytes.len(), "cut {cut}");
                ok += 1;
            }
            Err(e) => {
                assert!(e.to_string().contains("damaged.uff"), "{e}");
                failed += 1;
            }
        }
    }
    use rand::RngExt;
    let mut rng = ChaCha8Rng::seed_from_u64(58);
    for trial in 0..3000 {
        let mut b = bytes.clone();
        for _ in 0..rng.random_range(1..5) {
            let i = rng.random_range(0..b.len());
            match trial % 3 {
                0 => b[i] ^= 1 << rng.random_range(0..8),
                1 => b[i] = *b"-1 \n\r0589b.E+".get(rng.random_range(0..13)).unwrap(),
                _ => {
                    b.remove(i);
                }
            }
        }
        match parse(name, &b) {
            Ok(_) => ok += 1,
            Err(e) => {
                assert!(e.to_string().contains("damaged.uff"), "{e}");
                failed += 1;
            }
        }
    }
    eprintln!("damaged UFF files: {ok} read, {failed} errors");
    assert!(
        failed > bytes.len() * 9 / 10,
        "nearly every cut must fail: {failed}"
    );
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(400))]
    /// Any bytes after a 58b header line, or in place of a whole file.
    #[test]
    fn arbitrary_bytes_never_panic(
        tail in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..600),
        binary in proptest::prelude::any::<bool>(),
    ) {
        let mut b = if binary {
            b"    -1\n    58b     2     2          11          16     0     0           0           0\n".to_vec()
        } else {
            Vec::new()
        };
        b.extend(&tail);
        let _ = parse(Path::new("p.uff"), &b);
    }
}

#[test]
fn the_command_line_imports_uff_without_channel_flags() {
    let dir = tempfile::tempdir().unwrap();
    let (bytes, s) = mixed_binary_file();
    let p = write(dir.path(), "test.58", &bytes);
    let out = dir.path().join("rec");
    let o = hystid(&[
        "import",
        p.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert_mentions(&text(&o), &["note: dataset 1 (151", "4 channels"]);
    let r = hystid::record::read_recording(&dir.path().join("rec.json")).unwrap();
    assert_eq!(r.meta.sample_rate_hz, 3200.0);
    assert_eq!(r.meta.channels.len(), 4);
    // float32 WAV: the big-endian double force to float precision
    let worst = r.channels[0]
        .iter()
        .zip(&s[0])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst <= 120.0 * 2f64.powi(-24), "{worst}");
    // the overrides still apply
    let o = hystid(&[
        "import",
        p.to_str().unwrap(),
        "--out",
        dir.path().join("two").to_str().unwrap(),
        "-c",
        "drive=#2:force",
        "-c",
        "acc=acceleration_2-X:acceleration*9.80665",
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let r = hystid::record::read_recording(&dir.path().join("two.json")).unwrap();
    let names: Vec<&str> = r.meta.channels.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["drive", "acc"]);
    // identical input, identical bytes
    let o = hystid(&[
        "import",
        p.to_str().unwrap(),
        "--out",
        dir.path().join("again").to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success());
    for ext in ["wav", "json"] {
        assert_eq!(
            std::fs::read(dir.path().join(format!("rec.{ext}"))).unwrap(),
            std::fs::read(dir.path().join(format!("again.{ext}"))).unwrap()
        );
    }
}

// ---------------------------------------------------------------------------
// pyuff, the reference implementation

/// Whether pyuff and numpy import; under CI they must.
fn pyuff_available() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import pyuff, numpy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        eprintln!("SKIPPED: pyuff not installed (pip install pyuff==2.5.8)");
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set: pyuff must be installed (.ci/run)"
        );
    }
    ok
}

fn script(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/interop")
        .join(name)
}

fn floats(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// Largest |a - b| / |b| (0 where both are 0).
fn worst_relative(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| if x == y { 0.0 } else { (x - y).abs() / y.abs() })
        .fold(0.0, f64::max)
}

#[test]
fn files_written_by_pyuff_read_as_pyuff_reads_them() {
    if !pyuff_available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let o = Command::new("python3")
        .arg(script("uff_pyuff_write.py"))
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "uff_pyuff_write.py: {}", text(&o));
    let expect: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("expect.json")).unwrap()).unwrap();
    let written = &expect["written"];
    let originals = [
        floats(&written["force"]),
        floats(&written["acc"]),
        floats(&written["vel"]),
        floats(&written["disp"]),
    ];
    let t = floats(&written["t"]);
    for (name, e) in expect["files"].as_object().unwrap() {
        let path = dir.path().join(name);
        if !e["pyuff_reads_it"].as_bool().unwrap() {
            // pyuff 2.5 writes 58b "single precision" as doubles and cannot
            // read it back: hystid says why
            let msg = err_text(UffFile::open(&path));
            assert_mentions(&msg, &[name, "no closing `-1`", "double precision"]);
            eprintln!("{name}: pyuff cannot read it back; hystid: {msg}");
            continue;
        }
        let file = UffFile::open(&path).unwrap();
        let sets = e["read"].as_array().unwrap();
        assert_eq!(file.datasets.len(), sets.len(), "{name}");
        let mut k58 = 0;
        for (d, s) in file.datasets.iter().zip(sets) {
            assert_eq!(d.number as i64, s["type"].as_i64().unwrap(), "{name}");
            let Some(f) = &d.function else { continue };
            let here = format!("{name} {}", d.describe());
            // the same metadata
            for (k, id) in ["id1", "id2", "id3", "id4", "id5"].iter().enumerate() {
                assert_eq!(f.id_lines[k], s[id].as_str().unwrap().trim(), "{here}");
            }
            assert_eq!(f.function_type, s["func_type"].as_i64().unwrap());
            assert_eq!(f.function_id, s["func_id"].as_i64().unwrap());
            assert_eq!(f.response.node, s["rsp_node"].as_i64().unwrap());
            assert_eq!(f.response.direction, s["rsp_dir"].as_i64().unwrap());
            assert_eq!(
                f.response.entity,
                s["rsp_ent_name"].as_str().unwrap().trim()
            );
            assert_eq!(f.ordinate_data_type(), s["ord_data_type"].as_i64().unwrap());
            assert_eq!(
                f.ordinate_axis.data_type,
                s["ordinate_spec_data_type"].as_i64().unwrap()
            );
            assert_eq!(
                f.ordinate_axis.units,
                s["ordinate_axis_units_lab"].as_str().unwrap().trim()
            );
            assert_eq!(
                f.ordinate_axis.label,
                s["ordinate_axis_lab"].as_str().unwrap().trim()
            );
            assert_eq!(f.abscissa_axis.data_type, 17);
            // the same numbers, bit for bit (both read the same decimal text
            // or bytes), abscissa included
            let y = real(&f.ordinate);
            assert!(same_bits(y, &floats(&s["re"])), "{here}");
            let x: Vec<f64> = match &f.abscissa {
                Abscissa::Even {
                    start, increment, ..
                } => {
                    assert_eq!(*start, s["abscissa_min"].as_f64().unwrap(), "{here}");
                    assert_eq!(*increment, s["abscissa_inc"].as_f64().unwrap(), "{here}");
                    (0..y.len()).map(|k| start + k as f64 * increment).collect()
                }
                Abscissa::Uneven(x) => {
                    assert!(same_bits(x, &floats(&s["x"])), "{here}");
                    x.clone()
                }
            };
            // and the written data to the precision of the format
            let tol = if name.starts_with("binary") {
                0.0
            } else if name == "ascii_single.uff" {
                5e-6 // 6E13.5: six significant digits
            } else {
                5e-12 // pyuff's %20.11e: twelve
            };
            let original = &originals[k58];
            let worst = worst_relative(y, original);
            assert!(worst <= tol * (1.0 + 1e-9), "{here}: {worst:e} > {tol:e}");
            // the abscissa (record 7's increment, or stored times) is E13.5
            // in every case: six significant digits
            let worst_t = worst_relative(&x[1..], &t[1..]);
            assert!(worst_t <= 5e-6, "{here}: time off by {worst_t:e}");
            assert_eq!(x[0], 0.0);
            eprintln!(
                "{here}: data within {worst:.2e} of what pyuff was given, bit-equal to pyuff's reading"
            );
            k58 += 1;
        }
        // into a recording: channels, units and rate from the file
        let imp = import(&path, &ImportSpec::default()).unwrap();
        let r = &imp.recording;
        assert_eq!(r.meta.channels[0].name, "force_1+Z", "{name}");
        assert_eq!(r.meta.channels[0].quantity, Quantity::Force);
        let fs = r.meta.sample_rate_hz;
        if name == "ascii_uneven.uff" {
            // least squares over times printed with six digits
            assert!((fs - 2048.0).abs() < 2048.0 * 1e-6, "{name}: {fs}");
        } else {
            // 4.88281E-04 is 1/2048 s to its printed digits
            assert_eq!(fs, 2048.0, "{name}");
        }
        if name == "ascii_double.uff" {
            let q: Vec<(String, Quantity, f64)> = r
                .meta
                .channels
                .iter()
                .map(|c| (c.name.clone(), c.quantity, c.scale))
                .collect();
            assert_eq!(
                q,
                [
                    ("force_1+Z".to_string(), Quantity::Force, 1.0),
                    ("acceleration_2-X".into(), Quantity::Acceleration, 9.80665),
                    ("velocity_3+Y".into(), Quantity::Velocity, 1e-3),
                    ("displacement_4+Z".into(), Quantity::Displacement, 1e-6),
                ]
            );
            assert_eq!(imp.notes.len(), 2, "{:?}", imp.notes);
            let worst = worst_relative(
                &r.channels[1],
                &originals[1].iter().map(|v| v * 9.80665).collect::<Vec<_>>(),
            );
            assert!(worst < 1e-11, "{worst}");
        }
    }
}

/// FRFs of two levels (one swept down, frequencies out of order), four
/// harmonics, values across 15 decades with both signs.
fn awkward_frf() -> NonlinearFrf {
    let level = |level: f64, direction: Direction, freqs: &[f64]| FrfLevel {
        level,
        direction,
        points: freqs
            .iter()
            .enumerate()
            .map(|(i, &f)| FrfPoint {
                frequency_hz: f,
                force_amplitude: level * (1.0 + 1e-3 * i as f64),
                h: (0..4)
                    .map(|h| {
                        let m = 10f64.powi(-(h as i32) * 4 - 3) * (1.0 + i as f64 / 7.0);
                        Complex64::from_polar(m, 0.37 * (i * (h + 1)) as f64 - 1.3)
                    })
                    .collect(),
                std_error: vec![1e-6; 4],
                force_distortion: Vec::new(),
                blocks: 4,
                settle_periods: 10,
                settled: true,
                subharmonic: None,
            })
            .collect(),
    };
    NonlinearFrf {
        response: Quantity::Acceleration,
        reference: Quantity::Force,
        max_harmonic: 3,
        levels: vec![
            level(
                5.0,
                Direction::Up,
                &[100.0, 102.539_062_5, 105.1, 250.125, 1_234.567_89],
            ),
            level(
                246.048,
                Direction::Down,
                &[350.0, 312.5, 275.333_333_333, 200.0, 150.0, 100.000_1],
            ),
        ],
    }
}

#[test]
fn frf_export_reads_back_in_pyuff_with_the_same_values_and_ids() {
    let frf = awkward_frf();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frf.uff");
    hystid::analysis::frf_uff::write_frf_uff(&path, &frf).unwrap();
    // byte-identical for the same FRFs
    let again = dir.path().join("again.uff");
    hystid::analysis::frf_uff::write_frf_uff(&again, &frf).unwrap();
    assert_eq!(
        std::fs::read(&path).unwrap(),
        std::fs::read(&again).unwrap()
    );
    // hystid reads its own export
    let own = UffFile::open(&path).unwrap();
    assert_eq!(own.datasets.len(), 2 * 4);
    if !pyuff_available() {
        return;
    }
    let json = dir.path().join("frf.json");
    let o = Command::new("python3")
        .arg(script("uff_pyuff_read.py"))
        .arg(&path)
        .arg(&json)
        .output()
        .unwrap();
    assert!(o.status.success(), "uff_pyuff_read.py: {}", text(&o));
    let sets: Vec<serde_json::Value> =
        serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(sets.len(), 8);
    let mut worst = 0.0f64;
    for (k, (s, (d, f))) in sets.iter().zip(own.functions()).enumerate() {
        let l = &frf.levels[k / 4];
        let h = k % 4;
        let dir = if l.direction == Direction::Up {
            "up"
        } else {
            "down"
        };
        assert_eq!(s["type"], 58);
        assert_eq!(s["func_type"], 4);
        assert_eq!(s["func_id"], k as i64 + 1);
        assert_eq!(s["ver_num"], h as i64);
        assert_eq!(
            s["id1"].as_str().unwrap().trim(),
            format!("H{h} at level {} N ({dir})", l.level)
        );
        assert_eq!(
            s["id4"].as_str().unwrap().trim(),
            format!("level {} N, sweep {dir}", l.level)
        );
        assert_eq!(s["id5"].as_str().unwrap().trim(), format!("harmonic {h}"));
        assert_eq!(s["z_axis_value"].as_f64().unwrap(), l.level);
        assert_eq!(s["ord_data_type"], 6);
        assert_eq!(s["abscissa_spacing"], 0);
        assert_eq!(
            (s["rsp_node"].as_i64(), s["rsp_dir"].as_i64()),
            (Some(1), Some(3))
        );
        assert_eq!(s["abscissa_spec_data_type"], 18);
        assert_eq!(s["ordinate_spec_data_type"], 12);
        assert_eq!(
            s["ordinate_axis_units_lab"].as_str().unwrap().trim(),
            "m/s2"
        );
        assert_eq!(s["orddenom_spec_data_type"], 13);
        assert_eq!(s["orddenom_axis_units_lab"].as_str().unwrap().trim(), "N");
        // pyuff and hystid read the same bits from the text
        let (Abscissa::Uneven(x), Ordinate::Complex(y)) = (&f.abscissa, &f.ordinate) else {
            panic!("{}", d.describe())
        };
        assert!(same_bits(x, &floats(&s["x"])));
        let re: Vec<f64> = y.iter().map(|c| c.re).collect();
        let im: Vec<f64> = y.iter().map(|c| c.im).collect();
        assert!(same_bits(&re, &floats(&s["re"])));
        assert!(same_bits(&im, &floats(&s["im"])));
        // within the printed digits of the FRFs written, frequencies ascending
        let mut points: Vec<&FrfPoint> = l.points.iter().collect();
        points.sort_by(|a, b| a.frequency_hz.total_cmp(&b.frequency_hz));
        for ((x, y), p) in x.iter().zip(y).zip(points) {
            assert!((x - p.frequency_hz).abs() <= 5e-6 * p.frequency_hz, "{x}");
            let e = (y - p.h[h]).norm() / p.h[h].norm();
            worst = worst.max(e);
        }
    }
    // E20.12: thirteen significant digits per part
    assert!(worst <= 5e-13, "{worst:e}");
    eprintln!("frf.uff read by pyuff: H within {worst:.2e} (relative) of the FRFs written");
}
