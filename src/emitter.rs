//! Emitters: the NLOS laser (Mitsuba's `projector`) and the line-of-sight lights (`area`,
//! `point`) of `transient_path` scenes.

use crate::error::{NlosError, Result};
use crate::math::Transform;
use crate::props::{Colour, Props};
use glam::{DMat4, Vec3A};

/// Mitsuba's `projector` emitter, used as the NLOS laser (mitransient-model §1).
#[derive(Clone, Debug)]
pub struct Projector {
    /// `to_world` as given (origin = laser position, local +z = aiming direction).
    pub to_world: DMat4,
    /// Laser origin o_L.
    pub origin: Vec3A,
    /// Unit frame of the projector: local x, y and the optical axis z.
    pub axes: [Vec3A; 3],
    /// tan of the half field of view along local x and y.
    pub tan_half_fov: [f32; 2],
    /// Irradiance E (times `scale`).
    pub irradiance: Colour,
}

impl Projector {
    /// Read a `projector`.
    pub fn from_props(p: &Props) -> Result<Self> {
        if p.plugin != "projector" {
            return Err(NlosError::Scene(format!(
                "emitter '{}' is not supported in NLOS scenes: the laser must be a 'projector'",
                p.plugin
            )));
        }
        let irr = p.emission("irradiance", Colour::Uniform(1.0))?;
        let scale = p.float("scale", 1.0)?;
        if !(scale >= 0.0) {
            return Err(NlosError::prop(
                "projector",
                "scale",
                "must be non-negative",
            ));
        }
        let irradiance = irr.scaled(scale);
        // Laser power enters every contribution: keep it where single precision has headroom.
        if irradiance.spectrum(false).max_element() > 1e20 {
            return Err(NlosError::prop(
                "projector",
                "scale",
                "irradiance × scale must be at most 1e20",
            ));
        }
        let fov = p.float("fov", 30.0)?;
        if !(fov > 0.0 && fov < 180.0) {
            return Err(NlosError::prop(
                "projector",
                "fov",
                format!("must be in (0, 180) degrees, got {fov}"),
            ));
        }
        // A constant irradiance has aspect 1, so x, y, smaller and larger agree.
        let axis = p.string("fov_axis", "x")?;
        let t = (fov.to_radians() / 2.0).tan();
        let t = match axis.as_str() {
            "x" | "y" | "smaller" | "larger" => t,
            "diagonal" => t / 2f64.sqrt(),
            _ => {
                return Err(NlosError::prop(
                    "projector",
                    "fov_axis",
                    format!("unknown value '{axis}'"),
                ));
            }
        } as f32;
        let to_world = p.matrix("to_world")?;
        p.finish()?;
        let mut proj = Self {
            to_world,
            origin: Vec3A::ZERO,
            axes: [Vec3A::X, Vec3A::Y, Vec3A::Z],
            tan_half_fov: [t, t],
            irradiance,
        };
        proj.set_to_world(to_world)
            .map_err(|m| NlosError::prop("projector", "to_world", m))?;
        Ok(proj)
    }

    /// Re-aim the laser (as `mitr.nlos.focus_emitter_at_*` do).
    pub fn set_to_world(&mut self, m: DMat4) -> std::result::Result<(), String> {
        let t = Transform::from_dmat4(m).ok_or("must be an invertible affine 4x4 matrix")?;
        let axes = [Vec3A::X, Vec3A::Y, Vec3A::Z].map(|a| t.vector(a).normalize_or_zero());
        if axes.contains(&Vec3A::ZERO) {
            return Err("has a degenerate axis".into());
        }
        self.to_world = m;
        self.origin = t.point(Vec3A::ZERO);
        self.axes = axes;
        Ok(())
    }

    /// The projector's weight towards a world point p (Mitsuba `projector::sample_direction`):
    /// π·E/(z_l²·cos_e) inside the frustum, else zero; z_l is p's depth along the axis.
    pub fn weight_at(&self, p: Vec3A) -> f32 {
        let v = p - self.origin;
        let zl = v.dot(self.axes[2]);
        if zl <= 0.0 {
            return 0.0;
        }
        let (xl, yl) = (v.dot(self.axes[0]) / zl, v.dot(self.axes[1]) / zl);
        if xl.abs() > self.tan_half_fov[0] || yl.abs() > self.tan_half_fov[1] {
            return 0.0;
        }
        let cos_e = zl / v.length();
        std::f32::consts::PI / (zl * zl * cos_e)
    }

    /// The weight of a projector virtually re-aimed at p (confocal / exhaustive focusing, §3.5).
    pub fn focused_weight_at(&self, p: Vec3A) -> f32 {
        std::f32::consts::PI / (p - self.origin).length_squared()
    }
}

/// A light of a line-of-sight scene.
#[derive(Clone, Debug)]
pub enum Light {
    /// Mitsuba's `area` (uniform, one-sided radiance on the front of a shape), or mitransient's
    /// `angulararea` (the same radiance times an angular falloff).
    Area {
        /// Index of the emitting shape.
        shape: usize,
        /// Radiance.
        radiance: Colour,
        /// `angulararea`'s falloff with the angle from the surface normal.
        falloff: Option<AngularFalloff>,
    },
    /// Mitsuba's `point`: isotropic intensity (W/sr) at a position.
    Point {
        /// Position.
        position: Vec3A,
        /// Intensity.
        intensity: Colour,
    },
}

impl Light {
    /// Read a `point` light (`position` or `to_world`'s translation, `intensity`).
    pub fn point_from_props(p: &Props) -> Result<Self> {
        let intensity = p.emission("intensity", Colour::Uniform(1.0))?;
        let m = p.matrix("to_world")?;
        let position = if p.has("position") {
            let v = p.vec3("position", [0.0; 3])?;
            Vec3A::new(v[0] as f32, v[1] as f32, v[2] as f32)
        } else {
            m.transform_point3(glam::DVec3::ZERO).as_vec3a()
        };
        p.finish()?;
        Ok(Light::Point {
            position,
            intensity,
        })
    }

    /// Read an `area` or `angulararea` emitter nested in shape `shape`.
    pub fn area_from_props(p: &Props, shape: usize) -> Result<Self> {
        let radiance = p.emission("radiance", Colour::Uniform(1.0))?;
        let falloff = if p.plugin == "angulararea" {
            Some(AngularFalloff::from_props(p)?)
        } else {
            None
        };
        p.finish()?;
        Ok(Light::Area {
            shape,
            radiance,
            falloff,
        })
    }
}

/// mitransient's `angulararea` profile: full radiance within `beam_width` of the surface normal,
/// falling linearly in angle to zero at `cutoff_angle` (degrees; defaults 10 and `cutoff_angle`).
/// nlos_rs emits exactly this radiance whichever way a path finds the light; mitransient's
/// light sampling weights it by an extra 1/distance² (docs/compatibility.md).
#[derive(Clone, Copy, Debug)]
pub struct AngularFalloff {
    cutoff: f32,
    cos_cutoff: f32,
    cos_beam: f32,
    inv_transition: f32,
}

impl AngularFalloff {
    fn from_props(p: &Props) -> Result<Self> {
        let cutoff = p.float("cutoff_angle", 10.0)?;
        let beam = p.float("beam_width", cutoff)?;
        if !(cutoff > 0.0 && cutoff <= 90.0) {
            return Err(NlosError::prop(
                "angulararea",
                "cutoff_angle",
                format!("must be in (0, 90] degrees, got {cutoff}"),
            ));
        }
        if !(beam > 0.0 && beam <= cutoff) {
            return Err(NlosError::prop(
                "angulararea",
                "beam_width",
                format!("must be in (0, cutoff_angle] degrees, got {beam}"),
            ));
        }
        let (c, b) = (cutoff.to_radians() as f32, beam.to_radians() as f32);
        Ok(Self {
            cutoff: c,
            cos_cutoff: c.cos(),
            cos_beam: b.cos(),
            inv_transition: if c > b { 1.0 / (c - b) } else { f32::INFINITY },
        })
    }

    /// The factor on the radiance leaving at `cos_theta` from the normal.
    #[inline]
    pub fn eval(&self, cos_theta: f32) -> f32 {
        if cos_theta <= self.cos_cutoff {
            0.0
        } else if cos_theta >= self.cos_beam {
            1.0
        } else {
            (self.cutoff - cos_theta.clamp(-1.0, 1.0).acos()) * self.inv_transition
        }
    }
}
