//! Decode + assemble throughput of skin16 traffic (4 buses x 64 modules, 200 cycles) and of icub8
//! traffic (4 buses x 64 triangles, 200 windows), and replays of the fixture logs (text parsing
//! included).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the bench

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use skin_can::candump::{CanFrame, CandumpLog};
use skin_can::decode::icub8::encode_triangle;
use skin_can::decode::skin16::{encode_module, encode_sync};
use skin_can::decode::{Icub8, Skin16};
use skin_can::{Assembler, BusMap};
use std::fmt::Write as _;
use std::path::Path;

fn four_buses() -> (BusMap, Vec<String>, Vec<CanFrame>) {
    let mut toml = String::from("format = \"skin16\"\n");
    let mut frames = Vec::new();
    let interfaces: Vec<String> = (0..4).map(|b| format!("can{b}")).collect();
    for (b, name) in interfaces.iter().enumerate() {
        let _ = write!(toml, "[[bus]]\ninterface = \"{name}\"\n");
        for m in 0..64u32 {
            let module = (b as u32) * 64 + m + 1;
            let taxels: Vec<String> = (0..12)
                .map(|c| {
                    if c < 11 {
                        ((module << 4) | c).to_string()
                    } else {
                        "-1".into()
                    }
                })
                .collect();
            let _ = write!(
                toml,
                "[[bus.module]]\naddress = {m}\ntaxels = [{}]\n",
                taxels.join(", ")
            );
        }
    }
    for c in 0..200u64 {
        for b in 0..4u16 {
            let t = c * 50_000;
            frames.push(encode_sync(c as u8, t, b));
            for m in 0..64u32 {
                let readings: [u16; 12] =
                    std::array::from_fn(|s| (c as u16).wrapping_mul(31).wrapping_add(s as u16));
                frames.extend(encode_module(m, &readings, t + 100, b));
            }
        }
    }
    (
        BusMap::parse(&toml, Path::new("bench.toml")).unwrap(),
        interfaces,
        frames,
    )
}

/// The same skin as icub8: triangles free-running at 50 ms, 300 µs apart on each bus.
fn four_buses_icub8() -> (BusMap, Vec<String>, Vec<CanFrame>) {
    let (skin16, interfaces, _) = four_buses();
    let toml = skin16
        .to_toml()
        .replacen("format = \"skin16\"", "format = \"icub8\"", 1);
    let mut frames = Vec::new();
    for c in 0..200u64 {
        for b in 0..4u16 {
            for m in 0..64u32 {
                let readings: [u8; 12] =
                    std::array::from_fn(|s| (c as u8).wrapping_mul(31).wrapping_add(s as u8));
                let t = c * 50_000 + 1_000 * u64::from(b) + 300 * u64::from(m);
                frames.extend(encode_triangle(m, &readings, 0, 0, t, b));
            }
        }
    }
    frames.sort_by_key(|f| f.time_us);
    (
        BusMap::parse(&toml, Path::new("bench.toml")).unwrap(),
        interfaces,
        frames,
    )
}

fn assemble(c: &mut Criterion) {
    let (map, interfaces, frames) = four_buses();
    let mut group = c.benchmark_group("skin16");
    group.throughput(Throughput::Elements(frames.len() as u64));
    group.bench_function("decode+assemble (4 buses x 64 modules, CAN frames)", |b| {
        b.iter(|| {
            let mut asm = Assembler::new(&map, &interfaces, Skin16);
            let mut n = 0u64;
            for f in &frames {
                asm.push(f, &mut |a| n += a.values.len() as u64);
            }
            asm.finish(&mut |a| n += a.values.len() as u64);
            n
        })
    });
    group.finish();

    let (map, interfaces, frames) = four_buses_icub8();
    let mut group = c.benchmark_group("icub8");
    group.throughput(Throughput::Elements(frames.len() as u64));
    group.bench_function("decode+assemble (4 buses x 64 triangles, CAN frames)", |b| {
        b.iter(|| {
            let mut asm = Assembler::windowed(&map, &interfaces, Icub8, 50_000);
            let mut n = 0u64;
            let mut complete = 0u64;
            for f in &frames {
                asm.push(f, &mut |a| {
                    n += a.values.len() as u64;
                    complete += u64::from(a.is_complete());
                });
            }
            asm.finish(&mut |a| {
                n += a.values.len() as u64;
                complete += u64::from(a.is_complete());
            });
            assert_eq!(complete, 200, "every window complete");
            n
        })
    });
    group.finish();

    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/forearm");
    let text = std::fs::read_to_string(root.join("touches.candump.log")).unwrap();
    let map = BusMap::read(&root.join("busmap.toml")).unwrap();
    c.bench_function("replay fixture log (6.45 s of traffic: parse + assemble)", |b| {
        b.iter(|| {
            let log = CandumpLog::parse(&text, Path::new("log")).unwrap();
            let mut asm = Assembler::new(&map, &log.interfaces, Skin16);
            let mut frames = 0u32;
            for f in &log.frames {
                asm.push(f, &mut |_| frames += 1);
            }
            asm.finish(&mut |_| frames += 1);
            frames
        })
    });
    let text = std::fs::read_to_string(root.join("touches.icub8.log")).unwrap();
    let map = BusMap::read(&root.join("busmap.icub8.toml")).unwrap();
    c.bench_function(
        "replay fixture icub8 log (6.5 s of traffic: parse + assemble)",
        |b| {
            b.iter(|| {
                let log = CandumpLog::parse(&text, Path::new("log")).unwrap();
                let mut asm = Assembler::windowed(&map, &log.interfaces, Icub8, 50_000);
                let mut complete = 0u32;
                for f in &log.frames {
                    asm.push(f, &mut |a| complete += u32::from(a.is_complete()));
                }
                asm.finish(&mut |a| complete += u32::from(a.is_complete()));
                assert_eq!(complete, 130);
                complete
            })
        },
    );
}

criterion_group!(benches, assemble);
criterion_main!(benches);
