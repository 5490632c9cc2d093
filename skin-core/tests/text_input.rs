//! Text files as editors and tools leave them, through every reader: a byte-order mark, gzip,
//! UTF-16, Latin-1, CR-only and mixed line ends, binary data, a file without line ends, a folder,
//! a file past the size read whole. Each is read, or refused in one line naming the file, the line
//! and the fix; memory stays bounded.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use skin_core::format::poses::Postures;
use skin_core::format::{cyskin, icub, load_link, native, read_text, recording};
use skin_core::text::{Lines, MAX_DOCUMENT_BYTES, MAX_LINE_BYTES, read_document};
use skin_core::{LinkSkin, Taxel, TaxelId};
use std::io::{BufReader, Read, Write};
use std::path::{Path, PathBuf};

const BOM: &[u8] = b"\xef\xbb\xbf";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(root().join("fixtures").join(name)).unwrap()
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn bom(bytes: &[u8]) -> Vec<u8> {
    [BOM, bytes].concat()
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn small_link() -> LinkSkin {
    use nalgebra::{Point3, Unit, Vector3};
    let t = |id, x: f64, y: f64| Taxel {
        id: TaxelId(id),
        position: Point3::new(x, y, 0.01),
        normal: Unit::new_normalize(Vector3::new(0.0, 0.1, 1.0)),
    };
    let mut link = LinkSkin::new(
        "patch",
        vec![t(16, 0.0, 0.0), t(17, 0.008, 0.0), t(18, 0.004, 0.007)],
    );
    link.faces = Some(vec![[0, 1, 2]]);
    link
}

/// An iCub taxel file of one module (12 slots, the last 2 unused).
fn icub_text(eol: &str) -> String {
    let mut t = format!("name left_forearm{eol}spatial_sampling taxel{eol}[calibration]{eol}");
    for k in 0..12 {
        if k < 10 {
            let x = 0.001 * f64::from(k % 4);
            let y = 0.001 * f64::from(k / 4);
            t.push_str(&format!("{x:.4} {y:.4} 0.0100 0.0 0.0 1.0{eol}"));
        } else {
            t.push_str(&format!("0 0 0 0 0 0{eol}"));
        }
    }
    t
}

fn message<T: std::fmt::Debug>(r: skin_core::Result<T>) -> String {
    r.unwrap_err().to_string()
}

#[test]
fn a_byte_order_mark_is_skipped_by_every_reader() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let layout = fixture("forearm/layout.json");
    let plain = native::read_layout(&write(d, "plain.json", &layout)).unwrap();
    assert_eq!(
        native::read_layout(&write(d, "bom.json", &bom(&layout))).unwrap(),
        plain
    );
    assert_eq!(
        load_link(&write(d, "bom2.json", &bom(&layout))).unwrap().value,
        plain.links[0]
    );

    let skin = cyskin::skin_to_string(&small_link());
    let plain = cyskin::read_skin(&write(d, "c.json", skin.as_bytes())).unwrap();
    assert_eq!(
        cyskin::read_skin(&write(d, "cb.json", &bom(skin.as_bytes()))).unwrap(),
        plain
    );

    let poses = fixture("arm/poses.json");
    let plain = Postures::read(&write(d, "p.json", &poses)).unwrap();
    assert_eq!(Postures::read(&write(d, "pb.json", &bom(&poses))).unwrap(), plain);

    let rec = fixture("forearm/touches.txt");
    let plain = recording::read(&write(d, "r.txt", &rec)).unwrap();
    assert_eq!(recording::read(&write(d, "rb.txt", &bom(&rec))).unwrap(), plain);

    let config = b"layout = \"layout.json\"\n";
    assert_eq!(
        read_text(&write(d, "run.toml", &bom(config))).unwrap().as_bytes(),
        config
    );
}

#[test]
fn an_icub_file_with_a_byte_order_mark_keeps_its_link_name() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "left_forearm_mesh.txt",
        &bom(icub_text("\n").as_bytes()),
    );
    let read = icub::read(&p, icub::Duplicates::Merge).unwrap();
    assert_eq!(read.skin.name, "left_forearm");
    assert_eq!(read.skin.taxels.len(), 10);
}

#[test]
fn gzip_recordings_are_read_and_gzip_documents_refused_with_the_command() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rec = fixture("forearm/touches.txt");
    let plain = recording::read(&write(d, "r.txt", &rec)).unwrap();
    assert_eq!(
        recording::read(&write(d, "r.txt.gz", &gzip(&rec))).unwrap(),
        plain
    );
    // Two members, as `cat a.gz b.gz` makes: one stream.
    let half = rec.len() / 2;
    let cut = half + rec[half..].iter().position(|&b| b == b'\n').unwrap() + 1;
    let joined = [gzip(&rec[..cut]), gzip(&rec[cut..])].concat();
    assert_eq!(recording::read(&write(d, "j.txt.gz", &joined)).unwrap(), plain);

    let layout = write(d, "layout.json.gz", &gzip(&fixture("forearm/layout.json")));
    let e = message(native::read_layout(&layout));
    assert!(
        e.contains("layout.json.gz") && e.contains("gzip-compressed"),
        "{e}"
    );
    assert!(e.contains("gunzip -k"), "{e}");
    let txt = write(d, "left.txt", &gzip(icub_text("\n").as_bytes()));
    let e = message(icub::read(&txt, icub::Duplicates::Merge));
    assert!(e.contains("gzip-compressed") && e.contains("gunzip -k"), "{e}");
}

#[test]
fn a_truncated_gzip_recording_is_named_with_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let whole = gzip(&fixture("forearm/touches.txt"));
    let p = write(dir.path(), "cut.txt.gz", &whole[..whole.len() * 2 / 3]);
    let e = message(recording::read(&p));
    assert!(e.contains("cut.txt.gz: line "), "{e}");
    assert!(e.contains("ends early or is damaged"), "{e}");
}

#[test]
fn a_recording_copied_while_it_was_written_names_the_lines_to_keep() {
    let dir = tempfile::tempdir().unwrap();
    let whole = fixture("forearm/touches.txt");
    // Cut in the middle of a frame's line: the last line has no line end and too few values.
    let cut = whole.len() / 2;
    let cut = cut + whole[cut..].iter().position(|&b| b == b' ').unwrap();
    let lines = whole[..cut].iter().filter(|&&b| b == b'\n').count();
    let p = write(dir.path(), "live.txt", &whole[..cut]);
    let e = message(recording::read(&p));
    assert!(
        e.contains(&format!("live.txt: line {}: expected", lines + 1)),
        "{e}"
    );
    assert!(e.contains("ends in the middle of this line"), "{e}");
    let head = dir.path().join("live.head.txt");
    assert!(
        e.contains(&format!(
            "head -n {lines} '{}' > '{}'",
            p.display(),
            head.display()
        )),
        "{e}"
    );
    // A whole last line without its line end reads as any other.
    let end = whole[..cut].iter().rposition(|&b| b == b'\n').unwrap();
    let p = write(dir.path(), "whole.txt", &whole[..end]);
    assert_eq!(recording::read(&p).unwrap().frames.len(), lines - 1);
    // A bad line that has its line end is not said to be cut short.
    let mut bad = whole[..end].to_vec();
    bad.extend_from_slice(b"\n1 2 3\n");
    let e = message(recording::read(&write(dir.path(), "bad.txt", &bad)));
    assert!(e.contains("expected") && !e.contains("middle"), "{e}");
}

#[test]
fn other_compressed_formats_are_named_with_the_command() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "r.txt.xz", b"\xfd7zXZ\x00\x00\x04\xe6\xd6\xb4\x46");
    let e = message(recording::read(&p));
    assert!(e.contains("xz-compressed") && e.contains("xz -dk"), "{e}");
}

/// `text` in UTF-16 little-endian, with or without its byte-order mark.
fn utf16le(text: &str, mark: bool) -> Vec<u8> {
    let mut out = if mark { vec![0xff, 0xfe] } else { Vec::new() };
    for u in text.encode_utf16() {
        out.extend_from_slice(&u.to_le_bytes());
    }
    out
}

#[test]
fn utf16_files_are_named_with_the_conversion() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = "16 17\n0 0.0 1 2\n";
    for (name, mark) in [("bom.txt", true), ("bare.txt", false)] {
        let p = write(d, name, &utf16le(text, mark));
        let e = message(recording::read(&p));
        assert!(e.contains(name) && e.contains("line 1"), "{e}");
        assert!(e.contains("UTF-16LE text, not UTF-8"), "{e}");
        assert!(e.contains("iconv -f UTF-16LE -t UTF-8"), "{e}");
    }
    let layout = String::from_utf8(fixture("forearm/layout.json")).unwrap();
    let p = write(d, "layout.json", &utf16le(&layout, true));
    let e = message(native::read_layout(&p));
    assert!(e.contains("UTF-16LE") && e.contains("iconv"), "{e}");
}

#[test]
fn latin1_files_are_named_with_the_line_and_the_conversion() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // "é" in Latin-1 on line 3, column 5.
    let p = write(d, "rec.txt", b"16 17\n0 0.0 1 2\n1 0.\xe9 1 2\n");
    let e = message(recording::read(&p));
    assert!(e.contains("rec.txt: line 3, column 5"), "{e}");
    assert!(e.contains("byte 0xE9 is not UTF-8"), "{e}");
    assert!(e.contains("iconv -f latin1 -t utf-8"), "{e}");
    assert!(e.contains("rec.utf8.txt"), "{e}");

    let p = write(
        d,
        "layout.json",
        b"{\n  \"format\": \"skin-layout/1\",\n  \"links\": [{\"name\": \"b\xe4r\"}]\n}\n",
    );
    let e = message(native::read_layout(&p));
    assert!(e.contains("layout.json: line 3, column 24"), "{e}");
    assert!(e.contains("iconv -f latin1"), "{e}");
}

#[test]
fn cr_only_and_mixed_line_ends_read_as_lines() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let rec = String::from_utf8(fixture("forearm/touches.txt")).unwrap();
    let plain = recording::read(&write(d, "r.txt", rec.as_bytes())).unwrap();
    let mac = rec.replace('\n', "\r");
    assert_eq!(
        recording::read(&write(d, "mac.txt", mac.as_bytes())).unwrap(),
        plain
    );
    let mixed: String = rec
        .split_inclusive('\n')
        .enumerate()
        .map(|(i, l)| match i % 3 {
            0 => l.to_string(),
            1 => l.replace('\n', "\r\n"),
            _ => l.replace('\n', "\r"),
        })
        .collect();
    assert_eq!(
        recording::read(&write(d, "mixed.txt", mixed.as_bytes())).unwrap(),
        plain
    );
    // An error in a CR-only file names the line an editor shows.
    let e = message(recording::read(&write(
        d,
        "bad.txt",
        b"16 17\r0 0.0 1 2\r1 0.1 1 x\r",
    )));
    assert!(e.contains("bad.txt: line 3 field 4"), "{e}");

    let icub_plain = icub::read(
        &write(d, "a.txt", icub_text("\n").as_bytes()),
        icub::Duplicates::Merge,
    )
    .unwrap();
    let icub_mac = icub::read(
        &write(d, "b.txt", icub_text("\r").as_bytes()),
        icub::Duplicates::Merge,
    )
    .unwrap();
    assert_eq!(icub_mac, icub_plain);

    let layout = String::from_utf8(fixture("forearm/layout.json")).unwrap();
    let plain = native::read_layout(&write(d, "l.json", layout.as_bytes())).unwrap();
    let mac = native::read_layout(&write(d, "m.json", layout.replace('\n', "\r").as_bytes())).unwrap();
    assert_eq!(mac, plain);
}

#[test]
fn crlf_tabs_and_trailing_spaces_keep_working() {
    let dir = tempfile::tempdir().unwrap();
    let rec = recording::read(&write(
        dir.path(),
        "r.txt",
        b"16\t17 \r\n0\t0.0\t1 2  \r\n\r\n1 0.5 3\t4\t\r\n",
    ))
    .unwrap();
    assert_eq!(rec.taxel_ids, [TaxelId(16), TaxelId(17)]);
    assert_eq!(rec.frames[1].values, [3.0, 4.0]);
}

#[test]
fn binary_data_is_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let png = b"\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR\x00\x00";
    let e = message(recording::read(&write(dir.path(), "touch.png", png)));
    assert!(
        e.contains("touch.png: line 3: a NUL byte: binary data, not a text file"),
        "{e}"
    );
    let e = message(native::read_layout(&write(dir.path(), "l.json", png)));
    assert!(e.contains("binary data"), "{e}");
}

#[test]
fn a_folder_is_named_as_a_folder() {
    let dir = tempfile::tempdir().unwrap();
    for e in [
        message(recording::read(dir.path())),
        message(native::read_layout(dir.path())),
        message(read_text(dir.path())),
    ] {
        assert!(e.contains("a folder, not a file"), "{e}");
    }
}

/// An endless input of one byte, counting what was read from it.
struct Endless {
    byte: u8,
    read: u64,
}

impl Read for Endless {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        buf.fill(self.byte);
        self.read += buf.len() as u64;
        Ok(buf.len())
    }
}

#[test]
fn an_endless_input_without_line_ends_fails_after_a_bounded_read() {
    // /dev/zero: binary from its first byte.
    let mut zeros = BufReader::new(Endless { byte: 0, read: 0 });
    let mut lines = Lines::new(&mut zeros, Path::new("/dev/zero"));
    let e = lines.next_line().unwrap_err().to_string();
    assert!(
        e.contains("/dev/zero: line 1") && e.contains("binary data"),
        "{e}"
    );
    assert!(
        zeros.get_ref().read <= 1 << 16,
        "{} bytes read",
        zeros.get_ref().read
    );

    // A 2 GB line of text: refused once the bound is passed.
    let mut text = BufReader::new(Endless { byte: b'7', read: 0 });
    let mut lines = Lines::new(&mut text, Path::new("one-line.txt"));
    let e = lines.next_line().unwrap_err().to_string();
    assert!(
        e.contains("one-line.txt: line 1: more than 1.0 MiB without a line end"),
        "{e}"
    );
    let read = text.get_ref().read;
    assert!(read <= (MAX_LINE_BYTES + (1 << 16)) as u64, "{read} bytes read");

    // Through a recording reader, the same (after a header line).
    let header = std::io::Cursor::new(b"16 17\n".to_vec()).chain(Endless { byte: b'1', read: 0 });
    let mut rec = recording::RecordingReader::new(BufReader::new(header), Path::new("r.txt")).unwrap();
    let e = rec.next_frame().unwrap_err().to_string();
    assert!(e.contains("r.txt: line 2: more than"), "{e}");
}

#[cfg(unix)]
#[test]
fn a_device_past_the_size_read_whole_is_refused_after_a_bounded_read() {
    // /dev/zero has no size: it is read up to the limit, then refused.
    let e = message(read_document(Path::new("/dev/zero"), 1 << 20));
    assert!(e.contains("/dev/zero: size: more than the 1.0 MiB"), "{e}");
    assert!(
        e.contains("a device or a pipe has no size, so 1.0 MiB were read"),
        "{e}"
    );
    let e = message(native::read_layout(Path::new("/dev/zero")));
    assert!(e.contains("more than the 64.0 MiB"), "{e}");
}

#[cfg(unix)]
#[test]
fn a_pipe_read_twice_is_refused_instead_of_waiting_forever() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("layout.json");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let writer = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::write(fifo, fixture("forearm/layout.json")).unwrap())
    };
    // Read once, as any file.
    assert_eq!(native::read_layout(&fifo).unwrap().links.len(), 1);
    writer.join().unwrap();
    // Again: the writer is gone, and opening it would wait for another forever.
    let e = message(native::read_layout(&fifo));
    assert!(
        e.contains("layout.json: file: a pipe, already read to its end"),
        "{e}"
    );
}

#[test]
fn a_file_past_the_size_read_whole_is_refused_before_it_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("huge.json");
    // Sparse: no disk, and reading it would take a while; it is refused by its size.
    let f = std::fs::File::create(&p).unwrap();
    f.set_len(MAX_DOCUMENT_BYTES + (1 << 20)).unwrap();
    for e in [
        message(native::read_layout(&p)),
        message(load_link(&p)),
        message(Postures::read(&p)),
    ] {
        assert!(
            e.contains("huge.json: size: 65.0 MiB, more than the 64.0 MiB"),
            "{e}"
        );
    }
}

/// The lines of `text` as an editor shows them: split at CRLF, LF or CR, a byte-order mark first
/// skipped, no line after a final line end.
fn reference_lines(text: &str) -> Vec<String> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut out = Vec::new();
    let mut line = String::new();
    let mut chars = text.chars().peekable();
    let mut open = false;
    while let Some(c) = chars.next() {
        match c {
            '\r' | '\n' => {
                if c == '\r' && chars.peek() == Some(&'\n') {
                    chars.next();
                }
                out.push(std::mem::take(&mut line));
                open = false;
            }
            c => {
                line.push(c);
                open = true;
            }
        }
    }
    if open {
        out.push(line);
    }
    out
}

mod fuzz {
    use super::*;
    use proptest::prelude::*;

    fn read_all(bytes: &[u8], cap: usize, max: usize) -> skin_core::Result<Vec<String>> {
        let mut lines = Lines::new(BufReader::with_capacity(cap, bytes), Path::new("x")).with_max_line(max);
        let mut out = Vec::new();
        while let Some(l) = lines.next_line()? {
            out.push(l.text().to_owned());
        }
        Ok(out)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        /// Arbitrary bytes through every buffer size: lines or one error, never a panic, and no
        /// line past the bound.
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300), cap in 1usize..20) {
            if let Ok(lines) = read_all(&bytes, cap, 64) {
                prop_assert!(lines.iter().all(|l| l.len() <= 64));
            }
            let _ = recording::RecordingReader::new(BufReader::with_capacity(cap, &bytes[..]), Path::new("x"))
                .and_then(recording::RecordingReader::into_recording);
            let _ = icub::from_reader(&bytes[..], Path::new("x"), icub::Duplicates::Merge);
        }

        /// Text with every kind of line end, through every buffer size: the lines an editor shows.
        #[test]
        fn lines_are_split_as_an_editor_shows_them(
            text in "[a \\t\\r\\n\u{e9}\u{feff}]{0,60}",
            cap in 1usize..12,
        ) {
            // A byte-order mark is skipped only at the very start; elsewhere it is a character.
            prop_assert_eq!(read_all(text.as_bytes(), cap, MAX_LINE_BYTES).unwrap(), reference_lines(&text));
        }

        /// A document read whole: whatever the bytes, text or one error, never a panic.
        #[test]
        fn arbitrary_documents_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..200)) {
            let dir = tempfile::tempdir().unwrap();
            let p = dir.path().join("d.json");
            std::fs::write(&p, &bytes).unwrap();
            if let Ok(text) = read_document(&p, 150) {
                // Lone CRs were made LFs: every CR left is a CRLF's.
                let b = text.as_bytes();
                prop_assert!((0..b.len()).all(|i| b[i] != b'\r' || b.get(i + 1) == Some(&b'\n')));
            }
        }
    }
}
