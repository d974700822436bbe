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
use std::ops::Range;

/// The frequency set of a phasor film.
#[derive(Clone, Debug, PartialEq)]
pub struct Phasor {
    /// Frequencies, in cycles per unit optical path (1/m): the FFT grid's, k/(n·w).
    pub frequencies: Vec<f64>,
    /// The FFT's spacing 1/(n·w), by which consecutive FFT indices' frequencies differ.
    spacing: f64,
    /// The runs of `frequencies` at consecutive FFT indices.
    runs: Vec<Run>,
    /// (sin, cos) of 2π k / [`CIRCLE`] for k in 0..[`CIRCLE`].
    circle: Vec<(f64, f64)>,
}

/// Points of the unit circle `Phasor::circle` holds (16 KB): a turn is the nearest one's phasor
/// turned by the rest, at most π / 1024, whose sine and cosine take four Taylor terms each.
const CIRCLE: usize = 1024;

/// A run of frequencies at consecutive FFT indices.
#[derive(Clone, Debug, PartialEq)]
struct Run {
    /// Their indices in [`Phasor::frequencies`].
    freqs: Range<usize>,
    /// The first's FFT index k (signed), whose frequency is k spacings.
    index: i64,
}

/// Frequencies whose phasors a run advances together, each turned by four spacings a step.
const LANES: usize = 4;

/// The complex product of the phasors (sin, cos) `a` and `b`.
#[inline(always)]
fn turn_by(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0 * b.1 + a.1 * b.0, a.1 * b.1 - a.0 * b.0)
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
        let frequencies: Vec<f64> = (lo..=hi).map(|k| signed(k) / (n * bin_width)).collect();
        let mut runs: Vec<Run> = Vec::new();
        for (j, k) in (lo..=hi).enumerate() {
            match runs.last_mut() {
                Some(run) if signed(k) == signed(k - 1) + 1.0 => run.freqs.end = j + 1,
                _ => runs.push(Run {
                    freqs: j..j + 1,
                    index: signed(k) as i64,
                }),
            }
        }
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
        let circle = (0..CIRCLE)
            .map(|k| (std::f64::consts::TAU * k as f64 / CIRCLE as f64).sin_cos())
            .collect();
        Ok(Self {
            frequencies,
            spacing: 1.0 / (n * bin_width),
            runs,
            circle,
        })
    }

    /// Add a contribution of value `v` (one channel) at relative optical path `d` to `out`,
    /// laid out as [re, im] per frequency.
    ///
    /// The phasors e^{−2πi f d} of a run of consecutive FFT frequencies are one rotation apart,
    /// e^{−2πi Δ d} for the spacing Δ, and the run's first, of FFT index k, is that rotation's
    /// k-th power (by squaring): a run's first [`LANES`] phasors are its first one turned by that
    /// rotation, and each later one is the phasor [`LANES`] before it turned by that rotation's
    /// [`LANES`]-th power (one sine and cosine a contribution instead of one per frequency, which
    /// took most of a phasor render's time). The phasors are exact to about 1e-14, against the
    /// 6e-8 of the f32 sums. The [`LANES`] frequencies of a step are independent: with AVX2 they
    /// are one vector (the same operations, so the same bits).
    #[inline]
    pub fn put(&self, d: f64, v: f32, out: &mut [f32]) {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::available() {
            // SAFETY: the CPU runs AVX2 (and FMA, which `put_lanes` does not use: Rust fuses no
            // multiply-add it is not asked to).
            return unsafe { self.put_avx2(d, v, out) };
        }
        self.put_lanes(d, v, out)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn put_avx2(&self, d: f64, v: f32, out: &mut [f32]) {
        self.put_lanes(d, v, out)
    }

    /// (sin, cos) of −2π `cycles`: the nearest point of [`CIRCLE`] turned by the rest φ
    /// (|φ| ≤ π / 1024; the Taylor polynomials' truncation is below 1e-22).
    #[inline(always)]
    fn turn(&self, cycles: f64) -> (f64, f64) {
        let x = (cycles - cycles.floor()) * CIRCLE as f64;
        let k = x.round();
        let phi = (x - k) * (std::f64::consts::TAU / CIRCLE as f64);
        let p2 = phi * phi;
        let sin = phi * (1.0 - p2 * (1.0 / 6.0 - p2 * (1.0 / 120.0 - p2 * (1.0 / 5040.0))));
        let cos = 1.0 - p2 * (0.5 - p2 * (1.0 / 24.0 - p2 * (1.0 / 720.0)));
        let (s, c) = turn_by(self.circle[k as usize % CIRCLE], (sin, cos));
        (-s, c)
    }

    #[inline(always)]
    fn put_lanes(&self, d: f64, v: f32, out: &mut [f32]) {
        let step = self.turn(self.spacing * d);
        let stride = turn_by(turn_by(step, step), turn_by(step, step));
        for Run { freqs: run, index } in &self.runs {
            // The phasors of frequencies j..j + LANES, as sines and cosines.
            let (mut s, mut c) = ([0.0; LANES], [1.0; LANES]);
            (s[0], c[0]) = power(step, *index);
            for k in 1..LANES {
                (s[k], c[k]) = turn_by((s[k - 1], c[k - 1]), step);
            }
            let mut j = run.start;
            while j < run.end {
                let n = (run.end - j).min(LANES);
                if n == LANES {
                    let re_im: &mut [f32; 2 * LANES] = (&mut out[2 * j..2 * (j + LANES)])
                        .try_into()
                        .expect("a frequency's [re, im] per frequency");
                    let add: [f32; 2 * LANES] = std::array::from_fn(|i| {
                        v * if i % 2 == 0 { c[i / 2] } else { s[i / 2] } as f32
                    });
                    for (o, a) in re_im.iter_mut().zip(add) {
                        *o += a;
                    }
                } else {
                    for k in 0..n {
                        out[2 * (j + k)] += v * c[k] as f32;
                        out[2 * (j + k) + 1] += v * s[k] as f32;
                    }
                }
                (s, c) = turn_lanes(s, c, stride);
                j += n;
            }
        }
    }
}

/// The phasor `z` (sin, cos) to the power `k` (its conjugate's for k < 0), by squaring.
#[inline(always)]
fn power(z: (f64, f64), k: i64) -> (f64, f64) {
    let (mut base, mut e) = (z, k.unsigned_abs());
    let mut out = (0.0, 1.0);
    while e != 0 {
        if e & 1 != 0 {
            out = turn_by(out, base);
        }
        base = turn_by(base, base);
        e >>= 1;
    }
    if k < 0 { (-out.0, out.1) } else { out }
}

/// The phasors (`s`, `c`) each turned by `by`.
#[inline(always)]
fn turn_lanes(s: [f64; LANES], c: [f64; LANES], by: (f64, f64)) -> ([f64; LANES], [f64; LANES]) {
    (
        std::array::from_fn(|k| s[k] * by.1 + c[k] * by.0),
        std::array::from_fn(|k| c[k] * by.1 - s[k] * by.0),
    )
}
