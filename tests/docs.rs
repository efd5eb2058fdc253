//! The book's generated pages are what their sources make of them today.
//!
//! * `docs/src/validation/*.md` are rendered from the templates in
//!   `docs/validation/pages/` and the pinned figures of
//!   `docs/validation/figures.json` (the figures the tests assert).
//! * `docs/src/reference/cli.md` is rendered from the binary's `--help`.
//!
//! A page that differs from its rendering fails here; run the tests with
//! `HYSTID_BLESS=1` to write the pages afresh, then review the diff.

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The placeholder a template puts where a pinned figure is printed.
const FIGURE: &str = "{#}";

/// Compares `page` with `rendered`, or writes it under `HYSTID_BLESS`.
fn check_page(page: &Path, rendered: &str) {
    if std::env::var_os("HYSTID_BLESS").is_some() {
        std::fs::create_dir_all(page.parent().unwrap()).unwrap();
        std::fs::write(page, rendered).unwrap();
        return;
    }
    let on_disk = std::fs::read_to_string(page).unwrap_or_default();
    if on_disk != rendered {
        let first = on_disk
            .lines()
            .zip(rendered.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(on_disk.lines().count().min(rendered.lines().count()));
        panic!(
            "{} is stale from line {}: regenerate it with `HYSTID_BLESS=1 cargo test --release \
             --test integration docs::`",
            page.display(),
            first + 1
        );
    }
}

/// A template line with its placeholders filled from the shortest pinned key
/// it starts with; the figures of a longer key on the same line must be the
/// tail of the shorter key's.
fn render_line(
    line: &str,
    figures: &serde_json::Map<String, serde_json::Value>,
    used: &mut std::collections::BTreeSet<String>,
) -> Result<String, String> {
    let count = line.matches(FIGURE).count();
    if count == 0 {
        return Ok(line.to_string());
    }
    let trimmed = line.trim_start();
    let mut keys: Vec<&String> = figures
        .keys()
        .filter(|k| trimmed.starts_with(k.as_str()))
        .collect();
    keys.sort_by_key(|k| k.len());
    let Some(key) = keys.first() else {
        return Err(format!("no pinned key starts the line `{line}`"));
    };
    let printed = |k: &str| -> Vec<String> {
        figures[k]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap().to_string())
            .collect()
    };
    let values = printed(key);
    if values.len() != count {
        return Err(format!(
            "`{key}` pins {} figures, its line has {count} places: `{line}`",
            values.len()
        ));
    }
    for longer in &keys[1..] {
        let tail = printed(longer);
        if !values.ends_with(&tail) {
            return Err(format!(
                "`{longer}` pins {tail:?}, the line prints {values:?}"
            ));
        }
        used.insert((*longer).clone());
    }
    used.insert((*key).clone());
    let mut out = String::new();
    let mut parts = line.split(FIGURE);
    out.push_str(parts.next().unwrap());
    for (part, value) in parts.zip(&values) {
        out.push_str(value);
        out.push_str(part);
    }
    Ok(out)
}

/// Every validation page is its template with the pinned figures in place,
/// and every pinned figure is printed on some page.
#[test]
fn validation_pages_are_current() {
    let figures = crate::common::pinned_table();
    let templates = root().join("docs/validation/pages");
    let mut names: Vec<PathBuf> = std::fs::read_dir(&templates)
        .unwrap_or_else(|e| panic!("{}: {e}", templates.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    names.sort();
    assert!(!names.is_empty(), "no templates in {}", templates.display());
    let mut used = std::collections::BTreeSet::new();
    let mut errors = Vec::new();
    for template in &names {
        let text = std::fs::read_to_string(template).unwrap();
        let mut page = String::new();
        for (i, line) in text.lines().enumerate() {
            match render_line(line, &figures, &mut used) {
                Ok(l) => page.push_str(&l),
                Err(e) => errors.push(format!("{}:{}: {e}", template.display(), i + 1)),
            }
            page.push('\n');
        }
        let name = template.file_name().unwrap();
        check_page(&root().join("docs/src/validation").join(name), &page);
    }
    let unused: Vec<&String> = figures.keys().filter(|k| !used.contains(*k)).collect();
    assert!(errors.is_empty(), "{}", errors.join("\n"));
    assert!(
        unused.is_empty(),
        "pinned but printed on no page: {unused:?}"
    );
}

/// One template line with two keys: the shorter key fills it, the longer
/// one's figures must be its tail (a planted mismatch fails).
#[test]
fn a_line_printed_from_two_keys_must_agree() {
    let figures: serde_json::Map<String, serde_json::Value> = serde_json::from_str(
        r#"{"| a |": ["1.5", "2"], "| a | 1.5 |": ["2"], "| b |": ["3"], "| b | x |": ["4"]}"#,
    )
    .unwrap();
    let mut used = Default::default();
    assert_eq!(
        render_line("| a | {#} | {#} |", &figures, &mut used).unwrap(),
        "| a | 1.5 | 2 |"
    );
    assert!(render_line("| b | x | {#} |", &figures, &mut used).is_err());
    assert!(render_line("| c | {#} |", &figures, &mut used).is_err());
    assert!(render_line("| a | {#} |", &figures, &mut used).is_err());
}

/// `docs/src/reference/cli.md` is every command's `--help`, as the binary
/// prints it.
#[test]
fn the_command_reference_is_current() {
    let bin = env!("CARGO_BIN_EXE_hystid");
    let help = |args: &[&str]| -> String {
        let out = std::process::Command::new(bin)
            .args(args)
            .env("COLUMNS", "100")
            .output()
            .expect("the binary runs");
        assert!(out.status.success(), "{args:?}: {out:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    let top = help(&["--help"]);
    let commands: Vec<String> = top
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|c| c != "help")
        .collect();
    assert!(commands.len() >= 6, "{top}");
    let mut page = String::from(
        "# Commands\n\n<!-- generated from the binary's --help by tests/docs.rs; do not edit -->\n\n",
    );
    page.push_str("```text\n");
    page.push_str(&top);
    page.push_str("```\n");
    for command in &commands {
        page.push_str(&format!("\n## `hystid {command}`\n\n```text\n"));
        page.push_str(&help(&[command, "--help"]));
        page.push_str("```\n");
    }
    check_page(&root().join("docs/src/reference/cli.md"), &page);
}

/// The book's table of contents names only pages that exist, and every page
/// under `docs/src` is in it.
#[test]
fn the_book_links_every_page() {
    let src = root().join("docs/src");
    let summary = std::fs::read_to_string(src.join("SUMMARY.md")).unwrap();
    let linked: std::collections::BTreeSet<String> = summary
        .split("](")
        .skip(1)
        .filter_map(|s| s.split(')').next())
        .map(str::to_string)
        .collect();
    for link in &linked {
        assert!(
            src.join(link).is_file(),
            "SUMMARY.md links {link}, which does not exist"
        );
    }
    let mut stack = vec![src.clone()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|x| x == "md") && !path.ends_with("SUMMARY.md") {
                let rel = path
                    .strip_prefix(&src)
                    .unwrap()
                    .to_string_lossy()
                    .to_string();
                assert!(linked.contains(&rel), "{rel} is not in SUMMARY.md");
            }
        }
    }
}

/// The pinned stays a front page: at most 150 lines, and every link into
/// the book resolves.
#[test]
fn the_readme_is_a_front_page() {
    let text = std::fs::read_to_string(root().join("README.md")).unwrap();
    let lines = text.lines().count();
    assert!(lines <= 150, "README.md has {lines} lines (at most 150)");
    for link in text.split("](").skip(1).filter_map(|s| s.split(')').next()) {
        if link.starts_with("http") || link.starts_with('#') {
            continue;
        }
        let path = link.split('#').next().unwrap();
        assert!(
            root().join(path).exists(),
            "README.md links {path}, which does not exist"
        );
    }
}

/// A stepped-sine test of a linear SDOF (10 kg, 200 N s/m, 1e7 N/m) as a CSV
/// of time, force and acceleration at 5 kHz: 26 dwells of 0.6 s, 100-350 Hz,
/// at each level, integrated by RK4 at ten steps a sample (an integrator
/// independent of hystid's digital filters), transients and all.
fn linear_sdof_csv(path: &Path, levels_n: &[f64]) {
    let (fs, m, c, k) = (5000.0, 10.0, 200.0, 1.0e7);
    let steps = 10;
    let h = 1.0 / (fs * steps as f64);
    let accel = |x: f64, v: f64, f: f64| (f - c * v - k * x) / m;
    let (mut x, mut v) = (0.0, 0.0);
    let mut text = String::from("time,force_N,acc_ms2\n");
    let mut sample = 0usize;
    for &level in levels_n {
        for f in (0..26).map(|i| 100.0 + 10.0 * i as f64) {
            let w = 2.0 * std::f64::consts::PI * f;
            let force = |t: f64| level * (w * t).sin();
            for _ in 0..(0.6 * fs) as usize {
                let t0 = sample as f64 / fs;
                text.push_str(&format!(
                    "{t0:.6},{:.6e},{:.6e}\n",
                    force(t0),
                    accel(x, v, force(t0))
                ));
                for j in 0..steps {
                    let t = t0 + j as f64 * h;
                    let (f1, f2, f3) = (force(t), force(t + h / 2.0), force(t + h));
                    let (k1x, k1v) = (v, accel(x, v, f1));
                    let (k2x, k2v) = (
                        v + h / 2.0 * k1v,
                        accel(x + h / 2.0 * k1x, v + h / 2.0 * k1v, f2),
                    );
                    let (k3x, k3v) = (
                        v + h / 2.0 * k2v,
                        accel(x + h / 2.0 * k2x, v + h / 2.0 * k2v, f2),
                    );
                    let (k4x, k4v) = (v + h * k3v, accel(x + h * k3x, v + h * k3v, f3));
                    x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
                    v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
                }
                sample += 1;
            }
        }
    }
    std::fs::write(path, text).unwrap();
}

/// The README's own-recording example runs as written, command by command,
/// on two CSV files of a linear SDOF integrated independently: the fit
/// finds the SDOF's mass and stiffness within 0.5 % (0.1 % in practice: the
/// dwells' transients and the CSV's six digits), the final model replays
/// the recording it was not fitted to within 2 % of its RMS (0.9 %), and
/// the figures' titles name the optimiser and the error's unit.
#[test]
fn the_readme_example_runs() {
    let text = std::fs::read_to_string(root().join("README.md")).unwrap();
    let block = text
        .split("## Your own recording")
        .nth(1)
        .and_then(|s| s.split("```sh\n").nth(1))
        .and_then(|s| s.split("```").next())
        .expect("the README's own-recording example");
    let dir = tempfile::tempdir().unwrap();
    linear_sdof_csv(&dir.path().join("test.csv"), &[50.0, 500.0]);
    linear_sdof_csv(&dir.path().join("check.csv"), &[200.0]);
    let commands: Vec<Vec<&str>> = block
        .lines()
        .filter_map(|l| l.trim().strip_prefix("hystid "))
        .map(|l| l.split_whitespace().collect())
        .collect();
    assert_eq!(commands.len(), 5, "{block}");
    for args in &commands {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_hystid"))
            .args(args)
            .arg("--quiet")
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "hystid {}: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let fit: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("fit/fit.json")).unwrap()).unwrap();
    for (name, truth) in [("mass", 10.0), ("stiffness", 1.0e7)] {
        let value = fit["parameters"][name]["value"].as_f64().unwrap();
        assert!(
            (value / truth - 1.0).abs() < 5e-3,
            "{name} {value} against {truth}"
        );
    }
    let validation: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("val/validate.json")).unwrap())
            .unwrap();
    let relative = validation["recordings"][0]["whole"]["relative"]
        .as_f64()
        .unwrap();
    assert!(
        relative < 0.02,
        "the held-out recording replayed at {relative}"
    );
    let convergence = std::fs::read_to_string(dir.path().join("fit/convergence.svg")).unwrap();
    assert!(convergence.contains(": cost per evaluation") && !convergence.contains("NelderMead"));
    let overlay = std::fs::read_to_string(dir.path().join("val/check_time.svg")).unwrap();
    assert!(overlay.contains("m/s^2 (") && overlay.contains("% of the RMS)"));
}
