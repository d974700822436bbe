//! Mitsuba 3 XML scene files (the form mitransient 1.3.1 and tal write), read into a [`Props`]
//! tree: `<default>` and `$name` substitution, typed properties, `<transform>` operations
//! (translate, rotate, scale, lookat, matrix) and `<ref>`.

use crate::error::{NlosError, Result};
use crate::math::{look_at, rotate, scale, translate};
use crate::props::{Props, Value};
use glam::DMat4;
use roxmltree::{Document, Node};
use std::collections::{HashMap, HashSet};
use std::path::Path;

const OBJECT_TAGS: [&str; 13] = [
    "scene",
    "medium",
    "phase",
    "texture",
    "volume",
    "integrator",
    "shape",
    "bsdf",
    "emitter",
    "sensor",
    "sampler",
    "film",
    "rfilter",
];

/// Deepest nesting of objects read (a scene needs a handful; the limit guards the stack).
pub const MAX_DEPTH: usize = 64;

/// Largest XML file read.
pub const MAX_XML_BYTES: u64 = 256 << 20;

struct Reader<'a> {
    path: &'a Path,
    doc: &'a Document<'a>,
    params: HashMap<String, String>,
    used_params: HashSet<String>,
}

impl Reader<'_> {
    fn err(&self, node: Node, msg: impl Into<String>) -> NlosError {
        let pos = self.doc.text_pos_at(node.range().start);
        NlosError::Xml {
            path: self.path.to_path_buf(),
            msg: format!("line {}: {}", pos.row, msg.into()),
        }
    }

    /// An attribute with `$name` parameters substituted.
    fn attr(&mut self, node: Node, name: &str) -> Result<Option<String>> {
        let Some(raw) = node.attribute(name) else {
            return Ok(None);
        };
        let mut out = String::new();
        let mut rest = raw;
        while let Some(i) = rest.find('$') {
            out.push_str(&rest[..i]);
            let tail = &rest[i + 1..];
            let end = tail
                .find(|c: char| !(c.is_alphanumeric() || c == '_'))
                .unwrap_or(tail.len());
            let key = &tail[..end];
            let v = self.params.get(key).ok_or_else(|| {
                self.err(
                    node,
                    format!(
                        "undefined parameter '${key}' (pass it to load_file or add a <default>)"
                    ),
                )
            })?;
            out.push_str(v);
            self.used_params.insert(key.to_string());
            rest = &tail[end..];
        }
        out.push_str(rest);
        Ok(Some(out))
    }

    fn need(&mut self, node: Node, name: &str) -> Result<String> {
        self.attr(node, name)?.ok_or_else(|| {
            self.err(
                node,
                format!("<{}> needs a '{name}' attribute", node.tag_name().name()),
            )
        })
    }

    fn numbers(&self, node: Node, s: &str) -> Result<Vec<f64>> {
        s.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(|t| {
                t.parse::<f64>()
                    .map_err(|_| self.err(node, format!("'{t}' is not a number")))
            })
            .collect()
    }

    /// `"400:0.1, 500:0.5"`: wavelength:value pairs.
    fn pairs(&self, node: Node, s: &str) -> Result<Vec<(f64, f64)>> {
        s.split(',')
            .map(|item| {
                let (w, v) = item.split_once(':').ok_or_else(|| {
                    self.err(node, format!("'{}' is not wavelength:value", item.trim()))
                })?;
                let num = |t: &str| {
                    t.trim()
                        .parse::<f64>()
                        .map_err(|_| self.err(node, format!("'{}' is not a number", t.trim())))
                };
                Ok((num(w)?, num(v)?))
            })
            .collect()
    }

    fn vec3(&mut self, node: Node, attr: &str, default: f64) -> Result<[f64; 3]> {
        if let Some(v) = self.attr(node, attr)? {
            let n = self.numbers(node, &v)?;
            return match n.len() {
                1 => Ok([n[0]; 3]),
                3 => Ok([n[0], n[1], n[2]]),
                _ => Err(self.err(node, format!("'{attr}' needs 1 or 3 numbers"))),
            };
        }
        let mut out = [default; 3];
        for (i, k) in ["x", "y", "z"].iter().enumerate() {
            if let Some(v) = self.attr(node, k)? {
                out[i] = v
                    .trim()
                    .parse()
                    .map_err(|_| self.err(node, format!("'{k}' is not a number")))?;
            }
        }
        Ok(out)
    }

    fn transform(&mut self, node: Node) -> Result<DMat4> {
        let mut m = DMat4::IDENTITY;
        for op in node.children().filter(Node::is_element) {
            let step = match op.tag_name().name() {
                "translate" => translate(self.vec3(op, "value", 0.0)?),
                "scale" => scale(self.vec3(op, "value", 1.0)?),
                "rotate" => {
                    let axis = self.vec3(op, "value", 0.0)?;
                    let angle = self.need(op, "angle")?;
                    rotate(
                        axis,
                        angle
                            .trim()
                            .parse()
                            .map_err(|_| self.err(op, "'angle' is not a number"))?,
                    )
                }
                "lookat" | "lookAt" => {
                    let mut pt = |name: &str| -> Result<[f64; 3]> {
                        let s = self.need(op, name)?;
                        let n = self.numbers(op, &s)?;
                        if n.len() != 3 {
                            return Err(self.err(op, format!("'{name}' needs 3 numbers")));
                        }
                        Ok([n[0], n[1], n[2]])
                    };
                    let (o, t) = (pt("origin")?, pt("target")?);
                    let up = if op.attribute("up").is_some() {
                        pt("up")?
                    } else {
                        [0.0, 1.0, 0.0]
                    };
                    look_at(o, t, up).ok_or_else(|| {
                        self.err(
                            op,
                            "degenerate lookat (target = origin or up parallel to the view)",
                        )
                    })?
                }
                "matrix" => {
                    let s = self.need(op, "value")?;
                    let n = self.numbers(op, &s)?;
                    if n.len() != 16 {
                        return Err(self.err(op, "<matrix> needs 16 numbers"));
                    }
                    DMat4::from_cols_array(&n.try_into().unwrap_or([0.0; 16])).transpose()
                }
                other => return Err(self.err(op, format!("unknown transform operation <{other}>"))),
            };
            m = step * m;
        }
        Ok(m)
    }

    fn object(&mut self, node: Node) -> Result<Props> {
        let depth = node.ancestors().count();
        if depth > MAX_DEPTH {
            return Err(self.err(node, format!("objects nested more than {MAX_DEPTH} deep")));
        }
        let tag = node.tag_name().name();
        let plugin = if tag == "scene" {
            "scene".to_string()
        } else {
            self.need(node, "type")?
        };
        let mut props = Props::new(plugin, self.attr(node, "id")?);
        for (n, child) in node.children().filter(Node::is_element).enumerate() {
            let ctag = child.tag_name().name();
            if ctag == "default" {
                if tag != "scene" {
                    return Err(self.err(child, "<default> is only allowed at the top of <scene>"));
                }
                continue;
            }
            let name = self.attr(child, "name")?;
            let value = match ctag {
                t if OBJECT_TAGS.contains(&t) => {
                    let obj = self.object(child)?;
                    let key = name
                        .or_else(|| obj.id.clone())
                        .unwrap_or_else(|| format!("_{t}_{n}"));
                    props
                        .insert(key, Value::Object(obj))
                        .map_err(|e| self.err(child, e.to_string()))?;
                    continue;
                }
                "ref" => {
                    let id = self.need(child, "id")?;
                    let key = name.unwrap_or_else(|| format!("_ref_{n}"));
                    props
                        .insert(key, Value::Ref(id))
                        .map_err(|e| self.err(child, e.to_string()))?;
                    continue;
                }
                "integer" => {
                    let v = self.need(child, "value")?;
                    Value::Int(
                        v.trim()
                            .parse()
                            .map_err(|_| self.err(child, format!("'{v}' is not an integer")))?,
                    )
                }
                "float" => {
                    let v = self.need(child, "value")?;
                    Value::Float(
                        v.trim()
                            .parse()
                            .map_err(|_| self.err(child, format!("'{v}' is not a float")))?,
                    )
                }
                // Any case, as Mitsuba reads them ("True", "FALSE", ...).
                "boolean" => match self.need(child, "value")?.trim().to_lowercase().as_str() {
                    "true" => Value::Bool(true),
                    "false" => Value::Bool(false),
                    v => {
                        return Err(self.err(child, format!("'{v}' is not a boolean (true/false)")));
                    }
                },
                "string" => Value::Str(self.need(child, "value")?),
                "point" | "vector" => Value::Vec3(self.vec3(child, "value", 0.0)?),
                "rgb" => {
                    let v = self.need(child, "value")?;
                    let n = self.numbers(child, &v)?;
                    match n.len() {
                        1 => Value::Rgb([n[0]; 3]),
                        3 => Value::Rgb([n[0], n[1], n[2]]),
                        _ => return Err(self.err(child, "<rgb> needs 1 or 3 numbers")),
                    }
                }
                // <spectrum type="regular|irregular|..."> is a spectrum plugin with properties.
                "spectrum" if child.has_attribute("type") => Value::Object(self.object(child)?),
                "spectrum" => {
                    let v = self.need(child, "value")?;
                    if v.contains(':') {
                        Value::Spectrum(self.pairs(child, &v)?)
                    } else {
                        match self.numbers(child, &v)?.as_slice() {
                            [x] => Value::UniformSpectrum(*x),
                            _ => {
                                return Err(self.err(
                                    child,
                                    "<spectrum value> is one number or wavelength:value pairs",
                                ));
                            }
                        }
                    }
                }
                "transform" => Value::Matrix(self.transform(child)?),
                other => return Err(self.err(child, format!("unknown element <{other}>"))),
            };
            let key =
                name.ok_or_else(|| self.err(child, format!("<{ctag}> needs a 'name' attribute")))?;
            props
                .insert(key, value)
                .map_err(|e| self.err(child, e.to_string()))?;
        }
        Ok(props)
    }
}

/// Parse a Mitsuba XML scene file; `params` override its `<default>`s.
pub fn load(path: &Path, params: &HashMap<String, String>) -> Result<Props> {
    let xml_err = |msg: String| NlosError::Xml {
        path: path.to_path_buf(),
        msg,
    };
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() => return Err(xml_err("is not a regular file".into())),
        Ok(m) if m.len() > MAX_XML_BYTES => {
            return Err(xml_err(format!(
                "is {} bytes, more than the {MAX_XML_BYTES} a scene file may have",
                m.len()
            )));
        }
        _ => {}
    }
    let text = std::fs::read_to_string(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => NlosError::NotFound(path.to_path_buf()),
        _ => NlosError::Xml {
            path: path.to_path_buf(),
            msg: e.to_string(),
        },
    })?;
    parse(&text, path, params)
}

/// Parse XML text; `path` names it in errors.
pub fn parse(text: &str, path: &Path, params: &HashMap<String, String>) -> Result<Props> {
    let doc = Document::parse(text).map_err(|e| NlosError::Xml {
        path: path.to_path_buf(),
        msg: e.to_string(),
    })?;
    let root = doc.root_element();
    let mut r = Reader {
        path,
        doc: &doc,
        params: HashMap::new(),
        used_params: HashSet::new(),
    };
    if root.tag_name().name() != "scene" {
        return Err(r.err(root, "the root element must be <scene>"));
    }
    // Defaults first, then the caller's parameters override them.
    for d in root.children().filter(|n| n.has_tag_name("default")) {
        let (name, value) = (r.need(d, "name")?, r.need(d, "value")?);
        r.params.insert(name.clone(), value);
        r.used_params.insert(name);
    }
    for (k, v) in params {
        r.params.insert(k.clone(), v.clone());
    }
    let props = r.object(root)?;
    if let Some(k) = params.keys().find(|k| !r.used_params.contains(*k)) {
        return Err(NlosError::Xml {
            path: path.to_path_buf(),
            msg: format!("parameter '{k}' is not used by the scene (no ${k} in it)"),
        });
    }
    Ok(props)
}
