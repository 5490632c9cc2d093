//! `skin image`: a PNG per frame, and one clear line for a missing or malformed input.

use super::*;

#[test]
fn image_turns_every_frame_into_a_png() {
    let dir = tempfile::tempdir().unwrap();
    let o = skin(&[
        "image",
        "--map",
        &fixture("layout.json"),
        &fixture("touches.txt"),
        "-o",
        dir.path().to_str().unwrap(),
        "--morph",
        "--size",
        "68x100",
        "--threshold",
        "10",
        "-q",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("130 frames") && out.contains("68 x 100 px"), "{out}");
    let pngs = std::fs::read_dir(dir.path().join("touches")).unwrap().count();
    assert_eq!(pngs, 130);
    let img = image::open(dir.path().join("touches/frame_00020.png"))
        .unwrap()
        .to_luma8();
    assert_eq!(img.dimensions(), (100, 68));
    // Frame 20 (t = 1.0 s) is during the fingertip press: a bright spot.
    assert!(img.pixels().filter(|p| p.0[0] > 100).count() >= 4);
    let blank = image::open(dir.path().join("touches/frame_00000.png"))
        .unwrap()
        .to_luma8();
    assert!(
        blank.pixels().all(|p| p.0[0] == 0),
        "frame 0 has only noise, under the threshold"
    );
}

#[test]
fn a_missing_file_is_one_clear_line_and_exit_code_1() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("m.json");
    let o = skin(&["flatten", "no/such/layout.json", "-o", out.to_str().unwrap()]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        err.starts_with("error: no/such/layout.json:") && err.lines().count() == 1,
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn a_recording_of_another_link_is_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("other.txt");
    std::fs::write(&rec, "1 2 3\n0 0.0 1 2 3\n").unwrap();
    let out = dir.path().join("out");
    let o = skin(&[
        "image",
        "--map",
        &fixture("layout.json"),
        rec.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        err.contains("other.txt") && err.contains("is in the recording"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn a_recording_that_lacks_some_taxels_images_across_them() {
    // The fixture recording without the columns of three taxels: they are dead, reported once,
    // and the images are made over the map without them (Test B's re-triangulation).
    let dir = tempfile::tempdir().unwrap();
    let full = skin_core::format::recording::read(Path::new(&fixture("touches.txt"))).unwrap();
    let rec = dir.path().join("partial.txt");
    skin_core::format::recording::write(&rec, &recordings::without_columns(&full, &[5, 100, 300])).unwrap();
    let out = dir.path().join("out");
    let o = skin(&[
        "image",
        "--map",
        &fixture("layout.json"),
        rec.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--size",
        "68x100",
        "-q",
    ]);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert_eq!(
        stdout
            .matches("3 taxel(s) of the map have no column in the recording")
            .count(),
        1,
        "{stdout}"
    );
    assert_eq!(
        std::fs::read_dir(out.join("partial")).unwrap().count(),
        full.frames.len()
    );
}

#[test]
fn malformed_inputs_name_the_place() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, "{\"skin\": {\"taxels\": [{\"id\": 1, \"x\": [0, 0").unwrap();
    let o = skin(&[
        "flatten",
        bad.to_str().unwrap(),
        "-o",
        dir.path().join("m.json").to_str().unwrap(),
    ]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(1));
    assert!(err.contains("bad.json:1:"), "{err}");
    let rec = dir.path().join("r.txt");
    let mut rows = std::fs::read_to_string(fixture("touches.txt")).unwrap();
    rows.push_str("999 9.9 1 2\n");
    std::fs::write(&rec, rows).unwrap();
    let o = skin(&[
        "image",
        "--map",
        &fixture("layout.json"),
        rec.to_str().unwrap(),
        "-o",
        dir.path().join("o").to_str().unwrap(),
    ]);
    let (_, err) = text(&o);
    assert!(err.contains("r.txt: line 132"), "{err}");
    let o = skin(&[
        "image",
        "--map",
        &fixture("layout.json"),
        &fixture("touches.txt"),
        "-o",
        "x",
        "--norm",
        "full-scale",
    ]);
    assert!(text(&o).1.contains("--full-scale"), "{}", text(&o).1);
}
