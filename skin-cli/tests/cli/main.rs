//! The `skin` command as a user runs it: outputs, reports, and one clear line for bad input.
//! One file per command (or family of commands); what several of them use is here.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test or bench

use std::path::{Path, PathBuf};
use std::process::Output;

skin_test_support::skin_binary!(); // skin(args) runs this package's binary; root()

use shared_data::shared;
use skin_test_support::recordings;
use skin_test_support::shared_data;

/// The path of the fixture forearm's file `name`.
fn fixture(name: &str) -> String {
    root().join("fixtures/forearm").join(name).display().to_string()
}

/// What a run printed: its standard output and its standard error.
fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// `skin synth` of 60 samples of 4 subjects on the fixture forearm, with `extra` arguments.
fn synth_run(dir: &Path, seed: &str, extra: &[&str]) -> std::process::Output {
    let layout = root().join("fixtures/forearm/layout.json");
    let mut args = vec![
        "synth",
        "--layout",
        layout.to_str().unwrap(),
        "--count",
        "60",
        "--subjects",
        "4",
        "--seed",
        seed,
        "-o",
        dir.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    skin(&args)
}

/// `skin synth` of the fixture forearm into `dir` ([`synth_run`]), which must succeed; what it
/// printed.
fn synth(dir: &Path, seed: &str) -> String {
    let o = synth_run(dir, seed, &[]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    out
}

/// The grey values of the image at `path`.
fn grey(path: &Path) -> Vec<u8> {
    image::open(path).unwrap().into_luma8().into_raw()
}

mod calibrate;
mod can;
mod classify;
mod control;
mod degrade;
mod eval;
mod flatten;
mod force;
mod help;
mod images;
mod run;
mod stitch;
mod synth;
