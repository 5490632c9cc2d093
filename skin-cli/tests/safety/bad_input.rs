//! Bad input is refused by name before it sizes anything: numbers, configurations, images,
//! taxels, recordings and scenes.

use super::*;

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
