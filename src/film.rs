//! `transient_hdr_film`: the scan grid size and the optical-path-length (OPL) binning of each
//! contribution (mitransient-nlos-spec §1.2, §3.8).

use crate::error::{NlosError, Result};
use crate::props::{Props, Value};

/// The film of an `nlos_capture_meter`.
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
}

impl Film {
    /// Read a `transient_hdr_film`.
    pub fn from_props(p: &Props) -> Result<Self> {
        if p.plugin != "transient_hdr_film" {
            return Err(NlosError::prop(
                "nlos_capture_meter",
                "film",
                format!("must be a 'transient_hdr_film', got '{}'", p.plugin),
            ));
        }
        let width = p.int_in("width", 768, 1, 1 << 16)? as usize;
        let height = p.int_in("height", 576, 1, 1 << 16)? as usize;
        let temporal_bins = p.int_in("temporal_bins", 2048, 1, 1 << 24)? as usize;
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
        })
    }

    /// Number of laser slots per pixel (1 unless exhaustive).
    pub fn laser_slots(&self) -> usize {
        self.laser_scan.map_or(1, |(w, h)| w * h)
    }

    /// The bin of a contribution with optical path length `opl`, if inside the time window.
    #[inline]
    pub fn bin(&self, opl: f64) -> Option<usize> {
        let x = (opl - self.start_opl) / self.bin_width_opl;
        (x >= 0.0 && x < self.temporal_bins as f64).then_some(x as usize)
    }
}
