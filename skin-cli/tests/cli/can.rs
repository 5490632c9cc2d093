//! The CAN commands: `skin replay`, `skin record` and `skin live`, `skin busmap`.

use super::*;

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
