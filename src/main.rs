//! The `hystid` binary: a thin layer over the library (see `cli`).

mod cli;

use clap::Parser;
use cli::args::{Cli, Command};
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = Cli::parse();
    if let Some(n) = args.threads {
        // results do not depend on the thread count; only the speed does
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build_global();
    }
    let result = match &args.command {
        Command::Simulate(a) => cli::simulate::simulate(a, args.quiet),
        Command::Identify(a) => cli::identify::identify_command(a, args.quiet),
        Command::Run(a) => cli::run::run_command(a, args.quiet),
        Command::Diagnose(a) => cli::diagnose::diagnose_command(a, args.quiet),
        Command::Import(a) => cli::import::import_command(a, args.quiet),
        Command::Validate(a) => cli::validate::validate_command(a, args.quiet),
    };
    match result {
        Ok(code) => ExitCode::from(code),
        Err(e) => {
            eprintln!("error: {}", error_chain(&e));
            ExitCode::from(2)
        }
    }
}

/// The error and its causes on one line, each said once: a cause whose text
/// its parent already ends with (a file error that prints its own cause) is
/// not repeated, nor a path the parent has just named.
fn error_chain(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.ends_with(&text) {
            continue;
        }
        // "reducing X" followed by "X: why" reads "reducing X: why"
        let text = match out.rsplit_once(' ') {
            Some((_, last)) if !last.is_empty() => text
                .strip_prefix(last)
                .and_then(|t| t.strip_prefix(": "))
                .map(str::to_string)
                .unwrap_or(text),
            _ => text,
        };
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    #[test]
    fn cli_definition_is_consistent() {
        super::cli::args::Cli::command().debug_assert();
    }
}
