//! `skin run` of raw recordings with a configuration of the layout alone.

use super::*;

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
