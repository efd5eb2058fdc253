//! Issue 13's benchmark table: `cargo bench --bench datasets` runs the three
//! data sets' protocols (see `tests/protocols`), and the F-16's and UNESP's
//! again from the models written down in `signals/` (each row's
//! `from_start`), prints the tables and writes
//! `target/datasets/report.json`. Reads `$HYSTID_DATASETS` or
//! `../shared/datasets` (skips a data set that is absent, saying so) and
//! runs the `hystid` binary (`$HYSTID_BIN`, else the one cargo built).

#[path = "../tests/protocols/mod.rs"]
mod protocols;

use serde_json::Value;
use std::path::{Path, PathBuf};

fn main() {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target"));
    let out = target.join("datasets");
    let work = out.join("work");
    std::fs::create_dir_all(&work).expect("target/datasets/work");
    let root = Some(
        std::env::var_os("HYSTID_DATASETS")
            .map(PathBuf::from)
            .unwrap_or_else(|| {
                PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/datasets")
            }),
    );
    let mut rows = Vec::new();

    for (name, protocol) in [
        (
            "boucwen_benchmark",
            protocols::bouc_wen as fn(&Path, &Path) -> Vec<Value>,
        ),
        ("f16_gvt_benchmark", protocols::f16),
        ("bolted_beam_unesp_bert", protocols::unesp),
    ] {
        if let Some(d) = protocols::dataset(&root, name) {
            rows.extend(protocol(&d, &work));
        }
    }
    // the same protocols fitted from the models written down in
    // `signals/`: each row's `from_start`
    let mut started = Vec::new();
    for (name, protocol) in [
        (
            "f16_gvt_benchmark",
            protocols::f16_from_start as fn(&Path, &Path) -> Vec<Value>,
        ),
        ("bolted_beam_unesp_bert", protocols::unesp_from_start),
    ] {
        if let Some(d) = protocols::dataset(&root, name) {
            started.extend(protocol(&d, &work));
        }
    }
    for s in &started {
        if let Some(r) = rows
            .iter_mut()
            .find(|r| r["dataset"] == s["dataset"] && r["recording"] == s["recording"])
        {
            r["from_start"] = serde_json::json!({
                "start": s["start"],
                "e_rms": s["e_rms"],
                "e_rms_relative": s["e_rms_relative"],
                "seconds": s["seconds"],
            });
        }
    }

    println!(
        "\n| data set | validation recording | window | e_RMS | % of the RMS | linearised model | target | seconds |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for r in &rows {
        let pct = |v: &Value| {
            v.as_f64()
                .map_or("".into(), |x| format!("{:.1} %", 100.0 * x))
        };
        let target = match (r["target_relative"].as_f64(), r["target_e_rms"].as_f64()) {
            (Some(t), _) => format!("<= {:.0} %", 100.0 * t),
            (None, Some(t)) => format!("<= {t:.0e}"),
            _ => String::new(),
        };
        let window = r["window_hz"]
            .as_array()
            .map_or("whole record".to_string(), |w| {
                format!("{}-{} Hz", w[0], w[1])
            });
        println!(
            "| {} | {} | {window} | {:.4e} | {} | {} | {target} | {:.1} |",
            r["dataset"].as_str().unwrap(),
            r["recording"].as_str().unwrap(),
            r["e_rms"].as_f64().unwrap(),
            pct(&r["e_rms_relative"]),
            pct(&r["linear_e_rms_relative"]),
            r["seconds"].as_f64().unwrap(),
        );
    }
    if !started.is_empty() {
        println!("\nFitted from the models written down:\n");
        println!("| data set | start | validation recording | e_RMS | % of the RMS | seconds |");
        println!("|---|---|---|---|---|---|");
        for r in &started {
            println!(
                "| {} | {} | {} | {:.4e} | {:.1} % | {:.1} |",
                r["dataset"].as_str().unwrap(),
                r["start"].as_str().unwrap(),
                r["recording"].as_str().unwrap(),
                r["e_rms"].as_f64().unwrap(),
                100.0 * r["e_rms_relative"].as_f64().unwrap(),
                r["seconds"].as_f64().unwrap(),
            );
        }
    }
    let path = out.join("report.json");
    let tmp = out.join("report.json.tmp");
    std::fs::write(&tmp, serde_json::to_vec_pretty(&rows).unwrap()).expect("report");
    std::fs::rename(&tmp, &path).expect("report");
    println!("\nreport: {}", path.display());
}
