//! The one random-number scheme of laydown: every random stream is a `ChaCha8Rng` keyed
//! by blake3("laydown-rng-v1" | seed | replicate) on stream `item`. The stages draw from
//! it ([`crate::stages::RunContext::rng`]), and so does the library API
//! ([`crate::rod::simulate`] takes `&mut stream_rng(seed, replicate, 0)`), so a replicate
//! computed with the library is the replicate the archive holds (see the crate docs for a
//! run reproduced bit for bit). A stream depends only on (seed, replicate, item), never on
//! the thread that draws it or the order of the draws: any number of threads, a Slurm task
//! or a library call computes the same replicate.
//!
//! Which items a stage uses: a laydown replicate and a spectra realisation draw from item
//! 0; a laid web's shared turbulence from item 0 and fibre j from item j + 1; a synthetic
//! image's seed is the first `u64` of item 0 of its sample's replicate. The stochastic web
//! regenerates fibre j of realisation k from its own stored `rng_seed`
//! ([`crate::stages::web::fibre_rng`]), so a grid can redraw any single fibre.
//!
//! ```
//! use laydown::rng::stream_rng;
//! use rand::RngCore;
//! let a = stream_rng(42, 3, 0).next_u64();
//! assert_eq!(a, stream_rng(42, 3, 0).next_u64()); // a pure function of (seed, replicate, item)
//! assert_ne!(a, stream_rng(42, 2, 0).next_u64()); // another replicate
//! assert_ne!(a, stream_rng(42, 3, 1).next_u64()); // another item
//! ```
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The scheme as stored with every stage version (provenance attribute `rng_scheme`).
pub const SCHEME: &str = "ChaCha8Rng (rand_chacha 0.9); key = blake3(\"laydown-rng-v1\" | seed u64 LE | replicate u64 LE), \
stream = item index within the replicate (stage-specific); sweep points share the replicate's stream (common random numbers)";

/// The random stream of `item` within `replicate` of a run seeded with `seed`:
/// ChaCha8Rng keyed by blake3("laydown-rng-v1" | seed | replicate), on stream `item`.
pub fn stream_rng(seed: u64, replicate: u64, item: u64) -> ChaCha8Rng {
    let mut h = blake3::Hasher::new();
    h.update(b"laydown-rng-v1");
    h.update(&seed.to_le_bytes());
    h.update(&replicate.to_le_bytes());
    let mut rng = ChaCha8Rng::from_seed(*h.finalize().as_bytes());
    rng.set_stream(item);
    rng
}
