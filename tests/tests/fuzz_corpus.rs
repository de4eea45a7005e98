//! Every fuzz target on its committed corpus (`fuzz/corpus/<target>/`) and
//! on a burst of seeded mutations of it: a short run of each target in
//! every `cargo test`. The long runs are `cargo fuzz run -s none <target>`.

use std::path::Path;
use std::time::{Duration, Instant};

/// xorshift64*: the same mutations on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// One mutation: flip, set, insert, delete, duplicate or truncate.
fn mutate(seed: &[u8], rng: &mut Rng) -> Vec<u8> {
    let mut d = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(d.len() + 1);
        match rng.below(6) {
            0 if at < d.len() => d[at] ^= 1 << rng.below(8),
            1 if at < d.len() => {
                d[at] = [0, 0xff, b'-', b'9', b'[', b'"', b'\n', 0x80][rng.below(8)];
            }
            2 => d.insert(at, rng.next() as u8),
            3 if at < d.len() => drop(d.remove(at)),
            4 => {
                let end = (at + rng.below(64)).min(d.len());
                let piece = d[at..end].to_vec();
                d.splice(at..at, piece);
            }
            _ => d.truncate(at),
        }
    }
    d
}

fn run(target: &str, body: fn(&[u8]), mutations: usize) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/corpus").join(target);
    let mut seeds: Vec<Vec<u8>> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|f| std::fs::read(f.expect("entry").path()).expect("read seed"))
        .collect();
    seeds.sort();
    assert!(!seeds.is_empty(), "no corpus for {target}");
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15 ^ target.len() as u64);
    let start = Instant::now();
    for s in &seeds {
        body(s);
    }
    for i in 0..mutations {
        let m = mutate(&seeds[i % seeds.len()], &mut rng);
        body(&m);
    }
    // No input may hang: the whole burst takes seconds.
    assert!(start.elapsed() < Duration::from_secs(120), "{target} took {:?}", start.elapsed());
}

#[test]
fn scene_parser_survives_its_corpus_and_mutations() {
    run("scene", farm_tests::fuzz::scene, 50_000);
}

#[test]
fn ply_reader_survives_its_corpus_and_mutations() {
    run("ply", farm_tests::fuzz::ply, 200_000);
}

#[test]
fn image_readers_survive_their_corpus_and_mutations() {
    run("image", farm_tests::fuzz::image, 200_000);
}

#[test]
fn coordinator_message_decoding_survives_its_corpus_and_mutations() {
    run("messages", farm_tests::fuzz::messages, 200_000);
}
