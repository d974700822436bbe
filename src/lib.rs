//! # nlos_rs
//!
//! Transient light transport for non-line-of-sight (NLOS) imaging: a Rust re-implementation of
//! mitransient's `transient_nlos_path` (Royo et al. 2022) that takes the same scene descriptions and
//! returns the same arrays, with mitransient's defects corrected.
//!
//! Module map: [`props`] (scene description trees) → [`xml`] / dicts → [`scene`] (shapes, laser,
//! capture meter, camera) over [`geometry`] (primitives, BVH); [`emitter`] (laser, lights),
//! [`camera`] (perspective), [`capture`] (NLOS scan points, laser spots),
//! [`integrator`] (path sampling), [`film`] (time binning), [`render`] (parallel loop);
//! [`sampling`] and [`math`] underneath. `python` holds the PyO3 binding, nothing else.

#![warn(missing_docs)]

pub mod camera;
pub mod capture;
pub mod emitter;
pub mod error;
pub mod film;
pub mod geometry;
pub mod integrator;
pub mod math;
pub mod props;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod xml;

#[cfg(feature = "python")]
mod python;

pub use error::{NlosError, Result};
pub use render::{RenderOptions, Rendered, render};
pub use scene::Scene;
