//! The parameters of `transient_path` (line of sight): Mitsuba's `path` with a time dimension.

use super::{accept_inert, max_depth, rr_depth, temporal_filter};
use crate::error::Result;
use crate::film::TemporalKernel;
use crate::props::Props;

/// The parameters of `transient_path`.
#[derive(Clone, Debug)]
pub struct PathSettings {
    /// Longest path in segments (Mitsuba's meaning: 1 = directly visible lights); `u32::MAX` for -1.
    pub max_depth: u32,
    /// Depth from which Russian roulette applies.
    pub rr_depth: u32,
    /// Measure time from the first surface the camera sees instead of from the pinhole.
    pub camera_unwarp: bool,
    /// Start the optical path at the camera's near-clip plane, as mitransient does (Mitsuba moves a
    /// camera ray's origin there), instead of at the pinhole.
    pub opl_from_near_clip: bool,
    /// Drop light seen directly by the camera.
    pub discard_direct_light: bool,
    /// `temporal_filter='gaussian'` with `gaussian_stddev` (bins).
    pub temporal_kernel: Option<TemporalKernel>,
}

impl PathSettings {
    /// Read the integrator's properties; unknown ones are rejected.
    pub fn from_props(p: &Props) -> Result<Self> {
        let s = Self {
            max_depth: max_depth(p)?,
            rr_depth: rr_depth(p)?,
            camera_unwarp: p.bool("camera_unwarp", false)?,
            opl_from_near_clip: p.bool("opl_from_near_clip", false)?,
            discard_direct_light: p.bool("discard_direct_light", false)?,
            temporal_kernel: temporal_filter(p, 2.0)?,
        };
        // Without an environment light these change nothing.
        accept_inert(p)?;
        p.finish()?;
        Ok(s)
    }
}
