//! ROS 2 CDR (XCDR1, little endian) for the `hystid_msgs/msg/SignalBlock`
//! message: enough of the encoding for one fixed message type.
//!
//! A message is the 4-byte encapsulation header `00 01 00 00` followed by
//! the fields, each primitive aligned to its own size counted from the end of
//! the header; a sequence is a `u32` element count then its elements
//! (OMG DDS-XTypes 1.3, section 7.4.3.5; ROS 2 `rmw` uses plain CDR).

/// The ROS 2 message definition (`ros2msg` schema) of a signal block.
pub(crate) const SIGNAL_BLOCK_SCHEMA: &str = "\
# One block of consecutive samples of a hystid run, physical SI units.
# Arrays of quantities that are not recorded are empty. `force` is the
# reference (a voltage driving a shaker, when the run says so); gauge_force
# is the force a gauge reads beside a voltage reference (absent in runs
# written before it was added: read as empty).
uint32 step
uint64 first_frame
float64 t0
float64 fs
float32[] force
float32[] displacement
float32[] velocity
float32[] acceleration
float32[] gauge_force
";

/// The ROS 2 type name of a signal block.
pub(crate) const SIGNAL_BLOCK_NAME: &str = "hystid_msgs/msg/SignalBlock";

const HEADER: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// The signal arrays of a block, in order.
pub(crate) const ARRAYS: usize = 5;
/// Their field names.
pub(crate) const ARRAY_NAMES: [&str; ARRAYS] = [
    "force",
    "displacement",
    "velocity",
    "acceleration",
    "gauge_force",
];

/// Pads `buf` so the next field of `size` bytes is aligned, counting from the
/// end of the encapsulation header.
fn align(buf: &mut Vec<u8>, size: usize) {
    let offset = buf.len() - HEADER.len();
    let pad = (size - offset % size) % size;
    buf.resize(buf.len() + pad, 0);
}

/// Encodes one signal block into `buf` (cleared first). The samples are
/// rounded to f32; the caller has checked that they are finite and in range.
pub(crate) fn encode_signal_block(
    buf: &mut Vec<u8>,
    step: u32,
    first_frame: u64,
    t0: f64,
    fs: f64,
    arrays: [&[f64]; ARRAYS],
) {
    buf.clear();
    buf.extend_from_slice(&HEADER);
    align(buf, 4);
    buf.extend_from_slice(&step.to_le_bytes());
    align(buf, 8);
    buf.extend_from_slice(&first_frame.to_le_bytes());
    buf.extend_from_slice(&t0.to_le_bytes());
    buf.extend_from_slice(&fs.to_le_bytes());
    for a in arrays {
        align(buf, 4);
        buf.extend_from_slice(&(a.len() as u32).to_le_bytes());
        let start = buf.len();
        buf.resize(start + 4 * a.len(), 0);
        for (dst, &x) in buf[start..].chunks_exact_mut(4).zip(a) {
            dst.copy_from_slice(&(x as f32).to_le_bytes());
        }
    }
}

/// A decoded signal block; the arrays borrow the message bytes.
pub(crate) struct SignalBlock<'a> {
    pub step: u32,
    pub first_frame: u64,
    /// Sample rate, Hz (`t0` is `first_frame / fs` and is not kept).
    pub fs: f64,
    /// Raw little-endian f32 bytes of each of [`ARRAY_NAMES`].
    pub arrays: [&'a [u8]; ARRAYS],
}

impl SignalBlock<'_> {
    /// Samples in array `q`.
    pub fn len(&self, q: usize) -> usize {
        self.arrays[q].len() / 4
    }

    /// Appends array `q` to `out` as f64.
    pub fn extend(&self, q: usize, out: &mut Vec<f64>) {
        out.extend(
            self.arrays[q]
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64),
        );
    }
}

/// What is wrong with a signal block's bytes.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub(crate) enum CdrError {
    /// The encapsulation header is not little-endian CDR.
    #[error("expected the little-endian CDR header 00 01, got {got:02x?}")]
    Header {
        /// The first bytes found (up to two).
        got: Vec<u8>,
    },
    /// The message ends before a field does.
    #[error(
        "message ends inside `{field}` (byte {offset} of the body, {needed} needed, {len} there)"
    )]
    Truncated {
        /// The field.
        field: &'static str,
        /// Where the field starts in the body (after the header), aligned.
        offset: usize,
        /// Bytes the field needs.
        needed: usize,
        /// Bytes in the body.
        len: usize,
    },
    /// An array's element count overflows the address space.
    #[error("`{field}` too long")]
    TooLong {
        /// The array.
        field: &'static str,
    },
}

/// Decodes a signal block, or says what is wrong with it.
pub(crate) fn decode_signal_block(data: &[u8]) -> Result<SignalBlock<'_>, CdrError> {
    if data.len() < HEADER.len() || data[..2] != HEADER[..2] {
        return Err(CdrError::Header {
            got: data[..data.len().min(2)].to_vec(),
        });
    }
    let body = &data[HEADER.len()..];
    let at = std::cell::Cell::new(0usize);
    let take =
        |size: usize, align: usize, field: &'static str| -> Result<&[u8], CdrError> {
            let start = at.get().div_ceil(align) * align;
            let end = start.checked_add(size).filter(|&e| e <= body.len()).ok_or(
                CdrError::Truncated {
                    field,
                    offset: start,
                    needed: size,
                    len: body.len(),
                },
            )?;
            at.set(end);
            Ok(&body[start..end])
        };
    let u32_at = |b: &[u8]| u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    let u64_at = |b: &[u8]| u64::from_le_bytes(b.try_into().expect("8 bytes"));
    let step = u32_at(take(4, 4, "step")?);
    let first_frame = u64_at(take(8, 8, "first_frame")?);
    take(8, 8, "t0")?;
    let fs = f64::from_bits(u64_at(take(8, 8, "fs")?));
    let mut arrays: [&[u8]; ARRAYS] = [&[]; ARRAYS];
    for (q, name) in ARRAY_NAMES.into_iter().enumerate() {
        // a block written before the gauge's array was added ends here
        if name == "gauge_force" && at.get() == body.len() {
            break;
        }
        let n = u32_at(take(4, 4, name)?) as usize;
        arrays[q] = take(
            n.checked_mul(4).ok_or(CdrError::TooLong { field: name })?,
            4,
            name,
        )?;
    }
    Ok(SignalBlock {
        step,
        first_frame,
        fs,
        arrays,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The byte layout written out by hand: u32 at 0, four bytes of padding,
    /// u64 at 8 (offsets after the header), then count + elements.
    #[test]
    fn layout_matches_hand_encoding() {
        let mut buf = Vec::new();
        encode_signal_block(
            &mut buf,
            7,
            0x0102_0304_0506_0708,
            0.5,
            1000.0,
            [&[1.0, -2.0], &[], &[], &[0.25, 4.0], &[]],
        );
        let mut want = vec![0, 1, 0, 0, 7, 0, 0, 0, 0, 0, 0, 0];
        want.extend_from_slice(&0x0102_0304_0506_0708u64.to_le_bytes());
        want.extend_from_slice(&0.5f64.to_le_bytes());
        want.extend_from_slice(&1000.0f64.to_le_bytes());
        want.extend_from_slice(&2u32.to_le_bytes());
        want.extend_from_slice(&1.0f32.to_le_bytes());
        want.extend_from_slice(&(-2.0f32).to_le_bytes());
        want.extend_from_slice(&[0; 8]);
        want.extend_from_slice(&2u32.to_le_bytes());
        want.extend_from_slice(&0.25f32.to_le_bytes());
        want.extend_from_slice(&4.0f32.to_le_bytes());
        want.extend_from_slice(&0u32.to_le_bytes());
        assert_eq!(buf, want);

        let b = decode_signal_block(&buf).unwrap();
        assert_eq!(
            (b.step, b.first_frame, b.fs),
            (7, 0x0102_0304_0506_0708, 1000.0)
        );
        let mut acc = Vec::new();
        b.extend(3, &mut acc);
        assert_eq!(acc, [0.25, 4.0]);
        assert_eq!((b.len(0), b.len(1), b.len(2)), (2, 0, 0));
        // a block of the four-array layout (before the gauge's) reads with
        // the gauge's empty; any other cut is an error
        let old = decode_signal_block(&buf[..buf.len() - 4]).unwrap();
        assert_eq!((old.len(3), old.len(4)), (2, 0));
        for cut in (0..buf.len()).filter(|&c| c != buf.len() - 4) {
            assert!(decode_signal_block(&buf[..cut]).is_err(), "cut at {cut}");
        }
    }
}
