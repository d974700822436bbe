//! `transient_path`: line-of-sight transient path tracing (mitransient 1.3.1's `TransientPath`,
//! itself Mitsuba 3's `path` with a time dimension). Next-event estimation and BSDF sampling are
//! combined with the power heuristic (Veach 1997); emission found by either is splatted at the
//! optical path length travelled so far, from the camera's pinhole (or from the first surface with
//! `camera_unwarp`).

use super::path_packet::PathPacket;
use super::scan_cone::pixel_footprints;
use super::{Splat, Tracer, Vertex, russian_roulette};
use crate::bsdf::Bsdf;
use crate::emitter::{AngularFalloff, Light};
use crate::error::{NlosError, Result};
use crate::geometry::{Hit, Ray};
use crate::math::Spectrum;
use crate::sampling::Sampler;
use crate::scene::{AreaSampler, Los, Scene};
use crate::sensor::Camera;
use crate::settings::PathSettings;
use glam::Vec3A;
use std::ops::Range;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Radiance an area light sends at `cos_theta` from its normal (`None` where its falloff is zero).
#[inline]
fn emitted(
    radiance: Spectrum,
    falloff: Option<AngularFalloff>,
    cos_theta: f32,
) -> Option<Spectrum> {
    match falloff {
        None => Some(radiance),
        Some(f) => {
            let k = f.eval(cos_theta);
            (k > 0.0).then(|| radiance * k)
        }
    }
}

/// Power heuristic with exponent 2 (Mitsuba's `mis_weight`).
#[inline]
pub(super) fn mis(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

enum Emitter {
    Area {
        sampler: AreaSampler,
        radiance: Spectrum,
        falloff: Option<AngularFalloff>,
    },
    Point {
        position: Vec3A,
        intensity: Spectrum,
    },
}

/// A prepared `transient_path` render.
pub struct PathTracer<'a> {
    scene: &'a Scene,
    settings: &'a PathSettings,
    camera: &'a Camera,
    /// Film size (pixels).
    width: usize,
    height: usize,
    /// Each shape's BSDF.
    bsdfs: Vec<Bsdf<Spectrum>>,
    /// Per shape: whether every component of its BSDF is a delta, computed once.
    delta: Vec<bool>,
    emitters: Vec<Emitter>,
    /// Emitter index of each shape, if it emits.
    shape_emitter: Vec<Option<usize>>,
    /// Per pixel, the one small shape its camera rays can meet, if only one
    /// ([`super::scan_cone::Footprints::sole_shapes`]); `None` for a render of fewer than
    /// [`SOLE_SHAPES_MIN_SPP`] samples per pixel.
    sole_shapes: Option<Arc<SoleShapes>>,
    /// The lockstep render, where the scene and the render allow it.
    packet: Option<PathPacket<'a>>,
}

/// Fewest samples per pixel for which a render finds its pixels' sole shapes: that takes about
/// 0.45 µs a pixel (72 ms for mitransient's Cornell box file at 400×400, once per scene), and
/// spares each camera ray of those pixels the scene's scan (mitransient's line-of-sight examples
/// with one area light 1.04–1.14× as fast; the golden digest `los_cornell_adaptive` renders with
/// them).
const SOLE_SHAPES_MIN_SPP: u64 = 64;

/// What a render prepares from the scene alone: each pixel's sole shape. A render of every pixel
/// makes it once per scene and variant, and later renders take it from the scene
/// ([`crate::scene::Prepared`]).
struct SoleShapes(Vec<Option<u32>>);

impl<'a> PathTracer<'a> {
    /// Prepare a render of the pixels `pixels`, `spp` samples each, in mono or rgb; in lockstep
    /// lanes ([`PathPacket`]) if `lockstep` (the render keeps no per-sample values and draws
    /// independent numbers) and the scene allows.
    pub fn new(
        scene: &'a Scene,
        los: &'a Los,
        mono: bool,
        spp: u64,
        cancel: &AtomicBool,
        pixels: Range<usize>,
        lockstep: bool,
    ) -> Result<Self> {
        let packet = lockstep
            .then(|| PathPacket::new(scene, los, mono))
            .flatten();
        let mut shape_emitter = vec![None; scene.shapes.len()];
        let mut emitters = Vec::with_capacity(los.lights.len());
        for light in &los.lights {
            emitters.push(match *light {
                Light::Area {
                    shape,
                    radiance,
                    falloff,
                } => {
                    shape_emitter[shape] = Some(emitters.len());
                    let sampler = AreaSampler::new(scene, |s| s == shape).ok_or_else(|| {
                        NlosError::prop("area", "radiance", "the emitting shape has no area")
                    })?;
                    Emitter::Area {
                        sampler,
                        radiance: radiance.spectrum(mono),
                        falloff,
                    }
                }
                Light::Point {
                    position,
                    intensity,
                } => Emitter::Point {
                    position,
                    intensity: intensity.spectrum(mono),
                },
            });
        }
        let film = &scene.meter.film;
        let make = || {
            let f = pixel_footprints(scene, &los.camera, cancel, pixels.clone());
            // (The footprints stop early, empty, once the render is cancelled: nothing is kept.)
            if cancel.load(Ordering::Relaxed) {
                return Err(NlosError::Interrupted);
            }
            Ok(SoleShapes(f.sole_shapes))
        };
        let sole_shapes = if spp < SOLE_SHAPES_MIN_SPP || packet.is_some() {
            None
        } else if pixels == (0..film.width * film.height) {
            Some(scene.prepared.get_or_make(mono, make)?)
        } else {
            Some(Arc::new(make()?))
        };
        let bsdfs = scene.shape_bsdfs(mono);
        Ok(Self {
            sole_shapes,
            scene,
            settings: &los.settings,
            camera: &los.camera,
            width: scene.meter.film.width,
            height: scene.meter.film.height,
            delta: bsdfs.iter().map(Bsdf::is_delta).collect(),
            bsdfs,
            emitters,
            shape_emitter,
            packet,
        })
    }

    /// Solid-angle density with which next-event estimation picks the point y (normal `ng`) of an
    /// area light from x: (1/N_lights) · r² / (A·|cos|), from `v` = y − x, r² and r (which the
    /// callers have already computed).
    #[inline]
    fn light_pdf(&self, sampler: &AreaSampler, v: Vec3A, r2: f32, r: f32, ng: Vec3A) -> f32 {
        let cos = ng.dot(v).abs() / r;
        if cos <= 0.0 {
            0.0
        } else {
            r2 / (cos * sampler.total_area() * self.emitters.len() as f32)
        }
    }

    /// A camera ray's hit on the one shape its pixel's rays can meet ([`Scene::camera_hit`]),
    /// out of line: inlined into the path loop, it slowed every bounce (mitransient's
    /// `cbox_diffuse.xml` 0.97×).
    #[inline(never)]
    fn sole_hit(&self, ray: &Ray, shape: u32) -> Option<Hit> {
        self.scene.camera_hit(ray, Some(shape))
    }

    /// Next-event estimation at `x` (a light chosen uniformly, then a point on it).
    #[inline]
    fn sample_light(
        &self,
        path: &Vertex,
        bsdf: &Bsdf<Spectrum>,
        rng: &mut Sampler,
        out: &mut impl FnMut(Splat),
    ) {
        let (x, wi, beta, opl, eta) = (&path.it, path.wi, path.beta, path.opl, path.eta);
        let n = self.emitters.len();
        let k = ((rng.next_1d() * n as f32) as usize).min(n - 1);
        let (target, le_over_pdf, mis_w, dist) = match &self.emitters[k] {
            Emitter::Point {
                position,
                intensity,
            } => {
                let r2 = (*position - x.p).length_squared();
                (*position, *intensity * (n as f32 / r2), 1.0, r2.sqrt())
            }
            Emitter::Area {
                sampler,
                radiance,
                falloff,
            } => {
                let y = sampler.sample(self.scene, rng);
                // The direction to x, its length and squared length, each computed once (as
                // `normalize`, `length` and `length_squared` would: the same bits).
                let to_x = x.p - y.p;
                let r2 = to_x.length_squared();
                let r = r2.sqrt();
                let w = to_x / r;
                if y.ns.dot(w) <= 0.0 {
                    return; // the back of a one-sided area light
                }
                let Some(le) = emitted(*radiance, *falloff, y.ns.dot(w)) else {
                    return;
                };
                let pdf = self.light_pdf(sampler, -to_x, r2, r, y.ng);
                (y.p, le / pdf, mis(pdf, bsdf.pdf(x.ns, wi, -w)), r)
            }
        };
        let v = target - x.p;
        let Some(f) = bsdf.eval(x.ns, wi, v / dist) else {
            return;
        };
        if !self.scene.visible(x, target) {
            return;
        }
        out(Splat {
            slot: 0,
            opl: opl + (dist * eta) as f64,
            value: beta * f * le_over_pdf * mis_w,
        });
    }
}

/// A camera path between bounces: the ray to trace next and what the path carries.
pub struct CameraPath {
    ray: Ray,
    beta: Spectrum,
    opl: f64,
    /// Index of refraction of the medium the path is in: light is slower by it.
    eta: f32,
    /// The previous vertex and its BSDF sampling density (`None` after a delta reflection,
    /// which no light sample can find), for MIS on emission hits.
    prev: Option<(Vec3A, Option<f32>)>,
    depth: u32,
    /// Before the first bounce, the one shape the camera ray can meet, if known.
    sole: Option<u32>,
}

impl Tracer for PathTracer<'_> {
    type Light = ();
    type Path = CameraPath;
    const IN_FLIGHT: usize = 2;

    fn packet(&self) -> Option<&PathPacket<'_>> {
        self.packet.as_ref()
    }

    /// A camera path through pixel `pixel` (row-major), before its first bounce.
    #[inline]
    fn begin(&self, pixel: usize, rng: &mut Sampler) -> CameraPath {
        CameraPath {
            ray: self
                .camera
                .pixel_ray(pixel, self.width, self.height, rng.next_2d()),
            beta: Spectrum::ONE,
            opl: 0.0,
            eta: 1.0,
            prev: None,
            depth: 0,
            sole: self.sole_shapes.as_ref().and_then(|s| s.0[pixel]),
        }
    }

    /// Trace the path's ray and shade what it hits: emission found, a light sample, the next
    /// direction.
    #[inline]
    fn bounce(
        &self,
        path: &mut CameraPath,
        rng: &mut Sampler,
        out: &mut impl FnMut(Splat),
    ) -> bool {
        let st = self.settings;
        let CameraPath {
            ray,
            beta,
            opl,
            eta,
            prev,
            depth,
            sole,
        } = path;
        let hit = match sole.take() {
            Some(shape) => self.sole_hit(ray, shape),
            None => self.scene.accel.intersect(ray.o, ray.d, ray.tmin, ray.tmax),
        };
        let Some(hit) = hit else {
            return false;
        };
        let it = self.scene.interaction(ray.o, ray.d, &hit);
        // The segment just travelled (its length as `length` computes it; reused by MIS).
        let from = prev.map_or(ray.o, |p| p.0);
        let to_it = it.p - from;
        let r2 = to_it.length_squared();
        let r = r2.sqrt();
        let seg = r as f64;
        *opl += match *depth {
            0 if st.camera_unwarp => 0.0,
            0 if st.opl_from_near_clip => seg - ray.tmin as f64,
            _ => seg * *eta as f64,
        };
        let wi = -ray.d;
        // ---- Emission found by the camera ray or by BSDF sampling
        if let Some(k) = self.shape_emitter[it.shape as usize]
            && let Emitter::Area {
                sampler,
                radiance,
                falloff,
            } = &self.emitters[k]
            && it.ns.dot(wi) > 0.0
            && !(*depth == 0 && st.discard_direct_light)
            && let Some(le) = emitted(*radiance, *falloff, it.ns.dot(wi))
        {
            let w = match *prev {
                // `from` is the previous vertex here, so `to_it` is the light sample's y − x.
                Some((_, Some(bsdf_pdf))) => {
                    mis(bsdf_pdf, self.light_pdf(sampler, to_it, r2, r, it.ng))
                }
                _ => 1.0,
            };
            out(Splat {
                slot: 0,
                opl: *opl,
                value: *beta * le * w,
            });
        }
        if depth.saturating_add(1) >= st.max_depth {
            return false;
        }
        let bsdf = &self.bsdfs[it.shape as usize];
        // ---- Emitter sampling (not at a delta vertex: nothing to connect to)
        if !self.delta[it.shape as usize] {
            self.sample_light(&Vertex::new(it, wi, *beta, *opl, *eta), bsdf, rng, out);
        }
        // ---- BSDF sampling
        let Some(s) = bsdf.sample(it.ns, wi, rng) else {
            return false;
        };
        *beta *= s.weight;
        *eta *= s.eta;
        if !russian_roulette(beta, *eta, *depth, st.rr_depth, rng) {
            return false;
        }
        *prev = Some((it.p, (!s.delta).then_some(s.pdf)));
        *ray = Ray {
            o: it.offset_origin(s.wo),
            d: s.wo,
            tmin: 0.0,
            tmax: f32::INFINITY,
        };
        *depth += 1;
        true
    }
}
