//! Absolute calibration: how many photons a SPAD detects per unit of the rendered transient
//! (docs/sensor.md derives it).
//!
//! With laser sampling the renderer treats the laser spot as a Lambertian patch of unit area
//! lit by the irradiance E_spot = E · W(p_L) · cos θ_L (mitransient-model §3.4–3.5): a transient
//! value is the radiance leaving the scan point towards the sensor for that spot. A real laser
//! puts the energy of a pulse, Q = P / f_rep, into a spot of whatever size; radiance scales with
//! the spot's power, so one pulse gives a radiance (time-integrated, J m⁻² sr⁻¹ per bin) of
//! H · Q / (E_spot · 1 m²). The pixel collects it from its footprint A (at the scan point, whose
//! normal makes angle θ_s with the sensor) through an aperture of area A_ap at distance d:
//! energy = L · A · cos θ_s · A_ap / d². Divided by the photon energy h c / λ, times the detection
//! efficiency η and the number of pulses f_rep · exposure:
//!
//!   photons per unit = Q / E_spot · A cos θ_s A_ap / d² · η · f_rep · t_exp · λ / (h c).
//!
//! It is linear in the power, the exposure and the efficiency.

use super::{C, Layout, PLUGIN, Spad};
use crate::capture::Capture;
use crate::error::{NlosError, Result};
use crate::scene::Scene;
use crate::settings::CaptureType;
use std::sync::atomic::AtomicBool;

/// Planck's constant (J s).
const PLANCK: f64 = 6.626_070_15e-34;

/// Photons detected over the exposure per unit of rendered transient, per histogram
/// (scan point × laser slot, as in the transient).
pub fn photons_per_unit(scene: &Scene, spad: &Spad, layout: &Layout) -> Result<Vec<f64>> {
    let nlos = scene.nlos()?;
    if !nlos.settings.laser_sampling {
        return Err(NlosError::prop(
            PLUGIN,
            "nlos_laser_sampling",
            "photon counts are calibrated for laser sampling (the spot as a unit-area patch); render with nlos_laser_sampling=true",
        ));
    }
    nlos.relay_wall.ok_or_else(|| {
        NlosError::prop(
            PLUGIN,
            "sensor",
            "a capture measured by a perspective camera has no scan points to calibrate",
        )
    })?;
    if nlos.settings.capture_type == CaptureType::Exhaustive && layout.slots == 1 {
        return Err(NlosError::prop(
            PLUGIN,
            "exhaustive_scan",
            "an exhaustive capture without a laser axis sums every laser point into one histogram; render it with a laser axis",
        ));
    }
    let capture = Capture::new(scene, true, &AtomicBool::new(false))?;
    let aperture = std::f64::consts::PI * (0.5e-3 * spad.aperture_diameter_mm).powi(2);
    let pulse_energy = spad.laser_power_w / spad.rep_rate_hz;
    let photon_energy = PLANCK * C / (spad.wavelength_nm * 1e-9);
    let common = pulse_energy * spad.footprint_m2 * aperture * spad.efficiency * spad.periods()
        / photon_energy;
    let s = scene.meter.origin;
    let spot_irradiance = |k: usize| {
        let spot = &capture.spots[k];
        (spot.incident[0] * spot.it.ns.dot(spot.to_laser).max(0.0)) as f64
    };
    let mut out = Vec::with_capacity(layout.histograms);
    for (pixel, x) in capture.scan_points.iter().enumerate() {
        // What the pixel collects from its scan point: A cos θ_s A_ap / d² (zero if unseen).
        let geometry = x.map_or(0.0, |x| {
            let v = s - x.p;
            let d2 = v.length_squared() as f64;
            let cos = (x.ns.dot(v) as f64 / d2.sqrt()).max(0.0);
            cos / d2
        });
        for slot in 0..layout.slots {
            let spot = match nlos.settings.capture_type {
                CaptureType::Confocal => pixel,
                CaptureType::Single => 0,
                CaptureType::Exhaustive => slot,
            };
            let e = spot_irradiance(spot);
            out.push(if e > 0.0 { common * geometry / e } else { 0.0 });
        }
    }
    Ok(out)
}
