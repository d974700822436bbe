//! The capture geometry of an `nlos_capture_meter` (mitransient-model §1, §3.1, §4): which
//! relay-wall point each pixel scans, where the laser spots are, and each spot's next-event
//! estimate towards the laser, which is the same for every path and so is computed once per render.

use crate::bsdf::Bsdf;
use crate::error::{NlosError, Result};
use crate::geometry::Interaction;
use crate::math::Spectrum;
use crate::parallel::map_indices;
use crate::scene::{Nlos, Scene};
use crate::settings::CaptureType;
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;
use std::sync::atomic::{AtomicBool, Ordering};

/// A laser spot p_L on the scene and its NEE to the laser: the light arriving there,
/// E · W(p_L) · V(p_L, o_L), and, for a Lambertian spot, the radiance it sends towards any vertex
/// above it, E · W(p_L) · ρ/π · cosθ(p_L → o_L) · V(p_L, o_L).
#[derive(Clone, Copy, Debug)]
pub struct Spot {
    /// The spot's surface point.
    pub it: Interaction,
    /// E · W(p_L) · V(p_L, o_L): zero where the laser does not reach.
    pub incident: Spectrum,
    /// Unit direction from the spot to the laser.
    pub to_laser: Vec3A,
    /// For a Lambertian spot, the radiance leaving it towards any vertex above it (before that
    /// vertex's cosine); `None` when it depends on the direction (evaluate the spot's BSDF).
    pub radiance: Option<Spectrum>,
    /// Optical path from the spot back to the laser, if it is accounted for (else 0).
    pub last_leg: f64,
    /// Whether the laser reaches a surface here at all.
    pub hit: bool,
}

impl Spot {
    /// A spot the laser cannot light (no surface there, or not visible from the laser).
    pub const DARK: Spot = Spot {
        it: Interaction {
            p: Vec3A::ZERO,
            ng: Vec3A::Z,
            ns: Vec3A::Z,
            shape: 0,
            prim: 0,
        },
        incident: Spectrum::ZERO,
        to_laser: Vec3A::Z,
        radiance: Some(Spectrum::ZERO),
        last_leg: 0.0,
        hit: false,
    };
}

/// Where a capture looks and where its laser shines.
pub struct Capture {
    /// First surface seen by the sensor through each pixel's scan point (row-major, y first).
    pub scan_points: Vec<Option<Interaction>>,
    /// Laser spots: one (single), one per pixel (confocal), one per laser grid point (exhaustive).
    pub spots: Vec<Spot>,
}

impl Capture {
    /// The scan points of `scene` and, with laser sampling, its laser spots (spectra for a mono or
    /// rgb render).
    pub fn new(scene: &Scene, mono: bool, cancel: &AtomicBool) -> Result<Self> {
        let scan_points = scan_points(scene)?;
        let spots = if scene.nlos()?.settings.laser_sampling {
            laser_spots(scene, &scan_points, mono, cancel)?
        } else {
            Vec::new()
        };
        Ok(Self { scan_points, spots })
    }
}

/// Scan points: pixel (x, y) looks at uv = ((x + ½)/W, (y + ½)/H) of the relay wall; the first
/// surface on the way from the sensor is the path's first vertex x₁ (exact pixel centres, unlike
/// mitransient: mitransient-model §5 item 4).
pub fn scan_points(scene: &Scene) -> Result<Vec<Option<Interaction>>> {
    let film = &scene.meter.film;
    let s = scene.meter.origin;
    let seen_through = |target: Vec3A| {
        let d = (target - s).normalize_or_zero();
        if d == Vec3A::ZERO {
            None
        } else {
            scene.intersect(s, d, f32::INFINITY).map(|h| h.1)
        }
    };
    let nlos = scene.nlos()?;
    if scene.meter.confocal_grid.is_some() {
        // tal's confocal scan: the one pixel looks where the laser is aimed.
        return Ok(vec![seen_through(nlos.laser_target)]);
    }
    if let Some(camera) = &nlos.camera {
        // A camera: the surface its pixel-centre ray sees (each sample jitters within the pixel).
        let (w, h) = (film.width, film.height);
        let points: Vec<_> = (0..w * h)
            .map(|i| {
                let r = camera.pixel_ray(i, w, h, Vec2::splat(0.5));
                scene
                    .accel
                    .intersect(r.o, r.d, r.tmin, r.tmax)
                    .map(|hit| scene.interaction(r.o, r.d, &hit))
            })
            .collect();
        return check_visible(points);
    }
    let w = film.width;
    let points = map_indices(w * film.height, |i| {
        let uv = Vec2::new(
            ((i % w) as f32 + 0.5) / w as f32,
            ((i / w) as f32 + 0.5) / film.height as f32,
        );
        Ok(seen_through(scene.relay_wall_point(uv)?.0))
    });
    check_visible(points.into_iter().collect::<Result<_>>()?)
}

fn check_visible(points: Vec<Option<Interaction>>) -> Result<Vec<Option<Interaction>>> {
    if points.iter().all(Option::is_none) {
        return Err(NlosError::prop(
            "nlos_capture_meter",
            "sensor_origin",
            "no scan point is visible from the sensor",
        ));
    }
    Ok(points)
}

/// The laser spots of the capture (one, one per scan point, or one per laser grid point).
pub fn laser_spots(
    scene: &Scene,
    scan_points: &[Option<Interaction>],
    mono: bool,
    cancel: &AtomicBool,
) -> Result<Vec<Spot>> {
    let nlos = scene.nlos()?;
    let (laser, settings) = (&nlos.laser, &nlos.settings);
    let lit = Illumination {
        scene,
        nlos,
        bsdfs: scene.shape_bsdfs(mono),
        irradiance: laser.irradiance.spectrum(mono),
    };
    let from_laser = |d: Vec3A| {
        scene
            .intersect(laser.origin, d.normalize(), f32::INFINITY)
            .map(|h| h.1)
    };
    // Confocal / equal-grid exhaustive: a spot at every scan point, the laser re-aimed at each.
    let at_scan_points = || -> Result<Vec<Spot>> {
        map_indices(scan_points.len(), |i| {
            if i % 4096 == 4095 && cancel.load(Ordering::Relaxed) {
                return Err(NlosError::Interrupted);
            }
            Ok(scan_points[i].map_or(Spot::DARK, |it| lit.spot(it, true)))
        })
        .into_iter()
        .collect()
    };
    Ok(match settings.capture_type {
        CaptureType::Single => {
            let it = from_laser(laser.axes[2]).ok_or_else(|| {
                NlosError::prop(
                    "projector",
                    "to_world",
                    "the laser does not point at the scene (its +z axis hits nothing)",
                )
            })?;
            vec![lit.spot(it, false)]
        }
        CaptureType::Confocal => at_scan_points()?,
        CaptureType::Exhaustive if settings.force_equal_illumination_scanning => at_scan_points()?,
        CaptureType::Exhaustive => {
            // A virtual projector with the emitter's frame scans an LW×LH grid of directions
            // (pixel-centred, Mitsuba's camera convention: uv (0,0) is local (+x, +y)).
            let (lw, lh) = scene.meter.film.laser_scan.unwrap_or((1, 1));
            let t = (settings.illumination_scan_fov.to_radians() / 2.0).tan() as f32;
            let mut spots = Vec::with_capacity(lw * lh);
            for ly in 0..lh {
                if cancel.load(Ordering::Relaxed) {
                    return Err(NlosError::Interrupted);
                }
                for lx in 0..lw {
                    let (u, v) = ((lx as f32 + 0.5) / lw as f32, (ly as f32 + 0.5) / lh as f32);
                    let d = laser.axes[0] * ((1.0 - 2.0 * u) * t)
                        + laser.axes[1] * ((1.0 - 2.0 * v) * t)
                        + laser.axes[2];
                    spots.push(from_laser(d).map_or(Spot::DARK, |it| lit.spot(it, true)));
                }
            }
            spots
        }
    })
}

/// What a spot's NEE needs.
struct Illumination<'a> {
    scene: &'a Scene,
    nlos: &'a Nlos,
    bsdfs: Vec<Bsdf<Spectrum>>,
    irradiance: Spectrum,
}

impl Illumination<'_> {
    /// The NEE from a spot to the laser (mitransient-model §3.5); `focused`: the laser re-aimed at it.
    fn spot(&self, it: Interaction, focused: bool) -> Spot {
        let laser = &self.nlos.laser;
        let w = laser.origin - it.p;
        let dist = w.length();
        let cos = it.ns.dot(w / dist);
        let weight = if focused {
            laser.focused_weight_at(it.p)
        } else {
            laser.weight_at(it.p)
        };
        let bsdf = &self.bsdfs[it.shape as usize];
        let visible =
            cos > 0.0 && weight > 0.0 && !bsdf.is_delta() && self.scene.visible(&it, laser.origin);
        let incident = if visible {
            self.irradiance * weight
        } else {
            Spectrum::ZERO
        };
        let radiance = bsdf.albedo().map(|rho| {
            if visible {
                self.irradiance * rho * (weight * FRAC_1_PI * cos)
            } else {
                Spectrum::ZERO
            }
        });
        let last_leg = if self.nlos.settings.account_first_and_last_bounces {
            dist as f64
        } else {
            0.0
        };
        Spot {
            it,
            incident,
            to_laser: w / dist,
            radiance,
            last_leg,
            hit: true,
        }
    }
}
