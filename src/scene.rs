//! Scenes as mitransient 1.3.1 describes them (mitransient-nlos-spec §1): a relay wall owning an
//! `nlos_capture_meter`, one `projector` laser, hidden shapes with `diffuse` BSDFs, and the
//! `transient_nlos_path` integrator settings. Built from a [`Props`] tree (dict or XML).

use crate::error::{NlosError, Result};
use crate::film::Film;
use crate::geometry::{Hit, Interaction, Prim, bvh::Accel, mesh::Mesh};
use crate::integrator::NlosSettings;
use crate::math::{Transform, look_at};
use crate::props::{Colour, Props, Value};
use glam::{DMat4, Vec2, Vec3A};
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

/// Mitsuba's `projector` emitter, used as the NLOS laser (mitransient-nlos-spec §1.3).
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
    fn from_props(p: &Props) -> Result<Self> {
        if p.plugin != "projector" {
            return Err(NlosError::Scene(format!(
                "emitter '{}' is not supported in NLOS scenes: the laser must be a 'projector'",
                p.plugin
            )));
        }
        let irr = p.colour("irradiance", Colour::Uniform(1.0))?;
        let scale = p.float("scale", 1.0)?;
        if !(scale >= 0.0) {
            return Err(NlosError::prop(
                "projector",
                "scale",
                "must be non-negative",
            ));
        }
        let irradiance = match irr {
            Colour::Uniform(v) => Colour::Uniform(v * scale),
            Colour::Rgb(c) => Colour::Rgb(c.map(|v| v * scale)),
        };
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
        if axes.iter().any(|a| *a == Vec3A::ZERO) {
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
    fn from_props(p: &Props) -> Result<Self> {
        let origin = p.vec3("sensor_origin", [0.0; 3])?;
        let mut warnings = Vec::new();
        if p.has("account_first_and_last_bounces") {
            // tal still writes it here; mitransient 1.3.1 warns and ignores it, and so do we.
            p.bool("account_first_and_last_bounces", false)?;
            warnings.push(
                "nlos_capture_meter: 'account_first_and_last_bounces' is deprecated and ignored here; set it on the transient_nlos_path integrator".to_string(),
            );
        }
        for key in ["shutter_open", "shutter_close"] {
            // mitransient adds shutter_open (seconds) to the optical path (metres): a defect we do not copy.
            p.float(key, 0.0)?;
        }
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
                        "nlos_capture_meter",
                        &key,
                        format!("sampler '{}' is not supported: use 'independent'", s.plugin),
                    ));
                }
                Value::Object(f) if f.plugin.ends_with("film") => {
                    film = Some(Film::from_props(&f)?)
                }
                _ => {
                    return Err(NlosError::prop(
                        "nlos_capture_meter",
                        &key,
                        "unexpected nested object (a sampler and a film)",
                    ));
                }
            }
        }
        p.finish()?;
        let film = film.ok_or_else(|| {
            NlosError::prop(
                "nlos_capture_meter",
                "film",
                "missing (a 'transient_hdr_film')",
            )
        })?;
        let o = Vec3A::new(origin[0] as f32, origin[1] as f32, origin[2] as f32);
        Ok(Self {
            origin: o,
            spp,
            seed,
            film,
            warnings,
        })
    }
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
    /// Index of the relay wall (the shape owning the capture meter).
    pub relay_wall: usize,
    /// The laser.
    pub laser: Projector,
    /// The sensor.
    pub meter: Meter,
    /// Integrator settings.
    pub integrator: NlosSettings,
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
                    return Err(NlosError::prop(
                        plugin,
                        &child_key,
                        "area emitters are not supported in NLOS scenes (the laser is a 'projector')",
                    ));
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

impl Scene {
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
        };
        let (mut integrator, mut lasers) = (None, Vec::new());
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
                    if integrator.is_some() {
                        return Err(NlosError::prop("scene", key, "a second integrator"));
                    }
                    integrator = Some(NlosSettings::from_props(p)?);
                }
                "projector" | "point" | "area" | "spot" | "constant" | "envmap" | "directional" => {
                    lasers.push(Projector::from_props(p)?)
                }
                "nlos_capture_meter" => {
                    return Err(NlosError::prop(
                        "scene",
                        key,
                        "the nlos_capture_meter must be nested inside the relay-wall shape",
                    ));
                }
                "transient_path" | "path" | "direct" => {
                    return Err(NlosError::prop(
                        "scene",
                        key,
                        format!(
                            "integrator '{}' is not supported for NLOS scenes (use 'transient_nlos_path')",
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
        let integrator = integrator.ok_or_else(|| {
            NlosError::Scene(
                "the scene has no integrator (add {'type': 'transient_nlos_path'})".into(),
            )
        })?;
        if lasers.len() != 1 {
            return Err(NlosError::Scene(format!(
                "an NLOS scene needs exactly one emitter (the projector laser); found {}",
                lasers.len()
            )));
        }
        let (relay_wall, meter) = b.meter.ok_or_else(|| {
            NlosError::Scene("no shape owns an nlos_capture_meter (the relay wall)".into())
        })?;
        if b.shapes[relay_wall].rectangle.is_none() {
            return Err(NlosError::Scene(format!(
                "the relay wall must be a 'rectangle' (got '{}'): the scan grid is defined on its parametrisation",
                b.shapes[relay_wall].plugin
            )));
        }
        let mut meter = meter;
        if let Some(k) = integrator.temporal_kernel {
            if meter.film.kernel != crate::film::TemporalKernel::Box {
                return Err(NlosError::prop(
                    "transient_hdr_film",
                    "kernel_sigma",
                    "the integrator's temporal_filter='gaussian' already sets a temporal kernel",
                ));
            }
            meter.film.kernel = k;
        }
        integrator.check(&meter.film)?;
        let accel = std::sync::Arc::new(Accel::build(&b.prims));
        Ok(Self {
            shapes: b.shapes,
            bsdfs: b.bsdfs,
            prims: b.prims,
            prim_shape: b.prim_shape,
            prim_normals: b.prim_normals,
            shape_flip: b.shape_flip,
            accel,
            relay_wall,
            laser: lasers.pop().unwrap_or_else(|| unreachable!()),
            meter,
            integrator,
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
    pub fn relay_wall_point(&self, uv: Vec2) -> (Vec3A, Vec3A) {
        let t = self.shapes[self.relay_wall]
            .rectangle
            .unwrap_or(Transform::IDENTITY);
        let p = t.point(Vec3A::new(2.0 * uv.x - 1.0, 2.0 * uv.y - 1.0, 0.0));
        let s = if self.shape_flip[self.relay_wall] {
            -1.0
        } else {
            1.0
        };
        (p, t.normal(Vec3A::Z) * s)
    }

    /// Aim the laser at a 3D point from its current origin (`mitr.nlos.focus_emitter_at_relay_wall_3dpoint`).
    pub fn focus_laser_at(&mut self, target: Vec3A) -> Result<()> {
        let o = self.laser.origin.as_dvec3().to_array();
        let m = look_at(o, target.as_dvec3().to_array(), [0.0, 1.0, 0.0]).ok_or_else(|| {
            NlosError::prop(
                "projector",
                "to_world",
                "cannot aim the laser at its own origin",
            )
        })?;
        self.laser
            .set_to_world(m)
            .map_err(|e| NlosError::prop("projector", "to_world", e))
    }
}
