//! Integration tests, one binary, one module per topic.
//!
//! Tests that read the real data sets in `../shared/datasets` skip with a
//! message when the folder is absent (set `HYSTID_DATASETS` to point
//! elsewhere).

mod common;

mod architecture;
mod armature;
mod bench;
mod cli;
mod cli_newcomer;
mod cli_points;
mod cli_realdata;
mod diagnose;
mod docs;
mod extract;
mod fit;
mod hb;
mod import;
mod independent;
mod plot;
mod protocols;
mod realdata;
mod record;
mod reliability;
mod shaker;
mod sim;
mod time_fit;
mod uff;
