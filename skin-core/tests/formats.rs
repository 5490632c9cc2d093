//! Readers and writers: round trips, the real third-party files, and malformed input.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test or bench

use proptest::prelude::*;
use skin_core::format::{cyskin, icub, native, recording};
use skin_core::{Error, LinkSkin, Taxel, TaxelId};
use std::path::Path;

use shared_data::shared;
use skin_test_support::shared_data;

fn place_of(e: &Error) -> String {
    e.to_string()
}

fn small_link() -> LinkSkin {
    use nalgebra::{Point3, Unit, Vector3};
    let t = |id, x: f64, y: f64| Taxel {
        id: TaxelId(id),
        position: Point3::new(x, y, 0.01),
        normal: Unit::new_normalize(Vector3::new(0.0, 0.1, 1.0)),
    };
    let mut link = LinkSkin::new(
        "patch",
        vec![t(16, 0.0, 0.0), t(17, 0.008, 0.0), t(18, 0.004, 0.007)],
    );
    link.faces = Some(vec![[0, 1, 2]]);
    link
}

#[test]
fn the_cyskin_patch_reads_with_its_taxels_faces_and_frame() {
    let Some(p) = shared("cyskin/ur10e_link1_patch1.json") else {
        return;
    };
    let link = cyskin::read_skin(&p).unwrap().value;
    assert_eq!(link.taxels.len(), 642);
    assert_eq!(link.faces.as_ref().unwrap().len(), 1232);
    assert_eq!(link.taxels[0].id, TaxelId(83931));
    assert!((link.taxels[0].position.x + 0.07665742436530114).abs() < 1e-15);
    let tf = link.frame_to_parent.unwrap();
    // Column-major: the translation is the last column.
    assert!((tf[(2, 3)] - 0.024).abs() < 1e-12);
}

#[test]
fn cyskin_and_native_files_round_trip() {
    let link = small_link();
    let back = cyskin::parse_skin(&cyskin::skin_to_string(&link), Path::new("mem"))
        .unwrap()
        .value;
    for (a, b) in back.taxels.iter().zip(&link.taxels) {
        assert_eq!((a.id, a.position), (b.id, b.position));
        // Normals are normalised again on reading: equal to the last bit or so.
        assert!((a.normal.into_inner() - b.normal.into_inner()).norm() < 1e-15);
    }
    assert_eq!(back.faces, link.faces);
    let layout = skin_core::SkinLayout { links: vec![link] };
    let back = native::parse_layout(&native::to_string(&layout), Path::new("mem")).unwrap();
    assert_eq!(back.links[0].faces, layout.links[0].faces);
    assert_eq!(back.links[0].ids(), layout.links[0].ids());
}

#[test]
fn truncated_json_names_the_file_and_line() {
    let text = cyskin::skin_to_string(&small_link());
    let cut = &text[..text.len() / 2];
    let e = cyskin::parse_skin(cut, Path::new("cut.json")).unwrap_err();
    assert!(matches!(e, Error::Json { line, .. } if line > 1), "{e}");
    assert!(place_of(&e).starts_with("cut.json:"), "{e}");
}

#[test]
fn a_huge_bad_field_is_quoted_by_its_first_characters_only() {
    let long = "7".repeat(1_000_000) + "x";
    let short = |e: Error| {
        let e = e.to_string();
        assert!(
            e.len() < 300 && e.contains("bytes)"),
            "{}",
            &e[..e.len().min(400)]
        );
    };
    short(recording::parse(&format!("16 {long}\n"), Path::new("r.txt")).unwrap_err());
    short(recording::parse(&format!("16\n0 0.0 {long}\n"), Path::new("r.txt")).unwrap_err());
    short(
        icub::parse(
            &format!("[calibration]\n0 0 {long} 0 0 1\n"),
            Path::new("i.txt"),
            icub::Duplicates::Merge,
        )
        .unwrap_err(),
    );
}

#[test]
fn a_value_beyond_the_physical_range_names_its_place_and_the_bound() {
    let e = recording::parse("16 17\n0 0.0 1 3e9\n", Path::new("r.txt"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("line 2 field 4 (taxel 17)") && e.contains("1e9"),
        "{e}"
    );
    let mut link = small_link();
    link.frame_to_parent = Some(nalgebra::Matrix4::new_translation(&nalgebra::Vector3::new(
        0.0, 0.0, 1e6,
    )));
    let e = native::parse_layout(
        &native::to_string(&skin_core::SkinLayout { links: vec![link] }),
        Path::new("l.json"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("parent frame") && e.contains("100 m"), "{e}");
    // A normal with a huge component still has a direction (its length overflowed before).
    let text = r#"{"format": "skin-layout/1", "links": [{"name": "p", "taxels": [
        {"id": 1, "position": [0, 0, 0], "normal": [1e308, 0, 1]}]}]}"#;
    let l = native::parse_layout(text, Path::new("l.json")).unwrap();
    assert!((l.links[0].taxels[0].normal.into_inner() - nalgebra::Vector3::x()).norm() < 1e-12);
}

#[test]
fn a_non_finite_coordinate_names_the_taxel() {
    // JSON has no NaN; an overflowing number is the way such files carry one.
    let text = cyskin::skin_to_string(&small_link()).replacen("0.008", "1e999", 1);
    let e = cyskin::parse_skin(&text, Path::new("nan.json")).unwrap_err();
    assert!(e.to_string().contains("nan.json"), "{e}");
    let icub_text = "name t\n[calibration]\n0.1 0.2 nan 0 0 1\n";
    let e = icub::parse(icub_text, Path::new("nan.txt"), icub::Duplicates::Merge).unwrap_err();
    assert!(e.to_string().contains("line 3"), "{e}");
    assert!(e.to_string().contains("not finite"), "{e}");
}

#[test]
fn a_face_index_out_of_range_names_the_face() {
    let mut link = small_link();
    link.faces = Some(vec![[0, 1, 2], [0, 2, 7]]);
    let e = cyskin::parse_skin(&cyskin::skin_to_string(&link), Path::new("f.json")).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("face 1") && msg.contains("index 7"), "{msg}");
}

#[test]
fn a_repeated_taxel_id_is_a_placeholder_in_cyskin_files_and_an_error_in_ours() {
    let mut link = small_link();
    link.taxels[2].id = TaxelId(16);
    // Cyskin: every taxel with the repeated id stays, under a placeholder id of its own.
    let read = cyskin::parse_skin(&cyskin::skin_to_string(&link), Path::new("d.json")).unwrap();
    let ids = read.value.ids();
    assert_eq!(ids.len(), link.taxels.len());
    assert_eq!(
        (ids[0], ids[2]),
        (TaxelId::placeholder(0), TaxelId::placeholder(1))
    );
    assert!(ids[0].is_placeholder() && ids[2].is_placeholder() && !ids[1].is_placeholder());
    assert_eq!(read.value.taxels[2].position, link.taxels[2].position);
    assert_eq!(read.value.faces, link.faces, "the mesh keeps its vertices");
    let note = read
        .notes
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("\n");
    assert!(
        note.contains("d.json: 2 taxels carry the placeholder id 16"),
        "{note}"
    );
    // The project's own layout: an error naming the taxel.
    let e = native::parse_layout(
        &native::to_string(&skin_core::SkinLayout { links: vec![link] }),
        Path::new("d.json"),
    )
    .unwrap_err();
    assert!(e.to_string().contains("taxel 16 (index 2)"), "{e}");
}

#[test]
fn a_zero_normal_is_rejected() {
    let text = r#"{"skin": {"taxels": [
        {"id": 1, "x": [0, 0, 0], "n": [0, 0, 1]},
        {"id": 2, "x": [0.01, 0, 0], "n": [0, 0, 0]}]}}"#;
    let e = cyskin::parse_skin(text, Path::new("n.json")).unwrap_err();
    assert!(e.to_string().contains("taxel 2 (skin.taxels[1])"), "{e}");
    assert!(e.to_string().contains("normal has zero length"), "{e}");
}

#[test]
fn a_recording_row_with_a_missing_value_names_the_line() {
    let text = "16 17 18\n0 0.0 1 2 3\n1 0.05 4 5\n";
    let e = recording::parse(text, Path::new("r.txt")).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("r.txt: line 3") && msg.contains("found 4"), "{msg}");
    let e = recording::parse("16 17\n0 0.0 1 x\n", Path::new("r.txt")).unwrap_err();
    assert!(e.to_string().contains("line 2 field 4 (taxel 17)"), "{e}");
}

#[test]
fn the_cyskin_recordings_read_frame_by_frame() {
    let Some(p) = shared("cyskin/recordings/0_finger/sample_01.txt") else {
        return;
    };
    let rec = recording::read(&p).unwrap();
    assert_eq!(rec.frames.len(), 30);
    assert_eq!(rec.taxel_ids[0], TaxelId(56560));
    assert_eq!(rec.taxel_ids[0].module(), 3535);
    assert!(rec.frames.iter().all(|f| f.values.len() == rec.taxel_ids.len()));
    assert!((rec.frames[1].time - 0.100650).abs() < 1e-9);
}

#[test]
fn icub_zero_rows_are_dropped_and_duplicates_merged_or_rejected() {
    let text = "name demo\nspatial_sampling taxel\n[calibration]\n\
        0.01 0.02 0.03 0 0 2\n\
        0 0 0 0 0 0\n\
        0.01 0.02 0.03 0 0 1\n\
        0.02 0.02 0.03 0 0 1\n";
    let read = icub::parse(text, Path::new("p.txt"), icub::Duplicates::Merge).unwrap();
    assert_eq!(read.skin.name, "demo");
    assert_eq!(read.zero_slots, vec![1]);
    assert_eq!(read.skin.ids(), vec![TaxelId(0), TaxelId(3)]);
    assert_eq!(read.duplicates.len(), 1);
    assert_eq!(read.duplicates[0].slots, vec![0, 2]);
    assert_eq!(read.duplicates[0].lines, vec![4, 6]);
    // Normals that are not unit length are normalised.
    assert!((read.skin.taxels[0].normal.z - 1.0).abs() < 1e-15);
    let e = icub::parse(text, Path::new("p.txt"), icub::Duplicates::Reject).unwrap_err();
    assert!(e.to_string().contains("lines [4, 6]"), "{e}");
}

#[test]
fn reading_an_icub_file_notes_the_rows_it_dropped_and_the_taxels_it_merged() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("hand.txt");
    std::fs::write(
        &p,
        "name demo\n[calibration]\n0.01 0.02 0.03 0 0 1\n0 0 0 0 0 0\n0.01 0.02 0.03 0 0 1\n0.02 0.02 0.03 0 0 1\n",
    )
    .unwrap();
    let read = skin_core::format::load_link(&p).unwrap();
    assert_eq!(read.value.ids(), vec![TaxelId(0), TaxelId(3)]);
    let notes: Vec<String> = read.notes.iter().map(ToString::to_string).collect();
    assert_eq!(notes.len(), 2, "{notes:?}");
    assert!(
        notes[0].ends_with("hand.txt: 4 taxel rows, 1 unused (all-zero) rows dropped"),
        "{notes:?}"
    );
    assert!(
        notes[1].contains("hand.txt: duplicated positions: 1 groups, 1 taxels merged")
            && notes[1].contains("lines [3, 5] (taxels [0, 2])"),
        "{notes:?}"
    );
    // A clean JSON layout reads with no note.
    let json = dir.path().join("l.json");
    native::write_layout(
        &json,
        &skin_core::SkinLayout {
            links: vec![small_link()],
        },
    )
    .unwrap();
    assert!(skin_core::format::load_link(&json).unwrap().notes.is_empty());
}

#[test]
fn a_recording_is_matched_to_a_layout_by_taxel_id() {
    // Columns 17, 5, 99 (99 is no taxel of the layout); the layout's taxels 5, 17, 42 (42 is
    // not recorded).
    let rec = recording::parse(
        "17 5 99\n0 0.0 1 2 3\n1 0.1 40 0 3\n1 0.2 0 0 0\n",
        Path::new("r.txt"),
    )
    .unwrap();
    let ids = [TaxelId(5), TaxelId(17), TaxelId(42)];
    let c = rec.columns(&ids);
    assert_eq!(c.of_taxel, vec![Some(1), Some(0), None]);
    assert_eq!(c.missing, vec![TaxelId(42)]);
    assert_eq!(c.ignored, 1);
    let mut out = [9.0f32; 3];
    assert!(c.gather(&rec.frames[0].values, 0.0, &mut out));
    assert_eq!(out, [2.0, 1.0, 0.0], "layout order; the missing taxel reads 0");
    assert!(c.gather(&rec.frames[1].values, 10.0, &mut out));
    assert_eq!(out, [0.0, 40.0, 0.0], "at or below the threshold reads 0");
    assert!(!c.gather(&rec.frames[2].values, 0.0, &mut out), "nothing pressed");
    assert!(!c.gather(&[], 0.0, &mut out), "a short frame reads 0, no panic");
    // Frame 1 repeats: its second image gets a suffix instead of overwriting the first.
    assert_eq!(
        rec.frame_stems(),
        (
            vec![
                "frame_00000".to_string(),
                "frame_00001".into(),
                "frame_00001_dup1".into()
            ],
            1
        )
    );
}

#[test]
fn icub_slots_that_taxel2repr_calls_no_taxel_are_dropped_and_noted() {
    // Slot 1 is a thermal pad (-2) with a position, slot 3 unused (-1) and all zeros.
    let text = "name t\ntaxel2Repr ( 0 -2 0\n -1 0 )\n[calibration]\n\
        0 0 0.01 0 0 1\n0.005 0 0.01 0 0 1\n0.01 0 0.01 0 0 1\n0 0 0 0 0 0\n0 0.01 0.01 0 0 1\n";
    let read = icub::parse(text, Path::new("t.txt"), icub::Duplicates::Merge).unwrap();
    assert_eq!(read.skin.ids(), vec![TaxelId(0), TaxelId(2), TaxelId(4)]);
    assert_eq!(
        (read.not_taxels.clone(), read.zero_slots.clone()),
        (vec![1], vec![3])
    );
    let notes: Vec<String> = read
        .notes(Path::new("t.txt"))
        .iter()
        .map(ToString::to_string)
        .collect();
    assert!(notes[0].contains("5 taxel rows, 1 unused"), "{notes:?}");
    assert!(
        notes[1].contains("1 slot(s) with a position are no taxel") && notes[1].contains("[1]"),
        "{notes:?}"
    );
}

#[test]
fn icub_taxels_without_normals_get_them_from_their_neighbours() {
    // A half cylinder (radius 40 mm about x) given by positions only, as *_nomesh.txt files are.
    let mut text = String::from("name nomesh\n[calibration]\n");
    let mut truth = Vec::new();
    for i in 0..12 {
        for k in 0..12 {
            let a = std::f64::consts::PI * k as f64 / 11.0;
            text += &format!(
                "{} {} {} 0 0 0\n",
                i as f64 * 0.008,
                0.04 * a.cos(),
                0.04 * a.sin()
            );
            truth.push(nalgebra::Vector3::new(0.0, a.cos(), a.sin()));
        }
    }
    let read = icub::parse(&text, Path::new("n.txt"), icub::Duplicates::Merge).unwrap();
    assert_eq!(read.estimated_normals.len(), 144);
    let angles: Vec<f64> = read
        .skin
        .taxels
        .iter()
        .zip(&truth)
        .map(|(t, n)| t.normal.dot(n).clamp(-1.0, 1.0).acos().to_degrees())
        .collect();
    let worst = angles.iter().fold(0.0f64, |m, &a| m.max(a));
    let mean = angles.iter().sum::<f64>() / angles.len() as f64;
    // All outward; a border taxel's neighbours are on one side only, which tilts its normal.
    assert!(
        worst < 20.0 && mean < 5.0,
        "from the outward normal: worst {worst:.1} deg, mean {mean:.2} deg"
    );
    let notes: Vec<String> = read
        .notes(Path::new("n.txt"))
        .iter()
        .map(ToString::to_string)
        .collect();
    assert!(
        notes
            .iter()
            .any(|n| n.contains("144 taxel(s) have an all-zero normal")),
        "{notes:?}"
    );
}

#[test]
fn the_icub_torso_drops_its_thermal_pads() {
    let Some(p) = shared("icub/torso.txt") else {
        return;
    };
    let read = icub::read(&p, icub::Duplicates::Merge).unwrap();
    // Slots 6 and 10 of each triangle are thermal pads (-2) with positions in this file.
    assert!(!read.not_taxels.is_empty() && read.not_taxels.iter().all(|s| s % 12 == 6 || s % 12 == 10));
    assert!(
        read.skin
            .taxels
            .iter()
            .all(|t| t.id.0 % 12 != 6 && t.id.0 % 12 != 10)
    );
}

#[test]
fn the_icub_forearm_reports_its_duplicates() {
    let Some(p) = shared("icub/left_forearm_V2.txt") else {
        return;
    };
    let read = icub::read(&p, icub::Duplicates::Merge).unwrap();
    assert_eq!(read.skin.name, "l_forearm");
    assert!(!read.duplicates.is_empty());
    // Slots 3..=11 of the first module share one position (lines 8.. in the file).
    assert!(read.duplicates[0].slots.starts_with(&[3, 4, 5]));
    let rows = read.skin.taxels.len()
        + read.zero_slots.len()
        + read.not_taxels.len()
        + read.duplicates.iter().map(|g| g.slots.len() - 1).sum::<usize>();
    assert_eq!(rows, 384);
    assert!(icub::read(&p, icub::Duplicates::Reject).is_err());
}

#[test]
fn load_link_picks_the_reader_and_rejects_unknown_json() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("x.json");
    std::fs::write(&p, "{\"something\": 1}").unwrap();
    let e = skin_core::format::load_link(&p).unwrap_err();
    assert!(e.to_string().contains("neither a skin layout"), "{e}");
    let e = skin_core::format::load_link(&dir.path().join("missing.json")).unwrap_err();
    assert!(matches!(e, Error::Io { .. }), "{e}");
}

proptest! {
    #[test]
    fn readers_never_panic_on_arbitrary_text(text in ".{0,400}") {
        let _ = recording::parse(&text, Path::new("x"));
        let _ = icub::parse(&text, Path::new("x"), icub::Duplicates::Merge);
        let _ = cyskin::parse_skin(&text, Path::new("x"));
        let _ = native::parse_layout(&text, Path::new("x"));
        let _ = cyskin::parse_tactile_map(&text, Path::new("x"));
    }

    #[test]
    fn readers_never_panic_on_mangled_files(cut in 0usize..2000, junk in "[0-9a-z\\[\\]{}, .-]{0,8}") {
        let good = cyskin::skin_to_string(&small_link());
        let cut = cut.min(good.len());
        let text = format!("{}{}{}", &good[..cut], junk, &good[cut..]);
        let _ = cyskin::parse_skin(&text, Path::new("x"));
        let rec = "16 17 18\n0 0.0 1 2 3\n1 0.05 4 5 6\n";
        let cut = cut.min(rec.len());
        let _ = recording::parse(&format!("{}{}{}", &rec[..cut], junk, &rec[cut..]), Path::new("x"));
    }

    #[test]
    fn recordings_round_trip(values in proptest::collection::vec(0u16..=u16::MAX, 3..60), ids in proptest::collection::btree_set(0u32..100_000, 3)) {
        let ids: Vec<TaxelId> = ids.into_iter().map(TaxelId).collect();
        let frames: Vec<skin_core::Frame> = values
            .chunks_exact(3)
            .enumerate()
            .map(|(k, v)| skin_core::Frame { time: k as f64 * 0.05, values: v.iter().map(|&x| f32::from(x)).collect() })
            .collect();
        let rec = skin_core::Recording { taxel_ids: ids, frame_numbers: (0..frames.len() as u64).collect(), frames };
        let back = recording::parse(&recording::to_string(&rec), Path::new("x")).unwrap();
        prop_assert_eq!(&back.taxel_ids, &rec.taxel_ids);
        prop_assert_eq!(&back.frame_numbers, &rec.frame_numbers);
        for (a, b) in back.frames.iter().zip(&rec.frames) {
            prop_assert_eq!(&a.values, &b.values);
            // Times are written to the microsecond.
            prop_assert!((a.time - b.time).abs() < 1e-6);
        }
    }
}

#[test]
fn load_links_gives_every_link_of_a_layout_and_refuses_an_empty_one() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures");
    let arm = skin_core::format::load_links(&root.join("arm/layout.json"))
        .unwrap()
        .value;
    let names: Vec<&str> = arm.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["forearm", "wrist"]);
    let one = skin_core::format::load_links(&root.join("forearm/layout.json"))
        .unwrap()
        .value;
    assert_eq!(one.len(), 1);
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.json");
    std::fs::write(&empty, "{\"format\": \"skin-layout/1\", \"links\": []}").unwrap();
    let e = skin_core::format::load_links(&empty).unwrap_err().to_string();
    assert!(e.contains("empty.json") && e.contains("no link"), "{e}");
}

/// Two links: `palm` carries a 2 x 3 array (sensor frame turned 90 degrees about z and lifted
/// 1 cm), `finger` a list of two taxels, and a sensor that both lists and has an array; a camera
/// is skipped.
const URDF: &str = r#"<?xml version="1.0"?>
<robot name="hand">
  <link name="palm"/><link name="finger"/>
  <joint name="j" type="fixed"><parent link="palm"/><child link="finger"/></joint>
  <sensor name="camera" update_rate="30"><parent link="palm"/><camera/></sensor>
  <sensor name="palm_array" update_rate="100">
    <parent link="palm"/>
    <origin xyz="0 0 0.01" rpy="0 0 1.5707963267948966"/>
    <tactile>
      <array rows="2" cols="3" size="0.005 0.004" offset="0.001 0.002"/>
    </tactile>
  </sensor>
  <sensor name="tips" update_rate="100">
    <parent link="finger"/>
    <origin xyz="0.1 0 0"/>
    <tactile channel="tips">
      <taxel idx="7" xyz="0 0.01 0" rpy="1.5707963267948966 0 0">
        <geometry><mesh filename="tip.stl"/></geometry>
      </taxel>
      <taxel idx="3" xyz="0 -0.01 0"/>
      <taxel idx="7" xyz="0 0.02 0"/>
      <array rows="4" cols="4" size="0.01 0.01"/>
    </tactile>
  </sensor>
</robot>
"#;

#[test]
fn urdf_tactile_arrays_and_taxel_lists_give_a_skin_per_link() {
    use skin_core::format::urdf_tactile;
    let read = urdf_tactile::parse(URDF, Path::new("hand.urdf")).unwrap();
    let [palm, finger] = &read.value[..] else {
        panic!("{:?}", read.value);
    };
    assert_eq!((palm.name.as_str(), finger.name.as_str()), ("palm", "finger"));
    // The array: idx = row * 3 + col at x = row * 5 mm - 1 mm, y = col * 4 mm - 2 mm in the
    // sensor frame (spacing = size), turned +90 deg about z: (x, y) -> (-y, x); 1 cm up.
    assert_eq!(palm.taxels.len(), 6);
    for (idx, t) in palm.taxels.iter().enumerate() {
        let (row, col) = ((idx / 3) as f64, (idx % 3) as f64);
        let (x, y) = (row * 0.005 - 0.001, col * 0.004 - 0.002);
        assert_eq!(
            t.id,
            TaxelId(idx as u32),
            "the first tactile sensor's ids are its indices"
        );
        assert!(
            (t.position - nalgebra::Point3::new(-y, x, 0.01)).norm() < 1e-12,
            "{idx}: {:?}",
            t.position
        );
        assert!((t.normal.z - 1.0).abs() < 1e-12);
    }
    // The list (second tactile sensor: ids 1 << 16 | idx), the first of the repeated idx 7
    // kept, the array beside it ignored. Rolled +90 deg about x, taxel 7's normal is -y.
    let ids: Vec<u32> = finger.ids().iter().map(|id| id.0).collect();
    assert_eq!(ids, [1 << 16 | 7, 1 << 16 | 3]);
    assert!((finger.taxels[0].position - nalgebra::Point3::new(0.1, 0.01, 0.0)).norm() < 1e-12);
    assert!((finger.taxels[0].normal.into_inner() - nalgebra::Vector3::new(0.0, -1.0, 0.0)).norm() < 1e-12);
    let notes: Vec<String> = read.notes.iter().map(ToString::to_string).collect();
    assert_eq!(notes.len(), 2, "{notes:?}");
    assert!(
        notes
            .iter()
            .any(|n| n.contains("\"tips\" has both a taxel list and an array"))
    );
    assert!(notes.iter().any(|n| n.contains("\"tips\" repeats taxel idx [7]")));
    // load_links reads it by its extension.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("hand.urdf");
    std::fs::write(&p, URDF).unwrap();
    assert_eq!(skin_core::format::load_links(&p).unwrap().value, read.value);
}

#[test]
fn a_bad_urdf_tactile_sensor_names_its_line() {
    use skin_core::format::urdf_tactile::parse;
    let bad = URDF.replace(r#"size="0.005 0.004""#, r#"size="0.005 x""#);
    let e = parse(&bad, Path::new("hand.urdf")).unwrap_err().to_string();
    assert!(
        e.contains("hand.urdf: line 10 (array)") && e.contains("size"),
        "{e}"
    );
    // Lines are counted as the reader moves on: 3,000 lines of links before the sensor move
    // the fault to line 3,010, and a cut file names its last line.
    let links: String = (0..3000).map(|i| format!("<link name=\"l{i}\"/>\n")).collect();
    let long = bad.replacen("<robot", &format!("{links}<robot"), 1);
    let e = parse(&long, Path::new("long.urdf")).unwrap_err().to_string();
    assert!(e.contains("long.urdf: line 3010 (array)"), "{e}");
    let e = parse(&format!("{links}<robot><sensor"), Path::new("cut.urdf"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("cut.urdf: line 3001"), "{e}");
    let huge = URDF.replace(r#"rows="2""#, r#"rows="100000""#);
    assert!(
        parse(&huge, Path::new("h.urdf"))
            .unwrap_err()
            .to_string()
            .contains("at most 65,536")
    );
    let none = "<robot name=\"r\"><link name=\"a\"/></robot>";
    assert!(
        parse(none, Path::new("r.urdf"))
            .unwrap_err()
            .to_string()
            .contains("no tactile sensor")
    );
    assert!(
        parse("<robot><sensor", Path::new("cut.urdf"))
            .unwrap_err()
            .to_string()
            .contains("cut.urdf: line 1")
    );
}

proptest! {
    #[test]
    fn the_urdf_reader_never_panics(text in ".{0,300}", cut in 0usize..1400) {
        let _ = skin_core::format::urdf_tactile::parse(&text, Path::new("x.urdf"));
        let cut = cut.min(URDF.len());
        let _ = skin_core::format::urdf_tactile::parse(&URDF[..cut], Path::new("x.urdf")); // ASCII
    }
}
