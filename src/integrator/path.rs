//! `transient_path`: line-of-sight transient path tracing (mitransient 1.3.1's `TransientPath`,
//! itself Mitsuba 3's `path` with a time dimension). Next-event estimation and BSDF sampling are
//! combined with the power heuristic (Veach 1997); emission found by either is splatted at the
//! optical path length travelled so far, from the camera's pinhole (or from the first surface with
//! `camera_unwarp`).

use super::{AreaSampler, Splat, diffuse_f, max_depth, russian_roulette, temporal_filter};
use crate::camera::Camera;
use crate::emitter::Light;
use crate::error::{NlosError, Result};
use crate::film::TemporalKernel;
use crate::geometry::{Interaction, shadow_segment};
use crate::math::{Frame, Spectrum};
use crate::props::Props;
use crate::sampling::{Sampler, square_to_cosine_hemisphere};
use crate::scene::Scene;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

/// The parameters of `transient_path`.
#[derive(Clone, Debug)]
pub struct PathSettings {
    /// Longest path in segments (Mitsuba's meaning: 1 = directly visible lights); `u32::MAX` for -1.
    pub max_depth: u32,
    /// Depth from which Russian roulette applies.
    pub rr_depth: u32,
    /// Measure time from the first surface the camera sees instead of from the pinhole.
    pub camera_unwarp: bool,
    /// Drop light seen directly by the camera.
    pub discard_direct_light: bool,
    /// `temporal_filter='gaussian'` with `gaussian_stddev` (bins).
    pub temporal_kernel: Option<TemporalKernel>,
}

impl PathSettings {
    /// Read the integrator's properties; unknown ones are rejected.
    pub fn from_props(p: &Props) -> Result<Self> {
        let plugin = p.plugin.as_str();
        let max_depth = max_depth(p, 6)?;
        let rr_depth = p.int("rr_depth", 5)?;
        if rr_depth <= 0 || rr_depth >= u32::MAX as i64 {
            return Err(NlosError::prop(plugin, "rr_depth", "must be > 0"));
        }
        let temporal_kernel = temporal_filter(p, 2.0)?;
        // Accepted because mitransient accepts them; without an environment light they change nothing.
        p.bool("hide_emitters", false)?;
        p.int("block_size", 0)?;
        p.int("samples_per_pass", -1)?;
        let s = Self {
            max_depth,
            rr_depth: rr_depth as u32,
            camera_unwarp: p.bool("camera_unwarp", false)?,
            discard_direct_light: p.bool("discard_direct_light", false)?,
            temporal_kernel,
        };
        p.finish()?;
        Ok(s)
    }
}

/// Power heuristic with exponent 2 (Mitsuba's `mis_weight`).
#[inline]
fn mis(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

enum Emitter {
    Area {
        sampler: AreaSampler,
        radiance: Spectrum,
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
    rho: Vec<Spectrum>,
    emitters: Vec<Emitter>,
    /// Emitter index of each shape, if it emits.
    shape_emitter: Vec<Option<usize>>,
    /// Output channels.
    pub channels: usize,
}

impl<'a> PathTracer<'a> {
    /// Prepare a render in mono or rgb.
    pub fn new(
        scene: &'a Scene,
        settings: &'a PathSettings,
        camera: &'a Camera,
        lights: &[Light],
        mono: bool,
    ) -> Result<Self> {
        let mut shape_emitter = vec![None; scene.shapes.len()];
        let mut emitters = Vec::with_capacity(lights.len());
        for light in lights {
            emitters.push(match *light {
                Light::Area { shape, radiance } => {
                    shape_emitter[shape] = Some(emitters.len());
                    let sampler = AreaSampler::new(scene, |s| s == shape).ok_or_else(|| {
                        NlosError::prop("area", "radiance", "the emitting shape has no area")
                    })?;
                    Emitter::Area {
                        sampler,
                        radiance: radiance.spectrum(mono),
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
        let rho = scene
            .bsdfs
            .iter()
            .map(|b| b.reflectance.spectrum(mono))
            .collect();
        Ok(Self {
            scene,
            settings,
            camera,
            rho,
            emitters,
            shape_emitter,
            channels: if mono { 1 } else { 3 },
        })
    }

    /// Solid-angle density with which next-event estimation picks the point `y` (normal `ng`) of
    /// an area light from `x`: (1/N_lights) · r² / (A·|cos|).
    fn light_pdf(&self, sampler: &AreaSampler, x: Vec3A, y: Vec3A, ng: Vec3A) -> f32 {
        let v = y - x;
        let r2 = v.length_squared();
        let cos = ng.dot(v).abs() / r2.sqrt();
        if cos <= 0.0 {
            0.0
        } else {
            r2 / (cos * sampler.total_area() * self.emitters.len() as f32)
        }
    }

    /// Next-event estimation at `x` (a light chosen uniformly, then a point on it).
    #[inline]
    fn sample_light(
        &self,
        x: &Interaction,
        wi: Vec3A,
        rho: Spectrum,
        beta: Spectrum,
        opl: f64,
        rng: &mut Sampler,
        out: &mut impl FnMut(Splat),
    ) {
        let n = self.emitters.len();
        let k = ((rng.next_1d() * n as f32) as usize).min(n - 1);
        let (target, le_over_pdf, mis_w) = match &self.emitters[k] {
            Emitter::Point {
                position,
                intensity,
            } => {
                let r2 = (*position - x.p).length_squared();
                (*position, *intensity * (n as f32 / r2), 1.0)
            }
            Emitter::Area { sampler, radiance } => {
                let y = sampler.sample(self.scene, rng.next_1d(), rng.next_2d());
                let w = (x.p - y.p).normalize();
                if y.ns.dot(w) <= 0.0 {
                    return; // the back of a one-sided area light
                }
                let pdf = self.light_pdf(sampler, x.p, y.p, y.ng);
                let wo = -w;
                let bsdf_pdf = x.ns.dot(wo).max(0.0) * FRAC_1_PI;
                (y.p, *radiance / pdf, mis(pdf, bsdf_pdf))
            }
        };
        let v = target - x.p;
        let dist = v.length();
        let Some(f) = diffuse_f(rho, x.ns, wi, v / dist) else {
            return;
        };
        let (o, d, tmax) = shadow_segment(x, target);
        if !self.scene.accel.unoccluded(o, d, 0.0, tmax) {
            return;
        }
        out((0, opl + dist as f64, beta * f * le_over_pdf * mis_w));
    }

    /// Trace one camera path through pixel `pixel` (row-major), emitting its contributions.
    pub fn trace(
        &self,
        pixel: usize,
        width: usize,
        height: usize,
        rng: &mut Sampler,
        out: &mut impl FnMut(Splat),
    ) {
        let st = self.settings;
        let j = rng.next_2d();
        let uv = Vec2::new(
            ((pixel % width) as f32 + j.x) / width as f32,
            ((pixel / width) as f32 + j.y) / height as f32,
        );
        let (mut o, mut d, mut tmin, mut tmax) = self.camera.ray(uv);
        let mut beta = Spectrum::ONE;
        let mut opl = 0.0f64;
        // The previous vertex and its BSDF sampling density, for MIS on emission hits.
        let mut prev: Option<(Vec3A, f32)> = None;
        let mut depth: u32 = 0;
        loop {
            let Some(hit) = self.scene.accel.intersect(o, d, tmin, tmax) else {
                break;
            };
            let it = self.scene.interaction(o, d, &hit);
            let from = prev.map_or(o, |p| p.0);
            let seg = (it.p - from).length() as f64;
            opl += if depth == 0 && st.camera_unwarp {
                0.0
            } else {
                seg
            };
            let wi = -d;
            // ---- Emission found by the camera ray or by BSDF sampling
            if let Some(k) = self.shape_emitter[it.shape as usize] {
                if let Emitter::Area { sampler, radiance } = &self.emitters[k] {
                    if it.ns.dot(wi) > 0.0 && !(depth == 0 && st.discard_direct_light) {
                        let w = prev.map_or(1.0, |(px, bsdf_pdf)| {
                            mis(bsdf_pdf, self.light_pdf(sampler, px, it.p, it.ng))
                        });
                        out((0, opl, beta * *radiance * w));
                    }
                }
            }
            if depth.saturating_add(1) >= st.max_depth {
                break;
            }
            let rho = self.rho[self.scene.shapes[it.shape as usize].bsdf];
            // ---- Emitter sampling
            self.sample_light(&it, wi, rho, beta, opl, rng, out);
            // ---- BSDF sampling (cosine-weighted: weight ρ, pdf cosθ/π)
            if it.ns.dot(wi) <= 0.0 {
                break;
            }
            let local = square_to_cosine_hemisphere(rng.next_2d());
            let wo = Frame::new(it.ns).to_world(local);
            beta *= rho;
            if !russian_roulette(&mut beta, depth, st.rr_depth, rng) {
                break;
            }
            prev = Some((it.p, local.z * FRAC_1_PI));
            o = it.offset_origin(wo);
            d = wo;
            (tmin, tmax) = (0.0, f32::INFINITY);
            depth += 1;
        }
    }
}
