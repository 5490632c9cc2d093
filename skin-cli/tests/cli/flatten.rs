//! `skin flatten`: tactile maps from layouts (the project's, Cyskin's, iCub's, a URDF's), and their report.

use super::*;

#[test]
fn flatten_writes_a_native_map_an_svg_and_prints_the_report() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("map.json");
    let svg = dir.path().join("map.svg");
    let o = skin(&[
        "flatten",
        &fixture("layout.json"),
        "-o",
        map.to_str().unwrap(),
        "--svg",
        svg.to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("715 taxels")
            && out.contains("unrolled best-fit cylinder")
            && out.contains("flipped triangles  0"),
        "{out}"
    );
    let m = skin_geom::TactileMap::read(&map).unwrap();
    assert_eq!(m.ids.len(), 715);
    let (w, h) = m.extent();
    // Close to the 247 x 362 mm map of the thesis' forearm.
    assert!(
        (0.30..0.40).contains(&w) && (0.19..0.26).contains(&h),
        "{w} x {h}"
    );
    assert!(std::fs::read_to_string(&svg).unwrap().contains("<polygon"));
}

/// `skin flatten` of the fixture forearm to a Cyskin `tactile_maps` file.
fn flatten_fixture_to_cyskin(map: &Path) {
    let o = skin(&[
        "flatten",
        &fixture("layout.json"),
        "-o",
        map.to_str().unwrap(),
        "--format",
        "cyskin",
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
}

#[test]
fn flatten_writes_cyskin_maps_in_metres_with_faces_indexing_the_taxel_list() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("m.json");
    flatten_fixture_to_cyskin(&map);
    let text = std::fs::read_to_string(&map).unwrap();
    let m = skin_core::format::cyskin::parse_tactile_map(&text, &map).unwrap();
    assert_eq!(m.kind, "lscm");
    assert_eq!(m.ids.len(), 715);
    assert!(m.points.iter().all(|p| p[0] < 0.5 && p[1] < 0.5));
    assert!(text.contains("\"n_faces\""));
}

#[test]
fn a_cyskin_map_written_by_flatten_drives_image() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("cyskin_map.json");
    flatten_fixture_to_cyskin(&map);
    let out = dir.path().join("imgs");
    let o = skin(&[
        "image",
        "--map",
        map.to_str().unwrap(),
        &fixture("touches.txt"),
        "-o",
        out.to_str().unwrap(),
        "--grid",
        "68x100",
        "-q",
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    assert_eq!(std::fs::read_dir(out.join("touches")).unwrap().count(), 130);
}

#[test]
fn flatten_reads_icub_files_and_lists_the_merged_rows() {
    let Some(p) = shared("icub/left_forearm_V2.txt") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let o = skin(&[
        "flatten",
        p.to_str().unwrap(),
        "-o",
        dir.path().join("m.json").to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("duplicated positions:")
            && out.contains("lines [8, 9, 10, 12, 13, 14, 16] (taxels [3, 4, 5, 7, 8, 9, 11])"),
        "{out}"
    );
    assert!(out.contains("flipped triangles  0"), "{out}");
}

#[test]
fn flatten_reads_the_tactile_sensors_of_a_urdf_one_link_at_a_time() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = dir.path().join("robot.urdf");
    std::fs::write(
        &urdf,
        r#"<robot name="r"><link name="base"/><link name="arm"/>
  <sensor name="a" update_rate="50"><parent link="base"/><origin xyz="0 0 0.1"/>
    <tactile><array rows="8" cols="6" size="0.006 0.006"/></tactile></sensor>
  <sensor name="b" update_rate="50"><parent link="arm"/>
    <tactile><array rows="5" cols="5" size="0.008 0.008"/></tactile></sensor>
</robot>"#,
    )
    .unwrap();
    let out = dir.path().join("map.json");
    let o = skin(&["flatten", urdf.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    let (_, err) = text(&o);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        err.contains("2 links (base, arm); choose one with --link"),
        "{err}"
    );
    let o = skin(&[
        "flatten",
        urdf.to_str().unwrap(),
        "--link",
        "arm",
        "-o",
        out.to_str().unwrap(),
    ]);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        stdout.contains("link \"arm\", 25 taxels") && stdout.contains("flipped triangles  0"),
        "{stdout}"
    );
    let map = skin_geom::TactileMap::read(&out).unwrap();
    assert_eq!(map.ids.len(), 25);
}
