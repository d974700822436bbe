//! BSDFs, one file per Mitsuba plugin. A BSDF is read from the scene with its spectral parameters
//! as given ([`Bsdf<Colour>`]) and resolved for a render's variant, mono or rgb
//! ([`Bsdf<Spectrum>`], via [`Bsdf::resolve`]); the tracers evaluate and sample the resolved form.
//!
//! Conventions (Mitsuba's): `wi` points towards where light goes (the previous vertex), `wo` towards
//! where it comes from; `eval` includes the cosine at `wo`; directions and the shading normal `ns`
//! are in world space.

pub mod blendbsdf;
pub mod conductor;
pub mod dielectric;
pub mod diffuse;
pub mod fresnel;
pub mod ior;
pub mod microfacet;
pub mod plastic;
pub mod rough_lanes;
pub mod roughconductor;
pub mod roughplastic;
pub mod thindielectric;
pub mod twosided;

pub use blendbsdf::Blend;
pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use diffuse::Diffuse;
pub use plastic::Plastic;
pub use rough_lanes::{Rough, RoughLanes};
pub use roughconductor::RoughConductor;
pub use roughplastic::RoughPlastic;
pub use thindielectric::ThinDielectric;
pub use twosided::TwoSided;

use crate::error::{NlosError, Result};
use crate::math::{Frame, Spectrum};
use crate::props::{Colour, Props};
use crate::sampling::Sampler;
use glam::{Vec2, Vec3A};
use microfacet::Microfacet;

/// A BSDF, with spectral parameters of type `S` ([`Colour`] as read, [`Spectrum`] to render).
#[derive(Clone, Debug)]
pub enum Bsdf<S> {
    /// `diffuse`: Lambertian.
    Diffuse(Diffuse<S>),
    /// `twosided`: a BSDF on both sides of the surface.
    TwoSided(TwoSided<S>),
    /// `conductor`: a smooth metal (delta reflection).
    Conductor(Conductor<S>),
    /// `roughconductor`: a microfacet metal.
    RoughConductor(RoughConductor<S>),
    /// `dielectric`: smooth glass (delta reflection and refraction).
    Dielectric(Dielectric<S>),
    /// `thindielectric`: a thin sheet (delta reflection and straight transmission).
    ThinDielectric(ThinDielectric<S>),
    /// `plastic`: a diffuse base under a smooth coating.
    Plastic(Plastic<S>),
    /// `roughplastic`: a diffuse base under a rough coating.
    RoughPlastic(RoughPlastic<S>),
    /// `blendbsdf` and `mask`: a mixture of two BSDFs (or of one and a pass-through).
    Blend(Blend<S>),
}

/// The plugin names [`Bsdf::from_props`] reads.
pub const PLUGINS: [&str; 10] = [
    "blendbsdf",
    "mask",
    "roughplastic",
    "diffuse",
    "twosided",
    "conductor",
    "roughconductor",
    "dielectric",
    "thindielectric",
    "plastic",
];

/// A sampled direction and its weight.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// The sampled direction (world space).
    pub wo: Vec3A,
    /// f·cos / pdf.
    pub weight: Spectrum,
    /// Solid-angle density of `wo` (1 for a delta component).
    pub pdf: f32,
    /// Whether `wo` came from a Dirac delta component (a mirror): no connection can find it.
    pub delta: bool,
    /// Relative index of refraction in the direction of travel (1 unless refracted): light is
    /// that much slower beyond the surface.
    pub eta: f32,
}

impl BsdfSample {
    /// Mirror reflection of `wi` about `ns` (`cos_i = ns·wi`), chosen with probability `pdf`.
    #[inline]
    pub fn mirror(ns: Vec3A, wi: Vec3A, cos_i: f32, weight: Spectrum, pdf: f32) -> Self {
        Self {
            wo: 2.0 * cos_i * ns - wi,
            weight,
            pdf,
            delta: true,
            eta: 1.0,
        }
    }
}

/// A microfacet BSDF (a rough conductor, a rough coating over a base) defined in its local
/// shading frame (z = shading normal, one-sided) through the half vector h of the two directions
/// and the density D(h) of its normals, with a proposal of outgoing directions; the local and
/// world-space evaluation, density and sampling follow, h and D(h) found once for both.
pub(crate) trait LocalBsdf {
    /// The distribution of microfacet normals.
    fn microfacet(&self) -> &Microfacet;
    /// f·cos θ_o for local directions above the surface, of half vector `h` and D(h) = `d`.
    fn eval_half(&self, wi: Vec3A, wo: Vec3A, h: Vec3A, d: f32) -> Option<Spectrum>;
    /// Density of the directions [`LocalBsdf::propose`] gives, likewise.
    fn pdf_half(&self, wi: Vec3A, wo: Vec3A, h: Vec3A, d: f32) -> f32;
    /// A local outgoing direction for local `wi` (above the surface).
    fn propose(&self, wi: Vec3A, rng: &mut Sampler) -> Vec3A;

    /// The half vector of local `wi` and `wo` and D there, if both lie above the surface.
    #[inline]
    fn half(&self, wi: Vec3A, wo: Vec3A) -> Option<(Vec3A, f32)> {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return None;
        }
        let h = (wi + wo).normalize();
        Some((h, self.microfacet().d(h)))
    }

    /// f·cos θ_o and the density of `wo`, for local directions.
    fn eval_pdf_local(&self, wi: Vec3A, wo: Vec3A) -> (Option<Spectrum>, f32) {
        match self.half(wi, wo) {
            Some((h, d)) => (self.eval_half(wi, wo, h, d), self.pdf_half(wi, wo, h, d)),
            None => (None, 0.0),
        }
    }

    fn eval_world(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> Option<Spectrum> {
        let f = Frame::new(ns);
        let (wi, wo) = (f.to_local(wi), f.to_local(wo));
        let (h, d) = self.half(wi, wo)?;
        self.eval_half(wi, wo, h, d)
    }

    fn pdf_world(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> f32 {
        let f = Frame::new(ns);
        let (wi, wo) = (f.to_local(wi), f.to_local(wo));
        self.half(wi, wo)
            .map_or(0.0, |(h, d)| self.pdf_half(wi, wo, h, d))
    }

    fn eval_pdf_world(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> (Option<Spectrum>, f32) {
        let f = Frame::new(ns);
        self.eval_pdf_local(f.to_local(wi), f.to_local(wo))
    }

    fn sample_world(&self, ns: Vec3A, wi: Vec3A, rng: &mut Sampler) -> Option<BsdfSample> {
        let f = Frame::new(ns);
        let wi_l = f.to_local(wi);
        if wi_l.z <= 0.0 {
            return None;
        }
        let wo_l = self.propose(wi_l, rng);
        let (value, pdf) = self.eval_pdf_local(wi_l, wo_l);
        let value = value?;
        (pdf > 0.0).then(|| BsdfSample {
            wo: f.to_world(wo_l),
            weight: value / pdf,
            pdf,
            delta: false,
            eta: 1.0,
        })
    }
}

impl Bsdf<Colour> {
    /// Mitsuba's default BSDF: diffuse with reflectance 0.5.
    pub const DEFAULT: Self = Bsdf::Diffuse(Diffuse {
        reflectance: Colour::Uniform(0.5),
    });

    /// Read a BSDF plugin (one of [`PLUGINS`]).
    pub fn from_props(p: &Props) -> Result<Self> {
        match p.plugin.as_str() {
            "diffuse" => Ok(Bsdf::Diffuse(Diffuse::from_props(p)?)),
            "twosided" => Ok(Bsdf::TwoSided(TwoSided::from_props(p)?)),
            "conductor" => Ok(Bsdf::Conductor(Conductor::from_props(p)?)),
            "roughconductor" => Ok(Bsdf::RoughConductor(RoughConductor::from_props(p)?)),
            "dielectric" => Ok(Bsdf::Dielectric(Dielectric::from_props(p)?)),
            "thindielectric" => Ok(Bsdf::ThinDielectric(ThinDielectric(
                Dielectric::from_props(p)?,
            ))),
            "plastic" => Ok(Bsdf::Plastic(Plastic::from_props(p)?)),
            "roughplastic" => Ok(Bsdf::RoughPlastic(RoughPlastic::from_props(p)?)),
            "blendbsdf" | "mask" => Ok(Bsdf::Blend(Blend::from_props(p)?)),
            other => Err(NlosError::prop(
                other,
                "type",
                format!("bsdf '{other}' is not supported (supported: {PLUGINS:?})"),
            )),
        }
    }

    /// The BSDF with its parameters resolved for a mono or rgb render.
    pub fn resolve(&self, mono: bool) -> Bsdf<Spectrum> {
        match self {
            Bsdf::Diffuse(d) => Bsdf::Diffuse(Diffuse {
                reflectance: d.reflectance.spectrum(mono),
            }),
            Bsdf::TwoSided(t) => Bsdf::TwoSided(TwoSided {
                front: Box::new(t.front.resolve(mono)),
                back: Box::new(t.back.resolve(mono)),
            }),
            Bsdf::Conductor(c) => Bsdf::Conductor(Conductor {
                eta: c.eta.spectrum(mono),
                k: c.k.spectrum(mono),
                specular_reflectance: c.specular_reflectance.spectrum(mono),
            }),
            Bsdf::RoughConductor(c) => Bsdf::RoughConductor(RoughConductor {
                eta: c.eta.spectrum(mono),
                k: c.k.spectrum(mono),
                specular_reflectance: c.specular_reflectance.spectrum(mono),
                microfacet: c.microfacet,
            }),
            Bsdf::Dielectric(d) => Bsdf::Dielectric(d.resolve(mono)),
            Bsdf::ThinDielectric(d) => Bsdf::ThinDielectric(ThinDielectric(d.0.resolve(mono))),
            Bsdf::Plastic(p) => Bsdf::Plastic(Plastic {
                diffuse_reflectance: p.diffuse_reflectance.spectrum(mono),
                specular_reflectance: p.specular_reflectance.spectrum(mono),
                eta: p.eta,
                nonlinear: p.nonlinear,
            }),
            Bsdf::RoughPlastic(p) => Bsdf::RoughPlastic(RoughPlastic {
                diffuse_reflectance: p.diffuse_reflectance.spectrum(mono),
                specular_reflectance: p.specular_reflectance.spectrum(mono),
                eta: p.eta,
                nonlinear: p.nonlinear,
                microfacet: p.microfacet,
                transmittance: p.transmittance.clone(),
                internal_reflectance: p.internal_reflectance,
            }),
            Bsdf::Blend(b) => Bsdf::Blend(Blend {
                weight: b.weight,
                first: b.first.as_ref().map(|f| Box::new(f.resolve(mono))),
                second: Box::new(b.second.resolve(mono)),
            }),
        }
    }
}

impl Bsdf<Spectrum> {
    // A diffuse surface, one- or two-sided (by far the most common), is evaluated and sampled
    // inline at every call site; the other BSDFs go through one out-of-line function each.
    // Inlining the whole match everywhere would bloat the hot loops; calling it out of line for
    // every surface was measurably slower (docs/architecture.md, "The BVH", the last paragraph).

    /// The diffuse BSDF answering on the side of `wi`, and the normal it sees: this BSDF if it is
    /// diffuse, the side's if it is two-sided with a diffuse side there.
    #[inline(always)]
    fn diffuse_side(&self, ns: Vec3A, wi: Vec3A) -> Option<(&Diffuse<Spectrum>, Vec3A)> {
        match self {
            Bsdf::Diffuse(d) => Some((d, ns)),
            Bsdf::TwoSided(t) => match t.side(ns, wi) {
                (Bsdf::Diffuse(d), n) => Some((d, n)),
                _ => None,
            },
            _ => None,
        }
    }

    /// f(wi, wo)·cos θ_o, `None` where it is zero.
    #[inline(always)]
    pub fn eval(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> Option<Spectrum> {
        match self.diffuse_side(ns, wi) {
            Some((d, n)) => d.eval(n, wi, wo),
            None => self.eval_other(ns, wi, wo),
        }
    }

    /// [`Self::eval`] for the BSDFs not answered inline.
    #[inline(never)]
    fn eval_other(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> Option<Spectrum> {
        match self {
            Bsdf::Diffuse(d) => d.eval(ns, wi, wo),
            Bsdf::TwoSided(t) => t.eval(ns, wi, wo),
            Bsdf::Conductor(_) | Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) => None,
            Bsdf::RoughConductor(c) => c.eval_world(ns, wi, wo),
            Bsdf::Plastic(p) => p.eval(ns, wi, wo),
            Bsdf::RoughPlastic(p) => p.eval_world(ns, wi, wo),
            Bsdf::Blend(b) => b.eval(ns, wi, wo),
        }
    }

    /// Sample `wo` given `wi`; `None` if no direction can be sampled (e.g. `wi` below the surface).
    #[inline(always)]
    pub fn sample(&self, ns: Vec3A, wi: Vec3A, rng: &mut Sampler) -> Option<BsdfSample> {
        self.sample_where(ns, wi, rng, |_, _| true)
    }

    /// [`Self::sample`], where a diffuse side first lets `keep` turn down its square sample u
    /// (with the normal it is drawn about) before the warp ([`Diffuse::sample_where`]; other
    /// BSDFs sample as usual).
    #[inline(always)]
    pub fn sample_where(
        &self,
        ns: Vec3A,
        wi: Vec3A,
        rng: &mut Sampler,
        keep: impl FnOnce(Vec3A, Vec2) -> bool,
    ) -> Option<BsdfSample> {
        match self.diffuse_side(ns, wi) {
            Some((d, n)) => d.sample_where(n, wi, rng, keep),
            None => self.sample_other(ns, wi, rng),
        }
    }

    /// The normal around which a diffuse side samples its cosine-weighted directions (`wi`'s
    /// side), if this BSDF is diffuse there.
    pub fn diffuse_normal(&self, ns: Vec3A, wi: Vec3A) -> Option<Vec3A> {
        self.diffuse_side(ns, wi).map(|(_, n)| n)
    }

    /// [`Self::sample`] for the BSDFs not answered inline.
    #[inline(never)]
    fn sample_other(&self, ns: Vec3A, wi: Vec3A, rng: &mut Sampler) -> Option<BsdfSample> {
        match self {
            Bsdf::Diffuse(d) => d.sample(ns, wi, rng),
            Bsdf::TwoSided(t) => t.sample(ns, wi, rng),
            Bsdf::Conductor(c) => c.sample(ns, wi),
            Bsdf::RoughConductor(c) => c.sample_world(ns, wi, rng),
            Bsdf::Dielectric(d) => d.sample(ns, wi, rng),
            Bsdf::ThinDielectric(d) => d.sample(ns, wi, rng),
            Bsdf::Plastic(p) => p.sample(ns, wi, rng),
            Bsdf::RoughPlastic(p) => p.sample_world(ns, wi, rng),
            Bsdf::Blend(b) => b.sample(ns, wi, rng),
        }
    }

    /// Solid-angle density with which [`Bsdf::sample`] picks `wo` given `wi`.
    #[inline(always)]
    pub fn pdf(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> f32 {
        match self.diffuse_side(ns, wi) {
            Some((d, n)) => d.pdf(n, wo),
            None => self.pdf_other(ns, wi, wo),
        }
    }

    /// [`Self::pdf`] for the BSDFs not answered inline.
    #[inline(never)]
    fn pdf_other(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> f32 {
        match self {
            Bsdf::Diffuse(d) => d.pdf(ns, wo),
            Bsdf::TwoSided(t) => t.pdf(ns, wi, wo),
            Bsdf::Conductor(_) | Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) => 0.0,
            Bsdf::RoughConductor(c) => c.pdf_world(ns, wi, wo),
            Bsdf::Plastic(p) => p.pdf(ns, wi, wo),
            Bsdf::RoughPlastic(p) => p.pdf_world(ns, wi, wo),
            Bsdf::Blend(b) => b.pdf(ns, wi, wo),
        }
    }

    /// [`Self::eval`] and [`Self::pdf`] at once, with the same bits (what both need is found
    /// once: a microfacet BSDF's half vector and D there, a coating's Fresnel reflectance).
    #[inline(always)]
    pub fn eval_pdf(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> (Option<Spectrum>, f32) {
        match self.diffuse_side(ns, wi) {
            Some((d, n)) => (d.eval(n, wi, wo), d.pdf(n, wo)),
            None => self.eval_pdf_other(ns, wi, wo),
        }
    }

    /// [`Self::eval_pdf`] for the BSDFs not answered inline.
    #[inline(never)]
    fn eval_pdf_other(&self, ns: Vec3A, wi: Vec3A, wo: Vec3A) -> (Option<Spectrum>, f32) {
        match self {
            Bsdf::Diffuse(d) => (d.eval(ns, wi, wo), d.pdf(ns, wo)),
            Bsdf::TwoSided(t) => t.eval_pdf(ns, wi, wo),
            Bsdf::Conductor(_) | Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) => (None, 0.0),
            Bsdf::RoughConductor(c) => c.eval_pdf_world(ns, wi, wo),
            Bsdf::Plastic(p) => p.eval_pdf(ns, wi, wo),
            Bsdf::RoughPlastic(p) => p.eval_pdf_world(ns, wi, wo),
            Bsdf::Blend(b) => b.eval_pdf(ns, wi, wo),
        }
    }

    /// Whether every component is a Dirac delta (nothing to connect to).
    #[inline]
    pub fn is_delta(&self) -> bool {
        match self {
            Bsdf::Diffuse(_)
            | Bsdf::RoughConductor(_)
            | Bsdf::Plastic(_)
            | Bsdf::RoughPlastic(_) => false,
            Bsdf::Conductor(_) | Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) => true,
            Bsdf::TwoSided(t) => t.front.is_delta() && t.back.is_delta(),
            Bsdf::Blend(b) => b.is_delta(),
        }
    }

    /// Whether some component is a Dirac delta: a technique that only connects (hidden-geometry
    /// sampling) would miss it, so the path must go on by sampling the BSDF.
    #[inline]
    pub fn has_delta(&self) -> bool {
        match self {
            Bsdf::Diffuse(_) | Bsdf::RoughConductor(_) | Bsdf::RoughPlastic(_) => false,
            Bsdf::Conductor(_) | Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) => true,
            Bsdf::Plastic(_) => true,
            Bsdf::TwoSided(t) => t.front.has_delta() || t.back.has_delta(),
            Bsdf::Blend(b) => b.has_delta(),
        }
    }

    /// Whether it scatters nothing, whatever the directions: a `diffuse` of reflectance zero (the
    /// black occluders of two-corner scenes), or `twosided` and `blendbsdf` made of such alone.
    /// A path that reaches it ends there.
    pub fn is_black(&self) -> bool {
        match self {
            Bsdf::Diffuse(d) => d.reflectance == Spectrum::ZERO,
            Bsdf::TwoSided(t) => t.front.is_black() && t.back.is_black(),
            // A mask's pass-through (no first component) lets light on.
            Bsdf::Blend(b) => b.first.as_ref().is_some_and(|f| f.is_black()) && b.second.is_black(),
            _ => false,
        }
    }

    /// Whether light arriving from behind the shading normal scatters on (`twosided` reflects it,
    /// glass transmits it): geometric tests outside the BSDF (hidden-geometry sampling) must then
    /// accept both sides of the surface. Every other BSDF is one-sided, as in Mitsuba.
    #[inline]
    pub fn scatters_behind(&self) -> bool {
        match self {
            Bsdf::Diffuse(_)
            | Bsdf::Conductor(_)
            | Bsdf::RoughConductor(_)
            | Bsdf::Plastic(_)
            | Bsdf::RoughPlastic(_) => false,
            Bsdf::TwoSided(_) | Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) => true,
            Bsdf::Blend(b) => b.scatters_behind(),
        }
    }

    /// The albedo ρ of a view-independent (Lambertian) BSDF on the side the shading normal points
    /// to, for caching a laser spot's next-event estimate once for every path that reaches it;
    /// `None` for any other BSDF.
    #[inline]
    pub fn albedo(&self) -> Option<Spectrum> {
        match self {
            Bsdf::Diffuse(d) => Some(d.reflectance),
            Bsdf::TwoSided(t) => t.front.albedo(),
            _ => None,
        }
    }
}
