//! `transient_hdr_film`: the sensor grid and the optical-path-length (OPL) time axis
//! (mitransient-model §1, §3.8). How a contribution is spread over the time bins — the box of
//! mitransient or a temporal kernel density estimate — is in [`temporal_kernel`]; the
//! frequency-domain `phasor_hdr_film` in [`phasor`]; a kernel width chosen per scan point in
//! [`auto_width`]; the memory a render's film is summed in, [`memory`].

pub mod auto_width;
pub mod memory;
pub mod phasor;
pub mod temporal_kernel;

pub use phasor::Phasor;
pub use temporal_kernel::{GAUSSIAN_CUTOFF_SIGMAS, Splatter, TemporalKernel};

use crate::error::{NlosError, Result};
use crate::props::{Props, Value};

/// A `transient_hdr_film`: the grid of an `nlos_capture_meter` or a perspective camera, and the time axis.
#[derive(Clone, Debug)]
pub struct Film {
    /// Scan grid width W (relay-wall points along the wall's local x).
    pub width: usize,
    /// Scan grid height H.
    pub height: usize,
    /// Number of time bins T.
    pub temporal_bins: usize,
    /// Bin width Δ in OPL (scene units, normally metres).
    pub bin_width_opl: f64,
    /// OPL of the start of bin 0.
    pub start_opl: f64,
    /// Laser grid (LW, LH) when the film stores an exhaustive scan.
    pub laser_scan: Option<(usize, usize)>,
    /// Temporal density estimation kernel (`kernel_sigma` / `kernel_bandwidth`).
    pub kernel: TemporalKernel,
    /// A `phasor_hdr_film`: the frequencies it stores instead of time bins.
    pub phasor: Option<Phasor>,
}

impl Film {
    /// Read a `transient_hdr_film` or a `phasor_hdr_film`; `sensor` names the sensor it is in.
    pub fn from_props(p: &Props, sensor: &str) -> Result<Self> {
        let phasor = match p.plugin.as_str() {
            "transient_hdr_film" => false,
            "phasor_hdr_film" => true,
            other => {
                return Err(NlosError::prop(
                    sensor,
                    "film",
                    format!("must be a 'transient_hdr_film' or 'phasor_hdr_film', got '{other}'"),
                ));
            }
        };
        let width = p.int_in("width", 768, 1, 1 << 16)? as usize;
        let height = p.int_in("height", 576, 1, 1 << 16)? as usize;
        let default_bins = if phasor { 4096 } else { 2048 };
        let temporal_bins = p.int_in("temporal_bins", default_bins, 1, 1 << 24)? as usize;
        let bin_width_opl = p.float("bin_width_opl", 0.003)?;
        if !(bin_width_opl > 0.0) {
            return Err(NlosError::prop(
                &p.plugin,
                "bin_width_opl",
                "must be positive",
            ));
        }
        let start_opl = p.float("start_opl", 0.0)?;
        let exhaustive = p.bool("exhaustive_scan", false)?;
        let lw = p.int_in("laser_scan_width", 0, 0, 1 << 12)? as usize;
        let lh = p.int_in("laser_scan_height", 0, 0, 1 << 12)? as usize;
        let opt = |key: &str| -> Result<Option<f64>> {
            Ok(if p.has(key) {
                Some(p.float(key, 0.0)?)
            } else {
                None
            })
        };
        let name = if p.has("kernel") {
            Some(p.string("kernel", "")?)
        } else {
            None
        };
        let kernel = TemporalKernel::from_params(
            &p.plugin,
            name.as_deref(),
            opt("kernel_sigma")?,
            opt("kernel_bandwidth")?,
        )?;
        let phasor = if phasor {
            Some(Phasor::from_props(p, temporal_bins, bin_width_opl)?)
        } else {
            None
        };
        let laser_scan = if exhaustive {
            if lw == 0 || lh == 0 {
                return Err(NlosError::prop(
                    &p.plugin,
                    "laser_scan_width",
                    "exhaustive_scan needs laser_scan_width and laser_scan_height > 0",
                ));
            }
            Some((lw, lh))
        } else {
            None
        };
        // The spatial reconstruction filter: only `box` is meaningful for a scan grid
        // (mitransient raises at render time for any other; we raise at load time).
        let mut has_rfilter = false;
        for (key, v) in p.objects() {
            match v {
                Value::Object(f) if f.plugin == "box" => {
                    f.finish()?;
                    has_rfilter = true;
                }
                Value::Object(f)
                    if matches!(
                        f.plugin.as_str(),
                        "gaussian" | "tent" | "lanczos" | "mitchell" | "catmullrom"
                    ) =>
                {
                    return Err(NlosError::prop(
                        &p.plugin,
                        &key,
                        format!(
                            "rfilter '{}' is not supported: use {{'type': 'box'}}",
                            f.plugin
                        ),
                    ));
                }
                _ => {
                    return Err(NlosError::prop(
                        &p.plugin,
                        &key,
                        "unexpected nested object (only an rfilter of type 'box')",
                    ));
                }
            }
        }
        if !has_rfilter {
            return Err(NlosError::prop(
                &p.plugin,
                "rfilter",
                "missing: Mitsuba's default is a gaussian, which transient films do not support; add {'type': 'box'}",
            ));
        }
        p.finish()?;
        Ok(Self {
            width,
            height,
            temporal_bins,
            bin_width_opl,
            start_opl,
            laser_scan,
            kernel,
            phasor,
        })
    }

    /// The temporal kernel must not be wider than the time window (a wider one spreads every
    /// contribution over nothing but its tails) nor make a weight table beyond a few MiB.
    pub fn check_kernel(&self) -> Result<()> {
        let max = (4.0 * self.temporal_bins as f64).min(4096.0);
        if self.kernel.radius() > max {
            return Err(NlosError::prop(
                "transient_hdr_film",
                "kernel_sigma",
                format!(
                    "the temporal kernel reaches {} bins from its centre; at most {max} (4 × temporal_bins, ≤ 4096)",
                    self.kernel.radius()
                ),
            ));
        }
        Ok(())
    }

    /// Number of laser slots per pixel (1 unless exhaustive).
    pub fn laser_slots(&self) -> usize {
        self.laser_scan.map_or(1, |(w, h)| w * h)
    }

    /// Values per pixel and laser slot for `channels` channels: T bins × channels, or, for a
    /// phasor film, frequencies × [re, im].
    pub fn slot_len(&self, channels: usize) -> usize {
        match &self.phasor {
            Some(ph) => ph.frequencies.len() * 2,
            None => self.temporal_bins * channels,
        }
    }

    /// The splatter of this film's bins and kernel, for one render.
    pub fn splatter(&self) -> Splatter {
        Splatter::new(self)
    }
}
