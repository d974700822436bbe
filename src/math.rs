//! Small geometric utilities: Mitsuba-convention transforms, shading frames, spectra.

use crate::simd::Real;
use glam::{Affine3A, DMat4, DVec3, Vec3A};

/// Speed of light in m/s (`mitransient.utils.speed_of_light`).
pub const SPEED_OF_LIGHT: f64 = 299_792_458.0;

/// Colour triple; in `mono` renders all three lanes hold the same (luminance) value.
pub type Spectrum = Vec3A;

/// `dr.epsilon(Float32)`: the cosine threshold mitransient uses for hidden-geometry sampling.
pub const COS_EPS: f32 = 5.960_464_5e-8;

/// Mitsuba's `math::RayEpsilon<float>`: relative offset used to spawn rays off a surface.
pub const RAY_EPS: f32 = 8.940_697e-5;

/// Mitsuba's `math::ShadowEpsilon<float>`: a shadow ray stops this fraction short of its target.
pub const SHADOW_EPS: f32 = 8.940_697e-4;

/// Rec. 709 luminance, as Mitsuba's mono variants use to turn an RGB value into one channel.
pub fn luminance(rgb: [f64; 3]) -> f64 {
    0.212_671 * rgb[0] + 0.715_160 * rgb[1] + 0.072_169 * rgb[2]
}

/// Mitsuba's `Transform4f.translate(v)`.
pub fn translate(v: [f64; 3]) -> DMat4 {
    DMat4::from_translation(DVec3::from(v))
}

/// Mitsuba's `Transform4f.scale(v)`.
pub fn scale(v: [f64; 3]) -> DMat4 {
    DMat4::from_scale(DVec3::from(v))
}

/// Mitsuba's `Transform4f.rotate(axis, angle)`: right-handed rotation, angle in degrees.
pub fn rotate(axis: [f64; 3], angle_deg: f64) -> DMat4 {
    let axis = DVec3::from(axis);
    if axis.length_squared() == 0.0 {
        return DMat4::IDENTITY;
    }
    DMat4::from_axis_angle(axis.normalize(), angle_deg.to_radians())
}

/// Mitsuba's `Transform4f.look_at(origin, target, up)`: local +z points at the target, local
/// +x is `up × dir` ("left"), local +y completes the frame; the translation is the origin.
pub fn look_at(origin: [f64; 3], target: [f64; 3], up: [f64; 3]) -> Option<DMat4> {
    let (o, t, up) = (DVec3::from(origin), DVec3::from(target), DVec3::from(up));
    let dir = (t - o).try_normalize()?;
    let left = up.normalize_or_zero().cross(dir).try_normalize()?;
    let new_up = dir.cross(left);
    Some(DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        o.extend(1.0),
    ))
}

/// A 4×4 affine transform (`to_world`) in single precision, with its inverse and normal matrix.
#[derive(Clone, Copy, Debug)]
pub struct Transform {
    /// Local → world.
    pub m: Affine3A,
    /// World → local.
    pub inv: Affine3A,
}

impl Transform {
    /// From a double-precision matrix; `None` if it is singular or projective.
    pub fn from_dmat4(m: DMat4) -> Option<Self> {
        let rows_ok = m.row(3).abs_diff_eq(glam::DVec4::W, 1e-9);
        if !rows_ok || m.determinant().abs() < 1e-300 || !m.is_finite() {
            return None;
        }
        let a = Affine3A::from_mat4(m.as_mat4());
        Some(Self {
            m: a,
            inv: Affine3A::from_mat4(m.inverse().as_mat4()),
        })
    }
    /// Identity.
    pub const IDENTITY: Self = Self {
        m: Affine3A::IDENTITY,
        inv: Affine3A::IDENTITY,
    };
    /// Transform a point.
    pub fn point(&self, p: Vec3A) -> Vec3A {
        self.m.transform_point3a(p)
    }
    /// Transform a vector.
    pub fn vector(&self, v: Vec3A) -> Vec3A {
        self.m.transform_vector3a(v)
    }
    /// Transform a normal (inverse transpose), normalised.
    pub fn normal(&self, n: Vec3A) -> Vec3A {
        self.inv.matrix3.transpose().mul_vec3a(n).normalize()
    }
}

/// Orthonormal frame around a unit normal (Duff et al. 2017, "Building an orthonormal basis, revisited").
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// Tangent.
    pub s: Vec3A,
    /// Bitangent.
    pub t: Vec3A,
    /// Normal.
    pub n: Vec3A,
}

/// The tangent and bitangent of the frame whose z axis is the unit vector `n` (Duff et al. 2017,
/// "Building an orthonormal basis, revisited"), for an `f32` or for lanes of them (the same bits).
#[inline(always)]
pub fn frame_axes<T: Real>(n: [T; 3]) -> [[T; 3]; 2] {
    let k = T::from;
    let sign = n[2].signum();
    let a = k(-1.0) / (sign + n[2]);
    let b = n[0] * n[1] * a;
    [
        [k(1.0) + sign * n[0] * n[0] * a, sign * b, -sign * n[0]],
        [b, sign + n[1] * n[1] * a, -n[1]],
    ]
}

impl Frame {
    /// Frame whose z axis is `n`.
    pub fn new(n: Vec3A) -> Self {
        let [s, t] = frame_axes(n.to_array());
        Self {
            s: Vec3A::from_array(s),
            t: Vec3A::from_array(t),
            n,
        }
    }
    /// Local → world.
    pub fn to_world(&self, v: Vec3A) -> Vec3A {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
    /// World → local.
    pub fn to_local(&self, v: Vec3A) -> Vec3A {
        Vec3A::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
}
