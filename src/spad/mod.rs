//! The SPAD capture model: what a single-photon avalanche diode with time-correlated single-photon
//! counting (TCSPC) records of a rendered transient (docs/sensor.md). A render gives the
//! noise-free radiometric transient; this module turns it into
//! * [`expected_counts`]: the mean number of detections per bin over the exposure, absolutely
//!   calibrated ([`calibration`]) and blurred by the instrument response ([`irf`]), plus dark and
//!   ambient counts;
//! * [`simulate`]: one noisy capture drawn from that mean, with pile-up, afterpulsing and
//!   crosstalk ([`detection`]);
//! * [`coates`]: the pile-up correction of Coates (1968) that recovers the mean from counts.
//!
//! Histograms are laid out as the render's transient: (H, W, T, 1) or, exhaustive,
//! (H, W, LH, LW, T, 1), mono only. Random streams are keyed by (seed, histogram), so a capture is
//! bit-identical whatever the thread count.

pub mod calibration;
pub mod detection;
pub mod irf;

use crate::error::{NlosError, Result};
use crate::parallel::pool;
use crate::scene::Scene;
use rayon::prelude::*;

/// Plugin name in error messages.
const PLUGIN: &str = "spad";

/// Speed of light (m/s).
pub const C: f64 = 299_792_458.0;

/// A SPAD and its laser (defaults: a typical NLOS system, docs/sensor.md).
#[derive(Clone, Debug)]
pub struct Spad {
    /// Laser pulse width, full width at half maximum (ps), Gaussian.
    pub pulse_fwhm_ps: f64,
    /// Detector timing jitter, FWHM (ps), Gaussian.
    pub jitter_fwhm_ps: f64,
    /// Time constant of the jitter's exponential tail (ps); 0 = none.
    pub jitter_tail_ps: f64,
    /// A measured instrument response at the capture's bin width, replacing pulse and jitter.
    pub irf: Option<Vec<f64>>,
    /// Average laser power (W).
    pub laser_power_w: f64,
    /// Laser repetition rate (Hz).
    pub rep_rate_hz: f64,
    /// Laser wavelength (nm).
    pub wavelength_nm: f64,
    /// Exposure per scan point (s).
    pub exposure_s: f64,
    /// Photon detection efficiency in [0, 1].
    pub efficiency: f64,
    /// Dark counts per second.
    pub dark_count_rate_hz: f64,
    /// Detected ambient-light counts per second.
    pub ambient_rate_hz: f64,
    /// First-photon detection per laser period (pile-up).
    pub pile_up: bool,
    /// Dead time after a detection (ns); also the afterpulse delay.
    pub dead_time_ns: f64,
    /// Probability that a detection is followed by an afterpulse one dead time later.
    pub afterpulse_prob: f64,
    /// Probability that a detection triggers a count in one of the four neighbouring pixels.
    pub crosstalk_prob: f64,
    /// Diameter of the collecting aperture (mm).
    pub aperture_diameter_mm: f64,
    /// Area of the wall one pixel sees (m²): the SPAD's active area imaged on the wall.
    pub footprint_m2: f64,
}

impl Default for Spad {
    fn default() -> Self {
        Self {
            pulse_fwhm_ps: 30.0,
            jitter_fwhm_ps: 20.0,
            jitter_tail_ps: 0.0,
            irf: None,
            laser_power_w: 0.25,
            rep_rate_hz: 11e6,
            wavelength_nm: 532.0,
            exposure_s: 8e-3,
            efficiency: 0.4,
            dark_count_rate_hz: 1e3,
            ambient_rate_hz: 0.0,
            pile_up: false,
            dead_time_ns: 0.0,
            afterpulse_prob: 0.0,
            crosstalk_prob: 0.0,
            aperture_diameter_mm: 25.4,
            footprint_m2: 2e-5,
        }
    }
}

impl Spad {
    /// Every parameter finite and in range; errors name the key.
    pub fn check(&self) -> Result<()> {
        let bad = |key: &str, msg: &str| Err(NlosError::prop(PLUGIN, key, msg));
        let non_negative = [
            ("pulse_fwhm_ps", self.pulse_fwhm_ps),
            ("jitter_fwhm_ps", self.jitter_fwhm_ps),
            ("jitter_tail_ps", self.jitter_tail_ps),
            ("laser_power_w", self.laser_power_w),
            ("dark_count_rate_hz", self.dark_count_rate_hz),
            ("ambient_rate_hz", self.ambient_rate_hz),
            ("dead_time_ns", self.dead_time_ns),
        ];
        for (key, v) in non_negative {
            if !(v >= 0.0) || !v.is_finite() {
                return bad(key, "must be a finite number >= 0");
            }
        }
        let positive = [
            ("rep_rate_hz", self.rep_rate_hz),
            ("wavelength_nm", self.wavelength_nm),
            ("exposure_s", self.exposure_s),
            ("aperture_diameter_mm", self.aperture_diameter_mm),
            ("footprint_m2", self.footprint_m2),
        ];
        for (key, v) in positive {
            if !(v > 0.0) || !v.is_finite() {
                return bad(key, "must be a finite number > 0");
            }
        }
        let probabilities = [
            ("efficiency", self.efficiency),
            ("afterpulse_prob", self.afterpulse_prob),
            ("crosstalk_prob", self.crosstalk_prob),
        ];
        for (key, v) in probabilities {
            if !(0.0..=1.0).contains(&v) {
                return bad(key, "must be a probability in [0, 1]");
            }
        }
        if self.afterpulse_prob >= 1.0 {
            return bad(
                "afterpulse_prob",
                "must be below 1 (a chain of afterpulses must end)",
            );
        }
        if self.afterpulse_prob > 0.0 && self.dead_time_ns == 0.0 {
            return bad(
                "afterpulse_prob",
                "afterpulses come one dead time after a detection: set dead_time_ns > 0",
            );
        }
        if self.dead_time_ns * 1e-9 * self.rep_rate_hz > 1.0 {
            return bad(
                "dead_time_ns",
                "a dead time longer than the laser period is not modelled",
            );
        }
        if self.periods() > 1e15 {
            return bad("exposure_s", "more than 1e15 laser periods");
        }
        if let Some(irf) = &self.irf {
            let sum: f64 = irf.iter().sum();
            if irf.is_empty()
                || irf.iter().any(|v| !(*v >= 0.0))
                || !(sum > 0.0)
                || !sum.is_finite()
            {
                return bad(
                    "irf",
                    "must be a non-empty 1-D array of finite values >= 0 with a positive sum",
                );
            }
            if irf.len() > 1 << 20 {
                return bad("irf", "longer than 2^20 bins");
            }
        }
        Ok(())
    }

    /// Laser periods in the exposure, N = exposure × repetition rate.
    pub fn periods(&self) -> f64 {
        self.exposure_s * self.rep_rate_hz
    }
}

/// The capture's histograms: how many, how long, the bin width (ps) and where the window starts
/// within the laser period (ps).
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    /// Histograms (scan points × laser slots).
    pub histograms: usize,
    /// Bins per histogram.
    pub bins: usize,
    /// Bin width (ps).
    pub bin_ps: f64,
    /// Start of bin 0 after the laser fires (ps).
    pub start_ps: f64,
    /// Film (width, height): histograms are (y, x, slot) in row-major order.
    pub film: (usize, usize),
    /// Laser slots per scan point.
    pub slots: usize,
}

impl Layout {
    /// The layout of `scene`'s transient, checked against a transient of `len` values.
    pub fn of(scene: &Scene, len: usize) -> Result<Self> {
        let f = &scene.meter.film;
        if f.phasor.is_some() {
            return Err(NlosError::prop(
                PLUGIN,
                "transient",
                "a phasor_hdr_film has no time bins to count photons in",
            ));
        }
        let slots = f.laser_slots();
        let histograms = f.width * f.height * slots;
        let bins = f.temporal_bins;
        if len == histograms * bins * 3 {
            return Err(NlosError::prop(
                PLUGIN,
                "transient",
                "an rgb transient: a SPAD counts photons of one wavelength, render with mono=True",
            ));
        }
        if len != histograms * bins {
            return Err(NlosError::prop(
                PLUGIN,
                "transient",
                format!(
                    "{len} values do not match the scene's film ({histograms} histograms of {bins} bins, mono)"
                ),
            ));
        }
        let ps = |opl: f64| opl / C * 1e12;
        Ok(Self {
            histograms,
            bins,
            bin_ps: ps(f.bin_width_opl),
            start_ps: ps(f.start_opl),
            film: (f.width, f.height),
            slots,
        })
    }
}

/// Mean detections per bin over the exposure (signal through the instrument response, plus dark and
/// ambient counts), for the mono `transient` of `scene`.
pub fn expected_counts(scene: &Scene, transient: &[f32], spad: &Spad) -> Result<Vec<f64>> {
    spad.check()?;
    let layout = Layout::of(scene, transient.len())?;
    if transient.iter().any(|v| !(*v >= 0.0) || !v.is_finite()) {
        return Err(NlosError::prop(
            PLUGIN,
            "transient",
            "holds values that are negative or not finite (a radiometric transient is >= 0)",
        ));
    }
    let photons = calibration::photons_per_unit(scene, spad, &layout)?;
    let kernel = irf::Kernel::new(spad, layout.bin_ps)?;
    let period_ps = 1e12 / spad.rep_rate_hz;
    if layout.start_ps + layout.bins as f64 * layout.bin_ps > period_ps + 1e-6 {
        return Err(NlosError::prop(
            PLUGIN,
            "rep_rate_hz",
            "the capture's time window is longer than the laser period",
        ));
    }
    let background = detection::background_per_bin(spad, layout.bin_ps);
    let mut lam = vec![0.0f64; transient.len()];
    pool(None)?.install(|| {
        lam.par_chunks_mut(layout.bins)
            .zip(transient.par_chunks(layout.bins))
            .zip(photons.par_iter())
            .for_each(|((out, h), &k)| {
                let signal: Vec<f64> = h.iter().map(|&v| v as f64 * k).collect();
                kernel.convolve(&signal, out);
                out.iter_mut().for_each(|v| *v += background);
            })
    });
    if lam.iter().any(|v| !v.is_finite()) {
        return Err(NlosError::prop(
            PLUGIN,
            "laser_power_w",
            "the expected counts overflow: lower the power or the exposure",
        ));
    }
    Ok(lam)
}

/// One noisy capture of `scene`'s mono `transient`: detections per bin.
pub fn simulate(scene: &Scene, transient: &[f32], spad: &Spad, seed: u64) -> Result<Vec<u64>> {
    let lam = expected_counts(scene, transient, spad)?;
    let layout = Layout::of(scene, transient.len())?;
    pool(None)?.install(|| detection::detect(&lam, &layout, spad, seed))
}

/// Coates' pile-up correction of `counts` (laid out as `scene`'s transient): the estimated mean
/// detections per bin. Without pile-up the counts are already unbiased and are returned as they are.
pub fn coates(scene: &Scene, counts: &[u64], spad: &Spad) -> Result<Vec<f64>> {
    spad.check()?;
    let layout = Layout::of(scene, counts.len())?;
    if !spad.pile_up {
        return Ok(counts.iter().map(|&c| c as f64).collect());
    }
    detection::coates(counts, &layout, spad)
}
