//! A loaded scene: shapes and their primitives, BSDFs, the BVH, the sensor's [`Meter`] and what
//! the scene measures ([`Setup`]: an NLOS capture as mitransient describes it, mitransient-model §1,
//! or a line-of-sight camera). Built from a [`crate::props::Props`] tree in [`build`]; uniform
//! sampling of its surfaces is [`AreaSampler`].

pub mod area_sampler;
mod build;

pub use area_sampler::AreaSampler;

use crate::bsdf::Bsdf;
use crate::emitter::{Light, Projector};
use crate::error::{NlosError, Result};
use crate::geometry::{
    Hit, Interaction, Prim, Ray,
    bvh::{Accel, NO_PLANE, intersect_brute},
    shadow_segment,
};
use crate::math::{Spectrum, Transform, look_at};
use crate::props::Colour;
use crate::sensor::{Camera, Meter};
use crate::settings::{NlosSettings, PathSettings};
use glam::{Vec2, Vec3A};
use std::any::{Any, TypeId};
use std::sync::{Arc, Mutex, PoisonError};

/// A shape: its primitives, BSDF and area.
#[derive(Clone, Debug)]
pub struct Shape {
    /// Id (dict key or XML id; may be empty).
    pub id: String,
    /// Plugin type (`obj`, `rectangle`, ...).
    pub plugin: String,
    /// Index into [`Scene::bsdfs`].
    pub bsdf: usize,
    /// Total surface area.
    pub area: f64,
    /// Its primitives, as a range of [`Scene::prims`].
    pub prims: std::ops::Range<usize>,
    /// For a `rectangle`, its `to_world` (the relay-wall grid is defined through it).
    pub rectangle: Option<Transform>,
}

/// What a scene measures.
#[derive(Clone)]
pub enum Setup {
    /// An NLOS capture: relay wall with an `nlos_capture_meter`, a `projector` laser,
    /// `transient_nlos_path(_rs)`.
    Nlos(Box<Nlos>),
    /// A line-of-sight render: `perspective` camera, `area`/`point` lights, `transient_path`.
    Los(Los),
}

/// The NLOS part of a scene.
#[derive(Clone)]
pub struct Nlos {
    /// Index of the relay wall (the shape owning the capture meter); `None` when a perspective
    /// camera measures the capture.
    pub relay_wall: Option<usize>,
    /// A perspective camera as the NLOS sensor (mitransient accepts any sensor; its example
    /// `nlos-z-simple.xml` uses one): each sample's camera ray finds the path's first vertex.
    pub camera: Option<Camera>,
    /// The laser.
    pub laser: Projector,
    /// Where the laser was last aimed by [`Scene::focus_laser_at`] (the origin until then, as in
    /// mitransient): the scan point of tal's confocal scan ([`Meter::confocal_grid`]).
    pub laser_target: Vec3A,
    /// Integrator settings.
    pub settings: NlosSettings,
}

/// The line-of-sight part of a scene.
#[derive(Clone)]
pub struct Los {
    /// The camera.
    pub camera: Camera,
    /// The lights.
    pub lights: Vec<Light>,
    /// Integrator settings.
    pub settings: PathSettings,
}

/// A loaded scene.
#[derive(Clone)]
pub struct Scene {
    /// Shapes in declaration order.
    pub shapes: Vec<Shape>,
    /// BSDFs, as read.
    pub bsdfs: Vec<Bsdf<Colour>>,
    /// World-space primitives in scene order.
    pub prims: Vec<Prim>,
    /// Owning shape of each primitive.
    pub prim_shape: Vec<u32>,
    /// Per-vertex shading normals of triangles (None = flat).
    pub prim_normals: Vec<Option<[Vec3A; 3]>>,
    /// Normal orientation per shape (`flip_normals`).
    pub shape_flip: Vec<bool>,
    /// BVH over `prims`.
    pub accel: std::sync::Arc<Accel>,
    /// Samples, seed and film of the sensor (capture meter or camera).
    pub meter: Meter,
    /// NLOS capture or line-of-sight camera.
    pub setup: Setup,
    /// Area sampling over the hidden geometry without and with the relay wall, built on first
    /// use and kept for later renders ([`Scene::hidden_geometry`]).
    pub hidden: [std::sync::OnceLock<Option<std::sync::Arc<AreaSampler>>>; 2],
    /// Per hidden geometry (without and with the relay wall), how a shared render meets the
    /// surfaces whose BSDF has a delta component (whether it can carry them all, whether some
    /// hidden one is all delta, whether every one is): judged on first use by the sample-reuse
    /// rule (up to 1,024 primitives against each other: 4.8 ms for 968 plastic triangles) and kept.
    pub delta_surfaces: [std::sync::OnceLock<(bool, bool, bool)>; 2],
    /// What a render prepares from the scene alone, kept for later renders: code that changes
    /// the scene in place empties it ([`Scene::focus_laser_at`]).
    pub prepared: Prepared,
}

/// What renderers make from a scene alone before they trace (an NLOS capture's scan points,
/// laser spots and cones, the lanes' tree of a mesh), made once per type and variant (mono, rgb)
/// and kept for later renders. The types are the renderers', which the scene does not know. A
/// copy of the scene, made to change it, starts with nothing kept.
#[derive(Default)]
pub struct Prepared(Mutex<Vec<Kept>>);

/// One thing [`Prepared`] keeps: its type, its variant (mono or not) and it.
type Kept = (TypeId, bool, Arc<dyn Any + Send + Sync>);

impl Clone for Prepared {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl Prepared {
    /// What was kept for the variant `mono`, or else `make`'s, kept (a render running alongside
    /// may keep its own first: the same values).
    pub fn get_or_make<T: Any + Send + Sync>(
        &self,
        mono: bool,
        make: impl FnOnce() -> Result<T>,
    ) -> Result<Arc<T>> {
        let find = |kept: &[Kept]| {
            kept.iter()
                .find(|k| k.0 == TypeId::of::<T>() && k.1 == mono)
                .and_then(|k| k.2.clone().downcast::<T>().ok())
        };
        if let Some(kept) = find(&self.0.lock().unwrap_or_else(PoisonError::into_inner)) {
            return Ok(kept);
        }
        let made = Arc::new(make()?);
        let mut kept = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        if let Some(first) = find(&kept) {
            return Ok(first);
        }
        kept.push((TypeId::of::<T>(), mono, made.clone()));
        Ok(made)
    }
}

impl Scene {
    /// The NLOS part, or an error naming what the caller wanted.
    pub fn nlos(&self) -> Result<&Nlos> {
        match &self.setup {
            Setup::Nlos(n) => Ok(n),
            Setup::Los(_) => Err(NlosError::Scene(
                "this is a line-of-sight (transient_path) scene, not an NLOS capture".into(),
            )),
        }
    }

    /// Uniform area sampling over the hidden geometry of an NLOS scene: every shape but the relay
    /// wall (mitransient-model §3.1), or every shape `with_wall` (and with a camera, which has
    /// no relay-wall shape), less the shapes whose BSDF is black in mono and in rgb
    /// ([`Bsdf::is_black`]; mitransient-model §5.10): a point drawn there would carry nothing.
    /// `None` if that has no area. Its tables take a pass over every primitive, so they are built
    /// once per scene, not per render.
    pub fn hidden_geometry(&self, with_wall: bool) -> Option<&AreaSampler> {
        self.hidden[with_wall as usize]
            .get_or_init(|| {
                let wall = self.nlos().ok().and_then(|n| n.relay_wall);
                let [mono, rgb] = [true, false].map(|m| self.shape_bsdfs(m));
                let black = |s: usize| mono[s].is_black() && rgb[s].is_black();
                AreaSampler::new(self, |s| (with_wall || Some(s) != wall) && !black(s))
                    .map(std::sync::Arc::new)
            })
            .as_deref()
    }

    /// The hidden geometry that hidden-geometry sampling draws from in this NLOS scene, as its
    /// settings ask (`nlos_hidden_geometry_sampling`, `..._includes_relay_wall`): `None` with the
    /// sampling off, or with nothing of area to sample.
    pub fn sampled_hidden_geometry(&self) -> Option<&AreaSampler> {
        let s = &self.nlos().ok()?.settings;
        s.hidden_geometry_sampling
            .then(|| self.hidden_geometry(s.hgs_includes_relay_wall))
            .flatten()
    }

    /// −1 where `flip_normals` turns shape `shape`'s normals, else 1.
    #[inline]
    pub fn normal_sign(&self, shape: usize) -> f32 {
        if self.shape_flip[shape] { -1.0 } else { 1.0 }
    }

    /// Whether shape `shape` is a sheet of triangles in one plane (the tree's test,
    /// [`Accel::plane_of`]). (A disk is planar too, but not taken here: the scan cones outline a
    /// sheet by its triangles' edges.)
    pub fn is_planar(&self, shape: usize) -> bool {
        let range = self.shapes[shape].prims.clone();
        !range.is_empty()
            && self.accel.plane_of(shape as u32) != NO_PLANE
            && self.prims[range]
                .iter()
                .all(|p| matches!(p, Prim::Triangle { .. }))
    }

    /// Whether shape `shape` is a flat sheet of triangles shaded by their face normals: planar
    /// ([`Self::is_planar`]), without vertex normals. No light goes from one of its points to
    /// another: the direction between them lies in the plane, at a cosine of zero to both.
    pub fn is_flat(&self, shape: usize) -> bool {
        self.is_planar(shape)
            && self.prim_normals[self.shapes[shape].prims.clone()]
                .iter()
                .all(Option::is_none)
    }

    /// Each shape's BSDF resolved for a mono or rgb render, indexed by shape.
    pub fn shape_bsdfs(&self, mono: bool) -> Vec<Bsdf<Spectrum>> {
        self.shapes
            .iter()
            .map(|s| self.bsdfs[s.bsdf].resolve(mono))
            .collect()
    }

    /// The surface interaction of a hit.
    #[inline(always)]
    pub fn interaction(&self, o: Vec3A, d: Vec3A, hit: &Hit) -> Interaction {
        let i = hit.prim as usize;
        let (p, ng) = self.prims[i].surface(o, d, hit);
        self.surface_point(i, p, ng, hit.b)
    }

    /// The interaction at point `p` of primitive `i` (geometric normal `ng`, barycentrics `b` for
    /// triangles): shading normal interpolated from vertex normals, `flip_normals` applied.
    pub fn surface_point(&self, i: usize, p: Vec3A, ng: Vec3A, b: [f32; 2]) -> Interaction {
        let ns = self.prim_normals[i].map_or(ng, |n| {
            (n[0] * (1.0 - b[0] - b[1]) + n[1] * b[0] + n[2] * b[1]).normalize_or(ng)
        });
        let shape = self.prim_shape[i];
        let s = self.normal_sign(shape as usize);
        Interaction {
            p,
            ng: ng * s,
            ns: ns * s,
            shape,
            prim: i as u32,
        }
    }

    /// The closest hit of a camera ray within its clipping range: with `sole`, the one shape its
    /// pixel's rays can meet (found before the render by the scan cones' pixel footprints), its
    /// few primitives alone, tested as the scan and the tree test them (the same hit, the same tie
    /// rule); else through the whole scene.
    #[inline(always)]
    pub fn camera_hit(&self, r: &Ray, sole: Option<u32>) -> Option<Hit> {
        match sole {
            Some(shape) => {
                let prims = self.shapes[shape as usize].prims.clone();
                let first = prims.start as u32;
                intersect_brute(&self.prims[prims], r.o, r.d, r.tmin, r.tmax).map(|h| Hit {
                    prim: h.prim + first,
                    ..h
                })
            }
            None => self.accel.intersect(r.o, r.d, r.tmin, r.tmax),
        }
    }

    /// Closest surface along a unit-direction ray, with its distance.
    #[inline]
    pub fn intersect(&self, o: Vec3A, d: Vec3A, tmax: f32) -> Option<(f32, Interaction)> {
        let hit = self.accel.intersect(o, d, 0.0, tmax)?;
        Some((hit.t, self.interaction(o, d, &hit)))
    }

    /// Whether the point `target` is visible from the surface point `x` (a shadow ray from `x`,
    /// offset off its surface, ending just short of `target`).
    #[inline]
    pub fn visible(&self, x: &Interaction, target: Vec3A) -> bool {
        let (o, d, tmax) = shadow_segment(x, target);
        let skip = [self.accel.plane_of(x.shape), NO_PLANE];
        self.accel.unoccluded(o, d, 0.0, tmax, skip)
    }

    /// Whether the surface points `x` and `y` see each other ([`Self::visible`]; the segment ends
    /// on `y`'s surface, so neither's plane is tested).
    #[inline]
    pub fn visible_to(&self, x: &Interaction, y: &Interaction) -> bool {
        self.visible_along(x, y, shadow_segment(x, y.p))
    }

    /// [`Self::visible_to`] along its segment `(o, d, tmax)` ([`shadow_segment`]), made by the
    /// caller ahead of the test.
    #[inline]
    pub fn visible_along(
        &self,
        x: &Interaction,
        y: &Interaction,
        (o, d, tmax): (Vec3A, Vec3A, f32),
    ) -> bool {
        let skip = [self.accel.plane_of(x.shape), self.accel.plane_of(y.shape)];
        self.accel.unoccluded(o, d, 0.0, tmax, skip)
    }

    /// The relay-wall point of a uv in [0, 1]² (`rectangle.sample_position`: to_world·(2u−1, 2v−1, 0)).
    pub fn relay_wall_point(&self, uv: Vec2) -> Result<(Vec3A, Vec3A)> {
        let wall = self.nlos()?.relay_wall.ok_or_else(|| {
            NlosError::Scene(
                "this capture is measured by a perspective camera: it has no relay-wall scan grid"
                    .into(),
            )
        })?;
        let t = self.shapes[wall].rectangle.unwrap_or(Transform::IDENTITY);
        let p = t.point(Vec3A::new(2.0 * uv.x - 1.0, 2.0 * uv.y - 1.0, 0.0));
        Ok((p, t.normal(Vec3A::Z) * self.normal_sign(wall)))
    }

    /// Aim the laser at a 3D point from its current origin (`mitr.nlos.focus_emitter_at_relay_wall_3dpoint`).
    pub fn focus_laser_at(&mut self, target: Vec3A) -> Result<()> {
        let Setup::Nlos(nlos) = &mut self.setup else {
            return Err(NlosError::Scene(
                "this is a line-of-sight scene: it has no laser to aim".into(),
            ));
        };
        let o = nlos.laser.origin.as_dvec3().to_array();
        let m = look_at(o, target.as_dvec3().to_array(), [0.0, 1.0, 0.0]).ok_or_else(|| {
            NlosError::prop(
                "projector",
                "to_world",
                "cannot aim the laser at its own origin",
            )
        })?;
        nlos.laser
            .set_to_world(m)
            .map_err(|e| NlosError::prop("projector", "to_world", e))?;
        nlos.laser_target = target;
        // The laser spots were prepared for the old aim.
        self.prepared = Prepared::default();
        Ok(())
    }
}
