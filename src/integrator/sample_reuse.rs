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

use super::{NlosTracer, Splat, Vertex, russian_roulette};
use crate::bsdf::Bsdf;
use crate::math::{COS_EPS, Spectrum};
use crate::sampling::Sampler;
use crate::scene::{Scene, Setup};
use crate::settings::CaptureType;
use glam::Vec3A;
use std::ops::Range;

/// Whether a render of `scene` shares light subpaths among scan points: `nlos_sample_reuse` is on,
/// the capture is single with laser sampling and hidden-geometry sampling at every vertex (no
/// HGRS, no technique mixture, no depth limit on it), and no BSDF has a delta component (those paths are reached by BSDF sampling from the scan point's side,
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
        && s.hgrs.is_none()
        && !scene.shape_bsdfs(true).iter().any(Bsdf::has_delta)
}

/// A vertex of the light subpath: the hidden point, the direction towards the previous vertex
/// (the laser side), the throughput up to it without its own BSDF, and the optical path from it
/// back to the laser.
struct LightVertex {
    it: crate::geometry::Interaction,
    to_light: Vec3A,
    beta: Spectrum,
    opl: f64,
    /// Hidden vertices so far, this one included.
    count: u32,
}

impl NlosTracer<'_> {
    /// One light subpath, connected to every scan point of `pixels`; `out(pixel, splat)`. The
    /// first vertex of each pixel is drawn anew from that pixel's own stream in `pixel_rngs` (a
    /// camera's jittered ray; a scan point takes no randomness), so that no pixel's result depends on
    /// which others share the run.
    pub(super) fn trace_shared(
        &self,
        pixels: Range<usize>,
        rng: &mut Sampler,
        pixel_rngs: &mut [Sampler],
        out: &mut impl FnMut(usize, Splat),
    ) {
        let st = self.settings;
        let spot = &self.capture.spots[0];
        let p0 = pixels.start;
        let first: Vec<Option<Vertex>> = pixels
            .clone()
            .map(|p| self.first_vertex(p, &mut pixel_rngs[p - p0]))
            .collect();
        // Scan point – spot paths, which the per-point tracer adds at every sample.
        if st.max_depth > 1 && st.keep(2) {
            for (p, v) in pixels.clone().zip(&first) {
                if let Some(v) = v {
                    self.connect_spot(v, spot, 0, &mut |s| out(p, s));
                }
            }
        }
        let Some(hg) = self.hidden.as_ref() else {
            return;
        };
        if spot.radiance == Some(Spectrum::ZERO) || spot.incident == Spectrum::ZERO {
            return;
        }
        let area = hg.total_area();
        // ---- The first hidden vertex, lit by the spot (connect_spot's terms, from the other end).
        let y = hg.sample(self.scene, rng);
        let u = spot.it.p - y.p;
        let r2 = u.length_squared();
        let r = r2.sqrt();
        let w = u / r;
        let cos_z = spot.it.ns.dot(-w);
        if cos_z <= 0.0 || !self.scene.visible(&y, spot.it.p) {
            return;
        }
        let Some(radiance) = self.spot_radiance(spot, w) else {
            return;
        };
        let source = radiance * (cos_z / r2);
        let mut v = LightVertex {
            it: y,
            to_light: w,
            beta: Spectrum::splat(area),
            opl: r as f64 + spot.last_leg,
            count: 1,
        };
        loop {
            // ---- Connect this vertex to every scan point: a path of `count` hidden vertices,
            // depth count + 2 (the per-point tracer's emitter sampling at loop depth `count`).
            if v.count.saturating_add(1) < st.max_depth && st.keep(v.count + 2) {
                for (p, x) in pixels.clone().zip(&first) {
                    if let Some(x) = x {
                        self.connect_scan_point(x, &v, source, area, &mut |s| out(p, s));
                    }
                }
            }
            // ---- The next hidden vertex, on the scan point's side of this one.
            if v.count.saturating_add(2) >= st.max_depth
                || st.filter_depth.is_some_and(|f| v.count + 3 > f)
            {
                break;
            }
            let x = hg.sample(self.scene, rng);
            let d = v.it.p - x.p;
            let r2 = d.length_squared();
            let r = r2.sqrt();
            let w = d / r;
            let cos_g = v.it.ns.dot(-w);
            if x.ng.dot(w) <= COS_EPS || cos_g <= COS_EPS || r2 / (area * cos_g) <= COS_EPS {
                break;
            }
            let Some(f) = self.bsdf(&v.it).eval(v.it.ns, -w, v.to_light) else {
                break;
            };
            if !self.scene.visible(&x, v.it.p) {
                break;
            }
            let mut beta = v.beta * f * (area * cos_g / r2);
            if !russian_roulette(&mut beta, 1.0, v.count, st.rr_depth, rng) {
                break;
            }
            v = LightVertex {
                it: x,
                to_light: w,
                beta,
                opl: v.opl + r as f64,
                count: v.count + 1,
            };
        }
    }

    /// The contribution of the path scan point `x` → light subpath ending at `v`: the terms of a
    /// hidden-geometry step from `x` to `v` (whose area density is already in `v.beta`), `v`'s BSDF
    /// between `x` and the laser side, and the subpath's throughput.
    #[inline]
    fn connect_scan_point(
        &self,
        x: &Vertex,
        v: &LightVertex,
        source: Spectrum,
        area: f32,
        out: &mut impl FnMut(Splat),
    ) {
        let d = v.it.p - x.it.p;
        let r2 = d.length_squared();
        let r = r2.sqrt();
        let w = d / r;
        let cos_g = v.it.ns.dot(-w);
        if x.it.ng.dot(w) <= COS_EPS || cos_g <= COS_EPS || r2 / (area * cos_g) <= COS_EPS {
            return;
        }
        let Some(f_x) = self.bsdf(&x.it).eval(x.it.ns, x.wi, w) else {
            return;
        };
        let Some(f_v) = self.bsdf(&v.it).eval(v.it.ns, -w, v.to_light) else {
            return;
        };
        if !self.scene.visible(&x.it, v.it.p) {
            return;
        }
        out(Splat {
            slot: 0,
            opl: x.opl + r as f64 + v.opl,
            value: x.beta * f_x * (cos_g / r2) * f_v * v.beta * source,
        });
    }
}
