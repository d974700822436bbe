//! Mitsuba's `conductor`: a perfectly smooth metal (a mirror with Fresnel reflectance). Its
//! reflection is a Dirac delta: no connection can evaluate it, so laser sampling, hidden-geometry
//! sampling and next-event estimation skip such vertices and the path continues by sampling.
//!
//! | key | type | default |
//! |---|---|---|
//! | `material` | string: a named metal (`Au`, `Cu`, `Al`, …, see `bsdf/ior.rs`) or `none` (η = 0, k = 1: a perfect mirror) | `none` |
//! | `eta`, `k` | float or rgb: the complex index of refraction (instead of `material`) | 0, 1 |
//! | `specular_reflectance` | float, rgb or spectrum: a factor on the reflectance | 1 |

use super::{BsdfSample, fresnel, ior};
use crate::error::{NlosError, Result};
use crate::math::Spectrum;
use crate::props::{Colour, Props};
use glam::Vec3A;

/// A smooth conductor.
#[derive(Clone, Debug)]
pub struct Conductor<S> {
    /// Real part of the index of refraction.
    pub eta: S,
    /// Imaginary part (absorption).
    pub k: S,
    /// Factor on the reflectance.
    pub specular_reflectance: S,
}

/// `material` or `eta` + `k`, as Mitsuba reads them for both conductors.
pub(super) fn complex_ior(p: &Props) -> Result<(Colour, Colour)> {
    let material = p.string("material", "none")?;
    let explicit = p.has("eta") || p.has("k");
    if explicit && material != "none" {
        return Err(NlosError::prop(
            &p.plugin,
            "material",
            "give either eta and k or material, not both",
        ));
    }
    if material == "none" {
        return Ok((
            p.unbounded("eta", Colour::Uniform(0.0))?,
            p.unbounded("k", Colour::Uniform(1.0))?,
        ));
    }
    let (eta, k) = ior::conductor(&material).ok_or_else(|| {
        NlosError::prop(
            &p.plugin,
            "material",
            format!("unknown material '{material}' (see Mitsuba's conductor IOR list)"),
        )
    })?;
    Ok((Colour::Rgb(eta), Colour::Rgb(k)))
}

impl Conductor<Colour> {
    /// Read a `conductor`.
    pub fn from_props(p: &Props) -> Result<Self> {
        let (eta, k) = complex_ior(p)?;
        let specular_reflectance = p.colour("specular_reflectance", Colour::Uniform(1.0))?;
        p.finish()?;
        Ok(Self {
            eta,
            k,
            specular_reflectance,
        })
    }
}

impl Conductor<Spectrum> {
    /// Mirror reflection about `ns`, weighted by the Fresnel reflectance.
    #[inline]
    pub fn sample(&self, ns: Vec3A, wi: Vec3A) -> Option<BsdfSample> {
        let cos_i = ns.dot(wi);
        if cos_i <= 0.0 {
            return None;
        }
        let weight = fresnel::conductor(cos_i, self.eta, self.k) * self.specular_reflectance;
        Some(BsdfSample::mirror(ns, wi, cos_i, weight, 1.0))
    }
}
