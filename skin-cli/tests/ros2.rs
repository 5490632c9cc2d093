//! ROS 2 without ROS, end to end: `skin run --mcap` and `skin convert --mcap` read by the
//! Python `mcap` + `mcap-ros2-support` readers and rosbags (`tests/ros2/mcap_check.py`), `skin
//! run --zenoh` (and `--zenoh-listen`) seen by an `eclipse-zenoh` peer on loopback
//! (`tests/ros2/zenoh_peer.py`), and the data-safety and bad-input rules of both outputs. The Python checks skip (saying so) where no
//! Python has the packages; `.ci/run` installs them in its venv and sets SKIN_PYTHON.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use std::ffi::OsStr;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

skin_test_support::skin_binary!(); // skin(args) runs this package's binary; root()

use skin_test_support::cli::{free_port, names};
use skin_test_support::shared_data;

skin_test_support::python_checks!(); // mod python: python_with, run

const PACKAGES: &str = "mcap, mcap_ros2, rosbags, numpy";

fn config() -> String {
    root().join("fixtures/session/run.toml").display().to_string()
}

fn log() -> String {
    root()
        .join("fixtures/session/session.candump.log")
        .display()
        .to_string()
}

/// `skin run` on the fixture session into `out`, quietly, with `extra` arguments.
fn run_session(out: &str, extra: &[&str]) -> std::process::Output {
    let (config, log) = (config(), log());
    let mut args = vec!["run", &config, "--log", &log, "-o", out, "-q"];
    args.extend_from_slice(extra);
    skin(&args)
}

fn ok(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "skin failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Frames after the baseline in the fixture session (620 frames, 20 learn the baseline).
const FRAMES: usize = 600;

/// `skin convert INPUT --config CONFIG --mcap MCAP`.
fn convert(input: &str, config: &str, mcap: &str) -> std::process::Output {
    skin(&["convert", input, "--config", config, "--mcap", mcap])
}

/// `ros2/mcap_check.py` on `mcap` (fails the test on any problem): `events` is the run's
/// events.jsonl, `None` for `skin convert`; `frames` after the baseline, one cloud of `link` each.
fn mcap_check(py: &PathBuf, mcap: &Path, events: Option<&Path>, frames: usize, link: &str) -> String {
    let events = events.map_or(OsStr::new("-"), Path::as_os_str);
    let frames = frames.to_string();
    let said = python::run(
        py,
        "ros2/mcap_check.py",
        &[mcap.as_os_str(), events, OsStr::new(&frames), OsStr::new(link)],
    );
    eprintln!("{}: {said}", mcap.display());
    said
}

#[test]
fn mcap_of_the_fixture_session_reads_in_python() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let mcap = dir.path().join("session.mcap");
    let run = run_session(out.to_str().unwrap(), &["--mcap", mcap.to_str().unwrap()]);
    ok(&run);
    assert!(String::from_utf8_lossy(&run.stdout).contains("ROS 2 messages"));
    // Nothing but the two outputs: no partial file left beside them.
    assert_eq!(names(dir.path()), ["out", "session.mcap"]);
    let Some(py) = python::python_with(PACKAGES) else {
        return;
    };
    let said = mcap_check(&py, &mcap, Some(&out.join("events.jsonl")), FRAMES, "forearm");
    // The fixture's forearm is calibrated: every touch's force was checked in the file.
    assert!(said.contains("forces of 20 touches checked"), "{said}");
}

#[test]
fn service_hashes_are_rosidl_s_as_rosbags_computes_them() {
    // rmw_zenoh puts a service's hash in its key expression: a client whose hash differs never
    // reaches the service. rosbags (independent of skin) computes std_srvs/Trigger's published
    // hash by the same method, which pins every skin_msgs service's.
    let Some(py) = python::python_with("rosbags") else {
        return;
    };
    let said = python::run(&py, "ros2/service_hash.py", &[]);
    let all = skin_ros::interfaces::Interfaces::skin().unwrap();
    let lines: Vec<&str> = said.lines().collect();
    assert!(lines.len() >= 2, "{said}");
    for line in lines {
        let (name, hash) = line.split_once(' ').unwrap();
        assert_eq!(all.type_hash(name).as_deref(), Some(hash), "{name}");
    }
}

#[test]
fn convert_writes_frames_and_contacts_without_models() {
    let dir = tempfile::tempdir().unwrap();
    let mcap = dir.path().join("converted.mcap");
    ok(&convert(&log(), &config(), mcap.to_str().unwrap()));
    assert!(mcap.is_file());
    // Bad input: neither a log nor a recording, named with both reasons; nothing written.
    let junk = dir.path().join("junk.txt");
    std::fs::write(&junk, "not a recording\n").unwrap();
    let bad = convert(
        junk.to_str().unwrap(),
        &config(),
        dir.path().join("j.mcap").to_str().unwrap(),
    );
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("neither a candump log") && err.contains("junk.txt"),
        "{err}"
    );
    assert!(!dir.path().join("j.mcap").exists());
    let Some(py) = python::python_with(PACKAGES) else {
        return;
    };
    let _ = mcap_check(&py, &mcap, None, FRAMES, "forearm");
}

/// Real hardware recordings (Cyskin's curved patch, 0, 1 and 2 fingers; `../shared/data`) go
/// through `skin convert` and read back: one cloud of the patch's 642 taxels per frame after
/// the baseline, every message decoded.
#[test]
fn real_recordings_convert_to_ros2() {
    let (Some(patch), Some(recordings)) = (
        shared_data::shared("cyskin/curved_gesture_patch.json"),
        shared_data::shared("cyskin/recordings"),
    ) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("real.toml");
    std::fs::write(
        &config,
        format!(
            "layout = {:?}\n[baseline]\nframes = 5\n",
            patch.display().to_string()
        ),
    )
    .unwrap();
    let py = python::python_with(PACKAGES);
    for fingers in ["0_finger", "1_finger", "2_finger"] {
        let mut files: Vec<_> = std::fs::read_dir(recordings.join(fingers))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension() == Some(OsStr::new("txt")))
            .collect();
        files.sort();
        for file in files.iter().take(2) {
            let mcap = dir.path().join(format!("{fingers}.mcap"));
            let _ = std::fs::remove_file(&mcap);
            ok(&convert(
                file.to_str().unwrap(),
                config.to_str().unwrap(),
                mcap.to_str().unwrap(),
            ));
            // The ids line, then a frame a line; the first 5 frames are the baseline.
            let text = std::fs::read_to_string(file).unwrap();
            let frames = text.lines().filter(|l| !l.trim().is_empty()).count() - 1 - 5;
            if let Some(py) = &py {
                eprint!("{}: ", file.display());
                let _ = mcap_check(py, &mcap, None, frames, "UR10_link1_patch3");
            }
        }
    }
}

#[test]
fn mcap_output_follows_the_data_safety_rules() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n).display().to_string();
    // A user's other file at the path: refused, kept as it was, nothing else written.
    std::fs::write(dir.path().join("notes.mcap"), "my notes").unwrap();
    let r = run_session(&d("out"), &["--mcap", &d("notes.mcap")]);
    assert!(!r.status.success());
    assert!(String::from_utf8_lossy(&r.stderr).contains("notes.mcap"));
    assert_eq!(
        std::fs::read_to_string(dir.path().join("notes.mcap")).unwrap(),
        "my notes"
    );
    assert_eq!(names(dir.path()), ["notes.mcap"]);
    // The input as the output: refused.
    let copy = d("session.candump.log");
    std::fs::copy(log(), &copy).unwrap();
    let r = convert(&copy, &config(), &copy);
    assert!(!r.status.success());
    assert!(String::from_utf8_lossy(&r.stderr).contains("session.candump.log"));
    assert_eq!(std::fs::read(&copy).unwrap(), std::fs::read(log()).unwrap());
    // Inside the output folder: refused before any work.
    let r = run_session(&d("out"), &["--mcap", &d("out/s.mcap")]);
    assert!(!r.status.success());
    assert!(String::from_utf8_lossy(&r.stderr).contains("inside the output folder"));
    assert!(!dir.path().join("out").exists());
    // An earlier MCAP is replaced (running again works).
    for _ in 0..2 {
        ok(&convert(&log(), &config(), &d("again.mcap")));
    }
    let bytes = std::fs::read(dir.path().join("again.mcap")).unwrap();
    assert!(bytes.starts_with(b"\x89MCAP0\r\n") && bytes.ends_with(b"\x89MCAP0\r\n"));
}

#[test]
fn bad_endpoints_and_prefixes_are_one_clear_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out").display().to_string();
    for (flag, value, says) in [
        ("--zenoh", "127.0.0.1:7447", "only tcp/HOST:PORT"),
        ("--zenoh", "tcp/127.0.0.1:port", "port"),
        ("--ros-prefix", "skin", "must start with '/'"),
    ] {
        let r = run_session(&out, &[flag, value]);
        assert!(!r.status.success(), "{flag} {value}");
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(
            err.contains(says) && err.contains(value) && err.lines().count() == 1,
            "{err}"
        );
        assert!(!dir.path().join("out").exists());
    }
    // A port another program holds, and an address that is not this machine's.
    let held = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let in_use = format!("tcp/{}", held.local_addr().unwrap());
    for endpoint in [in_use.as_str(), "tcp/192.0.2.1:7447"] {
        let r = run_session(&out, &["--zenoh-listen", endpoint]);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(
            !r.status.success()
                && err.contains(endpoint)
                && err.contains("cannot listen there")
                && err.lines().count() == 1,
            "{err}"
        );
    }
    drop(held);
    // A wait with nothing to wait for, and a wait that is not a duration.
    let r = run_session(&out, &["--zenoh-wait", "5"]);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        !r.status.success() && err.contains("--zenoh-wait needs --zenoh") && err.lines().count() == 1,
        "{err}"
    );
    for bad in ["soon", "-1", "inf", "NaN"] {
        let wait = format!("--zenoh-wait={bad}");
        let r = run_session(&out, &["--zenoh-listen", "tcp/127.0.0.1:7448", &wait]);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(
            !r.status.success() && err.contains("not a number of seconds from 0 to 3600"),
            "{err}"
        );
    }
    assert!(!dir.path().join("out").exists());
}

#[test]
fn unreachable_endpoint_does_not_stop_the_frames() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let r = run_session(out.to_str().unwrap(), &["--zenoh", &endpoint]);
    ok(&r);
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(err.contains(&format!("nothing answers at {endpoint}")), "{err}");
    assert!(String::from_utf8_lossy(&r.stdout).contains("20 of 20 scripted touches found"));
}

#[test]
fn a_zenoh_peer_sees_the_session_as_rmw_zenoh_would() {
    peer_sees_the_session(Side::PeerListens);
}

#[test]
fn a_zenoh_peer_that_connects_to_a_listening_run_sees_it_all() {
    peer_sees_the_session(Side::RunListens);
}

/// Who listens on the loopback port: the Python peer (`skin run --zenoh`, as to a router) or
/// the run (`skin run --zenoh-listen --zenoh-wait`, a peer connecting to it).
#[derive(Clone, Copy, PartialEq)]
enum Side {
    PeerListens,
    RunListens,
}

fn peer_sees_the_session(side: Side) {
    let Some(py) = python::python_with("zenoh, rosbags, numpy") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let port = free_port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let script = root().join("skin-cli/tests/ros2/zenoh_peer.py");
    let start_peer = || {
        Command::new(&py)
            .arg(&script)
            .arg(if side == Side::PeerListens {
                "listen"
            } else {
                "connect"
            })
            .arg(port.to_string())
            .arg(out.join("events.jsonl"))
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (mut peer, r) = match side {
        Side::PeerListens => {
            let mut peer = start_peer();
            wait_ready(&mut peer);
            let r = run_session(out.to_str().unwrap(), &["--zenoh", &endpoint]);
            (peer, r)
        }
        Side::RunListens => {
            // The run listens and waits (bounded) for a subscriber before its first frame.
            let run = Command::new(env!("CARGO_BIN_EXE_skin"))
                .args([
                    "run",
                    &config(),
                    "--log",
                    &log(),
                    "-o",
                    out.to_str().unwrap(),
                    "-q",
                ])
                .args(["--zenoh-listen", &endpoint, "--zenoh-wait", "60"])
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap();
            let mut peer = start_peer();
            wait_ready(&mut peer);
            (peer, run.wait_with_output().unwrap())
        }
    };
    let _ = peer.stdin.as_mut().unwrap().write_all(b"done\n");
    ok(&r);
    let said: Vec<String> = BufReader::new(peer.stdout.take().unwrap())
        .lines()
        .map_while(Result::ok)
        .collect();
    let status = peer.wait().unwrap();
    let mut err = String::new();
    let _ = std::io::Read::read_to_string(&mut peer.stderr.take().unwrap(), &mut err);
    eprintln!("{}\n{}", said.join("\n"), String::from_utf8_lossy(&r.stderr));
    assert!(
        status.success(),
        "the peer's checks failed:\n{}\n{err}",
        said.join("\n")
    );
}

/// Reads the peer's "ready" (subscribed), within its own 120 s alarm.
fn wait_ready(peer: &mut std::process::Child) {
    let mut first = String::new();
    let _ = BufReader::new(peer.stdout.as_mut().unwrap()).read_line(&mut first);
    assert_eq!(first.trim(), "ready", "the peer did not start");
}

/// The fixture log with every timestamp moved by `shift_us` and, `copies` times over, each
/// copy after the last (31 s of traffic each, then 1 s): a longer session, or one stamped in
/// another year. Written into `dir`.
fn shifted_log(dir: &Path, name: &str, copies: u64, shift_us: u64) -> PathBuf {
    let text = std::fs::read_to_string(log()).unwrap();
    let us = |line: &str| -> (u64, usize) {
        let end = line.find(')').unwrap();
        let (s, frac) = line[1..end].split_once('.').unwrap();
        (
            s.parse::<u64>().unwrap() * 1_000_000 + frac.parse::<u64>().unwrap(),
            end,
        )
    };
    let first = us(text.lines().next().unwrap()).0;
    let last = us(text.lines().last().unwrap()).0;
    let period = last - first + 1_000_000;
    let path = dir.join(name);
    let mut out = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    for k in 0..copies {
        for line in text.lines() {
            let (t, end) = us(line);
            let t = t + shift_us + k * period;
            writeln!(out, "({}.{:06}{}", t / 1_000_000, t % 1_000_000, &line[end..]).unwrap();
        }
    }
    out.flush().unwrap();
    path
}

/// One topic of an MCAP as `ros2/stamps.py` reads it.
#[derive(Debug)]
struct Headers {
    topic: String,
    first_ns: u64,
    last_ns: u64,
    /// Every header stamp equals its message's log time.
    equal: bool,
    frame_ids: Vec<String>,
}

/// `ros2/stamps.py` on an MCAP: its topics' headers.
fn stamps(py: &PathBuf, mcap: &Path) -> Vec<Headers> {
    python::run(py, "ros2/stamps.py", &[mcap.as_os_str()])
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.splitn(6, ' ').collect();
            Headers {
                topic: f[0].to_owned(),
                first_ns: f[1].parse().unwrap(),
                last_ns: f[2].parse().unwrap(),
                equal: f[4] == "1",
                frame_ids: serde_json::from_str(f[5]).unwrap(),
            }
        })
        .collect()
}

/// A log stamped after 2038 (where ROS 2 time, int32 seconds, ends) or near 1.8e10 s (where
/// nanoseconds pass u64) is refused with one line naming its date and the fix; with
/// `--ros-time rebase` it is stamped from 0 at the first frame, exactly. A log of today keeps
/// its clock. Stamps were clamped at 2038 (seconds frozen, nanoseconds moving) or wrapped.
#[test]
fn stamps_past_2038_are_refused_or_rebased() {
    let dir = tempfile::tempdir().unwrap();
    let py = python::python_with("mcap, mcap_ros2, rosbags");
    // 2039, and 2554 (past 1.8e10 s, where nanoseconds since 1970 overflow a u64).
    for (name, shift_s, date) in [
        ("2039.log", 500_000_000, "2039-09-18 23:06:40 UTC"),
        ("2554.log", 16_747_000_000, "2554-07-24 22:40:00 UTC"),
    ] {
        let late = shifted_log(dir.path(), name, 1, shift_s * 1_000_000);
        let late = late.to_str().unwrap();
        let mcap = dir.path().join(format!("{name}.mcap"));
        let r = convert(late, &config(), mcap.to_str().unwrap());
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(
            !r.status.success()
                && err.lines().count() == 1
                && err.contains(date)
                && err.contains("past the end of ROS 2 time")
                && err.contains("--ros-time rebase"),
            "{name}: {err}"
        );
        assert!(!mcap.exists(), "{name}: an MCAP of a refused run");
        let r = skin(&[
            "convert",
            late,
            "--config",
            &config(),
            "--mcap",
            mcap.to_str().unwrap(),
            "--ros-time",
            "rebase",
        ]);
        ok(&r);
        if let Some(py) = &py {
            let s = stamps(py, &mcap);
            let cloud = s.iter().find(|t| t.topic == "/skin/forearm/pressure").unwrap();
            // The first cloud follows the 20 baseline frames (1 s); the last, 31 s in.
            assert!(
                cloud.first_ns > 900_000_000 && cloud.first_ns < 1_100_000_000,
                "{s:?}"
            );
            assert!(
                cloud.last_ns > 30_000_000_000 && cloud.last_ns < 31_000_000_000,
                "{s:?}"
            );
            assert!(s.iter().all(|t| t.equal), "stamps differ from log times: {s:?}");
        }
    }
    // Today's log keeps its clock (2023-11-14), with or without the flag's default.
    let mcap = dir.path().join("today.mcap");
    ok(&convert(&log(), &config(), mcap.to_str().unwrap()));
    if let Some(py) = &py {
        let s = stamps(py, &mcap);
        let cloud = s.iter().find(|t| t.topic == "/skin/forearm/pressure").unwrap();
        assert_eq!(cloud.first_ns / 1_000_000_000, 1_700_000_001, "{s:?}");
        assert!(s.iter().all(|t| t.equal), "{s:?}");
    }
}

/// A link named " " (a layout written by hand, a CAD export): its topics and frame ids are
/// `link`, which tf2 accepts; the name reached every header's frame id as it was.
#[test]
fn a_blank_link_name_gets_a_frame_id_tf2_accepts() {
    let dir = tempfile::tempdir().unwrap();
    let fixtures = root().join("fixtures");
    let layout = std::fs::read_to_string(fixtures.join("forearm/layout.json")).unwrap();
    let layout = layout.replacen("\"name\": \"forearm\"", "\"name\": \" \"", 1);
    assert!(layout.contains("\"name\": \" \""));
    std::fs::write(dir.path().join("layout.json"), layout).unwrap();
    let config = dir.path().join("blank.toml");
    std::fs::write(
        &config,
        format!(
            "layout = \"layout.json\"\nbusmap = {:?}\n[baseline]\nframes = 20\n",
            fixtures.join("forearm/busmap.toml").display().to_string()
        ),
    )
    .unwrap();
    let mcap = dir.path().join("blank.mcap");
    ok(&convert(&log(), config.to_str().unwrap(), mcap.to_str().unwrap()));
    let Some(py) = python::python_with("mcap, mcap_ros2, rosbags") else {
        return;
    };
    let s = stamps(&py, &mcap);
    let cloud = s.iter().find(|t| t.topic == "/skin/link/pressure");
    assert!(cloud.is_some_and(|c| c.frame_ids == ["link"]), "{s:?}");
    for t in &s {
        assert!(
            t.frame_ids.iter().all(|f| f.is_empty() || f == "link"),
            "{}: frame ids {:?}",
            t.topic,
            t.frame_ids
        );
    }
}

/// Live options: each wrong use is refused before any work, in one line that names the value
/// and the fix, never a path inside Zenoh's sources.
#[test]
fn live_options_are_checked_in_one_clear_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out").display().to_string();
    let port = free_port();
    let listen = format!("tcp/127.0.0.1:{port}");
    let any = format!("tcp/0.0.0.0:{port}");
    let cases: [(&[&str], &[&str]); 6] = [
        (
            &["--zenoh-listen", &listen, "--ros-domain", "233"],
            &["--ros-domain 233", "0 to 232"],
        ),
        (&["--ros-domain", "5"], &["--ros-domain needs --zenoh"]),
        (&["--zenoh-drain", "5"], &["--zenoh-drain needs --zenoh"]),
        (
            &["--zenoh-listen", &listen, "--zenoh-listen", &listen],
            &[&listen, "given twice"],
        ),
        (
            &["--zenoh-listen", &listen, "--zenoh-listen", &any],
            &[&any, "already listens on that port"],
        ),
        (
            &["--zenoh", &listen, "--zenoh-listen", &listen],
            &[&listen, "connect to itself"],
        ),
    ];
    for (args, says) in cases {
        let r = run_session(&out, args);
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(
            !r.status.success()
                && err.lines().count() == 1
                && says.iter().all(|s| err.contains(s))
                && !err.contains(".rs:")
                && !err.contains(".cargo"),
            "{args:?}: {err}"
        );
        assert!(!dir.path().join("out").exists());
    }
}

/// Starts `ros2/slow_peer.py` (see there): `mode` listen or connect on `port`, subscribed to
/// `key`, `delay` seconds a sample, checking against `events` at the end. Returns once it is
/// subscribed.
fn slow_peer(
    py: &PathBuf,
    mode: &str,
    port: u16,
    key: &str,
    delay: &str,
    events: &Path,
) -> std::process::Child {
    let mut peer = Command::new(py)
        .arg(root().join("skin-cli/tests/ros2/slow_peer.py"))
        .args([mode, &port.to_string(), key, delay])
        .arg(events)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    if mode == "listen" {
        wait_ready(&mut peer);
    }
    peer
}

/// Tells the peer the run is over and returns its verdict: (passed, what it said).
fn peer_verdict(mut peer: std::process::Child) -> (bool, String) {
    let _ = peer.stdin.as_mut().unwrap().write_all(b"done\n");
    let out = peer.wait_with_output().unwrap();
    let said = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), said)
}

/// The run's line about the events topic: "zenoh: /skin/events: N event(s): ...".
fn events_line(stderr: &str) -> String {
    stderr
        .lines()
        .find(|l| l.starts_with("zenoh: /skin/events:"))
        .unwrap_or_else(|| panic!("no line about /skin/events:\n{stderr}"))
        .to_owned()
}

/// A subscriber that takes 50 ms a sample in Zenoh's receiving thread, on every topic: the
/// run's clouds, contacts and markers fill the connection, yet every event of the session
/// reaches it (they were lost: 33-40 of 100, while the run said "published"), and the run's
/// counts say what was handed over and acknowledged.
#[test]
fn a_slow_subscriber_receives_every_event() {
    let Some(py) = python::python_with("zenoh, rosbags, numpy") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let port = free_port();
    let peer = slow_peer(&py, "listen", port, "0/**", "0.05", &out.join("events.jsonl"));
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let r = run_session(
        out.to_str().unwrap(),
        &["--zenoh", &endpoint, "--zenoh-drain", "300"],
    );
    let (passed, said) = peer_verdict(peer);
    let err = String::from_utf8_lossy(&r.stderr).into_owned();
    eprintln!("{said}\n{err}");
    ok(&r);
    assert!(passed, "the slow peer missed events:\n{said}");
    let events = std::fs::read_to_string(out.join("events.jsonl"))
        .unwrap()
        .lines()
        .count();
    let line = events_line(&err);
    assert!(
        line.contains(&format!("{events} event(s): {events} handed to the network"))
            && !line.contains("undelivered"),
        "{line}"
    );
    assert!(
        err.contains("every byte written was read by the receiving process (on this machine)"),
        "{err}"
    );
    assert!(!err.contains("published"), "{err}");
}

/// The same subscriber, on the events only, through a log 40 times the fixture's (4,000 events,
/// 20 minutes of traffic): every event arrives.
#[test]
fn a_slow_subscriber_receives_every_event_of_a_long_log() {
    let Some(py) = python::python_with("zenoh, rosbags, numpy") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let long = shifted_log(dir.path(), "long.candump.log", 40, 0);
    let out = dir.path().join("out");
    let port = free_port();
    let peer = slow_peer(
        &py,
        "listen",
        port,
        "0/skin/events/**",
        "0.05",
        &out.join("events.jsonl"),
    );
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let started = std::time::Instant::now();
    let r = skin(&[
        "run",
        &config(),
        "--log",
        long.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "-q",
        "--zenoh",
        &endpoint,
        "--zenoh-drain",
        "600",
    ]);
    let (passed, said) = peer_verdict(peer);
    let err = String::from_utf8_lossy(&r.stderr).into_owned();
    eprintln!(
        "{said}\n{err}\n(run and peer: {:.0} s)",
        started.elapsed().as_secs_f64()
    );
    ok(&r);
    assert!(passed, "the slow peer missed events:\n{said}");
    let events = std::fs::read_to_string(out.join("events.jsonl"))
        .unwrap()
        .lines()
        .count();
    assert!(events > 3_000, "{events} events");
    let line = events_line(&err);
    assert!(
        line.contains(&format!("{events} event(s): {events} handed to the network")),
        "{line}"
    );
}

/// `--zenoh-wait` with a subscriber to one topic only (a cloud, not the events): the run starts
/// once that subscriber is there and says which topics have none (it waited the whole time in
/// silence).
#[test]
fn zenoh_wait_names_the_topics_without_a_subscriber() {
    let Some(py) = python::python_with("zenoh, rosbags, numpy") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let port = free_port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let run = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args([
            "run",
            &config(),
            "--log",
            &log(),
            "-o",
            out.to_str().unwrap(),
            "-q",
        ])
        .args(["--zenoh-listen", &endpoint, "--zenoh-wait", "600"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let peer = slow_peer(
        &py,
        "connect",
        port,
        "0/skin/forearm/pressure/**",
        "0",
        Path::new("-"),
    );
    let r = run.wait_with_output().unwrap();
    let (_, said) = peer_verdict(peer);
    let err = String::from_utf8_lossy(&r.stderr).into_owned();
    eprintln!("{said}\n{err}");
    ok(&r);
    assert!(
        // pressure, tactile image, contacts, events, markers, layout, tactile state, and the
        // calibrated forearm's wrench.
        err.contains("waiting up to 600 s for a subscriber to any of the 8 topics"),
        "{err}"
    );
    let none = err
        .lines()
        .find(|l| l.contains("a subscriber is there; none yet on"))
        .unwrap_or_else(|| panic!("no line about the topics without a subscriber:\n{err}"));
    assert!(
        none.contains("/skin/events")
            && none.contains("/skin/forearm/wrench")
            && !none.contains("/skin/forearm/pressure"),
        "{none}"
    );
}

/// `/skin/tare`, `/skin/tare_forced` and `/skin/describe` called by a Python Zenoh peer as an
/// rmw_zenoh client calls them, and the layout taken by a subscriber that joins late
/// (`ros2/service_peer.py`), while the run reads the fixture log from a FIFO the peer writes:
/// the peer knows where the run is (a tare before the first touch, then during it).
#[test]
fn services_answer_an_rmw_zenoh_client_and_the_layout_reaches_a_late_subscriber() {
    let Some(py) = python::python_with("zenoh, rosbags, numpy") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let (out, fifo) = (dir.path().join("out"), dir.path().join("log.fifo"));
    let made = Command::new("mkfifo").arg(&fifo).status();
    if !made.is_ok_and(|s| s.success()) {
        eprintln!("SKIPPED: no mkfifo here");
        return;
    }
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let run = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(["run", &config(), "--log"])
        .arg(&fifo)
        .arg("-o")
        .arg(&out)
        .args(["-q", "--zenoh-listen", &endpoint])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let describe = skin_ros::interfaces::Interfaces::skin()
        .unwrap()
        .type_hash("skin_msgs/srv/Describe")
        .unwrap();
    let port = endpoint.rsplit(':').next().unwrap().to_owned();
    let layout = root().join("fixtures/forearm/layout.json");
    let said = python::run(
        &py,
        "ros2/service_peer.py",
        &[
            OsStr::new(&port),
            fifo.as_os_str(),
            OsStr::new(&log()),
            layout.as_os_str(),
            OsStr::new(&describe),
        ],
    );
    eprintln!("{said}");
    let r = run.wait_with_output().unwrap();
    ok(&r);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(
        stderr.contains("zenoh: service /skin/tare: 3 call(s) answered (2 refused, with the reason)"),
        "{stderr}"
    );
    let events = std::fs::read_to_string(out.join("events.jsonl")).unwrap();
    let tares: Vec<serde_json::Value> = events
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|e| e["event"] == "tare")
        .collect();
    assert_eq!(tares.len(), 2, "{events}");
    assert_eq!(
        (tares[0]["forced"].as_bool(), tares[0]["released"].as_u64()),
        (Some(false), Some(0))
    );
    assert_eq!(
        (tares[1]["forced"].as_bool(), tares[1]["released"].as_u64()),
        (Some(true), Some(1))
    );
    // The touches after the forced tare are still found.
    let after = events
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|e| e["event"] == "released" && e["time"].as_f64() > tares[1]["time"].as_f64())
        .count();
    assert!(
        after >= 12,
        "{after} touches released after the forced tare:\n{events}"
    );
}

/// `skin run` of the fixture arm with `--joint-states`, its postures from a Python Zenoh peer
/// publishing as rmw_zenoh does (`ros2/joint_state_peer.py`), into `out`; the peer's stdout
/// and the run.
fn arm_with_joint_states(py: &PathBuf, out: &Path, mode: &str) -> (String, std::process::Output) {
    let port = free_port();
    let arm = root().join("fixtures/arm");
    // fixtures/arm/run.toml with its URDF and no poses file: only the joint states can place
    // the wrist (at rest it stays at the middle of its limits).
    let config = out.with_extension("toml");
    let text = std::fs::read_to_string(arm.join("run.toml")).unwrap();
    let absolute = |t: &str| {
        let mut t = t.to_owned();
        for file in [
            "layout.json",
            "busmap.toml",
            "arm.urdf",
            "../models/handsnet.onnx",
            "../../target/skin-cache",
        ] {
            t = t.replace(
                &format!("\"{file}\""),
                &format!("{:?}", arm.join(file).display().to_string()),
            );
        }
        t
    };
    let text: String = absolute(&text)
        .lines()
        .filter(|l| !l.starts_with("poses"))
        .map(|l| format!("{l}\n"))
        .collect();
    assert!(text.contains("urdf = ") && !text.contains("poses ="), "{text}");
    std::fs::write(&config, text).unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_skin"))
        .arg("run")
        .arg(&config)
        .arg("--log")
        .arg(arm.join("touch.candump.log"))
        .arg("-o")
        .arg(out)
        .args([
            "-q",
            "--frames",
            "--zenoh-wait",
            "60",
            "--joint-states",
            "/joint_states",
        ])
        .args(["--zenoh-listen", &format!("tcp/127.0.0.1:{port}")])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut peer = Command::new(py)
        .arg(root().join("skin-cli/tests/ros2/joint_state_peer.py"))
        .args([&port.to_string(), mode])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_ready(&mut peer);
    let r = run.wait_with_output().unwrap();
    let (fine, said) = peer_verdict(peer);
    assert!(fine, "the peer failed:\n{said}");
    (said, r)
}

/// The stitched images of a run's --frames, by name.
fn stitched_frames(out: &Path) -> Vec<(String, Vec<u8>)> {
    let mut frames: Vec<(String, Vec<u8>)> = std::fs::read_dir(out.join("frames/stitched"))
        .unwrap()
        .map(|e| {
            let p = e.unwrap().path();
            (
                p.file_name().unwrap().to_string_lossy().into_owned(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    frames.sort();
    frames
}

/// Joint states published over Zenoh as rmw_zenoh does give the events and stitched images of
/// the recorded postures; faulty ones and a flood of other samples on the topic are one event
/// each or counted, and the run goes on.
#[test]
fn joint_states_over_zenoh_place_the_arm_as_the_recorded_postures_do() {
    let Some(py) = python::python_with("zenoh, rosbags, numpy") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let arm = root().join("fixtures/arm");
    let recorded = dir.path().join("recorded");
    ok(&skin(&[
        "run",
        arm.join("run.toml").to_str().unwrap(),
        "--log",
        arm.join("touch.candump.log").to_str().unwrap(),
        "-o",
        recorded.to_str().unwrap(),
        "-q",
        "--frames",
    ]));
    let live = dir.path().join("live");
    let (_, r) = arm_with_joint_states(&py, &live, "clean");
    ok(&r);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(
        stderr.contains("zenoh: subscription /joint_states: 700 sample(s) received, 700 read"),
        "{stderr}"
    );
    let events = |d: &Path| std::fs::read_to_string(d.join("events.jsonl")).unwrap();
    assert_eq!(events(&live), events(&recorded));
    let (a, b) = (stitched_frames(&live), stitched_frames(&recorded));
    assert!(!b.is_empty());
    assert_eq!(a.len(), b.len());
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        assert!(x == y, "{name}: the stitched images differ");
    }

    let faulty = dir.path().join("faulty");
    let (said, r) = arm_with_joint_states(&py, &faulty, "faults");
    ok(&r);
    let stderr = String::from_utf8_lossy(&r.stderr);
    eprintln!("{said}\n{stderr}");
    let line = stderr
        .lines()
        .find(|l| l.contains("subscription /joint_states"))
        .unwrap_or_else(|| panic!("no line about the subscription:\n{stderr}"));
    assert!(
        line.contains("dropped of another type or type hash") && line.contains("not a readable message"),
        "{line}"
    );
    let all: Vec<serde_json::Value> = events(&faulty)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let problems: Vec<&str> = all
        .iter()
        .filter(|e| e["event"] == "joint_states")
        .map(|e| e["problem"].as_str().unwrap())
        .collect();
    for p in ["not_finite", "other_robot", "out_of_order"] {
        assert_eq!(
            problems.iter().filter(|q| **q == p).count(),
            1,
            "{p}: {problems:?}"
        );
    }
    let released = |v: &[serde_json::Value]| v.iter().filter(|e| e["event"] == "released").count();
    let recorded: Vec<serde_json::Value> = events(&recorded)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(released(&all), released(&recorded));
}
