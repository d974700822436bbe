//! Sample reuse across scan points: instead of one path per scan point, a light subpath is traced
//! through the hidden geometry and each of its vertices is connected to every scan point by one
//! shadow ray. The first vertex is drawn over the hidden geometry's area, as hidden-geometry
//! sampling draws it from the scan point's side, and later ones from the mixture of
//! [`super::hidden_mixture`] (from the light's end), each weighted by its area density, so each
//! scan point receives a path measurement contribution over its density as with a path traced
//! per scan point (`NlosTracer::trace`): the estimate is unbiased and its variance per sample is
//! that of one path, while a contribution costs one shadow ray instead of a path. The price is
//! correlation: all scan points of a render see the same hidden points, so their noise is
//! correlated (an image of N samples shows N hidden points' "speckle" in every pixel, not
//! independent noise per pixel).
//!
//! * A single capture's subpath starts at its one laser spot (the spot lights the first vertex).
//! * Confocal and exhaustive captures have many spots, so the subpath starts at its first hidden
//!   vertex, lit by no spot in particular; each spot is linked to that vertex by one shadow ray
//!   ([`SpotLink`]): once per subpath for an exhaustive capture's laser grid (every scan point
//!   shares the links, so a subpath serves every (scan point, laser point) pair), once per scan
//!   point for a confocal one (its own spot).
//! * Hidden glass and mirrors (BSDFs that are all delta) are carried: a light subpath goes on
//!   through them by sampling their BSDF (adjoint weights), and each pixel traces the paths whose
//!   vertex after its first lies on them, its delta prefixes (`NlosTracer::delta_prefix`).
//!
//! This is the connection idea of light tracing and bidirectional path tracing (Veach 1997, ch. 10)
//! applied to the scan grid. docs/techniques.md states when it applies and what it gains.

use super::clear_view::paths_end_on;
use super::nlos::{HiddenEdge, NlosPath};
use super::{NlosTracer, Splat, Step, Vertex, hgrs, russian_roulette};
use crate::bsdf::Bsdf;
use crate::capture::Spot;
use crate::geometry::{Interaction, shadow_segment};
use crate::math::{COS_EPS, Spectrum};
use crate::sampling::Sampler;
use crate::scene::{AreaSampler, Scene, Setup};
use crate::settings::CaptureType;
use glam::Vec3A;
use std::sync::atomic::Ordering;

/// Whether a render of `scene` shares light subpaths among scan points: `nlos_sample_reuse` is on,
/// the capture uses laser sampling and hidden-geometry sampling at every vertex (no technique
/// mixture, no depth limit on it; HGRS only for a single capture, whose first vertex's candidates
/// are judged from its one spot), and every surface whose BSDF has a delta component is one the
/// render can carry ([`delta_surfaces`]). Hidden surfaces whose BSDF is all delta (glass, mirrors)
/// are carried by light subpaths through them and by the pixels' delta prefixes; those take
/// neither HGRS nor `filter_bounces`, and the hidden geometry must have some surface that is not
/// all delta (else no path connects anything past its first vertex, and the per-point tracer ends
/// each there at once).
pub fn shares_samples(scene: &Scene) -> bool {
    let Setup::Nlos(n) = &scene.setup else {
        return false;
    };
    let s = &n.settings;
    let (carried, some_delta, all_delta) = *scene.delta_surfaces
        [s.hgs_includes_relay_wall as usize]
        .get_or_init(|| delta_surfaces(scene));
    s.sample_reuse
        && (s.capture_type == CaptureType::Single || s.hgrs.is_none())
        && laser_points(scene, s) <= MAX_LINKED_SPOTS
        && s.laser_sampling
        && s.hidden_geometry_sampling
        && !s.hgs_rroulette
        && s.hgs_max_depth.is_none()
        && carried
        && (!some_delta || (s.hgrs.is_none() && s.filter_depth.is_none() && !all_delta))
}

/// For the hidden geometry of `scene`: whether every surface whose BSDF has a delta component can
/// be carried by a shared render, whether some hidden surface's BSDF is all delta, and whether
/// every one is. A hidden surface whose BSDF is all delta is carried (light subpaths go on from it
/// by sampling its BSDF, and the paths whose vertex after the scan point lies there are each
/// pixel's delta prefixes). Any other (a delta component beside a non-delta one, as in smooth
/// plastic, or a delta off the hidden geometry) must end every path: such a path is reached by
/// BSDF sampling from the scan point's side, which a light subpath cannot mirror, so those
/// surfaces must have no hidden geometry beyond the sides their BSDF leaves by
/// (`clear_view::paths_end_on`: a flat plastic letter facing the relay wall, whose mirror
/// reflection meets nothing hidden; not an extruded one, whose sides face one another).
fn delta_surfaces(scene: &Scene) -> (bool, bool, bool) {
    let bsdfs = scene.shape_bsdfs(true);
    let Some(hidden) = scene.sampled_hidden_geometry() else {
        return (!bsdfs.iter().any(Bsdf::has_delta), false, false);
    };
    let delta_hidden = |k: usize| hidden.covers(k as u32) && bsdfs[k].is_delta();
    let blocked = |k: usize| bsdfs[k].has_delta() && !delta_hidden(k);
    let carried = !(0..bsdfs.len()).any(blocked)
        || paths_end_on(scene, hidden, blocked, |k| bsdfs[k].scatters_behind());
    let mut covered = (0..bsdfs.len()).filter(|&k| hidden.covers(k as u32));
    let some = covered.clone().any(delta_hidden);
    (carried, some, some && covered.all(delta_hidden))
}

/// Most laser points an exhaustive capture links to each light subpath: a block of subpaths holds a
/// link per laser point each (4,096 laser points: about 60 MB per block); beyond, the render
/// traces one path per scan point, which holds none.
pub const MAX_LINKED_SPOTS: usize = 4096;

/// The laser points an exhaustive capture links to each light subpath (0 for other captures):
/// one per scan point with equal illumination scanning, else the film's laser grid.
fn laser_points(scene: &Scene, s: &crate::settings::NlosSettings) -> usize {
    let film = &scene.meter.film;
    match (s.capture_type, film.laser_scan) {
        (CaptureType::Exhaustive, _) if s.force_equal_illumination_scanning => {
            film.width * film.height
        }
        (CaptureType::Exhaustive, Some((w, h))) => w.saturating_mul(h),
        _ => 0,
    }
}

/// A vertex of a light subpath: the hidden point, the direction towards the previous vertex (the
/// laser side; zero for the first vertex of a subpath that no single spot lights:
/// [`Self::to_light`]), the throughput up to it without its own BSDF (a single capture's spot
/// radiance included; nor the cosine at it towards the laser side, which that BSDF's value holds),
/// the optical path from it back to the laser (to the first vertex where no single spot lights
/// it), how many hidden vertices the subpath has up to it, whether it may face some scan point,
/// and whether every scan point sees it ([`super::clear_view`]). (112 bytes, the two counts and
/// flags where an `Option`'s tag would be: the Z's single capture connects about one vertex per
/// pixel and light sample, and at 144 bytes it ran about 7 % slower in one A/B run.)
struct LightVertex {
    it: Interaction,
    towards_light: Vec3A,
    weight: Spectrum,
    opl: f64,
    count: u32,
    faces_scan: bool,
    seen_from_scan: bool,
}

impl LightVertex {
    /// The direction towards the laser side, where one spot lights the subpath.
    #[inline(always)]
    fn to_light(&self) -> Option<Vec3A> {
        (self.towards_light != Vec3A::ZERO).then_some(self.towards_light)
    }
}

/// One light subpath: its vertices that connect to scan points (those whose path depth passes
/// `max_depth` and `filter_bounces`), and for confocal and exhaustive captures its first vertex
/// with what the spots need of it.
#[derive(Default)]
pub struct LightPath {
    vertices: Vec<LightVertex>,
    spot_free: Option<SpotFree>,
}

/// The start of a subpath that no single spot lights: its first hidden vertex, the direction on
/// to the second (if any), and for an exhaustive capture the link of every laser spot that lights
/// it, with its film slot.
struct SpotFree {
    first: Interaction,
    out: Option<Vec3A>,
    links: Vec<(usize, SpotLink)>,
}

/// A laser spot lighting the first vertex y₁ of a subpath: the direction y₁ → spot, the radiance
/// the spot sends to y₁ times its geometry term, that times y₁'s BSDF towards the second vertex,
/// and the optical path y₁ → spot → laser.
#[derive(Clone, Copy)]
struct SpotLink {
    to_spot: Vec3A,
    source: Spectrum,
    beyond: Spectrum,
    opl: f64,
}

/// Where the spot of a connection is: in the light vertex's weight (a single capture), linked to
/// the subpath's first vertex by each of the (slot, link) pairs (an exhaustive capture), or by the
/// confocal pixel's own link, whose shadow ray the closure casts once, when first asked; with
/// whether the link's segment is the connection to the first vertex (the spot is the scan point).
enum Spots<'a> {
    InWeight,
    Linked(&'a [(usize, SpotLink)]),
    Confocal(SpotLink, &'a mut dyn FnMut() -> bool, bool),
}

impl NlosTracer<'_> {
    /// Trace one light subpath through the hidden geometry: from the laser spot for a single
    /// capture, from a first hidden vertex for confocal and exhaustive ones. With
    /// `transient_nlos_path_rs` every vertex is an HGRS step (`super::hgrs`): its N candidates and
    /// their shadow rays are paid once for all scan points.
    ///
    /// The subpath is written into `path`, whose storage a block of subpaths keeps from one pass
    /// to the next; `None` (and no vertices) if it reaches nothing to connect.
    pub(super) fn trace_light(&self, rng: &mut Sampler, path: &mut LightPath) -> Option<()> {
        path.vertices.clear();
        let st = self.settings;
        let hg = self.hidden.as_ref()?;
        let area = hg.total_area();
        let step =
            |rng: &mut Sampler, candidate: &mut dyn FnMut(&mut Sampler) -> Option<Step>| match st
                .hgrs
            {
                Some(h) => hgrs::sample(h, rng, candidate),
                None => candidate(rng),
            };
        let single = st.capture_type == CaptureType::Single;
        // ---- The first hidden vertex, its area density 1/A included: the subpath's source. A
        // single capture's spot lights it (connect_spot's terms, from the other end).
        let (first, to_light, opl) = if single {
            let spot = &self.scan.capture.spots[0];
            if spot.radiance == Some(Spectrum::ZERO) || spot.incident == Spectrum::ZERO {
                return None;
            }
            let first = step(rng, &mut |rng| {
                let (y, inv_density) = self.first_hidden_vertex(hg, rng)?;
                let u = spot.it.p - y.p;
                let r2 = u.length_squared();
                let r = r2.sqrt();
                let w = u / r;
                let cos_z = spot.it.ns.dot(-w);
                if cos_z <= 0.0 || !self.sees_spot(&y, &spot.it) {
                    return None;
                }
                Some(Step {
                    next: y,
                    dist: r,
                    weight: self.spot_radiance(spot, w)? * (inv_density * cos_z / r2),
                    eta: 1.0,
                })
            })?;
            let to_light = (spot.it.p - first.next.p).normalize();
            let opl = first.dist as f64 + spot.last_leg;
            (first, Some(to_light), opl)
        } else {
            let (y, inv_density) = self.first_hidden_vertex(hg, rng)?;
            let first = Step {
                next: y,
                dist: 0.0,
                weight: Spectrum::splat(inv_density),
                eta: 1.0,
            };
            (first, None, 0.0)
        };
        let source = first.weight;
        path.spot_free = match (single, path.spot_free.take()) {
            (true, _) => None,
            (false, free) => {
                let mut links = free.map(|f| f.links).unwrap_or_default();
                links.clear();
                Some(SpotFree {
                    first: first.next,
                    out: None,
                    links,
                })
            }
        };
        // Russian roulette reads the throughput after the source, `beta` (without the first
        // vertex's BSDF where that depends on the spot). `eta`: the index of refraction where the
        // subpath is.
        let (mut it, mut beta, mut to_light, mut opl) = (first.next, Spectrum::ONE, to_light, opl);
        let (mut count, mut eta): (u32, f32) = (1, 1.0);
        loop {
            // A path of `count` hidden vertices has depth count + 2 (the per-point tracer's
            // emitter sampling at loop depth `count`). Nothing connects to a surface whose BSDF is
            // all delta; with delta prefixes in the render (`delta_hidden`), a vertex that faces
            // no scan point is kept for theirs.
            let all_delta = self.delta[it.shape as usize].0;
            let faces_scan = self.may_face_scan_points(&it);
            if count.saturating_add(1) < st.max_depth
                && st.keep(count + 2)
                && !all_delta
                && (faces_scan || self.delta_hidden.is_some())
            {
                path.vertices.push(LightVertex {
                    it,
                    towards_light: to_light.unwrap_or(Vec3A::ZERO),
                    weight: beta * source,
                    opl,
                    count,
                    faces_scan,
                    seen_from_scan: self.scan.clear.seen_from_scan_points(&it),
                });
            }
            // ---- The next hidden vertex, on the scan point's side of this one.
            if count.saturating_add(2) >= st.max_depth
                || st.filter_depth.is_some_and(|f| count + 3 > f)
                || self
                    .scan
                    .clear
                    .reaches_no_hidden(&it, self.scatters_behind(&it))
            {
                break;
            }
            let next = match to_light {
                // On glass or a mirror, its BSDF's draw.
                Some(to_light) if all_delta => self.delta_light_step(hg, &it, to_light, rng),
                // Lit from a known side: the mixture with BSDF sampling (the per-point tracer's
                // step beyond its first vertex, from the light's end).
                Some(to_light) if st.hgrs.is_none() => {
                    self.mixture_step(hg, &it, to_light, true, false, rng)
                }
                _ => step(rng, &mut |rng| {
                    let x = hg.sample(self.scene, rng);
                    let e = self.hidden_edge(&x, &it, area)?;
                    let f = match to_light {
                        Some(to_light) => self.bsdf(&it).eval(it.ns, -e.w, to_light)?,
                        None => Spectrum::ONE,
                    };
                    if !self.scene.visible_to(&x, &it) {
                        return None;
                    }
                    Some(Step {
                        next: x,
                        dist: e.r,
                        weight: f * (area * e.cos_y / e.r2),
                        eta: 1.0,
                    })
                }),
            };
            let Some(next) = next else {
                break;
            };
            beta *= next.weight;
            if !russian_roulette(&mut beta, 1.0, count, st.rr_depth, rng) {
                break;
            }
            let back = (it.p - next.next.p).normalize();
            if let Some(free) = path.spot_free.as_mut().filter(|_| count == 1) {
                free.out = Some(-back);
            }
            to_light = Some(back);
            // Light is slower by η inside a refracting medium.
            eta *= next.eta;
            (it, opl, count) = (next.next, opl + (next.dist * eta) as f64, count + 1);
        }
        Some(())
    }

    /// A subpath's first hidden vertex and its inverse area density: from the visibility guide
    /// if there is one, else uniform (density 1/A). `None` on a surface whose BSDF is all delta,
    /// which no spot lights (the per-point tracer connects nothing there).
    #[inline]
    fn first_hidden_vertex(
        &self,
        hg: &AreaSampler,
        rng: &mut Sampler,
    ) -> Option<(Interaction, f32)> {
        let (y, inv_density) = match &self.guide {
            Some(guide) => guide.sample(hg, self.scene, rng),
            None => (hg.sample(self.scene, rng), hg.total_area()),
        };
        (!self.delta[y.shape as usize].0).then_some((y, inv_density))
    }

    /// A light subpath's step from `it`, a vertex on a surface whose BSDF is all delta lit from
    /// `to_light`: its BSDF's draw, kept on the hidden geometry `hg`. Light subpaths carry
    /// importance, whose refraction lacks radiance's (η_t/η_i)⁻² (the adjoint BSDF, Veach 1997
    /// §5.2): the draw's weight times η². A subpath's weight leaves out the cosine at its newest
    /// vertex towards the light (that vertex's BSDF value holds it): the one at `it` is put in
    /// and the one at the next vertex taken out.
    fn delta_light_step(
        &self,
        hg: &AreaSampler,
        it: &Interaction,
        to_light: Vec3A,
        rng: &mut Sampler,
    ) -> Option<Step> {
        let step = self.bsdf_step(it, to_light, rng, None, Some(hg))?;
        let cos_next = step.next.ns.dot(it.p - step.next.p).abs() / step.dist;
        if !(cos_next > COS_EPS) {
            return None;
        }
        let cos_here = it.ns.dot(to_light).abs();
        Some(Step {
            weight: step.weight * (step.eta * step.eta * cos_here / cos_next),
            ..step
        })
    }

    /// An exhaustive capture's laser grid: every spot's link to the subpath's first vertex,
    /// shared by all scan points.
    pub(super) fn link_light(&self, path: &mut LightPath) {
        let Some(free) = path.spot_free.as_mut() else {
            return;
        };
        if self.settings.capture_type != CaptureType::Exhaustive || path.vertices.is_empty() {
            return;
        }
        // One slot per laser point, or all in one when the film has no laser axis.
        let per_spot = self.scene.meter.film.laser_scan.is_some();
        for (j, spot) in self.scan.capture.spots.iter().enumerate() {
            // Thousands of laser points per subpath: stay responsive to cancellation.
            if j % 1024 == 1023 && self.cancel.load(Ordering::Relaxed) {
                break;
            }
            if let Some(link) = self.spot_link(&free.first, free.out, spot, true) {
                free.links.push((if per_spot { j } else { 0 }, link));
            }
        }
    }

    /// Whether the hidden point `y` may face some scan point: false when a blocker hides its
    /// triangle from every scan point ([`super::clear_view`]), or when every corner of the
    /// scan points' bounding box lies behind its shading plane (by more than rounding), for then
    /// so does every scan point, and each connection to it would fail its cosine test (a camera's
    /// jittered first vertices have no such box, and a BSDF that scatters behind its surface faces
    /// both ways: always true).
    #[inline]
    fn may_face_scan_points(&self, y: &Interaction) -> bool {
        if self.scan.clear.hidden_from_scan_points(y) {
            return false;
        }
        self.scatters_behind(y)
            || self.scan.scan_box.is_none_or(|[lo, hi]| {
                (0..8).any(|i| {
                    let c = Vec3A::select(
                        glam::BVec3A::new(i & 1 != 0, i & 2 != 0, i & 4 != 0),
                        hi,
                        lo,
                    );
                    let u = c - y.p;
                    y.ns.dot(u) > -1e-5 * u.length()
                })
            })
    }

    /// Whether laser spot `spot` lights the hidden point `y`: faces it, unoccluded, sends light
    /// its way, and y's BSDF reflects that light.
    pub(super) fn spot_lights(&self, y: &Interaction, spot: &Spot) -> bool {
        let Some(link) = self.spot_link(y, None, spot, true) else {
            return false;
        };
        // Light from the spot's side must be able to leave y on that side (a one-sided BSDF lit
        // from behind sends nothing on).
        let out = if y.ns.dot(link.to_spot) > 0.0 {
            y.ns
        } else {
            -y.ns
        };
        self.bsdf(y)
            .eval(y.ns, link.to_spot, out)
            .is_some_and(|f| f != Spectrum::ZERO)
    }

    /// Laser spot `spot` lighting the first vertex `y` of a subpath that goes on along `out`: the
    /// terms [`Self::connect_spot`] adds at a vertex, but for every spot of the subpath; its shadow
    /// ray only if `test_visibility` (else the caller casts it). Always inlined: its callers
    /// settle `test_visibility`, and called out of line it ran the flat letter's confocal
    /// capture 0.94× as fast.
    #[inline(always)]
    fn spot_link(
        &self,
        y: &Interaction,
        out: Option<Vec3A>,
        spot: &Spot,
        test_visibility: bool,
    ) -> Option<SpotLink> {
        if spot.radiance == Some(Spectrum::ZERO) || spot.incident == Spectrum::ZERO {
            return None;
        }
        let u = spot.it.p - y.p;
        let r2 = u.length_squared();
        let r = r2.sqrt();
        let w = u / r;
        let cos_z = spot.it.ns.dot(-w);
        if cos_z <= 0.0 || (test_visibility && !self.sees_spot(y, &spot.it)) {
            return None;
        }
        let source = self.spot_radiance(spot, w)? * (cos_z / r2);
        let beyond = match out {
            Some(out) => self
                .bsdf(y)
                .eval(y.ns, out, w)
                .map_or(Spectrum::ZERO, |f| f * source),
            None => Spectrum::ZERO,
        };
        Some(SpotLink {
            to_spot: w,
            source,
            beyond,
            opl: r as f64 + spot.last_leg,
        })
    }

    /// A scan point's paths straight to the laser spots: the same at every sample, so traced
    /// once per pixel and block instead of once per sample, for shared renders and one path per
    /// scan point alike. A camera's jittered first vertex is different at each sample: its spot
    /// paths come with [`Self::connect_light`] or the path.
    pub(super) fn fixed_contributions(&self, pixel: usize, out: &mut impl FnMut(Splat)) {
        if self.spot_paths_fixed()
            && let Some(x) = self.scan.scan_vertices[pixel]
            && !self.delta[x.it.shape as usize].0
        {
            self.spot_paths(pixel, &x, out);
        }
    }

    /// Whether a scan point's paths straight to the laser spots take no randomness (no camera
    /// jitters its first vertex, and laser sampling connects it to the spots): then
    /// [`Self::fixed_contributions`] passes them, not each sample.
    #[inline]
    pub(super) fn spot_paths_fixed(&self) -> bool {
        self.camera.is_none() && self.settings.laser_sampling
    }

    /// The paths first vertex `x` of `pixel` → laser spot (depth 2).
    fn spot_paths(&self, pixel: usize, x: &Vertex, out: &mut impl FnMut(Splat)) {
        let st = self.settings;
        if st.max_depth > 1 && st.keep(2) {
            self.emitter_sampling(pixel, x, false, out);
        }
    }

    /// The first vertex of `pixel` for a tile of light samples, and to `out` a camera's jittered
    /// vertex's spot paths (a scan point's are fixed contributions). A camera's vertex is drawn
    /// once per tile from the pixel's own stream `pixel_rng` (a scan point takes no randomness),
    /// so no pixel's result depends on which others share the light samples; each of the tile's
    /// light samples pairs with it, so each pair keeps its distribution (a uniform point of the
    /// pixel, an independent light sample) and the estimate its expectation, for one camera ray
    /// and spot path per tile instead of per sample.
    pub(super) fn pixel_vertex(
        &self,
        pixel: usize,
        pixel_rng: &mut Sampler,
        out: &mut impl FnMut(Splat),
    ) -> Option<Vertex> {
        let x = self.first_vertex(pixel, pixel_rng)?;
        if !self.spot_paths_fixed() {
            self.spot_paths(pixel, &x, out);
        }
        Some(x)
    }

    /// The contributions of one light sample to `pixel` through its first vertex `x`: the
    /// connection of every vertex of `light`, and the sample's delta prefix
    /// ([`Self::delta_prefix`], drawn from the pixel's stream `rng`) where the render has one.
    /// Always inlined, as the connections are: a light subpath often has a single vertex, and a
    /// call per pixel and light sample took a fifth of the Z's single capture.
    #[inline(always)]
    pub(super) fn connect_light(
        &self,
        pixel: usize,
        x: &Vertex,
        light: Option<&LightPath>,
        rng: &mut Sampler,
        out: &mut impl FnMut(Splat),
    ) {
        let light = light.filter(|l| !l.vertices.is_empty());
        if let Some(light) = light {
            self.connect_path::<true>(pixel, x, 0, light, out);
        }
        // The prefix's first hidden vertex is drawn as hidden-geometry sampling draws it
        // (density 1/A over all hidden surfaces) and kept only on the all-delta ones: whether it
        // lands there is chosen first (most draws do not), then the point on them (`bounce`).
        if let Some((_, share)) = &self.delta_hidden
            && rng.next_1d() < *share
        {
            self.delta_prefix(pixel, x, light, rng, out);
        }
    }

    /// The paths of `pixel` whose vertex after its first, `x`, lies on a surface whose BSDF is all
    /// delta (glass, a mirror), which no connection can end at. They are traced from `x` as the
    /// per-point tracer traces them (`NlosTracer::bounce`: hidden-geometry sampling's first draw,
    /// kept only on such a surface, then its BSDF's draws), connecting each later vertex y whose
    /// BSDF is not all delta to the laser spots and to every vertex of `light`, and going on from y
    /// only onto such a surface again. Each path is made once: it is a connection of the light
    /// subpath at its first edge between two vertices whose BSDFs are not all delta, x's own for a
    /// path whose second vertex is not on glass, a prefix's otherwise, and where it has none, a
    /// prefix's connection to the spots (the partition of bidirectional path tracing's
    /// strategies, Veach 1997 §10.2, here one per path). Called once the draw of its first hidden
    /// vertex has chosen those surfaces ([`Self::connect_light`]).
    #[inline(never)]
    fn delta_prefix(
        &self,
        pixel: usize,
        x: &Vertex,
        light: Option<&LightPath>,
        rng: &mut Sampler,
        out: &mut impl FnMut(Splat),
    ) {
        let mut path = NlosPath {
            pixel,
            at: Some(*x),
            depth: 0,
        };
        while self.bounce::<true>(&mut path, rng, out) {
            if let (Some(y), Some(light)) = (&path.at, light)
                && !self.delta[y.it.shape as usize].0
            {
                self.connect_path::<false>(pixel, y, path.depth, light, out);
            }
        }
    }

    /// The connections of the path vertex `x` at loop depth `depth` (`FROM_SCAN`: 0, the pixel's
    /// first vertex) to every vertex of the light subpath `light` within the depth limit.
    #[inline(always)]
    fn connect_path<const FROM_SCAN: bool>(
        &self,
        pixel: usize,
        x: &Vertex,
        depth: u32,
        light: &LightPath,
        out: &mut impl FnMut(Splat),
    ) {
        let st = self.settings;
        let Some(hg) = self.hidden.as_ref() else {
            return;
        };
        let area = hg.total_area();
        let within = |v: &&LightVertex| {
            if FROM_SCAN {
                v.faces_scan
            } else {
                v.count.saturating_add(depth).saturating_add(1) < st.max_depth
            }
        };
        match (&light.spot_free, st.capture_type) {
            (None, _) => {
                for v in light.vertices.iter().filter(within) {
                    self.connect_vertex::<FROM_SCAN>(x, v, area, Spots::InWeight, out);
                }
            }
            (Some(free), CaptureType::Confocal) => {
                // The pixel's own spot. Where it is the scan point itself (`Capture` puts it
                // there; a camera's jittered first vertex moves off it), the spot's link to the
                // first hidden vertex and the scan point's connection to it are one segment, whose
                // shadow ray is cast once, and only if some contribution needs it.
                let spot = &self.scan.capture.spots[pixel];
                let same = spot.it.p == x.it.p;
                let Some(link) = self.spot_link(&free.first, free.out, spot, !same) else {
                    return;
                };
                let mut seen = (!same).then_some(true);
                let mut link_visible =
                    || *seen.get_or_insert_with(|| self.sees_scan_point(&x.it, &free.first));
                for v in light.vertices.iter().filter(within) {
                    let spots = Spots::Confocal(link, &mut link_visible, same);
                    self.connect_vertex::<FROM_SCAN>(x, v, area, spots, out);
                }
            }
            (Some(free), _) => {
                for v in light.vertices.iter().filter(within) {
                    let spots = Spots::Linked(&free.links);
                    self.connect_vertex::<FROM_SCAN>(x, v, area, spots, out);
                }
            }
        }
    }

    /// The contribution of the path through `x` (the scan point if `FROM_SCAN`, else a delta
    /// prefix's vertex) → light subpath ending at `v`: the terms of a step from `x` to `v` (whose
    /// area density is already in `v.weight`; from a scan point, a hidden-geometry step), `v`'s
    /// BSDF between `x` and the laser side, and the subpath's throughput; through each of `links`
    /// (slot, spot) for a subpath that no single spot lights.
    #[inline]
    fn connect_vertex<const FROM_SCAN: bool>(
        &self,
        x: &Vertex,
        v: &LightVertex,
        area: f32,
        spots: Spots,
        out: &mut impl FnMut(Splat),
    ) {
        let edge = if FROM_SCAN {
            self.hidden_edge(&x.it, &v.it, area)
        } else {
            self.facing_edge(&x.it, &v.it, area)
        };
        let Some(e) = edge else {
            return;
        };
        // The shadow ray's segment, made now where a ray may be cast (not to a vertex every scan
        // point sees): its square root and divisions then overlap the BSDF evaluations instead of
        // stalling the ray (mitransient's room with a glass Z, 1.12× in one A/B run).
        let segment = (!(FROM_SCAN && v.seen_from_scan)).then(|| shadow_segment(&x.it, v.it.p));
        let Some(f_x) = self.bsdf(&x.it).eval(x.it.ns, x.wi, e.w) else {
            return;
        };
        // v's BSDF, where its laser side does not depend on the spot.
        let f_v = match v.to_light() {
            Some(to_light) => match self.bsdf(&v.it).eval(v.it.ns, -e.w, to_light) {
                Some(f) => Some(f),
                None => return,
            },
            None => None,
        };
        // (A scan point's connections are to vertices that face some scan point, which no
        // blocker hides from all: `faces_scan`.)
        let sees = || match segment {
            Some(segment) => self.scene.visible_along(&x.it, &v.it, segment),
            None => true,
        };
        let head = x.beta * f_x * (e.cos_y / e.r2);
        let opl = x.opl + (e.r * x.eta) as f64 + v.opl;
        match spots {
            // A single capture: the spot is in v's weight.
            Spots::InWeight => {
                if let Some(f_v) = f_v
                    && sees()
                {
                    out(Splat {
                        slot: 0,
                        opl,
                        value: head * f_v * v.weight,
                    });
                }
            }
            Spots::Linked(links) => {
                if !sees() {
                    return;
                }
                for link in links {
                    if let Some(value) = linked_value(self.bsdf(&v.it), v, &e, head, f_v, &link.1) {
                        out(Splat {
                            slot: link.0,
                            opl: opl + link.1.opl,
                            value,
                        });
                    }
                }
            }
            // Every test that casts no ray first; a first vertex's connection from the spot is
            // the link's segment, so it casts none of its own.
            Spots::Confocal(link, link_visible, on_link) => {
                let Some(value) = linked_value(self.bsdf(&v.it), v, &e, head, f_v, &link) else {
                    return;
                };
                if !link_visible() || ((f_v.is_some() || !on_link) && !sees()) {
                    return;
                }
                out(Splat {
                    slot: 0,
                    opl: opl + link.opl,
                    value,
                });
            }
        }
    }
}

/// The value of a connection through `link` (its first factors `head`): for a deeper vertex, its
/// BSDF `f_v` and the link's `beyond` (the first vertex's BSDF); for the first vertex, its BSDF
/// between the scan point and the spot. `None` where it is zero.
#[inline]
fn linked_value(
    bsdf: &Bsdf<Spectrum>,
    v: &LightVertex,
    e: &HiddenEdge,
    head: Spectrum,
    f_v: Option<Spectrum>,
    link: &SpotLink,
) -> Option<Spectrum> {
    match f_v {
        Some(_) if link.beyond == Spectrum::ZERO => None,
        Some(f_v) => Some(head * f_v * v.weight * link.beyond),
        None => Some(head * bsdf.eval(v.it.ns, -e.w, link.to_spot)? * v.weight * link.source),
    }
}
