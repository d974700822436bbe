//! The PyO3 binding: converts Python values to the core's types and back, releases the GIL while
//! rendering, forwards progress and Ctrl-C, and maps [`crate::NlosError`]. No physics here.

mod parts;
mod spad;

use crate::error::NlosError;
use crate::props::{Props, Value};
use crate::render::{Monitor, RenderOptions, render as core_render, total_samples};
use glam::{DMat4, Vec2, Vec3A};
use numpy::{PyArray1, PyArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::{PyFileNotFoundError, PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::RecvTimeoutError;
use std::time::Duration;

create_exception!(
    nlos_rs,
    SceneError,
    PyValueError,
    "A scene description (dict, XML or mesh) is invalid."
);

impl From<NlosError> for PyErr {
    fn from(e: NlosError) -> PyErr {
        match e {
            NlosError::NotFound(_) => PyFileNotFoundError::new_err(short(&e.to_string())),
            NlosError::Interrupted => PyKeyboardInterrupt::new_err(e.to_string()),
            _ => SceneError::new_err(short(&e.to_string())),
        }
    }
}

/// A message cut to a few hundred characters (a value's repr can be megabytes).
fn short(s: &str) -> String {
    const MAX: usize = 300;
    match s.char_indices().nth(MAX) {
        Some((i, _)) => format!("{}… ({} characters)", &s[..i], s.chars().count()),
        None => s.to_string(),
    }
}

/// Run `work` on its own thread with the GIL released, waiting for its result while polling
/// Ctrl-C (and `tick`) every 100 ms; on an error from Python the shared cancel flag is set and the
/// work stops soon after.
fn interruptible<T: Send>(
    py: Python<'_>,
    cancel: &AtomicBool,
    work: impl FnOnce() -> PyResult<T> + Send,
    mut tick: impl FnMut() -> PyResult<()>,
) -> PyResult<T> {
    std::thread::scope(|s| {
        // The result comes back over a channel, so the wait ends the moment the work does.
        let (tx, mut rx) = std::sync::mpsc::sync_channel(1);
        let job = s.spawn(move || {
            let _ = tx.send(work());
        });
        let stop = |e: PyErr| {
            cancel.store(true, Ordering::Relaxed);
            e
        };
        loop {
            // (A receiver may move between threads but not be shared: it goes and comes back.)
            let got;
            (rx, got) = py.detach(move || {
                let got = rx.recv_timeout(Duration::from_millis(100));
                (rx, got)
            });
            match got {
                Ok(result) => {
                    tick().map_err(stop)?;
                    return result;
                }
                Err(RecvTimeoutError::Timeout) => {
                    tick().map_err(stop)?;
                    py.check_signals().map_err(stop)?;
                }
                // The worker dropped its sender without sending: it panicked.
                Err(RecvTimeoutError::Disconnected) => {
                    let _ = job.join();
                    return Err(SceneError::new_err(
                        "worker thread panicked (please report it)",
                    ));
                }
            }
        }
    })
}

/// Run scene building, turning a panic (a bug: every bad input must get its own error) into a
/// `SceneError` instead of a `PanicException` that `except Exception` would miss.
fn guarded<T>(f: impl FnOnce() -> crate::Result<T>) -> PyResult<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r.map_err(PyErr::from),
        Err(p) => {
            let what = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            Err(SceneError::new_err(short(&format!(
                "internal error while loading the scene (please report it): {what}"
            ))))
        }
    }
}

fn bad(plugin: &str, key: &str, msg: impl Into<String>) -> PyErr {
    NlosError::prop(plugin, key, msg).into()
}

fn numbers(v: &Bound<'_, PyAny>) -> Option<Vec<f64>> {
    let items: Vec<Bound<'_, PyAny>> = if let Ok(l) = v.cast::<PyList>() {
        l.iter().collect()
    } else if let Ok(t) = v.cast::<PyTuple>() {
        t.iter().collect()
    } else {
        return None;
    };
    items
        .iter()
        .map(|x| {
            if x.is_instance_of::<PyBool>() {
                None
            } else {
                x.extract::<f64>().ok()
            }
        })
        .collect()
}

/// Convert one dict value (already normalised by the Python layer: transforms and arrays are
/// nested lists).
fn value(plugin: &str, key: &str, v: &Bound<'_, PyAny>, depth: usize) -> PyResult<Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(Value::Bool(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return Ok(Value::Int(
            v.extract()
                .map_err(|_| bad(plugin, key, "integer out of range"))?,
        ));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(Value::Str(v.extract()?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let ty: String = match d.get_item("type")? {
            Some(t) => t
                .extract()
                .map_err(|_| bad(plugin, key, "'type' must be a string"))?,
            None => return Err(bad(plugin, key, "a nested dict needs a 'type'")),
        };
        return match ty.as_str() {
            "rgb" | "spectrum" => {
                let only = |k: &str| k == "type" || k == "value";
                for k in d.keys() {
                    let k: String = k.extract()?;
                    if !only(&k) {
                        return Err(bad(&ty, &k, "unreferenced property"));
                    }
                }
                let val = d
                    .get_item("value")?
                    .ok_or_else(|| bad(&ty, "value", "missing"))?;
                if let Ok(x) = val.extract::<f64>() {
                    return Ok(if ty == "rgb" {
                        Value::Rgb([x; 3])
                    } else {
                        Value::UniformSpectrum(x)
                    });
                }
                if ty == "spectrum" {
                    // [(wavelength, value), ...]
                    let pairs: Option<Vec<(f64, f64)>> = val.cast::<PyList>().ok().and_then(|l| {
                        l.iter()
                            .map(|p| match numbers(&p).as_deref() {
                                Some([w, v]) => Some((*w, *v)),
                                _ => None,
                            })
                            .collect()
                    });
                    return pairs.map(Value::Spectrum).ok_or_else(|| {
                        bad(
                            &ty,
                            "value",
                            "must be a number or a list of (wavelength, value) pairs",
                        )
                    });
                }
                match numbers(&val).as_deref() {
                    Some([r, g, b]) => Ok(Value::Rgb([*r, *g, *b])),
                    _ => Err(bad(&ty, "value", "must be a number or three numbers")),
                }
            }
            "ref" => {
                let id = d
                    .get_item("id")?
                    .ok_or_else(|| bad("ref", "id", "missing"))?;
                Ok(Value::Ref(
                    id.extract()
                        .map_err(|_| bad("ref", "id", "must be a string"))?,
                ))
            }
            _ => Ok(Value::Object(object(&ty, None, d, depth + 1)?)),
        };
    }
    if let Some(n) = numbers(v)
        && n.len() == 3
    {
        return Ok(Value::Vec3([n[0], n[1], n[2]]));
    }
    // A 4×4 matrix as nested lists.
    let rows: Option<Vec<Vec<f64>>> = v
        .cast::<PyList>()
        .ok()
        .and_then(|l| l.iter().map(|r| numbers(&r)).collect());
    if let Some(rows) = rows
        && rows.len() == 4
        && rows.iter().all(|r| r.len() == 4)
    {
        let flat: Vec<f64> = rows.concat();
        return Ok(Value::Matrix(DMat4::from_cols_slice(&flat).transpose()));
    }
    Err(bad(
        plugin,
        key,
        format!(
            "unsupported value {}",
            short(&v.repr().map(|r| r.to_string()).unwrap_or_default())
        ),
    ))
}

fn object(
    plugin: &str,
    id: Option<String>,
    d: &Bound<'_, PyDict>,
    depth: usize,
) -> PyResult<Props> {
    if depth > crate::xml::MAX_DEPTH {
        return Err(bad(
            plugin,
            "type",
            format!("objects nested more than {} deep", crate::xml::MAX_DEPTH),
        ));
    }
    let mut props = Props::new(plugin, id);
    let mut own_id = None;
    for (n, (k, v)) in d.iter().enumerate() {
        // A dict of 100,000 objects converts for a while: keep Ctrl-C working.
        if n % 1024 == 1023 {
            d.py().check_signals()?;
        }
        let key: String = k
            .extract()
            .map_err(|_| bad(plugin, "?", "dict keys must be strings"))?;
        match key.as_str() {
            "type" => continue,
            "id" => {
                own_id = Some(
                    v.extract::<String>()
                        .map_err(|_| bad(plugin, "id", "must be a string"))?,
                );
                continue;
            }
            _ => {}
        }
        let mut val = value(plugin, &key, &v, depth)?;
        // Top-level objects of a scene take their dict key as id (as mi.load_dict does).
        if plugin == "scene"
            && let Value::Object(o) = &mut val
        {
            o.id.get_or_insert_with(|| key.clone());
        }
        props.insert(key, val)?;
    }
    if own_id.is_some() {
        props.id = own_id;
    }
    Ok(props)
}

/// A loaded scene (immutable but for the laser's aim).
#[pyclass(module = "nlos_rs._core", name = "Scene", frozen, dict)]
pub struct PyScene {
    inner: std::sync::RwLock<Arc<crate::Scene>>,
}

impl PyScene {
    fn get(&self) -> Arc<crate::Scene> {
        self.inner
            .read()
            .map(|s| s.clone())
            .unwrap_or_else(|e| e.into_inner().clone())
    }
    fn wrap(s: crate::Scene) -> Self {
        Self {
            inner: std::sync::RwLock::new(Arc::new(s)),
        }
    }
}

#[pymethods]
impl PyScene {
    /// (width, height) of the scan grid.
    #[getter]
    fn film_size(&self) -> (usize, usize) {
        let f = &self.get().meter.film;
        (f.width, f.height)
    }
    /// (width, height) of the scan grid that pixel coordinates refer to: the film's, or in tal's
    /// confocal scan (a 1x1 film) `original_film_width/height`.
    #[getter]
    fn scan_grid(&self) -> (usize, usize) {
        let s = self.get();
        let f = &s.meter.film;
        s.meter.confocal_grid.unwrap_or((f.width, f.height))
    }
    /// Samples per scan point set in the scene's sampler.
    #[getter]
    fn spp(&self) -> u64 {
        self.get().meter.spp
    }
    /// Number of time bins, bin width and start (OPL, scene units).
    #[getter]
    fn temporal(&self) -> (usize, f64, f64) {
        let f = &self.get().meter.film;
        (f.temporal_bins, f.bin_width_opl, f.start_opl)
    }
    /// The frequencies (1/m of optical path) a phasor_hdr_film stores, else None.
    #[getter]
    fn phasor_frequencies(&self) -> Option<Vec<f64>> {
        self.get()
            .meter
            .film
            .phasor
            .as_ref()
            .map(|p| p.frequencies.clone())
    }
    /// Capture type: 'single', 'confocal' or 'exhaustive'.
    #[getter]
    fn capture_type(&self) -> &'static str {
        let s = self.get();
        let Ok(n) = s.nlos() else { return "camera" };
        match n.settings.capture_type {
            crate::settings::CaptureType::Single => "single",
            crate::settings::CaptureType::Confocal => "confocal",
            crate::settings::CaptureType::Exhaustive => "exhaustive",
        }
    }
    /// Laser grid (LW, LH) of an exhaustive film, else None.
    #[getter]
    fn laser_scan(&self) -> Option<(usize, usize)> {
        self.get().meter.film.laser_scan
    }
    /// Whether the optical path includes the sensor and laser legs.
    #[getter]
    fn account_first_and_last_bounces(&self) -> bool {
        self.get()
            .nlos()
            .is_ok_and(|n| n.settings.account_first_and_last_bounces)
    }
    /// Sensor origin.
    #[getter]
    fn sensor_origin(&self) -> [f32; 3] {
        self.get().meter.origin.to_array()
    }
    /// Laser origin.
    #[getter]
    fn laser_origin(&self) -> PyResult<[f32; 3]> {
        Ok(self.get().nlos()?.laser.origin.to_array())
    }
    /// The laser's to_world as a nested list (row-major).
    #[getter]
    fn laser_to_world(&self) -> PyResult<Vec<Vec<f64>>> {
        Ok(rows(self.get().nlos()?.laser.to_world))
    }
    /// Ids of the shapes, in order; the relay wall's index.
    #[getter]
    fn shape_ids(&self) -> Vec<String> {
        self.get().shapes.iter().map(|s| s.id.clone()).collect()
    }
    #[getter]
    fn relay_wall_index(&self) -> PyResult<Option<usize>> {
        Ok(self.get().nlos()?.relay_wall)
    }
    /// The integrator's name.
    #[getter]
    fn integrator(&self) -> &'static str {
        match &self.get().setup {
            crate::scene::Setup::Los(_) => "transient_path",
            crate::scene::Setup::Nlos(n) if n.settings.hgrs.is_some() => "transient_nlos_path_rs",
            crate::scene::Setup::Nlos(_) => "transient_nlos_path",
        }
    }
    /// The film's temporal kernel: ('box', 0), ('gaussian', sigma) or (name, bandwidth), in bins.
    #[getter]
    fn temporal_kernel(&self) -> (&'static str, f64) {
        self.get().meter.film.kernel.name_and_width()
    }
    /// The same scene with sample reuse across scan points (`nlos_sample_reuse`) on or off.
    fn with_sample_reuse(&self, on: bool) -> PyResult<PyScene> {
        let mut s = (*self.get()).clone();
        let crate::scene::Setup::Nlos(n) = &mut s.setup else {
            return Err(SceneError::new_err(
                "sample reuse is for NLOS scenes (transient_nlos_path / _rs)",
            ));
        };
        n.settings.sample_reuse = on;
        Ok(PyScene::wrap(s))
    }
    /// The same scene under another integrator ('transient_nlos_path' or 'transient_nlos_path_rs'),
    /// keeping every other parameter.
    #[pyo3(signature = (name, hgrs_max_iterations=None, hgrs_estimator=None))]
    fn with_integrator(
        &self,
        name: &str,
        hgrs_max_iterations: Option<i64>,
        hgrs_estimator: Option<&str>,
    ) -> PyResult<PyScene> {
        let mut s = (*self.get()).clone();
        let crate::scene::Setup::Nlos(n) = &mut s.setup else {
            return Err(SceneError::new_err(
                "integrator switching is for NLOS scenes (transient_nlos_path / _rs)",
            ));
        };
        n.settings = n
            .settings
            .switched(name, hgrs_max_iterations, hgrs_estimator)?;
        Ok(PyScene::wrap(s))
    }
    /// Warnings raised while loading (accepted-but-ignored parameters).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.get().meter.warnings.clone()
    }
    /// First surface point seen through each scan pixel, (H, W, 3) as nested lists (NaN where
    /// the sensor sees nothing): the points the capture measures and, in confocal and
    /// equal-grid exhaustive captures, where the laser is aimed.
    fn scan_points(&self) -> PyResult<Vec<Vec<[f32; 3]>>> {
        let s = self.get();
        let points = crate::capture::scan_points(&s)?;
        let w = s.meter.film.width;
        Ok(points
            .chunks(w)
            .map(|row| {
                row.iter()
                    .map(|t| t.map_or([f32::NAN; 3], |i| i.p.to_array()))
                    .collect()
            })
            .collect())
    }
    /// Illuminated wall points and their normals as nested lists: (1, 1, 3) for a single capture,
    /// the scan grid (H, W, 3) for confocal, (LH, LW, 3) for exhaustive (NaN where the laser misses).
    fn laser_points(&self) -> PyResult<(Grid3, Grid3)> {
        let s = self.get();
        let spots = crate::capture::laser_spots(
            &s,
            &crate::capture::scan_points(&s)?,
            true,
            &Default::default(),
        )?;
        let settings = &s.nlos()?.settings;
        let f = &s.meter.film;
        let w = match (settings.capture_type, f.laser_scan) {
            (crate::settings::CaptureType::Single, _) => 1,
            (crate::settings::CaptureType::Exhaustive, Some((lw, _)))
                if !settings.force_equal_illumination_scanning =>
            {
                lw
            }
            _ => f.width,
        };
        let lit = |sp: &crate::capture::Spot, v: glam::Vec3A| {
            if sp.hit { v.to_array() } else { [f32::NAN; 3] }
        };
        let pts = spots
            .chunks(w)
            .map(|r| r.iter().map(|sp| lit(sp, sp.it.p)).collect())
            .collect();
        let nrm = spots
            .chunks(w)
            .map(|r| r.iter().map(|sp| lit(sp, sp.it.ns)).collect())
            .collect();
        Ok((pts, nrm))
    }
    /// Relay-wall point and normal at uv ∈ [0, 1]² (`rectangle.sample_position`).
    fn relay_wall_point(&self, u: f32, v: f32) -> PyResult<([f32; 3], [f32; 3])> {
        let (p, n) = self.get().relay_wall_point(Vec2::new(u, v))?;
        Ok((p.to_array(), n.to_array()))
    }
    /// Aim the laser at a world point from its current origin. The scene no longer matches the
    /// description it was loaded from, so it forgets it (`_nlos_source`, which
    /// `nlos_rs.distributed` reloads on workers).
    fn focus_laser_at(slf: &Bound<'_, Self>, x: f32, y: f32, z: f32) -> PyResult<()> {
        {
            let this = slf.get();
            let mut guard = this
                .inner
                .write()
                .map_err(|_| SceneError::new_err("scene lock poisoned"))?;
            Arc::make_mut(&mut guard).focus_laser_at(Vec3A::new(x, y, z))?;
        }
        let dict = slf.getattr("__dict__")?;
        if dict.contains("_nlos_source")? {
            dict.del_item("_nlos_source")?;
        }
        Ok(())
    }
    fn __repr__(&self) -> String {
        let s = self.get();
        let f = &s.meter.film;
        format!(
            "Scene({} shapes, {} primitives, {}x{} scan, {} bins x {} from {}, {} spp)",
            s.shapes.len(),
            s.prims.len(),
            f.width,
            f.height,
            f.temporal_bins,
            f.bin_width_opl,
            f.start_opl,
            s.meter.spp
        )
    }
}

/// Build a scene from a (normalised) Mitsuba scene dict.
#[pyfunction]
#[pyo3(signature = (d, base_dir=None))]
fn load_dict(
    py: Python<'_>,
    d: &Bound<'_, PyDict>,
    base_dir: Option<PathBuf>,
) -> PyResult<PyScene> {
    let ty: Option<String> = d.get_item("type")?.and_then(|t| t.extract().ok());
    if ty.as_deref() != Some("scene") {
        return Err(SceneError::new_err("the scene dict needs 'type': 'scene'"));
    }
    let props = object("scene", None, d, 0)?;
    let dir = base_dir.unwrap_or_else(|| PathBuf::from("."));
    let cancel = AtomicBool::new(false);
    let flag = &cancel;
    let scene = interruptible(
        py,
        &cancel,
        move || guarded(|| crate::Scene::load(&props, &dir, flag)),
        || Ok(()),
    )?;
    Ok(PyScene::wrap(scene))
}

/// Load a Mitsuba XML scene file; `params` substitute `$name`s.
#[pyfunction]
fn load_file(py: Python<'_>, path: PathBuf, params: HashMap<String, String>) -> PyResult<PyScene> {
    let cancel = AtomicBool::new(false);
    let scene = interruptible(
        py,
        &cancel,
        || {
            guarded(|| {
                let props = crate::xml::load(&path, &params)?;
                let dir = path.parent().map(PathBuf::from).unwrap_or_default();
                crate::Scene::load(&props, &dir, &cancel)
            })
        },
        || Ok(()),
    )?;
    Ok(PyScene::wrap(scene))
}

/// A 2-D grid of 3-vectors as nested lists.
type Grid3 = Vec<Vec<[f32; 3]>>;

/// Render options as the Python layer passes them: a dict of `nlos_rs.render`'s keywords.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub(crate) struct Opts {
    mono: bool,
    #[pyo3(default)]
    spp: Option<u64>,
    #[pyo3(default)]
    seed: u64,
    #[pyo3(default)]
    threads: Option<usize>,
    #[pyo3(default)]
    kernel: Option<String>,
    #[pyo3(default)]
    kernel_sigma: Option<f64>,
    #[pyo3(default)]
    kernel_bandwidth: Option<f64>,
    #[pyo3(default)]
    max_memory: Option<u64>,
    #[pyo3(default)]
    return_variance: bool,
    #[pyo3(default)]
    target_rel_error: Option<f64>,
    #[pyo3(default)]
    auto_width: bool,
    #[pyo3(default)]
    low_discrepancy: Option<bool>,
}

impl Opts {
    /// The core's render options.
    pub(crate) fn core(&self) -> PyResult<RenderOptions> {
        let kernel = match (&self.kernel, self.kernel_sigma, self.kernel_bandwidth) {
            (None, None, None) => None,
            (k, s, b) => Some(crate::film::TemporalKernel::from_params(
                "render",
                k.as_deref(),
                s,
                b,
            )?),
        };
        Ok(RenderOptions {
            kernel,
            spp: self.spp,
            seed: self.seed,
            threads: self.threads,
            mono: self.mono,
            max_memory: self.max_memory,
            variance: self.return_variance,
            target_rel_error: self.target_rel_error,
            auto_width: self.auto_width,
            low_discrepancy: self.low_discrepancy,
        })
    }
}

/// Render with the GIL released: (steady, transient, variance or None). `progress(done, total)`
/// is called about ten times a second; Ctrl-C cancels within a poll interval.
#[pyfunction]
#[pyo3(signature = (scene, options, progress=None))]
fn render<'py>(
    py: Python<'py>,
    scene: &PyScene,
    options: Opts,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyTuple>> {
    let scene = scene.get();
    let opts = options.core()?;
    let total = total_samples(&scene, &opts);
    let monitor = Monitor::default();
    let out = interruptible(
        py,
        &monitor.cancel,
        || core_render(&scene, &opts, &monitor).map_err(PyErr::from),
        || match &progress {
            Some(cb) => cb
                .call1((monitor.done.load(Ordering::Relaxed), total))
                .map(|_| ()),
            None => Ok(()),
        },
    )?;
    let shape = out.transient_shape;
    let steady = PyArray1::from_vec(py, out.steady).reshape(out.steady_shape)?;
    let transient = film_array(py, out.transient)?.reshape(shape.clone())?;
    let variance = match out.variance {
        Some(v) => film_array(py, v)?.reshape(shape)?.into_any(),
        None => py.None().into_bound(py),
    };
    PyTuple::new(py, [steady.into_any(), transient.into_any(), variance])
}

/// The memory of a transient lent to NumPy: when its array is freed it goes back to the core,
/// which keeps it for the next render's film ([`crate::film::memory::keep`]).
#[pyclass(module = "nlos_rs._core", frozen)]
struct FilmMemory(Vec<f32>);

impl Drop for FilmMemory {
    fn drop(&mut self) {
        crate::film::memory::keep(std::mem::take(&mut self.0));
    }
}

/// A 1-D array over `bins`, owned by a [`FilmMemory`].
fn film_array(py: Python<'_>, bins: Vec<f32>) -> PyResult<Bound<'_, PyArray1<f32>>> {
    let owner = Bound::new(py, FilmMemory(bins))?;
    let view = numpy::ndarray::ArrayView1::from(&owner.get().0[..]);
    // SAFETY: the array's data is the vector in `owner`, its base object, which lives as long as
    // the array does and is never resized.
    Ok(unsafe { PyArray1::borrow_from_array(&view, owner.clone().into_any()) })
}

/// Mitsuba-convention transforms as row-major nested lists.
#[pyfunction]
fn transform_look_at(origin: [f64; 3], target: [f64; 3], up: [f64; 3]) -> PyResult<Vec<Vec<f64>>> {
    let m = crate::math::look_at(origin, target, up).ok_or_else(|| {
        SceneError::new_err("look_at: degenerate (target = origin, or up parallel to the view)")
    })?;
    Ok(rows(m))
}
#[pyfunction]
fn transform_translate(v: [f64; 3]) -> Vec<Vec<f64>> {
    rows(crate::math::translate(v))
}
#[pyfunction]
fn transform_scale(v: [f64; 3]) -> Vec<Vec<f64>> {
    rows(crate::math::scale(v))
}
#[pyfunction]
fn transform_rotate(axis: [f64; 3], angle: f64) -> Vec<Vec<f64>> {
    rows(crate::math::rotate(axis, angle))
}

fn rows(m: DMat4) -> Vec<Vec<f64>> {
    m.transpose()
        .to_cols_array_2d()
        .iter()
        .map(|r| r.to_vec())
        .collect()
}

/// The compiled core of nlos_rs.
#[pymodule]
#[pyo3(name = "_core")]
fn core_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add_class::<PyScene>()?;
    m.add_function(wrap_pyfunction!(load_dict, m)?)?;
    m.add_function(wrap_pyfunction!(load_file, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(parts::render_plan, m)?)?;
    m.add_function(wrap_pyfunction!(parts::render_part, m)?)?;
    m.add_function(wrap_pyfunction!(parts::assemble, m)?)?;
    m.add_function(wrap_pyfunction!(parts::render_check_memory, m)?)?;
    m.add_function(wrap_pyfunction!(parts::memory_limit, m)?)?;
    m.add_function(wrap_pyfunction!(spad::spad_check, m)?)?;
    m.add_function(wrap_pyfunction!(spad::spad_expected_counts, m)?)?;
    m.add_function(wrap_pyfunction!(spad::spad_simulate, m)?)?;
    m.add_function(wrap_pyfunction!(spad::spad_coates, m)?)?;
    m.add_function(wrap_pyfunction!(transform_look_at, m)?)?;
    m.add_function(wrap_pyfunction!(transform_translate, m)?)?;
    m.add_function(wrap_pyfunction!(transform_scale, m)?)?;
    m.add_function(wrap_pyfunction!(transform_rotate, m)?)?;
    Ok(())
}
