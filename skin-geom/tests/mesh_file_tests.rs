//! User meshes (OBJ, glTF) as skins or as triangles for a layout's taxels.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test or bench

use skin_geom::{FlattenOptions, TactileMap, load_mesh_file};
use std::io::Write;

const OBJ: &str = "# a 3 x 3 grid of vertices, 8 triangles, and one vertex no face uses
v 0 0 0\nv 0.01 0 0\nv 0.02 0 0\nv 0 0.01 0\nv 0.01 0.01 0\nv 0.02 0.01 0\nv 0 0.02 0\nv 0.01 0.02 0\nv 0.02 0.02 0\n
v 0.03 0.03 0\n
f 1 2 5\nf 1 5 4\nf 2 3 6\nf 2 6 5\nf 4 5 8\nf 4 8 7\nf 5 6 9\nf 5 9 8\n";

#[test]
fn an_obj_mesh_with_an_unreferenced_vertex_flattens_and_reports_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("patch.obj");
    std::fs::write(&path, OBJ).unwrap();
    let mesh = load_mesh_file(&path).unwrap();
    assert_eq!((mesh.vertices.len(), mesh.faces.len()), (10, 8));
    let link = mesh.into_link("patch").unwrap();
    // Normals come from the triangles (counter-clockwise seen from +z).
    assert!(link.taxels.iter().all(|t| (t.normal.z - 1.0).abs() < 1e-12));
    let map = TactileMap::flatten(&link, &FlattenOptions::default()).unwrap();
    assert_eq!(map.report.mesh.isolated.len(), 1);
    let p = map.points[9];
    assert!(p.x.is_finite() && p.y.is_finite());
    // The extrapolated point keeps its distance to the grid corner (the patch is flat).
    let corner = map.points[8];
    assert!(((p - corner).norm() - (0.01f64 * 2f64.sqrt())).abs() < 1e-9);
}

#[test]
fn a_gltf_mesh_with_a_separate_buffer_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let positions: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [0.01, 0.0, 0.0],
        [0.0, 0.01, 0.0],
        [0.01, 0.01, 0.002],
    ];
    let indices: [u16; 6] = [0, 1, 2, 1, 3, 2];
    let mut bin = Vec::new();
    for p in positions {
        for v in p {
            bin.write_all(&v.to_le_bytes()).unwrap();
        }
    }
    for i in indices {
        bin.write_all(&i.to_le_bytes()).unwrap();
    }
    std::fs::write(dir.path().join("m.bin"), &bin).unwrap();
    let gltf = format!(
        r#"{{"asset": {{"version": "2.0"}},
        "buffers": [{{"uri": "m.bin", "byteLength": {len}}}],
        "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 12}}],
        "accessors": [
          {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [0.01, 0.01, 0.002]}},
          {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}]}}"#,
        len = bin.len()
    );
    let path = dir.path().join("m.gltf");
    std::fs::write(&path, gltf).unwrap();
    let mesh = load_mesh_file(&path).unwrap();
    assert_eq!(mesh.faces, vec![[0, 1, 2], [1, 3, 2]]);
    assert!((mesh.vertices[3].z - 0.002).abs() < 1e-9);
    let map = TactileMap::flatten(&mesh.into_link("m").unwrap(), &FlattenOptions::default()).unwrap();
    assert_eq!(map.report.distortion.flipped_faces, 0);
}

#[test]
fn a_mesh_attached_to_a_layout_must_have_a_taxel_at_each_vertex() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("patch.obj");
    std::fs::write(&path, OBJ).unwrap();
    let mesh = load_mesh_file(&path).unwrap();
    let mut link = mesh.clone().into_link("patch").unwrap();
    // Taxel ids differ from vertex order: matching is by position.
    link.taxels.reverse();
    let attached = mesh.attach_to(&link, 1e-4).unwrap();
    let faces = attached.faces.unwrap();
    assert_eq!(faces[0], [9, 8, 5]);
    link.taxels.remove(0); // the unreferenced vertex now has no taxel
    let e = mesh.attach_to(&link, 1e-4).unwrap_err();
    assert!(e.to_string().contains("mesh vertex 9"), "{e}");
}

#[test]
fn broken_mesh_files_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nf 1 2 7\n").unwrap();
    let e = load_mesh_file(&bad).unwrap_err();
    assert!(e.to_string().contains("bad.obj"), "{e}");
    let e = load_mesh_file(&dir.path().join("x.stl")).unwrap_err();
    assert!(e.to_string().contains("unknown mesh format"), "{e}");
    let e = load_mesh_file(&dir.path().join("missing.glb")).unwrap_err();
    assert!(e.to_string().contains("missing.glb"), "{e}");
}
