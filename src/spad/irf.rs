//! The instrument response (IRF): the laser pulse's width and the detector's timing jitter blur
//! the transient along time. Both are Gaussian (given as FWHM); the jitter may have an exponential
//! tail (an exponentially modified Gaussian, the usual shape of a SPAD's timing response); or a
//! measured IRF replaces both. The response is integrated over each bin and normalised to sum 1,
//! so convolving with it conserves energy: what leaves the window at its ends is all that is lost.
//! The variance it adds is σ_pulse² + σ_jitter² + τ² (+ Δ²/12 from the binning, Δ the bin width).

use super::{PLUGIN, Spad};
use crate::error::{NlosError, Result};

/// FWHM of a Gaussian over its standard deviation, 2√(2 ln 2).
pub const FWHM_PER_SIGMA: f64 = 2.354_820_045_030_949;

/// Longest response accepted (bins): keeps the direct convolution bounded.
const MAX_TAPS: usize = 1 << 16;

/// A response at the capture's bin width: `taps[k]` weighs a delay of `k − lag0` bins.
#[derive(Clone, Debug)]
pub struct Kernel {
    /// Weights, summing to 1.
    pub taps: Vec<f64>,
    /// Index of zero delay.
    pub lag0: usize,
}

impl Kernel {
    /// The response of `spad` at bins of `bin_ps` picoseconds.
    pub fn new(spad: &Spad, bin_ps: f64) -> Result<Self> {
        if let Some(irf) = &spad.irf {
            // A measured response: zero delay at its peak.
            let sum: f64 = irf.iter().sum();
            let lag0 = irf
                .iter()
                .enumerate()
                .fold(0, |best, (i, &v)| if v > irf[best] { i } else { best });
            return Ok(Self {
                taps: irf.iter().map(|v| v / sum).collect(),
                lag0,
            });
        }
        let sigma =
            (spad.pulse_fwhm_ps.powi(2) + spad.jitter_fwhm_ps.powi(2)).sqrt() / FWHM_PER_SIGMA;
        let tau = spad.jitter_tail_ps;
        if sigma == 0.0 && tau == 0.0 {
            return Ok(Self {
                taps: vec![1.0],
                lag0: 0,
            });
        }
        // Support: 7σ before zero delay, 7σ + 30τ after (what lies beyond is below 1e-11).
        let before = 7.0 * sigma + bin_ps;
        let after = 7.0 * sigma + 30.0 * tau + bin_ps;
        let lag0 = (before / bin_ps).ceil() as usize;
        let len = lag0 + (after / bin_ps).ceil() as usize + 1;
        if len > MAX_TAPS {
            return Err(NlosError::prop(
                PLUGIN,
                "jitter_tail_ps",
                format!("the response spans {len} bins of {bin_ps:.3} ps (at most {MAX_TAPS})"),
            ));
        }
        // A fine grid (step h well below σ, τ and the bin) carries the Gaussian density, then the
        // exponential tail as a first-order recursive filter, then each fine cell's mass goes to the
        // bin holding its centre: bin k covers delays [(k − ½)Δ, (k + ½)Δ).
        let h = [bin_ps, sigma, tau]
            .into_iter()
            .filter(|&v| v > 0.0)
            .fold(f64::INFINITY, f64::min)
            / 32.0;
        let start = -(lag0 as f64 + 0.5) * bin_ps;
        let cells = ((len as f64 * bin_ps) / h).ceil() as usize;
        let mut fine: Vec<f64> = if sigma > 0.0 {
            (0..cells)
                .map(|m| (-0.5 * ((start + (m as f64 + 0.5) * h) / sigma).powi(2)).exp())
                .collect()
        } else {
            // No pulse width and no Gaussian jitter: the tail alone, from zero delay.
            let mut v = vec![0.0; cells];
            v[((-start / h) as usize).min(cells - 1)] = 1.0;
            v
        };
        if tau > 0.0 {
            let a = (-h / tau).exp();
            let mut y = 0.0;
            for v in fine.iter_mut() {
                y = a * y + (1.0 - a) * *v;
                *v = y;
            }
        }
        let mut taps = vec![0.0f64; len];
        for (m, v) in fine.iter().enumerate() {
            let t = start + (m as f64 + 0.5) * h;
            let k = (t / bin_ps + lag0 as f64 + 0.5).floor();
            if k >= 0.0 && (k as usize) < len {
                taps[k as usize] += v;
            }
        }
        let sum: f64 = taps.iter().sum();
        if !(sum > 0.0) {
            return Err(NlosError::prop(
                PLUGIN,
                "pulse_fwhm_ps",
                "the instrument response is empty at this bin width",
            ));
        }
        taps.iter_mut().for_each(|v| *v /= sum);
        Ok(Self { taps, lag0 })
    }

    /// `out = signal ⊛ taps` over the window (out's length is signal's), skipping empty bins.
    pub fn convolve(&self, signal: &[f64], out: &mut [f64]) {
        out.fill(0.0);
        let n = signal.len() as isize;
        for (j, &s) in signal.iter().enumerate() {
            if s == 0.0 {
                continue;
            }
            let first = j as isize - self.lag0 as isize;
            let k0 = (-first).max(0) as usize;
            let k1 = ((n - first).max(0) as usize).min(self.taps.len());
            for k in k0..k1 {
                out[(first + k as isize) as usize] += s * self.taps[k];
            }
        }
    }
}
