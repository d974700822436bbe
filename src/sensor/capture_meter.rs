//! `nlos_capture_meter` (mitransient-model §1): the SPAD of an NLOS capture, nested in the relay
//! wall. It looks from `sensor_origin` through each scan point of the wall; in tal's confocal scan
//! (`original_film_width/height`, a 1×1 film) through the one point the laser is aimed at.

use super::Meter;
use crate::error::{NlosError, Result};
use crate::props::Props;
use glam::Vec3A;

impl Meter {
    /// An `nlos_capture_meter` (nested in the relay wall).
    pub fn from_capture_meter(p: &Props) -> Result<Self> {
        let o = p.vec3("sensor_origin", [0.0; 3])?;
        let mut meter = Self::from_sensor(p, Vec3A::new(o[0] as f32, o[1] as f32, o[2] as f32))?;
        if p.has("account_first_and_last_bounces") {
            // tal still writes it here; mitransient 1.3.1 warns and ignores it, and so do we.
            p.bool("account_first_and_last_bounces", false)?;
            meter.warnings.push(
                "nlos_capture_meter: 'account_first_and_last_bounces' is deprecated and ignored here; set it on the transient_nlos_path integrator".to_string(),
            );
        }
        match (p.has("original_film_width"), p.has("original_film_height")) {
            (false, false) => {}
            (true, true) => {
                let w = p.int_in("original_film_width", 1, 1, 1 << 16)? as usize;
                let h = p.int_in("original_film_height", 1, 1, 1 << 16)? as usize;
                if (meter.film.width, meter.film.height) != (1, 1) {
                    return Err(NlosError::prop(
                        "nlos_capture_meter",
                        "original_film_width",
                        format!(
                            "tal's confocal scan needs a 1x1 film, got {}x{}",
                            meter.film.width, meter.film.height
                        ),
                    ));
                }
                meter.confocal_grid = Some((w, h));
            }
            _ => {
                return Err(NlosError::prop(
                    "nlos_capture_meter",
                    "original_film_width",
                    "give both original_film_width and original_film_height, or neither",
                ));
            }
        }
        for key in ["shutter_open", "shutter_close"] {
            // mitransient adds shutter_open (seconds) to the optical path (metres): a defect we do not copy.
            p.float(key, 0.0)?;
        }
        p.finish()?;
        Ok(meter)
    }
}
