//! The zstd chunk decoder of the run reader, with a bounded window.
//!
//! A zstd frame declares the window its decoder must keep (up to 2 GiB)
//! before any data, and libzstd allocates it on the frame header alone: a
//! 300-byte chunk could make the reader allocate 126 MB (found by fuzzing
//! `mcap_run`). This decoder refuses a frame whose window exceeds what the
//! file's size allows, so a corrupt or hostile file costs at most its own
//! bounded share of memory. The rest is the `mcap` crate's own decoder.

use mcap::McapError;
use mcap::sans_io::decompressor::{DecompressResult, Decompressor};
use zstd::zstd_safe::{DParameter, DStream, InBuffer, OutBuffer, ResetDirective, get_error_name};

/// The smallest bound: 2^19 = 512 KiB, the window zstd's fast levels (1-2,
/// what hystid writes) use when the chunk's size is not pledged.
pub(crate) const MIN_WINDOW_LOG: u32 = 19;

/// zstd's own default bound (128 MiB).
pub(crate) const MAX_WINDOW_LOG: u32 = 27;

/// The window bound for a chunk that may decompress to at most `limit`
/// bytes: the smallest power of two at least `limit`, within
/// [`MIN_WINDOW_LOG`, `MAX_WINDOW_LOG`] (no frame needs a window larger than
/// what it decodes to).
pub(crate) fn window_log_for(limit: u64) -> u32 {
    let log = 64 - limit.max(1).saturating_sub(1).leading_zeros();
    log.clamp(MIN_WINDOW_LOG, MAX_WINDOW_LOG)
}

/// A `"zstd"` chunk decoder whose frames may declare a window of at most
/// `2^window_log` bytes.
pub(crate) struct BoundedZstd {
    window_log: u32,
    stream: Option<DStream<'static>>,
    need: usize,
}

impl BoundedZstd {
    pub(crate) fn new(window_log: u32) -> Self {
        BoundedZstd {
            window_log,
            stream: None,
            need: 0,
        }
    }

    fn fail(&self, code: usize) -> McapError {
        McapError::DecompressionError(format!(
            "zstd: {} (windows are limited to {} KiB for a file of this size)",
            get_error_name(code),
            (1u64 << self.window_log) >> 10
        ))
    }

    fn stream(&mut self) -> Result<&mut DStream<'static>, McapError> {
        if self.stream.is_none() {
            let mut s = DStream::create();
            s.init().map_err(|c| self.fail(c))?;
            s.set_parameter(DParameter::WindowLogMax(self.window_log))
                .map_err(|c| self.fail(c))?;
            self.stream = Some(s);
        }
        Ok(self.stream.as_mut().expect("created above"))
    }
}

impl Decompressor for BoundedZstd {
    fn next_read_size(&self) -> usize {
        self.need
    }

    fn decompress(&mut self, src: &[u8], dst: &mut [u8]) -> Result<DecompressResult, McapError> {
        let mut input = InBuffer::around(src);
        let mut output = OutBuffer::around(dst);
        let stream = self.stream()?;
        let need = stream.decompress_stream(&mut output, &mut input);
        let need = need.map_err(|c| self.fail(c))?;
        self.need = need;
        Ok(DecompressResult {
            consumed: input.pos,
            wrote: output.pos(),
        })
    }

    fn reset(&mut self) -> Result<(), McapError> {
        self.need = 0;
        if let Some(s) = self.stream.as_mut() {
            // the session only: the window bound is a parameter and stays
            s.reset(ResetDirective::SessionOnly)
                .map_err(|c| McapError::DecompressionError(get_error_name(c).into()))?;
        }
        Ok(())
    }

    fn name(&self) -> &'static str {
        "zstd"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bound_is_the_next_power_of_two_within_its_limits() {
        assert_eq!(window_log_for(0), MIN_WINDOW_LOG);
        assert_eq!(window_log_for(300 * 8), MIN_WINDOW_LOG);
        assert_eq!(window_log_for(1 << 20), 20);
        assert_eq!(window_log_for((1 << 20) + 1), 21);
        assert_eq!(window_log_for(1 << 40), MAX_WINDOW_LOG);
    }

    /// A 3 MiB frame (its window the content's size) is refused under a
    /// 2^20 bound and read under 2^22.
    #[test]
    fn a_frame_whose_window_exceeds_the_bound_is_refused() {
        use zstd::zstd_safe::{CCtx, CParameter};
        let data: Vec<u8> = (0..(3u32 << 20))
            .map(|i| (i % 251) as u8 ^ (i >> 13) as u8)
            .collect();
        let mut c = CCtx::create();
        c.set_parameter(CParameter::WindowLog(22)).unwrap();
        let mut frame = vec![0u8; zstd::zstd_safe::compress_bound(data.len())];
        let n = c.compress2(&mut frame[..], &data).unwrap();
        frame.truncate(n);
        let decode = |log: u32| {
            let mut d = BoundedZstd::new(log);
            let mut out = vec![0u8; data.len()];
            let (mut at_in, mut at_out) = (0, 0);
            while at_out < out.len() {
                // 64 KiB at a time, as the reader asks: a destination
                // holding the whole frame is decoded into directly, without
                // a window to allocate
                let end = (at_out + (64 << 10)).min(out.len());
                let r = d.decompress(&frame[at_in..], &mut out[at_out..end])?;
                if r.consumed == 0 && r.wrote == 0 {
                    break;
                }
                (at_in, at_out) = (at_in + r.consumed, at_out + r.wrote);
            }
            Ok::<_, McapError>(out[..at_out] == data[..])
        };
        let refused = decode(20).expect_err("a 3 MiB window under a 1 MiB bound");
        assert!(refused.to_string().contains("1024 KiB"), "{refused}");
        assert!(decode(22).unwrap(), "the same frame under its own window");
    }
}
