//! MCAP outputs: a file another tool recorded is never replaced; one writer per path; a clear
//! line for what cannot be written.

use super::*;

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
