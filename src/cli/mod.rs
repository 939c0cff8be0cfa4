//! Command-line parsing (clap) and dispatch; one file per subcommand.

mod convert;
mod info;

use clap::{Parser, Subcommand};

/// OctoMap-compatible occupancy mapping, fast.
#[derive(Parser)]
#[command(name = "octoquant", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Summarise a .bt or .ot map: resolution, nodes, leaves, bounds, bytes per node.
    Info(info::Args),
    /// Convert between .bt and .ot (by extension).
    Convert(convert::Args),
}

pub fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Info(a)) => info::run(&a),
        Some(Command::Convert(a)) => convert::run(&a),
        None => {
            eprintln!("octoquant: no command given; try `octoquant --help`");
            Ok(())
        }
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("octoquant: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
