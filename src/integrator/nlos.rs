//! `transient_nlos_path`: transient path tracing for NLOS captures with laser sampling and
//! hidden-geometry sampling (Royo et al. 2022, "Non-line-of-sight transient rendering",
//! Computers & Graphics 107; the model is docs/mitransient-model.md §3). With
//! `transient_nlos_path_rs` the hidden-geometry step is Hidden Geometry Rejection Sampling
//! ([`super::hgrs`]).
//!
//! With a camera and hidden-geometry sampling off, small scenes are traced eight paths at a time
//! in lockstep lanes instead ([`super::path_packet`]).
//!
//! Where mitransient 1.3.1 is wrong (mitransient-model §5) this integrator is physically right
//! instead: hidden-geometry sampling tests visibility, the 50/50 technique choice does not double
//! the estimate, and the capture's time origin ignores the shutter. See docs/compatibility.md.

use super::clear_view::ClearView;
use super::path_packet::PathPacket;
use super::scan_cone::{ScanCone, pixel_footprints, scan_cones};
use super::visibility_guide::Guide;
use super::{Splat, Step, Tracer, Vertex, hgrs, russian_roulette};
use crate::bsdf::Bsdf;
use crate::capture::{Capture, Spot};
use crate::emitter::Projector;
use crate::error::{NlosError, Result};
use crate::geometry::{Interaction, Prim};
use crate::math::{COS_EPS, Spectrum};
use crate::parallel::map_indices;
use crate::sampling::{Sampler, unit};
use crate::scene::{AreaSampler, Scene};
use crate::sensor::Camera;
use crate::settings::{CaptureType, NlosSettings};
use glam::{Vec2, Vec3A};
use std::ops::Range;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// What a pixel's paths draw first, where that draw alone may end them before anything else is
/// done ([`Tracer::turned_down`]).
#[derive(Clone, Copy, Debug, PartialEq)]
enum FirstDraw {
    /// Nothing judged: every sample begins its path.
    Traced,
    /// The first direction, by the BSDF about the pixel's cone, which turns down directions that
    /// meet nothing ([`NlosTracer::bare_first_vertex`]).
    Cone,
    /// The first hidden vertex, drawn over the hidden geometry from the scan point (or the camera
    /// pixel's footprint), which ends the path where it surely faces away from there
    /// ([`AreaSampler::faces_away`]; [`NlosTracer::hidden_first`]).
    Hidden,
}

/// The edge x → y between two surface points, as a hidden-geometry step (y drawn uniformly over an
/// area A) sees it: its length r, r², unit direction w and the cosine at y, if x faces y and y
/// faces x (mitransient-model §3.3). "Faces" is one-sided (x's geometric normal towards y, y's
/// shading normal towards x) unless that end's BSDF scatters light on the back of its surface
/// ([`Bsdf::scatters_behind`]: `twosided`, glass): then either side, with |cos| in the density.
/// mitransient keeps the one-sided test for every BSDF and loses what lies behind two-sided
/// surfaces (docs/compatibility.md).
pub(super) struct HiddenEdge {
    /// Length.
    pub(super) r: f32,
    /// Squared length.
    pub(super) r2: f32,
    /// Unit direction from x to y.
    pub(super) w: Vec3A,
    /// |Cosine| at y (its shading normal and x).
    pub(super) cos_y: f32,
    /// Whether hidden-geometry sampling takes the step: its area density converts to a solid-angle
    /// one (r² / (A·cos_y) is not vanishing, as in mitransient).
    pub(super) drawable: bool,
}

impl HiddenEdge {
    /// `behind`: whether x's and y's BSDFs scatter behind their surfaces.
    #[inline]
    pub(super) fn new(
        x: &Interaction,
        y: &Interaction,
        area: f32,
        behind: (bool, bool),
    ) -> Option<Self> {
        let v = y.p - x.p;
        let r2 = v.length_squared();
        let r = r2.sqrt();
        let w = v / r;
        let facing = |cos: f32, either_side: bool| if either_side { cos.abs() } else { cos };
        let cos_x = facing(x.ng.dot(w), behind.0);
        let cos_y = facing(y.ns.dot(-w), behind.1);
        if cos_x <= COS_EPS || cos_y <= COS_EPS {
            return None;
        }
        Some(Self {
            r,
            r2,
            w,
            cos_y,
            drawable: r2 / (area * cos_y) > COS_EPS,
        })
    }
}

/// The path vertex at `it`, seen from the sensor at `sensor`: the direction back to it, and the
/// first leg if it is accounted for.
fn sensor_vertex(settings: &NlosSettings, it: Interaction, sensor: Vec3A) -> Vertex {
    Vertex {
        it,
        wi: (sensor - it.p).normalize(),
        beta: Spectrum::ONE,
        eta: 1.0,
        opl: if settings.account_first_and_last_bounces {
            (sensor - it.p).length() as f64
        } else {
            0.0
        },
    }
}

/// What a render prepares from the scene and its variant alone before tracing: the capture and,
/// per pixel, where its paths leave from and by which directions. A render of every pixel makes
/// it once per scene and variant, and later renders take it from the scene
/// ([`crate::scene::Prepared`]): for tal's bunny (16,384 scan points) it took 5-6 ms of every
/// render on two threads.
pub(super) struct ScanSetup {
    /// Scan points and laser spots.
    pub(super) capture: Capture,
    /// Each scan point as a path's first vertex (without a camera).
    pub(super) scan_vertices: Vec<Option<Vertex>>,
    /// Where each pixel's paths leave from: the scan point, or the camera pixel's footprint
    /// ([`super::scan_cone::Footprints::points`]).
    points: Vec<Option<(Interaction, Vec3A, f32)>>,
    /// Per scan point or camera pixel, the directions a path leaving it may meet something by
    /// (`None` where it has no cone).
    scan_cones: Vec<Option<ScanCone>>,
    /// Per camera pixel, the one small shape its rays can meet, if only one.
    sole_shapes: Vec<Option<u32>>,
    /// Per pixel, whether each of its paths' first vertices is its point's shape within the
    /// cone's reach, whatever the samples draw.
    covered: Vec<bool>,
    /// The scan points' bounding box (without a camera).
    pub(super) scan_box: Option<[Vec3A; 2]>,
    /// The triangles the scan points and laser spots see whole, and the sides of each with no
    /// hidden geometry beyond.
    pub(super) clear: ClearView,
}

impl ScanSetup {
    /// Prepare the pixels `pixels` (the others get no cone and no footprint).
    fn new(
        scene: &Scene,
        bsdfs: &[Bsdf<Spectrum>],
        mono: bool,
        cancel: &AtomicBool,
        pixels: Range<usize>,
    ) -> Result<Self> {
        let nlos = scene.nlos()?;
        let settings = &nlos.settings;
        let capture = Capture::new(scene, mono, cancel)?;
        let scan_vertices: Vec<Option<Vertex>> = match nlos.camera {
            Some(_) => Vec::new(),
            None => map_indices(capture.scan_points.len(), |i| {
                capture.scan_points[i].map(|it| sensor_vertex(settings, it, scene.meter.origin))
            }),
        };
        let (points, sole_shapes, covered) = match &nlos.camera {
            Some(camera) => {
                let f = pixel_footprints(scene, camera, cancel, pixels.clone());
                (f.points, f.sole_shapes, f.covered)
            }
            None => (
                scan_vertices
                    .iter()
                    .map(|v| v.map(|v| (v.it, v.wi, 0.0)))
                    .collect(),
                Vec::new(),
                // A scan point is its path's first vertex, whatever the samples draw.
                vec![true; scan_vertices.len()],
            ),
        };
        // (The footprints stop early, empty, once the render is cancelled: nothing is kept.)
        if cancel.load(Ordering::Relaxed) {
            return Err(NlosError::Interrupted);
        }
        let hidden = scene.sampled_hidden_geometry();
        let clear = ClearView::new(
            scene,
            scan_vertices.iter().flatten().map(|v| &v.it),
            capture.spots.iter().map(|s| &s.it),
            hidden,
        );
        Ok(Self {
            clear,
            scan_cones: scan_cones(scene, bsdfs, &points, pixels),
            scan_box: match nlos.camera {
                Some(_) => None,
                None => capture.scan_points.iter().flatten().fold(None, |b, it| {
                    let [lo, hi] = b.unwrap_or([it.p, it.p]);
                    Some([lo.min(it.p), hi.max(it.p)])
                }),
            },
            capture,
            scan_vertices,
            points,
            sole_shapes,
            covered,
        })
    }
}

/// A prepared `transient_nlos_path(_rs)` render.
pub struct NlosTracer<'a> {
    pub(super) scene: &'a Scene,
    pub(super) settings: &'a NlosSettings,
    laser: &'a Projector,
    /// Each shape's BSDF.
    bsdfs: Vec<Bsdf<Spectrum>>,
    /// Per shape: (every BSDF component is a delta, some component is), computed once.
    pub(super) delta: Vec<(bool, bool)>,
    /// Per shape: whether its BSDF scatters light on the back of the surface.
    behind: Vec<bool>,
    /// Per shape: whether it is a flat sheet ([`Scene::is_flat`]), which cannot light itself.
    flat: Vec<bool>,
    /// Every vertex after a path's first must lie on hidden geometry whose every BSDF is a delta
    /// (hidden-geometry sampling in force at every depth, without the technique roulette), where
    /// nothing is connected: no path adds anything past its first vertex, and each ends there.
    first_only: bool,
    /// Laser irradiance (× scale).
    irradiance: Spectrum,
    /// The scan points, laser spots and cones.
    pub(super) scan: Arc<ScanSetup>,
    /// Per pixel, what judges a path's first draw before anything else is done
    /// ([`Tracer::turned_down`]).
    first_draw: Vec<FirstDraw>,
    /// A perspective camera as the sensor, instead of the scan points.
    pub(super) camera: Option<&'a Camera>,
    /// Set by the caller to stop the render.
    pub(super) cancel: &'a AtomicBool,
    /// Hidden-geometry distribution, if that sampling is on.
    pub(super) hidden: Option<&'a AreaSampler>,
    /// The distribution of a shared light subpath's first hidden vertex, if guided.
    pub(super) guide: Option<Guide>,
    /// In a render that shares light subpaths, the hidden surfaces whose BSDF is all delta
    /// (glass, mirrors) and their share of the hidden area, if any: the paths whose vertex after
    /// the first lies there are traced from each pixel (`sample_reuse::delta_prefix`).
    pub(super) delta_hidden: Option<(AreaSampler, f32)>,
    /// The render in lockstep lanes, where the scene allows ([`PathPacket::nlos`]).
    packet: Option<PathPacket<'a>>,
}

impl<'a> NlosTracer<'a> {
    /// Prepare a render of `scene` in mono or rgb; `cancel` stops the preparation and long
    /// per-sample loops (an exhaustive capture's laser points) early. `shared_spp`: the render
    /// shares this many light subpaths among its scan points (it then learns their guide).
    /// `pixels`: the pixels the render traces (a part's): what each pixel alone needs (its cone,
    /// a camera pixel's footprint) is made for these only. `lockstep`: the render may trace in
    /// lockstep lanes (it keeps no per-sample values and draws independent numbers).
    pub fn new(
        scene: &'a Scene,
        mono: bool,
        cancel: &'a AtomicBool,
        shared_spp: Option<u64>,
        pixels: Range<usize>,
        lockstep: bool,
    ) -> Result<Self> {
        let nlos = scene.nlos()?;
        let settings = &nlos.settings;
        let hidden = scene.sampled_hidden_geometry();
        if settings.hidden_geometry_sampling && hidden.is_none() {
            return Err(NlosError::prop(
                "transient_nlos_path",
                "nlos_hidden_geometry_sampling",
                "the scene has no hidden geometry to sample (zero total area)",
            ));
        }
        let bsdfs = scene.shape_bsdfs(mono);
        let film = &scene.meter.film;
        let scan = if pixels == (0..film.width * film.height) {
            scene
                .prepared
                .get_or_make(mono, || ScanSetup::new(scene, &bsdfs, mono, cancel, pixels))?
        } else {
            Arc::new(ScanSetup::new(scene, &bsdfs, mono, cancel, pixels)?)
        };
        let mut tracer = Self {
            scan,
            first_draw: Vec::new(),
            scene,
            settings,
            laser: &nlos.laser,
            delta: bsdfs
                .iter()
                .map(|b| (b.is_delta(), b.has_delta()))
                .collect(),
            behind: bsdfs.iter().map(Bsdf::scatters_behind).collect(),
            flat: (0..scene.shapes.len()).map(|s| scene.is_flat(s)).collect(),
            first_only: hidden.is_some_and(|hg| {
                !settings.hgs_rroulette
                    && settings.hgs_max_depth.is_none()
                    && (0..bsdfs.len())
                        .filter(|&s| hg.covers(s as u32))
                        .all(|s| bsdfs[s].is_delta())
            }),
            bsdfs,
            irradiance: nlos.laser.irradiance.spectrum(mono),
            camera: nlos.camera.as_ref(),
            cancel,
            hidden,
            guide: None,
            delta_hidden: None,
            packet: None,
        };
        if let (Some(_), Some(hg)) = (shared_spp, hidden) {
            tracer.delta_hidden =
                AreaSampler::new(scene, |s| hg.covers(s as u32) && tracer.delta[s].0).map(|dh| {
                    let share = dh.total_area() / hg.total_area();
                    (dh, share)
                });
        }
        if lockstep {
            tracer.packet = PathPacket::nlos(scene, nlos, &tracer.scan.capture, mono);
        }
        let judged = hidden.is_some_and(AreaSampler::judges_facing);
        // Per shape a first vertex may lie on (its tests run over every laser spot: once per
        // shape, not per pixel).
        let bare: Vec<bool> = (0..scene.shapes.len())
            .map(|s| tracer.bare_first_bounce(s))
            .collect();
        let scan = &tracer.scan;
        tracer.first_draw = scan
            .covered
            .iter()
            .zip(&scan.points)
            .enumerate()
            .map(|(pixel, (&covered, point))| match point {
                Some((x, _, _)) if !bare[x.shape as usize] => FirstDraw::Traced,
                Some((x, wi, _)) if covered && tracer.bare_first_vertex(pixel, x, *wi) => {
                    FirstDraw::Cone
                }
                Some((x, _, _)) if judged && tracer.hidden_first(pixel, x) => FirstDraw::Hidden,
                _ => FirstDraw::Traced,
            })
            .collect();
        // The guide's pilot: a quarter of the render's light subpaths, 256 to 4,096 points.
        if let (Some(spp), Some(hg)) = (shared_spp, hidden)
            && settings.visibility_guiding
            && settings.hgrs.is_none()
        {
            tracer.guide = Guide::learn(&tracer, hg, (spp / 4).clamp(256, 4096) as usize);
        }
        Ok(tracer)
    }

    #[inline]
    pub(super) fn bsdf(&self, x: &Interaction) -> &Bsdf<Spectrum> {
        &self.bsdfs[x.shape as usize]
    }

    /// Whether `x`'s BSDF scatters light on the back of its surface.
    #[inline]
    pub(super) fn scatters_behind(&self, x: &Interaction) -> bool {
        self.behind[x.shape as usize]
    }

    /// The edge x → y over the hidden area `area`, each end facing the other on a side its BSDF
    /// scatters on.
    #[inline]
    pub(super) fn facing_edge(
        &self,
        x: &Interaction,
        y: &Interaction,
        area: f32,
    ) -> Option<HiddenEdge> {
        HiddenEdge::new(
            x,
            y,
            area,
            (self.scatters_behind(x), self.scatters_behind(y)),
        )
    }

    /// The edge x → y if hidden-geometry sampling takes it ([`Self::facing_edge`], drawable).
    #[inline]
    pub(super) fn hidden_edge(
        &self,
        x: &Interaction,
        y: &Interaction,
        area: f32,
    ) -> Option<HiddenEdge> {
        self.facing_edge(x, y, area).filter(|e| e.drawable)
    }

    /// Laser sampling (mitransient-model §3.4): connect the path vertex `v` to the laser spot,
    /// whose NEE is cached in `spot`; `clear`: the segment between them is known to be unoccluded.
    #[inline]
    pub(super) fn connect_spot(
        &self,
        v: &Vertex,
        spot: &Spot,
        slot: usize,
        clear: bool,
        out: &mut impl FnMut(Splat),
    ) {
        let (x, wi, beta, opl, eta) = (&v.it, v.wi, v.beta, v.opl, v.eta);
        if spot.radiance == Some(Spectrum::ZERO) || spot.incident == Spectrum::ZERO {
            return;
        }
        // A vertex on the spot's own flat wall: the connection grazes both ends (cosines of zero,
        // which rounding would make a few 1e-8 either way).
        if self.flat[x.shape as usize] && x.shape == spot.it.shape {
            return;
        }
        let u = spot.it.p - x.p;
        let r2 = u.length_squared();
        let r = r2.sqrt();
        let w = u / r;
        let cos_z = spot.it.ns.dot(-w);
        // Not above the spot, or at the spot itself (a confocal scan point: r = 0, w undefined).
        if !(cos_z > 0.0) {
            return;
        }
        let Some(f) = self.bsdf(x).eval(x.ns, wi, w) else {
            return;
        };
        if !clear && !self.sees_spot(x, &spot.it) {
            return;
        }
        let Some(radiance) = self.spot_radiance(spot, w) else {
            return;
        };
        out(Splat {
            slot,
            opl: opl + (r * eta) as f64 + spot.last_leg,
            value: beta * f * radiance * (cos_z / r2),
        });
    }

    /// The radiance the laser spot sends along −`w` (towards a vertex that sees it along `w`): a
    /// glossy spot reflects the laser by its BSDF (mitransient-model §3.5).
    #[inline]
    pub(super) fn spot_radiance(&self, spot: &Spot, w: Vec3A) -> Option<Spectrum> {
        match spot.radiance {
            Some(r) => Some(r),
            None => self
                .bsdf(&spot.it)
                .eval(spot.it.ns, -w, spot.to_laser)
                .map(|f_spot| spot.incident * f_spot),
        }
    }

    /// Next-event estimation straight to the projector (mitransient-model §3.5), used without
    /// laser sampling.
    #[inline]
    fn nee_laser(&self, v: &Vertex, out: &mut impl FnMut(Splat)) {
        let (x, wi, beta, opl, eta) = (&v.it, v.wi, v.beta, v.opl, v.eta);
        let weight = self.laser.weight_at(x.p);
        if weight == 0.0 {
            return;
        }
        let u = self.laser.origin - x.p;
        let r = u.length();
        let Some(f) = self.bsdf(x).eval(x.ns, wi, u / r) else {
            return;
        };
        if !self.scene.visible(x, self.laser.origin) {
            return;
        }
        let last = if self.settings.account_first_and_last_bounces {
            (r * eta) as f64
        } else {
            0.0
        };
        out(Splat {
            slot: 0,
            opl: opl + last,
            value: beta * f * self.irradiance * weight,
        });
    }

    /// Whether the point `y` and the laser spot `spot` see each other: no shadow ray where every
    /// spot sees `y`'s triangle whole, or none sees any of it ([`ClearView`]).
    #[inline(always)]
    pub(super) fn sees_spot(&self, y: &Interaction, spot: &Interaction) -> bool {
        let clear = &self.scan.clear;
        !clear.hidden_from_spots(y) && (clear.seen_from_spots(y) || self.scene.visible_to(y, spot))
    }

    /// Whether the scan point `x` and the point `y` see each other: no shadow ray where every scan
    /// point sees `y`'s triangle whole, or none sees any of it ([`ClearView`]).
    #[inline(always)]
    pub(super) fn sees_scan_point(&self, x: &Interaction, y: &Interaction) -> bool {
        let clear = &self.scan.clear;
        !clear.hidden_from_scan_points(y)
            && (clear.seen_from_scan_points(y) || self.scene.visible_to(x, y))
    }

    /// The step from `x` to `y`, a hidden-geometry draw (mitransient-model §3.3; density 1/A over
    /// `hg`), with the visibility test mitransient lacks: an invalid or occluded draw is a
    /// zero-valued sample of the area integral. The weight is f·A_total·cosθ_y/r².
    #[inline]
    fn hidden_candidate(
        &self,
        hg: &AreaSampler,
        y: Interaction,
        x: &Interaction,
        wi: Vec3A,
        from_scan_point: bool,
    ) -> Option<Step> {
        let e = self.hidden_edge(x, &y, hg.total_area())?;
        let f = self.bsdf(x).eval(x.ns, wi, e.w)?;
        let visible = if from_scan_point {
            self.sees_scan_point(x, &y)
        } else {
            self.scene.visible_to(x, &y)
        };
        if !visible {
            return None;
        }
        Some(Step {
            next: y,
            dist: e.r,
            weight: f * (hg.total_area() * e.cos_y / e.r2),
            eta: 1.0,
        })
    }

    /// BSDF sampling from `x`: the next vertex is what the sampled direction hits. From a scan
    /// point with a cone, a direction outside it ends the step untraced (it would meet nothing).
    /// With `keep` the step ends unless its hit lies on that hidden geometry, untraced where the
    /// direction surely misses it.
    #[inline(always)]
    pub(super) fn bsdf_step(
        &self,
        x: &Interaction,
        wi: Vec3A,
        rng: &mut Sampler,
        cone: Option<&ScanCone>,
        keep: Option<&AreaSampler>,
    ) -> Option<Step> {
        let hidden_only = keep.is_some();
        let s = match cone {
            Some(c) => {
                // The cone holds for directions drawn about its own normal.
                let mut about_cone = false;
                let s = self.bsdf(x).sample_where(x.ns, wi, rng, |n, u| {
                    about_cone = c.drawn_about(n);
                    !about_cone || c.may_reach_square(u)
                })?;
                if about_cone && !c.may_reach(s.wo) {
                    return None;
                }
                s
            }
            // Before its warp, where the square sample already tells.
            None if hidden_only => self.bsdf(x).sample_where(x.ns, wi, rng, |n, u| {
                !self.scan.clear.misses_hidden_about(x, n, u)
            })?,
            None => self.bsdf(x).sample(x.ns, wi, rng)?,
        };
        if hidden_only && self.scan.clear.misses_hidden(x, s.wo) {
            return None;
        }
        let (_, hit) = self
            .scene
            .intersect(x.offset_origin(s.wo), s.wo, f32::INFINITY)?;
        if keep.is_some_and(|hg| !hg.covers(hit.shape)) {
            return None;
        }
        Some(Step {
            next: hit,
            dist: (hit.p - x.p).length(),
            weight: s.weight,
            eta: s.eta,
        })
    }

    /// The path's first vertex x₁ for pixel `pixel`, the direction back to the sensor and the
    /// optical path so far: the scan point seen from the sensor origin (prepared once), or with a
    /// camera the surface its jittered ray hits (the first leg measured from the pinhole).
    #[inline]
    pub(super) fn first_vertex(&self, pixel: usize, rng: &mut Sampler) -> Option<Vertex> {
        match self.camera {
            None => self.scan.scan_vertices[pixel],
            Some(camera) => self.camera_vertex(camera, pixel, rng),
        }
    }

    /// Whether a pixel's paths need their first vertex only for their next direction: a scan
    /// point, or a camera pixel whose every ray meets one flat sheet (of which `x` is the
    /// central ray's point, `wi` the direction back from it). The first bounce connects nothing
    /// (the laser spots lie on that sheet, or no such connection is kept, or the fixed
    /// contributions pass it: [`Self::bare_first_bounce`], which the caller has checked), samples
    /// that direction from the BSDF about the normal of the pixel's cone wherever the vertex
    /// lies, and draws nothing before it.
    fn bare_first_vertex(&self, pixel: usize, x: &Interaction, wi: Vec3A) -> bool {
        let shape = x.shape as usize;
        let some_delta = self.delta[shape].1;
        let Some(cone) = self.scan.scan_cones[pixel].as_ref() else {
            return false;
        };
        let about_cone = |n: Vec3A| {
            self.bsdfs[shape]
                .diffuse_normal(n, wi)
                .is_some_and(|n| n.dot(wi) > 0.0 && cone.drawn_about(n))
        };
        let drawn_about_cone = match self.camera {
            // A scan point is the vertex itself.
            None => cone.holds_at(x) && about_cone(x.ns),
            // A camera ray meets any of the sheet's triangles.
            Some(_) => {
                let flip = self.scene.normal_sign(shape);
                self.scene.prims[self.scene.shapes[shape].prims.clone()]
                    .iter()
                    .all(|p| match p {
                        Prim::Triangle { n, .. } => about_cone(*n * flip),
                        _ => false,
                    })
            }
        };
        drawn_about_cone && self.hidden_technique(0, some_delta).is_none()
    }

    /// Whether a pixel's paths draw their first hidden vertex before anything else (with a
    /// camera, after the jitter of a ray that surely meets the pixel's footprint on one flat
    /// sheet), by plain hidden-geometry sampling (no HGRS candidates, no technique roulette) from
    /// a first bounce that connects nothing ([`Self::bare_first_bounce`], which the caller has
    /// checked) and whose path goes on to that draw, on whichever of the sheet's triangles it
    /// lies.
    fn hidden_first(&self, pixel: usize, x: &Interaction) -> bool {
        let st = self.settings;
        let behind = self.scatters_behind(x);
        let goes_on = |prim: usize| {
            let it = Interaction {
                prim: prim as u32,
                ..*x
            };
            !self.scan.clear.reaches_no_hidden(&it, behind)
        };
        let goes_on = match self.camera {
            None => goes_on(x.prim as usize),
            Some(_) => {
                self.scan.covered[pixel]
                    && self.scene.shapes[x.shape as usize]
                        .prims
                        .clone()
                        .all(goes_on)
            }
        };
        goes_on
            && self
                .hidden_technique(0, self.delta[x.shape as usize].1)
                .is_some()
            && st.hgrs.is_none()
            && !st.hgs_rroulette
    }

    /// `bounce`'s own tests at loop depth 0 for a first vertex on shape `shape`: it connects
    /// nothing (a connection between points of one flat sheet carries nothing) and its path
    /// neither ends before connecting nor after.
    fn bare_first_bounce(&self, shape: usize) -> bool {
        let connects_nothing = !self.connects(0, self.delta[shape].0)
            || (self.settings.laser_sampling
                && self.flat[shape]
                && self
                    .scan
                    .capture
                    .spots
                    .iter()
                    .all(|s| s.it.shape as usize == shape));
        connects_nothing && !self.ends_before_connecting(0) && !self.ends_after_connecting(0)
    }

    /// Contribution depth of a vertex at loop depth d: d + 2 with laser sampling (the spot is an
    /// extra vertex), d with NEE (mitransient-model §2, filter_bounces).
    #[inline(always)]
    fn depth_offset(&self) -> u32 {
        if self.settings.laser_sampling { 2 } else { 0 }
    }

    /// Whether a path ends at its vertex of loop depth `depth` before anything is done there: no
    /// later vertex is allowed (max_depth).
    #[inline(always)]
    fn ends_before_connecting(&self, depth: u32) -> bool {
        depth.saturating_add(1) >= self.settings.max_depth
    }

    /// Whether emitter sampling runs at a vertex of loop depth `depth` whose BSDF is all delta
    /// or not: not where filter_bounces drops its depth, not at an all-delta vertex (nothing to
    /// connect to), and not at a fixed scan point, whose connections `fixed_contributions`
    /// passes once.
    #[inline(always)]
    fn connects(&self, depth: u32, all_delta: bool) -> bool {
        self.settings.keep(depth + self.depth_offset())
            && !all_delta
            && !(depth == 0 && self.spot_paths_fixed())
    }

    /// Whether a path ends after its vertex of loop depth `depth` is connected: no later vertex
    /// can pass filter_bounces, or none connects anything ([`Self::first_only`]); stopping
    /// changes no result.
    #[inline(always)]
    fn ends_after_connecting(&self, depth: u32) -> bool {
        self.first_only
            || self
                .settings
                .filter_depth
                .is_some_and(|f| depth + 1 + self.depth_offset() > f)
    }

    /// The hidden geometry the next vertex at loop depth `depth` must lie on: with
    /// hidden-geometry sampling on, up to `hgs_max_depth`; `None` beyond (or with it off), where
    /// BSDF sampling keeps whatever its ray hits.
    #[inline(always)]
    fn hidden_at(&self, depth: u32) -> Option<&AreaSampler> {
        self.hidden
            .filter(|_| self.settings.hgs_max_depth.is_none_or(|m| depth < m))
    }

    /// The hidden geometry that draws the next vertex at loop depth `depth` (plain or HGRS), or
    /// `None` for BSDF sampling: none where some BSDF component is a delta (a draw towards hidden
    /// geometry would miss it) or beyond `hgs_max_depth`.
    #[inline(always)]
    fn hidden_technique(&self, depth: u32, some_delta: bool) -> Option<&AreaSampler> {
        self.hidden_at(depth).filter(|_| !some_delta)
    }

    /// [`Self::first_vertex`] with a camera (out of line: the scan points' case stays small
    /// where it is inlined).
    #[inline(never)]
    fn camera_vertex(&self, camera: &Camera, pixel: usize, rng: &mut Sampler) -> Option<Vertex> {
        let film = &self.scene.meter.film;
        let r = camera.pixel_ray(pixel, film.width, film.height, rng.next_2d());
        let hit = self.scene.camera_hit(&r, self.scan.sole_shapes[pixel])?;
        Some(sensor_vertex(
            self.settings,
            self.scene.interaction(r.o, r.d, &hit),
            r.o,
        ))
    }

    /// Emitter sampling at a vertex: laser sampling to the capture's spot(s), or NEE to the laser.
    /// `from_scan_point`: the vertex is a path's second, reached from its scan point (no camera)
    /// along a segment its step found clear — in a confocal capture that scan point is the spot,
    /// so the connection needs no shadow ray of its own (mitransient traces it again).
    #[inline]
    pub(super) fn emitter_sampling(
        &self,
        pixel: usize,
        v: &Vertex,
        from_scan_point: bool,
        out: &mut impl FnMut(Splat),
    ) {
        if !self.settings.laser_sampling {
            return self.nee_laser(v, out);
        }
        let spots = &self.scan.capture.spots;
        match self.settings.capture_type {
            CaptureType::Single => self.connect_spot(v, &spots[0], 0, false, out),
            CaptureType::Confocal => self.connect_spot(v, &spots[pixel], 0, from_scan_point, out),
            CaptureType::Exhaustive => {
                // One slot per laser point, or all in one when the film has no laser axis.
                let per_spot = self.scene.meter.film.laser_scan.is_some();
                for (slot, spot) in spots.iter().enumerate() {
                    // Thousands of laser points per vertex: stay responsive to cancellation.
                    if slot % 1024 == 1023 && self.cancel.load(Ordering::Relaxed) {
                        return;
                    }
                    self.connect_spot(v, spot, if per_spot { slot } else { 0 }, false, out);
                }
            }
        }
    }
}

/// A `transient_nlos_path` path between bounces: its pixel, the loop depth and, past the first
/// vertex, the vertex it is at.
pub struct NlosPath {
    pub(super) pixel: usize,
    pub(super) at: Option<Vertex>,
    pub(super) depth: u32,
}

impl Tracer for NlosTracer<'_> {
    type Light = super::sample_reuse::LightPath;
    type Path = NlosPath;
    const IN_FLIGHT: usize = 2;

    /// How many samples of `pixel` in a row, at most `max`, end at their first random numbers,
    /// before anything is traced, where the first vertex is needed for nothing else: their cone
    /// turns the path's first direction down (`bare_first_vertex`), or their first
    /// hidden-geometry draw lands on a surface turned away from the pixel's point or footprint
    /// (`hidden_first`). It reads the random numbers each path would draw (with a camera
    /// the jitter, then the BSDF's square sample or the draw's pair) and takes them only if the
    /// path ends.
    #[inline(always)]
    fn turned_down(&self, pixel: usize, rng: &mut Sampler, max: u64) -> u64 {
        if max == 0 {
            return 0;
        }
        match self.first_draw[pixel] {
            FirstDraw::Traced => 0,
            FirstDraw::Cone => {
                let Some(cone) = self.scan.scan_cones[pixel].as_ref() else {
                    return 0;
                };
                let jitter = usize::from(self.camera.is_some());
                rng.turned_down(max, jitter, |x, y| {
                    !cone.may_reach_square(Vec2::new(unit(x), unit(y)))
                })
            }
            FirstDraw::Hidden => {
                // The scan point, or any point of the camera pixel's footprint (after the jitter).
                let (Some(hg), Some((x, _, radius))) = (self.hidden, &self.scan.points[pixel])
                else {
                    return 0;
                };
                let jitter = usize::from(self.camera.is_some());
                rng.turned_down(max, jitter, |u, _| hg.faces_away(u, x.p, *radius))
            }
        }
    }

    /// A path of `pixel`: its first vertex is found by its first bounce (a scan point is read
    /// where it is kept, not copied).
    #[inline]
    fn begin(&self, pixel: usize, _rng: &mut Sampler) -> NlosPath {
        NlosPath {
            pixel,
            at: None,
            depth: 0,
        }
    }

    #[inline]
    fn bounce(&self, path: &mut NlosPath, rng: &mut Sampler, out: &mut impl FnMut(Splat)) -> bool {
        NlosTracer::bounce::<false>(self, path, rng, out)
    }

    fn packet(&self) -> Option<&PathPacket<'_>> {
        self.packet.as_ref()
    }

    fn first_cone(&self, pixel: usize) -> Option<&ScanCone> {
        match self.first_draw[pixel] {
            FirstDraw::Cone => self.scan.scan_cones[pixel].as_ref(),
            _ => None,
        }
    }

    fn trace_light(&self, rng: &mut Sampler, light: &mut Option<Self::Light>) {
        let path = light.get_or_insert_with(Default::default);
        // (A subpath that reaches nothing keeps no vertices, which connect to nothing.)
        let _ = NlosTracer::trace_light(self, rng, path);
    }

    fn link_light(&self, light: &mut Self::Light) {
        NlosTracer::link_light(self, light)
    }

    fn fixed_contributions(&self, pixel: usize, out: &mut impl FnMut(Splat)) {
        NlosTracer::fixed_contributions(self, pixel, out)
    }

    fn pixel_vertex(
        &self,
        pixel: usize,
        pixel_rng: &mut Sampler,
        out: &mut impl FnMut(Splat),
    ) -> Option<Vertex> {
        NlosTracer::pixel_vertex(self, pixel, pixel_rng, out)
    }

    fn connect_light(
        &self,
        pixel: usize,
        x: &Vertex,
        light: Option<&Self::Light>,
        rng: &mut Sampler,
        out: &mut impl FnMut(Splat),
    ) {
        NlosTracer::connect_light(self, pixel, x, light, rng, out)
    }
}

impl NlosTracer<'_> {
    /// One bounce of a path (mitransient-model §3.2–3.3): emitter sampling at its vertex, then the
    /// next vertex; false once the path has ended. With `DELTA_PREFIX` the path is one of a
    /// shared render's delta prefixes (`sample_reuse::delta_prefix`): it starts at its given first
    /// vertex, whose connections the pixel has made, and goes on only onto surfaces whose BSDF is
    /// all delta from vertices whose BSDF is not (a step between two such vertices is a light
    /// subpath's connection).
    #[inline]
    pub(super) fn bounce<const DELTA_PREFIX: bool>(
        &self,
        path: &mut NlosPath,
        rng: &mut Sampler,
        out: &mut impl FnMut(Splat),
    ) -> bool {
        let st = self.settings;
        let (pixel, depth) = (path.pixel, path.depth);
        let first;
        let v = match (depth, self.camera) {
            _ if DELTA_PREFIX => path.at.as_ref(),
            (0, None) => self.scan.scan_vertices[pixel].as_ref(),
            (0, Some(camera)) => {
                first = self.camera_vertex(camera, pixel, rng);
                first.as_ref()
            }
            _ => path.at.as_ref(),
        };
        let Some(v) = v else {
            return false;
        };
        if self.ends_before_connecting(depth) {
            return false;
        }
        // A delta (mirror-like) BSDF cannot be connected to: no emitter sampling at an
        // all-delta vertex, and where some component is delta the path goes on by sampling the
        // BSDF rather than towards hidden geometry (which would miss that component).
        let (all_delta, some_delta) = self.delta[v.it.shape as usize];
        // ---- Emitter sampling
        if self.connects(depth, all_delta) && !(DELTA_PREFIX && depth == 0) {
            self.emitter_sampling(pixel, v, depth == 1 && self.camera.is_none(), out);
        }
        if self.ends_after_connecting(depth) {
            return false;
        }
        // ---- A vertex whose next one must lie on hidden geometry (hidden-geometry sampling in
        // force, without the technique roulette's BSDF draws that keep any hit) ends here, before
        // any draw, where none lies beyond the sides its BSDF leaves by.
        if self.hidden_at(depth).is_some()
            && !st.hgs_rroulette
            && self
                .scan
                .clear
                .reaches_no_hidden(&v.it, self.scatters_behind(&v.it))
        {
            return false;
        }
        // ---- Direction sampling: hidden geometry (plain or HGRS) or the BSDF. Where some BSDF
        // component is a delta, a draw towards hidden geometry would miss it: the BSDF draws
        // instead and keeps its hit only on the hidden geometry in force (`keep_hidden`), so that
        // every vertex after the first lies there whatever the BSDF, as hidden-geometry sampling
        // defines the integral (mitransient-model §3.3). (The technique roulette's BSDF draws
        // keep any hit, as mitransient's do.)
        let mut hidden = self.hidden_technique(depth, some_delta);
        let keep_hidden = self.hidden_at(depth).filter(|_| some_delta);
        if hidden.is_some() && st.hgs_rroulette {
            // One of the two techniques at random; each is unbiased on its own, so the
            // mixture is too (mitransient also divides by 1/2 here and doubles the result).
            hidden = hidden.filter(|_| rng.next_1d() < 0.5);
        }
        // A scan point's shadow rays to the triangles it sees whole are answered without tracing.
        let from_scan_point = depth == 0 && self.camera.is_none();
        let step = match (hidden, st.hgrs) {
            (Some(hg), Some(h)) => hgrs::sample(h, rng, |rng| {
                let y = hg.sample(self.scene, rng);
                self.hidden_candidate(hg, y, &v.it, v.wi, from_scan_point)
            }),
            // Beyond the first vertex (on the relay wall, whence the hidden scene is far and
            // small) the mixture with BSDF sampling, unless the technique roulette chose.
            (Some(hg), None) if depth > 0 && !st.hgs_rroulette => {
                self.mixture_step(hg, &v.it, v.wi, false, DELTA_PREFIX, rng)
            }
            // (The prefix has chosen to draw on the all-delta surfaces.)
            (Some(hg), None) if DELTA_PREFIX => self.delta_hidden.as_ref().and_then(|(dh, _)| {
                let y = dh.sample(self.scene, rng);
                self.hidden_candidate(hg, y, &v.it, v.wi, from_scan_point)
            }),
            (Some(hg), None) => {
                let y = hg.sample(self.scene, rng);
                self.hidden_candidate(hg, y, &v.it, v.wi, from_scan_point)
            }
            (None, _) => {
                let cone = if depth == 0 {
                    self.scan
                        .scan_cones
                        .get(pixel)
                        .and_then(Option::as_ref)
                        .filter(|c| c.holds_at(&v.it))
                } else {
                    None
                };
                self.bsdf_step(&v.it, v.wi, rng, cone, keep_hidden)
            }
        };
        let Some(step) = step else { return false };
        let mut beta = v.beta * step.weight;
        let eta = v.eta * step.eta;
        // ---- Russian roulette (mitransient-model §3.3 step 4)
        if !russian_roulette(&mut beta, eta, depth, st.rr_depth, rng) {
            return false;
        }
        path.at = Some(Vertex {
            wi: (v.it.p - step.next.p).normalize(),
            beta,
            // Light is slower by η inside a refracting medium.
            opl: v.opl + (step.dist * eta) as f64,
            eta,
            it: step.next,
        });
        path.depth += 1;
        true
    }
}
