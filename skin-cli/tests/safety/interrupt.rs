//! An interrupted or failing command leaves the previous output or nothing: Ctrl-C, SIGTERM, a
//! full disk.

use super::*;

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
