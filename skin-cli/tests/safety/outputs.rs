//! Outputs never replace, empty or merge what the user owns: inputs, other files, devices,
//! a second writer's folder, names alike.

use super::*;

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
