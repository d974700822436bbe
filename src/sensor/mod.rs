//! Sensors: what measures the scene. Every sensor carries a [`Meter`] (its position, sampler and
//! film); the NLOS `nlos_capture_meter` is read in [`capture_meter`], the line-of-sight pinhole
//! `perspective` camera in [`perspective`].

pub mod capture_meter;
pub mod perspective;

pub use perspective::Camera;

use crate::error::{NlosError, Result};
use crate::film::Film;
use crate::props::{Props, Value};
use glam::Vec3A;

/// What every sensor has: where it sits, how many samples it takes and its film.
#[derive(Clone, Debug)]
pub struct Meter {
    /// Sensor origin s.
    pub origin: Vec3A,
    /// Samples per scan point (the sampler's `sample_count`).
    pub spp: u64,
    /// The sampler's `seed`.
    pub seed: u64,
    /// Film.
    pub film: Film,
    /// A `stratified`, `multijitter`, `orthogonal` or `ldsampler` sampler: samples come from a
    /// scrambled low-discrepancy sequence ([`crate::sampling::Sampler::low_discrepancy`]).
    pub low_discrepancy: bool,
    /// Things accepted but ignored, for the caller to show.
    pub warnings: Vec<String>,
    /// tal's confocal scan (`original_film_width/height` on an `nlos_capture_meter`): the film is
    /// 1×1, its one pixel looks at where the laser is aimed, and the scan grid it belongs to
    /// (for pixel → wall coordinates) is this size.
    pub confocal_grid: Option<(usize, usize)>,
}

impl Meter {
    /// The sampler and film nested in any sensor; the caller reads its other keys and finishes `p`.
    pub fn from_sensor(p: &Props, origin: Vec3A) -> Result<Self> {
        let plugin = p.plugin.as_str();
        let (mut spp, mut seed, mut film) = (4, 0, None);
        let (mut low_discrepancy, mut warnings) = (false, Vec::new());
        for (key, v) in p.objects() {
            match v {
                Value::Object(s) if s.plugin == "independent" => {
                    spp = s.int_in("sample_count", 4, 1, i64::MAX)? as u64;
                    seed = s.int_in("seed", 0, 0, u32::MAX as i64)? as u64;
                    s.finish()?;
                }
                Value::Object(s)
                    if matches!(
                        s.plugin.as_str(),
                        "stratified" | "multijitter" | "orthogonal" | "ldsampler"
                    ) =>
                {
                    let kind = s.plugin.as_str();
                    let n = s.int_in("sample_count", 4, 1, 1 << 40)? as u64;
                    seed = s.int_in("seed", 0, 0, u32::MAX as i64)? as u64;
                    // Mitsuba 3's own rounding of sample_count, so that a file renders as many
                    // samples as there: a square grid (stratified), a near-square one
                    // (multijitter), a prime squared (orthogonal), a power of four (ldsampler).
                    let root = (n as f64).sqrt();
                    spp = match kind {
                        "stratified" => (root.ceil() as u64).pow(2),
                        "multijitter" => {
                            let x = root.floor() as u64;
                            x * n.div_ceil(x)
                        }
                        "orthogonal" => {
                            let is_prime = |p: u64| {
                                (2..)
                                    .take_while(|d| d * d <= p)
                                    .all(|d| !p.is_multiple_of(d))
                            };
                            let p = ((root.ceil() as u64).max(2)..).find(|&p| is_prime(p));
                            p.map_or(n, |p| p * p)
                        }
                        // sample_count ≤ 2^40: the power of four stays below 2^42.
                        _ => {
                            1u64 << (n.max(4).next_power_of_two().trailing_zeros().div_ceil(2) * 2)
                        }
                    };
                    if kind != "ldsampler" && !s.bool("jitter", true)? {
                        warnings.push(format!(
                            "{kind}: jitter=false is ignored; every sampler here is an Owen-scrambled Sobol' sequence"
                        ));
                    }
                    if kind == "orthogonal" {
                        s.int_in("strength", 2, 1, 64)?;
                    }
                    s.finish()?;
                    low_discrepancy = true;
                }
                Value::Object(f) if f.plugin.ends_with("film") => {
                    film = Some(Film::from_props(&f, plugin)?)
                }
                _ => {
                    return Err(NlosError::prop(
                        plugin,
                        &key,
                        "unexpected nested object (a sampler and a film)",
                    ));
                }
            }
        }
        let film = film
            .ok_or_else(|| NlosError::prop(plugin, "film", "missing (a 'transient_hdr_film')"))?;
        Ok(Self {
            origin,
            spp,
            seed,
            low_discrepancy,
            film,
            warnings,
            confocal_grid: None,
        })
    }
}
