//! Sample reuse across scan points (single captures): instead of one path per scan point, a light
//! subpath is traced from the laser spot through the hidden geometry and each of its vertices is
//! connected to every scan point by one shadow ray. Every vertex is drawn uniformly over the hidden
//! geometry's area, as hidden-geometry sampling draws them from the scan point's side, so each scan
//! point receives the same path measurement contribution over the same density as with
//! [`super::NlosTracer::trace`]: the estimate is unbiased and its variance per sample is that of
//! one path, while a contribution costs one shadow ray instead of a path. The price is correlation:
//! all scan points of a render see the same hidden points, so their noise is correlated (an image
//! of N samples shows N hidden points' "speckle" in every pixel, not independent noise per pixel).
//!
//! This is the connection idea of light tracing and bidirectional path tracing (Veach 1997, ch. 10)
//! applied to the scan grid, which shares the light subpath because every scan point of a single
//! capture sees the same laser spot. docs/techniques.md states when it applies and what it gains.

use super::nlos::HiddenEdge;
use super::{NlosTracer, Splat, Step, Vertex, hgrs, russian_roulette};
use crate::bsdf::Bsdf;
use crate::math::Spectrum;
use crate::sampling::Sampler;
use crate::scene::{Scene, Setup};
use crate::settings::CaptureType;
use glam::Vec3A;

/// Whether a render of `scene` shares light subpaths among scan points: `nlos_sample_reuse` is on,
/// the capture is single with laser sampling and hidden-geometry sampling (plain or HGRS) at every
/// vertex (no technique mixture, no depth limit on it), and no BSDF has a delta component (those paths are reached by BSDF sampling from the scan point's side,
/// which a light subpath cannot mirror).
pub fn shares_samples(scene: &Scene) -> bool {
    let Setup::Nlos(n) = &scene.setup else {
        return false;
    };
    let s = &n.settings;
    s.sample_reuse
        && s.capture_type == CaptureType::Single
        && s.laser_sampling
        && s.hidden_geometry_sampling
        && !s.hgs_rroulette
        && s.hgs_max_depth.is_none()
        && !scene.shape_bsdfs(true).iter().any(Bsdf::has_delta)
}

/// A vertex of a light subpath: the hidden point, the direction towards the previous vertex (the
/// laser side), the throughput up to it without its own BSDF (the spot's radiance included), and
/// the optical path from it back to the laser.
struct LightVertex {
    it: crate::geometry::Interaction,
    to_light: Vec3A,
    weight: Spectrum,
    opl: f64,
}

/// One light subpath: its vertices that connect to scan points (those whose path depth passes
/// `max_depth` and `filter_bounces`).
pub struct LightPath {
    vertices: Vec<LightVertex>,
}

impl NlosTracer<'_> {
    /// Trace one light subpath from the laser spot through the hidden geometry. With
    /// `transient_nlos_path_rs` every vertex is an HGRS step (`super::hgrs`): its N candidates and
    /// their shadow rays are paid once for all scan points.
    pub(super) fn trace_light(&self, rng: &mut Sampler) -> Option<LightPath> {
        let st = self.settings;
        let spot = &self.capture.spots[0];
        let hg = self.hidden.as_ref()?;
        if spot.radiance == Some(Spectrum::ZERO) || spot.incident == Spectrum::ZERO {
            return None;
        }
        let area = hg.total_area();
        let step =
            |rng: &mut Sampler, candidate: &mut dyn FnMut(&mut Sampler) -> Option<Step>| match st
                .hgrs
            {
                Some(h) => hgrs::sample(h, rng, candidate),
                None => candidate(rng),
            };
        // ---- The first hidden vertex, lit by the spot (connect_spot's terms, from the other
        // end), its area density 1/A included: the subpath's source.
        let first = step(rng, &mut |rng| {
            let y = hg.sample(self.scene, rng);
            let u = spot.it.p - y.p;
            let r2 = u.length_squared();
            let r = r2.sqrt();
            let w = u / r;
            let cos_z = spot.it.ns.dot(-w);
            if cos_z <= 0.0 || !self.scene.visible(&y, spot.it.p) {
                return None;
            }
            Some(Step {
                next: y,
                dist: r,
                weight: self.spot_radiance(spot, w)? * (area * cos_z / r2),
                eta: 1.0,
            })
        })?;
        let source = first.weight;
        let mut path = LightPath {
            vertices: Vec::new(),
        };
        // Russian roulette reads the throughput after the source, `beta`.
        let (mut it, mut beta) = (first.next, Spectrum::ONE);
        let mut to_light = (spot.it.p - it.p).normalize();
        let mut opl = first.dist as f64 + spot.last_leg;
        let mut count: u32 = 1;
        loop {
            // A path of `count` hidden vertices has depth count + 2 (the per-point tracer's
            // emitter sampling at loop depth `count`).
            if count.saturating_add(1) < st.max_depth && st.keep(count + 2) {
                path.vertices.push(LightVertex {
                    it,
                    to_light,
                    weight: beta * source,
                    opl,
                });
            }
            // ---- The next hidden vertex, on the scan point's side of this one.
            if count.saturating_add(2) >= st.max_depth
                || st.filter_depth.is_some_and(|f| count + 3 > f)
            {
                break;
            }
            let next = step(rng, &mut |rng| {
                let x = hg.sample(self.scene, rng);
                let e = HiddenEdge::new(&x, &it, area)?;
                let f = self.bsdf(&it).eval(it.ns, -e.w, to_light)?;
                if !self.scene.visible(&x, it.p) {
                    return None;
                }
                Some(Step {
                    next: x,
                    dist: e.r,
                    weight: f * (area * e.cos_y / e.r2),
                    eta: 1.0,
                })
            });
            let Some(next) = next else {
                break;
            };
            beta *= next.weight;
            if !russian_roulette(&mut beta, 1.0, count, st.rr_depth, rng) {
                break;
            }
            to_light = (it.p - next.next.p).normalize();
            (it, opl, count) = (next.next, opl + next.dist as f64, count + 1);
        }
        Some(path)
    }

    /// The contributions of one light sample to `pixel`: its scan point – spot path (which the
    /// per-point tracer adds at every sample) and the connection of every vertex of `light`. The
    /// pixel's first vertex is drawn from its own stream `pixel_rng` (a camera's jittered ray; a
    /// scan point takes no randomness), so no pixel's result depends on which others share it.
    pub(super) fn connect_light(
        &self,
        pixel: usize,
        pixel_rng: &mut Sampler,
        light: Option<&LightPath>,
        out: &mut impl FnMut(Splat),
    ) {
        let st = self.settings;
        let Some(x) = self.first_vertex(pixel, pixel_rng) else {
            return;
        };
        if st.max_depth > 1 && st.keep(2) {
            self.connect_spot(&x, &self.capture.spots[0], 0, out);
        }
        let (Some(light), Some(hg)) = (light, self.hidden.as_ref()) else {
            return;
        };
        for v in &light.vertices {
            self.connect_scan_point(&x, v, hg.total_area(), out);
        }
    }

    /// The contribution of the path scan point `x` → light subpath ending at `v`: the terms of a
    /// hidden-geometry step from `x` to `v` (whose area density is already in `v.weight`), `v`'s
    /// BSDF between `x` and the laser side, and the subpath's throughput.
    #[inline]
    fn connect_scan_point(
        &self,
        x: &Vertex,
        v: &LightVertex,
        area: f32,
        out: &mut impl FnMut(Splat),
    ) {
        let Some(e) = HiddenEdge::new(&x.it, &v.it, area) else {
            return;
        };
        let Some(f_x) = self.bsdf(&x.it).eval(x.it.ns, x.wi, e.w) else {
            return;
        };
        let Some(f_v) = self.bsdf(&v.it).eval(v.it.ns, -e.w, v.to_light) else {
            return;
        };
        if !self.scene.visible(&x.it, v.it.p) {
            return;
        }
        out(Splat {
            slot: 0,
            opl: x.opl + e.r as f64 + v.opl,
            value: x.beta * f_x * (e.cos_y / e.r2) * f_v * v.weight,
        });
    }
}
