//! The parsers' fuzz invariants in `cargo test`: 2,000 mutated inputs per
//! format through the readers the commands use (`.ci/run` runs 10⁵ per
//! format with `examples/fuzz_parsers.rs`).

use host::fuzz::{self, Corpus, Counts, Format};

const SEED: u64 = 16;
const INPUTS: u64 = 2_000;

#[test]
fn mutated_files_are_read_or_refused_naming_file_and_place() {
    let corpus = Corpus::new().expect("the corpus is valid");
    let dir = fuzz::scratch_dir().expect("a temporary directory");
    for format in Format::ALL {
        let mut counts = Counts::default();
        if let Err((index, violation)) =
            fuzz::run(&corpus, format, SEED, 0..INPUTS, dir.path(), &mut counts)
        {
            panic!(
                "{} input {index}: {violation}\nreplay: cargo run --release -p host --example \
                 fuzz_parsers -- --seed {SEED} --case {}:{index}",
                format.name(),
                format.name()
            );
        }
        assert_eq!(counts.inputs, INPUTS);
        // The mutations reach past the syntax: some inputs are still valid
        // files, most are refused, with a line or key.
        let refused = counts.line_and_field + counts.line_only + counts.field_only;
        assert!(
            counts.accepted > INPUTS / 50 && refused > INPUTS / 2,
            "{}: {counts:?}",
            format.name()
        );
    }
}
