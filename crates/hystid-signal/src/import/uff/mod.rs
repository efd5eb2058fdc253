//! Universal File Format (UFF) dataset 58, "function at nodal DOF": ASCII
//! `58` and binary `58b`.
//!
//! A UFF file is a sequence of datasets, each framed by lines holding `-1`
//! (`    -1`, columns 1-6) and opened by a line with the dataset number.
//! Dataset 58 holds one function of one abscissa: a time record (function
//! type 1), an FRF (type 4), a spectrum... Its eleven header records are read
//! here in full:
//!
//! * records 1-5: five ID lines (free text; line 1 is the description);
//! * record 6: function type, function ID, version, load case, response
//!   entity/node/direction, reference entity/node/direction;
//! * record 7: ordinate data type (2 real single, 4 real double, 5 complex
//!   single, 6 complex double), number of values, abscissa spacing (1 even:
//!   start and increment given; 0 uneven: an abscissa value stored with each
//!   ordinate), z-axis value;
//! * records 8-11: abscissa, ordinate (numerator), ordinate denominator and
//!   z-axis characteristics: specific data type (8 displacement, 9 reaction
//!   force, 11 velocity, 12 acceleration, 13 excitation force, 17 time, 18
//!   frequency, ...), unit exponents, axis label and units label;
//! * record 12: the values, as text in the fixed formats of the UFF
//!   specification (`6E13.5`, `4E20.12`, `2(E13.5,E20.12)`, `E13.5,2E20.12`)
//!   or, in `58b`, as raw IEEE 754 bytes (little- or big-endian, as the `58b`
//!   line says) right after the header.
//!
//! All eight data cases are read (real/complex, single/double, even/uneven);
//! other datasets (151 header, 164 units, 2411 nodes, ...) are skipped and
//! listed. [`write()`] writes dataset 58 as ASCII (what hystid's FRF export
//! uses).
//!
//! What real exporters do that the specification does not, and is accepted
//! here (several broke pyuff: its issues 38, 61, 88 and 103, Simcenter
//! Testlab's binary export among them): CRLF, LF or CR line ends; trailing
//! blanks and blank lines; header lines shorter or longer than 80 columns;
//! values run together in their fixed columns (`-1.23457E-100-2.0...`) or
//! separated by any blanks; Fortran `D` exponents; in `58b`, a line end
//! between the binary data and the closing `-1`, and a header byte count that
//! disagrees with the values record 7 declares (the layout whose end meets the
//! closing `-1` is taken; an uneven double-precision abscissa may be stored in
//! 4 or 8 bytes). Not supported: binary floating-point formats other than
//! IEEE 754 (DEC VMS, IBM/370), which are reported as such.
//!
//! Errors name the file, the dataset (its position in the file, from 1, its
//! type and the line it starts on, and its ID line 1 once read), the line and
//! what was expected. No byte sequence makes the reader panic.

mod channels;
mod cursor;
mod dataset58;
mod parse;
mod types;
mod write;

pub(crate) use channels::load;
pub use channels::{NotAChannel, TimeChannel, channels, default_name, rate_of, time_channel};
pub use cursor::parse_real;
pub use parse::parse;
pub use types::{
    Abscissa, Axis, BinaryLayout, Dataset, Dof, Function, Ordinate, Precision, UffFile,
    function_type_name,
};
pub use write::{fortran_e, write, write_ascii};

#[cfg(test)]
mod tests;
