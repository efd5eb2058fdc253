//! A record read a block at a time: the sizes the long reductions work in
//! and how they read a force and a response (or a reference alone) from a
//! [`FrameSource`] (a recording on disk, or channels held in memory or in
//! scratch files), shared by the swept-sine and stepped-sine reductions.

use crate::error::{Error, Result};
use crate::signals::FrameSource;

/// Records of at most this many frames are reduced whole (2^21: 105 s at
/// 20 kHz), longer ones a block at a time (see the module docs).
pub const WHOLE_RECORD_FRAMES: usize = BLOCKS.whole;

/// The sizes the reduction works in.
#[derive(Clone, Copy, Debug)]
pub(super) struct Blocks {
    /// Records of at most this many frames are transformed whole.
    pub whole: usize,
    /// Frames of the phase kept per analytic block.
    pub analytic_block: usize,
    /// Frames of the record transformed with a block on either side.
    pub analytic_margin: usize,
    /// The compensation's FFT length, at least.
    pub convolution: usize,
    /// Phase and envelope points kept, at most.
    pub phase_points: usize,
    /// Frames read from a file at a time, at least.
    pub read: usize,
}

/// The sizes the library uses.
pub(super) const BLOCKS: Blocks = Blocks {
    whole: 1 << 21,
    analytic_block: 1 << 19,
    analytic_margin: 1 << 17,
    convolution: 1 << 19,
    phase_points: 1 << 18,
    read: 1 << 18,
};

/// Blocks small enough that the tests' records of some 10^5 frames are read
/// as long ones are: analytic blocks of 16 384 frames with 8 192 either side
/// (40 periods at the test sweep's lowest 5 Hz), FFTs of 4 096 at least,
/// reads of 1 024.
#[cfg(test)]
pub(super) const SMALL: Blocks = Blocks {
    whole: 1 << 12,
    analytic_block: 1 << 14,
    analytic_margin: 1 << 13,
    convolution: 1 << 12,
    phase_points: 1 << 17,
    read: 1 << 10,
};

/// The force (reference) and response of a swept record, a stretch at a
/// time.
pub(super) trait PairSource {
    /// Frames in the record.
    fn frames(&self) -> usize;
    /// The force and the response over frames `a..b` (`a ≤ b ≤ frames`).
    fn pair(&mut self, a: usize, b: usize) -> Result<(&[f64], &[f64])>;
}

/// Both channels in memory (the tests' records, read by the block stages
/// directly).
#[cfg(test)]
pub(super) struct InMemory<'a> {
    pub force: &'a [f64],
    pub response: &'a [f64],
}

#[cfg(test)]
impl PairSource for InMemory<'_> {
    fn frames(&self) -> usize {
        self.force.len()
    }
    fn pair(&mut self, a: usize, b: usize) -> Result<(&[f64], &[f64])> {
        Ok((&self.force[a..b], &self.response[a..b]))
    }
}

/// Two channels of a [`FrameSource`], read a stretch of at least
/// [`Blocks::read`] frames at a time.
pub(super) struct FramePair<'s, S: FrameSource> {
    source: &'s mut S,
    /// Reference and response channels.
    channels: [usize; 2],
    /// The first frame held.
    start: usize,
    held: [Vec<f64>; 2],
    scratch: Vec<Vec<f64>>,
    read: usize,
}

impl<S: FrameSource> PairSource for FramePair<'_, S> {
    fn frames(&self) -> usize {
        self.source.frames()
    }
    fn pair(&mut self, a: usize, b: usize) -> Result<(&[f64], &[f64])> {
        if a < self.start || b > self.start + self.held[0].len() {
            let count = (b - a).max(self.read).min(self.source.frames() - a);
            let got = self.source.read_at(a, count, &mut self.scratch)?;
            if got < b - a {
                return Err(Error::input(
                    self.source.source_name(),
                    format!("read {got} of frames {a}..{b}: the file ends early"),
                ));
            }
            let [reference, response] = self.channels;
            std::mem::swap(&mut self.held[0], &mut self.scratch[reference]);
            if response != reference {
                std::mem::swap(&mut self.held[1], &mut self.scratch[response]);
            }
            self.start = a;
        }
        let o = a - self.start;
        let n = b - a;
        // a reference read alone is its own response
        let response = if self.channels[0] == self.channels[1] {
            &self.held[0]
        } else {
            &self.held[1]
        };
        Ok((&self.held[0][o..o + n], &response[o..o + n]))
    }
}

/// Channel `reference` of `source` alone as a [`PairSource`] (the response:
/// the same stretch), read a stretch of at least `blocks.read` frames at a
/// time.
pub(super) fn frame_reference<'s, S: FrameSource>(
    source: &'s mut S,
    reference: usize,
    blocks: &Blocks,
) -> Result<FramePair<'s, S>> {
    let n = source.meta().channels.len();
    if reference >= n {
        return Err(Error::input(
            format!("reference channel {reference}"),
            format!("out of range: {} has {n} channels", source.source_name()),
        ));
    }
    Ok(FramePair {
        source,
        channels: [reference, reference],
        start: 0,
        held: [Vec::new(), Vec::new()],
        scratch: vec![Vec::new(); n],
        read: blocks.read,
    })
}

pub(super) fn frame_pair<'s, S: FrameSource>(
    source: &'s mut S,
    reference: usize,
    response: usize,
    blocks: &Blocks,
) -> Result<FramePair<'s, S>> {
    let n = source.meta().channels.len();
    if reference >= n || response >= n || reference == response {
        return Err(Error::input(
            format!("{} channels", source.source_name()),
            format!(
                "reference {reference} and response {response}: two different channels of the \
                 {n} are needed"
            ),
        ));
    }
    Ok(FramePair {
        source,
        channels: [reference, response],
        start: 0,
        held: [Vec::new(), Vec::new()],
        scratch: vec![Vec::new(); n],
        read: blocks.read,
    })
}
