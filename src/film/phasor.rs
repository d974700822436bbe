//! `phasor_hdr_film` (mitransient): the transient stored in the frequency domain, for phasor-field
//! NLOS reconstruction (Liu et al. 2019, "Non-line-of-sight imaging using phasor-field virtual wave
//! optics"). Each contribution of value v at optical path d adds v·e^{−2πi f (d − start_opl)} to
//! every stored frequency f; nothing is binned, so the phasors are exact in time. The frequencies
//! are those of an FFT of the film's `temporal_bins` bins of `bin_width_opl` that a Morlet filter
//! of central wavelength `wl_mean` and width ~6·`wl_sigma` passes (±3 of its standard deviations).
//!
//! Output per pixel: (frequency, [re, im]), mono only, as mitransient.

use crate::error::{NlosError, Result};
use crate::props::Props;

/// The frequency set of a phasor film.
#[derive(Clone, Debug, PartialEq)]
pub struct Phasor {
    /// Frequencies, in cycles per unit optical path (1/m).
    pub frequencies: Vec<f64>,
}

impl Phasor {
    /// `wl_mean` and `wl_sigma` (optical path units) over `bins` bins of `bin_width`.
    pub fn from_props(p: &Props, bins: usize, bin_width: f64) -> Result<Self> {
        let wl_mean = p.float("wl_mean", 100.0)?;
        let wl_sigma = p.float("wl_sigma", 1000.0)?;
        for (key, v) in [("wl_mean", wl_mean), ("wl_sigma", wl_sigma)] {
            if !(v > 0.0) {
                return Err(NlosError::prop(&p.plugin, key, "must be positive"));
            }
        }
        let n = bins as f64;
        let mean_idx = n * bin_width / wl_mean;
        let sigma_idx = n * bin_width / (wl_sigma * 6.0);
        let lo = (mean_idx - 3.0 * sigma_idx).floor().max(0.0) as usize;
        let hi = ((mean_idx + 3.0 * sigma_idx).ceil() as usize).min(bins / 2);
        // numpy.fft.fftfreq(n, d)[k]: k/(n d) below ⌈n/2⌉, (k − n)/(n d) from there.
        let positive = bins.div_ceil(2);
        let frequencies: Vec<f64> = (lo..=hi)
            .map(|k| {
                let k = if k < positive { k as f64 } else { k as f64 - n };
                (k / (n * bin_width)) as f32 as f64
            })
            .collect();
        if frequencies.is_empty() || frequencies.len() > 65_536 {
            return Err(NlosError::prop(
                &p.plugin,
                "wl_mean",
                format!(
                    "selects {} frequencies (wl_mean, wl_sigma, temporal_bins and bin_width_opl give the range)",
                    frequencies.len()
                ),
            ));
        }
        Ok(Self { frequencies })
    }

    /// Add a contribution of value `v` (one channel) at relative optical path `d` to `out`,
    /// laid out as [re, im] per frequency.
    #[inline]
    pub fn put(&self, d: f64, v: f32, out: &mut [f32]) {
        for (f, re_im) in self.frequencies.iter().zip(out.chunks_exact_mut(2)) {
            let phase =
                (-2.0 * std::f64::consts::PI * f * d).rem_euclid(2.0 * std::f64::consts::PI);
            let (s, c) = phase.sin_cos();
            re_im[0] += v * c as f32;
            re_im[1] += v * s as f32;
        }
    }
}
