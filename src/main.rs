//! The `advise` command line: a thin layer over the library. Each subcommand parses its
//! arguments, calls one library function, and renders errors as miette diagnostics.

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "advise",
    version,
    about = "Teach a robot's motion controller by critiquing and advising its executions"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    match cli.command {
        None => {
            println!("advise: the operator checker lands with the language issue");
            std::process::ExitCode::SUCCESS
        }
        Some(c) => match c {},
    }
}
