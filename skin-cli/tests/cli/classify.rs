//! `skin classify`: a classifier run on every touched frame of a recording.

use super::*;

#[test]
fn classify_runs_the_matlab_handsnet_on_every_touched_frame_of_a_recording() {
    let Some(model) = shared("cyskin/HandsNet_handles_finetuned.onnx") else {
        return;
    };
    let model = model.to_str().unwrap();
    let o = skin(&[
        "classify",
        "--model",
        model,
        "--map",
        &fixture("layout.json"),
        &fixture("touches.txt"),
        "--labels",
        "first,second",
    ]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        out.contains("[N, 1, 68, 100] -> 2 classes (first, second)"),
        "{out}"
    );
    let frames = out.lines().filter(|l| l.contains(" frame ")).count();
    let quiet: usize = out
        .lines()
        .find(|l| l.contains("with no contact"))
        .and_then(|l| l.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap();
    assert_eq!(frames + quiet, 130, "{out}");
    // A PNG of the wrong size is one clear line.
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("big.png");
    std::fs::write(&png, skin_geom_png(10, 20)).unwrap();
    let o = skin(&["classify", "--model", model, png.to_str().unwrap()]);
    let (_, err) = text(&o);
    assert!(
        !o.status.success() && err.contains("10 x 20 px, the model takes 68 x 100"),
        "{err}"
    );
    // Wrong label count.
    let o = skin(&[
        "classify",
        "--model",
        model,
        png.to_str().unwrap(),
        "--labels",
        "a,b,c",
    ]);
    let (_, err) = text(&o);
    assert!(
        !o.status.success() && err.contains("--labels names 3 classes"),
        "{err}"
    );
}

fn skin_geom_png(rows: u32, cols: u32) -> Vec<u8> {
    let mut out = Vec::new();
    image::GrayImage::new(cols, rows)
        .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .unwrap();
    out
}
