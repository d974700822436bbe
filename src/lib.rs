//! # nlos_rs
//!
//! Transient light transport for non-line-of-sight (NLOS) imaging: mitransient's
//! `transient_nlos_path` (Royo et al. 2022) and `transient_path` re-implemented, taking the same
//! scene descriptions and returning the same arrays, with mitransient's defects corrected, plus the
//! techniques of Tienda Hernando 2023 (Hidden Geometry Rejection Sampling, temporal kernel density
//! estimation). docs/architecture.md walks through the flow; in dependency order:
//!
//! * [`math`], [`error`], [`sampling`], [`cache`]: transforms, spectra and frames; the one error
//!   type; random streams and warps; prefetch hints.
//! * [`props`] (a scene description as a property tree) ← [`xml`] (Mitsuba XML files).
//! * [`geometry`] (primitives, meshes, the BVH), [`bsdf`] (one file per BSDF), [`film`] (grid, time
//!   axis and the temporal kernels), [`emitter`] (laser, lights), [`sensor`] (capture meter, camera),
//!   [`settings`] (integrator parameter tables).
//! * [`scene`]: the loaded scene, built from props in `scene/build.rs`.
//! * [`capture`]: scan points and laser spots of an NLOS capture.
//! * [`integrator`]: the [`integrator::Tracer`]s (NLOS, HGRS, line of sight).
//! * [`render`]: the parallel loop that runs a tracer into a film, on a pool from [`parallel`].
//! * [`spad`]: what a SPAD records of a rendered transient (calibration, instrument response,
//!   photon noise, pile-up).
//!
//! `python` holds the PyO3 binding, which only converts.

#![warn(missing_docs)]

pub mod bsdf;
pub mod cache;
pub mod capture;
pub mod emitter;
pub mod error;
pub mod film;
pub mod geometry;
pub mod integrator;
pub mod math;
pub mod parallel;
pub mod props;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod sensor;
pub mod settings;
pub mod simd;
pub mod spad;
pub mod spectrum;
pub mod xml;

#[cfg(feature = "python")]
mod python;

pub use error::{NlosError, Result};
pub use render::{RenderOptions, Rendered, render};
pub use scene::Scene;
