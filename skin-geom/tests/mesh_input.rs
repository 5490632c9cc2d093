//! Mesh files as editors and exporters leave them: a byte-order mark and CR line ends read as
//! without, a file past the size read whole refused by its size before it is read.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use skin_geom::{MAX_MESH_BYTES, load_mesh_file};

const OBJ: &str = "v 0 0 0.01\nv 0.008 0 0.01\nv 0.004 0.007 0.01\nv 0.012 0.007 0.01\nf 1 2 3\nf 2 4 3\n";

#[test]
fn an_obj_with_a_byte_order_mark_or_cr_line_ends_reads_as_without() {
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("plain.obj");
    std::fs::write(&plain, OBJ).unwrap();
    let want = load_mesh_file(&plain).unwrap();
    assert_eq!(want.faces.len(), 2);
    for (name, text) in [
        ("bom.obj", format!("\u{feff}{OBJ}")),
        ("mac.obj", OBJ.replace('\n', "\r")),
    ] {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        assert_eq!(load_mesh_file(&p).unwrap(), want, "{name}");
    }
}

#[test]
fn a_mesh_past_its_size_is_refused_before_it_is_read() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["huge.obj", "huge.glb"] {
        let p = dir.path().join(name);
        // Sparse: refused by its size, never read.
        std::fs::File::create(&p)
            .unwrap()
            .set_len(MAX_MESH_BYTES + 1)
            .unwrap();
        let e = load_mesh_file(&p).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains("more than the 256.0 MiB"), "{e}");
    }
}
