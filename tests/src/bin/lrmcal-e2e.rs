//! `lrmcal` itself, built as a binary of package `e2e` for the emulated-board tests that run
//! the CLI as a process: Ctrl-C at a terminal, `servo-tune` in a pseudo-terminal.

fn main() -> std::process::ExitCode {
    host::main_impl()
}
