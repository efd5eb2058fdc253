//! Coherent extraction for the virtual test bench: whole periods per block,
//! one FFT per block, harmonics exactly on bins.
//!
//! When a block of `L` samples holds exactly `M` periods, harmonic `h` is
//! exactly bin `hM` of the block's DFT and a rectangular window has no leakage
//! (coherent sampling; Antoni & Schoukens, IEEE TIM 58(9), 2009). The
//! single-sided amplitude is `2 X[hM] / L` (`X[0]/L` for the mean), in the
//! convention of [`crate::harmonics`].

use super::DwellHarmonics;
use super::estimator::{check_finite, h1_from_blocks};
use crate::error::{Error, Result};
use num_complex::Complex64;
use realfft::{RealFftPlanner, RealToComplex};
use std::sync::Arc;

/// Extracts harmonics from coherently sampled records, caching the FFT plan
/// and the buffers between calls (one analyser per thread: it is `Send`).
pub struct HarmonicAnalyser {
    planner: RealFftPlanner<f64>,
    plan: Option<Arc<dyn RealToComplex<f64>>>,
    input: Vec<f64>,
    spectrum: Vec<Complex64>,
    scratch: Vec<Complex64>,
    force_blocks: Vec<Complex64>,
    response_blocks: Vec<Complex64>,
}

impl std::fmt::Debug for HarmonicAnalyser {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HarmonicAnalyser")
            .field("block_len", &self.plan.as_ref().map(|p| p.len()))
            .finish_non_exhaustive()
    }
}

impl Default for HarmonicAnalyser {
    fn default() -> Self {
        Self::new()
    }
}

/// Checks the block layout; `K·M` must stay below `L/2` so that every
/// harmonic is a distinct bin under the Nyquist bin.
pub(crate) fn check_layout(
    block_len: usize,
    periods_per_block: usize,
    max_harmonic: usize,
) -> Result<()> {
    if periods_per_block == 0 {
        return Err(Error::input(
            "periods_per_block",
            "must be at least 1 (each block holds whole periods)",
        ));
    }
    if max_harmonic == 0 {
        return Err(Error::input(
            "max_harmonic",
            "must be at least 1: the FRF is taken relative to the force fundamental",
        ));
    }
    if max_harmonic
        .saturating_mul(periods_per_block)
        .saturating_mul(2)
        >= block_len
    {
        return Err(Error::input(
            "max_harmonic",
            format!(
                "harmonic {max_harmonic} of a block of {block_len} samples holding \
                 {periods_per_block} period(s) is bin {} at or above the Nyquist bin {}: \
                 at most harmonic {} is resolvable ({:.2} samples per period)",
                max_harmonic * periods_per_block,
                block_len / 2,
                (block_len - 1) / (2 * periods_per_block),
                block_len as f64 / periods_per_block as f64
            ),
        ));
    }
    Ok(())
}

impl HarmonicAnalyser {
    /// An analyser with no plan yet (the first call plans its block length).
    pub fn new() -> Self {
        HarmonicAnalyser {
            planner: RealFftPlanner::new(),
            plan: None,
            input: Vec::new(),
            spectrum: Vec::new(),
            scratch: Vec::new(),
            force_blocks: Vec::new(),
            response_blocks: Vec::new(),
        }
    }

    fn prepare(&mut self, block_len: usize) {
        if self.plan.as_ref().is_some_and(|p| p.len() == block_len) {
            return;
        }
        let plan = self.planner.plan_fft_forward(block_len);
        self.input = plan.make_input_vec();
        self.spectrum = plan.make_output_vec();
        self.scratch = plan.make_scratch_vec();
        self.plan = Some(plan);
    }

    /// Harmonics `0..=K` of the block currently in `self.input` (destroyed),
    /// written to `out`.
    fn transform(&mut self, periods_per_block: usize, out: &mut [Complex64]) -> Result<()> {
        let plan = self.plan.as_ref().expect("prepared");
        let len = plan.len();
        plan.process_with_scratch(&mut self.input, &mut self.spectrum, &mut self.scratch)
            .map_err(|e| Error::input("FFT", e.to_string()))?;
        let scale = 2.0 / len as f64;
        out[0] = Complex64::new(self.spectrum[0].re / len as f64, 0.0);
        for (h, o) in out.iter_mut().enumerate().skip(1) {
            *o = self.spectrum[h * periods_per_block] * scale;
        }
        Ok(())
    }

    /// Harmonics `F_0..F_K` and `Y_0..Y_K` of force and response and the H1
    /// FRFs `H_k = Y_k/F_1` with their standard errors, from a coherently
    /// sampled dwell.
    ///
    /// The record is split into whole blocks of `block_len` samples, each
    /// holding exactly `periods_per_block` periods (the caller's sampling
    /// guarantees it), so harmonic `h` is bin `h·periods_per_block`. Samples
    /// after the last whole block are not used. The harmonics returned are
    /// the block means; `H_k` is the H1 estimator over blocks and its
    /// standard error is the RMS of the complex error from the block scatter
    /// (see [`DwellHarmonics::std_error`]).
    ///
    /// Errors: lengths differ, a non-finite sample (named), harmonic `K` at or
    /// above Nyquist, fewer than 2 whole blocks, zero force fundamental.
    pub fn coherent(
        &mut self,
        force: &[f64],
        response: &[f64],
        block_len: usize,
        periods_per_block: usize,
        max_harmonic: usize,
    ) -> Result<DwellHarmonics> {
        check_layout(block_len, periods_per_block, max_harmonic)?;
        super::check_paired(force, response, "response")?;
        let blocks = force.len() / block_len;
        if blocks < 2 {
            return Err(Error::input(
                "force",
                format!(
                    "{} samples hold {blocks} whole block(s) of {block_len}: at least 2 are \
                     needed (the standard error comes from the block-to-block scatter)",
                    force.len()
                ),
            ));
        }
        let used = blocks * block_len;
        check_finite(&force[..used], "force")?;
        check_finite(&response[..used], "response")?;
        self.prepare(block_len);
        let width = max_harmonic + 1;
        let mut fb = std::mem::take(&mut self.force_blocks);
        let mut yb = std::mem::take(&mut self.response_blocks);
        fb.resize(blocks * width, Complex64::default());
        yb.resize(blocks * width, Complex64::default());
        let mut result = Ok(());
        for b in 0..blocks {
            let range = b * block_len..(b + 1) * block_len;
            self.input.copy_from_slice(&force[range.clone()]);
            result = result.and(self.transform(periods_per_block, &mut fb[b * width..][..width]));
            self.input.copy_from_slice(&response[range]);
            result = result.and(self.transform(periods_per_block, &mut yb[b * width..][..width]));
        }
        let out = result.and_then(|_| h1_from_blocks(&fb, &yb, max_harmonic, "coherent dwell"));
        self.force_blocks = fb;
        self.response_blocks = yb;
        out
    }

    /// Harmonics `0..=K` of `signal`, averaged over its whole blocks (the
    /// harmonics of the synchronous average; one FFT however many blocks).
    /// The cheap per-block check of the bench's settling test.
    ///
    /// Errors: no whole block, a non-finite sample, harmonic `K` at or above
    /// Nyquist.
    pub fn harmonics(
        &mut self,
        signal: &[f64],
        block_len: usize,
        periods_per_block: usize,
        max_harmonic: usize,
    ) -> Result<Vec<Complex64>> {
        let mut out = vec![Complex64::default(); max_harmonic + 1];
        self.harmonics_into(signal, block_len, periods_per_block, &mut out)?;
        Ok(out)
    }

    /// [`Self::harmonics`] into a caller's buffer of `K+1` values (no
    /// allocation once the plan exists).
    pub fn harmonics_into(
        &mut self,
        signal: &[f64],
        block_len: usize,
        periods_per_block: usize,
        out: &mut [Complex64],
    ) -> Result<()> {
        let max_harmonic = out.len().saturating_sub(1);
        check_layout(block_len, periods_per_block, max_harmonic)?;
        let blocks = signal.len() / block_len;
        if blocks == 0 {
            return Err(Error::input(
                "signal",
                format!(
                    "{} samples: at least one whole block of {block_len} is needed",
                    signal.len()
                ),
            ));
        }
        check_finite(&signal[..blocks * block_len], "signal")?;
        self.prepare(block_len);
        self.input.copy_from_slice(&signal[..block_len]);
        for b in 1..blocks {
            for (a, s) in self.input.iter_mut().zip(&signal[b * block_len..]) {
                *a += s;
            }
        }
        if blocks > 1 {
            let inv = 1.0 / blocks as f64;
            self.input.iter_mut().for_each(|a| *a *= inv);
        }
        self.transform(periods_per_block, out)
    }
}

/// Whether two harmonic sets agree: `max_k |a_k − b_k| ≤ rel_tol · |a_1|`
/// (relative to the fundamental's magnitude, the settling test's measure).
/// False when the lengths differ, a value is not finite, or either has no
/// fundamental.
pub fn harmonics_agree(a: &[Complex64], b: &[Complex64], rel_tol: f64) -> bool {
    if a.len() != b.len() || a.len() < 2 {
        return false;
    }
    let limit = rel_tol * a[1].norm();
    a.iter()
        .zip(b)
        .all(|(x, y)| x.is_finite() && y.is_finite() && (x - y).norm() <= limit)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn analyser_is_send() {
        fn send<T: Send>() {}
        send::<HarmonicAnalyser>();
    }

    #[test]
    fn agreement_is_relative_to_the_fundamental() {
        let a = [Complex64::new(0.1, 0.0), Complex64::new(2.0, 0.0)];
        let b = [Complex64::new(0.1 + 1.9e-3, 0.0), Complex64::new(2.0, 0.0)];
        assert!(harmonics_agree(&a, &b, 1e-3));
        assert!(!harmonics_agree(&a, &b, 0.9e-3));
        assert!(!harmonics_agree(&a, &b[..1], 1.0));
        let nan = [Complex64::new(f64::NAN, 0.0), Complex64::new(2.0, 0.0)];
        assert!(!harmonics_agree(&a, &nan, 1.0));
    }
}
