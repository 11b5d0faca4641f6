//! libFuzzer target: the input is what arrives on the serial line. Every
//! frame in it (cut at each 0x00) goes through the frame reader, the decoder
//! and the handler of a board, with a servo frame after each, and every
//! invariant of `firmware::fuzz` is checked; a broken one is a crash.
#![no_main]

use std::sync::OnceLock;

use firmware::fuzz::{self, Case, Counts, Fixtures, Step};
use libfuzzer_sys::fuzz_target;

static FIXTURES: OnceLock<Fixtures> = OnceLock::new();

fuzz_target!(|data: &[u8]| {
    let fixtures = FIXTURES.get_or_init(Fixtures::new);
    // The first byte picks the calibration in flash at power-on.
    let Some((&first, line)) = data.split_first() else {
        return;
    };
    let valid = fixtures.valid();
    let preload = valid.get(usize::from(first) % (valid.len() + 1)).copied();
    let steps = line
        .split_inclusive(|&b| b == 0)
        .flat_map(|frame| [Step::Bytes(frame.to_vec()), Step::Frames(1)])
        .collect();
    let case = Case { preload, steps };
    if let Err(violation) = fuzz::run(fixtures, &case, &mut Counts::default()) {
        panic!("{violation}");
    }
});
