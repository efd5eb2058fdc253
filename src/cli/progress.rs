//! Progress bars (indicatif), hidden when stderr is not a terminal, under CI,
//! or with `--quiet`.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

/// A progress bar over `total` items with a message.
pub fn bar(total: u64, message: &str, quiet: bool) -> ProgressBar {
    let pb = ProgressBar::new(total);
    if quiet || !std::io::stderr().is_terminal() || std::env::var_os("CI").is_some() {
        pb.set_draw_target(ProgressDrawTarget::hidden());
    }
    if let Ok(style) = ProgressStyle::with_template(
        "{msg:>12} [{bar:40}] {pos}/{len} {elapsed_precise} (eta {eta})",
    ) {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_message(message.to_string());
    pb
}

/// A spinner with a changing message (for iterative work of unknown length).
pub fn spinner(message: &str, quiet: bool) -> ProgressBar {
    let pb = ProgressBar::new_spinner();
    if quiet || !std::io::stderr().is_terminal() || std::env::var_os("CI").is_some() {
        pb.set_draw_target(ProgressDrawTarget::hidden());
    }
    pb.set_message(message.to_string());
    pb
}

/// The terminal's one observer: every stage's events drawn on `pb`
/// (a dwell advances the bar, a cost evaluation and the diagnosis's steps
/// set its message).
pub struct BarObserver<'a>(pub &'a ProgressBar);

impl hystid::observe::Observer for BarObserver<'_> {
    fn observe(&self, event: hystid::observe::Event<'_>) {
        use hystid::observe::DiagnoseEvent as D;
        use hystid::observe::Event;
        let pb = self.0;
        match event {
            Event::Dwell { .. } => pb.inc(1),
            Event::Cost(t) => {
                pb.set_message(format!("evaluation {}: cost {:.6e}", t.evaluation, t.cost));
                pb.tick();
            }
            Event::Diagnosis(D::Baseline { chi2_per_dof }) => {
                pb.set_message(format!("baseline chi2/dof {chi2_per_dof:.3}"))
            }
            Event::Diagnosis(D::Round { round, candidates }) => {
                pb.set_position(0);
                pb.set_length(*candidates as u64);
                pb.reset_eta();
                pb.set_message(format!("round {round}: candidates"));
            }
            Event::Diagnosis(D::Candidate { round, effect }) => {
                pb.inc(1);
                pb.set_message(format!("round {round}: {} done", effect.name()));
            }
            Event::Diagnosis(D::Checking { effect }) => {
                pb.set_message(format!("checking {}", effect.name()))
            }
            Event::Progress { task, done, total } => {
                pb.set_message(progress_message(task, done, total));
                pb.tick();
            }
        }
    }

    fn cancelled(&self) -> bool {
        super::INTERRUPTED.load(std::sync::atomic::Ordering::Relaxed)
    }
}

/// `simulating 42 %`.
pub fn progress_message(task: &str, done: u64, total: u64) -> String {
    format!("{task} {:.0} %", 100.0 * done as f64 / total.max(1) as f64)
}
