//! The `lrmcal` command: everything lives in the library so tests can drive it.

fn main() -> std::process::ExitCode {
    host::main_impl()
}
