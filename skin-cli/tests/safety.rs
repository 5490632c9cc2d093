//! Your files are safe: every case of the data-safety review, as a user would try it. Each test
//! fails on a `skin` that destroys, replaces or silently drops what the user owns.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

skin_test_support::skin_binary!(); // skin(args) runs this package's binary; root()

fn err(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A copy of a fixture file in `dir`.
fn copy(dir: &Path, fixture: &str) -> PathBuf {
    let to = dir.join(Path::new(fixture).file_name().unwrap());
    std::fs::copy(root().join("fixtures").join(fixture), &to).unwrap();
    to
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every file under `dir` with its bytes, to compare a folder before and after.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((p.clone(), std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let d = tempfile::tempdir().unwrap();
    let layout = copy(d.path(), "forearm/layout.json");
    let log = copy(d.path(), "forearm/touches.candump.log");
    let busmap = copy(d.path(), "forearm/busmap.toml");
    let before = snapshot(d.path());
    let cases: Vec<Vec<&str>> = vec![
        vec!["flatten", s(&layout), "-o", s(&layout)],
        vec!["flatten", s(&layout), "-o", "/dev/null", "--svg", s(&layout)],
        vec!["replay", s(&log), "--busmap", s(&busmap), "-o", s(&log)],
        vec!["busmap", "--layout", s(&layout), "-o", s(&layout)],
        vec![
            "degrade",
            "--map",
            s(&layout),
            "--remove",
            "0.1",
            "-o",
            s(&layout),
        ],
        vec!["probe-sim", "--layout", s(&layout), "-o", s(&layout)],
    ];
    for args in &cases {
        let o = skin(args);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(err(&o).contains("also an input"), "{args:?}: {}", err(&o));
    }
    // Through a hard link and a symbolic link too.
    let hard = d.path().join("hard.json");
    std::fs::hard_link(&layout, &hard).unwrap();
    let soft = d.path().join("soft.json");
    std::os::unix::fs::symlink(&layout, &soft).unwrap();
    for out in [&hard, &soft] {
        let o = skin(&["flatten", s(&layout), "-o", s(out)]);
        assert!(
            !o.status.success() && err(&o).contains("the input"),
            "{}",
            err(&o)
        );
    }
    std::fs::remove_file(&hard).unwrap();
    std::fs::remove_file(&soft).unwrap();
    assert!(snapshot(d.path()) == before, "a file changed");
}

#[test]
fn calibrate_refuses_to_write_over_its_probes() {
    let d = tempfile::tempdir().unwrap();
    let layout = copy(d.path(), "forearm/layout.json");
    let probes = d.path().join("probes.csv");
    let o = skin(&[
        "probe-sim",
        "--layout",
        s(&layout),
        "--contacts",
        "50",
        "-o",
        s(&probes),
    ]);
    assert!(o.status.success(), "{}", err(&o));
    let before = std::fs::read(&probes).unwrap();
    let o = skin(&["calibrate", s(&probes), "-o", s(&probes)]);
    assert!(
        !o.status.success() && err(&o).contains("also an input"),
        "{}",
        err(&o)
    );
    assert_eq!(std::fs::read(&probes).unwrap(), before);
}

/// The user's folder holding the config, the log and notes: `skin run -o` it, or `-o .`.
#[test]
fn run_never_empties_a_folder_it_did_not_write() {
    let d = tempfile::tempdir().unwrap();
    let fixtures = d.path().join("fixtures");
    for f in ["forearm/layout.json", "forearm/busmap.toml"] {
        std::fs::create_dir_all(fixtures.join("forearm")).unwrap();
        std::fs::copy(root().join("fixtures").join(f), fixtures.join(f)).unwrap();
    }
    let session = fixtures.join("session");
    std::fs::create_dir_all(&session).unwrap();
    let config = session.join("run.toml");
    // No models: the test is about the folder, not the decisions.
    std::fs::write(
        &config,
        "layout = \"../forearm/layout.json\"\nbusmap = \"../forearm/busmap.toml\"\n",
    )
    .unwrap();
    let log = copy(&session, "forearm/touches.candump.log");
    std::fs::write(session.join("notes.txt"), "my notes").unwrap();
    let before = snapshot(&session);
    let o = skin(&["run", s(&config), "--log", s(&log), "-o", s(&session), "-q"]);
    assert!(!o.status.success(), "a folder of the user's was written into");
    assert!(
        err(&o).contains("notes.txt") && err(&o).contains("--force"),
        "{}",
        err(&o)
    );
    let o = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(["run", s(&config), "--log", s(&log), "-o", ".", "-q"])
        .current_dir(&session)
        .output()
        .unwrap();
    assert!(!o.status.success(), "-o . was written into");
    let after = snapshot(&session);
    let names = |v: &[(PathBuf, Vec<u8>)]| v.iter().map(|(p, _)| p.display().to_string()).collect::<Vec<_>>();
    assert!(
        after == before,
        "the folder changed: {:?} -> {:?}",
        names(&before),
        names(&after)
    );

    // --force writes skin's files beside the user's, and touches nothing else.
    let o = skin(&[
        "run",
        s(&config),
        "--log",
        s(&log),
        "-o",
        s(&session),
        "-q",
        "--force",
    ]);
    assert!(o.status.success(), "{}", err(&o));
    for (path, bytes) in &before {
        assert_eq!(&std::fs::read(path).unwrap(), bytes, "{}", path.display());
    }
    assert!(session.join("events.jsonl").is_file() && session.join("summary.txt").is_file());
    // A re-run into its own output needs no --force, and leaves no temporary file.
    let out = d.path().join("out");
    for _ in 0..2 {
        let o = skin(&["run", s(&config), "--log", s(&log), "-o", s(&out), "-q"]);
        assert!(o.status.success(), "{}", err(&o));
    }
    let names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert!(!names.iter().any(|n| n.contains("partial")), "{names:?}");
    assert!(
        !d.path()
            .read_dir()
            .unwrap()
            .flatten()
            .any(|e| e.file_name().to_string_lossy().contains("partial"))
    );
}

#[test]
fn a_second_writer_of_one_folder_refuses_at_once() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out");
    std::fs::create_dir(&out).unwrap();
    // Hold the lock as a running `skin` would.
    std::fs::write(out.join(".skin-output"), r#"{"command":"skin image","files":[]}"#).unwrap();
    let lock = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(out.join(".skin-lock"))
        .unwrap();
    lock.lock().unwrap();
    let map = root().join("fixtures/forearm/layout.json");
    let rec = root().join("fixtures/forearm/touches.txt");
    let o = skin(&["image", "--map", s(&map), s(&rec), "-o", s(&out), "-q"]);
    assert!(
        !o.status.success() && err(&o).contains("another skin command"),
        "{}",
        err(&o)
    );
}

#[test]
fn devices_fifos_and_symlinks_are_written_through() {
    let d = tempfile::tempdir().unwrap();
    let layout = root().join("fixtures/forearm/layout.json");
    // A device stays a device, and its error is the user's path.
    let o = skin(&["flatten", s(&layout), "-o", "/dev/null"]);
    assert!(o.status.success(), "{}", err(&o));
    let null = std::fs::symlink_metadata("/dev/null").unwrap();
    assert!(!null.is_file());
    // A FIFO is written through: its reader gets the map, and it stays a FIFO.
    let fifo = d.path().join("map.fifo");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
    };
    let o = skin(&["flatten", s(&layout), "-o", s(&fifo)]);
    assert!(o.status.success(), "{}", err(&o));
    assert!(reader.join().unwrap().contains("points"));
    use std::os::unix::fs::FileTypeExt as _;
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
    // A symlink, even dangling, keeps being a link and its target gets the map.
    let target = d.path().join("real.json");
    let link = d.path().join("link.json");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let o = skin(&["flatten", s(&layout), "-o", s(&link)]);
    assert!(o.status.success(), "{}", err(&o));
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    assert!(std::fs::read_to_string(&target).unwrap().contains("points"));
    // A folder given as a file is named as such.
    let o = skin(&["flatten", s(&layout), "-o", s(d.path())]);
    assert!(!o.status.success() && err(&o).contains("a folder"), "{}", err(&o));
    // What the system refuses is said once, about the user's path, never a temporary name.
    let under_file = target.join("m.json");
    let o = skin(&["flatten", s(&layout), "-o", s(&under_file)]);
    let e = err(&o);
    assert!(
        !o.status.success() && e.contains(s(&under_file)) && !e.contains("partial"),
        "{e}"
    );
    assert_eq!(e.matches("os error").count(), 1, "{e}");
}

#[test]
fn two_inputs_named_alike_never_land_on_one_file() {
    let d = tempfile::tempdir().unwrap();
    let rec = root().join("fixtures/forearm/touches.txt");
    for sub in ["a", "b"] {
        std::fs::create_dir(d.path().join(sub)).unwrap();
        std::fs::copy(&rec, d.path().join(sub).join("touches.txt")).unwrap();
    }
    let map = root().join("fixtures/forearm/layout.json");
    let out = d.path().join("out");
    let (a, b) = (d.path().join("a/touches.txt"), d.path().join("b/touches.txt"));
    let o = skin(&["image", "--map", s(&map), s(&a), s(&b), "-o", s(&out), "-q"]);
    assert!(o.status.success(), "{}", err(&o));
    assert!(out.join("a_touches").is_dir() && out.join("b_touches").is_dir());
    // The same file twice is one mistake, said.
    let o = skin(&[
        "image",
        "--map",
        s(&map),
        s(&a),
        s(&a),
        "-o",
        s(&d.path().join("o2")),
        "-q",
    ]);
    assert!(!o.status.success() && err(&o).contains("distinct"), "{}", err(&o));
}

#[test]
fn repeated_frame_numbers_get_their_own_images() {
    let d = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("fixtures/forearm/touches.txt")).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    let frames = lines.len() - 1;
    // Join the recording with itself: every frame number appears twice.
    let again: Vec<&str> = lines[1..].to_vec();
    lines.extend(again);
    let rec = d.path().join("joined.txt");
    std::fs::write(&rec, lines.join("\n")).unwrap();
    let map = root().join("fixtures/forearm/layout.json");
    let out = d.path().join("out");
    let o = skin(&["image", "--map", s(&map), s(&rec), "-o", s(&out), "-q"]);
    assert!(o.status.success(), "{}", err(&o));
    let written = std::fs::read_dir(out.join("joined")).unwrap().count();
    assert_eq!(written, 2 * frames);
}

#[test]
fn a_smaller_synth_into_its_own_dataset_leaves_no_stale_image() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("data");
    let layout = root().join("fixtures/forearm/layout.json");
    for count in ["12", "5"] {
        let o = skin(&["synth", "--layout", s(&layout), "--count", count, "-o", s(&out)]);
        assert!(o.status.success(), "{}", err(&o));
    }
    let images = std::fs::read_dir(out.join("images")).unwrap().count();
    let labels = std::fs::read_to_string(out.join("labels.csv"))
        .unwrap()
        .lines()
        .count()
        - 1;
    assert_eq!((images, labels), (5, 5));
}

#[test]
fn numbers_are_checked_before_they_size_anything() {
    let layout = root().join("fixtures/forearm/layout.json");
    let rec = root().join("fixtures/forearm/touches.txt");
    let d = tempfile::tempdir().unwrap();
    let o_dir = d.path().join("o");
    // Each command line ({L}: a layout, {R}: a recording, {O}: an output folder) and what its
    // error must say.
    let cases = [
        ("busmap --layout {L} --buses 4294967295", "1 to 256"),
        ("busmap --layout {L} --buses 100", "would leave buses empty"),
        ("synth --layout {L} --count 4000000000 -o {O}", "1 to 1000000"),
        ("synth --layout {L} --count 10 --size 50000x50000 -o {O}", "4096"),
        ("image --map {L} {R} --size 100000x100000 -o {O}", "4096"),
        ("image --map {L} {R} --step-mm 0.0001 -o {O}", "0.01"),
        ("image --map {L} {R} --threshold NaN -o {O}", "finite"),
        ("stitch --layout {L} --poses {L} --threshold NaN -o {O}", "finite"),
        (
            "stitch --layout {L} --poses {L} --max-edge-mm NaN -o {O}",
            "finite",
        ),
        ("degrade --map {L} --remove NaN -o /dev/null", "finite"),
        (
            "eval --model {L} --dataset {O} --test-fraction=-0.5",
            "from 0 to 1",
        ),
        ("eval --model {L} --dataset {O} --test-fraction 2", "from 0 to 1"),
        ("eval --model {L} --dataset {O} --patterns 0", "1 to 10000"),
        ("eval --model {L} --dataset {O} --threads 100000", "1 to 256"),
        ("reach --trials 0", "1 to 100000"),
        ("classify --model {L} {R} --threshold NaN", "finite"),
    ];
    for (line, want) in cases {
        let args: Vec<&str> = line
            .split(' ')
            .map(|w| match w {
                "{L}" => s(&layout),
                "{R}" => s(&rec),
                "{O}" => s(&o_dir),
                w => w,
            })
            .collect();
        let o = skin(&args);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(err(&o).contains(want), "{args:?}: {}", err(&o));
    }
    assert!(!o_dir.exists(), "a refused command created its output");
    // Many buses for few modules: every bus carries some.
    let o = skin(&["busmap", "--layout", s(&layout), "--buses", "60"]);
    assert!(o.status.success(), "{}", err(&o));
    let map = String::from_utf8_lossy(&o.stdout).into_owned();
    let buses: Vec<&str> = map.split("[[bus]]").skip(1).collect();
    assert_eq!(buses.len(), 60);
    assert!(buses.iter().all(|b| b.contains("address")), "an empty bus");
}

#[test]
fn busmap_covers_every_link_of_a_layout() {
    let o = skin(&["busmap", "--layout", s(&root().join("fixtures/arm/layout.json"))]);
    assert!(o.status.success(), "{}", err(&o));
    let map = String::from_utf8_lossy(&o.stdout).into_owned();
    let layout = skin_core::format::native::read_layout(&root().join("fixtures/arm/layout.json")).unwrap();
    assert!(layout.links.len() > 1);
    for link in &layout.links {
        for t in &link.taxels {
            assert!(
                map.contains(&format!(" {},", t.id))
                    || map.contains(&format!("[{},", t.id))
                    || map.contains(&format!(" {}]", t.id)),
                "taxel {} of {}",
                t.id,
                link.name
            );
        }
    }
}

#[test]
fn config_values_are_closed_sets_and_checked() {
    let d = tempfile::tempdir().unwrap();
    let fx = root().join("fixtures");
    let base = format!(
        "layout = \"{}\"\nbusmap = \"{}\"\n",
        fx.join("forearm/layout.json").display(),
        fx.join("forearm/busmap.toml").display()
    );
    let log = fx.join("forearm/touches.candump.log");
    for (extra, want) in [
        ("[gate]\nhand = \"explode\"\n", "comply"),
        ("[touch]\nreclassify_growth = nan\n", "reclassify_growth"),
        ("[baseline]\npolarity = \"up\"\n", "rising"),
        ("[touch]\nrelease_frames = 0\n", "release_frames"),
    ] {
        let config = d.path().join("run.toml");
        std::fs::write(&config, format!("{base}{extra}")).unwrap();
        let o = skin(&[
            "run",
            s(&config),
            "--log",
            s(&log),
            "-o",
            s(&d.path().join("out")),
            "-q",
        ]);
        assert!(!o.status.success(), "{extra} accepted");
        assert!(err(&o).contains(want), "{extra}: {}", err(&o));
    }
}

#[test]
fn classify_refuses_images_that_are_not_8_bit_grey() {
    let d = tempfile::tempdir().unwrap();
    let model = root().join("fixtures/models/handsnet.onnx");
    let rgb = d.path().join("rgb.png");
    image::RgbImage::new(100, 68).save(&rgb).unwrap();
    let deep = d.path().join("deep.png");
    image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::new(100, 68)
        .save(&deep)
        .unwrap();
    for p in [&rgb, &deep] {
        let o = skin(&["classify", "--model", s(&model), s(p)]);
        assert!(
            !o.status.success() && err(&o).contains("8-bit grey"),
            "{}",
            err(&o)
        );
    }
    // A model path that is a folder is named as one.
    let o = skin(&["classify", "--model", s(d.path()), s(&rgb)]);
    assert!(!o.status.success() && err(&o).contains("a folder"), "{}", err(&o));
}

#[test]
fn a_taxel_a_world_away_is_refused_by_name() {
    let d = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("fixtures/forearm/layout.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["links"][0]["taxels"][3]["position"][0] = serde_json::json!(1e308);
    let bad = d.path().join("far.json");
    std::fs::write(&bad, v.to_string()).unwrap();
    let o = skin(&["flatten", s(&bad), "-o", s(&d.path().join("m.json"))]);
    assert!(!o.status.success(), "flattened a taxel at 1e308 m");
    assert!(
        err(&o).contains("index 3") && err(&o).contains("100 m"),
        "{}",
        err(&o)
    );
    // A taxel of the wrong shape is named, not blamed on line 0, column 0.
    v["links"][0]["taxels"][5]["normal"] = serde_json::json!("up");
    std::fs::write(&bad, v.to_string()).unwrap();
    let o = skin(&["flatten", s(&bad), "-o", s(&d.path().join("m.json"))]);
    assert!(
        err(&o).contains("index 5") && !err(&o).contains(":0:0"),
        "{}",
        err(&o)
    );
}

#[test]
fn a_repeated_taxel_id_in_a_recording_header_names_both_columns() {
    let d = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("fixtures/forearm/touches.txt")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    let mut ids: Vec<&str> = lines[0].split_whitespace().collect();
    let first = ids[0].to_owned();
    ids[4] = &first;
    lines[0] = ids.join(" ");
    let rec = d.path().join("dup.txt");
    std::fs::write(&rec, lines.join("\n")).unwrap();
    let map = root().join("fixtures/forearm/layout.json");
    let o = skin(&[
        "image",
        "--map",
        s(&map),
        s(&rec),
        "-o",
        s(&d.path().join("out")),
        "-q",
    ]);
    assert!(!o.status.success());
    assert!(
        err(&o).contains("field 5") && err(&o).contains("field 1"),
        "{}",
        err(&o)
    );
    // A 10 MB field is quoted by its start only.
    let long = "x".repeat(10_000_000);
    std::fs::write(&rec, format!("{long}\n")).unwrap();
    let o = skin(&[
        "image",
        "--map",
        s(&map),
        s(&rec),
        "-o",
        s(&d.path().join("out")),
        "-q",
    ]);
    assert!(
        !o.status.success() && err(&o).len() < 1000,
        "{} bytes",
        err(&o).len()
    );
}

#[test]
fn candump_error_frames_are_counted_and_skipped() {
    let d = tempfile::tempdir().unwrap();
    let fx = root().join("fixtures/forearm");
    let text = std::fs::read_to_string(fx.join("touches.candump.log")).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    let error = "(1700000000.000001) can0 20000080#0000000000000000";
    lines.insert(5, error);
    let log = d.path().join("with_errors.log");
    std::fs::write(&log, lines.join("\n")).unwrap();
    let o = skin(&["replay", s(&log), "--busmap", s(&fx.join("busmap.toml"))]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", err(&o));
    assert!(out.contains("error frames in the log, skipped: 1"), "{out}");
}

#[test]
fn a_capsule_too_large_for_the_collision_library_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let scene = d.path().join("scene.json");
    std::fs::write(
        &scene,
        r#"{"obstacles": [{"type": "capsule", "a": [0.5, -0.2, 0.3], "b": [0.5, 0.2, 0.3], "radius": 1e100}],
            "goals": [[0.4, 0.0, 0.4]]}"#,
    )
    .unwrap();
    for cmd in ["reach", "phri"] {
        let o = skin(&[cmd, "--scene", s(&scene)]);
        assert!(!o.status.success(), "{cmd}");
        assert!(
            err(&o).contains("radius") && !err(&o).contains("panicked"),
            "{cmd}: {}",
            err(&o)
        );
    }
    std::fs::write(&scene, r#"{"goals": [[0.4, 0.0, 0.4]], "rate": 1e9}"#).unwrap();
    let o = skin(&["reach", "--scene", s(&scene)]);
    assert!(!o.status.success() && err(&o).contains("rate"), "{}", err(&o));
}

/// Starts `skin ARGS -o OUT`, waits until it has built a file in its staging folder, sends it
/// SIGINT, and checks that it stopped with 130 and removed what it was building.
#[cfg(unix)]
fn interrupt(args: &[&str], out: &Path) {
    use std::time::{Duration, Instant};
    let mut child = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(args)
        .args(["-o", s(out)])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let staging = out.join(".skin-partial");
    let building = || {
        let mut stack = vec![staging.clone()];
        while let Some(d) = stack.pop() {
            for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
                if e.path().is_dir() {
                    stack.push(e.path());
                } else {
                    return true;
                }
            }
        }
        false
    };
    let start = Instant::now();
    while !building() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("{args:?} ended ({status}) before it could be interrupted");
        }
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "{args:?} never started writing"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{args:?}: {}", err(&o));
    assert!(!staging.exists(), "{args:?} left its staging folder");
}

#[cfg(unix)]
#[test]
fn an_interrupted_image_or_stitch_leaves_the_previous_output_or_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let fx = |p: &str| root().join("fixtures").join(p).display().to_string();
    let (forearm, touches) = (fx("forearm/layout.json"), fx("forearm/touches.txt"));
    let (arm, poses, touch) = (fx("arm/layout.json"), fx("arm/poses.json"), fx("arm/touch.txt"));
    // Each command with a slow and a quick setting: the slow one is interrupted.
    let image = |size: &'static str| vec!["image", "--map", &forearm, &touches, "--size", size, "-q"];
    let stitch = |step: &'static str| {
        vec![
            "stitch",
            "--layout",
            &arm,
            "--poses",
            &poses,
            &touch,
            "--threshold",
            "10",
            "--step-mm",
            step,
        ]
    };
    for (name, slow, quick) in [
        ("image", image("4096x4096"), image("68x100")),
        ("stitch", stitch("0.1"), stitch("1")),
    ] {
        // Interrupted on its first run: the folder it created is gone.
        let out = dir.path().join(name);
        interrupt(&slow, &out);
        assert!(
            !out.exists(),
            "{name}: an interrupted first run left {}",
            out.display()
        );
        // Interrupted over an earlier output: that output stays, byte for byte.
        let o = Command::new(env!("CARGO_BIN_EXE_skin"))
            .args(&quick)
            .args(["-o", s(&out)])
            .output()
            .unwrap();
        assert!(o.status.success(), "{name}: {}", err(&o));
        let before = snapshot(&out);
        assert!(before.len() > 100, "{name}: {} files", before.len());
        interrupt(&slow, &out);
        assert_eq!(snapshot(&out), before, "{name}: the earlier output changed");
        assert!(!out.join("INCOMPLETE").exists());
    }
}

#[test]
fn a_users_other_file_is_never_replaced_and_an_earlier_output_is() {
    let d = tempfile::tempdir().unwrap();
    let layout = root().join("fixtures/forearm/layout.json");
    let busmap = root().join("fixtures/forearm/busmap.toml");
    let log = root().join("fixtures/forearm/touches.candump.log");
    let probes = root().join("fixtures/hex_patch/probes.csv");
    let notes = d.path().join("notes.txt");
    std::fs::write(&notes, "a day of lab notes\n").unwrap();
    let map = d.path().join("map.json");
    let o = skin(&["flatten", s(&layout), "-o", s(&map)]);
    assert!(o.status.success(), "{}", err(&o));
    let n = s(&notes);
    for args in [
        vec!["flatten", s(&layout), "-o", n],
        vec!["flatten", s(&layout), "-o", "/dev/null", "--svg", n],
        vec!["busmap", "--layout", s(&layout), "-o", n],
        vec!["degrade", "--map", s(&map), "--remove", "0.1", "-o", n],
        vec!["probe-sim", "--layout", s(&layout), "-o", n],
        vec!["calibrate", s(&probes), "-o", n],
        vec!["replay", s(&log), "--busmap", s(&busmap), "-o", n],
        vec!["reach", "--trials", "1", "--csv", n],
        vec!["phri", "--csv", n],
        vec!["phri", "--svg", n],
    ] {
        let o = skin(&args);
        assert!(!o.status.success(), "{args:?} replaced the user's file");
        assert!(err(&o).contains("exists and is not"), "{args:?}: {}", err(&o));
        assert_eq!(
            std::fs::read_to_string(&notes).unwrap(),
            "a day of lab notes\n",
            "{args:?}"
        );
    }
    // Running a command again over its own output works, for every kind of file.
    let svg = d.path().join("map.svg");
    let table = d.path().join("frames.csv");
    let sim = d.path().join("probes.csv");
    for _ in 0..2 {
        for args in [
            vec!["flatten", s(&layout), "-o", s(&map), "--svg", s(&svg)],
            vec!["replay", s(&log), "--busmap", s(&busmap), "-o", s(&table)],
            vec![
                "probe-sim",
                "--layout",
                s(&layout),
                "--contacts",
                "20",
                "-o",
                s(&sim),
            ],
        ] {
            let o = skin(&args);
            assert!(o.status.success(), "{args:?}: {}", err(&o));
        }
    }
}

/// The fixture session's configuration and log, and the log repeated `times` times one after
/// the other (a longer run, to interrupt), written in `dir`.
fn session(dir: &Path, times: u64) -> (String, String) {
    use skin_can::candump::{CanFrame, CandumpLog};
    let config = root().join("fixtures/session/run.toml").display().to_string();
    let one = CandumpLog::read(&root().join("fixtures/session/session.candump.log")).unwrap();
    let first = one.frames.first().unwrap().time_us;
    let span = one.frames.last().unwrap().time_us - first + 50_000;
    let mut long = one.clone();
    long.frames = (0..times)
        .flat_map(|k| {
            one.frames.iter().map(move |f| CanFrame {
                time_us: f.time_us + k * span,
                ..*f
            })
        })
        .collect();
    let path = dir.join(format!("session{times}.log"));
    long.write(&path).unwrap();
    (config, path.display().to_string())
}

/// Starts `skin ARGS` and returns it once `ready()` holds (or panics if it ends first).
#[cfg(unix)]
fn start_until(args: &[&str], ready: impl Fn() -> bool) -> std::process::Child {
    use std::time::{Duration, Instant};
    let mut child = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !ready() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("{args:?} ended ({status}) before it was ready");
        }
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "{args:?} never got ready"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
    child
}

#[cfg(unix)]
fn signal(child: &std::process::Child, sig: &str) {
    let sent = Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
}

#[cfg(unix)]
#[test]
fn an_interrupted_run_leaves_no_folder_however_busy_it_was() {
    // Every frame with contact makes an image: the run is writing one whenever it is
    // interrupted, and the handler must not race it.
    let dir = tempfile::tempdir().unwrap();
    let (config, log) = session(dir.path(), 6);
    for (k, sig) in ["-INT", "-TERM", "-INT", "-TERM", "-INT", "-TERM"]
        .iter()
        .enumerate()
    {
        let out = dir.path().join(format!("out{k}"));
        let frames = out.join(".skin-partial/frames");
        let args = ["run", &config, "--log", &log, "--frames", "-q", "-o", s(&out)];
        // Interrupted while it writes images, a little later each time.
        let child = start_until(&args, || {
            std::fs::read_dir(frames.join("forearm")).is_ok_and(|d| d.count() > 20 * k)
        });
        signal(&child, sig);
        let o = child.wait_with_output().unwrap();
        assert_eq!(o.status.code(), Some(130), "{}", err(&o));
        assert!(
            err(&o).contains("interrupted: nothing was written"),
            "{}",
            err(&o)
        );
        assert!(
            !out.exists(),
            "run {k} ({sig}) left {:?}",
            snapshot(&out).iter().map(|f| f.0.clone()).collect::<Vec<_>>()
        );
    }
}

#[test]
fn a_name_as_long_as_linux_allows_can_be_written() {
    let d = tempfile::tempdir().unwrap();
    let layout = root().join("fixtures/forearm/layout.json");
    for n in [236, 237, 255] {
        let map = d.path().join(format!("{}.json", "m".repeat(n - 5)));
        let o = skin(&["flatten", s(&layout), "-o", s(&map)]);
        assert!(o.status.success(), "{n} bytes: {}", err(&o));
        assert!(map.is_file());
    }
    assert_eq!(
        std::fs::read_dir(d.path()).unwrap().count(),
        3,
        "no temporary file left"
    );
}

/// An MCAP file as another recorder leaves it: the magic, a header naming its library, the
/// magic again.
#[cfg(feature = "mcap")]
fn foreign_mcap(library: &str) -> Vec<u8> {
    let magic = b"\x89MCAP0\r\n";
    let mut body = Vec::new();
    for s in ["ros2", library] {
        body.extend_from_slice(&u32::try_from(s.len()).unwrap().to_le_bytes());
        body.extend_from_slice(s.as_bytes());
    }
    let mut bytes = magic.to_vec();
    bytes.push(0x01);
    bytes.extend_from_slice(&u64::try_from(body.len()).unwrap().to_le_bytes());
    bytes.extend_from_slice(&body);
    bytes.extend_from_slice(magic);
    bytes
}

#[cfg(feature = "mcap")]
#[test]
fn an_mcap_another_tool_recorded_is_never_replaced() {
    let d = tempfile::tempdir().unwrap();
    let (config, log) = session(d.path(), 1);
    let bag = d.path().join("robot.mcap");
    let bytes = foreign_mcap("rosbag2_storage_mcap");
    std::fs::write(&bag, &bytes).unwrap();
    let out = d.path().join("out");
    let o = skin(&[
        "run",
        &config,
        "--log",
        &log,
        "-q",
        "-o",
        s(&out),
        "--mcap",
        s(&bag),
    ]);
    assert!(!o.status.success());
    assert!(
        err(&o).contains("robot.mcap: exists and is not an MCAP file that skin wrote"),
        "{}",
        err(&o)
    );
    assert_eq!(std::fs::read(&bag).unwrap(), bytes);
    assert!(!out.exists());
    // One that skin wrote is replaced: running again works.
    let again = d.path().join("again.mcap");
    for _ in 0..2 {
        let o = skin(&[
            "run",
            &config,
            "--log",
            &log,
            "-q",
            "-o",
            s(&out),
            "--mcap",
            s(&again),
        ]);
        assert!(o.status.success(), "{}", err(&o));
    }
}

#[cfg(feature = "mcap")]
#[test]
fn an_mcap_moves_into_place_with_its_folder_or_not_at_all() {
    let d = tempfile::tempdir().unwrap();
    let (config, log) = session(d.path(), 1);
    let out = d.path().join("out");
    let mcap = d.path().join("first.mcap");
    let o = skin(&[
        "run",
        &config,
        "--log",
        &log,
        "-q",
        "-o",
        s(&out),
        "--mcap",
        s(&mcap),
    ]);
    assert!(o.status.success(), "{}", err(&o));
    // A folder now stands where the run writes its summary: the folder cannot be committed,
    // so neither a new MCAP file nor the earlier one changes.
    std::fs::remove_file(out.join("summary.txt")).unwrap();
    std::fs::create_dir(out.join("summary.txt")).unwrap();
    let before = (snapshot(&out), std::fs::read(&mcap).unwrap());
    let second = d.path().join("second.mcap");
    for path in [&second, &mcap] {
        let o = skin(&[
            "run",
            &config,
            "--log",
            &log,
            "-q",
            "-o",
            s(&out),
            "--mcap",
            s(path),
        ]);
        assert!(!o.status.success());
        assert!(err(&o).contains("summary.txt: is a folder"), "{}", err(&o));
        assert_eq!((snapshot(&out), std::fs::read(&mcap).unwrap()), before);
        assert!(
            !second.exists(),
            "the MCAP file went into place without its folder"
        );
    }
    let mut left: Vec<_> = std::fs::read_dir(d.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    left.sort();
    assert_eq!(
        left,
        ["first.mcap", "out", "session1.log"],
        "no temporary file left"
    );
}

#[cfg(all(unix, feature = "mcap"))]
#[test]
fn one_mcap_path_has_one_writer_and_a_killed_ones_file_goes() {
    let d = tempfile::tempdir().unwrap();
    let (config, log) = session(d.path(), 6);
    let mcap = d.path().join("run.mcap");
    // A run killed while it records leaves its partial file.
    let out = d.path().join("killed");
    let args = [
        "run",
        &config,
        "--log",
        &log,
        "-q",
        "-o",
        s(&out),
        "--mcap",
        s(&mcap),
    ];
    let partial = || {
        std::fs::read_dir(d.path()).unwrap().flatten().any(|e| {
            let n = e.file_name().to_string_lossy().into_owned();
            n.starts_with(".run.mcap.partial") && e.metadata().is_ok_and(|m| m.len() > 100_000)
        })
    };
    let mut killed = start_until(&args, partial);
    // Meanwhile a second run of the same MCAP path is refused at once, naming it.
    let other = d.path().join("other");
    let o = skin(&[
        "run",
        &config,
        "--log",
        &log,
        "-q",
        "-o",
        s(&other),
        "--mcap",
        s(&mcap),
    ]);
    assert!(!o.status.success());
    assert!(
        err(&o).contains("run.mcap: another skin command is writing this file"),
        "{}",
        err(&o)
    );
    assert!(!other.exists());
    killed.kill().unwrap();
    killed.wait().unwrap();
    assert!(partial(), "the killed run left no partial file to clean");
    // The next run that writes there removes what the killed one left.
    let (_, short) = session(d.path(), 1);
    let o = skin(&[
        "run",
        &config,
        "--log",
        &short,
        "-q",
        "-o",
        s(&other),
        "--mcap",
        s(&mcap),
    ]);
    assert!(o.status.success(), "{}", err(&o));
    let hidden: Vec<String> = std::fs::read_dir(d.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("partial"))
        .collect();
    assert!(hidden.is_empty(), "{hidden:?}");
}

#[cfg(feature = "mcap")]
#[test]
fn mcap_paths_that_cannot_be_written_are_one_clear_line() {
    let d = tempfile::tempdir().unwrap();
    let (config, log) = session(d.path(), 1);
    let out = d.path().join("out");
    let o = skin(&["run", &config, "--log", &log, "-q", "-o", s(&out)]);
    assert!(o.status.success(), "{}", err(&o));
    // The output folder as the MCAP file: a name beside it is suggested, not one inside it.
    let o = skin(&[
        "run",
        &config,
        "--log",
        &log,
        "-q",
        "-o",
        s(&out),
        "--mcap",
        s(&out),
    ]);
    assert!(!o.status.success());
    let e = err(&o);
    assert!(
        e.contains("is the output folder") && e.contains(&format!("--mcap {}.mcap", s(&out))),
        "{e}"
    );
    assert!(!e.contains("out/out"), "{e}");
    // A device that is full: the file and what the system said.
    #[cfg(target_os = "linux")]
    {
        let o = skin(&[
            "run",
            &config,
            "--log",
            &log,
            "-q",
            "-o",
            s(&out),
            "--mcap",
            "/dev/full",
        ]);
        assert!(!o.status.success());
        let e = err(&o);
        assert!(
            e.contains("/dev/full") && e.contains("No space left on device"),
            "{e}"
        );
        assert!(!e.contains("compression stream"), "{e}");
        assert_eq!(e.trim().lines().count(), 1, "{e}");
    }
}

/// A disk that fills while the run writes (a file size limit, as `ulimit -f` sets): the error
/// names the user's folder, never the staging folder, and no folder is left.
#[cfg(target_os = "linux")]
#[test]
fn a_full_disk_during_a_run_names_the_users_folder() {
    let d = tempfile::tempdir().unwrap();
    let (config, log) = session(d.path(), 1);
    // The maps cached first, so that the limit meets the run's own files.
    let warm = d.path().join("warm");
    let o = skin(&["run", &config, "--log", &log, "-q", "-o", s(&warm)]);
    assert!(o.status.success(), "{}", err(&o));
    for extra in ["", "--frames"] {
        let out = d.path().join(format!("out{}", extra.len()));
        let o = Command::new("bash")
            .args([
                "-c",
                &format!(
                    "ulimit -f 4; trap '' XFSZ; exec \"$0\" run {config} --log {log} -q -o {} {extra}",
                    s(&out)
                ),
                env!("CARGO_BIN_EXE_skin"),
            ])
            .output()
            .unwrap();
        let e = err(&o);
        assert_eq!(o.status.code(), Some(1), "{e}");
        assert!(e.contains(s(&out)) && e.contains("File too large"), "{e}");
        assert!(!e.contains(".skin-partial"), "{e}");
        assert!(!out.exists(), "{e}");
    }
}
