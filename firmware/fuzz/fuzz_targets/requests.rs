//! libFuzzer target: the input drives the generator of request sequences
//! (requests, uploads, servo frames, power cuts, reboots), as the campaign's
//! random numbers do; every invariant of `firmware::fuzz` is checked after
//! every step, and a broken one is a crash.
#![no_main]

use std::sync::OnceLock;

use firmware::fuzz::{self, Counts, Fixtures};
use libfuzzer_sys::fuzz_target;

static FIXTURES: OnceLock<Fixtures> = OnceLock::new();

fuzz_target!(|data: &[u8]| {
    let fixtures = FIXTURES.get_or_init(Fixtures::new);
    // Eight input bytes per word; zeros once the input runs out, which ends the case.
    let mut words = data.chunks(8);
    let mut src = || {
        let mut word = [0u8; 8];
        if let Some(chunk) = words.next() {
            word[..chunk.len()].copy_from_slice(chunk);
        }
        u64::from_le_bytes(word)
    };
    let case = fuzz::sequence_case(&mut src, fixtures);
    if let Err(violation) = fuzz::run(fixtures, &case, &mut Counts::default()) {
        panic!("{violation}");
    }
});
