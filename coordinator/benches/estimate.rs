//! `cargo bench -p farm-coordinator --bench estimate`: what a finished
//! film's error estimate costs, per pass over a 2048×2048 film of noisy
//! pixels (Halton-like halves: the sequence's two halves of 8 samples),
//! with a sprinkle of fireflies. Prints the fastest of 7 runs of each
//! pass in milliseconds, and a checksum of what each computed, so that two
//! builds can be compared for speed and for bits.

use farm_common::film::{HalfImages, Pixel};
use farm_common::rng::Rng;
use farm_coordinator::estimate::{levelled_errors, suspects};
use std::time::Instant;

const SIDE: usize = 2048;
const RUNS: usize = 7;

fn film() -> Vec<Pixel> {
    let mut rng = Rng::new(11);
    (0..SIDE * SIDE)
        .map(|i| {
            let mut u = || rng.uniform_f32();
            let w = 8.0 + u();
            let w_b = 4.0 + 0.5 * u();
            // A smooth gradient with noise, a firefly in every 997 pixels.
            let base = (i % SIDE) as f32 / SIDE as f32 + 0.1;
            let fire = if i % 997 == 0 { 500.0 } else { 1.0 };
            let c = [base, 0.5 * base, 0.25];
            let noise = |c: f32, u: f32| c * (0.8 + 0.4 * u);
            // The firefly is a sample of the second half alone.
            let second = c.map(|c| w_b * noise(c, u()) * fire);
            let first = c.map(|c| (w - w_b) * noise(c, u()));
            Pixel {
                contrib: std::array::from_fn(|k| first[k] + second[k]),
                weight: w,
                second_contrib: second,
                second_weight: w_b,
            }
        })
        .collect()
}

fn fastest<T>(mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..RUNS {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (1e3 * best, out.expect("at least one run"))
}

fn main() {
    let film = film();
    let pixel = |i: usize| film[i];
    let size = (SIDE, SIDE);
    let (t_suspects, s) = fastest(|| suspects(size, pixel, 1.0, 16));
    let (t_levelled, errors) =
        fastest(|| levelled_errors(size, pixel, 1.0, HalfImages::Sequence, &s.fireflies));
    let sum: f64 = errors.iter().filter(|e| !e.is_nan()).sum();
    let bits = errors.iter().fold(0u64, |h, e| h.rotate_left(5) ^ e.to_bits());
    println!("error estimate of a {SIDE}×{SIDE} film, fastest of {RUNS} runs");
    println!(
        "{:>12} {:>12} {:>10} {:>10} {:>18}",
        "suspects ms", "levelled ms", "fireflies", "edges", "errors' bits"
    );
    println!(
        "{t_suspects:>12.1} {t_levelled:>12.1} {:>10} {:>10} {bits:>18x}  (sum {sum:.6e})",
        s.fireflies.len(),
        s.edges.len()
    );
}
