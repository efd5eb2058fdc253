//! Issue 71's multi-response benchmark: `cargo bench --bench points`
//! imports the F-16's sine sweeps (levels 1-7) with the force and the three
//! accelerometers (drive point, wing and payload beside the interface),
//! reduces each response to its nonlinear FRFs over 4.5-9 Hz, fits the
//! structure at those three points with a joint ([`hystid::fit::points`]),
//! between the wing's and the payload's accelerometers or at a coordinate
//! of its own that no sensor reads, on levels 1, 3, 5, 7 together (and
//! each alone), judges the held-out levels 2, 4, 6 by each response's FRF
//! error and by a time-domain replay of their recorded force
//! ([`hystid::sim::points::PointSimulator`]) over the part of the sweep
//! inside the band, prints a table and writes `target/points/f16.json`.
//! Reads `$HYSTID_DATASETS` or `../shared/datasets` (skips, saying so,
//! when the F-16 is absent) and imports through the `hystid` binary
//! (`$HYSTID_BIN`, else the one cargo built).

#[path = "points/f16.rs"]
mod f16;
#[path = "../tests/protocols/mod.rs"]
mod protocols;

use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

fn main() {
    let clock = Instant::now();
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target"));
    let out = target.join("points");
    let work = out.join("work");
    std::fs::create_dir_all(&work).expect("target/points/work");
    let root = Some(
        std::env::var_os("HYSTID_DATASETS")
            .map(PathBuf::from)
            .unwrap_or_else(|| {
                PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/datasets")
            }),
    );
    let Some(dir) = protocols::dataset(&root, "f16_gvt_benchmark") else {
        return;
    };
    let levels = f16::levels(&dir, &work);
    println!(
        "imported and reduced: {:.1} s",
        clock.elapsed().as_secs_f64()
    );
    let mut report = Vec::new();
    for at in f16::Placement::all() {
        for law in f16::laws() {
            let row = f16::judge(&levels, law, at);
            f16::print(&row);
            report.push(row);
        }
    }
    let report = json!({ "laws": report, "seconds": clock.elapsed().as_secs_f64() });
    let path = out.join("f16.json");
    std::fs::write(&path, serde_json::to_vec_pretty(&report).unwrap()).expect("report");
    println!(
        "\nreport: {} ({:.0} s)",
        path.display(),
        clock.elapsed().as_secs_f64()
    );
}
