//! Triangle meshes: OBJ (tobj) and PLY (ply-rs) loading, and Mitsuba's built-in `rectangle` and
//! `cube` meshes. A mesh is validated here so that a broken file is an error, never a crash.

use crate::error::{NlosError, Result};
use glam::Vec3A;
use std::path::Path;

/// Positions, triangle indices and optional per-vertex normals, in object space.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<Vec3A>,
    /// Per-vertex normals (same length as `positions`) if the file has them.
    pub normals: Option<Vec<Vec3A>>,
    /// Triangles as vertex-index triples.
    pub triangles: Vec<[u32; 3]>,
}

/// Largest mesh file read (a file beyond it is refused before reading).
pub const MAX_MESH_BYTES: u64 = 4 << 30;

/// A mesh file's bytes, after checking that it is a regular file of a sane size (not a device,
/// a directory or a pipe, which could be endless).
fn read_mesh_file(path: &Path) -> Result<Vec<u8>> {
    let meta = std::fs::metadata(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => NlosError::NotFound(path.to_path_buf()),
        _ => mesh_err(path, e.to_string()),
    })?;
    if !meta.is_file() {
        return Err(mesh_err(path, "is not a regular file"));
    }
    if meta.len() > MAX_MESH_BYTES {
        return Err(mesh_err(
            path,
            format!(
                "is {} bytes, more than the {MAX_MESH_BYTES} a mesh may have",
                meta.len()
            ),
        ));
    }
    std::fs::read(path).map_err(|e| mesh_err(path, e.to_string()))
}

/// Check a PLY header before a parser allocates what it declares: every element has properties,
/// and the counts cannot need more bytes than the file has (each property takes ≥ 1 byte).
fn check_ply_header(path: &Path, bytes: &[u8]) -> Result<()> {
    let end = bytes
        .windows(10)
        .take(1 << 16)
        .position(|w| w == b"end_header")
        .ok_or_else(|| mesh_err(path, "no 'end_header' in the first 64 KiB"))?;
    let header = String::from_utf8_lossy(&bytes[..end]);
    // ply-rs reads header numbers as u64 and panics beyond: no number that long.
    let longest_number = header
        .split(|c: char| !c.is_ascii_digit())
        .map(str::len)
        .max()
        .unwrap_or(0);
    if longest_number > 18 {
        return Err(mesh_err(
            path,
            "a number in the header has more than 18 digits",
        ));
    }
    let mut elements: Vec<(String, u64, u64)> = Vec::new();
    for line in header.lines() {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["element", name, count] => {
                let n = count
                    .parse::<u64>()
                    .map_err(|_| mesh_err(path, format!("element '{name}' has count '{count}'")))?;
                elements.push((name.to_string(), n, 0));
            }
            ["property", ..] => match elements.last_mut() {
                Some(e) => e.2 += 1,
                None => return Err(mesh_err(path, "a property before any element")),
            },
            _ => {}
        }
    }
    let mut need: u64 = 0;
    for (name, count, props) in &elements {
        if *count > 0 && *props == 0 {
            return Err(mesh_err(
                path,
                format!("element '{name}' has no properties"),
            ));
        }
        need = need.saturating_add(count.saturating_mul(*props));
    }
    let have = (bytes.len() - end) as u64;
    if need > have {
        return Err(mesh_err(
            path,
            format!("the header declares {need} values but only {have} bytes follow it"),
        ));
    }
    Ok(())
}

/// Check every face/line/point index of an OBJ before tobj sees it (tobj's index arithmetic can
/// overflow on huge or out-of-range indices): each `v/vt/vn` index must be a non-zero integer
/// referring to an element of that kind in the file (negative: counted back from the current one).
fn check_obj_indices(path: &Path, bytes: &[u8]) -> Result<()> {
    let text = String::from_utf8_lossy(bytes);
    let mut total = [0i64; 3];
    for line in text.lines() {
        match line.split_whitespace().next() {
            Some("v") => total[0] += 1,
            Some("vt") => total[1] += 1,
            Some("vn") => total[2] += 1,
            _ => {}
        }
    }
    let mut seen = [0i64; 3];
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => seen[0] += 1,
            Some("vt") => seen[1] += 1,
            Some("vn") => seen[2] += 1,
            Some("f" | "l" | "p") => {
                for token in words {
                    for (kind, part) in token.split('/').enumerate().take(3) {
                        if part.is_empty() {
                            continue;
                        }
                        let ok = part.parse::<i64>().is_ok_and(|i| {
                            (i > 0 && i <= total[kind]) || (i < 0 && -i <= seen[kind])
                        });
                        if !ok {
                            return Err(mesh_err(
                                path,
                                format!("line {}: index '{part}' refers to no element", n + 1),
                            ));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

fn mesh_err(path: &Path, msg: impl Into<String>) -> NlosError {
    NlosError::Mesh {
        path: path.to_path_buf(),
        msg: msg.into(),
    }
}

impl Mesh {
    /// Check indices, finiteness and that some triangle has area.
    pub fn validate(&self, path: &Path) -> Result<()> {
        let n = self.positions.len();
        if self.triangles.is_empty() {
            return Err(mesh_err(path, "has no triangles"));
        }
        if let Some(bad) = self.triangles.iter().flatten().find(|&&i| i as usize >= n) {
            return Err(mesh_err(
                path,
                format!("face index {bad} out of range ({n} vertices)"),
            ));
        }
        if !self.positions.iter().all(|p| p.is_finite()) {
            return Err(mesh_err(path, "has non-finite vertex positions"));
        }
        if let Some(ns) = &self.normals
            && (ns.len() != n || !ns.iter().all(|v| v.is_finite()))
        {
            return Err(mesh_err(path, "has malformed vertex normals"));
        }
        let area: f32 = self.triangles.iter().map(|t| self.area(t)).sum();
        if !(area > 0.0) {
            return Err(mesh_err(path, "has zero surface area"));
        }
        Ok(())
    }

    fn area(&self, t: &[u32; 3]) -> f32 {
        let [a, b, c] = t.map(|i| self.positions[i as usize]);
        0.5 * (b - a).cross(c - a).length()
    }

    /// Load an OBJ file (polygons are triangulated; normals kept if every vertex has one).
    pub fn load_obj(path: &Path) -> Result<Self> {
        Self::parse_obj(&read_mesh_file(path)?, path)
    }

    /// Parse OBJ text (`path` names it in errors); `mtllib` files are never opened.
    pub fn parse_obj(bytes: &[u8], path: &Path) -> Result<Self> {
        check_obj_indices(path, bytes)?;
        let opts = tobj::LoadOptions {
            single_index: true,
            triangulate: true,
            ..Default::default()
        };
        // Materials are not used: `mtllib` files are never opened.
        let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &opts, |_| {
            Ok(Default::default())
        })
        .map_err(|e| mesh_err(path, e.to_string()))?;
        let mut mesh = Mesh::default();
        let mut all_normals = true;
        let mut normals = Vec::new();
        for m in models {
            let m = m.mesh;
            let base = mesh.positions.len() as u32;
            mesh.positions.extend(
                m.positions
                    .chunks_exact(3)
                    .map(|p| Vec3A::new(p[0], p[1], p[2])),
            );
            if m.normals.len() == m.positions.len() {
                normals.extend(
                    m.normals
                        .chunks_exact(3)
                        .map(|p| Vec3A::new(p[0], p[1], p[2])),
                );
            } else {
                all_normals = false;
            }
            mesh.triangles.extend(
                m.indices
                    .chunks_exact(3)
                    .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
            );
        }
        if all_normals && !normals.is_empty() {
            mesh.normals = Some(normals);
        }
        mesh.validate(path)?;
        Ok(mesh)
    }

    /// Load a PLY file (ASCII or binary; `vertex` x/y/z [nx/ny/nz], `face` vertex_indices).
    pub fn load_ply(path: &Path) -> Result<Self> {
        Self::parse_ply(&read_mesh_file(path)?, path)
    }

    /// Parse PLY bytes (`path` names it in errors), its header checked first.
    pub fn parse_ply(bytes: &[u8], path: &Path) -> Result<Self> {
        use ply_rs::{parser::Parser, ply::Property};
        check_ply_header(path, bytes)?;
        let mut reader = std::io::Cursor::new(bytes);
        let ply = Parser::<ply_rs::ply::DefaultElement>::new()
            .read_ply(&mut reader)
            .map_err(|e| mesh_err(path, e.to_string()))?;
        let num = |p: Option<&Property>| -> Option<f32> {
            Some(match p? {
                Property::Float(v) => *v,
                Property::Double(v) => *v as f32,
                Property::Int(v) => *v as f32,
                Property::UInt(v) => *v as f32,
                Property::Short(v) => *v as f32,
                Property::UShort(v) => *v as f32,
                Property::Char(v) => *v as f32,
                Property::UChar(v) => *v as f32,
                _ => return None,
            })
        };
        let mut mesh = Mesh::default();
        let verts = ply
            .payload
            .get("vertex")
            .ok_or_else(|| mesh_err(path, "no 'vertex' element"))?;
        let mut normals = Vec::new();
        for v in verts {
            let p = [num(v.get("x")), num(v.get("y")), num(v.get("z"))];
            let [Some(x), Some(y), Some(z)] = p else {
                return Err(mesh_err(path, "vertex without numeric x, y, z"));
            };
            mesh.positions.push(Vec3A::new(x, y, z));
            if let [Some(x), Some(y), Some(z)] =
                [num(v.get("nx")), num(v.get("ny")), num(v.get("nz"))]
            {
                normals.push(Vec3A::new(x, y, z));
            }
        }
        if normals.len() == mesh.positions.len() && !normals.is_empty() {
            mesh.normals = Some(normals);
        }
        let faces = ply
            .payload
            .get("face")
            .ok_or_else(|| mesh_err(path, "no 'face' element"))?;
        for f in faces {
            let idx: Vec<i64> = match f.get("vertex_indices").or_else(|| f.get("vertex_index")) {
                Some(Property::ListInt(v)) => v.iter().map(|&i| i as i64).collect(),
                Some(Property::ListUInt(v)) => v.iter().map(|&i| i as i64).collect(),
                Some(Property::ListUChar(v)) => v.iter().map(|&i| i as i64).collect(),
                Some(Property::ListShort(v)) => v.iter().map(|&i| i as i64).collect(),
                Some(Property::ListUShort(v)) => v.iter().map(|&i| i as i64).collect(),
                _ => {
                    return Err(mesh_err(
                        path,
                        "face without an integer vertex_indices list",
                    ));
                }
            };
            if idx.len() < 3 || idx.iter().any(|&i| i < 0 || i > u32::MAX as i64) {
                return Err(mesh_err(path, "face with fewer than 3 or negative indices"));
            }
            // Triangulate polygons as fans.
            for k in 1..idx.len() - 1 {
                mesh.triangles
                    .push([idx[0] as u32, idx[k] as u32, idx[k + 1] as u32]);
            }
        }
        mesh.validate(path)?;
        Ok(mesh)
    }

    /// Mitsuba's `Mesh::recompute_vertex_normals`, applied to OBJ/PLY files without normals
    /// (unless `face_normals`): each face normal weighted by the face's angle at the vertex
    /// (Thürmer and Wüthrich 1998, "Computing vertex normals from polygonal facets").
    pub fn recompute_vertex_normals(&mut self) {
        let mut normals = vec![Vec3A::ZERO; self.positions.len()];
        for t in &self.triangles {
            let v = t.map(|i| self.positions[i as usize]);
            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
            for k in 0..3 {
                let d0 = (v[(k + 1) % 3] - v[k]).normalize_or_zero();
                let d1 = (v[(k + 2) % 3] - v[k]).normalize_or_zero();
                normals[t[k] as usize] += n * d0.dot(d1).clamp(-1.0, 1.0).acos();
            }
        }
        for n in &mut normals {
            *n = n.try_normalize().unwrap_or(Vec3A::X);
        }
        self.normals = Some(normals);
    }

    /// Mitsuba's `rectangle`: [-1, 1]² in the z = 0 plane, normal +z.
    pub fn rectangle() -> Self {
        let positions = vec![
            Vec3A::new(-1.0, -1.0, 0.0),
            Vec3A::new(1.0, -1.0, 0.0),
            Vec3A::new(1.0, 1.0, 0.0),
            Vec3A::new(-1.0, 1.0, 0.0),
        ];
        Mesh {
            positions,
            normals: None,
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    /// Mitsuba's `cube`: [-1, 1]³, outward faces, flat shading.
    pub fn cube() -> Self {
        let mut mesh = Mesh::default();
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let n = Vec3A::AXES[axis] * sign;
                let u = Vec3A::AXES[(axis + 1) % 3];
                let v = n.cross(u);
                let base = mesh.positions.len() as u32;
                for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                    mesh.positions.push(n + u * a + v * b);
                }
                mesh.triangles.push([base, base + 1, base + 2]);
                mesh.triangles.push([base, base + 2, base + 3]);
            }
        }
        mesh
    }
}
