//! `abandon_unfinished` removes every output the process is building: a process of its own, so
//! that no other test's output is abandoned with them.

#![allow(clippy::unwrap_used)]

use skin_core::output::{Inputs, OutputDir, OutputFile, abandon_unfinished};
use std::io::Write as _;

#[test]
fn abandon_unfinished_removes_what_is_half_built_and_nothing_else() {
    let d = tempfile::tempdir().unwrap();
    // An earlier output, a folder being built over it, a new folder, and a file being replaced.
    let earlier = d.path().join("earlier");
    let o = OutputDir::create(&earlier, "skin image", false, &Inputs::default()).unwrap();
    std::fs::write(o.path().join("a.png"), "1").unwrap();
    o.commit().unwrap();
    let again = OutputDir::create(&earlier, "skin image", false, &Inputs::default()).unwrap();
    std::fs::write(again.path().join("a.png"), "2").unwrap();
    let fresh = d.path().join("fresh");
    let new = OutputDir::create(&fresh, "skin image", false, &Inputs::default()).unwrap();
    std::fs::write(new.path().join("b.png"), "1").unwrap();
    let file = d.path().join("map.json");
    std::fs::write(&file, "old").unwrap();
    let mut f = OutputFile::create(&file, &Inputs::default()).unwrap();
    f.write_all(b"half").unwrap();

    assert_eq!(abandon_unfinished(), 4); // two staging folders, a new folder, a temporary file
    assert!(!fresh.exists());
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "old");
    assert_eq!(std::fs::read_to_string(earlier.join("a.png")).unwrap(), "1");
    let mut left: Vec<_> = std::fs::read_dir(d.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    left.sort();
    assert_eq!(left, ["earlier", "map.json"]);
    drop((again, new, f));
}
