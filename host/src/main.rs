//! The `lrmcal` command.
fn main() {}
