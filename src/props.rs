//! A Mitsuba-style property tree, the common form of a scene dict and a scene XML file.
//!
//! Plugins read their properties through [`Props`], which remembers what was read; [`Props::finish`]
//! then rejects anything left over, as Mitsuba's "unreferenced property" check does.

use crate::error::{NlosError, Result};
use crate::math::{Transform, luminance};
use crate::spectrum;
use glam::DMat4;
use std::cell::Cell;
use std::collections::HashMap;

/// A property value.
#[derive(Clone, Debug)]
pub enum Value {
    /// `boolean`.
    Bool(bool),
    /// `integer`.
    Int(i64),
    /// `float`.
    Float(f64),
    /// `string`.
    Str(String),
    /// `point` / `vector` (three numbers).
    Vec3([f64; 3]),
    /// `rgb` colour.
    Rgb([f64; 3]),
    /// `spectrum` given as (wavelength nm, value) pairs.
    Spectrum(Vec<(f64, f64)>),
    /// `spectrum` given as one value (uniform).
    UniformSpectrum(f64),
    /// 4×4 matrix (`transform`).
    Matrix(DMat4),
    /// A nested plugin.
    Object(Props),
    /// `{'type': 'ref', 'id': ...}` / `<ref id=.../>`.
    Ref(String),
}

impl Value {
    fn kind(&self) -> &'static str {
        match self {
            Value::Bool(_) => "boolean",
            Value::Int(_) => "integer",
            Value::Float(_) => "float",
            Value::Str(_) => "string",
            Value::Vec3(_) => "point",
            Value::Rgb(_) => "rgb",
            Value::Spectrum(_) | Value::UniformSpectrum(_) => "spectrum",
            Value::Matrix(_) => "transform",
            Value::Object(_) => "object",
            Value::Ref(_) => "reference",
        }
    }
}

/// A plugin instance: its type, optional id, and named properties in declaration order.
#[derive(Clone, Debug)]
pub struct Props {
    /// Plugin type, e.g. `rectangle`.
    pub plugin: String,
    /// Object id (dict key or XML `id`), if any.
    pub id: Option<String>,
    entries: Vec<(String, Value)>,
    used: Vec<Cell<bool>>,
    /// Key → position in `entries` (scenes can have 100,000 objects: no linear scans).
    index: HashMap<String, usize>,
}

/// A colour or a plain number as Mitsuba accepts for `reflectance`, `irradiance`, ...
#[derive(Clone, Copy, Debug)]
pub enum Colour {
    /// Uniform value.
    Uniform(f64),
    /// RGB triple.
    Rgb([f64; 3]),
    /// A spectrum whose RGB and mono values differ from a plain triple's (a uniform illuminant:
    /// not grey in RGB, its value in mono).
    Spectral {
        /// The RGB value.
        rgb: [f64; 3],
        /// The mono value.
        mono: f64,
    },
}

impl Colour {
    /// As a render spectrum: RGB as is, or (mono) the luminance in all lanes.
    pub fn spectrum(self, mono: bool) -> crate::math::Spectrum {
        let rgb = match self {
            Colour::Uniform(v) => [v; 3],
            Colour::Rgb(c) | Colour::Spectral { rgb: c, .. } => c,
        };
        if mono {
            let l = match self {
                Colour::Uniform(v) | Colour::Spectral { mono: v, .. } => v,
                Colour::Rgb(c) => luminance(c),
            };
            glam::Vec3A::splat(l as f32)
        } else {
            glam::Vec3A::new(rgb[0] as f32, rgb[1] as f32, rgb[2] as f32)
        }
    }

    /// Scaled by `s` (an emitter's `scale`).
    pub fn scaled(self, s: f64) -> Self {
        match self {
            Colour::Uniform(v) => Colour::Uniform(v * s),
            Colour::Rgb(c) => Colour::Rgb(c.map(|v| v * s)),
            Colour::Spectral { rgb, mono } => Colour::Spectral {
                rgb: rgb.map(|v| v * s),
                mono: mono * s,
            },
        }
    }
}

/// The (wavelength, value) pairs of a `regular` (evenly spaced between `wavelength_min` and
/// `wavelength_max`) or `irregular` (`wavelengths`) spectrum plugin with its `values`.
fn spectrum_plugin_pairs(o: &Props, key: &str) -> Result<Vec<(f64, f64)>> {
    let list = |k: &str| -> Result<Vec<f64>> {
        o.string(k, "")?
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(|t| {
                t.parse::<f64>()
                    .map_err(|_| o.err(k, format!("'{t}' is not a number")))
            })
            .collect()
    };
    let values = list("values")?;
    let wavelengths = match o.plugin.as_str() {
        "regular" => {
            let (lo, hi) = (
                o.float("wavelength_min", 0.0)?,
                o.float("wavelength_max", 0.0)?,
            );
            let n = values.len();
            (0..n)
                .map(|i| lo + (hi - lo) * i as f64 / (n.max(2) - 1) as f64)
                .collect()
        }
        "irregular" => list("wavelengths")?,
        other => {
            return Err(NlosError::prop(
                other,
                key,
                format!(
                    "spectrum '{other}' is not supported (a number, rgb, wavelength:value pairs, regular or irregular)"
                ),
            ));
        }
    };
    o.finish()?;
    if wavelengths.len() != values.len() || values.len() < 2 {
        return Err(o.err(
            "values",
            "needs two or more values (and as many wavelengths)",
        ));
    }
    let pairs: Vec<(f64, f64)> = wavelengths.into_iter().zip(values).collect();
    if !pairs.windows(2).all(|w| w[0].0 < w[1].0)
        || !pairs
            .iter()
            .all(|(w, v)| w.is_finite() && v.is_finite() && *v >= 0.0)
    {
        return Err(o.err(
            "values",
            "wavelengths must increase and values be finite and non-negative",
        ));
    }
    Ok(pairs)
}

impl Props {
    /// Empty property set for a plugin.
    pub fn new(plugin: impl Into<String>, id: Option<String>) -> Self {
        Self {
            plugin: plugin.into(),
            id,
            entries: Vec::new(),
            used: Vec::new(),
            index: HashMap::new(),
        }
    }

    /// Add a property; a repeated name is an error, as in Mitsuba.
    pub fn insert(&mut self, key: impl Into<String>, value: Value) -> Result<()> {
        let key = key.into();
        if self.index.contains_key(&key) {
            return Err(NlosError::prop(&self.plugin, &key, "given twice"));
        }
        self.index.insert(key.clone(), self.entries.len());
        self.entries.push((key, value));
        self.used.push(Cell::new(false));
        Ok(())
    }

    fn err(&self, key: &str, msg: impl Into<String>) -> NlosError {
        NlosError::prop(&self.plugin, key, msg)
    }

    fn take(&self, key: &str) -> Option<&Value> {
        let i = *self.index.get(key)?;
        self.used[i].set(true);
        Some(&self.entries[i].1)
    }

    fn wrong(&self, key: &str, want: &str, got: &Value) -> NlosError {
        self.err(key, format!("expected {want}, got {}", got.kind()))
    }

    /// Is the key present (without consuming it)?
    pub fn has(&self, key: &str) -> bool {
        self.index.contains_key(key)
    }

    /// Integer property.
    pub fn int(&self, key: &str, default: i64) -> Result<i64> {
        match self.take(key) {
            None => Ok(default),
            Some(Value::Int(v)) => Ok(*v),
            Some(v) => Err(self.wrong(key, "an integer", v)),
        }
    }

    /// Non-negative integer property that must lie in `[lo, hi]`.
    pub fn int_in(&self, key: &str, default: i64, lo: i64, hi: i64) -> Result<i64> {
        let v = self.int(key, default)?;
        if v < lo || v > hi {
            return Err(self.err(key, format!("must be in [{lo}, {hi}], got {v}")));
        }
        Ok(v)
    }

    /// "−1 or a count" (depths and filters): −1 gives `None`, a value in `[min, u32::MAX)` gives
    /// `Some`; anything else is an error naming the key.
    pub fn optional_count(&self, key: &str, default: i64, min: i64) -> Result<Option<u32>> {
        match self.int(key, default)? {
            -1 => Ok(None),
            v if v >= min && v < u32::MAX as i64 => Ok(Some(v as u32)),
            v => Err(self.err(key, format!("must be -1 or an integer >= {min}, got {v}"))),
        }
    }

    /// Float property (an integer is accepted, as in Mitsuba).
    pub fn float(&self, key: &str, default: f64) -> Result<f64> {
        match self.take(key) {
            None => Ok(default),
            Some(Value::Float(v)) if v.is_finite() && v.abs() <= f32::MAX as f64 => Ok(*v),
            Some(Value::Int(v)) if (*v as f64).abs() <= f32::MAX as f64 => Ok(*v as f64),
            Some(Value::Float(v)) => Err(self.err(
                key,
                format!("must be finite and within single precision, got {v}"),
            )),
            Some(v) => Err(self.wrong(key, "a float", v)),
        }
    }

    /// Boolean property.
    pub fn bool(&self, key: &str, default: bool) -> Result<bool> {
        match self.take(key) {
            None => Ok(default),
            Some(Value::Bool(v)) => Ok(*v),
            Some(v) => Err(self.wrong(key, "a boolean", v)),
        }
    }

    /// String property.
    pub fn string(&self, key: &str, default: &str) -> Result<String> {
        match self.take(key) {
            None => Ok(default.to_string()),
            Some(Value::Str(v)) => Ok(v.clone()),
            Some(v) => Err(self.wrong(key, "a string", v)),
        }
    }

    /// A string property that Mitsuba plugins also take as an integer code (e.g. `capture_type`,
    /// a string or mitransient's `CaptureType` IntEnum): an integer comes back as its decimal text.
    pub fn string_or_int(&self, key: &str, default: &str) -> Result<String> {
        match self.take(key) {
            None => Ok(default.to_string()),
            Some(Value::Str(v)) => Ok(v.clone()),
            Some(Value::Int(v)) => Ok(v.to_string()),
            Some(v) => Err(self.wrong(key, "a string or an integer", v)),
        }
    }

    /// A property that is a number or a name (an index of refraction): `Some(Ok(number))`,
    /// `Some(Err(name))` or `None` when absent.
    pub fn string_or_float(&self, key: &str) -> Result<Option<std::result::Result<f64, String>>> {
        match self.take(key) {
            None => Ok(None),
            Some(Value::Float(v)) => Ok(Some(Ok(*v))),
            Some(Value::Int(v)) => Ok(Some(Ok(*v as f64))),
            Some(Value::Str(s)) => Ok(Some(Err(s.clone()))),
            Some(v) => Err(self.wrong(key, "a number or a name", v)),
        }
    }

    /// Point / vector property.
    pub fn vec3(&self, key: &str, default: [f64; 3]) -> Result<[f64; 3]> {
        match self.take(key) {
            None => Ok(default),
            Some(Value::Vec3(v))
                if v.iter()
                    .all(|x| x.is_finite() && x.abs() <= f32::MAX as f64) =>
            {
                Ok(*v)
            }
            Some(Value::Vec3(_)) => {
                Err(self.err(key, "must be finite and within single precision"))
            }
            Some(v) => Err(self.wrong(key, "a point (three numbers)", v)),
        }
    }

    /// `to_world`-like transform property (identity if absent).
    pub fn transform(&self, key: &str) -> Result<Transform> {
        Transform::from_dmat4(self.matrix(key)?).ok_or_else(|| {
            self.err(
                key,
                "must be an invertible affine 4x4 matrix (last row 0 0 0 1)",
            )
        })
    }

    /// Raw 4×4 matrix property (identity if absent).
    pub fn matrix(&self, key: &str) -> Result<DMat4> {
        match self.take(key) {
            None => Ok(DMat4::IDENTITY),
            Some(Value::Matrix(m)) => Ok(*m),
            Some(v) => Err(self.wrong(key, "a 4x4 transform", v)),
        }
    }

    /// A reflectance-like colour property: a number, an `rgb` value or a `spectrum`
    /// ([`crate::spectrum`]: weighted by D65 and clamped to [0, 1], as Mitsuba does for BSDFs).
    pub fn colour(&self, key: &str, default: Colour) -> Result<Colour> {
        // A reflectance above one would create energy: rejected (Mitsuba only clamps spectra).
        self.colour_as(key, default, true, 1.0)
    }

    /// An unbounded number or RGB triple (an index of refraction): a float, an `rgb` value or a
    /// uniform `spectrum`; finite and non-negative.
    pub fn unbounded(&self, key: &str, default: Colour) -> Result<Colour> {
        let entry = self.index.get(key).map(|&i| &self.entries[i].1);
        if let Some(Value::Spectrum(_) | Value::Object(_)) = entry {
            return Err(self.err(
                key,
                "wavelength:value spectra are not supported here: give a float or rgb value",
            ));
        }
        self.colour_as(key, default, true, 1e6)
    }

    /// An emitted colour (`irradiance`, `radiance`, `intensity`): as [`Props::colour`], but a
    /// `spectrum` is an illuminant (a uniform one is the equal-energy white of that value).
    pub fn emission(&self, key: &str, default: Colour) -> Result<Colour> {
        // Bounded so that any product with a laser's scale stays within f32.
        self.colour_as(key, default, false, 1e20)
    }

    fn colour_as(&self, key: &str, default: Colour, reflectance: bool, max: f64) -> Result<Colour> {
        let c = match self.take(key) {
            None => return Ok(default),
            Some(Value::Float(v)) => Colour::Uniform(*v),
            Some(Value::Int(v)) => Colour::Uniform(*v as f64),
            // Three numbers (a list, a Mitsuba colour or point in a dict) are an RGB colour.
            Some(Value::Rgb(c) | Value::Vec3(c)) => Colour::Rgb(*c),
            Some(Value::UniformSpectrum(v)) if reflectance => Colour::Uniform(*v),
            Some(Value::UniformSpectrum(v)) => Colour::Spectral {
                rgb: spectrum::uniform_illuminant_srgb(*v),
                mono: *v,
            },
            Some(Value::Object(o)) => Colour::Rgb(spectrum::to_srgb(
                &spectrum_plugin_pairs(o, key)?,
                reflectance,
            )),
            Some(Value::Spectrum(pairs)) => {
                let ok = pairs.windows(2).all(|w| w[0].0 < w[1].0)
                    && pairs
                        .iter()
                        .all(|(w, v)| w.is_finite() && v.is_finite() && *v >= 0.0);
                if pairs.len() < 2 || !ok {
                    return Err(self.err(
                        key,
                        "a spectrum needs two or more wavelength:value pairs, wavelengths increasing, values finite and non-negative",
                    ));
                }
                Colour::Rgb(spectrum::to_srgb(pairs, reflectance))
            }
            Some(v) => return Err(self.wrong(key, "a float, rgb or spectrum", v)),
        };
        let ok = |v: f64| v.is_finite() && (0.0..=max).contains(&v);
        let valid = match c {
            Colour::Uniform(v) | Colour::Spectral { mono: v, .. } => ok(v),
            Colour::Rgb(c) => c.iter().all(|v| ok(*v)),
        };
        if !valid {
            return Err(self.err(key, format!("must be finite and in [0, {max}]")));
        }
        Ok(c)
    }

    /// Consume every nested object (and reference), in declaration order, with its key.
    pub fn objects(&self) -> Vec<(String, Value)> {
        let mut out = Vec::new();
        for (i, (k, v)) in self.entries.iter().enumerate() {
            if matches!(v, Value::Object(_) | Value::Ref(_)) {
                self.used[i].set(true);
                out.push((k.clone(), v.clone()));
            }
        }
        out
    }

    /// Reject every property that no reader consumed.
    pub fn finish(&self) -> Result<()> {
        let left: Vec<&str> = self
            .entries
            .iter()
            .zip(&self.used)
            .filter(|(_, u)| !u.get())
            .map(|((k, _), _)| k.as_str())
            .collect();
        match left.first() {
            None => Ok(()),
            Some(k) => Err(self.err(
                k,
                format!(
                    "unreferenced property (not a parameter of this plugin); all unused: {left:?}"
                ),
            )),
        }
    }
}
