//! Integrators: how one path sample of a pixel is traced and what it contributes. Each is a
//! [`Tracer`]: `transient_nlos_path(_rs)` is [`NlosTracer`] (with Hidden Geometry Rejection
//! Sampling in [`hgrs`], the mixture of hidden-geometry and BSDF sampling at hidden vertices in
//! [`hidden_mixture`], sample reuse across scan points in [`sample_reuse`], the directions
//! from a scan point that may meet anything in [`scan_cone`] and the shadow rays and traces
//! answered without tracing in [`clear_view`]), `transient_path`
//! is [`PathTracer`] (with its lockstep lanes for small Lambertian scenes in [`path_packet`]). The
//! render loop
//! (`render.rs`) only sees the trait; a new integrator is a new file here and a line in
//! `render::render`.

pub mod clear_view;
pub mod hgrs;
pub mod hidden_mixture;
pub mod nlos;
pub mod path;
pub mod path_packet;
pub mod sample_reuse;
pub mod scan_cone;
pub mod visibility_guide;

pub use nlos::NlosTracer;
pub use path::PathTracer;
pub use sample_reuse::shares_samples;

use crate::geometry::Interaction;
use crate::math::Spectrum;
use crate::sampling::Sampler;
use glam::Vec3A;

/// One contribution of a path: its value, optical path length and laser slot (exhaustive captures;
/// 0 otherwise). The film's splatter spreads it over time bins.
#[derive(Clone, Copy, Debug)]
pub struct Splat {
    /// Laser slot.
    pub slot: usize,
    /// Optical path length (scene units).
    pub opl: f64,
    /// Value.
    pub value: Spectrum,
}

/// A sampled next vertex of a path: where it is, how far, and the throughput weight of the step.
#[derive(Clone, Copy, Debug)]
pub struct Step {
    /// The next vertex.
    pub next: Interaction,
    /// Its distance from the current vertex.
    pub dist: f32,
    /// f·cos/pdf of the step (including any geometry term of an area-measure sample).
    pub weight: Spectrum,
    /// Relative index of refraction crossed (1 unless the step refracted).
    pub eta: f32,
}

/// A path at a surface vertex: where it is, the direction back along the path, its throughput and
/// the optical path length travelled so far.
#[derive(Clone, Copy, Debug)]
pub struct Vertex {
    /// The surface point.
    pub it: Interaction,
    /// Unit direction towards the previous vertex.
    pub wi: Vec3A,
    /// Throughput β.
    pub beta: Spectrum,
    /// Optical path length so far.
    pub opl: f64,
    /// Index of refraction of the medium the path is in (relative to where it started).
    pub eta: f32,
}

impl Vertex {
    /// The path state at `it`.
    #[inline]
    pub fn new(it: Interaction, wi: Vec3A, beta: Spectrum, opl: f64, eta: f32) -> Self {
        Self {
            it,
            wi,
            beta,
            opl,
            eta,
        }
    }
}

/// A path sampler for one pixel of a film.
pub trait Tracer: Sync {
    /// A path sample between [`Self::bounce`]s.
    type Path;

    /// Paths the render loop keeps in flight per thread: with more than one it advances them a
    /// bounce at a time in turn, each from its own stream, so that one path's work fills the
    /// cycles another waits on (a bounce's ray and shading depend on the one before, and one
    /// path alone leaves the core idle between them). Each pixel's samples are still drawn and
    /// added in sample order: the count changes no bits.
    const IN_FLIGHT: usize = 1;

    /// How many of the samples about to begin for `pixel`, at most `max` in a row, end at their
    /// first random numbers with nothing traced and nothing added but the
    /// [`Self::fixed_contributions`] (their first direction turned down by a cone,
    /// [`scan_cone`], or their first hidden vertex drawn onto a surface turned away). Their numbers are taken from `rng`, and none of the next sample's. The
    /// render loop asks before each [`Self::begin`] and finishes the samples counted at once.
    #[inline(always)]
    fn turned_down(&self, _pixel: usize, _rng: &mut Sampler, _max: u64) -> u64 {
        0
    }

    /// The lockstep render of this tracer's samples ([`path_packet`]), if it has one: the render
    /// loop then traces each run of a pixel's samples through it instead of path by path.
    fn packet(&self) -> Option<&path_packet::PathPacket<'_>> {
        None
    }

    /// The cone of `pixel` that turns its samples down by their first direction before anything
    /// is traced ([`Self::turned_down`]), for its lockstep render ([`Self::packet`]).
    fn first_cone(&self, _pixel: usize) -> Option<&scan_cone::ScanCone> {
        None
    }

    /// Start a path sample of `pixel` (row-major).
    fn begin(&self, pixel: usize, rng: &mut Sampler) -> Self::Path;

    /// Advance `path` by one bounce (or, for a tracer with one path in flight, to its end),
    /// passing every contribution to `out`; false once the path has ended.
    fn bounce(&self, path: &mut Self::Path, rng: &mut Sampler, out: &mut impl FnMut(Splat))
    -> bool;

    /// A light subpath shared by all pixels ([`sample_reuse`]); `()` for a tracer that never
    /// shares (`transient_path`).
    type Light: Send + Sync;

    /// Trace one light subpath into `light` (only called where [`shares_samples`] holds), reusing
    /// the storage of the subpath it held: a block's subpaths are traced into the same places
    /// pass after pass, so the render allocates none once the first pass has run.
    fn trace_light(&self, _rng: &mut Sampler, light: &mut Option<Self::Light>) {
        *light = None;
    }

    /// Complete a traced light subpath with what takes no randomness (an exhaustive capture's
    /// links to every laser point); called in parallel over a block's subpaths.
    fn link_light(&self, _light: &mut Self::Light) {}

    /// The contributions every sample (a path, or a light sample) adds to `pixel` unchanged,
    /// passed to `out` once: the paths that take no randomness when the pixel's first vertex
    /// takes none. [`Self::bounce`] and [`Self::connect_light`] leave out what this passes.
    fn fixed_contributions(&self, _pixel: usize, _out: &mut impl FnMut(Splat)) {}

    /// The first vertex of `pixel` for a tile of light samples: a camera's jittered one, drawn
    /// from the pixel's own stream `pixel_rng`, or the fixed scan point (which takes none); and
    /// to `out` the paths from it that use no light subpath and that [`Self::fixed_contributions`]
    /// does not pass (a jittered point's paths straight to the laser spots), which each sample
    /// of the tile adds. `None` if the pixel sees nothing.
    fn pixel_vertex(
        &self,
        _pixel: usize,
        _pixel_rng: &mut Sampler,
        _out: &mut impl FnMut(Splat),
    ) -> Option<Vertex> {
        None
    }

    /// Pass the contributions of one light sample (`light`, possibly empty) to pixel `pixel`
    /// through its first vertex `x` ([`Self::pixel_vertex`]), with what the pixel draws for the
    /// sample taken from its stream `rng` (after the tile's first vertex).
    fn connect_light(
        &self,
        _pixel: usize,
        _x: &Vertex,
        _light: Option<&Self::Light>,
        _rng: &mut Sampler,
        _out: &mut impl FnMut(Splat),
    ) {
    }
}

/// Russian roulette as Mitsuba does it: a path with zero throughput ends; from loop depth `rr_depth`
/// on it survives with probability q = min(max β · η², 0.95) and β is divided by q (η² undoes the
/// radiance scaling of refraction, so a path inside glass is not killed for it). Returns whether
/// the path goes on.
#[inline]
pub(crate) fn russian_roulette(
    beta: &mut Spectrum,
    eta: f32,
    depth: u32,
    rr_depth: u32,
    rng: &mut Sampler,
) -> bool {
    let m = beta.max_element() * (eta * eta);
    if !(m > 0.0) {
        return false;
    }
    if depth >= rr_depth {
        let q = m.min(0.95);
        if rng.next_1d() >= q {
            return false;
        }
        *beta /= q;
    }
    true
}
