//! Integrator settings: the parameter tables of `transient_nlos_path(_rs)` ([`nlos`]) and
//! `transient_path` ([`path`]), read from a [`Props`] and validated. Plain data: the tracers in
//! `integrator/` read them, the scene stores them.

pub mod nlos;
pub mod path;

pub use nlos::{CaptureType, Hgrs, HgrsEstimator, NlosSettings};
pub use path::PathSettings;

use crate::error::{NlosError, Result};
use crate::film::TemporalKernel;
use crate::props::Props;

/// `max_depth`: −1 is unbounded (`u32::MAX`).
fn max_depth(p: &Props) -> Result<u32> {
    Ok(p.optional_count("max_depth", 6, 0)?.unwrap_or(u32::MAX))
}

/// `rr_depth`: the loop depth from which Russian roulette applies; positive.
fn rr_depth(p: &Props) -> Result<u32> {
    match p.int("rr_depth", 5)? {
        v if v > 0 && v < u32::MAX as i64 => Ok(v as u32),
        v => Err(NlosError::prop(
            &p.plugin,
            "rr_depth",
            format!("must be > 0, got {v}"),
        )),
    }
}

/// mitransient's `temporal_filter` / `gaussian_stddev`, which it accepts and ignores: here `'gaussian'`
/// is the Gaussian temporal kernel with σ = `gaussian_stddev` bins.
fn temporal_filter(p: &Props, default_stddev: f64) -> Result<Option<TemporalKernel>> {
    let plugin = p.plugin.as_str();
    let stddev = p.float("gaussian_stddev", default_stddev)?;
    match p.string("temporal_filter", "")?.as_str() {
        "" | "box" => Ok(None),
        "gaussian" => TemporalKernel::from_params(plugin, None, Some(stddev), None)
            .map(Some)
            .map_err(|_| NlosError::prop(plugin, "gaussian_stddev", "must be positive")),
        other => Err(NlosError::prop(
            plugin,
            "temporal_filter",
            format!("must be 'box' or 'gaussian', got '{other}'"),
        )),
    }
}

/// Keys mitransient's base classes accept and that change nothing here.
fn accept_inert(p: &Props) -> Result<()> {
    p.bool("hide_emitters", false)?;
    p.int("block_size", 0)?;
    p.int("samples_per_pass", -1)?;
    Ok(())
}
