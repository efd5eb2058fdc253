//! Tests of the UFF reader and writer: records, precisions, binary layouts and
//! malformed files.

use super::cursor::resolution;
use super::write::id_text;
use super::*;
use num_complex::Complex64;
use std::path::Path;

fn p() -> &'static Path {
    Path::new("t.uff")
}

fn time_record(values: Vec<f64>, precision: Precision) -> Function {
    Function {
        id_lines: [
            "Force".into(),
            "run 1".into(),
            "NONE".into(),
            "".into(),
            "".into(),
        ],
        function_type: 1,
        function_id: 7,
        version: 0,
        load_case: 0,
        response: Dof {
            entity: "drive".into(),
            node: 12,
            direction: -3,
        },
        reference: Dof {
            entity: "NONE".into(),
            node: 0,
            direction: 0,
        },
        precision,
        abscissa: Abscissa::Even {
            start: 0.0,
            increment: 1.0 / 4096.0,
            increment_resolution: 0.0,
        },
        z_axis_value: 0.0,
        abscissa_axis: Axis::new(17, "Time", "s"),
        ordinate_axis: Axis::new(13, "Force", "N"),
        denominator_axis: Axis::unused(),
        z_axis: Axis::unused(),
        ordinate: Ordinate::Real(values),
        binary: None,
    }
}

fn written(f: &Function) -> Vec<u8> {
    let mut v = Vec::new();
    write_ascii(&mut v, f).unwrap();
    v
}

#[test]
fn fortran_fields() {
    assert_eq!(fortran_e(0.0, 13, 5), "  0.00000E+00");
    assert_eq!(fortran_e(-1.5e-5, 13, 5), " -1.50000E-05");
    assert_eq!(fortran_e(-1.25e-100, 13, 5), "-1.25000E-100");
    assert_eq!(fortran_e(1.0 / 3.0, 20, 12), "  3.333333333333E-01");
    for s in [
        "1.5",
        "-2.5E+03",
        "2.5D-03",
        "0.12345-100",
        " 7 ",
        "1.0e5",
        "-0.5+07",
    ] {
        assert!(parse_real(s).is_some(), "{s}");
    }
    assert_eq!(parse_real("0.12345-100"), Some(0.12345e-100));
    assert_eq!(parse_real("-0.5+07"), Some(-0.5e7));
    assert_eq!(parse_real("2.5D-03"), Some(2.5e-3));
    for s in ["", "1.0e5-2.0e5", "abc", "1-", "--1", "1.0E+00-2.0E+00"] {
        assert_eq!(parse_real(s), None, "{s}");
    }
    assert_eq!(resolution("1.52588E-05"), 0.5e-10);
    assert_eq!(resolution("3.125e-4"), 0.5e-7);
    assert_eq!(resolution("0.001"), 0.5e-3);
}

#[test]
fn ascii_round_trip_every_case() {
    let y: Vec<f64> = (0..13)
        .map(|k| (k as f64 * 0.7).sin() * 10f64.powi(k - 6))
        .collect();
    for precision in [Precision::Single, Precision::Double] {
        for even in [true, false] {
            for complex in [false, true] {
                let mut f = time_record(y.clone(), precision);
                if !even {
                    f.abscissa = Abscissa::Uneven((0..13).map(|k| 100.0 + k as f64).collect());
                }
                if complex {
                    f.ordinate =
                        Ordinate::Complex(y.iter().map(|&v| Complex64::new(v, -2.0 * v)).collect());
                }
                let bytes = written(&f);
                let back = parse(p(), &bytes).unwrap();
                let g = back.datasets[0].function.as_ref().unwrap();
                assert_eq!(g.id_lines, f.id_lines.clone().map(|s| id_text(&s)));
                assert_eq!(g.response, f.response);
                assert_eq!(g.ordinate_axis, f.ordinate_axis);
                assert_eq!(g.function_id, 7);
                let tol = if precision == Precision::Single {
                    5e-6
                } else {
                    5e-13
                };
                let (a, b): (Vec<f64>, Vec<f64>) = match (&f.ordinate, &g.ordinate) {
                    (Ordinate::Real(a), Ordinate::Real(b)) => (a.clone(), b.clone()),
                    (Ordinate::Complex(a), Ordinate::Complex(b)) => (
                        a.iter().flat_map(|c| [c.re, c.im]).collect(),
                        b.iter().flat_map(|c| [c.re, c.im]).collect(),
                    ),
                    _ => panic!("kind changed"),
                };
                for (x, y) in a.iter().zip(&b) {
                    assert!((x - y).abs() <= tol * x.abs(), "{x} {y}");
                }
                if let (Abscissa::Uneven(a), Abscissa::Uneven(b)) = (&f.abscissa, &g.abscissa) {
                    assert_eq!(a, b);
                }
                // written again from what was read: the same bytes
                assert_eq!(written(g), bytes);
            }
        }
    }
}

#[test]
fn crlf_blank_lines_and_run_together_values() {
    let text = "\r\n    -1\r\n    58\r\nF\r\nNONE\r\nNONE\r\nNONE\r\nNONE\r\n\
        \x20   1         0    0         0      drive        12  -3       NONE         0   0\r\n\
        \x20        2         4         1  0.00000E+00  1.00000E-03  0.00000E+00\r\n\
        \x20       17    0    0    0 Time                 s\r\n\
        \x20       13    0    0    0 Force                N  \r\n\
        \x20        0    0    0    0 NONE                 NONE\r\n\
        \x20        0    0    0    0\r\n\
        -1.25000E-100-2.00000E+00\r\n\r\n  3.0 4.0D0   \r\n    -1\r\n";
    let f = parse(p(), text.as_bytes()).unwrap();
    let g = f.datasets[0].function.as_ref().unwrap();
    assert_eq!(g.ordinate, Ordinate::Real(vec![-1.25e-100, -2.0, 3.0, 4.0]));
    assert_eq!(g.ordinate_axis.units, "N");
    assert_eq!(g.z_axis.label, "NONE");
    assert_eq!(g.response.label(), "12-Z");
}

#[test]
fn errors_name_dataset_line_and_expectation() {
    let good = written(&time_record(vec![1.0, 2.0, 3.0], Precision::Double));
    let s = String::from_utf8(good).unwrap();
    let cases = [
        (
            s.replace("2.000000000000E+00", "2.0000000000x0E+00"),
            "line 14",
        ),
        (
            s.replace("         3         1", "         5         1"),
            "after 3 of 5",
        ),
        (
            s.replace("         4         3", "         9         3"),
            "ordinate data type 9",
        ),
    ];
    for (text, want) in cases {
        let e = parse(p(), text.as_bytes()).unwrap_err().to_string();
        assert!(
            e.contains("t.uff") && e.contains("dataset 1") && e.contains(want),
            "{e}"
        );
        assert!(e.contains("\"Force\""), "{e}");
    }
}

#[test]
fn every_truncation_is_an_error_not_a_panic() {
    let first = written(&time_record(
        vec![1.0, -2.0, 3.5, 4.0, 5.0],
        Precision::Single,
    ));
    let mut bytes = first.clone();
    bytes.extend(written(&time_record(vec![0.5; 9], Precision::Double)));
    let n1 = first.len();
    for cut in 0..bytes.len() - 7 {
        // only cuts that leave the first dataset whole (and at most the
        // blanks of the next `    -1`) are a valid, shorter file
        if let Ok(f) = parse(p(), &bytes[..cut]) {
            assert!((n1 - 1..=n1 + 4).contains(&cut), "cut {cut} of {n1}");
            assert_eq!(f.datasets.len(), 1);
        }
    }
}
