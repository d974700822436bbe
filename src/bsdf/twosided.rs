//! Mitsuba's `twosided`: makes a BSDF reflect on both sides of a surface. Light arriving from
//! below the shading normal sees the (back) BSDF with the normal flipped; a path never crosses the
//! surface. Hidden-geometry sampling accepts both sides of a two-sided surface
//! (`Bsdf::scatters_behind`); the laser spot's cosine test stays one-sided, as in mitransient.
//!
//! | key | type | default |
//! |---|---|---|
//! | (nested) | one BSDF for both sides, or two: front then back | — |

use super::{Bsdf, BsdfSample};
use crate::error::{NlosError, Result};
use crate::math::Spectrum;
use crate::props::{Colour, Props, Value};
use crate::sampling::Sampler;
use glam::Vec3A;

/// A two-sided BSDF: `front` above the shading normal, `back` below it.
#[derive(Clone, Debug)]
pub struct TwoSided<S> {
    /// BSDF of the side the shading normal points to.
    pub front: Box<Bsdf<S>>,
    /// BSDF of the other side (the same as `front` when one is given).
    pub back: Box<Bsdf<S>>,
}

impl TwoSided<Colour> {
    /// Read a `twosided` plugin: one or two nested BSDFs.
    pub fn from_props(p: &Props) -> Result<Self> {
        let mut inner = Vec::new();
        for (key, v) in p.objects() {
            match v {
                Value::Object(b) if b.plugin == "twosided" => {
                    return Err(NlosError::prop(
                        &p.plugin,
                        &key,
                        "cannot nest a twosided BSDF",
                    ));
                }
                Value::Object(b) => inner.push(Bsdf::from_props(&b)?),
                _ => {
                    return Err(NlosError::prop(
                        &p.plugin,
                        &key,
                        "a reference is not supported here: nest the BSDF",
                    ));
                }
            }
        }
        p.finish()?;
        let mut inner = inner.into_iter();
        match (inner.next(), inner.next(), inner.next()) {
            (Some(front), None, None) => Ok(Self {
                back: Box::new(front.clone()),
                front: Box::new(front),
            }),
            (Some(front), Some(back), None) => Ok(Self {
                front: Box::new(front),
                back: Box::new(back),
            }),
            _ => Err(NlosError::prop(
                &p.plugin,
                "bsdf",
                "needs one nested BSDF (both sides) or two (front, back)",
            )),
        }
    }
}

impl TwoSided<Spectrum> {
    /// The side's BSDF and the normal it sees, chosen by the side `wi` is on.
    #[inline]
    pub(super) fn side(&self, ns: Vec3A, wi: Vec3A) -> (&Bsdf<Spectrum>, Vec3A) {
        if ns.dot(wi) > 0.0 {
            (&self.front, ns)
        } else {
            (&self.back, -ns)
        }
    }

    /// f·cos on the side of `wi`.
    #[inline]
    pub fn eval(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> Option<Spectrum> {
        let (b, n) = self.side(ns, wi);
        b.eval(n, wi, wo)
    }

    /// Sample on the side of `wi`.
    #[inline]
    pub fn sample(&self, ns: Vec3A, wi: Vec3A, rng: &mut Sampler) -> Option<BsdfSample> {
        let (b, n) = self.side(ns, wi);
        b.sample(n, wi, rng)
    }

    /// Density of [`TwoSided::sample`].
    #[inline]
    pub fn pdf(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> f32 {
        let (b, n) = self.side(ns, wi);
        b.pdf(n, wi, wo)
    }

    /// [`TwoSided::eval`] and [`TwoSided::pdf`] at once.
    #[inline]
    pub fn eval_pdf(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> (Option<Spectrum>, f32) {
        let (b, n) = self.side(ns, wi);
        b.eval_pdf(n, wi, wo)
    }
}
