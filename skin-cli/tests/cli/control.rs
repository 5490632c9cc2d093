//! `skin reach` and `skin phri`: the control experiments (thesis Ch. 8).

use super::*;

/// A small reach scene: the first two goals and bars of the default one, two starts each.
fn small_reach_scene(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(root().join("skin-control/scenes/fig8_4.json")).unwrap();
    let mut scene: serde_json::Value = serde_json::from_str(&text).unwrap();
    for key in ["obstacles", "goals"] {
        scene[key].as_array_mut().unwrap().truncate(2);
    }
    scene["random_starts"] = 2.into();
    let path = dir.join("scene.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    path
}

#[test]
fn reach_prints_the_same_table_for_the_same_seed_and_the_baseline_fails_on_force() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_reach_scene(dir.path());
    let scene = scene.to_str().unwrap();
    let csv = dir.path().join("trials.csv");
    let a = skin(&["reach", "--scene", scene, "--csv", csv.to_str().unwrap()]);
    let b = skin(&["reach", "--scene", scene]);
    assert!(a.status.success(), "{:?}", text(&a));
    assert_eq!(a.stdout, b.stdout, "same seed, same table");
    let (out, _) = text(&a);
    assert!(out.contains("F_thresh = 15 N"), "{out}");
    assert!(out.lines().any(|l| l.starts_with("A ")) && out.lines().any(|l| l.starts_with("all ")));
    let rows = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(rows.lines().count(), 1 + 4);
    assert!(
        rows.starts_with("seed,skin,goal,start,outcome,")
            && rows.lines().nth(1).unwrap().starts_with("1,1,A,0,"),
        "{rows}"
    );
    let base = skin(&["reach", "--scene", scene, "--no-skin"]);
    let (out, _) = text(&base);
    assert!(out.contains("WITHOUT skin"), "{out}");
    // Every baseline trial pushes through a bar: 0 successes, 4 force failures.
    let all = out.lines().find(|l| l.starts_with("all ")).unwrap();
    assert!(all.contains("0/4"), "{all}");
    let other = skin(&["reach", "--scene", scene, "--seed", "5"]);
    assert_ne!(other.stdout, a.stdout, "another seed, other starts");
}

#[test]
fn reach_over_seeds_gives_each_seed_pooled_and_mean_rates_with_the_baseline() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_reach_scene(dir.path());
    let scene = scene.to_str().unwrap();
    let csv = dir.path().join("trials.csv");
    let o = skin(&[
        "reach",
        "--scene",
        scene,
        "--seed",
        "3",
        "--seeds",
        "2",
        "--baseline",
        "--csv",
        csv.to_str().unwrap(),
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("seeds 3-4") && out.contains("WITHOUT skin"), "{out}");
    let seed_rows: Vec<&str> = out
        .lines()
        .filter(|l| l.starts_with("3 ") || l.starts_with("4 "))
        .collect();
    assert_eq!(seed_rows.len(), 2, "{out}");
    // Each seed: 4 trials with the skin and the same 4 without; the baseline pushes through the
    // bars every time.
    assert!(
        seed_rows
            .iter()
            .all(|l| l.matches("/4 ").count() == 2 && l.contains("0/4 ")),
        "{out}"
    );
    let all = out.lines().rfind(|l| l.starts_with("all ")).unwrap();
    assert!(all.contains("/8 ") && all.contains("0/8 "), "{all}");
    assert!(
        out.contains("mean over 2 seeds (95% t interval): with skin"),
        "{out}"
    );
    // Seed 3 alone gives its own row of the same numbers.
    let one = skin(&["reach", "--scene", scene, "--seed", "3", "--baseline"]);
    let (one, _) = text(&one);
    let row3 = |t: &str| t.lines().find(|l| l.starts_with("3 ")).map(str::to_owned);
    assert_eq!(row3(&one), row3(&out));
    let rows = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(rows.lines().count(), 1 + 2 * 4 * 2);
    assert_eq!(rows.lines().filter(|l| l.starts_with("4,0,")).count(), 4);
    let o = skin(&["reach", "--scene", scene, "--seeds", "0"]);
    assert!(
        !o.status.success() && text(&o).1.contains("--seeds"),
        "{:?}",
        text(&o)
    );
    let o = skin(&["reach", "--scene", scene, "--no-skin", "--baseline"]);
    assert!(
        !o.status.success() && text(&o).1.contains("--baseline"),
        "{:?}",
        text(&o)
    );
}

#[test]
fn reach_refuses_a_bad_threshold_and_a_bad_scene_in_one_line() {
    let o = skin(&["reach", "--threshold=-3"]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("--threshold"), "{err}");
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, r#"{"goals": [[0.5, 0, 0.5]], "obstacles": [{"type": "capsule", "a": [0,0,0], "b": [0,0,1], "radius": 0}]}"#).unwrap();
    let o = skin(&["reach", "--scene", bad.to_str().unwrap()]);
    let (_, err) = text(&o);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains("bad.json") && err.contains("obstacles[0].radius"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

#[test]
fn phri_reports_the_ignored_bump_and_the_push_and_plots_the_timeline() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("timeline.svg");
    let o = skin(&["phri", "--svg", svg.to_str().unwrap()]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(out.contains("task 1 not activated (ignored)"), "{out}");
    assert!(out.contains("task 1 active after"), "{out}");
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert!(plot.starts_with("<svg") && plot.contains("path error (mm)"));
}
