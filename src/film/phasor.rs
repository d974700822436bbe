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
    /// The FFT's spacing 1/(n·w), by which consecutive FFT indices' frequencies differ.
    spacing: f64,
    /// Per frequency, how far it lies from its run's first frequency plus whole spacings (its and
    /// the first's rounding to f32); `None` where a run of consecutive FFT indices starts.
    drift: Vec<Option<f64>>,
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
        let signed = |k: usize| if k < positive { k as f64 } else { k as f64 - n };
        let frequencies: Vec<f64> = (lo..=hi)
            .map(|k| (signed(k) / (n * bin_width)) as f32 as f64)
            .collect();
        let spacing = 1.0 / (n * bin_width);
        let mut first = 0;
        let drift = (lo..=hi)
            .enumerate()
            .map(|(j, k)| {
                if k == lo || signed(k) != signed(k - 1) + 1.0 {
                    first = j;
                    return None;
                }
                Some(frequencies[j] - frequencies[first] - (j - first) as f64 * spacing)
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
        Ok(Self {
            frequencies,
            spacing,
            drift,
        })
    }

    /// Add a contribution of value `v` (one channel) at relative optical path `d` to `out`,
    /// laid out as [re, im] per frequency.
    ///
    /// The phasors e^{−2πi f d} of a run of consecutive FFT frequencies are one rotation apart,
    /// e^{−2πi Δ d} for the spacing Δ: each is the one before times that rotation (two sines and
    /// cosines a contribution instead of one per frequency, which took most of a phasor render's
    /// time), then turned by the frequency's small drift off the grid (its rounding to f32) from
    /// the sine's and cosine's Taylor polynomials. Both are exact to about 1e-14, against the
    /// 6e-8 of the f32 sums; a drift whose turn is not small is computed directly.
    #[inline]
    pub fn put(&self, d: f64, v: f32, out: &mut [f32]) {
        use std::f64::consts::TAU;
        let turn = |f: f64| (-TAU * f * d).rem_euclid(TAU).sin_cos();
        let (rs, rc) = turn(self.spacing);
        let (mut s, mut c) = (0.0, 1.0);
        for ((&f, &drift), re_im) in self
            .frequencies
            .iter()
            .zip(&self.drift)
            .zip(out.chunks_exact_mut(2))
        {
            let (ps, pc) = if let Some(drift) = drift {
                (s, c) = (s * rc + c * rs, c * rc - s * rs);
                let a = -TAU * drift * d;
                if a.abs() < 1e-3 {
                    // sin a and cos a to a⁵ and a⁴ (truncation below 2e-21).
                    let a2 = a * a;
                    let (sa, ca) = (
                        a * (1.0 - a2 / 6.0 * (1.0 - a2 / 20.0)),
                        1.0 - a2 / 2.0 * (1.0 - a2 / 12.0),
                    );
                    (s * ca + c * sa, c * ca - s * sa)
                } else {
                    turn(f)
                }
            } else {
                (s, c) = turn(f);
                (s, c)
            };
            re_im[0] += v * pc as f32;
            re_im[1] += v * ps as f32;
        }
    }
}
