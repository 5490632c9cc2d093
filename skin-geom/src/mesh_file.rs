//! User meshes from OBJ (tobj) and glTF (gltf) files.
//!
//! A mesh file can be the skin itself (each vertex a taxel, ids = vertex index, normals from the
//! triangles) or the triangles for a layout's taxels ([`MeshFileLink::attach_to`]: each mesh
//! vertex is matched to the taxel at its position).

use crate::{Error, Result};
use nalgebra::{Point3, Unit, Vector3};
use skin_core::{LinkSkin, Taxel, TaxelId};
use std::path::Path;

/// The vertices and triangles read from a mesh file, metres.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshFileLink {
    /// Vertex positions.
    pub vertices: Vec<Point3<f64>>,
    /// Triangles (counter-clockwise seen from outside, as mesh files are written).
    pub faces: Vec<[usize; 3]>,
}

fn mesh_error(path: &Path, message: impl Into<String>) -> Error {
    Error::MeshFile {
        path: path.display().to_string(),
        message: message.into(),
    }
}

/// Reads an OBJ (`.obj`) or glTF (`.gltf`, `.glb`) file; all its meshes are merged.
pub fn load_mesh_file(path: &Path) -> Result<MeshFileLink> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let mesh = match ext.as_str() {
        "obj" => load_obj(path)?,
        "gltf" | "glb" => load_gltf(path)?,
        _ => {
            return Err(mesh_error(
                path,
                "unknown mesh format (expected .obj, .gltf or .glb)",
            ));
        }
    };
    let n = mesh.vertices.len();
    if let Some(i) = mesh
        .vertices
        .iter()
        .position(|p| !p.coords.iter().all(|v| v.is_finite()))
    {
        return Err(mesh_error(
            path,
            format!("vertex {i} has a coordinate that is not finite"),
        ));
    }
    for (f, face) in mesh.faces.iter().enumerate() {
        if let Some(v) = face.iter().find(|&&v| v >= n) {
            return Err(mesh_error(
                path,
                format!("face {f} uses vertex {v}, but there are {n} vertices"),
            ));
        }
    }
    Ok(mesh)
}

fn load_obj(path: &Path) -> Result<MeshFileLink> {
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    let (models, _materials) =
        tobj::load_obj(path, &options).map_err(|e| mesh_error(path, format!("OBJ: {e}")))?;
    // tobj keeps only the vertices that faces use, but every vertex of a skin mesh is a taxel:
    // read the `v` lines too, and map tobj's vertices back to them by their (identical) values.
    let text = std::fs::read_to_string(path).map_err(|e| mesh_error(path, e.to_string()))?;
    let mut vertices = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let mut fields = line.split_whitespace();
        if fields.next() != Some("v") {
            continue;
        }
        let xyz: Vec<f64> = fields
            .take(3)
            .map(str::parse)
            .collect::<Result<_, _>>()
            .map_err(|_| {
                mesh_error(
                    path,
                    format!("line {}: a vertex coordinate is not a number", i + 1),
                )
            })?;
        if xyz.len() != 3 {
            return Err(mesh_error(path, format!("line {}: a vertex needs x y z", i + 1)));
        }
        vertices.push(Point3::new(xyz[0], xyz[1], xyz[2]));
    }
    let key = |p: &Point3<f64>| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    let mut by_value: std::collections::HashMap<[u64; 3], Vec<usize>> = std::collections::HashMap::new();
    for (i, p) in vertices.iter().enumerate().rev() {
        by_value.entry(key(p)).or_default().push(i);
    }
    let mut faces = Vec::new();
    for m in models {
        let mut original = Vec::with_capacity(m.mesh.positions.len() / 3);
        for p in m.mesh.positions.chunks_exact(3) {
            let p = Point3::new(p[0], p[1], p[2]);
            let candidates = by_value.get_mut(&key(&p));
            // Several `v` lines with one value are one vertex to tobj: reuse the first.
            let index = match candidates {
                Some(c) if c.len() > 1 => c.pop(),
                Some(c) => c.first().copied(),
                None => None,
            }
            .ok_or_else(|| mesh_error(path, "OBJ: a face vertex is not among the v lines"))?;
            original.push(index);
        }
        faces.extend(m.mesh.indices.chunks_exact(3).map(|f| {
            [
                original[f[0] as usize],
                original[f[1] as usize],
                original[f[2] as usize],
            ]
        }));
    }
    Ok(MeshFileLink { vertices, faces })
}

fn load_gltf(path: &Path) -> Result<MeshFileLink> {
    let bytes = std::fs::read(path).map_err(|e| mesh_error(path, e.to_string()))?;
    let gltf = gltf::Gltf::from_slice(&bytes).map_err(|e| mesh_error(path, format!("glTF: {e}")))?;
    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for buffer in gltf.buffers() {
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => gltf
                .blob
                .clone()
                .ok_or_else(|| mesh_error(path, "glTF: binary buffer missing"))?,
            gltf::buffer::Source::Uri(uri) if !uri.starts_with("data:") => {
                let file = path.parent().unwrap_or(Path::new(".")).join(uri);
                std::fs::read(&file)
                    .map_err(|e| mesh_error(path, format!("glTF buffer {}: {e}", file.display())))?
            }
            gltf::buffer::Source::Uri(_) => {
                return Err(mesh_error(
                    path,
                    "glTF: embedded data URIs are not supported; save as .glb or with a separate .bin",
                ));
            }
        };
        buffers.push(data);
    }
    let mut mesh = MeshFileLink {
        vertices: Vec::new(),
        faces: Vec::new(),
    };
    for m in gltf.meshes() {
        for prim in m.primitives() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                continue;
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(|v| v.as_slice()));
            let base = mesh.vertices.len();
            let positions = reader
                .read_positions()
                .ok_or_else(|| mesh_error(path, "glTF: a primitive has no positions"))?;
            mesh.vertices
                .extend(positions.map(|p| Point3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))));
            let count = mesh.vertices.len() - base;
            let indices: Vec<usize> = match reader.read_indices() {
                Some(ix) => ix.into_u32().map(|i| i as usize).collect(),
                None => (0..count).collect(),
            };
            mesh.faces.extend(
                indices
                    .chunks_exact(3)
                    .map(|f| [base + f[0], base + f[1], base + f[2]]),
            );
        }
    }
    Ok(mesh)
}

impl MeshFileLink {
    /// The mesh as a skin: one taxel per vertex (id = vertex index), normals averaged from the
    /// triangles around each vertex (a vertex in no triangle takes its nearest neighbour's).
    pub fn into_link(self, name: &str) -> Result<LinkSkin> {
        let n = self.vertices.len();
        let mut normals = vec![Vector3::zeros(); n];
        for f in &self.faces {
            let [a, b, c] = f.map(|i| self.vertices[i]);
            let nrm = (b - a).cross(&(c - a)); // length = twice the area: area weighting
            for &v in f {
                normals[v] += nrm;
            }
        }
        let known: Vec<usize> = (0..n).filter(|&v| normals[v].norm() > 0.0).collect();
        if known.is_empty() {
            return Err(Error::TooFewTaxels(
                "the mesh has no triangle of non-zero area".into(),
            ));
        }
        let mut taxels = Vec::with_capacity(n);
        for v in 0..n {
            let nrm = if normals[v].norm() > 0.0 {
                normals[v]
            } else {
                let p = self.vertices[v];
                let near = known
                    .iter()
                    .copied()
                    .min_by(|&a, &b| {
                        (self.vertices[a] - p)
                            .norm()
                            .total_cmp(&(self.vertices[b] - p).norm())
                    })
                    .unwrap_or(known[0]);
                normals[near]
            };
            taxels.push(Taxel {
                id: TaxelId(v as u32),
                position: self.vertices[v],
                normal: Unit::new_normalize(nrm),
            });
        }
        let mut link = LinkSkin::new(name, taxels);
        link.faces = Some(self.faces);
        Ok(link)
    }

    /// Gives `link` the triangles of this mesh: each mesh vertex is matched to the taxel within
    /// `tolerance` metres of it; a vertex with no taxel there is an error naming it.
    pub fn attach_to(&self, link: &LinkSkin, tolerance: f64) -> Result<LinkSkin> {
        let mut matched = Vec::with_capacity(self.vertices.len());
        for (v, p) in self.vertices.iter().enumerate() {
            let (best, d) = link
                .taxels
                .iter()
                .enumerate()
                .map(|(i, t)| (i, (t.position - p).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .ok_or_else(|| Error::TooFewTaxels("the layout has no taxel".into()))?;
            if d > tolerance {
                return Err(Error::Mismatch(format!(
                    "mesh vertex {v} at ({:.4}, {:.4}, {:.4}) m has no taxel within {:.1} mm (nearest: taxel {} at {:.1} mm)",
                    p.x,
                    p.y,
                    p.z,
                    tolerance * 1e3,
                    link.taxels[best].id,
                    d * 1e3
                )));
            }
            matched.push(best);
        }
        let mut out = link.clone();
        out.faces = Some(self.faces.iter().map(|f| f.map(|v| matched[v])).collect());
        Ok(out)
    }
}
