//! Bounded-time mutation fuzzing of every parser that reads user bytes (cargo-fuzz needs a
//! nightly toolchain; this harness runs on stable, in CI, for a few seconds per target).
//!
//! For each target: the regression corpus in `tests/fuzz_corpus/<target>/` is replayed, then
//! random mutations of the seeds (bit flips, interesting bytes and integers, insertions,
//! deletions, duplications, truncations, splices, and text tokens for the text parsers) run
//! until the time budget is spent.  A target fails on a panic (the input is saved to
//! `target/fuzz-crashes/`; add it to the corpus once fixed) or on an input that takes longer
//! than 10 s.  Returning an `Err` is the expected answer to garbage.
//!
//! Budget: `SPHEREMAP_FUZZ_SECONDS` per target (default 2); `SPHEREMAP_FUZZ_SEED` picks the
//! random stream.  Long runs: `SPHEREMAP_FUZZ_SECONDS=600 cargo test --release --test fuzz`.

use spheremap::images::codec::{self, Limits, ReadOptions, WriteOptions};
use spheremap::images::cube_layout::Layout;
use spheremap::images::format::Format;
use spheremap::images::Image;
use spheremap::resample::Filter;
use spheremap::trace::scene::Scene;
use spheremap::Mapping;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

mod common;
use common::GLTF_TRIANGLE as GLTF_SEED;

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        if n == 0 {
            0
        } else {
            (self.next() % n as u64) as usize
        }
    }
}

const NUMBERS: &[&str] = &[
    "0",
    "1",
    "2",
    "3",
    "4",
    "5",
    "6",
    "7",
    "8",
    "12",
    "36",
    "42",
    "255",
    "5120",
    "5121",
    "5122",
    "5123",
    "5125",
    "5126",
    "34962",
    "34963",
    "65535",
    "65536",
    "2147483647",
    "4294967295",
    "18446744073709551615",
    "1e9",
    "0.5",
    "1e38",
    "99999999999",
];

const TOKENS: &[&str] = &[
    "nan",
    "inf",
    "-inf",
    "1e309",
    "-0",
    "0",
    "1",
    "-1",
    "4294967296",
    ",",
    " ",
    "\n",
    "lookat:",
    "identity",
    "f ",
    "v ",
    "vt ",
    "vn ",
    "usemtl ",
    "mtllib ",
    "/",
    "//",
    "-2147483648",
    "{",
    "}",
    "\"",
    ":",
    "[",
    "]",
    "null",
    "1e-45",
    "65536",
    "hcross",
    "cube",
    "sphere",
    "latlong",
];

/// How a target's inputs are mutated.
#[derive(Clone, Copy, PartialEq)]
enum Mode {
    Binary,
    Text,
    /// Mostly number swaps, which keep JSON valid so the reader goes past the parser.
    Json,
}

fn mutate(rng: &mut Rng, seeds: &[Vec<u8>], mode: Mode) -> Vec<u8> {
    let mut d = seeds[rng.below(seeds.len())].clone();
    let numbers_only = mode == Mode::Json && rng.below(4) != 0;
    for _ in 0..1 + rng.below(4) {
        let n = d.len();
        let op = match mode {
            _ if numbers_only => 10,
            Mode::Binary => rng.below(9),
            _ => rng.below(12),
        };
        match op {
            0 if n > 0 => {
                let i = rng.below(n);
                d[i] ^= 1 << rng.below(8);
            }
            1 if n > 0 => {
                let i = rng.below(n);
                d[i] = [0u8, 0xff, 0x7f, 0x80, b'0', b'-'][rng.below(6)];
            }
            2 if n >= 4 => {
                let i = rng.below(n - 3);
                let v: u32 = [
                    0,
                    1,
                    0xffff_ffff,
                    0x7fff_ffff,
                    0x8000_0000,
                    65_536,
                    0x10_0000,
                ][rng.below(7)];
                let b = if rng.below(2) == 0 {
                    v.to_le_bytes()
                } else {
                    v.to_be_bytes()
                };
                d[i..i + 4].copy_from_slice(&b);
            }
            3 => {
                let i = rng.below(n + 1);
                let k = 1 + rng.below(16);
                let bytes: Vec<u8> = (0..k).map(|_| rng.next() as u8).collect();
                d.splice(i..i, bytes);
            }
            4 if n > 0 => {
                let i = rng.below(n);
                let k = 1 + rng.below((n - i).min(64));
                d.drain(i..i + k);
            }
            5 if n > 0 => {
                let i = rng.below(n);
                let k = 1 + rng.below((n - i).min(64));
                let chunk = d[i..i + k].to_vec();
                let j = rng.below(n + 1);
                d.splice(j..j, chunk);
            }
            6 if n > 0 => d.truncate(rng.below(n)),
            7 => {
                let other = &seeds[rng.below(seeds.len())];
                let (i, j) = (rng.below(n + 1), rng.below(other.len() + 1));
                d.truncate(i);
                d.extend_from_slice(&other[j..]);
            }
            8 if n > 0 => {
                // Repeat a byte run (long lines, deep nesting).
                let i = rng.below(n);
                let b = d[i];
                let k = 1 + rng.below(512);
                d.splice(i..i, std::iter::repeat_n(b, k));
            }
            9 => {
                let i = rng.below(n + 1);
                let t = TOKENS[rng.below(TOKENS.len())].as_bytes().to_vec();
                d.splice(i..i, t);
            }
            // Structure-preserving: replace a number with another (indices, counts, offsets
            // and sizes of a glTF stay syntactically valid, so the reader goes deep).
            10 | 11 if n > 0 => {
                let start = rng.below(n);
                if let Some(a) = (start..n).find(|&k| d[k].is_ascii_digit()) {
                    let b = (a..n).find(|&k| !d[k].is_ascii_digit()).unwrap_or(n);
                    let v = NUMBERS[rng.below(NUMBERS.len())].as_bytes().to_vec();
                    d.splice(a..b, v);
                }
            }
            _ => {}
        }
    }
    d
}

struct Target {
    name: &'static str,
    mode: Mode,
    seeds: Vec<Vec<u8>>,
    run: fn(&[u8]),
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn crash_dir() -> PathBuf {
    root().join("target/fuzz-crashes")
}

/// Replays the corpus, then fuzzes for `budget`; returns (executions, failures).
fn fuzz(t: &Target, budget: Duration, seed: u64) -> (u64, Vec<String>) {
    let mut failures = Vec::new();
    let mut execs = 0u64;
    let mut seeds = t.seeds.clone();
    let corpus = root().join("tests/fuzz_corpus").join(t.name);
    if let Ok(rd) = std::fs::read_dir(&corpus) {
        let mut files: Vec<PathBuf> = rd.flatten().map(|e| e.path()).collect();
        files.sort();
        for p in files {
            if let Ok(b) = std::fs::read(&p) {
                seeds.push(b);
            }
        }
    }
    let name_hash = t
        .name
        .bytes()
        .fold(0u64, |h, b| h.wrapping_mul(31).wrapping_add(b as u64));
    let mut rng = Rng(seed ^ name_hash.wrapping_mul(0x1234_5678_9ABC));
    let start = Instant::now();
    let mut i = 0usize;
    loop {
        // Every seed as is first, then mutations.
        let data = if i < seeds.len() {
            seeds[i].clone()
        } else {
            mutate(&mut rng, &seeds, t.mode)
        };
        i += 1;
        let t0 = Instant::now();
        let r = std::panic::catch_unwind(|| (t.run)(&data));
        let dt = t0.elapsed();
        execs += 1;
        let why = match r {
            Err(_) => Some("panic"),
            Ok(()) if dt > Duration::from_secs(10) => Some("slow"),
            Ok(()) => None,
        };
        if let Some(why) = why {
            let h = data.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
                (h ^ *b as u64).wrapping_mul(0x100_0000_01b3)
            });
            let p = crash_dir().join(format!("{}-{why}-{h:016x}.bin", t.name));
            let _ = std::fs::create_dir_all(crash_dir());
            let _ = std::fs::write(&p, &data);
            failures.push(format!(
                "{why} ({:.1} s): {}",
                dt.as_secs_f64(),
                p.display()
            ));
            if failures.len() > 20 {
                break;
            }
        }
        if i >= seeds.len() && start.elapsed() >= budget {
            break;
        }
    }
    (execs, failures)
}

/// Images: small limits so a fuzzed header cannot ask for gigabytes (the limit check is part
/// of what is fuzzed).
fn run_image(data: &[u8]) {
    let opts = ReadOptions {
        linear: false,
        limits: Limits {
            max_width: 2048,
            max_height: 2048,
            max_pixels: 1 << 20,
        },
    };
    for name in ["fuzz.exr", "fuzz.png", "fuzz"] {
        if let Ok(img) = codec::decode(Path::new(name), data, &opts) {
            assert_eq!(img.data.len(), img.width * img.height * img.channels);
        }
    }
    // spheremap's note in the file's header (crate::images::note), and its parse.
    if let Some(t) = spheremap::images::note::read(data) {
        let _ = spheremap::images::note::MapNote::parse(&t);
    }
}

/// OBJ, or OBJ + MTL when the input holds a line `#MTL` (the MTL follows it).
fn run_obj(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let _ = spheremap::mesh::parse_obj("fuzz.obj", &text);
    let split = data.windows(6).position(|w| w == b"\n#MTL\n");
    let (obj, mtl) = match split {
        Some(i) => (&data[..i], Some(&data[i + 6..])),
        None => (data, None),
    };
    if let Ok(s) = Scene::load_obj_bytes("fuzz.obj", obj, mtl) {
        let _ = s.radiance([0.0; 3], [0.0, 0.0, -1.0]);
    }
}

fn run_gltf(data: &[u8]) {
    if let Ok(s) = Scene::load_bytes("fuzz.gltf", data) {
        let _ = s.radiance([0.0, 1.0, 0.0], [0.0, -1.0, 0.0]);
    }
}

fn run_text(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    let _ = spheremap::base::parse::parse_matrix4(&text, false, "m");
    let _ = spheremap::base::parse::parse_matrix4(&text, true, "m");
    if let Ok(v) = spheremap::base::parse::parse_numbers(&text, "v") {
        if v.len() >= 6 {
            let _ = spheremap::frame::view::look_up([v[0], v[1], v[2]], [v[3], v[4], v[5]]);
            let _ = spheremap::frame::view::yaw_pitch_roll(v[0], v[1], v[2]);
        }
    }
    let _ = Layout::parse(&text);
    let mut parts = text.splitn(2, ':');
    let (m, p) = (parts.next().unwrap_or(""), parts.next());
    let _ = Mapping::parse(m, p);
    let _ = Filter::parse(&text);
    let _ = spheremap::images::envmap::env_paths(&text);
    if let Some(t) = spheremap::images::note::MapNote::parse(&text) {
        assert_eq!(spheremap::images::note::MapNote::parse(&t.text()), Some(t));
    }
}

fn image_seeds() -> Vec<Vec<u8>> {
    let mut img = Image::new(5, 3, 3);
    for (i, v) in img.data.iter_mut().enumerate() {
        *v = (i as f32 * 0.37).sin().abs() * 2.0;
    }
    let mut grey = Image::new(4, 4, 1);
    grey.data
        .iter_mut()
        .enumerate()
        .for_each(|(i, v)| *v = i as f32 / 16.0);
    let mut seeds = Vec::new();
    for (f, o) in [
        (Format::Exr, WriteOptions::default()),
        (
            Format::Exr,
            WriteOptions {
                half: true,
                ..Default::default()
            },
        ),
        (Format::Hdr, WriteOptions::default()),
        (Format::Pfm, WriteOptions::default()),
        (Format::Png, WriteOptions::default()),
        (
            Format::Png,
            WriteOptions {
                png16: true,
                ..Default::default()
            },
        ),
        (Format::Jpeg, WriteOptions::default()),
    ] {
        for im in [&img, &grey] {
            if let Ok(b) = codec::encode(Path::new("seed"), im, f, &o) {
                seeds.push(b);
            }
        }
        // The same with spheremap's note (crate::images::note) in the header.
        let note = "mapping=cube preset=d3d layout=vcross look=0.5,0,-1 up=0,1,0";
        if let Ok(b) = codec::encode_with_note(Path::new("seed"), &img, f, &o, Some(note)) {
            seeds.push(b);
        }
    }
    if let Ok(b) = std::fs::read(root().join("testdata/matcap_0177.webp")) {
        seeds.push(b);
    }
    seeds
}

const OBJ_SEED: &str = "v 0 0 -1\nv 1 0 -1\nv 0 1 -1\nv 1 1 -1\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\n\
f 1/1/1 2/2/1 3/3/1\nf 2 4 3\ng g\nusemtl m\nf -1 -2 -3\n";

const MTL_SEED: &str = "newmtl m\nKe 1 0.5 0\nKd 0.2 0.3 0.4\nKs 1 1 1\nillum 3\n\
newmtl n\nKd 0.5 0.5 0.5\nd 1\nNs 10\n";

fn targets() -> Vec<Target> {
    vec![
        Target {
            name: "image",
            mode: Mode::Binary,
            seeds: image_seeds(),
            run: run_image,
        },
        Target {
            name: "obj",
            mode: Mode::Text,
            seeds: vec![
                OBJ_SEED.as_bytes().to_vec(),
                format!("mtllib m.mtl\n{OBJ_SEED}\n#MTL\n{MTL_SEED}").into_bytes(),
            ],
            run: run_obj,
        },
        Target {
            name: "gltf",
            mode: Mode::Json,
            seeds: vec![GLTF_SEED.as_bytes().to_vec()],
            run: run_gltf,
        },
        Target {
            name: "text",
            mode: Mode::Text,
            seeds: [
                "identity",
                "1 0 0 0, 0 1 0 0, 0 0 1 0, 0 0 0 1",
                "lookat:0,12,40,0,0,0,0,1,0",
                "0 0 -1 0 1 0",
                "hcross",
                "latlong:blender",
                "sphere:skylibs",
                "sky_{face}.exr",
                "gaussian",
                "mapping=sphere preset=skylibs face=px layout=dice look=1,0,0 up=0,1,0",
            ]
            .iter()
            .map(|s| s.as_bytes().to_vec())
            .collect(),
            run: run_text,
        },
    ]
}

#[test]
fn fuzz_every_parser() {
    let seconds: f64 = std::env::var("SPHEREMAP_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2.0);
    let seed: u64 = std::env::var("SPHEREMAP_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let only = std::env::var("SPHEREMAP_FUZZ_TARGET").ok();
    // Panics are expected to be caught here; keep their messages short.
    std::panic::set_hook(Box::new(|info| {
        if !spheremap::base::error::panic_is_guarded() {
            eprintln!("fuzz: panic: {info}")
        }
    }));
    let mut all = Vec::new();
    for t in targets() {
        if only.as_deref().is_some_and(|o| o != t.name) {
            continue;
        }
        let (n, f) = fuzz(&t, Duration::from_secs_f64(seconds), seed);
        eprintln!("fuzz {}: {n} inputs, {} failures", t.name, f.len());
        all.extend(f.into_iter().map(|s| format!("{}: {s}", t.name)));
    }
    let _ = std::panic::take_hook();
    assert!(all.is_empty(), "fuzz failures:\n{}", all.join("\n"));
}

/// The seeds are valid inputs (so mutations start deep inside each parser).
#[test]
fn fuzz_seeds_parse() {
    assert_eq!(
        Scene::load_bytes("seed.gltf", GLTF_SEED.as_bytes())
            .unwrap()
            .triangle_count(),
        1
    );
    assert_eq!(
        Scene::load_bytes("seed.obj", OBJ_SEED.as_bytes())
            .unwrap()
            .triangle_count(),
        3
    );
    let with_mtl = format!("mtllib m.mtl\n{OBJ_SEED}");
    let s =
        Scene::load_obj_bytes("seed.obj", with_mtl.as_bytes(), Some(MTL_SEED.as_bytes())).unwrap();
    assert_eq!(s.materials.len(), 3);
    let opts = ReadOptions::default();
    let seeds = image_seeds();
    assert!(seeds.len() >= 14);
    for s in &seeds {
        codec::decode(Path::new("seed"), s, &opts).unwrap();
    }
}
