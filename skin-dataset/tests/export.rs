//! `export_files` on the fixtures: every frame back bit for bit (against the assembler's frames
//! for a log, against the numbers written for a recording), episodes appended, other skins and
//! rates refused, a bad input among good ones left out with nothing of it behind.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::record::{Field, Row};
use skin_can::candump::CandumpReader;
use skin_can::{BusMap, DEFAULT_WINDOW_US};
use skin_dataset::{DatasetError, DatasetOptions, export_files};
use skin_learn::session::{FromConfig, Session, SessionConfig};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A run.toml without models (touches tracked, not decided): what the values' tests need.
fn config_without_models(dir: &Path, layout: &str, busmap: Option<&str>, frames: u32) -> SessionConfig {
    let r = repo();
    let mut text = format!("layout = {:?}\n", r.join(layout));
    if let Some(b) = busmap {
        text += &format!("busmap = {:?}\n", r.join(b));
    }
    text += &format!(
        "cache = {:?}\n[baseline]\nframes = {frames}\n",
        r.join("target/skin-cache")
    );
    let path = dir.join("run.toml");
    std::fs::write(&path, text).unwrap();
    SessionConfig::read(&path).unwrap()
}

/// The fixture forearm's configuration, without models (baseline of 20 frames).
fn forearm(dir: &Path) -> SessionConfig {
    config_without_models(
        dir,
        "fixtures/forearm/layout.json",
        Some("fixtures/forearm/busmap.toml"),
        20,
    )
}

fn rows(path: &Path) -> Vec<Row> {
    let reader = SerializedFileReader::new(std::fs::File::open(path).unwrap()).unwrap();
    reader.get_row_iter(None).unwrap().map(Result::unwrap).collect()
}

fn get<'a>(row: &'a Row, name: &str) -> &'a Field {
    row.get_column_iter()
        .find(|(k, _)| *k == name)
        .unwrap_or_else(|| panic!("no column {name}"))
        .1
}

fn floats(field: &Field) -> Vec<u32> {
    let Field::ListInternal(list) = field else {
        panic!("{field:?}")
    };
    list.elements()
        .iter()
        .map(|f| match f {
            Field::Float(x) => x.to_bits(),
            other => panic!("{other:?}"),
        })
        .collect()
}

fn info(root: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(root.join("meta/info.json")).unwrap()).unwrap()
}

#[test]
fn a_log_comes_back_frame_by_frame_in_bus_map_order() {
    let tmp = tempfile::tempdir().unwrap();
    let config = config_without_models(
        tmp.path(),
        "fixtures/arm/layout.json",
        Some("fixtures/arm/busmap.toml"),
        8,
    );
    let log = repo().join("fixtures/arm/touch.candump.log");
    let root = tmp.path().join("ds");
    let export = export_files(
        std::slice::from_ref(&log),
        &mut || Session::from_config(&config),
        &root,
        DatasetOptions::default(),
    )
    .unwrap();
    assert!(export.failed.is_empty(), "{:?}", export.failed);
    let summary = export.summary.unwrap();
    assert_eq!(summary.fps, 20, "the fixture arm's frames are 50 ms apart");

    // The frames as the assembler gives them (what `skin replay -o` writes): bus-map order.
    let map = BusMap::read(&repo().join("fixtures/arm/busmap.toml")).unwrap();
    let mut frames: Vec<(u64, bool, Vec<Option<u16>>)> = Vec::new();
    let mut reader = CandumpReader::open(&log).unwrap();
    skin_can::replay(&mut reader, &map, DEFAULT_WINDOW_US, &mut |f| {
        frames.push((f.time_us, f.is_complete(), f.values.clone()));
        true
    })
    .unwrap();
    let data = rows(&root.join("data/chunk-000/file-000.parquet"));
    assert_eq!(data.len(), frames.len());
    assert_eq!(summary.frames as usize, frames.len());

    // Which link, and which column of it, each taxel of the bus map is.
    let meta = info(&root);
    let mut column: HashMap<String, (String, usize)> = HashMap::new();
    for link in meta["skin"]["links"].as_array().unwrap() {
        for (i, id) in link["taxels"].as_array().unwrap().iter().enumerate() {
            column.insert(
                id.as_str().unwrap().to_owned(),
                (link["feature"].as_str().unwrap().to_owned(), i),
            );
        }
    }
    assert_eq!(meta["skin"]["order"], "bus map");
    let ids = map.taxel_ids();
    let mut last: HashMap<usize, f32> = HashMap::new();
    for (k, (row, frame)) in data.iter().zip(&frames).enumerate() {
        assert_eq!(get(row, "frame_index"), &Field::Long(k as i64));
        assert_eq!(get(row, "time_us"), &Field::Long(frame.0 as i64));
        assert_eq!(get(row, "complete"), &Field::Bool(frame.1));
        for (slot, (id, value)) in ids.iter().zip(&frame.2).enumerate() {
            let (feature, i) = &column[&id.to_string()];
            // A module missing from a frame holds its last reading.
            let want = value.map(f32::from).or(last.get(&slot).copied()).unwrap_or(0.0);
            last.insert(slot, want);
            assert_eq!(
                floats(get(row, feature))[*i],
                want.to_bits(),
                "frame {k}, taxel {id}"
            );
        }
    }
}

#[test]
fn a_recording_comes_back_bit_for_bit_and_its_baseline_beside_it() {
    let tmp = tempfile::tempdir().unwrap();
    let config = config_without_models(tmp.path(), "fixtures/forearm/layout.json", None, 5);
    let layout =
        skin_core::format::native::read_layout(&repo().join("fixtures/forearm/layout.json")).unwrap();
    let ids: Vec<String> = layout.links[0].taxels.iter().map(|t| t.id.to_string()).collect();
    // Counts with fractions and large values: written as text, read back as the same f32.
    let mut text = ids.join(" ") + "\n";
    let mut written: Vec<Vec<f32>> = Vec::new();
    for k in 0..40u32 {
        // The first five frames idle (the baseline learns them); then every taxel but the
        // first pressed by up to 65,535 counts, fractions of a count included.
        let values: Vec<f32> = (0..ids.len() as u32)
            .map(|i| {
                let idle = 100.0 + (i % 7) as f32 + 0.25 * (i % 4) as f32;
                let press = if k < 5 || i == 0 {
                    0
                } else {
                    (k * 7919 + i * 104_729) % 65_536
                };
                idle + press as f32
            })
            .collect();
        text += &format!("{k} {:.6}", f64::from(k) * 0.01);
        for v in &values {
            text += &format!(" {v}");
        }
        text += "\n";
        written.push(values);
    }
    let input = tmp.path().join("press.txt");
    std::fs::write(&input, text).unwrap();
    let root = tmp.path().join("ds");
    let export = export_files(
        &[input],
        &mut || Session::from_config(&config),
        &root,
        DatasetOptions::default(),
    )
    .unwrap();
    let summary = export.summary.unwrap();
    assert_eq!((summary.frames, summary.fps), (40, 100));
    let meta = info(&root);
    assert_eq!(meta["skin"]["order"], "layout");
    let taxels: Vec<&str> = meta["skin"]["links"][0]["taxels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(taxels, ids);
    for (row, want) in rows(&root.join("data/chunk-000/file-000.parquet"))
        .iter()
        .zip(&written)
    {
        let want: Vec<u32> = want.iter().map(|v| v.to_bits()).collect();
        assert_eq!(floats(get(row, "observation.tactile.forearm")), want);
    }
    // The baseline the episode ended with: the untouched taxel's offset is its idle reading.
    let episodes = rows(&root.join("meta/episodes/chunk-000/file-000.parquet"));
    let offsets = floats(get(&episodes[0], "skin/baseline/forearm"));
    assert_eq!(offsets.len(), ids.len());
    assert_eq!(f32::from_bits(offsets[0]), 100.0);
    assert_eq!(floats(get(&episodes[0], "skin/noise/forearm")).len(), ids.len());
}

#[test]
fn episodes_append_to_a_dataset_of_the_same_skin_and_nothing_else() {
    let tmp = tempfile::tempdir().unwrap();
    let config = forearm(tmp.path());
    let log = repo().join("fixtures/forearm/touches.candump.log");
    let root = tmp.path().join("ds");
    let mut session = || Session::from_config(&config);
    export_files(
        std::slice::from_ref(&log),
        &mut session,
        &root,
        DatasetOptions::default(),
    )
    .unwrap();
    let first = std::fs::read(root.join("data/chunk-000/file-000.parquet")).unwrap();

    // Again without --append: refused, the dataset untouched.
    let e = export_files(
        std::slice::from_ref(&log),
        &mut session,
        &root,
        DatasetOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, DatasetError::Exists { episodes: 1, .. }), "{e}");

    let append = DatasetOptions {
        append: true,
        ..DatasetOptions::default()
    };
    let s = export_files(std::slice::from_ref(&log), &mut session, &root, append.clone())
        .unwrap()
        .summary
        .unwrap();
    assert_eq!(s.episodes, 2);
    let meta = info(&root);
    assert_eq!(
        (meta["total_episodes"].as_u64(), meta["total_frames"].as_u64()),
        (Some(2), Some(s.frames))
    );
    // The first episode's file is as it was; the second is the same frames, numbered on.
    assert_eq!(
        std::fs::read(root.join("data/chunk-000/file-000.parquet")).unwrap(),
        first
    );
    let second = rows(&root.join("data/chunk-000/file-001.parquet"));
    assert_eq!(get(&second[0], "episode_index"), &Field::Long(1));
    assert_eq!(get(&second[0], "index"), &Field::Long((s.frames / 2) as i64));
    assert!(root.join("meta/episodes/chunk-000/file-001.parquet").is_file());

    // Another skin (the arm's two links) is refused by name, the dataset left as it was.
    let arm = config_without_models(
        &tmp.path().join(".."),
        "fixtures/arm/layout.json",
        Some("fixtures/arm/busmap.toml"),
        8,
    );
    let before = std::fs::read(root.join("meta/info.json")).unwrap();
    let out = export_files(
        &[repo().join("fixtures/arm/touch.candump.log")],
        &mut || Session::from_config(&arm),
        &root,
        append,
    )
    .unwrap();
    assert!(out.summary.is_none());
    let why = out.failed[0].1.to_string();
    assert!(
        why.contains("touch.candump.log") && why.contains("not the skin of the dataset"),
        "{why}"
    );
    assert_eq!(std::fs::read(root.join("meta/info.json")).unwrap(), before);
}

#[test]
fn a_corrupt_input_among_good_ones_is_named_and_leaves_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let config = forearm(tmp.path());
    let good = repo().join("fixtures/forearm/touches.candump.log");
    let text = std::fs::read_to_string(&good).unwrap();
    // Half a log, then a line that is no CAN frame.
    let lines: Vec<&str> = text.lines().collect();
    let bad = tmp.path().join("bad.log");
    std::fs::write(
        &bad,
        lines[..lines.len() / 2].join("\n") + "\n(17.0) can0 zz#00\n",
    )
    .unwrap();
    let root = tmp.path().join("ds");
    let export = export_files(
        &[good.clone(), bad.clone(), good],
        &mut || Session::from_config(&config),
        &root,
        DatasetOptions::default(),
    )
    .unwrap();
    let s = export.summary.unwrap();
    assert_eq!(s.episodes, 2);
    assert_eq!(export.failed.len(), 1);
    let why = export.failed[0].1.to_string();
    assert!(
        why.contains("bad.log") && why.contains(&format!("line {}", lines.len() / 2 + 1)),
        "{why}"
    );
    // The good ones are episodes 0 and 1, in files 0 and 1: nothing of the bad one anywhere.
    let mut files: Vec<String> = walk(&root);
    files.sort();
    assert_eq!(
        files,
        [
            ".skin-output",
            "contacts/chunk-000/file-000.parquet",
            "contacts/chunk-000/file-001.parquet",
            "data/chunk-000/file-000.parquet",
            "data/chunk-000/file-001.parquet",
            "events/chunk-000/file-000.parquet",
            "events/chunk-000/file-001.parquet",
            "meta/episodes/chunk-000/file-000.parquet",
            "meta/info.json",
            "meta/tasks.parquet",
        ]
    );
}

#[test]
fn a_dataset_dropped_before_it_is_finished_leaves_no_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path().join("ds");
    let ds = skin_dataset::Dataset::create(
        &root,
        DatasetOptions::default(),
        &skin_core::output::Inputs::new::<&Path>([]),
    )
    .unwrap();
    assert!(root.exists());
    drop(ds);
    assert!(!root.exists());
    // No input could be exported: no dataset either.
    let config = forearm(tmp.path());
    let missing = tmp.path().join("missing.log");
    let export = export_files(
        &[missing],
        &mut || Session::from_config(&config),
        &root,
        DatasetOptions::default(),
    )
    .unwrap();
    assert!(export.summary.is_none());
    assert!(export.failed[0].1.to_string().contains("missing.log"));
    assert!(!root.exists());
}

fn walk(root: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_owned()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap().flatten() {
            if e.file_type().unwrap().is_dir() {
                stack.push(e.path());
            } else {
                out.push(
                    e.path()
                        .strip_prefix(root)
                        .unwrap()
                        .to_string_lossy()
                        .replace('\\', "/"),
                );
            }
        }
    }
    out.retain(|f| f != ".skin-lock");
    out
}

#[test]
fn a_missing_module_is_reported_on_its_own_frame() {
    let tmp = tempfile::tempdir().unwrap();
    let config = forearm(tmp.path());
    let text = std::fs::read_to_string(repo().join("fixtures/forearm/touches.candump.log")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    // One CAN frame of a module dropped, well after the baseline's frames.
    let cut = lines.len() * 2 / 3;
    let log = tmp.path().join("lossy.log");
    let kept: Vec<&str> = lines
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != cut)
        .map(|(_, l)| *l)
        .collect();
    std::fs::write(&log, kept.join("\n") + "\n").unwrap();
    let root = tmp.path().join("ds");
    let export = export_files(
        std::slice::from_ref(&log),
        &mut || Session::from_config(&config),
        &root,
        DatasetOptions::default(),
    )
    .unwrap();
    assert_eq!(export.summary.unwrap().added[0].incomplete, 1);
    let data = rows(&root.join("data/chunk-000/file-000.parquet"));
    let incomplete: Vec<i64> = rows(&root.join("events/chunk-000/file-000.parquet"))
        .iter()
        .filter(|e| get(e, "kind") == &Field::Str("incomplete".into()))
        .map(|e| match get(e, "frame_index") {
            Field::Long(i) => *i,
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(incomplete.len(), 1);
    assert_eq!(
        get(&data[incomplete[0] as usize], "complete"),
        &Field::Bool(false)
    );
}
