//! `skin calibrate` and `skin probe-sim`: taxel positions fitted from probe presses (thesis Ch. 7).

use super::*;

fn hex(name: &str) -> String {
    root().join("fixtures/hex_patch").join(name).display().to_string()
}

#[test]
fn calibrate_recovers_the_hex_patch_and_prints_the_thesis_table() {
    let dir = tempfile::tempdir().unwrap();
    let (out, plot) = (dir.path().join("cal.json"), dir.path().join("curve.svg"));
    let o = skin(&[
        "calibrate",
        &hex("probes.csv"),
        "-o",
        out.to_str().unwrap(),
        "--truth",
        &hex("layout.json"),
        "--plot",
        plot.to_str().unwrap(),
    ]);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        stdout.contains("61 fitted, 0 flagged") && stdout.contains("thesis ABS"),
        "{stdout}"
    );
    // The table's row: mean error, sigma, normal error, max; all within the thesis' figures.
    let row: Vec<f64> = stdout
        .lines()
        .find(|l| l.starts_with("this dataset"))
        .unwrap()
        .split_whitespace()
        .filter_map(|w| w.parse().ok())
        .collect();
    assert!(row[0] <= 1.9 && row[2] <= 0.06 && row[4] <= 4.0, "{row:?}");
    let layout = skin_core::format::load_link(&out).unwrap().value;
    assert_eq!(layout.taxels.len(), 61);
    assert!(
        std::fs::read_to_string(&plot)
            .unwrap()
            .contains("samples per taxel")
    );
}

/// `skin probe-sim` on the hexagonal patch with `args`, into DIR/p.csv.
fn hex_probes(dir: &Path, args: &[&str]) -> PathBuf {
    let probes = dir.join("p.csv");
    let mut all = vec!["probe-sim", "--layout"];
    let layout = hex("layout.json");
    all.push(&layout);
    all.extend_from_slice(args);
    all.extend_from_slice(&["-o", probes.to_str().unwrap()]);
    let o = skin(&all);
    assert!(o.status.success(), "{}", text(&o).1);
    probes
}

#[test]
fn probe_sim_then_calibrate_writes_a_cyskin_layout_and_flags_what_it_cannot_fit() {
    let dir = tempfile::tempdir().unwrap();
    // Few contacts: some border taxels answer too rarely and must be flagged, not guessed.
    let probes = hex_probes(dir.path(), &["--contacts", "60", "--seed", "3"]);
    let out = dir.path().join("cal.json");
    let o = skin(&[
        "calibrate",
        probes.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--format",
        "cyskin",
    ]);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(stdout.contains("too few responses"), "{stdout}");
    let flagged: usize = stdout
        .split(" fitted, ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap();
    let link = skin_core::format::cyskin::read_skin(&out).unwrap().value;
    assert!(flagged > 0 && link.taxels.len() + flagged <= 61, "{stdout}");
}

/// Probed only inside its outermost taxels, the hexagonal patch's border is one-sided: the
/// taxels there are flagged as not surrounded, and the report gives every taxel's status and
/// the fitted ones' uncertainty.
#[test]
fn calibrate_flags_edge_taxels_its_contacts_do_not_surround_and_reports_uncertainty() {
    let dir = tempfile::tempdir().unwrap();
    let probes = hex_probes(dir.path(), &["--contacts", "800", "--margin-mm", "0"]);
    let (out, report) = (dir.path().join("cal.json"), dir.path().join("report.tsv"));
    let o = skin(&[
        "calibrate",
        probes.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    let (stdout, err) = text(&o);
    assert!(o.status.success(), "{err}");
    assert!(stdout.contains("not surrounded by its contacts"), "{stdout}");
    assert!(stdout.contains("centre uncertainty"), "{stdout}");
    let table = std::fs::read_to_string(&report).unwrap();
    let mut lines = table.lines();
    assert_eq!(lines.next(), Some(skin_learn::calibration::REPORT_HEADER));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split('\t').collect()).collect();
    assert_eq!(rows.len(), 61);
    for r in &rows {
        assert_eq!(r.len(), 8, "{r:?}");
        if r[1] == "fitted" {
            let sd: f64 = r[6].parse().unwrap();
            assert!(sd > 0.0 && sd < 2.0, "{r:?}");
        } else {
            assert!(r[3].is_empty(), "a flagged taxel has no position: {r:?}");
        }
    }
    let edge = rows.iter().filter(|r| r[1].starts_with("not surrounded")).count();
    assert!(
        (1..=30).contains(&edge),
        "{edge} taxels flagged as not surrounded"
    );
    // A bad angle is refused before anything is written.
    let o = skin(&[
        "calibrate",
        probes.to_str().unwrap(),
        "-o",
        dir.path().join("x.json").to_str().unwrap(),
        "--max-open-angle",
        "400",
    ]);
    assert!(!o.status.success() && text(&o).1.contains("--max-open-angle"));
    assert!(!dir.path().join("x.json").exists());
}

#[test]
fn calibrate_names_the_line_and_field_of_a_bad_row() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.csv");
    std::fs::write(
        &bad,
        "contact,x_m,y_m,z_m,taxel,response\n0,0.1,0.2,0.3,16,5\n1,0.1,0.2,abc,16,5\n",
    )
    .unwrap();
    let out = dir.path().join("o.json");
    let o = skin(&["calibrate", bad.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    let (_, err) = text(&o);
    assert!(!o.status.success() && err.contains("line 3, field z_m"), "{err}");
    assert!(!out.exists());
    let o = skin(&[
        "calibrate",
        &hex("probes.csv"),
        "-o",
        out.to_str().unwrap(),
        "--plot",
        "c.svg",
    ]);
    assert!(
        !o.status.success() && text(&o).1.contains("give --truth"),
        "{}",
        text(&o).1
    );
}
