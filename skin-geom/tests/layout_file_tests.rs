//! Any layout file by its extension and content (`read_layout`, `read_link`, `read_map`), with
//! the notes of what reading did.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use skin_core::format::Note;
use skin_geom::{FlattenOptions, read_layout, read_link, read_map};
use std::path::Path;

fn fixtures() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures"))
}

#[test]
fn every_kind_of_layout_file_reads_by_its_extension() {
    // A project layout: every link, or the first.
    let arm = read_layout(&fixtures().join("arm/layout.json")).unwrap();
    let names: Vec<&str> = arm.value.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["forearm", "wrist"]);
    assert!(arm.notes.is_empty());
    assert_eq!(
        read_link(&fixtures().join("arm/layout.json")).unwrap().value.name,
        "forearm"
    );
    // A mesh: its vertices are the taxels, the link is named after the file.
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("patch.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 0.01 0 0\nv 0 0.01 0\nv 0.01 0.01 0\nf 1 2 4\nf 1 4 3\n",
    )
    .unwrap();
    let links = read_layout(&obj).unwrap().value;
    assert_eq!(
        (links.len(), links[0].name.as_str(), links[0].taxels.len()),
        (1, "patch", 4)
    );
    // An iCub file: its notes come back with it.
    let txt = dir.path().join("part.txt");
    std::fs::write(
        &txt,
        "name part\n[calibration]\n0 0 0 0 0 0\n0 0 0.01 0 0 1\n0.01 0 0.01 0 0 1\n0 0.01 0.01 0 0 1\n",
    )
    .unwrap();
    let read = read_link(&txt).unwrap();
    assert_eq!(read.value.taxels.len(), 3);
    assert!(
        matches!(&read.notes[..], [Note::IcubRows { rows: 4, unused, .. }] if unused == &[0]),
        "{:?}",
        read.notes
    );
    // Anything else is refused by name.
    let yaml = dir.path().join("layout.yaml");
    std::fs::write(&yaml, "links: []").unwrap();
    let e = read_link(&yaml).unwrap_err().to_string();
    assert!(
        e.contains("layout.yaml") && e.contains("unknown layout format"),
        "{e}"
    );
    assert!(
        read_layout(&dir.path().join("missing.json"))
            .unwrap_err()
            .to_string()
            .contains("missing.json")
    );
}

#[test]
fn a_layout_given_for_a_map_is_flattened_and_noted() {
    let layout = fixtures().join("forearm/layout.json");
    let read = read_map(&layout, &FlattenOptions::default()).unwrap();
    let [
        Note::Flattened {
            path,
            extent_m,
            angle_error_deg,
        },
    ] = &read.notes[..]
    else {
        panic!("{:?}", read.notes);
    };
    assert_eq!(path, &layout);
    assert_eq!(*extent_m, read.value.extent());
    assert!(*angle_error_deg >= 0.0 && *angle_error_deg < 5.0);
    // The map saved and read back is taken as it is, with no note.
    let dir = tempfile::tempdir().unwrap();
    let saved = dir.path().join("map.json");
    std::fs::write(&saved, read.value.to_json()).unwrap();
    let again = read_map(&saved, &FlattenOptions::default()).unwrap();
    assert!(again.notes.is_empty());
    assert_eq!(again.value.ids, read.value.ids);
    // A layout that cannot be flattened names its file.
    let line = dir.path().join("line.json");
    std::fs::write(
        &line,
        r#"{"format": "skin-layout/1", "links": [{"name": "l", "taxels": [
            {"id": 1, "position": [0, 0, 0], "normal": [0, 0, 1]},
            {"id": 2, "position": [0.01, 0, 0], "normal": [0, 0, 1]},
            {"id": 3, "position": [0.02, 0, 0], "normal": [0, 0, 1]}]}]}"#,
    )
    .unwrap();
    let e = read_map(&line, &FlattenOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with(&line.display().to_string()), "{e}");
}
