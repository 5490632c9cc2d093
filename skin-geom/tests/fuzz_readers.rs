//! Fuzzing of skin-geom's readers, OBJ / glTF / GLB meshes and tactile maps: arbitrary bytes and
//! hostile edits of valid files (see `skin_test_support::mutate`) give `Ok` or an error, never a
//! panic; what is accepted goes on through the next step (a skin, a flattening, a rasterizer)
//! without a panic either.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::{Point3, Unit, Vector3};
use proptest::prelude::*;
use skin_core::format::MAX_POSITION_M;
use skin_core::{LinkSkin, Taxel, TaxelId};
use skin_geom::{FlattenOptions, Grid, MeshFileLink, Rasterizer, TactileMap, load_mesh_file};
use std::path::Path;

use mutate::{arbitrary_text, config, mutated, mutated_bytes};
use skin_test_support::mutate;

const OBJ: &str = "# a patch of four taxels\n\
v 0 0 0.01\nv 0.008 0 0.01\nv 0.004 0.007 0.01\nv 0.012 0.007 0.011\n\
vn 0 0 1\nf 1 2 3\nf 2 4 3\n";

const VERTICES: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.01],
    [0.008, 0.0, 0.01],
    [0.004, 0.007, 0.01],
    [0.012, 0.007, 0.011],
];
const INDICES: [u16; 6] = [0, 1, 2, 1, 3, 2];

/// The vertex and index data of the glTF files: 48 bytes of positions, 12 of indices.
fn bin() -> Vec<u8> {
    let mut b: Vec<u8> = VERTICES.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
    b.extend(INDICES.iter().flat_map(|i| i.to_le_bytes()));
    b
}

/// glTF JSON over [`bin`], in `mesh.bin` beside it or (uri `None`) in the GLB's binary chunk.
fn gltf_json(uri: Option<&str>) -> String {
    let uri = uri.map_or(String::new(), |u| format!("\"uri\": \"{u}\", "));
    format!(
        r#"{{"asset": {{"version": "2.0"}},
 "buffers": [{{{uri}"byteLength": 60}}],
 "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}],
 "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0.01], "max": [0.012, 0.007, 0.011]}},
               {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}],
 "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}]}}"#
    )
}

/// A GLB: header, JSON chunk, binary chunk, each chunk padded to 4 bytes.
fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(0x4E4F_534Au32.to_le_bytes());
    out.extend(j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(0x004E_4942u32.to_le_bytes());
    out.extend(b);
    out
}

/// A mesh accepted by the reader holds finite vertices within bounds and faces of three distinct
/// vertices that exist; as a skin it flattens or fails, without a panic.
fn check_mesh(mesh: &MeshFileLink) -> Result<(), TestCaseError> {
    let n = mesh.vertices.len();
    let near = |p: &Point3<f64>| {
        p.coords
            .iter()
            .all(|v| v.is_finite() && v.abs() <= MAX_POSITION_M)
    };
    prop_assert!(mesh.vertices.iter().all(near), "a vertex out of bounds");
    for f in &mesh.faces {
        prop_assert!(
            f.iter().all(|&v| v < n) && f[0] != f[1] && f[1] != f[2] && f[0] != f[2],
            "face {f:?}"
        );
    }
    if n <= 64
        && let Ok(link) = mesh.clone().into_link("mesh")
    {
        prop_assert!(link.taxels.iter().all(|t| t.normal.iter().all(|v| v.is_finite())));
        let _ = TactileMap::flatten(&link, &FlattenOptions::default());
    }
    Ok(())
}

fn read_mesh(name: &str, bytes: &[u8], bin: Option<&[u8]>) -> Result<(), TestCaseError> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    if let Some(bin) = bin {
        std::fs::write(dir.path().join("mesh.bin"), bin).unwrap();
    }
    if let Ok(mesh) = load_mesh_file(&p) {
        check_mesh(&mesh)?;
    }
    Ok(())
}

fn small_map() -> TactileMap {
    let t = |k: u32, x: f64, y: f64| Taxel {
        id: TaxelId(100 + k),
        position: Point3::new(x, y, 0.002 * k as f64),
        normal: Unit::new_normalize(Vector3::z()),
    };
    let taxels = (0..9u32)
        .map(|k| t(k, f64::from(k % 3) * 0.008, f64::from(k / 3) * 0.008))
        .collect();
    TactileMap::flatten(&LinkSkin::new("patch", taxels), &FlattenOptions::default()).unwrap()
}

/// A map accepted by the reader gives a rasterizer or an error, and renders without a panic.
fn check_map(text: &str) -> Result<(), TestCaseError> {
    let Ok(map) = TactileMap::parse(text, Path::new("map.json")) else {
        return Ok(());
    };
    prop_assert_eq!(map.ids.len(), map.points.len());
    prop_assert!(map.zeroed.iter().all(|&i| i < map.ids.len()));
    if let Ok(mut raster) = Rasterizer::new(&map, Grid::StepMm(1.0)) {
        let mut image = vec![0.0f32; raster.len()];
        let _ = raster.render(&vec![100.0; map.ids.len()], &mut image);
        prop_assert!(image.iter().all(|v| v.is_finite()));
    }
    Ok(())
}

#[test]
fn the_valid_files_read() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("p.obj");
    std::fs::write(&obj, OBJ).unwrap();
    let gltf = dir.path().join("p.gltf");
    std::fs::write(&gltf, gltf_json(Some("mesh.bin"))).unwrap();
    std::fs::write(dir.path().join("mesh.bin"), bin()).unwrap();
    let glb_path = dir.path().join("p.glb");
    std::fs::write(&glb_path, glb(&gltf_json(None), &bin())).unwrap();
    for p in [obj, gltf, glb_path] {
        let m = load_mesh_file(&p).unwrap();
        assert_eq!((m.vertices.len(), m.faces.len()), (4, 2), "{}", p.display());
    }
    let map = small_map();
    assert_eq!(
        TactileMap::parse(&map.to_json(), Path::new("m")).unwrap().ids,
        map.ids
    );
    let cyskin = skin_core::format::cyskin::tactile_map_to_string(&map.to_cyskin());
    assert_eq!(TactileMap::parse(&cyskin, Path::new("m")).unwrap().ids, map.ids);
}

#[test]
fn a_glb_whose_buffer_is_shorter_than_declared_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("short.glb");
    std::fs::write(&p, glb(&gltf_json(None).replace("60}", "600}"), &bin())).unwrap();
    let e = load_mesh_file(&p).unwrap_err().to_string();
    assert!(e.contains("declares 600"), "{e}");
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn obj_files(text in prop_oneof![mutated(OBJ), arbitrary_text()]) {
        read_mesh("patch.obj", text.as_bytes(), None)?;
    }

    #[test]
    fn gltf_files(json in mutated(&gltf_json(Some("mesh.bin"))), data in prop_oneof![Just(bin()), mutated_bytes(bin())]) {
        read_mesh("patch.gltf", json.as_bytes(), Some(&data))?;
    }

    #[test]
    fn glb_files(
        bytes in prop_oneof![
            mutated_bytes(glb(&gltf_json(None), &bin())),
            mutated(&gltf_json(None)).prop_map(|j| glb(&j, &bin())),
            mutated_bytes(bin()).prop_map(|b| glb(&gltf_json(None), &b)),
            prop::collection::vec(any::<u8>(), 0..200),
        ]
    ) {
        read_mesh("patch.glb", &bytes, None)?;
    }

    #[test]
    fn tactile_maps(text in prop_oneof![
        mutated(&small_map().to_json()),
        mutated(&skin_core::format::cyskin::tactile_map_to_string(&small_map().to_cyskin())),
        arbitrary_text(),
    ]) {
        check_map(&text)?;
    }
}

#[test]
fn a_glb_header_shorter_than_itself_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("short.glb");
    let mut bytes = glb(&gltf_json(None), &bin());
    bytes[8..12].copy_from_slice(&3u32.to_le_bytes());
    std::fs::write(&p, bytes).unwrap();
    let e = load_mesh_file(&p).unwrap_err().to_string();
    assert!(e.contains("declares 3 bytes"), "{e}");
}
