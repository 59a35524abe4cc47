//! The `panoconv` command; all work happens in the library, see `cli.rs` for the interface.

mod cli;

fn main() -> std::process::ExitCode {
    panoconv::run::alloc::keep_freed_memory();
    cli::main()
}
