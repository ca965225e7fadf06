//! Seeds derived from seeds: the hash behind every evaluation and test-set
//! seed, and the trainer's random stream of each worker process.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// A well-mixed 64-bit hash (splitmix64), used to derive evaluation seeds.
///
/// ```
/// use fmsr_core::seeding::splitmix64;
/// assert_eq!(splitmix64(0), 0xE220_A839_7B1D_CDAF); // SplitMix64's first output from seed 0
/// assert_ne!(splitmix64(1), splitmix64(2));
/// ```
#[must_use]
pub fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// The trainer's random stream of worker `rank` (worker 0: the single-process one).
pub(crate) fn rank_rng(seed: u64, rank: usize) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(rank as u64);
    rng
}
