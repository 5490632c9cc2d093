//! `skin run` end to end on the fixture session: every scripted touch found and classified, the
//! outputs written whole, and one clear line (and nothing written) for each kind of bad input.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use std::path::Path;

skin_test_support::skin_binary!(); // skin(args) runs this package's binary; root()

fn log() -> String {
    root()
        .join("fixtures/session/session.candump.log")
        .display()
        .to_string()
}

/// A configuration in `dir` naming the fixtures by absolute path, with `extra` lines appended
/// and the `replace` (key, line) pairs swapped in.
fn config(dir: &Path, replace: &[(&str, &str)], extra: &str) -> String {
    let r = root();
    let mut lines = vec![
        format!("layout = {:?}", r.join("fixtures/forearm/layout.json")),
        format!("busmap = {:?}", r.join("fixtures/forearm/busmap.toml")),
        format!("classifier = {:?}", r.join("fixtures/models/handsnet.onnx")),
        format!("segmenter = {:?}", r.join("fixtures/models/handseg.onnx")),
        format!("truth = {:?}", r.join("fixtures/session/session.tsv")),
        "cache = \"cache\"".to_string(),
    ];
    for (key, line) in replace {
        lines.retain(|l| !l.starts_with(&format!("{key} =")));
        lines.insert(0, line.to_string());
    }
    let text = format!(
        "{}\n{extra}\n[gate]\nhand = \"comply\"\nnon_hand = \"stop\"\n",
        lines.join("\n")
    );
    let path = dir.join("run.toml");
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

/// Runs `skin run CONFIG --log LOG -o OUT -q EXTRA...`, which must succeed; its stdout.
fn run_ok(cfg: &str, log: &str, out: &Path, extra: &[&str]) -> String {
    let mut args = vec!["run", cfg, "--log", log, "-o", out.to_str().unwrap(), "-q"];
    args.extend_from_slice(extra);
    let o = skin(&args);
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    stdout
}

/// Every event `skin run` wrote to `out/events.jsonl`, in order.
fn events(out: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(out.join("events.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// The events of one kind (`"event": kind`).
fn events_of(out: &Path, kind: &str) -> Vec<serde_json::Value> {
    events(out).into_iter().filter(|e| e["event"] == kind).collect()
}

/// (found, right, scripted) from the summary's script line.
fn score(stdout: &str) -> (usize, usize, usize) {
    let line = stdout
        .lines()
        .find(|l| l.starts_with("script: "))
        .unwrap_or_else(|| panic!("no script line in\n{stdout}"));
    let n: Vec<usize> = line
        .split(|c: char| !c.is_ascii_digit())
        .filter(|s| !s.is_empty())
        .filter_map(|s| s.parse().ok())
        .collect();
    (n[0], n[2], n[1])
}

#[test]
fn the_fixture_session_finds_every_scripted_touch_and_classifies_them() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), &[], "");
    let out = dir.path().join("out");
    let stdout = run_ok(&cfg, &log(), &out, &["--timings"]);
    let (found, right, scripted) = score(&stdout);
    assert_eq!(scripted, 20);
    assert_eq!(found, 20, "{stdout}");
    assert!(
        right * 100 >= 95 * scripted,
        "{right} of {scripted} right:\n{stdout}"
    );
    assert!(stdout.contains("0 touch(es) not in the script"), "{stdout}");
    assert!(stdout.contains("x real time"), "--timings: {stdout}");

    // The events: one appeared, one released per touch, classified in between, gate actions.
    let parsed = events(&out);
    let count = |kind: &str| parsed.iter().filter(|e| e["event"] == kind).count();
    assert_eq!(count("appeared"), 20);
    assert_eq!(count("released"), 20);
    assert!(count("classified") >= 20);
    assert!(count("gate") >= 2);
    assert_eq!(count("incomplete"), 0, "the fixture log has no lost frames");
    let hand = parsed
        .iter()
        .find(|e| e["event"] == "classified" && e["class"] == "hand")
        .unwrap();
    assert!(
        hand["parts"].as_array().is_some_and(|p| !p.is_empty()),
        "hands get their parts: {hand}"
    );
    // Touches are scripted one at a time: released before the next appears.
    let mut open = 0i32;
    for e in &parsed {
        open += match e["event"].as_str() {
            Some("appeared") => 1,
            Some("released") => -1,
            _ => 0,
        };
        assert!((0..=1).contains(&open));
    }
    // The images the decisions were made on, and the summary.
    let pngs = std::fs::read_dir(out.join("touches")).unwrap().count();
    assert!(pngs >= 20, "{pngs} decision images");
    assert!(
        std::fs::read_to_string(out.join("summary.txt"))
            .unwrap()
            .contains("script: ")
    );
    // The map was cached on first use.
    let cached = std::fs::read_dir(dir.path().join("cache")).unwrap().count();
    assert_eq!(cached, 1);
}

#[test]
fn frames_option_writes_an_image_per_touched_frame() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(
        dir.path(),
        &[("segmenter", "# no segmenter"), ("classifier", "# no classifier")],
        "",
    );
    let out = dir.path().join("out");
    let stdout = run_ok(&cfg, &log(), &out, &["--frames"]);
    // Without a classifier the touches are still found, with no class.
    let (found, right, _) = score(&stdout);
    assert_eq!((found, right), (20, 0), "{stdout}");
    let frames = std::fs::read_dir(out.join("frames/forearm")).unwrap().count();
    // 20 touches of 1 s at 20 Hz, minus the frames of the ramps below the threshold.
    assert!((300..=420).contains(&frames), "{frames} frame images");
}

/// Runs a bad configuration: one line on stderr containing `expect`, exit 1, no output folder.
fn refused(cfg: &str, log: &str, expect: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = skin(&["run", cfg, "--log", log, "-o", out.to_str().unwrap(), "-q"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "one line: {stderr}");
    for e in expect {
        assert!(stderr.contains(e), "{e:?} not in {stderr}");
    }
    assert!(!out.exists(), "nothing written");
    let leftovers: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert!(leftovers.is_empty(), "nothing half-written: {leftovers:?}");
}

#[test]
fn a_config_naming_a_missing_file_is_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), &[("classifier", "classifier = \"nowhere.onnx\"")], "");
    refused(&cfg, &log(), &["classifier = \"nowhere.onnx\"", "no such file"]);
    let cfg = config(dir.path(), &[], "colour = \"blue\"");
    refused(&cfg, &log(), &["run.toml", "colour"]);
}

#[test]
fn a_log_of_another_bus_map_is_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), &[], "");
    let icub = root().join("fixtures/forearm/touches.icub8.log");
    refused(&cfg, icub.to_str().unwrap(), &["touches.icub8.log", "bus map"]);
}

#[test]
fn a_model_for_another_image_size_is_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), &[], "image_size = \"64x96\"");
    refused(&cfg, &log(), &["handsnet.onnx", "68 x 100", "64 x 96"]);
}

#[test]
fn stitched_links_report_a_contact_across_the_joint_at_every_posture() {
    let dir = tempfile::tempdir().unwrap();
    let arm = root().join("fixtures/arm");
    let cfg = dir.path().join("arm.toml");
    std::fs::write(
        &cfg,
        format!(
            "layout = {:?}\nbusmap = {:?}\ncache = \"cache\"\n[baseline]\nframes = 8\n[touch]\nthreshold = 10.0\n[stitch]\nposes = {:?}\n",
            arm.join("layout.json"),
            arm.join("busmap.toml"),
            arm.join("poses.json")
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    let log = arm.join("touch.candump.log");
    let stdout = run_ok(cfg.to_str().unwrap(), log.to_str().unwrap(), &out, &["--frames"]);
    assert!(
        stdout.contains("contacts across joints (stitched maps): 3"),
        "{stdout}"
    );
    // The palm presses both links at once, at each of the three wrist rolls.
    assert!(stdout.contains("6 touch(es)"), "{stdout}");
    let across = events_of(&out, "across_joint");
    assert_eq!(across.len(), 3);
    for e in &across {
        assert_eq!(e["links"], serde_json::json!(["forearm", "wrist"]));
        // The palm's centre sits over the joint, 0.35 m along the forearm.
        let y = e["centroid"][1].as_f64().unwrap();
        assert!((y - 0.353).abs() < 0.01, "{e}");
    }
    assert!(std::fs::read_dir(out.join("frames/stitched")).unwrap().count() >= 50);

    // Poses naming other links than the layout's: one line.
    let bad = dir.path().join("poses.json");
    let poses = std::fs::read_to_string(arm.join("poses.json")).unwrap();
    std::fs::write(&bad, poses.replace("\"wrist\"", "\"hand\"")).unwrap();
    let text = std::fs::read_to_string(&cfg).unwrap();
    std::fs::write(
        &cfg,
        text.replace(arm.join("poses.json").to_str().unwrap(), bad.to_str().unwrap()),
    )
    .unwrap();
    let o = skin(&[
        "run",
        cfg.to_str().unwrap(),
        "--log",
        log.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "-q",
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr.contains("poses.json") && stderr.contains("hand"),
        "{stderr}"
    );
}

#[test]
fn frames_with_a_module_missing_are_reported_and_the_touches_still_found() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), &[], "");
    // Module 5 (CAN ids 0x214-0x216) goes silent from 5.0 s to 7.0 s of the session.
    let text = std::fs::read_to_string(log()).unwrap();
    let mut dropped = 0;
    let cut: String = text
        .lines()
        .filter(|l| {
            let t: f64 = l[1..18].parse().unwrap();
            let silent = (1_700_000_005.0..1_700_000_007.0).contains(&t)
                && [" can0 214#", " can0 215#", " can0 216#"]
                    .iter()
                    .any(|id| l.contains(id));
            dropped += usize::from(silent);
            !silent
        })
        .map(|l| format!("{l}\n"))
        .collect();
    assert_eq!(dropped, 3 * 40);
    let cut_log = dir.path().join("cut.log");
    std::fs::write(&cut_log, cut).unwrap();
    let out = dir.path().join("out");
    let stdout = run_ok(&cfg, cut_log.to_str().unwrap(), &out, &[]);
    assert!(stdout.contains("620 frames (40 incomplete)"), "{stdout}");
    let (found, _, _) = score(&stdout);
    assert_eq!(found, 20, "a lost module is not a release: {stdout}");
    let incomplete = events_of(&out, "incomplete");
    assert_eq!(incomplete.len(), 40);
    assert_eq!(
        incomplete[0]["missing"],
        serde_json::json!([{"bus": "can0", "address": 5}])
    );
}

#[test]
fn two_sessions_joined_keep_every_frame_and_report_the_counter_restart() {
    use skin_can::candump::{CanFrame, CandumpLog};
    let dir = tempfile::tempdir().unwrap();
    // No script: the second session repeats the first's touches.
    let cfg = config(dir.path(), &[("truth", "")], "");
    let one = CandumpLog::read(Path::new(&log())).unwrap();
    let first = one.frames.first().unwrap().time_us;
    let span = one.frames.last().unwrap().time_us - first + 50_000;
    let mut joined = one.clone();
    joined.frames.extend(one.frames.iter().map(|f| CanFrame {
        time_us: f.time_us + span,
        ..*f
    }));
    let path = dir.path().join("joined.log");
    joined.write(&path).unwrap();
    let out = dir.path().join("out");
    let stdout = run_ok(&cfg, path.to_str().unwrap(), &out, &[]);
    assert!(stdout.contains("1240 frames (0 incomplete)"), "{stdout}");
    assert!(stdout.contains("sync counter restarted 1 time(s)"), "{stdout}");
    let resets = events_of(&out, "counter_reset");
    assert_eq!(resets.len(), 1, "{resets:?}");
    assert_eq!(resets[0]["bus"], "can0");
    assert_eq!(
        events_of(&out, "appeared").len(),
        40,
        "the second session's touches are found"
    );
}

/// A configuration of the forearm's layout alone (a copy in `dir`, so that a test can change
/// it), for raw recordings; its cache in `dir/cache`.
fn recording_config(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let layout = dir.join("layout.json");
    std::fs::copy(root().join("fixtures/forearm/layout.json"), &layout).unwrap();
    let config = dir.join("rec.toml");
    std::fs::write(
        &config,
        "layout = \"layout.json\"\ncache = \"cache\"\n[baseline]\nframes = 5\n",
    )
    .unwrap();
    (config, layout)
}

#[test]
fn a_batch_reads_its_layout_once_and_each_recording_as_if_alone() {
    let dir = tempfile::tempdir().unwrap();
    let (config, layout) = recording_config(dir.path());
    let fixture = root().join("fixtures/forearm/touches.txt");
    let recs: Vec<String> = (0..24)
        .map(|k| {
            let p = dir.path().join(format!("rec{k:02}.txt"));
            std::fs::copy(&fixture, &p).unwrap();
            p.display().to_string()
        })
        .collect();
    // One recording alone: what every recording of the batch must give.
    let alone = dir.path().join("alone");
    let o = skin(&[
        "run",
        config.to_str().unwrap(),
        "--recording",
        &recs[0],
        "-o",
        alone.to_str().unwrap(),
        "-q",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let want = std::fs::read(alone.join("rec00/events.jsonl")).unwrap();
    // The batch: once its first recording is under way, the layout file is replaced by one
    // that does not read. A batch that reads it again fails there.
    let out = dir.path().join("out");
    let mut args = vec!["run", config.to_str().unwrap(), "-o", out.to_str().unwrap(), "-q"];
    args.push("--recording");
    args.extend(recs.iter().map(String::as_str));
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(&args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let started = out.join(".skin-partial/rec00");
    let t0 = std::time::Instant::now();
    while !started.exists() && t0.elapsed() < std::time::Duration::from_secs(120) {
        std::thread::sleep(std::time::Duration::from_millis(1));
    }
    std::fs::write(&layout, "{ not a layout").unwrap();
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for k in 0..recs.len() {
        let got = std::fs::read(out.join(format!("rec{k:02}/events.jsonl"))).unwrap();
        assert!(got == want, "recording {k} differs from the recording run alone");
    }
}

#[test]
fn a_batch_names_every_input_it_cannot_read_before_any_runs() {
    let dir = tempfile::tempdir().unwrap();
    let (rec_config, _) = recording_config(dir.path());
    let recs: Vec<String> = ["a.txt", "b.txt"]
        .iter()
        .map(|n| {
            let p = dir.path().join(n);
            std::fs::copy(root().join("fixtures/forearm/touches.txt"), &p).unwrap();
            p.display().to_string()
        })
        .collect();
    let folder = dir.path().join("recordings");
    std::fs::create_dir(&folder).unwrap();
    let missing = dir.path().join("missing.txt").display().to_string();
    let out = dir.path().join("out");
    let o = skin(&[
        "run",
        rec_config.to_str().unwrap(),
        "--recording",
        &recs[0],
        &missing,
        folder.to_str().unwrap(),
        &recs[1],
        "-o",
        out.to_str().unwrap(),
    ]);
    let (stdout, err) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("2 of the 4 inputs")
            && err.contains("missing.txt (no such file)")
            && err.contains("recordings (a folder, not a file)"),
        "{err}"
    );
    assert!(stdout.is_empty(), "a recording ran first: {stdout}");
    assert!(!out.exists() && !dir.path().join("cache").exists());
    // A log alone, missing: one line naming it.
    let cfg = config(dir.path(), &[], "");
    let o = skin(&["run", &cfg, "--log", &missing, "-o", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("missing.txt (no such file)"),
        "{err}"
    );
}

#[test]
fn a_layout_that_is_a_folder_is_named_as_one() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("forearm")).unwrap();
    let cfg = config(dir.path(), &[("layout", "layout = \"forearm\"")], "");
    refused(&cfg, &log(), &["layout = \"forearm\"", "this is a folder"]);
}

#[test]
fn a_map_cache_that_cannot_be_written_costs_time_not_the_run() {
    let dir = tempfile::tempdir().unwrap();
    // A file where the cache folder should be: no one can write there, not even root.
    std::fs::write(dir.path().join("blocked"), "a file").unwrap();
    let cfg = config(dir.path(), &[("cache", "cache = \"blocked/maps\"")], "");
    let out = dir.path().join("out");
    let o = skin(&["run", &cfg, "--log", &log(), "-o", out.to_str().unwrap(), "-q"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let warnings: Vec<&str> = err.lines().filter(|l| l.contains("blocked/maps")).collect();
    assert_eq!(warnings.len(), 1, "{err}");
    assert!(warnings[0].starts_with("warning: cannot keep tactile maps") && warnings[0].contains("cache ="));
    assert!(out.join("summary.txt").is_file());
}

#[test]
fn a_map_cache_inside_the_output_folder_is_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), &[("cache", "cache = \"out/cache\"")], "");
    let out = dir.path().join("out");
    let o = skin(&["run", &cfg, "--log", &log(), "-o", out.to_str().unwrap(), "-q"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("the map cache") && err.contains("inside the output folder") && err.contains("cache ="),
        "{err}"
    );
    assert!(!out.exists(), "nothing made");
}
