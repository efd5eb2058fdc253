//! Issue 10: an independent reference simulator and a seeded corpus of
//! recordings hystid did not make, and `hystid diagnose` run on them.
//!
//! `kit/` holds the simulator, generator, writer and scoring (no
//! `use hystid` there); `reference` checks the simulator against closed
//! forms; `sample` runs the CLI on a fixed sample of the corpus. The full
//! report is `cargo bench --bench corpus`.

pub mod kit;

mod bouc_wen;
mod broad;
mod hysteretic_mode;
mod iwan;
mod multisine;
mod reference;
mod sample;
mod shaker;
mod subharmonic;
