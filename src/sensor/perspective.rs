//! Mitsuba's `perspective` sensor (a pinhole), for line-of-sight `transient_path` renders.
//!
//! Film uv ∈ [0, 1]² maps to the camera-space direction ((1 − 2u)·tan(fov_x/2),
//! (1 − 2v)·tan(fov_x/2)/aspect, 1): uv (0, 0) is the top-left pixel, camera +x is "left" as in
//! Mitsuba's `look_at`. Rays start at the pinhole and are clipped to [near_clip, far_clip] along the
//! optical axis, as Mitsuba does.

use super::Meter;
use crate::error::{NlosError, Result};
use crate::geometry::Ray;
use crate::props::Props;
use crate::simd::Real;
use glam::{Vec2, Vec3A};

/// A pinhole camera.
#[derive(Clone, Debug)]
pub struct Camera {
    /// Pinhole position.
    pub origin: Vec3A,
    /// Unit camera axes in world space: x (left), y (up), z (forward).
    pub axes: [Vec3A; 3],
    /// tan of half the horizontal field of view.
    pub tan_half_fov_x: f32,
    /// Film width / height.
    pub aspect: f32,
    /// Near and far clip distances along the optical axis.
    pub clip: [f32; 2],
}

impl Camera {
    /// Read a `perspective` sensor with its sampler and film.
    pub fn from_props(p: &Props) -> Result<(Self, Meter)> {
        let plugin = "perspective";
        if p.has("focal_length") {
            return Err(NlosError::prop(
                plugin,
                "focal_length",
                "is not supported: give 'fov' (degrees) and 'fov_axis'",
            ));
        }
        if !p.has("fov") {
            return Err(NlosError::prop(plugin, "fov", "missing (degrees)"));
        }
        let fov = p.float("fov", 0.0)?;
        if !(fov > 0.0 && fov < 180.0) {
            return Err(NlosError::prop(
                plugin,
                "fov",
                format!("must be in (0, 180) degrees, got {fov}"),
            ));
        }
        let axis = p.string("fov_axis", "x")?;
        let near = p.float("near_clip", 1e-2)?;
        let far = p.float("far_clip", 1e4)?;
        if !(near > 0.0 && far > near) {
            return Err(NlosError::prop(
                plugin,
                "near_clip",
                "needs 0 < near_clip < far_clip",
            ));
        }
        p.float("focus_distance", 0.0)?; // a pinhole has no focus; accepted as Mitsuba does
        for key in ["shutter_open", "shutter_close"] {
            p.float(key, 0.0)?;
        }
        let to_world = p.transform("to_world")?;
        let meter = Meter::from_sensor(p, to_world.point(Vec3A::ZERO))?;
        let aspect = meter.film.width as f64 / meter.film.height as f64;
        // Mitsuba's fov_axis: which extent `fov` measures.
        let t = (fov.to_radians() / 2.0).tan();
        let tan_x = match axis.as_str() {
            "x" => t,
            "y" => t * aspect,
            "diagonal" => t / (1.0 + 1.0 / (aspect * aspect)).sqrt(),
            "smaller" => {
                if aspect > 1.0 {
                    t * aspect
                } else {
                    t
                }
            }
            "larger" => {
                if aspect > 1.0 {
                    t
                } else {
                    t * aspect
                }
            }
            other => {
                return Err(NlosError::prop(
                    plugin,
                    "fov_axis",
                    format!("unknown value '{other}'"),
                ));
            }
        };
        let axes = [Vec3A::X, Vec3A::Y, Vec3A::Z].map(|a| to_world.vector(a).normalize_or_zero());
        if axes.contains(&Vec3A::ZERO) {
            return Err(NlosError::prop(plugin, "to_world", "has a degenerate axis"));
        }
        let cam = Self {
            origin: to_world.point(Vec3A::ZERO),
            axes,
            tan_half_fov_x: tan_x as f32,
            aspect: aspect as f32,
            clip: [near as f32, far as f32],
        };
        Ok((cam, meter))
    }

    /// The ray through pixel `pixel` (row-major on a `width`×`height` film) at the offset
    /// `jitter` ∈ [0, 1)² within the pixel.
    #[inline]
    pub fn pixel_ray(&self, pixel: usize, width: usize, height: usize, jitter: Vec2) -> Ray {
        let (u, v) = pixel_uv(pixel, width, height, jitter.x, jitter.y);
        self.ray(Vec2::new(u, v))
    }

    /// [`Self::pixel_ray`]'s direction (by axis), tmin and tmax (the ray starts at
    /// [`Self::origin`]), for an `f32` jitter or lanes of them (one ray per lane, the same bits).
    #[inline(always)]
    pub fn pixel_ray_parts<T: Real>(
        &self,
        pixel: usize,
        width: usize,
        height: usize,
        jitter_x: T,
        jitter_y: T,
    ) -> ([T; 3], T, T) {
        let (u, v) = pixel_uv(pixel, width, height, jitter_x, jitter_y);
        self.ray_parts(u, v)
    }

    /// The ray through film position uv, clipped to (near, far).
    #[inline]
    pub fn ray(&self, uv: Vec2) -> Ray {
        let (d, tmin, tmax) = self.ray_parts(uv.x, uv.y);
        Ray {
            o: self.origin,
            d: Vec3A::from_array(d),
            tmin,
            tmax,
        }
    }

    /// [`Self::ray`]'s direction (by axis), tmin and tmax, for film positions in `f32` or lanes.
    #[inline(always)]
    fn ray_parts<T: Real>(&self, u: T, v: T) -> ([T; 3], T, T) {
        let k = T::from;
        let (lx, ly) = (
            (k(1.0) - k(2.0) * u) * k(self.tan_half_fov_x),
            (k(1.0) - k(2.0) * v) * k(self.tan_half_fov_x) / k(self.aspect),
        );
        let inv_len = k(1.0) / (lx * lx + ly * ly + k(1.0)).sqrt();
        // No closures here: lanes' arithmetic must inline into its `#[target_feature]` caller,
        // and a closure outside one is compiled without it.
        let [a, b, c] = self.axes;
        let d = [
            (k(a.x) * lx + k(b.x) * ly + k(c.x)) * inv_len,
            (k(a.y) * lx + k(b.y) * ly + k(c.y)) * inv_len,
            (k(a.z) * lx + k(b.z) * ly + k(c.z)) * inv_len,
        ];
        // Along a unit direction, the optical-axis depth is t·(z/|local|).
        (d, k(self.clip[0]) / inv_len, k(self.clip[1]) / inv_len)
    }
}

/// The film position of the offset (`jitter_x`, `jitter_y`) ∈ [0, 1)² within pixel `pixel`
/// (row-major on a `width`×`height` film).
#[inline(always)]
fn pixel_uv<T: Real>(
    pixel: usize,
    width: usize,
    height: usize,
    jitter_x: T,
    jitter_y: T,
) -> (T, T) {
    let k = T::from;
    (
        (k((pixel % width) as f32) + jitter_x) / k(width as f32),
        (k((pixel / width) as f32) + jitter_y) / k(height as f32),
    )
}
