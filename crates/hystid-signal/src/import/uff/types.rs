//! A UFF file as read: its datasets, and dataset 58's function with its DOFs,
//! axes, precision and record-12 layout.

use num_complex::Complex64;

/// A UFF file: its datasets in file order.
#[derive(Clone, Debug, PartialEq)]
pub struct UffFile {
    /// The datasets; only dataset 58 is decoded ([`Dataset::function`]).
    pub datasets: Vec<Dataset>,
}

/// One dataset of a UFF file.
#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    /// Position in the file, counted from 1.
    pub index: usize,
    /// Line of its dataset-number line, from 1 (bytes of binary data count
    /// their line-feed bytes, as an editor would).
    pub line: usize,
    /// The dataset number (58, 151, 164, 2411, ...).
    pub number: u32,
    /// Whether it is a binary variant (`58b`).
    pub binary: bool,
    /// The decoded content of a dataset 58; `None` for other datasets.
    pub function: Option<Function>,
}

impl Dataset {
    /// How messages name it: `dataset 3 (58b at line 120, "Force 1+Z")`.
    pub fn describe(&self) -> String {
        let b = if self.binary { "b" } else { "" };
        match &self.function {
            Some(f) if !f.id_lines[0].is_empty() && f.id_lines[0] != "NONE" => format!(
                "dataset {} ({}{b} at line {}, \"{}\")",
                self.index, self.number, self.line, f.id_lines[0]
            ),
            _ => format!(
                "dataset {} ({}{b} at line {})",
                self.index, self.number, self.line
            ),
        }
    }
}

/// A response or reference degree of freedom (record 6).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Dof {
    /// Entity name (`NONE` if unused).
    pub entity: String,
    /// Node number.
    pub node: i64,
    /// Direction: 0 scalar, ±1..±3 translation X/Y/Z, ±4..±6 rotation.
    pub direction: i64,
}

impl Dof {
    /// `1+Z`, `12-RX`, `7` (scalar).
    pub fn label(&self) -> String {
        let axis = match self.direction.abs() {
            1 => "X",
            2 => "Y",
            3 => "Z",
            4 => "RX",
            5 => "RY",
            6 => "RZ",
            _ => "",
        };
        if axis.is_empty() {
            format!("{}", self.node)
        } else {
            let sign = if self.direction < 0 { '-' } else { '+' };
            format!("{}{sign}{axis}", self.node)
        }
    }
}

/// Precision of the stored values (record 7 field 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Precision {
    /// 4-byte floats, `E13.5` text.
    Single,
    /// 8-byte floats, `E20.12` text.
    Double,
}

/// The abscissa (record 7 fields 3-5, and the stored values when uneven).
#[derive(Clone, Debug, PartialEq)]
pub enum Abscissa {
    /// Evenly spaced: `start + k increment`.
    Even {
        /// First abscissa value.
        start: f64,
        /// Spacing.
        increment: f64,
        /// Half a unit in the last digit the file printed the increment
        /// with (`1.52588E-05` gives 5e-11): how well the file knows it.
        increment_resolution: f64,
    },
    /// One stored value per ordinate value.
    Uneven(Vec<f64>),
}

/// The ordinate values.
#[derive(Clone, Debug, PartialEq)]
pub enum Ordinate {
    /// Real values (ordinate data type 2 or 4).
    Real(Vec<f64>),
    /// Complex values (type 5 or 6).
    Complex(Vec<Complex64>),
}

impl Ordinate {
    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            Ordinate::Real(v) => v.len(),
            Ordinate::Complex(v) => v.len(),
        }
    }

    /// Whether there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Data characteristics of one axis (records 8-11).
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// Specific data type: 0 unknown, 1 general, 8 displacement, 9 reaction
    /// force, 11 velocity, 12 acceleration, 13 excitation force, 17 time,
    /// 18 frequency, ...
    pub data_type: i64,
    /// Length units exponent.
    pub length_exponent: i64,
    /// Force units exponent.
    pub force_exponent: i64,
    /// Temperature units exponent.
    pub temperature_exponent: i64,
    /// Axis label (`NONE` if unused).
    pub label: String,
    /// Axis units label (`NONE` if unused).
    pub units: String,
}

impl Axis {
    /// An axis of `data_type` with a label and units label, exponents 0.
    pub fn new(data_type: i64, label: &str, units: &str) -> Axis {
        Axis {
            data_type,
            length_exponent: 0,
            force_exponent: 0,
            temperature_exponent: 0,
            label: label.to_string(),
            units: units.to_string(),
        }
    }

    /// An unused axis (type 0, `NONE`).
    pub fn unused() -> Axis {
        Axis::new(0, "NONE", "NONE")
    }
}

/// How a `58b` dataset stored its values.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BinaryLayout {
    /// Byte order: record 1 field 3 = 2.
    pub big_endian: bool,
    /// Bytes the `58b` line declares (field 6).
    pub declared_bytes: u64,
    /// Bytes actually read (the layout record 7 implies).
    pub data_bytes: u64,
    /// Whether an uneven abscissa was stored as 4-byte floats beside
    /// 8-byte ordinates (the Fortran layout) rather than as 8-byte ones.
    pub single_abscissa: bool,
}

/// The content of a dataset 58.
#[derive(Clone, Debug, PartialEq)]
pub struct Function {
    /// ID lines 1-5 (records 1-5), trailing blanks removed.
    pub id_lines: [String; 5],
    /// Function type: 0 general, 1 time response, 2 auto spectrum, 3 cross
    /// spectrum, 4 frequency response function, ...
    pub function_type: i64,
    /// Function identification number.
    pub function_id: i64,
    /// Version or sequence number.
    pub version: i64,
    /// Load case identification number (0: single-point excitation).
    pub load_case: i64,
    /// Response DOF.
    pub response: Dof,
    /// Reference DOF.
    pub reference: Dof,
    /// Precision of the values.
    pub precision: Precision,
    /// The abscissa.
    pub abscissa: Abscissa,
    /// Z-axis value (record 7 field 6).
    pub z_axis_value: f64,
    /// Abscissa characteristics (record 8).
    pub abscissa_axis: Axis,
    /// Ordinate (numerator) characteristics (record 9).
    pub ordinate_axis: Axis,
    /// Ordinate denominator characteristics (record 10).
    pub denominator_axis: Axis,
    /// Z-axis characteristics (record 11).
    pub z_axis: Axis,
    /// The values.
    pub ordinate: Ordinate,
    /// For `58b`: how the values were stored.
    pub binary: Option<BinaryLayout>,
}

impl Function {
    /// The ordinate data type code of record 7 (2, 4, 5 or 6).
    pub fn ordinate_data_type(&self) -> i64 {
        match (&self.ordinate, self.precision) {
            (Ordinate::Real(_), Precision::Single) => 2,
            (Ordinate::Real(_), Precision::Double) => 4,
            (Ordinate::Complex(_), Precision::Single) => 5,
            (Ordinate::Complex(_), Precision::Double) => 6,
        }
    }

    /// The function type's name (`time response`, `frequency response
    /// function`, ...).
    pub fn function_type_name(&self) -> &'static str {
        function_type_name(self.function_type)
    }
}

/// The name of a record 6 function type.
pub fn function_type_name(t: i64) -> &'static str {
    match t {
        0 => "general or unknown",
        1 => "time response",
        2 => "auto spectrum",
        3 => "cross spectrum",
        4 => "frequency response function",
        5 => "transmissibility",
        6 => "coherence",
        7 => "auto correlation",
        8 => "cross correlation",
        9 => "power spectral density",
        10 => "energy spectral density",
        11 => "probability density function",
        12 => "spectrum",
        _ => "other function",
    }
}

impl UffFile {
    /// The datasets 58.
    pub fn functions(&self) -> impl Iterator<Item = (&Dataset, &Function)> {
        self.datasets
            .iter()
            .filter_map(|d| d.function.as_ref().map(|f| (d, f)))
    }

    /// One line per dataset, for messages: `#1 58 "Force" time response
    /// 1+Z, excitation force [N], 4096 values`.
    pub fn listing(&self) -> String {
        let mut out = Vec::new();
        for d in &self.datasets {
            let b = if d.binary { "b" } else { "" };
            match &d.function {
                Some(f) => out.push(format!(
                    "#{} {}{b} \"{}\" {} {}, data type {} [{}], {} values",
                    d.index,
                    d.number,
                    f.id_lines[0],
                    f.function_type_name(),
                    f.response.label(),
                    f.ordinate_axis.data_type,
                    f.ordinate_axis.units,
                    f.ordinate.len()
                )),
                None => out.push(format!("#{} {}{b} (skipped)", d.index, d.number)),
            }
        }
        out.join("; ")
    }
}

/// The layouts of record 12 for each ordinate data type and spacing.
#[derive(Clone, Copy)]
pub(super) struct Case {
    pub(super) complex: bool,
    pub(super) precision: Precision,
    pub(super) even: bool,
}

impl Case {
    /// Values per point in the file: ordinate (1 or 2) plus abscissa.
    pub(super) fn per_point(self) -> usize {
        (if self.complex { 2 } else { 1 }) + usize::from(!self.even)
    }

    /// The fixed columns of the ASCII format, repeated along a line.
    pub(super) fn widths(self) -> &'static [usize] {
        match (self.precision, self.even, self.complex) {
            (Precision::Single, _, _) => &[13; 6],
            (Precision::Double, true, _) => &[20; 4],
            (Precision::Double, false, false) => &[13, 20, 13, 20],
            (Precision::Double, false, true) => &[13, 20, 20],
        }
    }

    pub(super) fn format(self) -> &'static str {
        match (self.precision, self.even, self.complex) {
            (Precision::Single, _, _) => "6E13.5",
            (Precision::Double, true, _) => "4E20.12",
            (Precision::Double, false, false) => "2(E13.5,E20.12)",
            (Precision::Double, false, true) => "E13.5,2E20.12",
        }
    }

    pub(super) fn describe(self) -> String {
        format!(
            "{} {}, {} abscissa",
            if self.complex { "complex" } else { "real" },
            match self.precision {
                Precision::Single => "single",
                Precision::Double => "double",
            },
            if self.even { "even" } else { "uneven" }
        )
    }
}
