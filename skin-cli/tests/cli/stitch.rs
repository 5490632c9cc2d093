//! `skin stitch`: one image across the links of an arm at every posture.

use super::*;

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
