//! User meshes from OBJ (tobj) and glTF (gltf) files.
//!
//! A mesh file can be the skin itself (each vertex a taxel, ids = vertex index, normals from the
//! triangles) or the triangles for a layout's taxels ([`MeshFileLink::attach_to`]: each mesh
//! vertex is matched to the taxel at its position).

use crate::{Error, Result};
use nalgebra::{Point3, Unit, Vector3};
use skin_core::format::MAX_POSITION_M;
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

/// The largest mesh file (OBJ, glTF, GLB, or a glTF's buffer) read, bytes: 256 MiB, far more
/// than a skin's mesh (a vertex per taxel) takes. A larger file (a whole robot's CAD model, a
/// wrong file) is refused before it is read.
pub const MAX_MESH_BYTES: u64 = 256 << 20;

fn mesh_error(path: &Path, message: impl Into<String>) -> Error {
    Error::MeshFile {
        path: path.display().to_string(),
        message: message.into(),
    }
}

/// Reads an OBJ (`.obj`) or glTF (`.gltf`, `.glb`) file; all its meshes are merged. A file (or
/// a glTF buffer) past [`MAX_MESH_BYTES`] is refused before it is read.
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
    if let Some(i) = mesh.vertices.iter().position(|p| {
        !p.coords
            .iter()
            .all(|v| v.is_finite() && v.abs() <= MAX_POSITION_M)
    }) {
        return Err(mesh_error(
            path,
            format!(
                "vertex {i} at {:?} is not finite metres within {MAX_POSITION_M} m of the origin (positions are in metres)",
                mesh.vertices[i].coords.as_slice()
            ),
        ));
    }
    for (f, face) in mesh.faces.iter().enumerate() {
        if let Some(v) = face.iter().find(|&&v| v >= n) {
            return Err(mesh_error(
                path,
                format!("face {f} uses vertex {v}, but there are {n} vertices"),
            ));
        }
        // A triangle on one vertex twice has no area and no normal; a layout's faces are held
        // to the same rule.
        if face[0] == face[1] || face[1] == face[2] || face[0] == face[2] {
            return Err(mesh_error(path, format!("face {f} {face:?} repeats a vertex")));
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
    // Read once, bounded, as text (byte-order mark, CR line ends): a pipe is read once too.
    let text = skin_core::text::read_document(path, MAX_MESH_BYTES)?;
    // Materials are not used: none is loaded.
    let (models, _materials) = tobj::load_obj_buf(&mut text.as_bytes(), &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| mesh_error(path, format!("OBJ: {e}")))?;
    // tobj keeps only the vertices that faces use, but every vertex of a skin mesh is a taxel:
    // read the `v` lines too, and map tobj's vertices back to them by their (identical) values.
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
    use gltf::json::mesh::Mode;
    use gltf::json::validation::Checked;
    let bytes = skin_core::text::read_bytes(path, MAX_MESH_BYTES)?;
    // The gltf crate's validation and accessor reader index by the file's numbers without
    // checking them all (a hostile file makes them panic), so the file is parsed without its
    // validation and every number read below is checked here before it indexes anything. Its
    // GLB reader subtracts the header's size from the length the header declares: checked first.
    if let Some(declared) = bytes
        .strip_prefix(b"glTF")
        .and_then(|rest| rest.get(4..8))
        .map(|l| u32::from_le_bytes([l[0], l[1], l[2], l[3]]))
        && declared < 12
    {
        return Err(mesh_error(
            path,
            format!("GLB: the header declares {declared} bytes, less than the header's 12"),
        ));
    }
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes)
        .map_err(|e| mesh_error(path, format!("glTF: {e}")))?;
    let buffers = gltf_buffers(path, &gltf)?;
    let root = gltf.document.as_json();
    let mut mesh = MeshFileLink {
        vertices: Vec::new(),
        faces: Vec::new(),
    };
    for (m, json_mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in json_mesh.primitives.iter().enumerate() {
            // Points and lines are not a surface.
            if prim.mode != Checked::Valid(Mode::Triangles) {
                continue;
            }
            let place = format!("mesh {m} primitive {p}");
            add_primitive(path, (root, &buffers), prim, &place, &mut mesh)?;
        }
    }
    Ok(mesh)
}

/// The file's buffers: its binary chunk, or the files their uris name (checked to hold the
/// bytes they declare).
fn gltf_buffers(path: &Path, gltf: &gltf::Gltf) -> Result<Vec<Vec<u8>>> {
    let root = gltf.document.as_json();
    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for (k, buffer) in root.buffers.iter().enumerate() {
        let data = match buffer.uri.as_deref() {
            None => gltf.blob.clone().ok_or_else(|| {
                mesh_error(
                    path,
                    format!("glTF: buffer {k} has no uri and the file no binary chunk"),
                )
            })?,
            Some(uri) if uri.starts_with("data:") => {
                return Err(mesh_error(
                    path,
                    "glTF: embedded data URIs are not supported; save as .glb or with a separate .bin",
                ));
            }
            Some(uri) => {
                let file = path.parent().unwrap_or(Path::new(".")).join(uri);
                skin_core::text::read_bytes(&file, MAX_MESH_BYTES)
                    .map_err(|e| mesh_error(path, format!("glTF buffer: {e}")))?
            }
        };
        let declared = buffer.byte_length.0;
        if (data.len() as u64) < declared {
            return Err(mesh_error(
                path,
                format!(
                    "glTF: buffer {k} holds {} bytes but declares {declared}",
                    data.len()
                ),
            ));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// Adds the triangles of primitive `prim` (named `place` in errors) to `mesh`.
fn add_primitive(
    path: &Path,
    (root, buffers): (&gltf::json::Root, &[Vec<u8>]),
    prim: &gltf::json::mesh::Primitive,
    place: &str,
    mesh: &mut MeshFileLink,
) -> Result<()> {
    use gltf::json::accessor::{ComponentType, Type};
    use gltf::json::mesh::Semantic;
    use gltf::json::validation::Checked;
    let positions = prim
        .attributes
        .get(&Checked::Valid(Semantic::Positions))
        .ok_or_else(|| mesh_error(path, format!("glTF: {place} has no positions")))?;
    let base = mesh.vertices.len();
    let (_, items) = elements(
        path,
        root,
        buffers,
        positions.value(),
        place,
        &[(ComponentType::F32, Type::Vec3)],
    )?;
    mesh.vertices.extend(items.iter().map(|b| {
        let c = |k: usize| {
            f64::from(f32::from_le_bytes([
                b[4 * k],
                b[4 * k + 1],
                b[4 * k + 2],
                b[4 * k + 3],
            ]))
        };
        Point3::new(c(0), c(1), c(2))
    }));
    let count = mesh.vertices.len() - base;
    let indices: Vec<usize> = match prim.indices {
        Some(ix) => {
            let allowed =
                [ComponentType::U8, ComponentType::U16, ComponentType::U32].map(|c| (c, Type::Scalar));
            let (kind, items) = elements(path, root, buffers, ix.value(), place, &allowed)?;
            items
                .iter()
                .map(|b| match kind {
                    ComponentType::U8 => usize::from(b[0]),
                    ComponentType::U16 => usize::from(u16::from_le_bytes([b[0], b[1]])),
                    _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
                })
                .collect()
        }
        None => (0..count).collect(),
    };
    mesh.faces.extend(
        indices
            .chunks_exact(3)
            .map(|f| [base + f[0], base + f[1], base + f[2]]),
    );
    Ok(())
}

/// The bytes of each element of accessor `index`, after checking that the accessor, its view and
/// its buffer exist, that it is one of `allowed` (component, type), and that every element lies
/// inside the view and the view inside the buffer. Returns the component type too.
fn elements<'a>(
    path: &Path,
    root: &gltf::json::Root,
    buffers: &'a [Vec<u8>],
    index: usize,
    place: &str,
    allowed: &[(gltf::json::accessor::ComponentType, gltf::json::accessor::Type)],
) -> Result<(gltf::json::accessor::ComponentType, Vec<&'a [u8]>)> {
    use gltf::json::validation::Checked;
    let err = |m: String| mesh_error(path, format!("glTF: {place}: accessor {index}: {m}"));
    let a = root
        .accessors
        .get(index)
        .ok_or_else(|| err(format!("does not exist ({} accessors)", root.accessors.len())))?;
    let (Checked::Valid(component), Checked::Valid(kind)) = (&a.component_type, &a.type_) else {
        return Err(err("unknown component type or type".into()));
    };
    let component = component.0;
    if !allowed.contains(&(component, *kind)) {
        return Err(err(format!(
            "{component:?} {kind:?}, expected one of {allowed:?}"
        )));
    }
    if a.sparse.is_some() {
        return Err(err("sparse accessors are not supported".into()));
    }
    let view_index = a
        .buffer_view
        .ok_or_else(|| err("has no buffer view".into()))?
        .value();
    let view = root
        .buffer_views
        .get(view_index)
        .ok_or_else(|| err(format!("buffer view {view_index} does not exist")))?;
    let data = buffers
        .get(view.buffer.value())
        .ok_or_else(|| err(format!("buffer {} does not exist", view.buffer.value())))?;
    let size = component.size() * kind.multiplicity();
    let stride = view.byte_stride.map_or(size, |s| s.0);
    if stride < size {
        return Err(err(format!(
            "byte stride {stride} is less than the element's {size} bytes"
        )));
    }
    let too_big = || err("the accessor or its buffer view reaches past the data".into());
    let to_usize = |v: u64| usize::try_from(v).map_err(|_| too_big());
    let view_start = to_usize(view.byte_offset.map_or(0, |o| o.0))?;
    let view_len = to_usize(view.byte_length.0)?;
    if view_start
        .checked_add(view_len)
        .is_none_or(|end| end > data.len())
    {
        return Err(too_big());
    }
    let start = to_usize(a.byte_offset.map_or(0, |o| o.0))?;
    let count = to_usize(a.count.0)?;
    if count == 0 {
        return Err(err("has no element".into()));
    }
    // Checked before the list of `count` slices is allocated: the data bounds it.
    let end = stride
        .checked_mul(count - 1)
        .and_then(|v| v.checked_add(start))
        .and_then(|v| v.checked_add(size));
    if end.is_none_or(|end| end > view_len) {
        return Err(too_big());
    }
    let view_data = &data[view_start..view_start + view_len];
    let items = (0..count)
        .map(|k| &view_data[start + k * stride..start + k * stride + size])
        .collect();
    Ok((component, items))
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
                return Err(Error::NoTaxelAtVertex {
                    vertex: v,
                    at: [p.x, p.y, p.z],
                    tolerance_m: tolerance,
                    nearest: link.taxels[best].id,
                    distance_m: d,
                });
            }
            matched.push(best);
        }
        let mut out = link.clone();
        out.faces = Some(self.faces.iter().map(|f| f.map(|v| matched[v])).collect());
        Ok(out)
    }
}
