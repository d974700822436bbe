//! The capture geometry of an `nlos_capture_meter` (mitransient-nlos-spec §1.1, §3.1, §5): which
//! relay-wall point each pixel scans, where the laser spots are, and the spots' cached
//! next-event estimate towards the laser. Prepared once per render.

use crate::emitter::Projector;
use crate::error::{NlosError, Result};
use crate::geometry::{Interaction, shadow_segment};
use crate::integrator::{AreaSampler, CaptureType, NlosSettings};
use crate::math::Spectrum;
use crate::scene::Scene;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

/// A laser spot p_L on the scene and its NEE to the laser, which is the same for every path:
/// radiance = E · W(p_L) · ρ/π · cosθ(p_L → o_L) · V(p_L, o_L).
#[derive(Clone, Copy, Debug)]
pub struct Spot {
    /// The spot's surface point.
    pub it: Interaction,
    /// Radiance leaving the spot towards any vertex above it (before that vertex's cosine).
    pub radiance: Spectrum,
    /// Optical path from the spot back to the laser, if it is accounted for (else 0).
    pub last_leg: f64,
    /// Whether the laser reaches a surface here at all.
    pub hit: bool,
}

/// Everything a render needs beyond the scene: spectra for the chosen variant, the scan points,
/// the laser spots and the hidden-geometry distribution.
pub struct Capture<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its integrator settings.
    pub settings: &'a NlosSettings,
    /// Its laser.
    pub laser: &'a Projector,
    /// Reflectance of each BSDF.
    pub rho: Vec<Spectrum>,
    /// Laser irradiance (× scale).
    pub irradiance: Spectrum,
    /// First surface seen by the sensor through each pixel's scan point (row-major, y first).
    pub sensor_targets: Vec<Option<Interaction>>,
    /// Laser spots: one (single), one per pixel (confocal), one per laser grid point (exhaustive).
    pub spots: Vec<Spot>,
    /// Hidden-geometry distribution, if that sampling is on.
    pub hidden: Option<AreaSampler>,
    /// Output channels (1 mono, 3 rgb).
    pub channels: usize,
}

impl Spot {
    /// A spot the laser cannot light (no surface there, or not visible from the laser).
    pub const DARK: Spot = Spot {
        it: Interaction {
            p: Vec3A::ZERO,
            ng: Vec3A::Z,
            ns: Vec3A::Z,
            shape: 0,
        },
        radiance: Spectrum::ZERO,
        last_leg: 0.0,
        hit: false,
    };
}

impl<'a> Capture<'a> {
    /// Prepare a render of `scene` in mono or rgb.
    pub fn new(scene: &'a Scene, mono: bool) -> Result<Self> {
        let nlos = scene.nlos()?;
        let (settings, laser) = (&nlos.settings, &nlos.laser);
        let film = &scene.meter.film;
        let rho = scene
            .bsdfs
            .iter()
            .map(|b| b.reflectance.spectrum(mono))
            .collect();
        let irradiance = laser.irradiance.spectrum(mono);
        let s = scene.meter.origin;
        // Scan points: pixel (x, y) looks at uv = ((x + ½)/W, (y + ½)/H) of the relay wall; the first
        // surface on the way is the path's first vertex x1 (exact pixel centres: spec §7 item 6).
        let mut sensor_targets = Vec::with_capacity(film.width * film.height);
        for y in 0..film.height {
            for x in 0..film.width {
                let uv = Vec2::new(
                    (x as f32 + 0.5) / film.width as f32,
                    (y as f32 + 0.5) / film.height as f32,
                );
                let (target, _) = scene.relay_wall_point(uv)?;
                let d = (target - s).normalize_or_zero();
                sensor_targets.push(if d == Vec3A::ZERO {
                    None
                } else {
                    scene.intersect(s, d, f32::INFINITY).map(|h| h.1)
                });
            }
        }
        if sensor_targets.iter().all(Option::is_none) {
            return Err(NlosError::prop(
                "nlos_capture_meter",
                "sensor_origin",
                "no scan point is visible from the sensor origin",
            ));
        }
        let hidden = if settings.hidden_geometry_sampling {
            // Every shape but the relay wall (unless included) is hidden geometry (spec §3.1).
            let wall = nlos.relay_wall;
            Some(
                AreaSampler::new(scene, |s| settings.hgs_includes_relay_wall || s != wall)
                    .ok_or_else(|| {
                        NlosError::prop(
                            "transient_nlos_path",
                            "nlos_hidden_geometry_sampling",
                            "the scene has no hidden geometry to sample (zero total area)",
                        )
                    })?,
            )
        } else {
            None
        };
        let mut cap = Self {
            scene,
            settings,
            laser,
            rho,
            irradiance,
            sensor_targets,
            spots: Vec::new(),
            hidden,
            channels: if mono { 1 } else { 3 },
        };
        if settings.laser_sampling {
            cap.spots = cap.laser_spots()?;
        }
        Ok(cap)
    }

    /// The laser spots of the capture (one, one per scan point, or one per laser grid point).
    pub fn laser_spots(&self) -> Result<Vec<Spot>> {
        let (scene, film) = (self.scene, &self.scene.meter.film);
        let laser = self.laser;
        let from_laser = |d: Vec3A| {
            scene
                .intersect(laser.origin, d.normalize(), f32::INFINITY)
                .map(|h| h.1)
        };
        Ok(match self.settings.capture_type {
            CaptureType::Single => {
                let it = from_laser(laser.axes[2]).ok_or_else(|| {
                    NlosError::prop(
                        "projector",
                        "to_world",
                        "the laser does not point at the scene (its +z axis hits nothing)",
                    )
                })?;
                vec![self.spot(it, false)]
            }
            CaptureType::Confocal => self.scan_spots(),
            CaptureType::Exhaustive if self.settings.force_equal_illumination_scanning => {
                self.scan_spots()
            }
            CaptureType::Exhaustive => {
                // A virtual projector with the emitter's frame scans an LW×LH grid of directions
                // (pixel-centred, Mitsuba's camera convention: uv (0,0) is local (+x, +y)).
                let (lw, lh) = film.laser_scan.unwrap_or((1, 1));
                let t = (self.settings.illumination_scan_fov.to_radians() / 2.0).tan() as f32;
                let mut spots = Vec::with_capacity(lw * lh);
                for ly in 0..lh {
                    for lx in 0..lw {
                        let (u, v) = ((lx as f32 + 0.5) / lw as f32, (ly as f32 + 0.5) / lh as f32);
                        let d = laser.axes[0] * ((1.0 - 2.0 * u) * t)
                            + laser.axes[1] * ((1.0 - 2.0 * v) * t)
                            + laser.axes[2];
                        spots.push(from_laser(d).map_or(Spot::DARK, |it| self.spot(it, true)));
                    }
                }
                spots
            }
        })
    }

    /// Confocal / equal-grid exhaustive: a spot at every scan point, the laser re-aimed at each.
    fn scan_spots(&self) -> Vec<Spot> {
        self.sensor_targets
            .iter()
            .map(|t| t.map_or(Spot::DARK, |it| self.spot(it, true)))
            .collect()
    }

    /// The NEE from a spot to the laser (spec §3.5), cached.
    fn spot(&self, it: Interaction, focused: bool) -> Spot {
        let laser = self.laser;
        let w = laser.origin - it.p;
        let dist = w.length();
        let cos = it.ns.dot(w / dist);
        let weight = if focused {
            laser.focused_weight_at(it.p)
        } else {
            laser.weight_at(it.p)
        };
        let (o, d, tmax) = shadow_segment(&it, laser.origin);
        let visible = cos > 0.0 && weight > 0.0 && self.scene.accel.unoccluded(o, d, 0.0, tmax);
        let rho = self.rho[self.scene.shapes[it.shape as usize].bsdf];
        let radiance = if visible {
            self.irradiance * rho * (weight * FRAC_1_PI * cos)
        } else {
            Spectrum::ZERO
        };
        let last_leg = if self.settings.account_first_and_last_bounces {
            dist as f64
        } else {
            0.0
        };
        Spot {
            it,
            radiance,
            last_leg,
            hit: true,
        }
    }
}
