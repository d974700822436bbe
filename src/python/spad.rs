//! Binding of the SPAD capture model ([`crate::spad`]): converts the parameter dict and the arrays,
//! releases the GIL while the core works.

use super::{PyScene, bad, numbers};
use crate::spad::{self, Spad};
use numpy::{
    Element, PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict};

const PLUGIN: &str = "spad";

/// The model's parameters from a dict of `Spad` fields.
fn params(d: &Bound<'_, PyDict>) -> PyResult<Spad> {
    let mut s = Spad::default();
    for (k, v) in d.iter() {
        let key: String = k.extract()?;
        let num = || -> PyResult<f64> {
            if v.is_instance_of::<PyBool>() {
                return Err(bad(PLUGIN, &key, "must be a number, not a bool"));
            }
            v.extract::<f64>()
                .map_err(|_| bad(PLUGIN, &key, "must be a number"))
        };
        let field = match key.as_str() {
            "pulse_fwhm_ps" => &mut s.pulse_fwhm_ps,
            "jitter_fwhm_ps" => &mut s.jitter_fwhm_ps,
            "jitter_tail_ps" => &mut s.jitter_tail_ps,
            "laser_power_w" => &mut s.laser_power_w,
            "rep_rate_hz" => &mut s.rep_rate_hz,
            "wavelength_nm" => &mut s.wavelength_nm,
            "exposure_s" => &mut s.exposure_s,
            "efficiency" => &mut s.efficiency,
            "dark_count_rate_hz" => &mut s.dark_count_rate_hz,
            "ambient_rate_hz" => &mut s.ambient_rate_hz,
            "dead_time_ns" => &mut s.dead_time_ns,
            "afterpulse_prob" => &mut s.afterpulse_prob,
            "crosstalk_prob" => &mut s.crosstalk_prob,
            "aperture_diameter_mm" => &mut s.aperture_diameter_mm,
            "footprint_m2" => &mut s.footprint_m2,
            "pile_up" => {
                s.pile_up = v
                    .cast::<PyBool>()
                    .map_err(|_| bad(PLUGIN, &key, "must be True or False"))?
                    .is_true();
                continue;
            }
            "irf" => {
                s.irf = if v.is_none() {
                    None
                } else {
                    Some(numbers(&v).ok_or_else(|| {
                        bad(PLUGIN, &key, "must be a 1-D sequence of numbers (or None)")
                    })?)
                };
                continue;
            }
            _ => return Err(bad(PLUGIN, &key, "unknown parameter")),
        };
        *field = num()?;
    }
    Ok(s)
}

/// Check the parameters (a `SceneError` naming the key).
#[pyfunction]
pub fn spad_check(spad: &Bound<'_, PyDict>) -> PyResult<()> {
    Ok(params(spad)?.check()?)
}

/// Run `work` on the scene and model without the GIL; its output, shaped as the input `array`.
fn call<'py, T: Element, R: Element + Send>(
    py: Python<'py>,
    scene: &PyScene,
    spad: &Bound<'py, PyDict>,
    array: &PyReadonlyArrayDyn<'py, T>,
    work: impl FnOnce(&crate::Scene, &[T], &Spad) -> PyResult<Vec<R>> + Send,
) -> PyResult<Bound<'py, PyArrayDyn<R>>> {
    let (scene, spad, shape) = (scene.get(), params(spad)?, array.shape().to_vec());
    let data = array.as_slice()?;
    let out = py.detach(|| work(&scene, data, &spad))?;
    PyArray1::from_vec(py, out).reshape(shape)
}

/// Mean detections per bin (float64, the transient's shape).
#[pyfunction]
pub fn spad_expected_counts<'py>(
    py: Python<'py>,
    scene: &PyScene,
    transient: PyReadonlyArrayDyn<'py, f32>,
    spad: &Bound<'py, PyDict>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    call(py, scene, spad, &transient, |scene, h, spad| {
        Ok(spad::expected_counts(scene, h, spad)?)
    })
}

/// One noisy capture (int64, the transient's shape).
#[pyfunction]
pub fn spad_simulate<'py>(
    py: Python<'py>,
    scene: &PyScene,
    transient: PyReadonlyArrayDyn<'py, f32>,
    spad: &Bound<'py, PyDict>,
    seed: u64,
) -> PyResult<Bound<'py, PyArrayDyn<i64>>> {
    call(py, scene, spad, &transient, |scene, h, spad| {
        let counts = spad::simulate(scene, h, spad, seed)?;
        Ok(counts
            .into_iter()
            .map(|c| i64::try_from(c).unwrap_or(i64::MAX))
            .collect())
    })
}

/// Coates' pile-up correction of counts (float64, their shape).
#[pyfunction]
pub fn spad_coates<'py>(
    py: Python<'py>,
    scene: &PyScene,
    counts: PyReadonlyArrayDyn<'py, i64>,
    spad: &Bound<'py, PyDict>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    call(py, scene, spad, &counts, |scene, c, spad| {
        let c: Vec<u64> = c
            .iter()
            .map(|&v| u64::try_from(v).map_err(|_| bad(PLUGIN, "counts", "must be >= 0")))
            .collect::<PyResult<_>>()?;
        Ok(spad::coates(scene, &c, spad)?)
    })
}
