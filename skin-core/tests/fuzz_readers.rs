//! Fuzzing of every reader of skin-core: arbitrary text and hostile edits of valid files (see
//! `skin_test_support::mutate`) give `Ok` or an error, never a panic, and what is accepted holds
//! what the readers promise (finite positions within `MAX_POSITION_M`, unit normals, unique ids,
//! faces of three distinct taxels, finite readings).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::{Matrix4, Point3, Unit, Vector3};
use proptest::prelude::*;
use skin_core::format::{MAX_POSITION_M, cyskin, icub, native, poses::Postures, recording};
use skin_core::{Frame, LinkSkin, Recording, SkinLayout, Taxel, TaxelId};
use std::collections::HashSet;
use std::path::Path;

use mutate::{arbitrary_text, config, mutated};
use skin_test_support::mutate;

fn link(name: &str, first_id: u32) -> LinkSkin {
    let t = |k: u32, x: f64, y: f64| Taxel {
        id: TaxelId(first_id + k),
        position: Point3::new(x, y, 0.01 * x),
        normal: Unit::new_normalize(Vector3::new(-0.01, 0.0, 1.0)),
    };
    let mut link = LinkSkin::new(
        name,
        vec![
            t(0, 0.0, 0.0),
            t(1, 0.008, 0.0),
            t(2, 0.004, 0.007),
            t(3, 0.012, 0.007),
        ],
    );
    link.faces = Some(vec![[0, 1, 2], [1, 3, 2]]);
    link.frame_to_parent = Some(Matrix4::new_translation(&Vector3::new(0.1, 0.0, 0.2)));
    link
}

/// What every reader promises of a link it accepts.
fn check_sane(link: &LinkSkin) -> Result<(), TestCaseError> {
    let mut ids = HashSet::new();
    for t in &link.taxels {
        prop_assert!(ids.insert(t.id), "taxel id {} twice", t.id);
        prop_assert!(
            t.position
                .coords
                .iter()
                .all(|v| v.is_finite() && v.abs() <= MAX_POSITION_M),
            "taxel {} at {:?}",
            t.id,
            t.position
        );
        prop_assert!(
            (t.normal.norm() - 1.0).abs() < 1e-9,
            "taxel {} normal {:?}",
            t.id,
            t.normal
        );
    }
    for f in link.faces.iter().flatten() {
        prop_assert!(f.iter().all(|&v| v < link.taxels.len()), "face {f:?}");
        prop_assert!(f[0] != f[1] && f[1] != f[2] && f[0] != f[2], "face {f:?}");
    }
    if let Some(m) = &link.frame_to_parent {
        prop_assert!(m.iter().all(|v| v.is_finite()), "frame {m:?}");
        prop_assert!(
            m.fixed_view::<3, 1>(0, 3)
                .iter()
                .all(|v| v.abs() <= MAX_POSITION_M),
            "frame {m:?}"
        );
    }
    Ok(())
}

fn layout_text() -> String {
    native::to_string(&SkinLayout {
        links: vec![link("forearm", 16), link("wrist", 100)],
    })
}

const ICUB: &str = "name    hand\nspatial_sampling     taxel\ntaxel2Repr ( 0 0 -1 3 )\n[calibration]\n\
0.0 0.0 0.0 0.0 0.0 0.0\n\
0.010 0.000 0.020 0.0 0.1 1.0\n\
0.012 0.004 0.020 0.0 0.1 1.0\n\
0.012 0.004 0.020 0.0 0.1 1.0\n\
0.014 -0.004 0.021 0.1 0.0 1.0\n\
-0.01 0.002 0.019 0.0 -0.2 0.9\n";

fn recording_text() -> String {
    let frames = (0..4)
        .map(|k| Frame {
            time: f64::from(k) * 0.05,
            values: vec![f32::from(k as u16) * 100.0, 3.0, 65535.0],
        })
        .collect();
    recording::to_string(&Recording {
        taxel_ids: vec![TaxelId(16), TaxelId(17), TaxelId(900)],
        frame_numbers: vec![0, 1, 2, 3],
        frames,
    })
}

const POSES: &str = r#"{
  "format": "skin-poses/1",
  "links": ["forearm", "wrist"],
  "postures": [
    {"name": "lower limit", "time_s": 0.0, "poses": [
      {"translation": [0.0, 0.0, 0.0], "rotation": [1.0, 0.0, 0.0, 0.0]},
      {"translation": [0.0, 0.342, 0.0], "rotation": [0.968912422, -0.0, -0.247403959, -0.0]}
    ]},
    {"name": "upper limit", "time_s": 4.0, "poses": [
      {"translation": [0.0, 0.0, 0.0], "rotation": [1.0, 0.0, 0.0, 0.0]},
      {"translation": [0.0, 0.342, 0.0], "rotation": [0.968912422, 0.0, 0.247403959, 0.0]}
    ]}
  ]
}"#;

fn check_layout(text: &str) -> Result<(), TestCaseError> {
    if let Ok(layout) = native::parse_layout(text, Path::new("layout.json")) {
        for l in &layout.links {
            check_sane(l)?;
        }
    }
    Ok(())
}

fn check_cyskin(text: &str) -> Result<(), TestCaseError> {
    if let Ok(l) = cyskin::parse_skin(text, Path::new("patch.json")).map(|n| n.value) {
        check_sane(&l)?;
    }
    if let Ok(m) = cyskin::parse_tactile_map(text, Path::new("map.json")) {
        prop_assert_eq!(m.ids.len(), m.points.len());
        prop_assert!(m.points.iter().flatten().all(|v| v.is_finite()));
        prop_assert!(m.faces.iter().flatten().all(|&v| v < m.ids.len()));
    }
    Ok(())
}

fn check_icub(text: &str) -> Result<(), TestCaseError> {
    for d in [icub::Duplicates::Merge, icub::Duplicates::Reject] {
        if let Ok(p) = icub::parse(text, Path::new("hand.txt"), d) {
            check_sane(&p.skin)?;
        }
    }
    Ok(())
}

fn check_recording(text: &str) -> Result<(), TestCaseError> {
    if let Ok(r) = recording::parse(text, Path::new("rec.txt")) {
        let ids: HashSet<_> = r.taxel_ids.iter().collect();
        prop_assert_eq!(ids.len(), r.taxel_ids.len());
        prop_assert_eq!(r.frames.len(), r.frame_numbers.len());
        for f in &r.frames {
            prop_assert_eq!(f.values.len(), r.taxel_ids.len());
            prop_assert!(f.time.is_finite());
            prop_assert!(
                f.values.iter().all(|v| v.abs() <= recording::MAX_READING),
                "{:?}",
                f.values
            );
        }
    }
    Ok(())
}

fn check_poses(text: &str) -> Result<(), TestCaseError> {
    if let Ok(p) = Postures::parse(text, Path::new("poses.json")) {
        prop_assert!(!p.postures.is_empty());
        let mut last = f64::NEG_INFINITY;
        for q in &p.postures {
            prop_assert!(q.time_s.is_finite() && q.time_s >= last);
            last = q.time_s;
            prop_assert_eq!(q.poses.len(), p.links.len());
            for pose in &q.poses {
                prop_assert!(
                    pose.translation
                        .vector
                        .iter()
                        .all(|v| v.is_finite() && v.abs() <= MAX_POSITION_M)
                );
                prop_assert!((pose.rotation.norm() - 1.0).abs() < 1e-9);
            }
            // The lookup by time works for any time.
            for t in [f64::NEG_INFINITY, -1.0, 0.0, 1e300, f64::NAN] {
                prop_assert!(p.at(t) < p.postures.len());
            }
        }
    }
    Ok(())
}

#[test]
fn the_valid_files_read() {
    assert_eq!(
        native::parse_layout(&layout_text(), Path::new("x"))
            .unwrap()
            .links
            .len(),
        2
    );
    cyskin::parse_skin(&cyskin::skin_to_string(&link("p", 0)), Path::new("x")).unwrap();
    assert_eq!(
        icub::parse(ICUB, Path::new("x"), icub::Duplicates::Merge)
            .unwrap()
            .skin
            .taxels
            .len(),
        4
    );
    assert_eq!(
        recording::parse(&recording_text(), Path::new("x"))
            .unwrap()
            .frames
            .len(),
        4
    );
    assert_eq!(Postures::parse(POSES, Path::new("x")).unwrap().postures.len(), 2);
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn layouts(text in prop_oneof![mutated(&layout_text()), arbitrary_text()]) {
        check_layout(&text)?;
        // load_link picks the reader from the content: the same rules hold through it.
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("layout.json");
        std::fs::write(&p, &text).unwrap();
        if let Ok(l) = skin_core::format::load_link(&p).map(|n| n.value) {
            check_sane(&l)?;
        }
    }

    #[test]
    fn cyskin_files(text in prop_oneof![
        mutated(&cyskin::skin_to_string(&link("patch", 83_931))),
        mutated(&cyskin::tactile_map_to_string(&cyskin::CyskinTactileMap {
            name: "patch".into(),
            kind: "lscm".into(),
            ids: vec![TaxelId(1), TaxelId(2), TaxelId(3), TaxelId(4)],
            points: vec![[0.0, 0.0], [0.008, 0.0], [0.004, 0.007], [0.012, 0.007]],
            faces: vec![[0, 1, 2], [1, 3, 2]],
        })),
        arbitrary_text(),
    ]) {
        check_cyskin(&text)?;
    }

    #[test]
    fn icub_files(text in prop_oneof![mutated(ICUB), arbitrary_text()]) {
        check_icub(&text)?;
    }

    #[test]
    fn recordings(text in prop_oneof![mutated(&recording_text()), arbitrary_text()]) {
        check_recording(&text)?;
    }

    #[test]
    fn poses(text in prop_oneof![mutated(POSES), arbitrary_text()]) {
        check_poses(&text)?;
    }
}
