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
    cli::catch_interrupt();
    let result = cli::check_paths(&args.command).and_then(|()| match &args.command {
        Command::Simulate(a) => cli::simulate::simulate(a, args.quiet),
        Command::Identify(a) => cli::identify::identify_command(a, args.quiet),
        Command::Run(a) => cli::run::run_command(a, args.quiet),
        Command::Diagnose(a) => cli::diagnose::diagnose_command(a, args.quiet),
        Command::Import(a) => cli::import::import_command(a, args.quiet),
        Command::Validate(a) => cli::validate::validate_command(a, args.quiet),
        Command::IdentifyPoints(a) => cli::points::identify_points_command(a, args.quiet),
    });
    match result {
        Ok(code) => ExitCode::from(code),
        Err(_) if cli::INTERRUPTED.load(std::sync::atomic::Ordering::SeqCst) => {
            // the stages' files were dropped on the way out: no temporary
            // and no lock is left
            eprintln!("interrupted: stopped, nothing half-written left");
            ExitCode::from(cli::EXIT_INTERRUPTED)
        }
        Err(e) => {
            eprintln!("error: {}", hystid::error::one_line(e.as_ref()));
            ExitCode::from(2)
        }
    }
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    #[test]
    fn cli_definition_is_consistent() {
        super::cli::args::Cli::command().debug_assert();
    }
}
