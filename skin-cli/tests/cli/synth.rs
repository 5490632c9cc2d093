//! `skin synth`: labelled synthetic datasets, with taxels removed, blind spots, labels as imaged.

use super::*;

#[test]
fn synth_writes_a_repeatable_labelled_dataset() {
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    let report = synth(&a, "5");
    synth(&b, "5");
    assert!(report.contains("60 samples of 4 subjects"), "{report}");
    for f in ["labels.csv", "frames.txt", "taxel_parts.txt", "map.json"] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f} differs between two runs with one seed"
        );
    }
    let data = skin_learn::dataset::Dataset::read(&a).unwrap();
    assert_eq!(data.entries.len(), 60);
    let hands = data.entries.iter().filter(|e| e.hand).count();
    assert!((15..=45).contains(&hands), "{hands} hands of 60 at a 50% share");
    let mut labelled = 0;
    for (i, e) in data.entries.iter().enumerate() {
        let image = grey(&a.join("images").join(&e.file));
        assert_eq!(image.len(), 68 * 100);
        let mask = a.join("masks").join(&e.file);
        assert_eq!(mask.exists(), e.hand, "a mask for hands only ({})", e.file);
        if e.hand {
            let mask = grey(&mask);
            assert!(mask.iter().all(|&l| l <= 6));
            assert!(
                mask.iter().zip(&image).all(|(&l, &g)| l == 0 || g > 0),
                "sample {i}: a part label on a black pixel"
            );
            labelled += usize::from(mask.iter().any(|&l| l > 0));
        }
    }
    assert!(
        labelled * 10 >= hands * 9,
        "only {labelled} of {hands} hand masks show a part"
    );
    // Another seed, another dataset.
    let c = tmp.path().join("c");
    synth(&c, "6");
    assert_ne!(
        std::fs::read(a.join("frames.txt")).unwrap(),
        std::fs::read(c.join("frames.txt")).unwrap()
    );
}

#[test]
fn synth_with_taxels_removed_keeps_the_readings_and_thins_the_images() {
    let tmp = tempfile::tempdir().unwrap();
    let (whole, thin) = (tmp.path().join("whole"), tmp.path().join("thin"));
    synth(&whole, "5");
    let args = |extra: &[&str]| synth_run(&thin, "5", extra);
    let o = args(&["--remove-up-to", "0.7", "--thinned-share", "1"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    assert!(
        out.contains("60 imaged through maps with up to 70% of the taxels removed"),
        "{out}"
    );
    // The same contacts, read by every taxel, with the same labels.
    for f in ["labels.csv", "frames.txt", "taxel_parts.txt", "map.json"] {
        assert_eq!(
            std::fs::read(whole.join(f)).unwrap(),
            std::fs::read(thin.join(f)).unwrap(),
            "{f}"
        );
    }
    let data = skin_learn::dataset::Dataset::read(&thin).unwrap();
    let changed = data
        .entries
        .iter()
        .filter(|e| grey(&thin.join("images").join(&e.file)) != grey(&whole.join("images").join(&e.file)))
        .count();
    assert!(changed >= 50, "{changed} of 60 images changed");
    // Refused: a share without a fraction, a fraction out of range.
    let o = args(&["--thinned-share", "0.5"]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("--remove-up-to"), "{err}");
    let o = args(&["--remove-up-to", "1"]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("--remove-up-to"), "{err}");
}

#[test]
fn synth_with_blind_spots_keeps_the_readings_and_darkens_some_images() {
    let tmp = tempfile::tempdir().unwrap();
    let (whole, blind) = (tmp.path().join("whole"), tmp.path().join("blind"));
    synth(&whole, "5");
    let args = |extra: &[&str]| synth_run(&blind, "5", extra);
    let o = args(&["--blind-spots", "4", "--blind-share", "1"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    assert!(
        out.contains("60 imaged through maps with 1 to 4 blind spots of up to 40 mm"),
        "{out}"
    );
    for f in ["labels.csv", "frames.txt", "taxel_parts.txt", "map.json"] {
        assert_eq!(
            std::fs::read(whole.join(f)).unwrap(),
            std::fs::read(blind.join(f)).unwrap(),
            "{f}"
        );
    }
    // A dead taxel only takes light away: no pixel brighter than in the whole map's image
    // except through contact-max normalisation, so compare lit pixel counts.
    let data = skin_learn::dataset::Dataset::read(&blind).unwrap();
    let (mut changed, mut darker) = (0, 0);
    for e in &data.entries {
        let (b, w) = (
            grey(&blind.join("images").join(&e.file)),
            grey(&whole.join("images").join(&e.file)),
        );
        if b != w {
            changed += 1;
            let lit = |g: &[u8]| g.iter().filter(|&&v| v > 0).count();
            darker += usize::from(lit(&b) <= lit(&w));
        }
    }
    assert!(changed >= 10, "{changed} of 60 images changed");
    assert!(
        darker * 10 >= changed * 9,
        "{darker} of {changed} changed images lit no more pixels"
    );
    // Refused: a share without spots, a radius outside (0, 1000] mm, shares adding up to more
    // than 1, spots out of range.
    let o = args(&["--blind-share", "0.5"]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("--blind-spots"), "{err}");
    for radius in ["0", "1000.1", "nan"] {
        let o = args(&["--blind-spots", "2", "--blind-radius-mm", radius]);
        let (_, err) = text(&o);
        assert!(
            !o.status.success() && err.contains("--blind-radius-mm"),
            "{radius}: {err}"
        );
    }
    let o = args(&["--blind-spots", "2", "--remove-up-to", "0.5"]);
    assert!(o.status.success(), "the default shares, 0.5 and 0.3, go together");
    let o = args(&[
        "--blind-spots",
        "2",
        "--blind-share",
        "0.6",
        "--remove-up-to",
        "0.5",
    ]);
    let (_, err) = text(&o);
    assert!(
        !o.status.success() && err.contains("--thinned-share") && err.contains("--blind-share"),
        "{err}"
    );
    let o = args(&["--blind-spots", "0"]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("--blind-spots"), "{err}");
}

#[test]
fn synth_labels_as_imaged_keep_the_images_and_redraw_some_masks() {
    let tmp = tempfile::tempdir().unwrap();
    let (pressing, as_imaged) = (tmp.path().join("pressing"), tmp.path().join("as_imaged"));
    synth(&pressing, "5");
    let o = synth_run(&as_imaged, "5", &["--mask-labels", "as-imaged"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "{out}{err}");
    assert!(out.contains("as it shows on the image"), "{out}");
    for f in ["labels.csv", "frames.txt", "taxel_parts.txt"] {
        assert_eq!(
            std::fs::read(pressing.join(f)).unwrap(),
            std::fs::read(as_imaged.join(f)).unwrap(),
            "{f}"
        );
    }
    let data = skin_learn::dataset::Dataset::read(&as_imaged).unwrap();
    let (mut same_images, mut masks_differ) = (0, 0);
    for e in &data.entries {
        same_images += usize::from(
            grey(&pressing.join("images").join(&e.file)) == grey(&as_imaged.join("images").join(&e.file)),
        );
        // Masks are written for hands only.
        if e.hand {
            masks_differ += usize::from(
                grey(&pressing.join("masks").join(&e.file)) != grey(&as_imaged.join("masks").join(&e.file)),
            );
        }
    }
    assert_eq!(same_images, 60);
    let hands = data.entries.iter().filter(|e| e.hand).count();
    assert!(masks_differ >= 5, "{masks_differ} of {hands} hand masks differ");
    let o = synth_run(&as_imaged, "5", &["--mask-labels", "drawn"]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("as-imaged"), "{err}");
}
