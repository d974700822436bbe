//! Mitsuba's `blendbsdf` (a linear mix of two BSDFs, f = (1 − w) f₀ + w f₁) and `mask` (a BSDF
//! covering a fraction `opacity` of the surface; the rest lets light straight through, a Dirac
//! delta). Sampling picks a component with its weight; a smooth sample's weight is the mixture's
//! f·cos over the mixture's pdf.
//!
//! | plugin | key | type | default |
//! |---|---|---|---|
//! | `blendbsdf` | `weight` | float in [0, 1] | 0.5 |
//! | `blendbsdf` | (nested) | two BSDFs | — |
//! | `mask` | `opacity` | float in [0, 1] | 0.5 |
//! | `mask` | (nested) | one BSDF | — |

use super::{Bsdf, BsdfSample};
use crate::error::{NlosError, Result};
use crate::math::Spectrum;
use crate::props::{Colour, Props, Value};
use crate::sampling::Sampler;
use glam::Vec3A;

/// (1 − `weight`)·`first` + `weight`·`second`; `second` = `None` is the pass-through of a mask.
#[derive(Clone, Debug)]
pub struct Blend<S> {
    /// Probability (and weight) of the second component.
    pub weight: f32,
    /// The first component (a mask's pass-through when `None`).
    pub first: Option<Box<Bsdf<S>>>,
    /// The second component.
    pub second: Box<Bsdf<S>>,
}

fn nested(p: &Props) -> Result<Vec<Bsdf<Colour>>> {
    p.objects()
        .into_iter()
        .map(|(key, v)| match v {
            Value::Object(b) => Bsdf::from_props(&b),
            _ => Err(NlosError::prop(
                &p.plugin,
                &key,
                "a reference is not supported here: nest the BSDF",
            )),
        })
        .collect()
}

fn unit(p: &Props, key: &str) -> Result<f32> {
    let v = p.float(key, 0.5)?;
    if !(0.0..=1.0).contains(&v) {
        return Err(NlosError::prop(&p.plugin, key, "must be in [0, 1]"));
    }
    Ok(v as f32)
}

impl Blend<Colour> {
    /// Read a `blendbsdf` (two nested BSDFs) or a `mask` (one).
    pub fn from_props(p: &Props) -> Result<Self> {
        let (key, count) = if p.plugin == "mask" {
            ("opacity", 1)
        } else {
            ("weight", 2)
        };
        let weight = unit(p, key)?;
        let mut inner = nested(p)?;
        p.finish()?;
        if inner.len() != count {
            return Err(NlosError::prop(
                &p.plugin,
                "bsdf",
                format!("needs {count} nested BSDF(s), got {}", inner.len()),
            ));
        }
        let second = Box::new(inner.pop().unwrap_or(Bsdf::DEFAULT));
        Ok(Self {
            weight,
            first: inner.pop().map(Box::new),
            second,
        })
    }
}

impl Blend<Spectrum> {
    fn parts(&self) -> [(f32, Option<&Bsdf<Spectrum>>); 2] {
        [
            (1.0 - self.weight, self.first.as_deref()),
            (self.weight, Some(&*self.second)),
        ]
    }

    /// The mixture's f·cos (the pass-through has none).
    #[inline]
    pub fn eval(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> Option<Spectrum> {
        let mut sum: Option<Spectrum> = None;
        for (w, b) in self.parts() {
            if let Some(f) = b.and_then(|b| b.eval(ns, wi, wo)) {
                sum = Some(sum.unwrap_or(Spectrum::ZERO) + f * w);
            }
        }
        sum
    }

    /// The mixture's pdf of smooth directions.
    #[inline]
    pub fn pdf(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> f32 {
        self.parts()
            .iter()
            .map(|(w, b)| b.map_or(0.0, |b| w * b.pdf(ns, wi, wo)))
            .sum()
    }

    /// [`Blend::eval`] and [`Blend::pdf`] at once (each component's at once), with their bits.
    #[inline]
    pub fn eval_pdf(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> (Option<Spectrum>, f32) {
        let (mut sum, mut pdf): (Option<Spectrum>, f32) = (None, 0.0);
        for (w, b) in self.parts() {
            let Some(b) = b else {
                continue;
            };
            let (f, p) = b.eval_pdf(ns, wi, wo);
            if let Some(f) = f {
                sum = Some(sum.unwrap_or(Spectrum::ZERO) + f * w);
            }
            pdf += w * p;
        }
        (sum, pdf)
    }

    /// Pick a component with its weight and sample it.
    #[inline]
    pub fn sample(&self, ns: Vec3A, wi: Vec3A, rng: &mut Sampler) -> Option<BsdfSample> {
        let (w, b) = if rng.next_1d() < self.weight {
            (self.weight, Some(&*self.second))
        } else {
            (1.0 - self.weight, self.first.as_deref())
        };
        let Some(b) = b else {
            // A mask's pass-through: the light goes straight on.
            return Some(BsdfSample {
                wo: -wi,
                weight: Spectrum::ONE,
                pdf: w,
                delta: true,
                eta: 1.0,
            });
        };
        let s = b.sample(ns, wi, rng)?;
        if s.delta {
            return Some(BsdfSample {
                pdf: w * s.pdf,
                ..s
            });
        }
        let (value, pdf) = self.eval_pdf(ns, wi, s.wo);
        let value = value?;
        (pdf > 0.0).then(|| BsdfSample {
            weight: value / pdf,
            pdf,
            ..s
        })
    }

    /// Whether every component is a delta.
    pub fn is_delta(&self) -> bool {
        self.parts()
            .iter()
            .all(|(w, b)| *w == 0.0 || b.is_none_or(|b| b.is_delta()))
    }

    /// Whether some component scatters light arriving from behind the surface.
    pub fn scatters_behind(&self) -> bool {
        self.parts()
            .iter()
            .any(|(w, b)| *w > 0.0 && b.is_some_and(|b| b.scatters_behind()))
    }

    /// Whether some component is a delta.
    pub fn has_delta(&self) -> bool {
        self.parts()
            .iter()
            .any(|(w, b)| *w > 0.0 && b.is_none_or(|b| b.has_delta()))
    }
}
