//! `skin degrade`: a faulty map, the same for the same seed.

use super::*;

#[test]
fn degrade_writes_the_same_faulty_map_for_the_same_seed() {
    let dir = tempfile::tempdir().unwrap();
    let run = |args: &[&str], out: &str| {
        let path = dir.path().join(out);
        let mut all = vec!["degrade", "--map"];
        let layout = fixture("layout.json");
        all.push(&layout);
        all.extend_from_slice(args);
        all.extend_from_slice(&["-o", path.to_str().unwrap()]);
        let o = skin(&all);
        assert!(o.status.success(), "{}", text(&o).1);
        (text(&o).0, std::fs::read_to_string(path).unwrap())
    };
    let (out, a) = run(
        &["--blind-spots", "2", "--radius-mm", "20", "--seed", "7"],
        "a.json",
    );
    assert!(out.contains("taxels read zero"), "{out}");
    let (_, b) = run(
        &["--blind-spots", "2", "--radius-mm", "20", "--seed", "7"],
        "b.json",
    );
    let (_, c) = run(
        &["--blind-spots", "2", "--radius-mm", "20", "--seed", "8"],
        "c.json",
    );
    assert!(a == b && a != c);
    // Removal: nested by seed, and the images still come out.
    let (_, r30) = run(&["--remove", "0.3", "--seed", "1"], "r30.json");
    let (_, r60) = run(&["--remove", "0.6", "--seed", "1"], "r60.json");
    let ids = |json: &str| -> Vec<u64> {
        let v: serde_json::Value = serde_json::from_str(json).unwrap();
        v["ids"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap())
            .collect()
    };
    let (few, many) = (ids(&r60), ids(&r30));
    assert!(few.len() < many.len() && few.iter().all(|i| many.contains(i)));
    let o = skin(&[
        "image",
        "--map",
        dir.path().join("r60.json").to_str().unwrap(),
        &fixture("touches.txt"),
        "-o",
        dir.path().join("img").to_str().unwrap(),
        "-q",
    ]);
    assert!(o.status.success(), "{}", text(&o).1);
    let o = skin(&["degrade", "--map", &fixture("layout.json"), "-o", "x.json"]);
    assert!(
        !o.status.success() && text(&o).1.contains("give either"),
        "{}",
        text(&o).1
    );
}
