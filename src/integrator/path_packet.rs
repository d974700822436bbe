//! Paths traced eight at a time, in lockstep lanes, for the scenes they are most run on — a few
//! dozen flat triangles (and meshes, spheres and disks beside them: [`Split`]), most surfaces
//! Lambertian (`diffuse`, or a `twosided` pair), smooth glass (`dielectric`) or a smooth mirror
//! (`conductor`), the others evaluated and sampled by their own BSDFs, eight lanes at a time for
//! rough metals and plastics ([`RoughLanes`]) and lane by lane for the rest (smooth plastics,
//! blends: [`Surface::general`]): the line-of-sight path tracer of [`super::path`] lit by area
//! lights (a Cornell box), and the NLOS tracer of [`super::nlos`] where a camera or a relay-wall
//! scan point gives each path's first vertex and laser sampling connects every vertex to the laser
//! spot (a single capture's, or a confocal pixel's own), hidden-geometry sampling off
//! (mitransient's camera files; tal's scenes as its generator writes them, behind two corners above
//! all). Each lane is one sample of the same pixel; the lanes advance a bounce at a time together,
//! and a lane whose path has ended takes the pixel's next sample at once, so the lanes stay full
//! until the pixel's last samples. The rays of the lanes are traced together, eight to a vector
//! ([`crate::geometry::ray_packet`]), and the steps between them are branch-free arithmetic on
//! eight lanes ([`crate::simd::F8`], AVX2 picked at run time): light sampling (a light part, or the
//! laser spot as a part of one point), cosine-weighted BSDF sampling, the glass's Fresnel choice
//! and the mirror's reflection, multiple importance sampling and Russian roulette, and the camera
//! rays of the lanes that begin a sample. Only the film's splats, the general BSDFs other than the
//! rough ones and the gathers of what a lane hit (its normal, albedo, plane and emitter) and of the
//! light part it chose (where the lights are more than one) are made lane by lane.
//!
//! The estimators are [`super::path`]'s (mitransient's `transient_path`: next-event estimation and
//! BSDF sampling under the power heuristic, emission splatted at the optical path length) and
//! [`super::nlos`]'s (laser sampling, the same depth filters), with the same clipping, depth,
//! Russian-roulette and time-origin settings. What differs:
//! - **Random numbers** are counter-based ([`crate::sampling::lane_uniform`]): the d-th number of a
//!   sample is a hash of its key and d, so a lane's numbers do not depend on the other lanes.
//!   A general BSDF other than a rough one draws its own from a stream of the lane's sample and
//!   depth.
//! - **Rays start on the surface** and skip the triangles of its plane, and a shadow ray those of
//!   its light point's plane, instead of being offset off them ([`crate::geometry::ray_packet`]).
//!   Scenes of more triangles than the packet test takes, or with spheres and disks (a mesh in a
//!   Cornell box), test a few spheres in lanes too and trace the rest in a tree beside it, each
//!   lane's ray alone, rays offset off those surfaces as the scalar tracer's rays are
//!   ([`Split`]); the rest of the bounce stays in lanes.
//!
//! Results are the same whatever the thread count: a pixel's samples are traced in one task, in
//! the same lanes, in the same order. Renders that keep per-sample values (variance, adaptive
//! sampling), draw from a low-discrepancy sequence or share light subpaths use the scalar tracers.

// Loops over the lanes (and channels, axes) index several arrays by one lane at once.
#![allow(clippy::needless_range_loop)]

use super::Splat;
use super::path::mis;
use super::scan_cone::ScanCone;
use crate::bsdf::{Bsdf, Rough, RoughLanes};
use crate::capture::Capture;
use crate::emitter::{AngularFalloff, Light};
use crate::error::{NlosError, Result};
use crate::geometry::bvh::Accel;
use crate::geometry::ray_packet::{
    Balls, LANES as L, MAX_BALLS, NO_PLANE, Packet, PacketScene, barycentric_maps, may_meet_box,
};
use crate::geometry::{Prim, offset_origin, segment_from};
use crate::math::{RAY_EPS, Spectrum, frame_axes};
use crate::sampling::{
    Sampler, lane_key, lane_uniform, square_to_uniform_disk_concentric_lanes as square_to_disk,
    square_to_uniform_triangle_lanes as square_to_triangle,
};
use crate::scene::{Los, Nlos, Scene};
use crate::sensor::Camera;
use crate::settings::CaptureType;
use crate::simd::{F8, M8};
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;
use std::ops::Range;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Random numbers a bounce draws: light choice, light point (2), BSDF direction (2), Russian
/// roulette; the camera ray's jitter takes the first two of depth 0's. Their slots:
const DIMS_PER_BOUNCE: u32 = 8;
const JITTER: u32 = 0;
const LIGHT_PICK: u32 = 2;
const LIGHT_POINT: u32 = 3;
/// (Glass takes the first for its choice of reflection or refraction.)
const BSDF_DIRECTION: u32 = 5;
const ROULETTE: u32 = 7;
/// The stream key of a general BSDF's numbers ([`PathPacket::general_samples`]: a [`Sampler`]
/// per lane, sample and depth, apart from the slots above).
const GENERAL_STREAM: u64 = 0x6765_6e65_7261_6c00;

type F = [f32; L];
type U = [u32; L];

/// Most primitives of a scene the lanes take in parts ([`Geometry::Split`]): each has a
/// [`Surface`] and a [`Smooth`], and a primitive of the tree a copy and its own tree nodes (about
/// 350 bytes in all: 90 MB at most); a bigger scene takes the scalar tracers.
pub const MAX_SPLIT_PRIMITIVES: usize = 1 << 18;

/// What the lanes' rays meet.
#[derive(Clone)]
enum Geometry {
    /// At most [`crate::geometry::ray_packet::MAX_TRIANGLES`] triangles, each tested against the
    /// eight rays at once; a ray skips the triangles of its origin's plane key.
    Packet(PacketScene),
    /// More (a mesh in a Cornell box), or spheres and disks: the scene in parts ([`Split`]).
    Split(Arc<Split>),
}

impl Geometry {
    /// The triangles tested against the eight rays at once (a split scene's smallest shapes).
    fn packet(&self) -> &PacketScene {
        match self {
            Geometry::Packet(g) => g,
            Geometry::Split(s) => &s.packet,
        }
    }
}

/// A scene of more triangles than the packet test takes, or with spheres and disks, in three
/// parts: its smallest shapes of triangles, up to [`crate::geometry::ray_packet::MAX_TRIANGLES`]
/// (a room's walls, a Cornell box's boxes), tested against the eight rays at once; up to
/// [`MAX_BALLS`] spheres, each also tested against the eight rays at once ([`Balls`]); and the
/// rest (meshes, disks, more spheres) in a tree of their own, through which each lane's ray goes
/// alone and no farther than its nearest hit so far. A ray leaving a primitive off the packet
/// starts off it, offset along its geometric normal as the scalar tracer's rays are, and such a
/// primitive's plane key is its own index.
struct Split {
    packet: PacketScene,
    balls: Balls,
    /// The tree, if any primitive is left for it.
    tree: Option<Accel>,
    /// The scene's index of each of the tree's primitives.
    tree_prims: Vec<u32>,
    /// Per scene primitive, whether it is off the packet (a ball or in the tree), and its shape.
    off_packet: Vec<bool>,
    prim_shape: Vec<u32>,
    /// The tree's bounding box, padded (low and high corners): most rays of a room pass it by,
    /// and are answered without entering the tree.
    bounds: [Vec3A; 2],
    /// That box padded by twice the most a shadow segment's ends move off the surfaces
    /// ([`segment_from`]), for the segments before they are moved.
    shadow_bounds: [Vec3A; 2],
}

impl Split {
    /// `scene` in two parts (at most [`MAX_SPLIT_PRIMITIVES`]; spheres and disks go in the
    /// tree).
    fn new(scene: &Scene) -> Option<Self> {
        let n = scene.prims.len();
        if n > MAX_SPLIT_PRIMITIVES {
            return None;
        }
        // The packet takes whole shapes, fewest triangles first, while they fit.
        let mut order: Vec<usize> = (0..scene.shapes.len()).collect();
        order.sort_by_key(|&k| (scene.shapes[k].prims.len(), k));
        let mut off_packet = vec![true; n];
        let mut taken = 0;
        for k in order {
            let prims = scene.shapes[k].prims.clone();
            if taken + prims.len() > crate::geometry::ray_packet::MAX_TRIANGLES {
                break;
            }
            if !scene.prims[prims.clone()]
                .iter()
                .all(|p| matches!(p, Prim::Triangle { .. }))
            {
                continue;
            }
            taken += prims.len();
            off_packet[prims].fill(false);
        }
        let packet = PacketScene::of(
            &scene.prims,
            |i, j| scene.prim_shape[i] == scene.prim_shape[j],
            |i| !off_packet[i],
        )?;
        // The lanes' f32 roots keep a sphere's hits to a few ulps of its centre's coordinates:
        // a sphere smaller than a thousandth of them goes to the tree (its test is in f64).
        let spheres: Vec<_> = (0..n as u32)
            .filter_map(|i| match scene.prims[i as usize] {
                Prim::Sphere { center, radius } if radius >= 1e-3 * center.abs().max_element() => {
                    Some((center, radius, i))
                }
                _ => None,
            })
            .take(MAX_BALLS)
            .collect();
        let tree_prims: Vec<u32> = (0..n as u32)
            .filter(|&i| off_packet[i as usize] && !spheres.iter().any(|b| b.2 == i))
            .collect();
        let prims: Vec<Prim> = tree_prims
            .iter()
            .map(|&i| scene.prims[i as usize])
            .collect();
        let shapes: Vec<u32> = tree_prims
            .iter()
            .map(|&i| scene.prim_shape[i as usize])
            .collect();
        let (lo, hi) = prims
            .iter()
            .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), p| {
                let (a, b) = p.bounds();
                (lo.min(a), hi.max(b))
            });
        let pad = Vec3A::splat(1e-4 * (1.0 + lo.abs().max(hi.abs()).max_element()));
        // A segment's origin moves off its surface by at most `RAY_EPS` (1 + the largest
        // coordinate of a scene point), its end not beyond the end given.
        let extent = (scene.prims.iter()).fold(0.0f32, |e, p| {
            let (a, b) = p.bounds();
            e.max(a.abs().max(b.abs()).max_element())
        });
        let moved = pad + Vec3A::splat(2.0 * RAY_EPS * (1.0 + extent));
        Some(Self {
            bounds: [lo - pad, hi + pad],
            shadow_bounds: [lo - moved, hi + moved],
            packet,
            tree: (!prims.is_empty()).then(|| Accel::build(&prims, &shapes, scene.shapes.len())),
            balls: Balls::new(spheres),
            tree_prims,
            off_packet,
            prim_shape: scene.prim_shape.clone(),
        })
    }
}

/// What a lane needs of the primitive it hit.
#[derive(Clone, Copy, Debug)]
struct Surface {
    /// Unit shading normal (`flip_normals` applied).
    n: [f32; 3],
    /// Unit geometric normal (for an area light's density in solid angle).
    ng: [f32; 3],
    /// Diffuse reflectance of the front (the side the shading normal points to) and of the back;
    /// for a `dielectric`, its specular reflectance and transmittance; for a `conductor`, its
    /// specular reflectance (front).
    albedo: [[f32; 3]; 2],
    /// It scatters on both sides (`twosided`); else a path that meets its back ends there.
    two_sided: bool,
    /// A smooth `dielectric` (glass) of relative index `eta` (inside / outside), instead of a
    /// Lambertian surface.
    dielectric: bool,
    eta: f32,
    /// A smooth `conductor` (a mirror, one-sided), instead: its shape, whose complex index
    /// η + ik is [`PathPacket::conductors`]'; else `u32::MAX` (the index kept here, a surface,
    /// which the lanes read at every hit, is 24 bytes smaller than with the index itself).
    conductor: u32,
    /// Any other BSDF (rough, plastic, blended, a mask; not emitting), instead: its shape, whose
    /// BSDF ([`PathPacket::bsdfs`]) the lanes on it evaluate and sample together where it is a
    /// rough conductor or plastic ([`PathPacket::rough`]), else each on its own, as the scalar
    /// tracers do; else `u32::MAX`.
    general: u32,
    /// Plane key ([`PacketScene::plane`]).
    plane: f32,
    /// Index in `emitters` of the area light the triangle belongs to, or `u32::MAX`.
    emitter: u32,
    /// Its normal varies: it is found at each hit ([`Smooth`]; a triangle's whose vertex
    /// normals differ, a sphere's).
    curved: bool,
}

/// A primitive's normal at a lane's hit x.
#[derive(Clone, Copy, Debug)]
enum Smooth {
    /// A triangle's vertex normals, interpolated: the barycentrics of x, b_k = a_k·x + w_k
    /// (k = 1, 2), and the normals n0, n1 − n0, n2 − n0 (`flip_normals` applied).
    Triangle {
        bary: [[f32; 4]; 2],
        n: [[f32; 3]; 3],
    },
    /// A sphere's, along x − centre (times `sign`: `flip_normals`).
    Sphere { center: [f32; 3], sign: f32 },
}

impl Smooth {
    /// The interpolation over the triangle `v` of the vertex normals `vn` (each face normal `ng`
    /// where there are none), times `sign`.
    fn triangle(v: [Vec3A; 3], vn: Option<[Vec3A; 3]>, ng: Vec3A, sign: f32) -> Self {
        let vn = vn.unwrap_or([ng; 3]).map(|n| n * sign);
        Self::Triangle {
            bary: barycentric_maps(v),
            n: [
                vn[0].to_array(),
                (vn[1] - vn[0]).to_array(),
                (vn[2] - vn[0]).to_array(),
            ],
        }
    }
}

/// A part of an area light that next-event estimation samples uniformly: a triangle, or two
/// that make a parallelogram (a rectangle's, as the packet test pairs them), as a corner and the
/// two edges from it, with what a light sample needs of its surface and emitter.
#[derive(Clone, Copy, Debug)]
struct LightPart {
    v0: [f32; 3],
    e1: [f32; 3],
    e2: [f32; 3],
    /// A parallelogram, v0 + a e1 + b e2 for a, b in [0, 1] (else the triangle of a + b ≤ 1).
    quad: bool,
    /// Its (first) triangle's surface, and its emitter.
    surface: Surface,
    emitter: Emitter,
}

/// The light parts the lanes chose, in lanes.
#[derive(Clone, Copy)]
struct LightLanes<const C: usize> {
    v0: [F8; 3],
    e1: [F8; 3],
    e2: [F8; 3],
    quad: M8,
    n: [F8; 3],
    ng: [F8; 3],
    plane: F8,
    radiance: [F8; C],
    area_pdf: F8,
    /// Index of the part's emitter in `PathPacket::emitters` (`u32::MAX` for the laser spot).
    emitter: U,
}

/// An area light: its radiance, the area density of its points under next-event estimation,
/// 1 / (lights · area), and `angulararea`'s falloff with the angle from its normal.
#[derive(Clone, Copy, Debug)]
struct Emitter {
    radiance: [f32; 3],
    area_pdf: f32,
    falloff: Option<AngularFalloff>,
}

/// How the lanes' paths are counted and cut: `transient_path`'s or `transient_nlos_path`'s
/// settings, in one form.
#[derive(Clone, Copy, Debug)]
struct Rules {
    /// A path ends at its vertex of loop depth d where d + 1 ≥ this.
    max_depth: u32,
    /// Loop depth from which Russian roulette applies.
    rr_depth: u32,
    /// What of the camera ray's length the optical path counts.
    first_leg: FirstLeg,
    /// Emission the camera ray finds is dropped (`discard_direct_light`).
    discard_direct_light: bool,
    /// Vertices connect from this loop depth on.
    connect_from: u32,
    /// The only loop depth whose vertex connects, after which the path ends (NLOS
    /// `filter_bounces`).
    connect_only: Option<u32>,
}

/// What of the camera ray's length the optical path counts.
#[derive(Clone, Copy, Debug, PartialEq)]
enum FirstLeg {
    /// None (`camera_unwarp`; an NLOS capture that does not account for its first bounce).
    Skipped,
    /// From the near clip plane on (`opl_from_near_clip`).
    FromNearClip,
    /// All of it.
    Whole,
}

/// What the lanes' vertices connect to.
enum Target {
    /// Line of sight: the area lights' parts, by next-event estimation under multiple importance
    /// sampling with the emission BSDF sampling finds; each part's cumulative probability (the
    /// last 1).
    Lights {
        parts: Vec<LightPart>,
        cdf: Vec<f32>,
    },
    /// NLOS laser sampling (mitransient-model §3.4): the laser spot of a single capture, or each
    /// pixel's own spot of a confocal one, as a light part of a single point of Lambertian
    /// radiance (BSDF sampling cannot find it: no MIS), with the optical path from it back to the
    /// laser.
    Spots(Vec<SpotPart>),
}

/// Where a sample's path begins.
enum Start<'a> {
    /// A camera ray through the pixel (jittered).
    Camera(&'a Camera),
    /// An NLOS capture's scan point on the relay wall, seen from the sensor's origin `origin`:
    /// per pixel the point and its primitive (`None` where the sensor sees nothing). The
    /// lanes' first vertex is that point, untraced, as the scalar tracer's.
    Scan {
        origin: Vec3A,
        points: Vec<Option<(Vec3A, u32)>>,
    },
}

/// A laser spot as the lanes connect to it.
#[derive(Clone, Copy, Debug)]
struct SpotPart {
    /// The spot as a light part of one point.
    part: LightPart,
    /// The optical path from it back to the laser.
    last_leg: f64,
    /// The laser lights it (else it connects nothing).
    lit: bool,
}

/// A prepared lockstep render of a scene ([`PathPacket::new`] and [`PathPacket::nlos`] say
/// whether it can be).
pub struct PathPacket<'a> {
    start: Start<'a>,
    rules: Rules,
    width: usize,
    height: usize,
    geometry: Geometry,
    surfaces: Vec<Surface>,
    target: Target,
    /// The area lights (none in an NLOS capture).
    emitters: Vec<Emitter>,
    /// Some area light is an `angulararea` one.
    falloff: bool,
    /// Per triangle, its vertex normals as lanes interpolate them (read for [`Surface::curved`]
    /// triangles only).
    smooth: Vec<Smooth>,
    /// Per shape, its complex index η + ik as (η, k) where it is a `conductor` (read for
    /// [`Surface::conductor`]).
    conductors: Vec<[[f32; 3]; 2]>,
    /// Per shape, its BSDF, where some surface is [`Surface::general`] (else empty).
    bsdfs: Vec<Bsdf<Spectrum>>,
    /// Per shape of `bsdfs`, its lane form where it is a rough conductor or rough plastic: the
    /// lanes on those evaluate and sample them together ([`RoughLanes`]).
    rough: Vec<Option<Rough>>,
    mono: bool,
    /// Some surface is glass, a mirror or general (what `GLASS` compiles in: deltas, refraction
    /// and BSDFs evaluated lane by lane).
    glass: bool,
}

/// The primitives of a scene as lanes read them: the geometry, each one's surface and normals,
/// and each shape's complex index where it is a `conductor`.
type LaneSurfaces = (
    Geometry,
    Vec<Surface>,
    Vec<Smooth>,
    Vec<[[f32; 3]; 2]>,
    Vec<Bsdf<Spectrum>>,
);

/// The lockstep form of `scene`'s primitives, if they are at most
/// [`crate::geometry::ray_packet::MAX_TRIANGLES`] triangles or, with `split`, at most
/// [`MAX_SPLIT_PRIMITIVES`] triangles, spheres and disks (lights on triangles only), and its every
/// emitting surface Lambertian (`diffuse`, or a `twosided` pair of them); `shape_emitter`: per
/// shape, the index of its area light or `u32::MAX`.
fn lane_surfaces(
    scene: &Scene,
    shape_emitter: &[u32],
    mono: bool,
    split: bool,
) -> Option<LaneSurfaces> {
    if !crate::simd::available() {
        return None;
    }
    let geometry = match PacketScene::new(&scene.prims, |i, j| {
        scene.prim_shape[i] == scene.prim_shape[j]
    }) {
        Some(g) => Geometry::Packet(g),
        // (Kept with the scene, made or not: one for both variants.)
        None if split => {
            let kept = (scene.prepared)
                .get_or_make(true, || Ok(Split::new(scene).map(Arc::new)))
                .ok()?;
            Geometry::Split(Option::clone(&kept)?)
        }
        None => return None,
    };
    let bsdfs = scene.shape_bsdfs(mono);
    let mut surfaces = Vec::with_capacity(scene.prims.len());
    let mut smooth = Vec::with_capacity(scene.prims.len());
    let mut conductors = vec![[[0.0; 3]; 2]; scene.shapes.len()];
    for (i, prim) in scene.prims.iter().enumerate() {
        let shape = scene.prim_shape[i] as usize;
        let emitter = shape_emitter[shape];
        let sign = scene.normal_sign(shape);
        // A triangle's vertex normals that are all one (a flat face's, as a mesh file rounds
        // it) are the shading normal of its every point; others are interpolated at each hit
        // (`curved`), as a sphere's are found there. (Light parts are triangles; spheres and
        // disks are off a split scene's packet.)
        let (ng, ns, curved, normals) = match *prim {
            Prim::Triangle { v, n } => {
                let (ns, curved) = match scene.prim_normals[i] {
                    None => (n, false),
                    Some(vn) => {
                        let m = vn[0].normalize_or(n);
                        (m, vn.iter().any(|k| k.normalize_or(n).dot(m) < 1.0 - 1e-6))
                    }
                };
                // A light sample's cosine is taken with one normal per light triangle.
                if curved && emitter != u32::MAX {
                    return None;
                }
                let normals = Smooth::triangle(v, scene.prim_normals[i], n, sign);
                (n, ns, curved, normals)
            }
            _ if emitter != u32::MAX || !matches!(geometry, Geometry::Split(_)) => return None,
            Prim::Sphere { center, .. } => {
                let center = center.to_array();
                (Vec3A::Z, Vec3A::Z, true, Smooth::Sphere { center, sign })
            }
            Prim::Disk { inv } => {
                // (Its one normal: the interpolation of three equal ones.)
                let n = Prim::disk_normal(&inv);
                let normals = Smooth::Triangle {
                    bary: [[0.0; 4]; 2],
                    n: [(n * sign).to_array(), [0.0; 3], [0.0; 3]],
                };
                (n, n, false, normals)
            }
        };
        let (mut albedo, mut two_sided, mut eta) = ([[0.0; 3]; 2], false, None);
        let (mut conductor, mut general) = (u32::MAX, u32::MAX);
        match &bsdfs[shape] {
            Bsdf::Diffuse(d) => albedo = [d.reflectance.to_array(); 2],
            Bsdf::TwoSided(t)
                if matches!((&*t.front, &*t.back), (Bsdf::Diffuse(_), Bsdf::Diffuse(_))) =>
            {
                let side = |b: &Bsdf<Spectrum>| b.albedo().unwrap_or_default().to_array();
                (albedo, two_sided) = ([side(&t.front), side(&t.back)], true);
            }
            // (No light sample is taken on the others, nor found on them.)
            _ if emitter != u32::MAX => return None,
            Bsdf::Dielectric(g) => {
                albedo = [g.specular_reflectance, g.specular_transmittance].map(|t| t.to_array());
                eta = Some(g.eta);
            }
            Bsdf::Conductor(m) => {
                conductors[shape] = [m.eta.to_array(), m.k.to_array()];
                (albedo, conductor) = ([m.specular_reflectance.to_array(); 2], shape as u32);
            }
            _ => general = shape as u32,
        }
        smooth.push(normals);
        let (n, ng) = (ns * sign, ng * sign);
        surfaces.push(Surface {
            n: n.to_array(),
            ng: ng.to_array(),
            albedo,
            two_sided,
            dielectric: eta.is_some(),
            eta: eta.unwrap_or(1.0),
            conductor,
            general,
            plane: geometry.packet().plane(i as u32),
            emitter,
            curved,
        });
    }
    let general = surfaces.iter().any(|s| s.general != u32::MAX);
    let bsdfs = if general { bsdfs } else { Vec::new() };
    Some((geometry, surfaces, smooth, conductors, bsdfs))
}

impl<'a> PathPacket<'a> {
    /// The lockstep render of the line-of-sight `scene`, if its triangles allow
    /// ([`lane_surfaces`]) and its lights are area lights (`area` or `angulararea`) of uniform
    /// radiance on flat-shaded triangles; else `None` (the scalar path tracer renders it).
    pub fn new(scene: &Scene, los: &'a Los, mono: bool) -> Option<Self> {
        if los.lights.is_empty() {
            return None;
        }
        let mut emitters = Vec::new();
        let mut shape_emitter = vec![u32::MAX; scene.shapes.len()];
        for light in &los.lights {
            let Light::Area {
                shape,
                radiance,
                falloff,
            } = *light
            else {
                return None;
            };
            let area: f32 = scene.prims[scene.shapes[shape].prims.clone()]
                .iter()
                .map(Prim::area)
                .sum();
            if !(area > 0.0) || shape_emitter[shape] != u32::MAX {
                return None;
            }
            shape_emitter[shape] = emitters.len() as u32;
            emitters.push(Emitter {
                radiance: radiance.spectrum(mono).to_array(),
                area_pdf: 1.0 / (area * los.lights.len() as f32),
                falloff,
            });
        }
        let (geometry, surfaces, smooth, conductors, bsdfs) =
            lane_surfaces(scene, &shape_emitter, mono, true)?;
        let rough = bsdfs.iter().map(Rough::of).collect();
        // The light parts: each light triangle, but the two of a parallelogram as one where they
        // share both normals (a light sample's cosines are taken with its part's).
        let mut corners = vec![None; scene.prims.len()];
        let mut second = vec![false; scene.prims.len()];
        for &(i, j, c) in geometry.packet().parallelograms() {
            let (a, b) = (&surfaces[i as usize], &surfaces[j as usize]);
            let same = |x: [f32; 3], y: [f32; 3]| (0..3).all(|k| (x[k] - y[k]).abs() <= 1e-6);
            if same(a.n, b.n) && same(a.ng, b.ng) {
                corners[i as usize] = Some(c);
                second[j as usize] = true;
            }
        }
        let (mut parts, mut weights) = (Vec::new(), Vec::new());
        for (i, surface) in surfaces.iter().enumerate() {
            if surface.emitter == u32::MAX || second[i] {
                continue;
            }
            let prim = &scene.prims[i];
            let Prim::Triangle { v, .. } = *prim else {
                unreachable!("every primitive is a triangle here");
            };
            let (corner, quad) = (corners[i].unwrap_or(v), corners[i].is_some());
            let emitter = emitters[surface.emitter as usize];
            parts.push(LightPart {
                v0: corner[0].to_array(),
                e1: (corner[1] - corner[0]).to_array(),
                e2: (corner[2] - corner[0]).to_array(),
                quad,
                surface: *surface,
                emitter,
            });
            let area = prim.area() as f64 * if quad { 2.0 } else { 1.0 };
            weights.push(area * emitter.area_pdf as f64);
        }
        let total: f64 = weights.iter().sum();
        let mut acc = 0.0;
        let mut cdf: Vec<f32> = weights
            .iter()
            .map(|w| {
                acc += w;
                (acc / total) as f32
            })
            .collect();
        *cdf.last_mut()? = 1.0;
        let st = &los.settings;
        let glass = surfaces
            .iter()
            .any(|s| s.dielectric || s.conductor != u32::MAX || s.general != u32::MAX);
        Some(Self {
            start: Start::Camera(&los.camera),
            rules: Rules {
                max_depth: st.max_depth,
                rr_depth: st.rr_depth,
                first_leg: if st.camera_unwarp {
                    FirstLeg::Skipped
                } else if st.opl_from_near_clip {
                    FirstLeg::FromNearClip
                } else {
                    FirstLeg::Whole
                },
                discard_direct_light: st.discard_direct_light,
                connect_from: 0,
                connect_only: None,
            },
            width: scene.meter.film.width,
            height: scene.meter.film.height,
            geometry,
            surfaces,
            target: Target::Lights { parts, cdf },
            falloff: emitters.iter().any(|e| e.falloff.is_some()),
            emitters,
            smooth,
            conductors,
            bsdfs,
            rough,
            mono,
            glass,
        })
    }

    /// The lockstep render of the NLOS `scene` (`transient_nlos_path`) whose scan points (the
    /// sensor's first hits, without a camera) and laser spots are `capture`'s, if a perspective
    /// camera or the scan points give its paths' first vertices, laser sampling connects them to
    /// the spot of a single capture or to each pixel's of a confocal one, every spot
    /// Lambertian, with hidden-geometry sampling off, and its triangles allow
    /// ([`lane_surfaces`]); else `None` (the scalar tracer renders it). Its paths are
    /// [`super::nlos`]'s: the same connections, depths and roulette.
    pub fn nlos(scene: &Scene, nlos: &'a Nlos, capture: &Capture, mono: bool) -> Option<Self> {
        let st = &nlos.settings;
        let start = match nlos.camera.as_ref() {
            Some(camera) => Start::Camera(camera),
            None => Start::Scan {
                origin: scene.meter.origin,
                points: capture
                    .scan_points
                    .iter()
                    .map(|it| it.map(|it| (it.p, it.prim)))
                    .collect(),
            },
        };
        // A path's vertex at loop depth d makes a contribution of depth d + 2 (the spot and the
        // laser are two more vertices); `filter_bounces` keeps one depth (below 2, none: the
        // scalar tracer renders it).
        let connect_only = match st.filter_depth {
            Some(f) => Some(f.checked_sub(2)?),
            None => None,
        };
        // One laser spot (single), or one per pixel (confocal; a camera captures single only).
        let spots = &capture.spots;
        let per_pixel = match st.capture_type {
            CaptureType::Single => spots.len() == 1,
            CaptureType::Confocal => {
                matches!(start, Start::Scan { ref points, .. } if points.len() == spots.len())
            }
            CaptureType::Exhaustive => false,
        };
        if !per_pixel || !st.laser_sampling || st.hidden_geometry_sampling {
            return None;
        }
        // Scan points' paths take meshes past the packet test in the scalar tracer: in lanes,
        // beside a tree, the 200k-triangle mesh's confocal capture ran 0.74× as fast.
        let split = matches!(start, Start::Camera(_));
        let (geometry, surfaces, smooth, conductors, bsdfs) =
            lane_surfaces(scene, &vec![u32::MAX; scene.shapes.len()], mono, split)?;
        let rough = bsdfs.iter().map(Rough::of).collect();
        let spots = spots
            .iter()
            .map(|spot| {
                let radiance = spot.radiance?;
                let ns = spot.it.ns.to_array();
                Some(SpotPart {
                    part: LightPart {
                        v0: spot.it.p.to_array(),
                        e1: [0.0; 3],
                        e2: [0.0; 3],
                        quad: false,
                        surface: Surface {
                            n: ns,
                            ng: ns,
                            ..surfaces[spot.it.prim as usize]
                        },
                        emitter: Emitter {
                            radiance: radiance.to_array(),
                            area_pdf: 1.0,
                            falloff: None,
                        },
                    },
                    last_leg: spot.last_leg,
                    lit: radiance != Spectrum::ZERO && spot.incident != Spectrum::ZERO,
                })
            })
            .collect::<Option<Vec<_>>>()?;
        let glass = surfaces
            .iter()
            .any(|s| s.dielectric || s.conductor != u32::MAX || s.general != u32::MAX);
        Some(Self {
            start,
            rules: Rules {
                max_depth: st.max_depth,
                rr_depth: st.rr_depth,
                first_leg: if st.account_first_and_last_bounces {
                    FirstLeg::Whole
                } else {
                    FirstLeg::Skipped
                },
                discard_direct_light: false,
                connect_from: if st.discard_direct_paths { 1 } else { 0 },
                connect_only,
            },
            width: scene.meter.film.width,
            height: scene.meter.film.height,
            geometry,
            surfaces,
            target: Target::Spots(spots),
            emitters: Vec::new(),
            falloff: false,
            smooth,
            conductors,
            bsdfs,
            rough,
            mono,
            glass,
        })
    }

    /// Trace samples `samples` of `pixel` (row-major), passing every contribution to `out`
    /// (laser slot 0); stops with [`NlosError::Interrupted`] once `cancel` is set. `cone`: the
    /// pixel's cone, which ends a sample with nothing traced where its first direction's square
    /// sample surely meets nothing ([`ScanCone::may_reach_square`]; the caller knows that the
    /// pixel's first vertex connects nothing and draws its direction about the cone's normal).
    pub fn trace(
        &self,
        pixel: usize,
        samples: Range<u64>,
        seed: u64,
        cone: Option<&ScanCone>,
        cancel: &AtomicBool,
        out: &mut impl FnMut(Splat),
    ) -> Result<()> {
        // SAFETY: a `PathPacket` is made only where the CPU runs `F8`'s vectors (its
        // `PacketScene`).
        unsafe {
            match (self.mono, self.glass) {
                (true, false) => self.lanes::<1, false>(pixel, samples, seed, cone, cancel, out),
                (false, false) => self.lanes::<3, false>(pixel, samples, seed, cone, cancel, out),
                (true, true) => self.lanes::<1, true>(pixel, samples, seed, cone, cancel, out),
                (false, true) => self.lanes::<3, true>(pixel, samples, seed, cone, cancel, out),
            }
        }
    }

    /// The lockstep loop over `C` colour channels (1 mono, 3 rgb); what glass needs is compiled
    /// in where the scene has some (`GLASS`).
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx2,fma"))]
    unsafe fn lanes<const C: usize, const GLASS: bool>(
        &self,
        pixel: usize,
        samples: Range<u64>,
        seed: u64,
        cone: Option<&ScanCone>,
        cancel: &AtomicBool,
        out: &mut impl FnMut(Splat),
    ) -> Result<()> {
        let st = self.rules;
        let b = F8::splat;
        let pixel_key = lane_key(seed, pixel as u64);
        // The pixel's laser spot in lanes, and the optical path from it back to the laser.
        let spot = match &self.target {
            Target::Lights { .. } => None,
            Target::Spots(spots) => Some(spots[if spots.len() == 1 { 0 } else { pixel }]),
        };
        // A scan point: the first vertex, where the ray from the sensor's origin ends.
        let scan = match &self.start {
            Start::Camera(_) => None,
            Start::Scan { origin, points } => {
                let Some((x1, prim)) = points[pixel] else {
                    return Ok(());
                };
                let u = x1 - *origin;
                let length = u.length();
                Some((*origin, u / length, length, prim))
            }
        };
        let dark = spot.is_some_and(|s| !s.lit);
        let spot = spot.map(|s| (part_lanes::<C>(&s.part), s.last_leg));
        let mut next = samples.start;
        let mut p = Paths::<C>::default();
        loop {
            if cancel.load(Ordering::Relaxed) {
                return Err(NlosError::Interrupted);
            }
            // ---- A new sample in every lane whose path has ended: its camera ray. (Samples
            // whose first direction the pixel's cone turns down end here.)
            let mut fresh = 0;
            for l in 0..L {
                while p.alive >> l & 1 == 0 && next < samples.end {
                    let key = pixel_key.sample(next);
                    next += 1;
                    // (Depth 0's BSDF numbers.)
                    let (i, j) = (BSDF_DIRECTION, BSDF_DIRECTION + 1);
                    let u = || Vec2::new(lane_uniform(key, i), lane_uniform(key, j));
                    if cone.is_none_or(|c| c.may_reach_square(u())) {
                        p.key[l] = key;
                        fresh |= 1 << l;
                        break;
                    }
                }
            }
            if fresh != 0 {
                match (&self.start, scan) {
                    (Start::Camera(camera), _) => {
                        let depth0 = [0; L];
                        let (jx, jy) = (p.uniforms(depth0, JITTER), p.uniforms(depth0, JITTER + 1));
                        let (d, tmin, tmax) = camera.pixel_ray_parts(
                            pixel,
                            self.width,
                            self.height,
                            F8::load(&jx),
                            F8::load(&jy),
                        );
                        p.start(fresh, camera.origin.to_array(), d, tmin, tmax);
                    }
                    (_, Some((o, d, length, _))) => {
                        let d = d.to_array().map(b);
                        p.start(fresh, o.to_array(), d, b(0.0), b(length));
                    }
                    _ => unreachable!("a scan start has its point"),
                }
            }
            if p.alive == 0 {
                return Ok(());
            }
            // ---- The closest hit of every lane's ray (a dead lane's ray is empty; a scan point's
            // is the point itself, untraced).
            let mut first = 0;
            for l in 0..L {
                if p.alive >> l & 1 == 0 {
                    p.ray.tmax[l] = f32::NEG_INFINITY;
                } else if scan.is_some() && p.depth[l] == 0 {
                    p.ray.tmax[l] = f32::NEG_INFINITY;
                    first |= 1 << l;
                }
            }
            let (mut t, mut prim) = self.closest(&mut p.ray);
            if let Some((_, _, length, at)) = scan {
                for l in 0..L {
                    if first >> l & 1 != 0 {
                        (t[l], prim[l]) = (length, at);
                    }
                }
            }
            // What each lane hit, gathered into lanes.
            let mut hit = Lanes::<C>::default();
            let (mut curved, mut two_sided, mut glass, mut mirror) = (0, 0, 0, 0);
            let (mut general, mut shape) = (0, [u32::MAX; L]);
            let mut ior = [1.0; L];
            for l in 0..L {
                if prim[l] == u32::MAX {
                    p.alive &= !(1 << l);
                    continue;
                }
                let s = &self.surfaces[prim[l] as usize];
                for a in 0..3 {
                    hit.n[a][l] = s.n[a];
                }
                for c in 0..C {
                    hit.albedo[0][c][l] = s.albedo[0][c];
                }
                if s.two_sided || s.dielectric {
                    for c in 0..C {
                        hit.albedo[1][c][l] = s.albedo[1][c];
                    }
                }
                if GLASS {
                    ior[l] = s.eta;
                }
                (hit.plane[l], hit.emitter[l]) = (s.plane, s.emitter);
                curved |= (s.curved as u32) << l;
                two_sided |= (s.two_sided as u32) << l;
                glass |= ((GLASS && s.dielectric) as u32) << l;
                mirror |= ((GLASS && s.conductor != u32::MAX) as u32) << l;
                if GLASS && s.general != u32::MAX {
                    (general, shape[l]) = (general | 1 << l, s.general);
                }
            }
            let tv = F8::load(&t);
            let o = p.ray.o.each_ref().map(F8::load);
            let d = p.ray.d.each_ref().map(F8::load);
            let x = [
                d[0].mul_add(tv, o[0]),
                d[1].mul_add(tv, o[1]),
                d[2].mul_add(tv, o[2]),
            ];
            let mut n = hit.n.each_ref().map(F8::load);
            // Lanes on triangles whose vertex normals differ, and on spheres, take the normal at
            // their hit.
            if curved != 0 {
                let ni = interpolated_normals(&self.smooth, &prim, curved, &x);
                let m = M8::from_bits(curved);
                for a in 0..3 {
                    n[a] = F8::select(m, ni[a], n[a]);
                }
            }
            // The cosine at the front (an emitter's side), and then at the side the ray meets a
            // two-sided surface on, whose normal and albedo are that side's (`twosided`).
            let cos_front = b(0.0) - dot(&n, &d);
            let mut cos_i = cos_front;
            let mut albedo = hit.albedo[0].each_ref().map(F8::load);
            if two_sided != 0 {
                let back = M8::from_bits(two_sided) & !cos_front.gt(b(0.0));
                for a in 0..3 {
                    n[a] = F8::select(back, -n[a], n[a]);
                }
                cos_i = F8::select(back, -cos_front, cos_front);
                for c in 0..C {
                    albedo[c] = F8::select(back, F8::load(&hit.albedo[1][c]), albedo[c]);
                }
            }
            let (front, cos_i) = (cos_front.store(), cos_i.store());
            for l in 0..L {
                // (Light is slower by η inside a refracting medium.)
                p.opl[l] += match (p.depth[l], st.first_leg) {
                    (0, FirstLeg::Skipped) => 0.0,
                    (0, FirstLeg::FromNearClip) => (t[l] - p.ray.tmin[l]) as f64,
                    _ if GLASS => t[l] as f64 * p.eta[l] as f64,
                    _ => t[l] as f64,
                };
            }
            // ---- Emission found by the camera ray or by BSDF sampling (MIS against the light
            // sample that could have found it; a camera ray's is taken whole).
            if !self.emitters.is_empty() {
                self.emission::<C, GLASS>(&p, &hit, &prim, &t, &front, out);
            }
            let mut rr = 0;
            for l in 0..L {
                let depth = p.depth[l];
                // Paths at their last vertex, and those that meet a surface from behind (a
                // one-sided BSDF neither reflects nor connects there; glass has two sides, and
                // a general BSDF answers for its own), end.
                if depth.saturating_add(1) >= st.max_depth
                    || ((glass | general) >> l & 1 == 0 && !(cos_i[l] > 0.0))
                {
                    p.alive &= !(1 << l);
                }
                rr |= ((depth >= st.rr_depth) as u32) << l;
            }
            // The lanes whose vertex connects, and those that end after it.
            let (mut connects, mut last) = (u32::MAX, 0);
            if dark {
                connects = 0;
            } else if st.connect_from > 0 || st.connect_only.is_some() {
                connects = 0;
                for l in 0..L {
                    let depth = p.depth[l];
                    let kept =
                        depth >= st.connect_from && st.connect_only.is_none_or(|f| depth == f);
                    connects |= (kept as u32) << l;
                    last |= (st.connect_only.is_some_and(|f| depth >= f) as u32) << l;
                }
            }
            if p.alive == 0 {
                continue;
            }
            let alive = M8::from_bits(p.alive);
            let mut dim = [0; L];
            for l in 0..L {
                dim[l] = p.depth[l].wrapping_mul(DIMS_PER_BOUNCE);
            }
            let beta = p.beta.each_ref().map(F8::load);
            // ---- Next-event estimation: a light part (or the laser spot), a point on it, its
            // contribution (weighted against BSDF sampling where that could find it too), and a
            // shadow ray for the lanes it lights.
            let sampled;
            let (light, last_leg) = match &spot {
                Some((s, last_leg)) => (s, *last_leg),
                None => {
                    sampled = self.light_lanes::<C>(&p, dim);
                    (&sampled, 0.0)
                }
            };
            let (u1, u2) = (
                F8::load(&p.uniforms(dim, LIGHT_POINT)),
                F8::load(&p.uniforms(dim, LIGHT_POINT + 1)),
            );
            let (b1, b2) = square_to_triangle(u1, u2);
            let (b1, b2) = (
                F8::select(light.quad, u1, b1),
                F8::select(light.quad, u2, b2),
            );
            let mut w = [b(0.0); 3];
            for a in 0..3 {
                let y = light.v0[a] + light.e1[a] * b1 + light.e2[a] * b2;
                w[a] = y - x[a];
            }
            let r2 = dot(&w, &w);
            let r = r2.sqrt();
            w = w.map(|w| w / r);
            // The tangent frame of each lane's normal, as `Frame::new` makes it.
            let frame = frame_axes(n);
            // The rough BSDFs of the lanes on them, met from −d, gathered once for the bounce's
            // light sample and BSDF sample.
            let (mut rough, mut rough_bsdfs) = (0, None);
            if GLASS && general & p.alive != 0 {
                let of;
                (rough, of) = self.rough_lanes(general & p.alive, &shape);
                if rough != 0 {
                    let wi = local(&frame, &n, [-d[0], -d[1], -d[2]]);
                    rough_bsdfs = Some(RoughLanes::<C>::gather(of, wi));
                }
            }
            // The light's cosines (one-sided: its front faces x; the density's is the geometric
            // normal's) and the BSDF's.
            let cos_l = b(0.0) - dot(&light.n, &w);
            let cos_o = dot(&n, &w);
            let bsdf_pdf = cos_o * b(FRAC_1_PI);
            // (Glass, a delta, connects to nothing.)
            let mut lights = alive
                & M8::from_bits(connects & !(glass | mirror))
                & cos_l.gt(b(0.0))
                & cos_o.gt(b(0.0));
            let weight = if spot.is_some() {
                // The spot: f·cos_o·cos_l / r² (a vertex on the spot's own plane sees it at a
                // grazing angle, as rounding makes it: nothing).
                lights = lights & light.plane.ne(F8::load(&hit.plane));
                bsdf_pdf * cos_l / r2
            } else {
                let light_pdf = r2 * light.area_pdf / dot(&light.ng, &w).abs();
                mis_lanes(light_pdf, bsdf_pdf) * bsdf_pdf / light_pdf
            };
            let mut lit = [[0.0; L]; C];
            for c in 0..C {
                let v = beta[c] * albedo[c] * light.radiance[c] * weight;
                lit[c] = F8::select(lights, v, b(0.0)).store();
            }
            // (Lanes on general surfaces: their BSDFs' own values and densities.)
            let lanes = (alive & M8::from_bits(connects & general) & cos_l.gt(b(0.0))).bits();
            if GLASS && lanes != 0 {
                let lanes = match spot {
                    Some(_) => lanes & light.plane.ne(F8::load(&hit.plane)).bits(),
                    None => lanes,
                };
                let rough = lanes & rough;
                let mut lit_general = 0;
                if let Some(bsdfs) = rough_bsdfs.as_ref().filter(|_| rough != 0) {
                    let (f, pdf, some) = bsdfs.eval_pdf(local(&frame, &n, w));
                    let weight = if spot.is_some() {
                        cos_l / r2
                    } else {
                        let light_pdf = r2 * light.area_pdf / dot(&light.ng, &w).abs();
                        mis_lanes(light_pdf, pdf) / light_pdf
                    };
                    let m = some & M8::from_bits(rough);
                    for c in 0..C {
                        let v = beta[c] * f[c] * light.radiance[c] * weight;
                        lit[c] = F8::select(m, v, F8::load(&lit[c])).store();
                    }
                    lit_general |= m.bits();
                }
                if lanes & !rough != 0 {
                    lit_general |= self.general_lights(
                        lanes & !rough,
                        &shape,
                        [&n, &d, &w].map(|v| v.map(F8::store)),
                        [r2, cos_l, light.area_pdf].map(F8::store),
                        (light.ng.map(F8::store), light.radiance.map(F8::store)),
                        spot.is_some(),
                        &beta.map(F8::store),
                        &mut lit,
                    );
                }
                lights = M8::from_bits(lights.bits() & !general | lit_general);
            }
            if self.falloff {
                lights = self.fall_off(&light.emitter, &cos_l.store(), lights, &mut lit);
            }
            let shadow = Packet {
                o: x.map(F8::store),
                d: w.map(F8::store),
                tmin: [0.0; L],
                tmax: r.store(),
                skip: [hit.plane, light.plane.store()],
            };
            let open = match lights.bits() {
                0 => 0,
                cand => self.unoccluded(&shadow, cand),
            };
            for l in 0..L {
                if open >> l & 1 != 0 {
                    let mut v = [0.0; C];
                    for c in 0..C {
                        v[c] = lit[c][l];
                    }
                    let leg = shadow.tmax[l] * if GLASS { p.eta[l] } else { 1.0 };
                    out(splat(p.opl[l] + leg as f64 + last_leg, v));
                }
            }
            // Paths whose only kept connection was this vertex's end.
            p.alive &= !last;
            // ---- BSDF sampling (cosine-weighted: the weight is the albedo), then Russian
            // roulette as Mitsuba plays it.
            let (v1, v2) = (
                p.uniforms(dim, BSDF_DIRECTION),
                p.uniforms(dim, BSDF_DIRECTION + 1),
            );
            let u_rr = F8::load(&p.uniforms(dim, ROULETTE));
            let (dx, dy) = square_to_disk(F8::load(&v1), F8::load(&v2));
            let dz = (b(1.0) - dx * dx - dy * dy).max(b(0.0)).sqrt();
            for a in 0..3 {
                let dir = frame[0][a] * dx + frame[1][a] * dy + n[a] * dz;
                p.ray.d[a] = dir.store();
                p.ray.o[a] = x[a].store();
            }
            p.bsdf_pdf = (dz * b(FRAC_1_PI)).store();
            // The sample's weight: the albedo, or on glass (reflection or refraction, chosen by
            // the Fresnel probability with the BSDF's first number) its tint and scale.
            let mut weight = albedo;
            if GLASS {
                p.delta = glass | mirror;
            }
            if GLASS && general & p.alive != 0 {
                let rough = general & p.alive & rough;
                if let Some(bsdfs) = rough_bsdfs.as_ref().filter(|_| rough != 0) {
                    // Each lane's direction from its own two numbers, then its value and density.
                    let wo = bsdfs.sample(F8::load(&v1), F8::load(&v2));
                    let (f, pdf, some) = bsdfs.eval_pdf(wo);
                    let up = bsdfs.incident()[2].gt(b(0.0));
                    let m = M8::from_bits(rough) & some & up & pdf.gt(b(0.0));
                    p.alive &= !rough | m.bits();
                    for a in 0..3 {
                        let dir = frame[0][a] * wo[0] + frame[1][a] * wo[1] + n[a] * wo[2];
                        p.ray.d[a] = F8::select(m, dir, F8::load(&p.ray.d[a])).store();
                    }
                    for c in 0..C {
                        weight[c] = F8::select(m, f[c] / pdf, weight[c]);
                    }
                    p.bsdf_pdf = F8::select(m, pdf, F8::load(&p.bsdf_pdf)).store();
                    p.delta &= !rough;
                }
                if general & p.alive & !rough != 0 {
                    let nd = [n, d].map(|v| v.map(F8::store));
                    let mut w = weight.map(F8::store);
                    self.general_samples(general & p.alive & !rough, &shape, nd, &mut p, &mut w);
                    weight = w.map(|c| F8::load(&c));
                }
            }
            if GLASS && glass & p.alive != 0 {
                let g = M8::from_bits(glass);
                let s = dielectric_sample(n, d, cos_front, F8::load(&ior), F8::load(&v1));
                for a in 0..3 {
                    p.ray.d[a] = F8::select(g, s.d[a], F8::load(&p.ray.d[a])).store();
                }
                for c in 0..C {
                    let tint = F8::select(s.reflected, albedo[c], F8::load(&hit.albedo[1][c]));
                    weight[c] = F8::select(g, tint * s.scale, weight[c]);
                }
                p.eta = (F8::load(&p.eta) * F8::select(g, s.eta, b(1.0))).store();
            }
            if GLASS && mirror & p.alive != 0 {
                // A mirror reflects about its normal.
                let (m, c2) = (M8::from_bits(mirror), F8::load(&cos_i) * b(2.0));
                for a in 0..3 {
                    let r = n[a].mul_add(c2, d[a]);
                    p.ray.d[a] = F8::select(m, r, F8::load(&p.ray.d[a])).store();
                }
                let mut w = weight.map(F8::store);
                self.mirror_weights(mirror & p.alive, &prim, &cos_i, &mut w);
                weight = w.map(|c| F8::load(&c));
            }
            let beta: [F8; C] = std::array::from_fn(|c| beta[c] * weight[c]);
            // Russian roulette weighs β by η² (the radiance scaling of refraction does not end a
            // path inside glass).
            let mut m = beta.iter().fold(b(0.0), |m, &x| x.max(m));
            if GLASS {
                let eta = F8::load(&p.eta);
                m = m * (eta * eta);
            }
            let rr = M8::from_bits(rr);
            let q = F8::select(rr, m.min(b(0.95)), b(1.0));
            let goes_on = m.gt(b(0.0)) & (!rr | u_rr.lt(q));
            for c in 0..C {
                p.beta[c] = (beta[c] / q).store();
            }
            p.alive &= goes_on.bits();
            p.ray.tmin = [0.0; L];
            p.ray.tmax = [f32::INFINITY; L];
            p.ray.skip[0] = hit.plane;
            for l in 0..L {
                p.depth[l] += 1;
            }
        }
    }
}

impl PathPacket<'_> {
    /// The geometric normal of primitive `prim` at its point `x` (a sphere's varies).
    #[inline(always)]
    fn geometric_normal(&self, prim: usize, x: Vec3A) -> Vec3A {
        match self.smooth[prim] {
            Smooth::Sphere { center, .. } => (x - Vec3A::from(center)).normalize(),
            Smooth::Triangle { .. } => self.surfaces[prim].ng.into(),
        }
    }

    /// Each ray's closest hit, distance and primitive (`u32::MAX` for none). In a [`Split`]
    /// scene, a ray leaving a primitive of the tree starts off it ([`offset_origin`]; its origin
    /// in `ray` is moved there), and the packet's closest hit bounds its way through the tree.
    #[inline(always)]
    fn closest(&self, ray: &mut Packet) -> (F, U) {
        let split = match &self.geometry {
            Geometry::Packet(g) => return g.closest(ray),
            Geometry::Split(s) => s,
        };
        for l in 0..L {
            let from = ray.skip[0][l];
            if from != NO_PLANE && split.off_packet[from as usize] {
                let d = lane(&ray.d, l);
                let o = lane(&ray.o, l);
                let o = offset_origin(o, self.geometric_normal(from as usize, o), d);
                for a in 0..3 {
                    ray.o[a][l] = o[a];
                }
            }
        }
        let (mut t, mut prim) = split.packet.closest(ray);
        if !split.balls.is_empty() {
            split.balls.closest(ray, &mut t, &mut prim);
        }
        let Some(tree) = &split.tree else {
            return (t, prim);
        };
        // The lanes whose rays may meet the tree before their hit so far.
        let tmax: F = std::array::from_fn(|l| ray.tmax[l].min(t[l]));
        let mut left = may_meet_box(ray, &tmax, &split.bounds, u8::MAX as u32);
        while left != 0 {
            let l = left.trailing_zeros() as usize;
            left &= left - 1;
            let (o, d) = (lane(&ray.o, l), lane(&ray.d, l));
            if let Some(hit) = tree.intersect(o, d, ray.tmin[l], tmax[l]) {
                (t[l], prim[l]) = (hit.t, split.tree_prims[hit.prim as usize]);
            }
        }
        (t, prim)
    }

    /// The shadow rays of the lanes `lanes` (bit per lane) from a surface point to a point of
    /// another surface (origin and `o + tmax d`) that meet nothing between, as bits. In a
    /// [`Split`] scene, those the packet leaves open go through the tree as
    /// [`Scene::visible_to`]'s: off the first surface, short of the second, neither's plane tested.
    #[inline(always)]
    fn unoccluded(&self, r: &Packet, lanes: u32) -> u32 {
        let split = match &self.geometry {
            Geometry::Packet(g) => return g.unoccluded(r, lanes),
            Geometry::Split(s) => s,
        };
        let mut open = split.packet.unoccluded(r, lanes);
        // The lanes whose segments may meet the tree (by the segments as given, in the box padded
        // for their moved ends), and those that take the segments as moved ([`segment_from`],
        // as [`Scene::visible_to`]'s: off the first surface, short of the second).
        let near_tree = match split.tree {
            Some(_) => may_meet_box(r, &r.tmax, &split.shadow_bounds, open),
            None => 0,
        };
        let moved = if split.balls.is_empty() {
            near_tree
        } else {
            open
        };
        let mut seg = Packet::default();
        let mut left = moved;
        while left != 0 {
            let l = left.trailing_zeros() as usize;
            left &= left - 1;
            let x = lane(&r.o, l);
            let from = r.skip[0][l] as usize;
            let y = x + lane(&r.d, l) * r.tmax[l];
            let (o, w, tmax) = segment_from(x, self.geometric_normal(from, x), y);
            for a in 0..3 {
                (seg.o[a][l], seg.d[a][l]) = (o[a], w[a]);
            }
            seg.tmax[l] = tmax;
        }
        if open != 0 && !split.balls.is_empty() {
            open = split.balls.unoccluded(&seg, open);
        }
        let Some(tree) = &split.tree else {
            return open;
        };
        let mut left = near_tree & open;
        while left != 0 {
            let l = left.trailing_zeros() as usize;
            left &= left - 1;
            // (A plane key is a triangle of that plane, or the tree's primitive itself.)
            let (from, to) = (r.skip[0][l] as usize, r.skip[1][l] as usize);
            let plane = |prim: usize| tree.plane_of(split.prim_shape[prim]);
            let (o, w) = (lane(&seg.o, l), lane(&seg.d, l));
            if !tree.unoccluded(o, w, 0.0, seg.tmax[l], [plane(from), plane(to)]) {
                open &= !(1 << l);
            }
        }
        open
    }

    /// The light part each lane samples next (its bounce's first number is `dim`): the first
    /// whose cumulative probability exceeds the lane's number, gathered into lanes; the only one
    /// in every lane where the lights are one part (a rectangle), and no number drawn.
    #[inline(always)]
    fn light_lanes<const C: usize>(&self, p: &Paths<C>, dim: U) -> LightLanes<C> {
        let b = F8::splat;
        let Target::Lights { parts, cdf } = &self.target else {
            unreachable!("light parts are sampled in line of sight only");
        };
        if let [part] = &parts[..] {
            return part_lanes(part);
        }
        let pick = F8::load(&p.uniforms(dim, LIGHT_PICK));
        let chosen = (cdf[..parts.len() - 1].iter())
            .fold(b(0.0), |i, &c| {
                i + F8::select(b(c).le(pick), b(1.0), b(0.0))
            })
            .store();
        let (mut v0, mut e1, mut e2) = ([[0.0; L]; 3], [[0.0; L]; 3], [[0.0; L]; 3]);
        let (mut n, mut ng) = ([[0.0; L]; 3], [[0.0; L]; 3]);
        let (mut plane, mut area_pdf, mut radiance) = ([0.0; L], [0.0; L], [[0.0; L]; C]);
        let (mut quad, mut emitter) = (0, [u32::MAX; L]);
        for l in 0..L {
            let part = &parts[chosen[l] as usize];
            for a in 0..3 {
                (v0[a][l], e1[a][l], e2[a][l]) = (part.v0[a], part.e1[a], part.e2[a]);
                (n[a][l], ng[a][l]) = (part.surface.n[a], part.surface.ng[a]);
            }
            for c in 0..C {
                radiance[c][l] = part.emitter.radiance[c];
            }
            (plane[l], area_pdf[l]) = (part.surface.plane, part.emitter.area_pdf);
            (quad, emitter[l]) = (quad | (part.quad as u32) << l, part.surface.emitter);
        }
        let lanes = |a: [F; 3]| a.each_ref().map(F8::load);
        LightLanes {
            v0: lanes(v0),
            e1: lanes(e1),
            e2: lanes(e2),
            quad: M8::from_bits(quad),
            n: lanes(n),
            ng: lanes(ng),
            plane: F8::load(&plane),
            radiance: radiance.each_ref().map(F8::load),
            area_pdf: F8::load(&area_pdf),
            emitter,
        }
    }

    /// The weights of the mirror reflections of the lanes `lanes` (bit per lane, on the
    /// `conductor`s `prim`, met at the cosines `cos_i`): the Fresnel reflectance times the
    /// specular reflectance ([`crate::bsdf::conductor::Conductor::sample`]), into `weight`.
    #[inline(never)]
    fn mirror_weights<const C: usize>(&self, lanes: u32, prim: &U, cos_i: &F, w: &mut [F; C]) {
        let mut left = lanes;
        while left != 0 {
            let l = left.trailing_zeros() as usize;
            left &= left - 1;
            let s = &self.surfaces[prim[l] as usize];
            let Some([eta, k]) = self.conductors.get(s.conductor as usize) else {
                continue;
            };
            let f = crate::bsdf::fresnel::conductor(cos_i[l], (*eta).into(), (*k).into());
            for c in 0..C {
                w[c][l] = f[c] * s.albedo[0][c];
            }
        }
    }

    /// The lanes of `lanes` on rough conductors and rough plastics ([`Self::rough`]), as bits, and
    /// each one's rough BSDF (its shape's, `shape`).
    #[inline(always)]
    fn rough_lanes(&self, lanes: u32, shape: &U) -> (u32, [Option<&Rough>; L]) {
        let (mut bits, mut rough) = (0, [None; L]);
        for l in 0..L {
            if lanes >> l & 1 != 0 {
                rough[l] = self.rough[shape[l] as usize].as_ref();
                bits |= (rough[l].is_some() as u32) << l;
            }
        }
        (bits, rough)
    }

    /// Next-event estimates of the lanes `lanes` on general surfaces (`shape`; their normals,
    /// the directions they were reached along and those to their light points, at squared
    /// distances `r2`, leaving the light at the cosines `cos_l`; the light's density per area,
    /// normal and radiance), as
    /// [`super::path`]'s and [`super::nlos`]'s light samples make them: the BSDF's f·cos, and
    /// for an area light the weight against the BSDF's own density; into `lit`. Returns the
    /// lanes lit (a bit per lane).
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn general_lights<const C: usize>(
        &self,
        lanes: u32,
        shape: &U,
        [n, d, w]: [[F; 3]; 3],
        [r2, cos_l, area_pdf]: [F; 3],
        (ng, radiance): ([F; 3], [F; C]),
        spot: bool,
        beta: &[F; C],
        lit: &mut [F; C],
    ) -> u32 {
        let (mut left, mut bits) = (lanes, 0);
        while left != 0 {
            let l = left.trailing_zeros() as usize;
            left &= left - 1;
            let bsdf = &self.bsdfs[shape[l] as usize];
            let (ns, wi, wo) = (lane(&n, l), -lane(&d, l), lane(&w, l));
            if bsdf.is_delta() {
                continue;
            }
            let weight;
            let f = if spot {
                weight = cos_l[l] / r2[l];
                bsdf.eval(ns, wi, wo)
            } else {
                let (f, pdf) = bsdf.eval_pdf(ns, wi, wo);
                let light_pdf = r2[l] * area_pdf[l] / lane(&ng, l).dot(wo).abs();
                weight = mis(light_pdf, pdf) / light_pdf;
                f
            };
            let Some(f) = f else {
                continue;
            };
            for c in 0..C {
                lit[c][l] = beta[c][l] * f[c] * radiance[c][l] * weight;
            }
            bits |= 1 << l;
        }
        bits
    }

    /// BSDF sampling of the lanes `lanes` on general surfaces (`shape`, normal `n`, reached
    /// along `d`), each lane from a stream of its own sample and depth: their rays' directions,
    /// densities, deltas and indices of refraction into `p`, their weights into `weight`; a lane
    /// whose BSDF samples nothing ends.
    #[inline(never)]
    fn general_samples<const C: usize>(
        &self,
        lanes: u32,
        shape: &U,
        [n, d]: [[F; 3]; 2],
        p: &mut Paths<C>,
        weight: &mut [F; C],
    ) {
        let mut left = lanes;
        while left != 0 {
            let l = left.trailing_zeros() as usize;
            left &= left - 1;
            let mut rng = Sampler::new(p.key[l] as u64, p.depth[l] as u64, GENERAL_STREAM);
            let Some(s) = self.bsdfs[shape[l] as usize].sample(lane(&n, l), -lane(&d, l), &mut rng)
            else {
                p.alive &= !(1 << l);
                continue;
            };
            for a in 0..3 {
                p.ray.d[a][l] = s.wo[a];
            }
            for c in 0..C {
                weight[c][l] = s.weight[c];
            }
            p.bsdf_pdf[l] = s.pdf;
            p.delta = p.delta & !(1 << l) | (s.delta as u32) << l;
            p.eta[l] *= s.eta;
        }
    }

    /// `angulararea` lights' falloff on the light samples `lit` of the lanes in `lights`, which
    /// leave their emitters (`emitter`) at the cosines `cos_l`: the lanes it zeroes leave the
    /// mask (no shadow ray).
    #[inline(never)]
    fn fall_off<const C: usize>(&self, emitter: &U, cos_l: &F, lights: M8, lit: &mut [F; C]) -> M8 {
        let mut bits = lights.bits();
        for l in 0..L {
            if bits >> l & 1 == 0 {
                continue;
            }
            let Some(f) = self.emitters[emitter[l] as usize].falloff else {
                continue;
            };
            let k = f.eval(cos_l[l]);
            if k == 0.0 {
                bits &= !(1 << l);
            }
            for c in lit.iter_mut() {
                c[l] *= k;
            }
        }
        M8::from_bits(bits)
    }

    /// Emission found by the lanes' rays at their hits (`prim` at distance `t`, met at the cosine
    /// `cos_front` with the front's normal) on area lights: a camera ray's taken whole (unless
    /// `discard_direct_light`), BSDF sampling's weighted against the light sample that could have
    /// found it.
    #[inline(always)]
    fn emission<const C: usize, const GLASS: bool>(
        &self,
        p: &Paths<C>,
        hit: &Lanes<C>,
        prim: &U,
        t: &F,
        cos_front: &F,
        out: &mut impl FnMut(Splat),
    ) {
        for l in 0..L {
            let k = hit.emitter[l];
            if p.alive >> l & 1 == 0
                || k == u32::MAX
                || cos_front[l] <= 0.0
                || (p.depth[l] == 0 && self.rules.discard_direct_light)
            {
                continue;
            }
            let e = &self.emitters[k as usize];
            let w = if p.depth[l] == 0 || (GLASS && p.delta >> l & 1 != 0) {
                1.0
            } else {
                // The density of the light sample that could have found this point: its
                // cosine is the geometric normal's.
                let ng = &self.surfaces[prim[l] as usize].ng;
                let d = &p.ray.d;
                let cos_g = (ng[0] * d[0][l] + ng[1] * d[1][l] + ng[2] * d[2][l]).abs();
                let light_pdf = if cos_g > 0.0 {
                    t[l] * t[l] * e.area_pdf / cos_g
                } else {
                    0.0
                };
                mis(p.bsdf_pdf[l], light_pdf)
            };
            let k = e.falloff.map_or(1.0, |f| f.eval(cos_front[l]));
            if k == 0.0 {
                continue;
            }
            let mut v = [0.0; C];
            for c in 0..C {
                v[c] = p.beta[c][l] * e.radiance[c] * w * k;
            }
            out(splat(p.opl[l], v));
        }
    }
}

/// The light part `part` in every lane.
#[inline(always)]
fn part_lanes<const C: usize>(part: &LightPart) -> LightLanes<C> {
    let b = F8::splat;
    LightLanes {
        v0: part.v0.map(b),
        e1: part.e1.map(b),
        e2: part.e2.map(b),
        quad: M8::from_bits(if part.quad { u32::MAX } else { 0 }),
        n: part.surface.n.map(b),
        ng: part.surface.ng.map(b),
        plane: b(part.surface.plane),
        radiance: std::array::from_fn(|c| b(part.emitter.radiance[c])),
        area_pdf: b(part.emitter.area_pdf),
        emitter: [part.surface.emitter; L],
    }
}

/// What the lanes hit, by lane: normal, albedo (front and back), plane key and emitter.
struct Lanes<const C: usize> {
    n: [F; 3],
    albedo: [[F; C]; 2],
    plane: F,
    emitter: U,
}

impl<const C: usize> Default for Lanes<C> {
    fn default() -> Self {
        Self {
            n: [[0.0; L]; 3],
            albedo: [[[0.0; L]; C]; 2],
            plane: [NO_PLANE; L],
            emitter: [u32::MAX; L],
        }
    }
}

/// The paths of the lanes between bounces, by lane.
struct Paths<const C: usize> {
    /// A bit per lane whose path goes on.
    alive: u32,
    /// The lane's sample key ([`lane_uniform`]).
    key: U,
    depth: U,
    /// The rays to trace next (each skipping its origin's plane).
    ray: Packet,
    beta: [F; C],
    opl: [f64; L],
    /// Density with which BSDF sampling chose the ray (for MIS on the emission it finds).
    bsdf_pdf: F,
    /// A bit per lane whose ray a delta (glass) chose: the emission it finds is taken whole.
    delta: u32,
    /// Relative index of refraction of the medium the lane's path is in.
    eta: F,
}

impl<const C: usize> Default for Paths<C> {
    fn default() -> Self {
        Self {
            alive: 0,
            key: [0; L],
            depth: [0; L],
            ray: Packet {
                skip: [[NO_PLANE; L]; 2],
                ..Packet::default()
            },
            beta: [[0.0; L]; C],
            opl: [0.0; L],
            bsdf_pdf: [0.0; L],
            delta: 0,
            eta: [1.0; L],
        }
    }
}

impl<const C: usize> Paths<C> {
    /// The lanes `fresh` (bit per lane, their keys set) begin a sample with the camera rays
    /// `o + t d`, t in (tmin, tmax), of their lanes.
    #[inline(always)]
    fn start(&mut self, fresh: u32, o: [f32; 3], d: [F8; 3], tmin: F8, tmax: F8) {
        self.alive |= fresh;
        let (d, tmin, tmax) = (d.map(F8::store), tmin.store(), tmax.store());
        let mut left = fresh;
        while left != 0 {
            let l = left.trailing_zeros() as usize;
            left &= left - 1;
            self.depth[l] = 0;
            self.ray.skip[0][l] = NO_PLANE;
            for a in 0..3 {
                self.ray.o[a][l] = o[a];
                self.ray.d[a][l] = d[a][l];
            }
            (self.ray.tmin[l], self.ray.tmax[l]) = (tmin[l], tmax[l]);
            for c in 0..C {
                self.beta[c][l] = 1.0;
            }
            self.opl[l] = 0.0;
            self.bsdf_pdf[l] = 0.0;
            self.eta[l] = 1.0;
        }
    }

    /// Each lane's random number `slot` of the bounce whose first is `dim`.
    #[inline(always)]
    fn uniforms(&self, dim: U, slot: u32) -> F {
        let mut u = [0.0; L];
        for l in 0..L {
            u[l] = lane_uniform(self.key[l], dim[l] + slot);
        }
        u
    }
}

/// The shading normal of each lane of `lanes` (bit per lane) at its hit `x` on primitive `prim`:
/// a triangle's interpolated from its vertex normals, a sphere's along x − centre, normalised
/// (as [`crate::scene::Scene::surface_point`] does); the other lanes' are not read.
#[inline(always)]
fn interpolated_normals(smooth: &[Smooth], prim: &U, lanes: u32, x: &[F8; 3]) -> [F8; 3] {
    let (mut bary, mut vn) = ([[[0.0; L]; 4]; 2], [[[0.0; L]; 3]; 3]);
    let mut spheres = 0u32;
    let mut left = lanes;
    while left != 0 {
        let l = left.trailing_zeros() as usize;
        left &= left - 1;
        match &smooth[prim[l] as usize] {
            Smooth::Triangle { bary: m, n } => {
                for k in 0..2 {
                    for a in 0..4 {
                        bary[k][a][l] = m[k][a];
                    }
                }
                for k in 0..3 {
                    for a in 0..3 {
                        vn[k][a][l] = n[k][a];
                    }
                }
            }
            Smooth::Sphere { .. } => spheres |= 1 << l,
        }
    }
    let b1 = aff(&bary[0], x, F8::load(&bary[0][3]));
    let b2 = aff(&bary[1], x, F8::load(&bary[1][3]));
    let mut n = [F8::splat(0.0); 3];
    for a in 0..3 {
        n[a] = F8::load(&vn[0][a]) + b1 * F8::load(&vn[1][a]) + b2 * F8::load(&vn[2][a]);
    }
    // A sphere's lanes: x − centre.
    if spheres != 0 {
        let (mut out, xs) = (n.map(F8::store), x.map(F8::store));
        let mut left = spheres;
        while left != 0 {
            let l = left.trailing_zeros() as usize;
            left &= left - 1;
            if let Smooth::Sphere { center, sign } = &smooth[prim[l] as usize] {
                for a in 0..3 {
                    out[a][l] = (xs[a][l] - center[a]) * sign;
                }
            }
        }
        n = out.map(|a| F8::load(&a));
    }
    let len = dot(&n, &n).sqrt();
    for c in &mut n {
        *c = *c / len;
    }
    n
}

/// Lane `l` of the vector `v` (by axis, then lane).
#[inline(always)]
fn lane(v: &[F; 3], l: usize) -> Vec3A {
    Vec3A::new(v[0][l], v[1][l], v[2][l])
}

/// a·x + w lane by lane, for the map `m` = (a, w) given by lanes (its w as `w`).
#[inline(always)]
fn aff(m: &[F; 4], x: &[F8; 3], w: F8) -> F8 {
    let a = [F8::load(&m[0]), F8::load(&m[1]), F8::load(&m[2])];
    a[2].mul_add(x[2], a[1].mul_add(x[1], a[0].mul_add(x[0], w)))
}

/// A smooth dielectric's sample, lane by lane.
struct DielectricSample {
    /// The new direction.
    d: [F8; 3],
    /// Reflected (else refracted).
    reflected: M8,
    /// The weight's scale beyond the tint: 1 reflected, (η_t/η_i)⁻² refracted.
    scale: F8,
    /// The factor on the path's relative index: 1 reflected, η_it refracted.
    eta: F8,
}

/// Reflect or refract the rays `d` at glass of relative index `ior` (inside / outside) whose
/// normal is `n`, met at the cosine `cos_i` = n · (−d) (negative from inside), with the Fresnel
/// probability ([`crate::bsdf::fresnel::dielectric`]'s, lane by lane), reflecting where the
/// number `u` ≤ F — [`crate::bsdf::Dielectric`]'s sample.
#[inline(always)]
fn dielectric_sample(n: [F8; 3], d: [F8; 3], cos_i: F8, ior: F8, u: F8) -> DielectricSample {
    let b = F8::splat;
    let (f, cos_t, eta_it, eta_ti) = crate::bsdf::fresnel::dielectric(cos_i, ior);
    let reflected = u.le(f);
    let mut dir = [b(0.0); 3];
    for a in 0..3 {
        // wi = −d: the mirror direction 2 cos_i n − wi, and the refracted
        // −η_ti (wi − cos_i n) + cos_t n.
        let mirror = b(2.0) * cos_i * n[a] + d[a];
        let refracted = eta_ti * (d[a] + cos_i * n[a]) + cos_t * n[a];
        dir[a] = F8::select(reflected, mirror, refracted);
    }
    DielectricSample {
        d: dir,
        reflected,
        scale: F8::select(reflected, b(1.0), eta_ti * eta_ti),
        eta: F8::select(reflected, b(1.0), eta_it),
    }
}

/// a · b over the three axes, lane by lane.
#[inline(always)]
fn dot(a: &[F8; 3], b: &[F8; 3]) -> F8 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `v` in the lanes' local frames (the tangents `frame`, then the normal `n`), as `Frame::to_local`
/// takes it.
#[inline(always)]
fn local(frame: &[[F8; 3]; 2], n: &[F8; 3], v: [F8; 3]) -> [F8; 3] {
    [dot(&v, &frame[0]), dot(&v, &frame[1]), dot(&v, n)]
}

/// The power heuristic ([`mis`]) lane by lane.
#[inline(always)]
fn mis_lanes(a: F8, b: F8) -> F8 {
    let (a2, b2) = (a * a, b * b);
    let sum = a2 + b2;
    F8::select(sum.gt(F8::splat(0.0)), a2 / sum, F8::splat(0.0))
}

/// A splat of `C` channels (mono fills all three, as a mono spectrum is).
#[inline(always)]
fn splat<const C: usize>(opl: f64, v: [f32; C]) -> Splat {
    let value = if C == 1 {
        Spectrum::splat(v[0])
    } else {
        Spectrum::new(v[0], v[1 % C], v[2 % C])
    };
    Splat {
        slot: 0,
        opl,
        value,
    }
}
