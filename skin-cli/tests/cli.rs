//! The `skin` command as a user runs it: outputs, reports, and one clear line for bad input.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test or bench

use std::path::{Path, PathBuf};
use std::process::Output;

skin_test_support::skin_binary!(); // skin(args) runs this package's binary; root()

use shared_data::shared;
use skin_test_support::recordings;
use skin_test_support::shared_data;

fn fixture(name: &str) -> String {
    root().join("fixtures/forearm").join(name).display().to_string()
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

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

/// `skin --help` gives one line per command at clap's default width (100 columns); the details
/// are in `skin help CMD`.
#[test]
fn help_lists_each_command_on_one_line() {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_skin"))
        .arg("--help")
        .env_remove("COLUMNS")
        .output()
        .unwrap();
    let out = String::from_utf8(o.stdout).unwrap();
    let commands: Vec<&str> = out
        .split("Commands:\n")
        .nth(1)
        .and_then(|rest| rest.split("\n\n").next())
        .unwrap_or_default()
        .lines()
        .collect();
    assert!(commands.len() >= 10, "{out}");
    for line in &commands {
        let name = line.split_whitespace().next().unwrap_or_default();
        assert!(
            line.starts_with("  ")
                && !line.starts_with("   ")
                && name.chars().all(|c| c.is_ascii_lowercase() || c == '-'),
            "a summary broken over lines: {line:?}\n{out}"
        );
    }
    let (long, _) = text(&skin(&["help", "replay"]));
    assert!(long.contains("--window-ms") && long.contains("sync"), "{long}");
}

#[test]
fn help_explains_units_and_formats() {
    let (out, _) = text(&skin(&["flatten", "--help"]));
    assert!(
        out.contains("metres") && out.contains("iCub") && out.contains("Cyskin"),
        "{out}"
    );
    let (out, _) = text(&skin(&["image", "--help"]));
    assert!(out.contains("millimetres") && out.contains("68x100"), "{out}");
}

#[test]
fn replay_assembles_the_fixture_log_into_the_recorded_values() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("frames.csv");
    let o = skin(&[
        "replay",
        &fixture("touches.candump.log"),
        "--busmap",
        &fixture("busmap.toml"),
        "-o",
        csv.to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("130 skin frames (one per sync cycle) of 715 taxels: 130 complete, 0 partial"),
        "{out}"
    );
    // The log's ground truth is the recording: same taxels, same readings, frame by frame.
    let rec = skin_core::format::recording::read(std::path::Path::new(&fixture("touches.txt"))).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let ids: Vec<String> = rec.taxel_ids.iter().map(|t| t.0.to_string()).collect();
    assert_eq!(
        &header[3..],
        &ids.iter().map(String::as_str).collect::<Vec<_>>()[..]
    );
    for (line, frame) in lines.zip(&rec.frames) {
        let cells: Vec<&str> = line.split(',').collect();
        assert_eq!(cells[2], "1");
        let values: Vec<f32> = cells[3..].iter().map(|c| c.parse().unwrap()).collect();
        assert_eq!(values, frame.values);
    }
}

#[test]
fn replay_reports_a_lost_can_frame_and_leaves_its_cells_empty() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("lossy.log");
    let original = std::fs::read_to_string(fixture("touches.candump.log")).unwrap();
    // Lose one data frame of module 7 (address 6) in the 11th cycle.
    let lost = original
        .lines()
        .filter(|l| l.contains(" can0 219#"))
        .nth(10)
        .unwrap()
        .to_string();
    std::fs::write(&log, original.replacen(&format!("{lost}\n"), "", 1)).unwrap();
    let csv = dir.path().join("f.csv");
    let o = skin(&[
        "replay",
        log.to_str().unwrap(),
        "--busmap",
        &fixture("busmap.toml"),
        "-o",
        csv.to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("129 complete, 1 partial") && out.contains("module 6 on can0 missing in 1 frame(s)"),
        "{out}"
    );
    let row = std::fs::read_to_string(&csv)
        .unwrap()
        .lines()
        .nth(11)
        .unwrap()
        .to_string();
    assert!(row.split(',').nth(2) == Some("0") && row.contains(",,"), "{row}");
}

#[test]
fn replay_cuts_icub8_traffic_into_windows_and_writes_exactly_the_ground_truth() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("frames.csv");
    let o = skin(&[
        "replay",
        &fixture("touches.icub8.log"),
        "--busmap",
        &fixture("busmap.icub8.toml"),
        "--layout",
        &fixture("layout.json"),
        "-o",
        csv.to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("all 715 taxels are on a bus")
            && out.contains("icub8 -> 130 skin frames (one per 50 ms window) of 715 taxels: 130 complete"),
        "{out}"
    );
    let ours = std::fs::read_to_string(&csv).unwrap();
    let truth = std::fs::read_to_string(fixture("touches.icub8.csv")).unwrap();
    assert!(ours == truth, "replayed frames differ from touches.icub8.csv");
    // A window much shorter than the boards' period splits every cycle: reported, not hidden.
    let o = skin(&[
        "replay",
        &fixture("touches.icub8.log"),
        "--busmap",
        &fixture("busmap.icub8.toml"),
        "--window-ms",
        "20",
    ]);
    let (out, _) = text(&o);
    assert!(
        out.contains("0 complete") && out.contains("modules missing: 65"),
        "{out}"
    );
}

#[test]
fn record_and_live_name_the_interface_that_cannot_be_opened_and_write_nothing() {
    // This workplace has no CAN interfaces: both commands must say so in one line and leave no file.
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("session.log");
    let o = skin(&[
        "record",
        "--busmap",
        &fixture("busmap.toml"),
        "--can",
        "skintest7",
        "-o",
        log.to_str().unwrap(),
        "--duration",
        "1",
    ]);
    let (_, err) = text(&o);
    assert!(!o.status.success());
    assert!(err.starts_with("error: skintest7: cannot open"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "nothing written"
    );
    let o = skin(&["live", "--busmap", &fixture("busmap.toml"), "--duration", "0"]);
    let (_, err) = text(&o);
    assert!(
        !o.status.success() && err.contains("--duration must be a positive"),
        "{err}"
    );
    let (help, _) = text(&skin(&["live", "--help"]));
    assert!(help.contains("SocketCAN") && help.contains("--master"), "{help}");
}

#[test]
fn replay_refuses_a_bus_map_for_another_layout() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("other.toml");
    std::fs::write(
        &map,
        "format = \"skin16\"\n[[bus]]\ninterface = \"can0\"\n[[bus.module]]\naddress = 0\ntaxels = [4000, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1]\n",
    )
    .unwrap();
    let o = skin(&[
        "replay",
        &fixture("touches.candump.log"),
        "--busmap",
        map.to_str().unwrap(),
        "--layout",
        &fixture("layout.json"),
    ]);
    let (_, err) = text(&o);
    assert!(!o.status.success());
    assert!(err.contains("taxel 4000 is not in the layout"), "{err}");
}

#[test]
fn busmap_for_the_fixture_layout_matches_the_fixture_bus_map() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("map.toml");
    let o = skin(&[
        "busmap",
        "--layout",
        &fixture("layout.json"),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let ours = skin_can::BusMap::read(&out).unwrap();
    let fixture_map = skin_can::BusMap::read(std::path::Path::new(&fixture("busmap.toml"))).unwrap();
    assert_eq!(ours, fixture_map);
    // Four buses share the 65 modules 17, 17, 17, 14.
    let o = skin(&["busmap", "--layout", &fixture("layout.json"), "--buses", "4"]);
    let four = skin_can::BusMap::parse(&text(&o).0, std::path::Path::new("stdout")).unwrap();
    let sizes: Vec<usize> = four.buses.iter().map(|b| b.modules.len()).collect();
    assert_eq!(sizes, vec![17, 17, 17, 14]);
    assert_eq!(four.taxel_ids(), ours.taxel_ids());
}

fn hex(name: &str) -> String {
    root().join("fixtures/hex_patch").join(name).display().to_string()
}

#[test]
fn calibrate_recovers_the_hex_patch_and_prints_the_thesis_table() {
    let dir = tempfile::tempdir().unwrap();
    let (out, plot) = (dir.path().join("cal.json"), dir.path().join("curve.svg"));
    let o = skin(&[
        "calibrate",
        &hex("probes.csv"),
        "-o",
        out.to_str().unwrap(),
        "--truth",
        &hex("layout.json"),
        "--plot",
        plot.to_str().unwrap(),
    ]);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        stdout.contains("61 fitted, 0 flagged") && stdout.contains("thesis ABS"),
        "{stdout}"
    );
    // The table's row: mean error, sigma, normal error, max; all within the thesis' figures.
    let row: Vec<f64> = stdout
        .lines()
        .find(|l| l.starts_with("this dataset"))
        .unwrap()
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    assert!(row[0] <= 1.9 && row[2] <= 0.06 && row[4] <= 4.0, "{row:?}");
    let layout = skin_core::format::load_link(&out).unwrap().value;
    assert_eq!(layout.taxels.len(), 61);
    assert!(
        std::fs::read_to_string(&plot)
            .unwrap()
            .contains("samples per taxel")
    );
}

/// `skin probe-sim` on the hexagonal patch with `args`, into DIR/p.csv.
fn hex_probes(dir: &Path, args: &[&str]) -> PathBuf {
    let probes = dir.join("p.csv");
    let mut all = vec!["probe-sim", "--layout"];
    let layout = hex("layout.json");
    all.push(&layout);
    all.extend_from_slice(args);
    all.extend_from_slice(&["-o", probes.to_str().unwrap()]);
    let o = skin(&all);
    assert!(o.status.success(), "{}", text(&o).1);
    probes
}

#[test]
fn probe_sim_then_calibrate_writes_a_cyskin_layout_and_flags_what_it_cannot_fit() {
    let dir = tempfile::tempdir().unwrap();
    // Few contacts: some border taxels answer too rarely and must be flagged, not guessed.
    let probes = hex_probes(dir.path(), &["--contacts", "60", "--seed", "3"]);
    let out = dir.path().join("cal.json");
    let o = skin(&[
        "calibrate",
        probes.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--format",
        "cyskin",
    ]);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(stdout.contains("too few responses"), "{stdout}");
    let flagged: usize = stdout
        .split(" fitted, ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap();
    let link = skin_core::format::cyskin::read_skin(&out).unwrap().value;
    assert!(flagged > 0 && link.taxels.len() + flagged <= 61, "{stdout}");
}

/// Probed only inside its outermost taxels, the hexagonal patch's border is one-sided: the
/// taxels there are flagged as not surrounded, and the report gives every taxel's status and
/// the fitted ones' uncertainty.
#[test]
fn calibrate_flags_edge_taxels_its_contacts_do_not_surround_and_reports_uncertainty() {
    let dir = tempfile::tempdir().unwrap();
    let probes = hex_probes(dir.path(), &["--contacts", "800", "--margin-mm", "0"]);
    let (out, report) = (dir.path().join("cal.json"), dir.path().join("report.tsv"));
    let o = skin(&[
        "calibrate",
        probes.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(stdout.contains("not surrounded by its contacts"), "{stdout}");
    assert!(stdout.contains("centre uncertainty"), "{stdout}");
    let table = std::fs::read_to_string(&report).unwrap();
    let mut lines = table.lines();
    assert_eq!(lines.next(), Some(skin_learn::calibration::REPORT_HEADER));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split('\t').collect()).collect();
    assert_eq!(rows.len(), 61);
    for r in &rows {
        assert_eq!(r.len(), 8, "{r:?}");
        if r[1] == "fitted" {
            let sd: f64 = r[6].parse().unwrap();
            assert!(sd > 0.0 && sd < 2.0, "{r:?}");
        } else {
            assert!(r[3].is_empty(), "a flagged taxel has no position: {r:?}");
        }
    }
    let edge = rows.iter().filter(|r| r[1].starts_with("not surrounded")).count();
    assert!(
        (1..=30).contains(&edge),
        "{edge} taxels flagged as not surrounded"
    );
    // A bad angle is refused before anything is written.
    let o = skin(&[
        "calibrate",
        probes.to_str().unwrap(),
        "-o",
        dir.path().join("x.json").to_str().unwrap(),
        "--max-open-angle",
        "400",
    ]);
    assert!(!o.status.success() && text(&o).1.contains("--max-open-angle"));
    assert!(!dir.path().join("x.json").exists());
}

#[test]
fn calibrate_names_the_line_and_field_of_a_bad_row() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.csv");
    std::fs::write(
        &bad,
        "contact,x_m,y_m,z_m,taxel,response\n0,0.1,0.2,0.3,16,5\n1,0.1,0.2,abc,16,5\n",
    )
    .unwrap();
    let out = dir.path().join("o.json");
    let o = skin(&["calibrate", bad.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("line 3, field z_m"), "{err}");
    assert!(!out.exists());
    let o = skin(&[
        "calibrate",
        &hex("probes.csv"),
        "-o",
        out.to_str().unwrap(),
        "--plot",
        "c.svg",
    ]);
    assert!(
        !o.status.success() && text(&o).1.contains("give --truth"),
        "{}",
        text(&o).1
    );
}

fn arm(name: &str) -> String {
    root().join("fixtures/arm").join(name).display().to_string()
}

/// Number of 8-connected groups of non-black pixels.
fn blobs(img: &image::GrayImage) -> usize {
    let (w, h) = img.dimensions();
    let mut seen = vec![false; (w * h) as usize];
    let mut count = 0;
    for start in 0..(w * h) {
        if seen[start as usize] || img.as_raw()[start as usize] == 0 {
            continue;
        }
        count += 1;
        let mut stack = vec![start];
        seen[start as usize] = true;
        while let Some(p) = stack.pop() {
            let (x, y) = ((p % w) as i64, (p / w) as i64);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let q = (ny as u32) * w + nx as u32;
                    if !seen[q as usize] && img.as_raw()[q as usize] != 0 {
                        seen[q as usize] = true;
                        stack.push(q);
                    }
                }
            }
        }
    }
    count
}

#[test]
fn stitch_shows_a_touch_across_the_joint_as_one_blob_at_every_posture() {
    let dir = tempfile::tempdir().unwrap();
    let o = skin(&[
        "stitch",
        "--layout",
        &arm("layout.json"),
        "--poses",
        &arm("poses.json"),
        &arm("touch.txt"),
        "-o",
        dir.path().to_str().unwrap(),
        "--threshold",
        "10",
        "--svg",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    // Every posture's stitched edges keep their 3D length within 5 %.
    let mut postures = 0;
    for line in out.lines().filter(|l| l.starts_with("posture")) {
        let pct: f64 = line
            .split("within ")
            .nth(1)
            .and_then(|s| s.split('%').next())
            .and_then(|s| s.parse().ok())
            .unwrap();
        assert!(pct < 5.0, "{line}");
        assert!(
            !line.contains("not converged") && !line.contains("no edge"),
            "{line}"
        );
        postures += 1;
    }
    assert_eq!(postures, 3, "{out}");
    // The palm presses at 1.0 s, 3.0 s and 5.0 s: lower limit, middle, upper limit.
    for frame in [20, 60, 100] {
        let img = image::open(dir.path().join(format!("touch/frame_{frame:05}.png")))
            .unwrap()
            .to_luma8();
        assert_eq!(blobs(&img), 1, "frame {frame}");
    }
    // Between touches, nothing.
    let idle = image::open(dir.path().join("touch/frame_00036.png"))
        .unwrap()
        .to_luma8();
    assert_eq!(blobs(&idle), 0);
    for name in ["lower_limit", "middle", "upper_limit"] {
        assert!(dir.path().join(format!("stitched_{name}.svg")).exists());
    }
}

/// A recording that lacks the most pressed taxel of each press: reported, the chain stitched
/// again without it, and each press is still one blob (no hole where the taxel was).
#[test]
fn stitch_bridges_the_taxels_a_recording_lacks() {
    let dir = tempfile::tempdir().unwrap();
    let full = skin_core::format::recording::read(Path::new(&arm("touch.txt"))).unwrap();
    let mut gone = Vec::new();
    for k in [20, 60, 100] {
        let v = &full.frames[k].values;
        let top = (0..v.len()).max_by(|&a, &b| v[a].total_cmp(&v[b])).unwrap();
        if !gone.contains(&top) {
            gone.push(top);
        }
    }
    let holed = recordings::without_columns(&full, &gone);
    let path = dir.path().join("holed.txt");
    skin_core::format::recording::write(&path, &holed).unwrap();
    let out = dir.path().join("out");
    let o = skin(&[
        "stitch",
        "--layout",
        &arm("layout.json"),
        "--poses",
        &arm("poses.json"),
        path.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--threshold",
        "10",
    ]);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        stdout.contains("are not recorded") && stdout.contains("dead, the images bridge them"),
        "{stdout}"
    );
    for frame in [20, 60, 100] {
        let img = image::open(out.join(format!("holed/frame_{frame:05}.png")))
            .unwrap()
            .to_luma8();
        assert_eq!(blobs(&img), 1, "frame {frame}");
    }
}

#[test]
fn stitch_refuses_poses_for_other_links() {
    let dir = tempfile::tempdir().unwrap();
    let poses = dir.path().join("poses.json");
    let text_in = std::fs::read_to_string(arm("poses.json"))
        .unwrap()
        .replace("\"wrist\"]", "\"hand\"]");
    std::fs::write(&poses, text_in).unwrap();
    let o = skin(&[
        "stitch",
        "--layout",
        &arm("layout.json"),
        "--poses",
        poses.to_str().unwrap(),
        "-o",
        dir.path().join("out").to_str().unwrap(),
    ]);
    let (_, err) = text(&o);
    assert!(
        !o.status.success() && err.contains("same names, same order"),
        "{err}"
    );
    let bad = dir.path().join("bad.json");
    let nan = std::fs::read_to_string(arm("poses.json")).unwrap().replacen(
        "[0.0, 0.0, 0.0]",
        "[0.0, 0.0, 1e300]",
        1,
    );
    std::fs::write(&bad, nan).unwrap();
    let o = skin(&[
        "stitch",
        "--layout",
        &arm("layout.json"),
        "--poses",
        bad.to_str().unwrap(),
        "-o",
        "x",
    ]);
    // The poses file is blamed, at the posture and link, not the layout.
    let (_, err) = text(&o);
    assert!(
        !o.status.success()
            && err.contains("bad.json")
            && err.contains("postures[0]")
            && err.contains("100 m"),
        "{err}"
    );
}

#[test]
fn degrade_writes_the_same_faulty_map_for_the_same_seed() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str], out: &str| {
        let path = dir.path().join(out);
        let mut all = vec!["degrade", "--map"];
        let layout = fixture("layout.json");
        all.push(&layout);
        all.extend_from_slice(args);
        all.extend_from_slice(&["-o", path.to_str().unwrap()]);
        let o = skin(&all);
        assert!(o.status.success(), "{}", text(&o).1);
        (text(&o).0, std::fs::read_to_string(path).unwrap())
    };
    let (out, a) = run(
        &["--blind-spots", "2", "--radius-mm", "20", "--seed", "7"],
        "a.json",
    );
    assert!(out.contains("taxels read zero"), "{out}");
    let (_, b) = run(
        &["--blind-spots", "2", "--radius-mm", "20", "--seed", "7"],
        "b.json",
    );
    let (_, c) = run(
        &["--blind-spots", "2", "--radius-mm", "20", "--seed", "8"],
        "c.json",
    );
    assert!(a == b && a != c);
    // Removal: nested by seed, and the images still come out.
    let (_, r30) = run(&["--remove", "0.3", "--seed", "1"], "r30.json");
    let (_, r60) = run(&["--remove", "0.6", "--seed", "1"], "r60.json");
    let ids = |json: &str| -> Vec<u64> {
        let v: serde_json::Value = serde_json::from_str(json).unwrap();
        v["ids"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap())
            .collect()
    };
    let (few, many) = (ids(&r60), ids(&r30));
    assert!(few.len() < many.len() && few.iter().all(|i| many.contains(i)));
    let o = skin(&[
        "image",
        "--map",
        dir.path().join("r60.json").to_str().unwrap(),
        &fixture("touches.txt"),
        "-o",
        dir.path().join("img").to_str().unwrap(),
        "-q",
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let o = skin(&["degrade", "--map", &fixture("layout.json"), "-o", "x.json"]);
    assert!(
        !o.status.success() && text(&o).1.contains("give either"),
        "{}",
        text(&o).1
    );
}

/// A small reach scene: the first two goals and bars of the default one, two starts each.
fn small_reach_scene(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(root().join("skin-control/scenes/fig8_4.json")).unwrap();
    let mut scene: serde_json::Value = serde_json::from_str(&text).unwrap();
    for key in ["obstacles", "goals"] {
        scene[key].as_array_mut().unwrap().truncate(2);
    }
    scene["random_starts"] = 2.into();
    let path = dir.join("scene.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    path
}

#[test]
fn reach_prints_the_same_table_for_the_same_seed_and_the_baseline_fails_on_force() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_reach_scene(dir.path());
    let scene = scene.to_str().unwrap();
    let csv = dir.path().join("trials.csv");
    let a = skin(&["reach", "--scene", scene, "--csv", csv.to_str().unwrap()]);
    let b = skin(&["reach", "--scene", scene]);
    assert!(a.status.success(), "{:?}", text(&a));
    assert_eq!(a.stdout, b.stdout, "same seed, same table");
    let (out, _) = text(&a);
    assert!(out.contains("F_thresh = 15 N"), "{out}");
    assert!(out.lines().any(|l| l.starts_with("A ")) && out.lines().any(|l| l.starts_with("all ")));
    let rows = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(rows.lines().count(), 1 + 4);
    assert!(
        rows.starts_with("seed,skin,goal,start,outcome,")
            && rows.lines().nth(1).unwrap().starts_with("1,1,A,0,"),
        "{rows}"
    );
    let base = skin(&["reach", "--scene", scene, "--no-skin"]);
    let (out, _) = text(&base);
    assert!(out.contains("WITHOUT skin"), "{out}");
    // Every baseline trial pushes through a bar: 0 successes, 4 force failures.
    let all = out.lines().find(|l| l.starts_with("all ")).unwrap();
    assert!(all.contains("0/4"), "{all}");
    let other = skin(&["reach", "--scene", scene, "--seed", "5"]);
    assert_ne!(other.stdout, a.stdout, "another seed, other starts");
}

#[test]
fn reach_over_seeds_gives_each_seed_pooled_and_mean_rates_with_the_baseline() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_reach_scene(dir.path());
    let scene = scene.to_str().unwrap();
    let csv = dir.path().join("trials.csv");
    let o = skin(&[
        "reach",
        "--scene",
        scene,
        "--seed",
        "3",
        "--seeds",
        "2",
        "--baseline",
        "--csv",
        csv.to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("seeds 3-4") && out.contains("WITHOUT skin"), "{out}");
    let seed_rows: Vec<&str> = out
        .lines()
        .filter(|l| l.starts_with("3 ") || l.starts_with("4 "))
        .collect();
    assert_eq!(seed_rows.len(), 2, "{out}");
    // Each seed: 4 trials with the skin and the same 4 without; the baseline pushes through the
    // bars every time.
    assert!(
        seed_rows
            .iter()
            .all(|l| l.matches("/4 ").count() == 2 && l.contains("0/4 ")),
        "{out}"
    );
    let all = out.lines().rfind(|l| l.starts_with("all ")).unwrap();
    assert!(all.contains("/8 ") && all.contains("0/8 "), "{all}");
    assert!(
        out.contains("mean over 2 seeds (95% t interval): with skin"),
        "{out}"
    );
    // Seed 3 alone gives its own row of the same numbers.
    let one = skin(&["reach", "--scene", scene, "--seed", "3", "--baseline"]);
    let (one, _) = text(&one);
    let row3 = |t: &str| t.lines().find(|l| l.starts_with("3 ")).map(str::to_owned);
    assert_eq!(row3(&one), row3(&out));
    let rows = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(rows.lines().count(), 1 + 2 * 4 * 2);
    assert_eq!(rows.lines().filter(|l| l.starts_with("4,0,")).count(), 4);
    let o = skin(&["reach", "--scene", scene, "--seeds", "0"]);
    assert!(
        !o.status.success() && text(&o).1.contains("--seeds"),
        "{:?}",
        text(&o)
    );
    let o = skin(&["reach", "--scene", scene, "--no-skin", "--baseline"]);
    assert!(
        !o.status.success() && text(&o).1.contains("--baseline"),
        "{:?}",
        text(&o)
    );
}

#[test]
fn reach_refuses_a_bad_threshold_and_a_bad_scene_in_one_line() {
    let o = skin(&["reach", "--threshold=-3"]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("--threshold"), "{err}");
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, r#"{"goals": [[0.5, 0, 0.5]], "obstacles": [{"type": "capsule", "a": [0,0,0], "b": [0,0,1], "radius": 0}]}"#).unwrap();
    let o = skin(&["reach", "--scene", bad.to_str().unwrap()]);
    let (_, err) = text(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("bad.json") && err.contains("obstacles[0].radius"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

#[test]
fn phri_reports_the_ignored_bump_and_the_push_and_plots_the_timeline() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("timeline.svg");
    let o = skin(&["phri", "--svg", svg.to_str().unwrap()]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("task 1 not activated (ignored)"), "{out}");
    assert!(out.contains("task 1 active after"), "{out}");
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert!(plot.starts_with("<svg") && plot.contains("path error (mm)"));
}

#[test]
fn classify_runs_the_matlab_handsnet_on_every_touched_frame_of_a_recording() {
    let Some(model) = shared("cyskin/HandsNet_handles_finetuned.onnx") else {
        return;
    };
    let model = model.to_str().unwrap();
    let o = skin(&[
        "classify",
        "--model",
        model,
        "--map",
        &fixture("layout.json"),
        &fixture("touches.txt"),
        "--labels",
        "first,second",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("[N, 1, 68, 100] -> 2 classes (first, second)"),
        "{out}"
    );
    let frames = out.lines().filter(|l| l.contains(" frame ")).count();
    let quiet: usize = out
        .lines()
        .find(|l| l.contains("with no contact"))
        .and_then(|l| l.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap();
    assert_eq!(frames + quiet, 130, "{out}");
    // A PNG of the wrong size is one clear line.
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("big.png");
    std::fs::write(&png, skin_geom_png(10, 20)).unwrap();
    let o = skin(&["classify", "--model", model, png.to_str().unwrap()]);
    let (_, err) = text(&o);
    assert!(
        !o.status.success() && err.contains("10 x 20 px, the model takes 68 x 100"),
        "{err}"
    );
    // Wrong label count.
    let o = skin(&[
        "classify",
        "--model",
        model,
        png.to_str().unwrap(),
        "--labels",
        "a,b,c",
    ]);
    let (_, err) = text(&o);
    assert!(
        !o.status.success() && err.contains("--labels names 3 classes"),
        "{err}"
    );
}

fn skin_geom_png(rows: u32, cols: u32) -> Vec<u8> {
    let mut out = Vec::new();
    image::GrayImage::new(cols, rows)
        .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .unwrap();
    out
}

// skin synth, skin eval, skin segment: touch understanding (Ch. 4, 5).

/// `skin synth` of 60 samples of 4 subjects on the fixture forearm, with `extra` arguments.
fn synth_run(dir: &Path, seed: &str, extra: &[&str]) -> std::process::Output {
    let layout = root().join("fixtures/forearm/layout.json");
    let mut args = vec![
        "synth",
        "--layout",
        layout.to_str().unwrap(),
        "--count",
        "60",
        "--subjects",
        "4",
        "--seed",
        seed,
        "-o",
        dir.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    skin(&args)
}

fn synth(dir: &Path, seed: &str) -> String {
    let o = synth_run(dir, seed, &[]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    out
}

fn grey(path: &Path) -> Vec<u8> {
    image::open(path).unwrap().into_luma8().into_raw()
}

#[test]
fn synth_writes_a_repeatable_labelled_dataset() {
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    let report = synth(&a, "5");
    synth(&b, "5");
    assert!(report.contains("60 samples of 4 subjects"), "{report}");
    for f in ["labels.csv", "frames.txt", "taxel_parts.txt", "map.json"] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f} differs between two runs with one seed"
        );
    }
    let data = skin_learn::dataset::Dataset::read(&a).unwrap();
    assert_eq!(data.entries.len(), 60);
    let hands = data.entries.iter().filter(|e| e.hand).count();
    assert!((15..=45).contains(&hands), "{hands} hands of 60 at a 50% share");
    let mut labelled = 0;
    for (i, e) in data.entries.iter().enumerate() {
        let image = grey(&a.join("images").join(&e.file));
        assert_eq!(image.len(), 68 * 100);
        let mask = a.join("masks").join(&e.file);
        assert_eq!(mask.exists(), e.hand, "a mask for hands only ({})", e.file);
        if e.hand {
            let mask = grey(&mask);
            assert!(mask.iter().all(|&l| l <= 6));
            assert!(
                mask.iter().zip(&image).all(|(&l, &g)| l == 0 || g > 0),
                "sample {i}: a part label on a black pixel"
            );
            labelled += usize::from(mask.iter().any(|&l| l > 0));
        }
    }
    assert!(
        labelled * 10 >= hands * 9,
        "only {labelled} of {hands} hand masks show a part"
    );
    // Another seed, another dataset.
    let c = tmp.path().join("c");
    synth(&c, "6");
    assert_ne!(
        std::fs::read(a.join("frames.txt")).unwrap(),
        std::fs::read(c.join("frames.txt")).unwrap()
    );
}

#[test]
fn synth_with_taxels_removed_keeps_the_readings_and_thins_the_images() {
    let tmp = tempfile::tempdir().unwrap();
    let (whole, thin) = (tmp.path().join("whole"), tmp.path().join("thin"));
    synth(&whole, "5");
    let args = |extra: &[&str]| synth_run(&thin, "5", extra);
    let o = args(&["--remove-up-to", "0.7", "--thinned-share", "1"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    assert!(
        out.contains("60 imaged through maps with up to 70% of the taxels removed"),
        "{out}"
    );
    // The same contacts, read by every taxel, with the same labels.
    for f in ["labels.csv", "frames.txt", "taxel_parts.txt", "map.json"] {
        assert_eq!(
            std::fs::read(whole.join(f)).unwrap(),
            std::fs::read(thin.join(f)).unwrap(),
            "{f}"
        );
    }
    let data = skin_learn::dataset::Dataset::read(&thin).unwrap();
    let changed = data
        .entries
        .iter()
        .filter(|e| grey(&thin.join("images").join(&e.file)) != grey(&whole.join("images").join(&e.file)))
        .count();
    assert!(changed >= 50, "{changed} of 60 images changed");
    // Refused: a share without a fraction, a fraction out of range.
    let o = args(&["--thinned-share", "0.5"]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("--remove-up-to"), "{err}");
    let o = args(&["--remove-up-to", "1"]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("--remove-up-to"), "{err}");
}

#[test]
fn synth_with_blind_spots_keeps_the_readings_and_darkens_some_images() {
    let tmp = tempfile::tempdir().unwrap();
    let (whole, blind) = (tmp.path().join("whole"), tmp.path().join("blind"));
    synth(&whole, "5");
    let args = |extra: &[&str]| synth_run(&blind, "5", extra);
    let o = args(&["--blind-spots", "4", "--blind-share", "1"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    assert!(
        out.contains("60 imaged through maps with 1 to 4 blind spots of up to 40 mm"),
        "{out}"
    );
    for f in ["labels.csv", "frames.txt", "taxel_parts.txt", "map.json"] {
        assert_eq!(
            std::fs::read(whole.join(f)).unwrap(),
            std::fs::read(blind.join(f)).unwrap(),
            "{f}"
        );
    }
    // A dead taxel only takes light away: no pixel brighter than in the whole map's image
    // except through contact-max normalisation, so compare lit pixel counts.
    let data = skin_learn::dataset::Dataset::read(&blind).unwrap();
    let (mut changed, mut darker) = (0, 0);
    for e in &data.entries {
        let (b, w) = (
            grey(&blind.join("images").join(&e.file)),
            grey(&whole.join("images").join(&e.file)),
        );
        if b != w {
            changed += 1;
            let lit = |g: &[u8]| g.iter().filter(|&&v| v > 0).count();
            darker += usize::from(lit(&b) <= lit(&w));
        }
    }
    assert!(changed >= 10, "{changed} of 60 images changed");
    assert!(
        darker * 10 >= changed * 9,
        "{darker} of {changed} changed images lit no more pixels"
    );
    // Refused: a share without spots, a radius outside (0, 1000] mm, shares adding up to more
    // than 1, spots out of range.
    let o = args(&["--blind-share", "0.5"]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("--blind-spots"), "{err}");
    for radius in ["0", "1000.1", "nan"] {
        let o = args(&["--blind-spots", "2", "--blind-radius-mm", radius]);
        let (_, err) = text(&o);
        assert!(
            !o.status.success() && err.contains("--blind-radius-mm"),
            "{radius}: {err}"
        );
    }
    let o = args(&["--blind-spots", "2", "--remove-up-to", "0.5"]);
    assert!(o.status.success(), "the default shares, 0.5 and 0.3, go together");
    let o = args(&[
        "--blind-spots",
        "2",
        "--blind-share",
        "0.6",
        "--remove-up-to",
        "0.5",
    ]);
    let (_, err) = text(&o);
    assert!(
        !o.status.success() && err.contains("--thinned-share") && err.contains("--blind-share"),
        "{err}"
    );
    let o = args(&["--blind-spots", "0"]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("--blind-spots"), "{err}");
}

#[test]
fn synth_labels_as_imaged_keep_the_images_and_redraw_some_masks() {
    let tmp = tempfile::tempdir().unwrap();
    let (pressing, as_imaged) = (tmp.path().join("pressing"), tmp.path().join("as_imaged"));
    synth(&pressing, "5");
    let o = synth_run(&as_imaged, "5", &["--mask-labels", "as-imaged"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    assert!(out.contains("as it shows on the image"), "{out}");
    for f in ["labels.csv", "frames.txt", "taxel_parts.txt"] {
        assert_eq!(
            std::fs::read(pressing.join(f)).unwrap(),
            std::fs::read(as_imaged.join(f)).unwrap(),
            "{f}"
        );
    }
    let data = skin_learn::dataset::Dataset::read(&as_imaged).unwrap();
    let (mut same_images, mut masks_differ) = (0, 0);
    for e in &data.entries {
        same_images += usize::from(
            grey(&pressing.join("images").join(&e.file)) == grey(&as_imaged.join("images").join(&e.file)),
        );
        // Masks are written for hands only.
        if e.hand {
            masks_differ += usize::from(
                grey(&pressing.join("masks").join(&e.file)) != grey(&as_imaged.join("masks").join(&e.file)),
            );
        }
    }
    assert_eq!(same_images, 60);
    let hands = data.entries.iter().filter(|e| e.hand).count();
    assert!(masks_differ >= 5, "{masks_differ} of {hands} hand masks differ");
    let o = synth_run(&as_imaged, "5", &["--mask-labels", "drawn"]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("as-imaged"), "{err}");
}

#[cfg(feature = "onnx")]
#[test]
fn eval_scores_the_matlab_handsnet_and_runs_test_a() {
    let model = root().join("../shared/data/cyskin/HandsNet_handles_finetuned.onnx");
    if !model.exists() {
        eprintln!(
            "skipped: {} is absent (../shared/data not beside the project)",
            model.display()
        );
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("d");
    synth(&data, "9");
    let m = model.to_str().unwrap();
    let d = data.to_str().unwrap();
    let o = skin(&["eval", "--model", m, "--dataset", d, "--test-fraction", "0"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    assert!(out.contains("60 test images"), "{out}");
    assert!(
        out.contains("accuracy ") && out.contains("by interaction / contact:"),
        "{out}"
    );
    // All subjects as the test set, for a dataset the model saw none of: 1 says it too.
    let o = skin(&["eval", "--model", m, "--dataset", d, "--test-fraction", "1"]);
    let (all, err) = text(&o);
    assert!(o.status.success(), "{all}{err}");
    assert!(all.contains("60 test images"), "{all}");
    // The default holds out the last 30% of the subjects.
    let o = skin(&["eval", "--model", m, "--dataset", d]);
    let (held_out, err) = text(&o);
    assert!(o.status.success(), "{held_out}{err}");
    assert!(!held_out.contains("60 test images"), "{held_out}");
    let o = skin(&[
        "eval",
        "--model",
        m,
        "--dataset",
        d,
        "--test-a",
        "--patterns",
        "1",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    let rows = out.lines().filter(|l| l.trim_end().ends_with('%')).count();
    assert_eq!(rows, 16, "Test A has 4 x 4 cells:\n{out}");
    // A segmenter's wrong model: HandsNet has no per-pixel output.
    let o = skin(&[
        "segment",
        "--model",
        m,
        &root().join("fixtures/forearm/layout.json").display().to_string(),
    ]);
    let (_, err) = text(&o);
    assert!(!o.status.success());
    assert!(err.contains("per-pixel class scores"), "{err}");
}

/// The number that follows `key` in `line`.
#[cfg(feature = "onnx")]
fn number_after(line: &str, key: &str) -> f64 {
    line.split(key)
        .nth(1)
        .unwrap_or_else(|| panic!("no '{key}' in: {line}"))
        .trim_start()
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no number after '{key}' in: {line}"))
}

#[cfg(feature = "onnx")]
#[test]
fn eval_scores_a_segmenter_by_case_and_over_mirrors() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("d");
    synth(&data, "9");
    let hands = skin_learn::dataset::Dataset::read(&data)
        .unwrap()
        .entries
        .iter()
        .filter(|e| e.hand)
        .count();
    let model = root().join("fixtures/models/handseg.onnx");
    let (m, d) = (model.to_str().unwrap(), data.to_str().unwrap());
    let eval = |extra: &[&str]| {
        let mut a = vec!["eval", "--model", m, "--dataset", d, "--test-fraction", "1"];
        a.extend_from_slice(extra);
        let o = skin(&a);
        let (out, err) = text(&o);
        assert!(o.status.success(), "{out}{err}");
        out
    };
    let plain = eval(&[]);
    eval_case_rows(&plain, hands);
    let plain_acc = eval_side_known(&plain, hands);
    eval_part_naming(&plain, plain_acc);
    eval_error_bins(&plain);
    eval_per_taxel(&plain);
    let mirrors = eval(&["--mirrors"]);
    // Acc, mAcc, mIoU, fwIoU (the time is left out: it differs anyway).
    let scores = |out: &str| -> Vec<String> {
        let line = out.lines().nth(2).unwrap_or_default();
        line.split_whitespace().take(4).map(str::to_owned).collect()
    };
    assert_eq!(scores(&plain).len(), 4, "{plain}");
    assert_ne!(
        scores(&plain),
        scores(&mirrors),
        "--mirrors changed nothing:\n{mirrors}"
    );
    // A dataset of images and masks only is scored per pixel, and says why not per taxel.
    std::fs::remove_file(data.join("taxel_parts.txt")).unwrap();
    let without = eval(&[]);
    assert!(
        without.contains("per taxel: not scored") && scores(&without) == scores(&plain),
        "{without}"
    );
    segment_colours_hand_pixels(tmp.path(), &data, m);
    // A classifier has no pixels to mirror.
    let classifier = root().join("fixtures/models/handsnet.onnx");
    let o = skin(&[
        "eval",
        "--model",
        classifier.to_str().unwrap(),
        "--dataset",
        d,
        "--mirrors",
    ]);
    let (_, err) = text(&o);
    assert!(!o.status.success());
    assert!(err.contains("--mirrors is for a segmenter"), "{err}");
}

/// The segmenter's rows by case: every hand image is in one of the view cases.
#[cfg(feature = "onnx")]
fn eval_case_rows(plain: &str, hands: usize) {
    // Each case row: its name, then images, Acc and mIoU.
    let images = |out: &str, case: &str| -> usize {
        let line = out
            .lines()
            .find(|l| l.trim_start().starts_with(case))
            .unwrap_or_else(|| panic!("no '{case}' row:\n{out}"));
        line[line.find(case).unwrap() + case.len()..]
            .split_whitespace()
            .next()
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{line}"))
    };
    assert_eq!(
        images(plain, "thumb or palm in view") + images(plain, "fingers only in view"),
        hands,
        "{plain}"
    );
    assert_eq!(images(plain, "pixels off part borders"), hands, "{plain}");
    assert!(images(plain, "whole hand on the skin") <= hands);
    assert!(images(plain, "all six parts in view") <= images(plain, "thumb or palm in view"));
}

/// The scores as if each hand's side were known: no fewer pixels right than against the masks
/// alone. Returns the plain pixel accuracy, %.
#[cfg(feature = "onnx")]
fn eval_side_known(plain: &str, hands: usize) -> f64 {
    // As if each hand's side were known: each image scored against the better fitting of its
    // mask and the mirror hand's, so no fewer pixels are right than against the masks alone.
    let side = plain
        .lines()
        .find(|l| l.starts_with("as if each hand's side were known"))
        .unwrap_or_else(|| panic!("no side-known line:\n{plain}"));
    let of = side.split(" images)").next().unwrap_or_default();
    let of: Vec<usize> = of
        .rsplit(", ")
        .next()
        .unwrap_or_default()
        .split(" of ")
        .map(|n| n.parse().unwrap())
        .collect();
    assert!(of[0] <= hands && of[1] == hands, "{side}");
    let side_acc: f64 = side
        .split("Acc ")
        .nth(1)
        .unwrap()
        .split('%')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    let plain_acc: f64 = plain
        .lines()
        .nth(2)
        .unwrap()
        .split('%')
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert!(side_acc >= plain_acc, "{side}\n{plain}");
    plain_acc
}

#[cfg(feature = "onnx")]
fn eval_part_naming(plain: &str, plain_acc: f64) {
    // Part regions named wrong: no more than there are regions, their share of the errors and
    // the rest's add up, and correcting their names loses no pixel.
    let naming = plain
        .lines()
        .find(|l| l.starts_with("part regions"))
        .unwrap_or_else(|| panic!("no part-regions line:\n{plain}"));
    let in_naming = |key: &str| number_after(naming, key);
    // "... part): M of N named as another part ..."
    let counts: Vec<f64> = naming
        .split("part):")
        .nth(1)
        .unwrap_or_default()
        .split_whitespace()
        .take(3)
        .filter_map(|w| w.parse().ok())
        .collect();
    let [misnamed, regions] = counts[..] else {
        panic!("{naming}")
    };
    assert!(regions >= 1.0 && misnamed <= regions, "{naming}");
    let (in_misnamed, elsewhere) = (in_naming("they hold"), in_naming("the other"));
    assert!((in_misnamed + elsewhere - 100.0).abs() < 0.02, "{naming}");
    assert!(in_naming("named right: Acc") >= plain_acc, "{naming}\n{plain}");
}

#[cfg(feature = "onnx")]
fn eval_error_bins(plain: &str) {
    // Where the errors lie: every wrong pixel is in one distance bin.
    let row = |name: &str| -> Vec<f64> {
        let line = plain
            .lines()
            .find(|l| l.trim_start().starts_with(name))
            .unwrap_or_else(|| panic!("no '{name}' row:\n{plain}"));
        line.trim_start()[name.len()..]
            .split_whitespace()
            .map(|v| v.trim_end_matches('%').parse().unwrap())
            .collect()
    };
    let (pixels, right, share) = (
        row("pixels  "),
        row("predicted right"),
        row("share of the errors"),
    );
    assert!(
        pixels.len() == 6 && right.len() == 6 && share.len() == 6,
        "{plain}"
    );
    let wrong: f64 = pixels
        .iter()
        .zip(&right)
        .map(|(n, r)| n * (1.0 - r / 100.0))
        .sum();
    assert!(
        wrong > 0.0 && (share.iter().sum::<f64>() - 100.0).abs() < 0.1,
        "{plain}"
    );
}

#[cfg(feature = "onnx")]
fn eval_per_taxel(plain: &str) {
    // Per taxel: the segmentation read at each pressed taxel, against taxel_parts.txt; the
    // true masks read the same way give (almost) every taxel its own part.
    let per_taxel = plain
        .lines()
        .find(|l| l.starts_with("per taxel ("))
        .unwrap_or_else(|| panic!("no per-taxel line:\n{plain}"));
    let after = |key: &str| number_after(per_taxel, key);
    assert!(after("per taxel (") > 0.0, "{per_taxel}");
    assert!(after("the same way: Acc") >= 98.0, "{per_taxel}");
    assert!((0.0..=100.0).contains(&after("does): Acc")), "{per_taxel}");
}

#[cfg(feature = "onnx")]
fn segment_colours_hand_pixels(tmp: &Path, data: &Path, m: &str) {
    // skin segment: a coloured part image per input, black where nothing pressed.
    let entries = skin_learn::dataset::Dataset::read(data).unwrap().entries;
    let hand = entries.iter().find(|e| e.hand).unwrap();
    let input = data.join("images").join(&hand.file);
    let out = tmp.join("parts");
    for extra in [&[][..], &["--mirrors"][..]] {
        let mut a = vec![
            "segment",
            "--model",
            m,
            input.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ];
        a.extend_from_slice(extra);
        let o = skin(&a);
        let (said, err) = text(&o);
        assert!(o.status.success(), "{said}{err}");
        let stem = hand.file.trim_end_matches(".png");
        let parts = image::open(out.join(format!("{stem}_parts.png")))
            .unwrap()
            .into_rgb8();
        assert_eq!(parts.dimensions(), (100, 68));
        // The hand's pixels in the true mask get a part: the model calls almost none of them
        // background (faint noise elsewhere in the image may stay black).
        let truth = grey(&data.join("masks").join(&hand.file));
        let (mut hand_px, mut coloured) = (0, 0);
        for ((px, &g), &t) in parts.pixels().zip(&grey(&input)).zip(&truth) {
            assert!(
                g > 0 || px.0 == [0, 0, 0],
                "{extra:?}: a part where nothing pressed"
            );
            hand_px += usize::from(t > 0);
            coloured += usize::from(t > 0 && px.0 != [0, 0, 0]);
        }
        assert!(
            coloured * 10 >= hand_px * 9,
            "{extra:?}: {coloured} of {hand_px} hand pixels coloured"
        );
    }
}

#[test]
fn a_broken_labels_file_names_its_line() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("d");
    synth(&data, "1");
    let csv = data.join("labels.csv");
    let mut text_csv = std::fs::read_to_string(&csv).unwrap();
    text_csv = text_csv.replacen(",hand,", ",hnad,", 1);
    std::fs::write(&csv, text_csv).unwrap();
    let err = skin_learn::dataset::Dataset::read(&data).unwrap_err().to_string();
    assert!(err.contains("labels.csv:") && err.contains("hnad"), "{err}");
}

#[test]
fn run_takes_raw_recordings_with_a_config_of_the_layout_alone() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("run.toml");
    std::fs::write(
        &config,
        format!("layout = {:?}\n[baseline]\nframes = 5\n", fixture("layout.json")),
    )
    .unwrap();
    let out = dir.path().join("out");
    let rec = fixture("touches.txt");
    let o = skin(&[
        "run",
        config.to_str().unwrap(),
        "--recording",
        &rec,
        "-o",
        out.to_str().unwrap(),
        "-q",
    ]);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{err}");
    // The four touches of touches.tsv, each released once.
    let tsv = std::fs::read_to_string(out.join("recordings.tsv")).unwrap();
    let row: Vec<&str> = tsv.lines().nth(1).unwrap().split('\t').collect();
    assert_eq!(row[..3], ["touches", "130", "4"], "{tsv}");
    let events = std::fs::read_to_string(out.join("touches/events.jsonl")).unwrap();
    assert_eq!(events.matches("\"event\":\"released\"").count(), 4, "{events}");
    assert!(
        out.join("touches/summary.txt").exists() && stdout.contains("touches "),
        "{stdout}"
    );
    // One input at a time: a log and recordings together are refused.
    let o = skin(&[
        "run",
        config.to_str().unwrap(),
        "--recording",
        &rec,
        "--log",
        &rec,
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o).1);
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
