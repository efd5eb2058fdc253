//! A reader for MATLAB level-5 MAT-files holding numeric arrays.
//!
//! Format: *MATLAB MAT-File Format*, The MathWorks (matfile_format.pdf,
//! "Level 5 MAT-File Format"): a 128-byte header (116 bytes of text, an
//! 8-byte subsystem offset, a 2-byte version and a 2-byte endian indicator
//! `IM`/`MI`), then tagged data elements. A tag is 8 bytes (type, byte
//! count), or 4 bytes in the *small element* format when the data fits in 4
//! bytes (byte count in the upper 16 bits of the type word). Elements are
//! padded to 8 bytes, except `miCOMPRESSED`, which holds one zlib-compressed
//! element. A variable is an `miMATRIX` element: array flags (class, complex
//! flag), dimensions, name, the real part and, if complex, the imaginary part.
//! The parts may be stored in any numeric type (MATLAB stores a `double`
//! array of small integers as `miUINT8`, say); every part is converted to
//! `f64` here.
//!
//! Why not the `matfile` crate: it reads the benchmark files, but it stops
//! silently at a truncated element (a file cut in half loses its last
//! variables without an error), drops non-numeric variables without a trace,
//! and its errors do not say where the file is broken. This reader indexes
//! every variable when the file is opened (decompressing only the first
//! bytes of each compressed element, enough for the name and the shape) and
//! decodes a variable's data only when it is asked for.
//!
//! Not supported (a clear error): MAT v4 and v7.3 (HDF5) files; complex
//! signals; sparse, cell, struct, char and object variables are listed but
//! cannot be read as signals.

use crate::{Error, Result};
use flate2::read::ZlibDecoder;
use std::io::Read;
use std::path::{Path, PathBuf};

// Data types of the tags (matfile_format.pdf, Table 1-1).
const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_INT16: u32 = 3;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_SINGLE: u32 = 7;
const MI_DOUBLE: u32 = 9;
const MI_INT64: u32 = 12;
const MI_UINT64: u32 = 13;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;
const MI_UTF8: u32 = 16;

/// Bytes of a compressed element decompressed to read a variable's name and
/// shape when the file is indexed (names are at most 63 characters, so the
/// flags, a few dimensions and the name fit easily).
const INDEX_PREFIX: u64 = 1024;

/// Most decompressed bytes indexing reads for one variable's header (a name
/// of at most 63 characters and a few dimensions take well under 1 KiB).
const HEADER_LIMIT: u64 = 1 << 20;

/// The MATLAB class of a variable (matfile_format.pdf, Table 1-3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MatClass {
    /// Cell array.
    Cell,
    /// Structure.
    Struct,
    /// Object.
    Object,
    /// Character array.
    Char,
    /// Sparse array.
    Sparse,
    /// Double precision.
    Double,
    /// Single precision.
    Single,
    /// 8-bit signed integer.
    Int8,
    /// 8-bit unsigned integer (also logical arrays).
    Uint8,
    /// 16-bit signed integer.
    Int16,
    /// 16-bit unsigned integer.
    Uint16,
    /// 32-bit signed integer.
    Int32,
    /// 32-bit unsigned integer.
    Uint32,
    /// 64-bit signed integer.
    Int64,
    /// 64-bit unsigned integer.
    Uint64,
    /// Any other class code (function handles, opaque objects).
    Other(u8),
}

impl MatClass {
    fn from_code(code: u8) -> MatClass {
        match code {
            1 => MatClass::Cell,
            2 => MatClass::Struct,
            3 => MatClass::Object,
            4 => MatClass::Char,
            5 => MatClass::Sparse,
            6 => MatClass::Double,
            7 => MatClass::Single,
            8 => MatClass::Int8,
            9 => MatClass::Uint8,
            10 => MatClass::Int16,
            11 => MatClass::Uint16,
            12 => MatClass::Int32,
            13 => MatClass::Uint32,
            14 => MatClass::Int64,
            15 => MatClass::Uint64,
            c => MatClass::Other(c),
        }
    }

    /// Whether the class is a dense numeric array (the only kind that can be
    /// read as a signal).
    pub fn is_numeric(self) -> bool {
        matches!(
            self,
            MatClass::Double
                | MatClass::Single
                | MatClass::Int8
                | MatClass::Uint8
                | MatClass::Int16
                | MatClass::Uint16
                | MatClass::Int32
                | MatClass::Uint32
                | MatClass::Int64
                | MatClass::Uint64
        )
    }

    /// MATLAB's name of the class (`double`, `struct`, ...).
    pub fn name(self) -> String {
        match self {
            MatClass::Cell => "cell".into(),
            MatClass::Struct => "struct".into(),
            MatClass::Object => "object".into(),
            MatClass::Char => "char".into(),
            MatClass::Sparse => "sparse".into(),
            MatClass::Double => "double".into(),
            MatClass::Single => "single".into(),
            MatClass::Int8 => "int8".into(),
            MatClass::Uint8 => "uint8".into(),
            MatClass::Int16 => "int16".into(),
            MatClass::Uint16 => "uint16".into(),
            MatClass::Int32 => "int32".into(),
            MatClass::Uint32 => "uint32".into(),
            MatClass::Int64 => "int64".into(),
            MatClass::Uint64 => "uint64".into(),
            MatClass::Other(c) => format!("class {c}"),
        }
    }
}

/// What the index knows about one variable, without its data.
#[derive(Clone, Debug, PartialEq)]
pub struct MatVariableInfo {
    /// The variable's name.
    pub name: String,
    /// Its class.
    pub class: MatClass,
    /// Its dimensions, MATLAB order (rows, columns, ...).
    pub dims: Vec<usize>,
    /// Whether it has an imaginary part.
    pub complex: bool,
    /// Byte offset of its top-level element in the file.
    pub offset: usize,
    /// Whether the element is `miCOMPRESSED`.
    pub compressed: bool,
}

impl MatVariableInfo {
    /// The shape as MATLAB prints it, e.g. `3x108477`.
    pub fn shape(&self) -> String {
        shape_text(&self.dims)
    }

    /// One line for listings: `Acceleration (3x108477 double)`.
    pub fn describe(&self) -> String {
        format!(
            "{} ({} {}{})",
            self.name,
            self.shape(),
            if self.complex { "complex " } else { "" },
            self.class.name()
        )
    }
}

/// A numeric variable's values.
#[derive(Clone, Debug, PartialEq)]
pub struct MatArray {
    /// The variable's name.
    pub name: String,
    /// Its class (the storage type of the data may differ; values are
    /// converted to `f64`).
    pub class: MatClass,
    /// Dimensions, MATLAB order.
    pub dims: Vec<usize>,
    /// The real part, column-major (MATLAB order).
    pub data: Vec<f64>,
}

impl MatArray {
    /// The shape as MATLAB prints it, e.g. `3x108477`.
    pub fn shape(&self) -> String {
        shape_text(&self.dims)
    }

    /// One signal of the array.
    ///
    /// A vector (`1xN` or `Nx1`) is one signal; `index` must be `None` or
    /// `Some(1)`. A 2-D matrix holds its signals along its longer dimension:
    /// `index` (1-based, as in MATLAB) is the row of a `kxN` matrix or the
    /// column of an `Nxk` one (rows when square). Errors name `path` and the
    /// variable and give the shape.
    pub fn signal(&self, index: Option<usize>, path: &Path) -> Result<Vec<f64>> {
        let field = match index {
            Some(i) => format!("{}(row {i})", self.name),
            None => self.name.clone(),
        };
        // Trailing singleton dimensions (1x5x1) do not matter.
        let mut dims: Vec<usize> = self.dims.clone();
        while dims.len() > 2 && dims.last() == Some(&1) {
            dims.pop();
        }
        if dims.len() != 2 {
            return Err(Error::format(
                path,
                field,
                format!(
                    "is a {}-dimensional array ({}); only vectors and 2-D matrices hold signals",
                    dims.len(),
                    self.shape()
                ),
            ));
        }
        let (rows, cols) = (dims[0], dims[1]);
        if rows.checked_mul(cols) != Some(self.data.len()) {
            return Err(Error::format(
                path,
                field,
                format!(
                    "holds {} values, its shape {} needs {}",
                    self.data.len(),
                    self.shape(),
                    rows.saturating_mul(cols)
                ),
            ));
        }
        if rows == 0 || cols == 0 {
            return Err(Error::format(
                path,
                field,
                format!("is empty ({})", self.shape()),
            ));
        }
        if rows == 1 || cols == 1 {
            return match index {
                None | Some(1) => Ok(self.data.clone()),
                Some(i) => Err(Error::format(
                    path,
                    field,
                    format!(
                        "row {i} is out of range: the variable is {} (a single signal, row 1)",
                        self.shape()
                    ),
                )),
            };
        }
        let signals_are_rows = rows <= cols;
        let count = if signals_are_rows { rows } else { cols };
        let what = if signals_are_rows { "row" } else { "column" };
        let i = match index {
            None => {
                return Err(Error::format(
                    path,
                    field,
                    format!(
                        "is a {} matrix holding {count} signals: give the {what} (1..={count})",
                        self.shape()
                    ),
                ));
            }
            Some(i) if i == 0 || i > count => {
                return Err(Error::format(
                    path,
                    field,
                    format!(
                        "row {i} is out of range: the variable is {} and holds {count} signals \
                         ({what}s 1..={count}, counted from 1 as in MATLAB)",
                        self.shape()
                    ),
                ));
            }
            Some(i) => i - 1,
        };
        Ok(if signals_are_rows {
            // Column-major: element (i, j) is at i + j*rows.
            (0..cols).map(|j| self.data[i + j * rows]).collect()
        } else {
            self.data[i * rows..(i + 1) * rows].to_vec()
        })
    }
}

fn shape_text(dims: &[usize]) -> String {
    dims.iter()
        .map(|d| d.to_string())
        .collect::<Vec<_>>()
        .join("x")
}

/// An opened MAT-file: its bytes and the index of its variables.
#[derive(Debug)]
pub struct MatFile {
    path: PathBuf,
    bytes: Vec<u8>,
    big_endian: bool,
    header_text: String,
    variables: Vec<MatVariableInfo>,
}

/// Byte order of the file.
#[derive(Clone, Copy)]
struct Endian(bool);

impl Endian {
    fn u16(self, b: &[u8]) -> u16 {
        let a = [b[0], b[1]];
        if self.0 {
            u16::from_be_bytes(a)
        } else {
            u16::from_le_bytes(a)
        }
    }
    fn u32(self, b: &[u8]) -> u32 {
        let a = [b[0], b[1], b[2], b[3]];
        if self.0 {
            u32::from_be_bytes(a)
        } else {
            u32::from_le_bytes(a)
        }
    }
    fn i32(self, b: &[u8]) -> i32 {
        self.u32(b) as i32
    }
}

/// What is wrong with a data element: where (a byte offset in the buffer
/// being parsed, the file or a decompressed element) and what was expected.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
enum ParseError {
    /// Fewer than the 8 bytes of a tag remain.
    #[error("data element tag at byte {offset} needs 8 bytes but only {remaining} remain")]
    TagTruncated { offset: usize, remaining: usize },
    /// A small data element declares more than its 4 data bytes.
    #[error("small data element at byte {offset} declares {len} bytes (at most 4 allowed)")]
    SmallTooLong { offset: usize, len: usize },
    /// An element declares more bytes than remain.
    #[error(
        "data element at byte {offset} declares {len} bytes but only {remaining} remain (file truncated?)"
    )]
    Truncated {
        offset: usize,
        len: usize,
        remaining: usize,
    },
    /// An `miMATRIX` with no content.
    #[error("empty miMATRIX element (no flags, dimensions or name)")]
    EmptyMatrix,
    /// The array flags sub-element is not 8 bytes of miUINT32.
    #[error(
        "array flags sub-element has type {dtype} and {len} bytes (expected miUINT32, 8 bytes)"
    )]
    Flags { dtype: u32, len: usize },
    /// The dimensions sub-element is not at least two miINT32.
    #[error(
        "dimensions sub-element has type {dtype} and {len} bytes (expected miINT32, at least 2 dimensions)"
    )]
    Dimensions { dtype: u32, len: usize },
    /// A dimension below zero.
    #[error("negative dimension {0}")]
    NegativeDimension(i32),
    /// The name sub-element is not text.
    #[error("array name sub-element has type {0} (expected miINT8)")]
    NameType(u32),
    /// Numeric data whose length is not a multiple of its value size.
    #[error("{bytes} bytes of data is not a whole number of {width}-byte values")]
    Ragged { bytes: usize, width: usize },
    /// Data of a non-numeric type where numbers were expected.
    #[error("data of type {0} is not a numeric type")]
    NotNumeric(u32),
}

/// A parsed tag: data type, data range and where the next element starts.
struct Tag {
    dtype: u32,
    start: usize,
    len: usize,
    next: usize,
}

/// Reads the tag at `pos` of `buf`. `Err` says where and what was expected.
fn read_tag(buf: &[u8], pos: usize, e: Endian) -> std::result::Result<Tag, ParseError> {
    if pos + 8 > buf.len() {
        return Err(ParseError::TagTruncated {
            offset: pos,
            remaining: buf.len().saturating_sub(pos),
        });
    }
    let w0 = e.u32(&buf[pos..]);
    if w0 >> 16 != 0 {
        // Small data element: 2-byte count, 2-byte type, data in the next 4 bytes.
        let len = (w0 >> 16) as usize;
        if len > 4 {
            return Err(ParseError::SmallTooLong { offset: pos, len });
        }
        return Ok(Tag {
            dtype: w0 & 0xffff,
            start: pos + 4,
            len,
            next: pos + 8,
        });
    }
    let len = e.u32(&buf[pos + 4..]) as usize;
    let start = pos + 8;
    if len > buf.len() - start {
        return Err(ParseError::Truncated {
            offset: pos,
            len,
            remaining: buf.len() - start,
        });
    }
    // Compressed elements are not padded; all others are padded to a
    // multiple of 8 bytes, counted from the element's own start (after a
    // compressed element it need not be aligned in the file). The padding
    // of the last element of a buffer may be missing.
    let next = if w0 == MI_COMPRESSED {
        start + len
    } else {
        (start + len.next_multiple_of(8)).min(buf.len())
    };
    Ok(Tag {
        dtype: w0,
        start,
        len,
        next,
    })
}

/// The header part of an `miMATRIX` (flags, dims, name) and where the data
/// sub-elements start, relative to the matrix content.
struct MatrixHeader {
    class: MatClass,
    complex: bool,
    dims: Vec<usize>,
    name: String,
    data_pos: usize,
}

/// Parses flags, dimensions and name from the content of an `miMATRIX`.
/// `Ok(None)` when `buf` is too short (a decompressed prefix).
fn parse_matrix_header(
    buf: &[u8],
    e: Endian,
    complete: bool,
) -> std::result::Result<Option<MatrixHeader>, ParseError> {
    let short = |r: std::result::Result<Tag, ParseError>| match r {
        Ok(t) => Ok(Some(t)),
        Err(m) if complete => Err(m),
        Err(_) => Ok(None),
    };
    if buf.is_empty() {
        // An empty placeholder matrix (valid inside cells; odd at top level).
        return Err(ParseError::EmptyMatrix);
    }
    let Some(flags) = short(read_tag(buf, 0, e))? else {
        return Ok(None);
    };
    if flags.dtype != MI_UINT32 || flags.len != 8 {
        return Err(ParseError::Flags {
            dtype: flags.dtype,
            len: flags.len,
        });
    }
    let word = e.u32(&buf[flags.start..]);
    let class = MatClass::from_code((word & 0xff) as u8);
    let complex = word & 0x0800 != 0;
    let Some(dims_tag) = short(read_tag(buf, flags.next, e))? else {
        return Ok(None);
    };
    if dims_tag.dtype != MI_INT32 || dims_tag.len % 4 != 0 || dims_tag.len < 8 {
        return Err(ParseError::Dimensions {
            dtype: dims_tag.dtype,
            len: dims_tag.len,
        });
    }
    let mut dims = Vec::with_capacity(dims_tag.len / 4);
    for k in 0..dims_tag.len / 4 {
        let d = e.i32(&buf[dims_tag.start + 4 * k..]);
        if d < 0 {
            return Err(ParseError::NegativeDimension(d));
        }
        dims.push(d as usize);
    }
    let Some(name_tag) = short(read_tag(buf, dims_tag.next, e))? else {
        return Ok(None);
    };
    if name_tag.dtype != MI_INT8 && name_tag.dtype != MI_UINT8 && name_tag.dtype != MI_UTF8 {
        return Err(ParseError::NameType(name_tag.dtype));
    }
    let name =
        String::from_utf8_lossy(&buf[name_tag.start..name_tag.start + name_tag.len]).into_owned();
    Ok(Some(MatrixHeader {
        class,
        complex,
        dims,
        name,
        data_pos: name_tag.next,
    }))
}

/// Converts a numeric sub-element's bytes to `f64`, appending to `out`.
fn convert(
    data: &[u8],
    dtype: u32,
    e: Endian,
    out: &mut Vec<f64>,
) -> std::result::Result<(), ParseError> {
    macro_rules! conv {
        ($t:ty, $n:expr) => {{
            #[allow(clippy::modulo_one)]
            let ragged = data.len() % $n != 0;
            if ragged {
                return Err(ParseError::Ragged {
                    bytes: data.len(),
                    width: $n,
                });
            }
            out.reserve(data.len() / $n);
            if e.0 {
                out.extend(
                    data.chunks_exact($n)
                        .map(|c| <$t>::from_be_bytes(c.try_into().unwrap()) as f64),
                );
            } else {
                out.extend(
                    data.chunks_exact($n)
                        .map(|c| <$t>::from_le_bytes(c.try_into().unwrap()) as f64),
                );
            }
        }};
    }
    match dtype {
        MI_INT8 => conv!(i8, 1),
        MI_UINT8 => conv!(u8, 1),
        MI_INT16 => conv!(i16, 2),
        MI_UINT16 => conv!(u16, 2),
        MI_INT32 => conv!(i32, 4),
        MI_UINT32 => conv!(u32, 4),
        MI_SINGLE => conv!(f32, 4),
        MI_DOUBLE => conv!(f64, 8),
        MI_INT64 => conv!(i64, 8),
        MI_UINT64 => conv!(u64, 8),
        t => return Err(ParseError::NotNumeric(t)),
    }
    Ok(())
}

/// Decompresses a zlib stream, at most `limit` bytes of output.
fn inflate(data: &[u8], limit: u64) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::new();
    ZlibDecoder::new(data).take(limit).read_to_end(&mut out)?;
    Ok(out)
}

impl MatFile {
    /// Reads and indexes a MAT-file.
    ///
    /// Errors name the file and the place: not a level-5 MAT-file (v4 or
    /// v7.3/HDF5 files are recognised and refused), a truncated element, a
    /// corrupted compressed element.
    pub fn open(path: &Path) -> Result<MatFile> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        MatFile::from_bytes(path, bytes)
    }

    /// Indexes a MAT-file already in memory; `path` is used in messages.
    pub fn from_bytes(path: &Path, bytes: Vec<u8>) -> Result<MatFile> {
        let err = |field: &str, msg: String| Error::format(path, field, msg);
        if bytes.len() < 128 {
            return Err(err(
                "header",
                format!(
                    "file has {} bytes, a MAT-file header alone has 128 (truncated or not a MAT-file)",
                    bytes.len()
                ),
            ));
        }
        let text = String::from_utf8_lossy(&bytes[..116])
            .trim_end_matches([' ', '\0'])
            .to_string();
        if text.starts_with("MATLAB 7.3") {
            return Err(err(
                "header",
                "is a MAT v7.3 (HDF5) file, which is not supported: re-save it with `save -v7`"
                    .into(),
            ));
        }
        let big_endian = match &bytes[126..128] {
            b"IM" => false,
            b"MI" => true,
            _ => {
                let hint = if bytes[..4].contains(&0) {
                    " (it looks like a MAT v4 file: re-save it with `save -v7`)"
                } else {
                    ""
                };
                return Err(err(
                    "header",
                    format!(
                        "bytes 126-127 are not the endian indicator `IM`/`MI`: not a level-5 MAT-file{hint}"
                    ),
                ));
            }
        };
        let e = Endian(big_endian);
        let version = e.u16(&bytes[124..]);
        if version != 0x0100 {
            return Err(err(
                "header",
                format!("version {version:#06x} (expected 0x0100, level 5)"),
            ));
        }
        let mut file = MatFile {
            path: path.to_path_buf(),
            bytes,
            big_endian,
            header_text: text,
            variables: Vec::new(),
        };
        file.index()?;
        Ok(file)
    }

    fn endian(&self) -> Endian {
        Endian(self.big_endian)
    }

    fn index(&mut self) -> Result<()> {
        let e = self.endian();
        let buf = &self.bytes;
        let mut pos = 128;
        let mut vars = Vec::new();
        while pos < buf.len() {
            let tag = read_tag(buf, pos, e).map_err(|m| {
                Error::format(&self.path, format!("element at byte {pos}"), m.to_string())
            })?;
            let at = |m: String| Error::format(&self.path, format!("element at byte {pos}"), m);
            let content = &buf[tag.start..tag.start + tag.len];
            match tag.dtype {
                MI_MATRIX => {
                    let h = parse_matrix_header(content, e, true)
                        .map_err(|m| at(m.to_string()))?
                        .expect("complete buffers never ask for more");
                    vars.push(MatVariableInfo {
                        name: h.name,
                        class: h.class,
                        dims: h.dims,
                        complex: h.complex,
                        offset: pos,
                        compressed: false,
                    });
                }
                MI_COMPRESSED => {
                    let prefix = inflate(content, INDEX_PREFIX)
                        .map_err(|x| at(format!("compressed element is corrupted: {x}")))?;
                    if prefix.len() < 8 {
                        return Err(at(format!(
                            "compressed element holds {} bytes, not even a tag",
                            prefix.len()
                        )));
                    }
                    // The inner tag's length may exceed the prefix: read its type only.
                    let inner_type = e.u32(&prefix);
                    if inner_type != MI_MATRIX {
                        // Compressed non-matrix elements (rare) are skipped.
                        pos = tag.next;
                        continue;
                    }
                    let whole = (prefix.len() as u64) < INDEX_PREFIX;
                    let mut h = parse_matrix_header(&prefix[8..], e, whole)
                        .map_err(|m| at(format!("in the decompressed data: {m}")))?;
                    if h.is_none() {
                        // Very long name or many dimensions: decompress more,
                        // but never more than a header can be (indexing must
                        // not inflate a variable's data, or a zlib bomb).
                        let more = inflate(content, HEADER_LIMIT)
                            .map_err(|x| at(format!("compressed element is corrupted: {x}")))?;
                        let whole = (more.len() as u64) < HEADER_LIMIT;
                        h = parse_matrix_header(&more[8..], e, whole)
                            .map_err(|m| at(format!("in the decompressed data: {m}")))?;
                    }
                    let Some(h) = h else {
                        return Err(at(format!(
                            "the variable's header (flags, dimensions, name) runs past \
                             its first {HEADER_LIMIT} decompressed bytes: corrupted"
                        )));
                    };
                    vars.push(MatVariableInfo {
                        name: h.name,
                        class: h.class,
                        dims: h.dims,
                        complex: h.complex,
                        offset: pos,
                        compressed: true,
                    });
                }
                // Other top-level elements carry no variables.
                _ => {}
            }
            pos = tag.next;
        }
        self.variables = vars;
        Ok(())
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The descriptive text of the header (`MATLAB 5.0 MAT-file, ...`).
    pub fn header_text(&self) -> &str {
        &self.header_text
    }

    /// Every variable in the file, in file order, numeric or not.
    pub fn variables(&self) -> &[MatVariableInfo] {
        &self.variables
    }

    /// A variable's index entry by name (case-sensitive, as in MATLAB).
    pub fn variable(&self, name: &str) -> Option<&MatVariableInfo> {
        self.variables.iter().find(|v| v.name == name)
    }

    /// `Force (1x108477 double), ...`: the variables, for error messages.
    pub fn listing(&self) -> String {
        if self.variables.is_empty() {
            return "the file holds no variables".into();
        }
        let list: Vec<String> = self.variables.iter().map(|v| v.describe()).collect();
        format!("variables present: {}", list.join(", "))
    }

    /// Reads a numeric, real variable.
    ///
    /// Errors: the variable is missing (the message lists those present),
    /// not numeric (struct, cell, char, sparse, ...), complex, or its data
    /// is corrupted or truncated (the message says where).
    pub fn read(&self, name: &str) -> Result<MatArray> {
        let path = &self.path;
        let Some(info) = self.variable(name) else {
            return Err(Error::format(
                path,
                name,
                format!("no such variable; {}", self.listing()),
            ));
        };
        if !info.class.is_numeric() {
            return Err(Error::format(
                path,
                name,
                format!(
                    "is a {} {} variable, not a numeric array",
                    info.shape(),
                    info.class.name()
                ),
            ));
        }
        if info.complex {
            return Err(Error::format(
                path,
                name,
                format!(
                    "is a complex {} {} array; only real signals can be imported",
                    info.shape(),
                    info.class.name()
                ),
            ));
        }
        let e = self.endian();
        let pos = info.offset;
        let at = |m: String| Error::format(path, name, format!("element at byte {pos}: {m}"));
        let tag = read_tag(&self.bytes, pos, e).map_err(|m| at(m.to_string()))?;
        let content = &self.bytes[tag.start..tag.start + tag.len];
        let decompressed;
        let matrix: &[u8] = if info.compressed {
            // Bounded by what the indexed shape can need (8 bytes a value,
            // twice for complex, plus the header), so a corrupted stream
            // cannot inflate without end.
            let need = info
                .dims
                .iter()
                .try_fold(16u64, |a, &d| a.checked_mul(d as u64))
                .unwrap_or(u64::MAX)
                .saturating_add(4096);
            decompressed = inflate(content, need)
                .map_err(|x| at(format!("compressed data is corrupted: {x}")))?;
            let inner = read_tag(&decompressed, 0, e)
                .map_err(|m| at(format!("in the decompressed data: {m}")))?;
            &decompressed[inner.start..inner.start + inner.len]
        } else {
            content
        };
        let h = parse_matrix_header(matrix, e, true)
            .map_err(|m| at(m.to_string()))?
            .expect("complete buffers never ask for more");
        let count = h
            .dims
            .iter()
            .try_fold(1usize, |a, &d| a.checked_mul(d))
            .ok_or_else(|| at(format!("dimensions {} overflow", shape_text(&h.dims))))?;
        let real = read_tag(matrix, h.data_pos, e).map_err(|m| at(format!("real part: {m}")))?;
        let mut data = Vec::new();
        convert(
            &matrix[real.start..real.start + real.len],
            real.dtype,
            e,
            &mut data,
        )
        .map_err(|m| at(format!("real part: {m}")))?;
        if data.len() != count {
            return Err(at(format!(
                "real part holds {} values but the dimensions {} need {count}",
                data.len(),
                shape_text(&h.dims)
            )));
        }
        Ok(MatArray {
            name: h.name,
            class: h.class,
            dims: h.dims,
            data,
        })
    }
}
