//! Building a [`Scene`] from a `scene` property tree (a dict or an XML file): BSDFs first (so that
//! references resolve in any order), then shapes with their nested sensor, BSDF and area light,
//! emitters, the sensor and the integrator; then the checks that make it an NLOS capture or a
//! line-of-sight render.

use super::{Los, Nlos, Scene, Setup, Shape};
use crate::bsdf::{self, Bsdf};
use crate::emitter::{Light, Projector};
use crate::error::{NlosError, Result};
use crate::film::TemporalKernel;
use crate::geometry::{Prim, bvh::Accel, mesh::Mesh};
use crate::math::Transform;
use crate::props::{Colour, Props, Value};
use crate::sensor::{Camera, Meter};
use crate::settings::{CaptureType, NlosSettings, PathSettings};
use glam::Vec3A;
use std::collections::HashMap;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

const SHAPES: [&str; 6] = ["obj", "ply", "rectangle", "disk", "cube", "sphere"];

/// Largest |coordinate| of any shape (single-precision geometry stays accurate well inside it).
const MAX_COORD: f32 = 1e12;

/// Mitsuba's BSDF plugins that nlos_rs does not read yet (an error names them as BSDFs).
const OTHER_BSDFS: [&str; 7] = [
    "roughdielectric",
    "bumpmap",
    "normalmap",
    "principled",
    "principledthin",
    "hair",
    "measured",
];

/// Emitter plugins other than the ones read (`projector`, `area`, `point`).
const OTHER_EMITTERS: [&str; 5] = [
    "spot",
    "constant",
    "envmap",
    "directional",
    "directionalarea",
];

/// Participating media and their integrators.
const MEDIA: [&str; 6] = [
    "homogeneous",
    "heterogeneous",
    "transient_prbvolpath",
    "volpath",
    "volpathmis",
    "prbvolpath",
];

/// The error for a medium or a volumetric integrator.
fn media_error(plugin: &str, key: &str) -> NlosError {
    NlosError::prop(
        plugin,
        key,
        format!(
            "participating media are not supported ('{plugin}'): nlos_rs renders surfaces only"
        ),
    )
}

/// What the top level of a scene holds, as it is read.
#[derive(Default)]
struct Parts {
    scene_bsdfs: HashMap<String, usize>,
    bsdfs: Vec<Bsdf<Colour>>,
    shapes: Vec<Shape>,
    prims: Vec<Prim>,
    prim_shape: Vec<u32>,
    prim_normals: Vec<Option<[Vec3A; 3]>>,
    shape_flip: Vec<bool>,
    /// The relay wall's index and its capture meter.
    meter: Option<(usize, Meter)>,
    lights: Vec<Light>,
    lasers: Vec<Projector>,
    cameras: Vec<(Camera, Meter)>,
    nlos_settings: Vec<NlosSettings>,
    path_settings: Vec<PathSettings>,
}

/// The primitives of a shape in world space, and per-vertex normals of its triangles.
struct Geometry {
    prims: Vec<Prim>,
    normals: Vec<Option<[Vec3A; 3]>>,
    rectangle: Option<Transform>,
}

impl Geometry {
    fn one(prim: Prim) -> Self {
        Self {
            prims: vec![prim],
            normals: vec![None],
            rectangle: None,
        }
    }

    /// A mesh placed by `to_world`; degenerate triangles can neither be hit nor sampled and are dropped.
    fn mesh(m: &Mesh, to_world: &Transform) -> Self {
        let (mut prims, mut normals) = (Vec::new(), Vec::new());
        for t in &m.triangles {
            let v = t.map(|i| to_world.point(m.positions[i as usize]));
            if (v[1] - v[0]).cross(v[2] - v[0]).length_squared() == 0.0 {
                continue;
            }
            prims.push(Prim::triangle(v));
            normals.push(
                m.normals
                    .as_ref()
                    .map(|ns| t.map(|i| to_world.normal(ns[i as usize]))),
            );
        }
        Self {
            prims,
            normals,
            rectangle: None,
        }
    }
}

/// The geometry of a shape plugin (one of [`SHAPES`]).
fn shape_geometry(p: &Props, to_world: &Transform, base_dir: &Path) -> Result<Geometry> {
    let plugin = p.plugin.as_str();
    Ok(match plugin {
        "obj" | "ply" => {
            let file = p.string("filename", "")?;
            if file.is_empty() {
                return Err(NlosError::prop(plugin, "filename", "missing"));
            }
            let path = base_dir.join(&file);
            let face_normals = p.bool("face_normals", false)?;
            let mut m = if plugin == "obj" {
                p.bool("flip_tex_coords", true)?; // texture coordinates are unused
                Mesh::load_obj(&path)?
            } else {
                Mesh::load_ply(&path)?
            };
            if face_normals {
                m.normals = None;
            } else if m.normals.is_none() {
                m.recompute_vertex_normals();
            }
            Geometry::mesh(&m, to_world)
        }
        "rectangle" => Geometry {
            rectangle: Some(*to_world),
            ..Geometry::mesh(&Mesh::rectangle(), to_world)
        },
        "cube" => Geometry::mesh(&Mesh::cube(), to_world),
        "disk" => Geometry::one(Prim::Disk { inv: to_world.inv }),
        _ => {
            // "sphere"
            let c = p.vec3("center", [0.0; 3])?;
            let r = p.float("radius", 1.0)?;
            if !(r > 0.0 && r <= MAX_COORD as f64) {
                return Err(NlosError::prop(
                    plugin,
                    "radius",
                    format!("must be in (0, {MAX_COORD:e}], got {r}"),
                ));
            }
            let lin = to_world.m.matrix3;
            let (sx, sy, sz) = (
                lin.x_axis.length(),
                lin.y_axis.length(),
                lin.z_axis.length(),
            );
            if (sx - sy).abs() > 1e-4 * sx || (sx - sz).abs() > 1e-4 * sx {
                return Err(NlosError::prop(
                    plugin,
                    "to_world",
                    "a sphere's to_world must scale uniformly",
                ));
            }
            let center = to_world.point(Vec3A::new(c[0] as f32, c[1] as f32, c[2] as f32));
            Geometry::one(Prim::Sphere {
                center,
                radius: r as f32 * sx,
            })
        }
    })
}

impl Parts {
    /// A shape with what is nested in it: a BSDF (or a reference to one), the relay wall's
    /// capture meter, an area light.
    fn add_shape(&mut self, key: &str, p: &Props, base_dir: &Path) -> Result<()> {
        let plugin = p.plugin.as_str();
        let shape_idx = self.shapes.len();
        let flip = p.bool("flip_normals", false)?;
        let to_world = p.transform("to_world")?;
        let mut bsdf = None;
        for (child_key, v) in p.objects() {
            match v {
                Value::Ref(id) => {
                    let i = *self.scene_bsdfs.get(&id).ok_or_else(|| {
                        NlosError::prop(
                            plugin,
                            &child_key,
                            format!("reference to unknown id '{id}'"),
                        )
                    })?;
                    bsdf = Some(i);
                }
                Value::Object(c) if c.plugin == "nlos_capture_meter" => {
                    if let Some((prev, _)) = &self.meter {
                        return Err(NlosError::Scene(format!(
                            "two shapes own an nlos_capture_meter ('{}' and '{key}'): there is one relay wall",
                            self.shapes[*prev].id
                        )));
                    }
                    self.meter = Some((shape_idx, Meter::from_capture_meter(&c)?));
                }
                Value::Object(c) if c.plugin == "area" || c.plugin == "angulararea" => {
                    self.lights.push(Light::area_from_props(&c, shape_idx)?)
                }
                Value::Object(c)
                    if bsdf::PLUGINS.contains(&c.plugin.as_str())
                        || OTHER_BSDFS.contains(&c.plugin.as_str()) =>
                {
                    self.bsdfs.push(Bsdf::from_props(&c)?);
                    bsdf = Some(self.bsdfs.len() - 1);
                }
                Value::Object(c) if OTHER_EMITTERS.contains(&c.plugin.as_str()) => {
                    return Err(NlosError::prop(
                        plugin,
                        &child_key,
                        format!(
                            "emitter '{}' is not supported (an 'area' emitter in a shape, a 'projector' laser or a 'point' light)",
                            c.plugin
                        ),
                    ));
                }
                Value::Object(c) if MEDIA.contains(&c.plugin.as_str()) => {
                    return Err(media_error(&c.plugin, &child_key));
                }
                Value::Object(c) => {
                    return Err(NlosError::prop(
                        plugin,
                        &child_key,
                        format!(
                            "unexpected nested '{}' (a shape holds a bsdf, an 'area' emitter and, in the relay wall, an nlos_capture_meter)",
                            c.plugin
                        ),
                    ));
                }
                other => {
                    return Err(NlosError::prop(
                        plugin,
                        &child_key,
                        format!("unexpected {other:?}"),
                    ));
                }
            }
        }
        let bsdf = bsdf.unwrap_or_else(|| {
            self.bsdfs.push(Bsdf::DEFAULT);
            self.bsdfs.len() - 1
        });
        let geometry = shape_geometry(p, &to_world, base_dir)?;
        p.finish()?;
        // Rays, areas and the BVH are single precision: keep every shape well inside its range.
        if let Some(q) = geometry.prims.iter().find(|q| {
            let (lo, hi) = q.bounds();
            !(lo.is_finite() && hi.is_finite() && lo.abs().max(hi.abs()).max_element() <= MAX_COORD)
        }) {
            return Err(NlosError::prop(
                plugin,
                "to_world",
                format!(
                    "shape '{key}' reaches {:?}: coordinates must lie within ±{MAX_COORD:e}",
                    q.bounds().1
                ),
            ));
        }
        let area: f64 = geometry.prims.iter().map(|q| q.area() as f64).sum();
        if !(area > 0.0) {
            return Err(NlosError::prop(
                plugin,
                "to_world",
                format!("shape '{key}' has zero area"),
            ));
        }
        let prims = self.prims.len()..self.prims.len() + geometry.prims.len();
        self.prims.extend(geometry.prims);
        self.prim_normals.extend(geometry.normals);
        self.prim_shape
            .extend(prims.clone().map(|_| shape_idx as u32));
        self.shape_flip.push(flip);
        self.shapes.push(Shape {
            id: p.id.clone().unwrap_or_default(),
            plugin: plugin.to_string(),
            bsdf,
            area,
            prims,
            rectangle: geometry.rectangle,
        });
        Ok(())
    }

    /// One top-level object of the scene.
    fn add(&mut self, key: &str, p: &Props, base_dir: &Path) -> Result<()> {
        let unsupported = |what: &str, hint: &str| {
            Err(NlosError::prop(
                "scene",
                key,
                format!("{what} '{}' is not supported ({hint})", p.plugin),
            ))
        };
        match p.plugin.as_str() {
            s if bsdf::PLUGINS.contains(&s) => {} // read first, see `Scene::from_props`
            s if OTHER_BSDFS.contains(&s) => {
                Bsdf::from_props(p)?;
            }
            s if MEDIA.contains(&s) => return Err(media_error(s, key)),
            s if SHAPES.contains(&s) => self.add_shape(key, p, base_dir)?,
            "transient_nlos_path" | "transient_nlos_path_rs" => {
                self.nlos_settings.push(NlosSettings::from_props(p)?)
            }
            "transient_path" => self.path_settings.push(PathSettings::from_props(p)?),
            "projector" => self.lasers.push(Projector::from_props(p)?),
            "point" => self.lights.push(Light::point_from_props(p)?),
            "perspective" => self.cameras.push(Camera::from_props(p)?),
            "nlos_capture_meter" => {
                return Err(NlosError::prop(
                    "scene",
                    key,
                    "the nlos_capture_meter must be nested inside the relay-wall shape",
                ));
            }
            s if OTHER_EMITTERS.contains(&s) || s == "area" || s == "angulararea" => {
                return unsupported(
                    "emitter",
                    "projector for NLOS; area lights nested in shapes and point lights for transient_path",
                );
            }
            "path" | "direct" | "prb" | "aov" | "moment" | "ptracer" => {
                return unsupported(
                    "integrator",
                    "use 'transient_path' or 'transient_nlos_path'",
                );
            }
            "thinlens" | "orthographic" | "irradiancemeter" | "radiancemeter" => {
                return unsupported(
                    "sensor",
                    "use 'perspective', or an nlos_capture_meter in the relay wall",
                );
            }
            other => {
                return Err(NlosError::prop(
                    "scene",
                    key,
                    format!("unknown or unsupported plugin type '{other}'"),
                ));
            }
        }
        Ok(())
    }

    /// An NLOS capture: one projector, the relay wall's capture meter, no camera.
    fn nlos_setup(&mut self, settings: NlosSettings) -> Result<(Meter, Setup)> {
        let laser = match (self.lasers.pop(), self.lasers.len(), self.lights.len()) {
            (Some(laser), 0, 0) => laser,
            (first, more, lights) => {
                return Err(NlosError::Scene(format!(
                    "an NLOS scene needs exactly one emitter, the projector laser; found {} projector(s) and {lights} other light(s)",
                    more + first.is_some() as usize
                )));
            }
        };
        let (relay_wall, camera, meter) = match (
            self.meter.take(),
            self.cameras.pop(),
            self.cameras.len(),
        ) {
            (Some((wall, meter)), None, _) => (Some(wall), None, meter),
            (None, Some((camera, meter)), 0) => {
                // A camera sees the relay surface; it scans no laser grid of its own.
                if settings.capture_type != CaptureType::Single {
                    return Err(NlosError::prop(
                        "transient_nlos_path",
                        "capture_type",
                        "a perspective camera as the NLOS sensor supports capture_type='single' only; use an nlos_capture_meter for confocal and exhaustive scans",
                    ));
                }
                (None, Some(camera), meter)
            }
            (None, None, _) => {
                return Err(NlosError::Scene(
                        "no shape owns an nlos_capture_meter (the relay wall), and there is no perspective sensor".into(),
                    ));
            }
            _ => {
                return Err(NlosError::Scene(
                        "an NLOS scene has one sensor: an nlos_capture_meter in the relay wall or one perspective camera".into(),
                    ));
            }
        };
        if let Some(wall) = relay_wall
            && self.shapes[wall].rectangle.is_none()
        {
            return Err(NlosError::Scene(format!(
                "the relay wall must be a 'rectangle' (got '{}'): the scan grid is defined on its parametrisation",
                self.shapes[wall].plugin
            )));
        }
        settings.check(&meter.film)?;
        let meter = apply_kernel(meter, settings.temporal_kernel)?;
        Ok((
            meter,
            Setup::Nlos(Box::new(Nlos {
                relay_wall,
                camera,
                laser,
                laser_target: Vec3A::ZERO,
                settings,
            })),
        ))
    }

    /// A line-of-sight render: one perspective camera, area or point lights, no laser.
    fn los_setup(&mut self, settings: PathSettings) -> Result<(Meter, Setup)> {
        let (camera, meter) = match (self.cameras.pop(), self.cameras.len(), &self.meter) {
            (Some(c), 0, None) => c,
            _ => {
                return Err(NlosError::Scene("transient_path needs exactly one 'perspective' sensor (and no nlos_capture_meter)".into()));
            }
        };
        if self.lights.is_empty() || !self.lasers.is_empty() {
            return Err(NlosError::Scene(
                "transient_path needs area or point lights (a projector laser is for NLOS scenes)"
                    .into(),
            ));
        }
        if meter.film.laser_scan.is_some() {
            return Err(NlosError::prop(
                "transient_hdr_film",
                "exhaustive_scan",
                "is for NLOS captures only",
            ));
        }
        let meter = apply_kernel(meter, settings.temporal_kernel)?;
        Ok((
            meter,
            Setup::Los(Los {
                camera,
                lights: std::mem::take(&mut self.lights),
                settings,
            }),
        ))
    }
}

/// The integrator's `temporal_filter='gaussian'` sets the film's kernel, unless the film has one.
fn apply_kernel(mut meter: Meter, kernel: Option<TemporalKernel>) -> Result<Meter> {
    if let Some(k) = kernel {
        if meter.film.kernel != TemporalKernel::Box {
            return Err(NlosError::prop(
                "transient_hdr_film",
                "kernel_sigma",
                "the integrator's temporal_filter='gaussian' already sets a temporal kernel",
            ));
        }
        meter.film.kernel = k;
    }
    Ok(meter)
}

impl Scene {
    /// Build from a `scene` property tree; relative mesh paths resolve against `base_dir`.
    pub fn from_props(root: &Props, base_dir: &Path) -> Result<Self> {
        Self::load(root, base_dir, &AtomicBool::new(false))
    }

    /// [`Scene::from_props`] that stops with [`NlosError::Interrupted`] once `cancel` is set
    /// (checked between objects: a scene of 100,000 objects stays interruptible).
    pub fn load(root: &Props, base_dir: &Path, cancel: &AtomicBool) -> Result<Self> {
        if root.plugin != "scene" {
            return Err(NlosError::Scene(format!(
                "the root object must be of type 'scene', got '{}'",
                root.plugin
            )));
        }
        let mut parts = Parts::default();
        let children = root.objects();
        // BSDFs first, so that references resolve whatever the declaration order.
        for (key, v) in &children {
            if let Value::Object(p) = v
                && bsdf::PLUGINS.contains(&p.plugin.as_str())
            {
                parts.bsdfs.push(Bsdf::from_props(p)?);
                let id = p.id.clone().unwrap_or_else(|| key.clone());
                if parts
                    .scene_bsdfs
                    .insert(id.clone(), parts.bsdfs.len() - 1)
                    .is_some()
                {
                    return Err(NlosError::prop(
                        &p.plugin,
                        "id",
                        format!("two objects have the id '{id}'"),
                    ));
                }
            }
        }
        for (i, (key, v)) in children.iter().enumerate() {
            if i % 256 == 255 && cancel.load(Ordering::Relaxed) {
                return Err(NlosError::Interrupted);
            }
            let Value::Object(p) = v else {
                return Err(NlosError::prop(
                    "scene",
                    key,
                    "a reference is only allowed inside a shape",
                ));
            };
            parts.add(key, p, base_dir)?;
        }
        root.finish()?;
        let (meter, setup) = match (parts.nlos_settings.pop(), parts.path_settings.pop()) {
            (Some(s), None) if parts.nlos_settings.is_empty() => parts.nlos_setup(s)?,
            (None, Some(s)) if parts.path_settings.is_empty() => parts.los_setup(s)?,
            (a, b) => {
                let found = parts.nlos_settings.len()
                    + parts.path_settings.len()
                    + a.is_some() as usize
                    + b.is_some() as usize;
                return Err(NlosError::Scene(format!(
                    "the scene needs exactly one integrator ('transient_nlos_path', 'transient_nlos_path_rs' or 'transient_path'); found {found}"
                )));
            }
        };
        // The BVH builds in parallel, on a pool of its own (see `parallel`).
        let accel = std::sync::Arc::new(
            crate::parallel::pool(None)?
                .install(|| Accel::build(&parts.prims, &parts.prim_shape, parts.shapes.len())),
        );
        Ok(Self {
            shapes: parts.shapes,
            bsdfs: parts.bsdfs,
            prims: parts.prims,
            prim_shape: parts.prim_shape,
            prim_normals: parts.prim_normals,
            shape_flip: parts.shape_flip,
            accel,
            meter,
            setup,
            hidden: Default::default(),
            delta_surfaces: Default::default(),
            prepared: Default::default(),
        })
    }
}
