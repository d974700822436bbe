//! Mitsuba's `dielectric`: a smooth interface between two indices of refraction (glass, water).
//! Reflection or refraction is chosen with the Fresnel probability, so either has weight 1 (times
//! the optional factors); a refracted radiance is scaled by (η_t/η_i)⁻² for the change of solid
//! angle. Both are Dirac deltas. Inside the medium light is slower: the path's optical length
//! grows by η per unit distance (the tracer tracks η from [`BsdfSample::eta`]).
//!
//! | key | type | default |
//! |---|---|---|
//! | `int_ior`, `ext_ior` | float or a name (`bk7`, `water`, `air`, …, see `bsdf/ior.rs`) | `bk7`, `air` |
//! | `specular_reflectance`, `specular_transmittance` | float, rgb or spectrum | 1 |

use super::{BsdfSample, fresnel, ior};
use crate::error::Result;
use crate::math::Spectrum;
use crate::props::{Colour, Props};
use crate::sampling::Sampler;
use glam::Vec3A;

/// A smooth dielectric interface.
#[derive(Clone, Debug)]
pub struct Dielectric<S> {
    /// Relative index of refraction, inside / outside.
    pub eta: f32,
    /// Factor on reflection.
    pub specular_reflectance: S,
    /// Factor on transmission.
    pub specular_transmittance: S,
}

impl Dielectric<Colour> {
    /// Read a `dielectric` (or a `thindielectric`, which has the same parameters).
    pub fn from_props(p: &Props) -> Result<Self> {
        let eta = ior::read_ior(p, "int_ior", "bk7")? / ior::read_ior(p, "ext_ior", "air")?;
        let specular_reflectance = p.colour("specular_reflectance", Colour::Uniform(1.0))?;
        let specular_transmittance = p.colour("specular_transmittance", Colour::Uniform(1.0))?;
        p.finish()?;
        Ok(Self {
            eta,
            specular_reflectance,
            specular_transmittance,
        })
    }
}

impl Dielectric<Colour> {
    /// Resolved for a mono or rgb render.
    pub fn resolve(&self, mono: bool) -> Dielectric<Spectrum> {
        Dielectric {
            eta: self.eta,
            specular_reflectance: self.specular_reflectance.spectrum(mono),
            specular_transmittance: self.specular_transmittance.spectrum(mono),
        }
    }
}

impl Dielectric<Spectrum> {
    /// Reflect or refract with the Fresnel probabilities.
    #[inline]
    pub fn sample(&self, ns: Vec3A, wi: Vec3A, rng: &mut Sampler) -> Option<BsdfSample> {
        let cos_i = ns.dot(wi);
        let (r, cos_t, eta_it, eta_ti) = fresnel::dielectric(cos_i, self.eta);
        Some(if rng.next_1d() <= r {
            BsdfSample::mirror(ns, wi, cos_i, self.specular_reflectance, r)
        } else {
            BsdfSample {
                wo: -eta_ti * (wi - cos_i * ns) + cos_t * ns,
                weight: self.specular_transmittance * (eta_ti * eta_ti),
                pdf: 1.0 - r,
                delta: true,
                eta: eta_it,
            }
        })
    }
}
