//! The independent reference: simulator, corpus generator, recording
//! writer and scoring. No `use hystid` anywhere here: shared by the tests
//! (`tests/independent`) and the corpus report (`benches/corpus.rs`).
#![allow(dead_code)]

pub mod corpus;
pub mod recording;
pub mod refsim;
pub mod runner;
pub mod score;
