//! Scenes as mitransient 1.3.1 describes them (mitransient-nlos-spec §1): a relay wall owning an
//! `nlos_capture_meter`, one `projector` laser, hidden shapes with `diffuse` BSDFs, and the
//! `transient_nlos_path` integrator settings. Built from a [`Props`] tree (dict or XML).

use crate::camera::Camera;
use crate::emitter::{Light, Projector};
use crate::error::{NlosError, Result};
use crate::film::Film;
use crate::geometry::{Hit, Interaction, Prim, bvh::Accel, mesh::Mesh};
use crate::integrator::{NlosSettings, PathSettings};
use crate::math::{Transform, look_at};
use crate::props::{Colour, Props, Value};
use glam::{Vec2, Vec3A};
use std::collections::HashMap;
use std::path::Path;

/// A Lambertian BSDF (Mitsuba's `diffuse`): one-sided, f = ρ/π · cosθ_o.
#[derive(Clone, Debug)]
pub struct Diffuse {
    /// Reflectance ρ.
    pub reflectance: Colour,
}

/// A shape: its primitives, BSDF and area.
#[derive(Clone, Debug)]
pub struct Shape {
    /// Id (dict key or XML id; may be empty).
    pub id: String,
    /// Plugin type (`obj`, `rectangle`, ...).
    pub plugin: String,
    /// Index into [`Scene::bsdfs`].
    pub bsdf: usize,
    /// Total surface area.
    pub area: f64,
    /// Its primitives, as a range of [`Scene::prims`].
    pub prims: std::ops::Range<usize>,
    /// For a `rectangle`, its `to_world` (the relay-wall grid is defined through it).
    pub rectangle: Option<Transform>,
}

/// `nlos_capture_meter`: where the SPAD sits and how many samples it takes.
#[derive(Clone, Debug)]
pub struct Meter {
    /// Sensor origin s.
    pub origin: Vec3A,
    /// Samples per scan point (the sampler's `sample_count`).
    pub spp: u64,
    /// The sampler's `seed`.
    pub seed: u64,
    /// Film.
    pub film: Film,
    /// Things accepted but ignored, for the caller to show.
    pub warnings: Vec<String>,
}

impl Meter {
    /// An `nlos_capture_meter` (nested in the relay wall).
    fn from_props(p: &Props) -> Result<Self> {
        let o = p.vec3("sensor_origin", [0.0; 3])?;
        let mut meter = Self::from_sensor(p, Vec3A::new(o[0] as f32, o[1] as f32, o[2] as f32))?;
        if p.has("account_first_and_last_bounces") {
            // tal still writes it here; mitransient 1.3.1 warns and ignores it, and so do we.
            p.bool("account_first_and_last_bounces", false)?;
            meter.warnings.push(
                "nlos_capture_meter: 'account_first_and_last_bounces' is deprecated and ignored here; set it on the transient_nlos_path integrator".to_string(),
            );
        }
        for key in ["shutter_open", "shutter_close"] {
            // mitransient adds shutter_open (seconds) to the optical path (metres): a defect we do not copy.
            p.float(key, 0.0)?;
        }
        p.finish()?;
        Ok(meter)
    }

    /// The sampler and film nested in any sensor; the caller reads its other keys and finishes `p`.
    pub fn from_sensor(p: &Props, origin: Vec3A) -> Result<Self> {
        let plugin = p.plugin.as_str();
        let (mut spp, mut seed, mut film) = (4, 0, None);
        for (key, v) in p.objects() {
            match v {
                Value::Object(s) if s.plugin == "independent" => {
                    spp = s.int_in("sample_count", 4, 1, i64::MAX)? as u64;
                    seed = s.int_in("seed", 0, 0, u32::MAX as i64)? as u64;
                    s.finish()?;
                }
                Value::Object(s)
                    if matches!(
                        s.plugin.as_str(),
                        "stratified" | "multijitter" | "orthogonal" | "ldsampler"
                    ) =>
                {
                    return Err(NlosError::prop(
                        plugin,
                        &key,
                        format!("sampler '{}' is not supported: use 'independent'", s.plugin),
                    ));
                }
                Value::Object(f) if f.plugin.ends_with("film") => {
                    film = Some(Film::from_props(&f)?)
                }
                _ => {
                    return Err(NlosError::prop(
                        plugin,
                        &key,
                        "unexpected nested object (a sampler and a film)",
                    ));
                }
            }
        }
        let film = film
            .ok_or_else(|| NlosError::prop(plugin, "film", "missing (a 'transient_hdr_film')"))?;
        Ok(Self {
            origin,
            spp,
            seed,
            film,
            warnings: Vec::new(),
        })
    }
}

/// What a scene measures.
#[derive(Clone)]
pub enum Setup {
    /// An NLOS capture: relay wall with an `nlos_capture_meter`, a `projector` laser,
    /// `transient_nlos_path(_rs)`.
    Nlos(Nlos),
    /// A line-of-sight render: `perspective` camera, `area`/`point` lights, `transient_path`.
    Los(Los),
}

/// The NLOS part of a scene.
#[derive(Clone)]
pub struct Nlos {
    /// Index of the relay wall (the shape owning the capture meter).
    pub relay_wall: usize,
    /// The laser.
    pub laser: Projector,
    /// Integrator settings.
    pub settings: NlosSettings,
}

/// The line-of-sight part of a scene.
#[derive(Clone)]
pub struct Los {
    /// The camera.
    pub camera: Camera,
    /// The lights.
    pub lights: Vec<Light>,
    /// Integrator settings.
    pub settings: PathSettings,
}

/// A loaded NLOS scene.
#[derive(Clone)]
pub struct Scene {
    /// Shapes in declaration order.
    pub shapes: Vec<Shape>,
    /// BSDFs.
    pub bsdfs: Vec<Diffuse>,
    /// World-space primitives in scene order.
    pub prims: Vec<Prim>,
    /// Owning shape of each primitive.
    pub prim_shape: Vec<u32>,
    /// Per-vertex shading normals of triangles (None = flat).
    pub prim_normals: Vec<Option<[Vec3A; 3]>>,
    /// Normal orientation per shape (`flip_normals`).
    pub shape_flip: Vec<bool>,
    /// BVH over `prims`.
    pub accel: std::sync::Arc<Accel>,
    /// Samples, seed and film of the sensor (capture meter or camera).
    pub meter: Meter,
    /// NLOS capture or line-of-sight camera.
    pub setup: Setup,
}

const SHAPES: [&str; 6] = ["obj", "ply", "rectangle", "disk", "cube", "sphere"];

struct Builder<'a> {
    base_dir: &'a Path,
    scene_bsdfs: HashMap<String, usize>,
    bsdfs: Vec<Diffuse>,
    shapes: Vec<Shape>,
    prims: Vec<Prim>,
    prim_shape: Vec<u32>,
    prim_normals: Vec<Option<[Vec3A; 3]>>,
    shape_flip: Vec<bool>,
    meter: Option<(usize, Meter)>,
    lights: Vec<Light>,
}

fn bsdf_from_props(p: &Props) -> Result<Diffuse> {
    match p.plugin.as_str() {
        "diffuse" => {
            let reflectance = p.colour("reflectance", Colour::Uniform(0.5))?;
            p.finish()?;
            Ok(Diffuse { reflectance })
        }
        other => Err(NlosError::Scene(format!(
            "bsdf '{other}' is not supported (only 'diffuse')"
        ))),
    }
}

impl Builder<'_> {
    fn add_shape(&mut self, key: &str, p: &Props) -> Result<()> {
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
                    self.meter = Some((shape_idx, Meter::from_props(&c)?));
                }
                Value::Object(c) if c.plugin == "area" => {
                    self.lights.push(Light::area_from_props(&c, shape_idx)?)
                }
                Value::Object(c) => {
                    // Anything else nested in a shape is its BSDF; non-diffuse ones are rejected there.
                    self.bsdfs.push(bsdf_from_props(&c)?);
                    bsdf = Some(self.bsdfs.len() - 1);
                }
                _ => unreachable!(),
            }
        }
        let bsdf = match bsdf {
            Some(b) => b,
            None => {
                // Mitsuba's default BSDF: diffuse, reflectance 0.5.
                self.bsdfs.push(Diffuse {
                    reflectance: Colour::Uniform(0.5),
                });
                self.bsdfs.len() - 1
            }
        };
        let first = self.prims.len();
        let mut rectangle = None;
        let mesh = match plugin {
            "obj" | "ply" => {
                let file = p.string("filename", "")?;
                if file.is_empty() {
                    return Err(NlosError::prop(plugin, "filename", "missing"));
                }
                let path = self.base_dir.join(&file);
                let face_normals = p.bool("face_normals", false)?;
                if plugin == "obj" {
                    p.bool("flip_tex_coords", true)?; // texture coordinates are unused
                }
                let mut m = if plugin == "obj" {
                    Mesh::load_obj(&path)?
                } else {
                    Mesh::load_ply(&path)?
                };
                if face_normals {
                    m.normals = None;
                } else if m.normals.is_none() {
                    m.recompute_vertex_normals();
                }
                Some(m)
            }
            "rectangle" => {
                rectangle = Some(to_world);
                Some(Mesh::rectangle())
            }
            "cube" => Some(Mesh::cube()),
            "disk" => {
                self.prims.push(Prim::Disk { inv: to_world.inv });
                self.prim_normals.push(None);
                None
            }
            "sphere" => {
                let c = p.vec3("center", [0.0; 3])?;
                let r = p.float("radius", 1.0)?;
                if !(r > 0.0) {
                    return Err(NlosError::prop(plugin, "radius", "must be positive"));
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
                self.prims.push(Prim::Sphere {
                    center,
                    radius: r as f32 * sx,
                });
                self.prim_normals.push(None);
                None
            }
            _ => unreachable!(),
        };
        if let Some(m) = mesh {
            for t in &m.triangles {
                let v = t.map(|i| to_world.point(m.positions[i as usize]));
                if (v[1] - v[0]).cross(v[2] - v[0]).length_squared() == 0.0 {
                    continue; // degenerate triangles can neither be hit nor sampled
                }
                self.prims.push(Prim::Triangle(v));
                self.prim_normals.push(
                    m.normals
                        .as_ref()
                        .map(|ns| t.map(|i| to_world.normal(ns[i as usize]))),
                );
            }
        }
        p.finish()?;
        let prims = first..self.prims.len();
        let area: f64 = self.prims[prims.clone()]
            .iter()
            .map(|q| q.area() as f64)
            .sum();
        if !(area > 0.0) {
            return Err(NlosError::prop(
                plugin,
                "to_world",
                format!("shape '{key}' has zero area"),
            ));
        }
        self.prim_shape
            .extend(prims.clone().map(|_| shape_idx as u32));
        self.shape_flip.push(flip);
        self.shapes.push(Shape {
            id: p.id.clone().unwrap_or_default(),
            plugin: plugin.to_string(),
            bsdf,
            area,
            prims,
            rectangle,
        });
        Ok(())
    }
}

/// The integrator's `temporal_filter='gaussian'` sets the film's kernel, unless the film has one.
fn apply_kernel(mut meter: Meter, kernel: Option<crate::film::TemporalKernel>) -> Result<Meter> {
    if let Some(k) = kernel {
        if meter.film.kernel != crate::film::TemporalKernel::Box {
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
    /// The NLOS part, or an error naming what the caller wanted.
    pub fn nlos(&self) -> Result<&Nlos> {
        match &self.setup {
            Setup::Nlos(n) => Ok(n),
            Setup::Los(_) => Err(NlosError::Scene(
                "this is a line-of-sight (transient_path) scene, not an NLOS capture".into(),
            )),
        }
    }

    /// Build from a `scene` property tree; relative mesh paths resolve against `base_dir`.
    pub fn from_props(root: &Props, base_dir: &Path) -> Result<Self> {
        if root.plugin != "scene" {
            return Err(NlosError::Scene(format!(
                "the root object must be of type 'scene', got '{}'",
                root.plugin
            )));
        }
        let mut b = Builder {
            base_dir,
            scene_bsdfs: HashMap::new(),
            bsdfs: Vec::new(),
            shapes: Vec::new(),
            prims: Vec::new(),
            prim_shape: Vec::new(),
            prim_normals: Vec::new(),
            shape_flip: Vec::new(),
            meter: None,
            lights: Vec::new(),
        };
        let (mut nlos_settings, mut path_settings, mut lasers, mut cameras) =
            (None, None, Vec::new(), Vec::new());
        let children = root.objects();
        // BSDFs first, so that references resolve whatever the declaration order.
        for (key, v) in &children {
            if let Value::Object(p) = v {
                if p.plugin == "diffuse" {
                    b.bsdfs.push(bsdf_from_props(p)?);
                    b.scene_bsdfs.insert(
                        p.id.clone().unwrap_or_else(|| key.clone()),
                        b.bsdfs.len() - 1,
                    );
                }
            }
        }
        let mut integrators = 0;
        for (key, v) in &children {
            let Value::Object(p) = v else {
                return Err(NlosError::prop(
                    "scene",
                    key,
                    "a reference is only allowed inside a shape",
                ));
            };
            match p.plugin.as_str() {
                "diffuse" => {}
                s if SHAPES.contains(&s) => b.add_shape(key, p)?,
                "transient_nlos_path" | "transient_nlos_path_rs" => {
                    integrators += 1;
                    nlos_settings = Some(NlosSettings::from_props(p)?);
                }
                "transient_path" => {
                    integrators += 1;
                    path_settings = Some(PathSettings::from_props(p)?);
                }
                "projector" => lasers.push(Projector::from_props(p)?),
                "point" => b.lights.push(Light::point_from_props(p)?),
                "perspective" => cameras.push(Camera::from_props(p)?),
                "nlos_capture_meter" => {
                    return Err(NlosError::prop(
                        "scene",
                        key,
                        "the nlos_capture_meter must be nested inside the relay-wall shape",
                    ));
                }
                "spot" | "constant" | "envmap" | "directional" | "area" => {
                    return Err(NlosError::prop(
                        "scene",
                        key,
                        format!(
                            "emitter '{}' is not supported (projector for NLOS; area lights nested in shapes and point lights for transient_path)",
                            p.plugin
                        ),
                    ));
                }
                "path" | "direct" | "volpath" | "prb" | "transient_prbvolpath" => {
                    return Err(NlosError::prop(
                        "scene",
                        key,
                        format!(
                            "integrator '{}' is not supported (use 'transient_path' or 'transient_nlos_path')",
                            p.plugin
                        ),
                    ));
                }
                "thinlens" | "orthographic" | "irradiancemeter" | "radiancemeter" => {
                    return Err(NlosError::prop(
                        "scene",
                        key,
                        format!(
                            "sensor '{}' is not supported (use 'perspective', or an nlos_capture_meter in the relay wall)",
                            p.plugin
                        ),
                    ));
                }
                other => {
                    return Err(NlosError::prop(
                        "scene",
                        key,
                        format!("unknown or unsupported plugin type '{other}'"),
                    ));
                }
            }
        }
        root.finish()?;
        if integrators != 1 {
            return Err(NlosError::Scene(format!(
                "the scene needs exactly one integrator ('transient_nlos_path', 'transient_nlos_path_rs' or 'transient_path'); found {integrators}"
            )));
        }
        let (meter, setup) = if let Some(settings) = nlos_settings {
            if lasers.len() != 1 || !b.lights.is_empty() {
                return Err(NlosError::Scene(format!(
                    "an NLOS scene needs exactly one emitter, the projector laser; found {} projector(s) and {} other light(s)",
                    lasers.len(),
                    b.lights.len()
                )));
            }
            if !cameras.is_empty() {
                return Err(NlosError::Scene("an NLOS scene measures with the relay wall's nlos_capture_meter, not a perspective camera".into()));
            }
            let (relay_wall, meter) = b.meter.take().ok_or_else(|| {
                NlosError::Scene("no shape owns an nlos_capture_meter (the relay wall)".into())
            })?;
            if b.shapes[relay_wall].rectangle.is_none() {
                return Err(NlosError::Scene(format!(
                    "the relay wall must be a 'rectangle' (got '{}'): the scan grid is defined on its parametrisation",
                    b.shapes[relay_wall].plugin
                )));
            }
            settings.check(&meter.film)?;
            let kernel = settings.temporal_kernel;
            let laser = lasers.pop().unwrap_or_else(|| unreachable!());
            (
                apply_kernel(meter, kernel)?,
                Setup::Nlos(Nlos {
                    relay_wall,
                    laser,
                    settings,
                }),
            )
        } else {
            let settings = path_settings.unwrap_or_else(|| unreachable!());
            if cameras.len() != 1 || b.meter.is_some() {
                return Err(NlosError::Scene("transient_path needs exactly one 'perspective' sensor (and no nlos_capture_meter)".into()));
            }
            if b.lights.is_empty() || !lasers.is_empty() {
                return Err(NlosError::Scene("transient_path needs area or point lights (a projector laser is for NLOS scenes)".into()));
            }
            let (camera, meter) = cameras.pop().unwrap_or_else(|| unreachable!());
            if meter.film.laser_scan.is_some() {
                return Err(NlosError::prop(
                    "transient_hdr_film",
                    "exhaustive_scan",
                    "is for NLOS captures only",
                ));
            }
            let kernel = settings.temporal_kernel;
            (
                apply_kernel(meter, kernel)?,
                Setup::Los(Los {
                    camera,
                    lights: std::mem::take(&mut b.lights),
                    settings,
                }),
            )
        };
        let accel = std::sync::Arc::new(Accel::build(&b.prims));
        Ok(Self {
            shapes: b.shapes,
            bsdfs: b.bsdfs,
            prims: b.prims,
            prim_shape: b.prim_shape,
            prim_normals: b.prim_normals,
            shape_flip: b.shape_flip,
            accel,
            meter,
            setup,
        })
    }

    /// The surface interaction of a hit.
    pub fn interaction(&self, o: Vec3A, d: Vec3A, hit: &Hit) -> Interaction {
        let i = hit.prim as usize;
        let (p, ng) = self.prims[i].surface(o, d, hit);
        self.surface_point(i, p, ng, hit.b)
    }

    /// The interaction at point `p` of primitive `i` (geometric normal `ng`, barycentrics `b` for
    /// triangles): shading normal interpolated from vertex normals, `flip_normals` applied.
    pub fn surface_point(&self, i: usize, p: Vec3A, ng: Vec3A, b: [f32; 2]) -> Interaction {
        let ns = self.prim_normals[i].map_or(ng, |n| {
            (n[0] * (1.0 - b[0] - b[1]) + n[1] * b[0] + n[2] * b[1]).normalize_or(ng)
        });
        let shape = self.prim_shape[i];
        let s = if self.shape_flip[shape as usize] {
            -1.0
        } else {
            1.0
        };
        Interaction {
            p,
            ng: ng * s,
            ns: ns * s,
            shape,
        }
    }

    /// Closest surface along a unit-direction ray, with its distance.
    #[inline]
    pub fn intersect(&self, o: Vec3A, d: Vec3A, tmax: f32) -> Option<(f32, Interaction)> {
        let hit = self.accel.intersect(o, d, 0.0, tmax)?;
        Some((hit.t, self.interaction(o, d, &hit)))
    }

    /// The relay-wall point of a uv in [0, 1]² (`rectangle.sample_position`: to_world·(2u−1, 2v−1, 0)).
    pub fn relay_wall_point(&self, uv: Vec2) -> Result<(Vec3A, Vec3A)> {
        let wall = self.nlos()?.relay_wall;
        let t = self.shapes[wall].rectangle.unwrap_or(Transform::IDENTITY);
        let p = t.point(Vec3A::new(2.0 * uv.x - 1.0, 2.0 * uv.y - 1.0, 0.0));
        let s = if self.shape_flip[wall] { -1.0 } else { 1.0 };
        Ok((p, t.normal(Vec3A::Z) * s))
    }

    /// Aim the laser at a 3D point from its current origin (`mitr.nlos.focus_emitter_at_relay_wall_3dpoint`).
    pub fn focus_laser_at(&mut self, target: Vec3A) -> Result<()> {
        let Setup::Nlos(nlos) = &mut self.setup else {
            return Err(NlosError::Scene(
                "this is a line-of-sight scene: it has no laser to aim".into(),
            ));
        };
        let o = nlos.laser.origin.as_dvec3().to_array();
        let m = look_at(o, target.as_dvec3().to_array(), [0.0, 1.0, 0.0]).ok_or_else(|| {
            NlosError::prop(
                "projector",
                "to_world",
                "cannot aim the laser at its own origin",
            )
        })?;
        nlos.laser
            .set_to_world(m)
            .map_err(|e| NlosError::prop("projector", "to_world", e))
    }
}
