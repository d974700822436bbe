//! Binding of a render in parts ([`crate::render::render_part`] and [`crate::render::assemble`]):
//! what `nlos_rs.distributed` and `nlos_rs.render_to_file` send to workers and put back together.

use super::{Opts, PyScene, interruptible};
use crate::render::{self, Monitor, Part, Plan};
use numpy::{PyArray1, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A part's arrays: transient sums (float32) and steady sums (float64).
type PartArrays<'py> = (Bound<'py, PyArray1<f32>>, Bound<'py, PyArray1<f64>>);

fn plan_of(scene: &PyScene, options: &Opts) -> PyResult<(Plan, render::RenderOptions)> {
    let opts = options.core()?;
    Ok((Plan::new(&scene.get(), &opts)?, opts))
}

/// How a render splits: pixels, chunks per pixel, floats per pixel, shapes.
#[pyfunction]
pub fn render_plan<'py>(
    py: Python<'py>,
    scene: &PyScene,
    options: Opts,
) -> PyResult<Bound<'py, PyDict>> {
    let (plan, _) = plan_of(scene, &options)?;
    let d = PyDict::new(py);
    d.set_item("pixels", plan.pixels)?;
    d.set_item("chunks", plan.chunks)?;
    d.set_item("pixel_len", plan.pixel_len)?;
    d.set_item("spp", plan.spp)?;
    d.set_item("transient_shape", plan.transient_shape)?;
    d.set_item("steady_shape", plan.steady_shape)?;
    Ok(d)
}

/// The memory a render may allocate: `max_memory`, or 80 % of the memory available.
#[pyfunction]
#[pyo3(signature = (max_memory=None))]
pub fn memory_limit(max_memory: Option<u64>) -> u64 {
    render::memory_limit(max_memory)
}

/// Check that `pixels` pixels of the render's transient fit in the options' `max_memory`
/// (default: 80 % of the memory available); the `SceneError` names `render_to_file`.
#[pyfunction]
pub fn render_check_memory(scene: &PyScene, pixels: usize, options: Opts) -> PyResult<()> {
    let (plan, opts) = plan_of(scene, &options)?;
    Ok(plan.check_memory(&opts, plan.bytes(pixels), "the transient")?)
}

/// Raw sums of chunks [c0, c1) of pixels [p0, p1): (transient float32, steady float64), flat.
#[pyfunction]
pub fn render_part<'py>(
    py: Python<'py>,
    scene: &PyScene,
    pixels: (usize, usize),
    chunks: (u64, u64),
    options: Opts,
) -> PyResult<PartArrays<'py>> {
    let opts = options.core()?;
    let scene = scene.get();
    let monitor = Monitor::default();
    let part = interruptible(
        py,
        &monitor.cancel,
        || {
            render::render_part(
                &scene,
                &opts,
                pixels.0..pixels.1,
                chunks.0..chunks.1,
                &monitor,
            )
            .map_err(PyErr::from)
        },
        || Ok(()),
    )?;
    Ok((
        PyArray1::from_vec(py, part.transient),
        PyArray1::from_vec(py, part.steady),
    ))
}

/// The render's (transient, steady) values, flat, of the run of pixels that `parts` cover: a list
/// of ((p0, p1), (c0, c1), transient, steady) in pixel then chunk order.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub fn assemble<'py>(
    py: Python<'py>,
    scene: &PyScene,
    parts: Vec<(
        (usize, usize),
        (u64, u64),
        PyReadonlyArray1<'py, f32>,
        PyReadonlyArray1<'py, f64>,
    )>,
    options: Opts,
) -> PyResult<(Bound<'py, PyArray1<f32>>, Bound<'py, PyArray1<f32>>)> {
    let (plan, _) = plan_of(scene, &options)?;
    let parts: Vec<Part> = parts
        .into_iter()
        .map(|(p, c, t, s)| {
            Ok(Part {
                pixels: p.0..p.1,
                chunks: c.0..c.1,
                transient: t.as_slice()?.to_vec(),
                steady: s.as_slice()?.to_vec(),
                squares: Vec::new(),
            })
        })
        .collect::<PyResult<_>>()?;
    let a = py.detach(|| render::assemble(&plan, &parts))?;
    Ok((
        PyArray1::from_vec(py, a.transient),
        PyArray1::from_vec(py, a.steady),
    ))
}
