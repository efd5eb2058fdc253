//! The library's dependency arrows and error discipline, checked on the
//! source text (a rule broken in a refactor fails here, not in review).
//!
//! * `extract` reads samples, never files: no `crate::record`, no `std::fs`.
//! * The model does not depend on the simulator: no `crate::sim` in `model`.
//! * The test bench does not depend on harmonic balance: no `crate::hb`.
//! * Harmonic balance does not depend on fitting or diagnosis.
//! * No `dyn Any` or `downcast` in `src/`: what a stage needs to know of an
//!   element it asks the element (`Element`, its law's `Description`).
//! * No `Result<_, String>` (nor a `String` conversion error) anywhere in
//!   `src/`: errors are typed.
//!
//! Comment lines and `#[cfg(test)]` items are skipped: documentation may
//! name another module, and a test may check one stage against another.

use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display())) {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|x| x == "rs") {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// The source's code lines, numbered from 1, without comment lines and
/// without `#[cfg(test)]` items (counted by braces, which is enough for
/// this crate's test modules).
fn code_lines(text: &str) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut lines = text.lines().enumerate();
    while let Some((i, line)) = lines.next() {
        let t = line.trim_start();
        if t.starts_with("//") {
            continue;
        }
        if let Some(item) = t.strip_prefix("#[cfg(test)]") {
            // skip the gated item (which may start on the attribute's line):
            // up to its closing brace, or a `;` item
            let mut depth = 0i64;
            let mut opened = false;
            let mut end = |l: &str| {
                depth += l.matches('{').count() as i64 - l.matches('}').count() as i64;
                opened |= l.contains('{');
                (opened && depth <= 0) || (!opened && l.trim_end().ends_with(';'))
            };
            if !end(item) {
                for (_, l) in lines.by_ref() {
                    if end(l) {
                        break;
                    }
                }
            }
            continue;
        }
        out.push((i + 1, line));
    }
    out
}

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

/// `file:line: text` for every code line of `src/<module>` holding one of
/// `forbidden`.
fn uses(module: &str, forbidden: &[&str]) -> Vec<String> {
    let root = src().join(module);
    let files = if root.is_dir() {
        rust_files(&root)
    } else {
        vec![root.with_extension("rs")]
    };
    let mut found = Vec::new();
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        for (n, line) in code_lines(&text) {
            if forbidden.iter().any(|p| line.contains(p)) {
                found.push(format!("{}:{n}: {}", f.display(), line.trim()));
            }
        }
    }
    found
}

#[test]
fn extract_reads_samples_not_files() {
    let found = uses("extract", &["crate::record", "std::fs", "File::open"]);
    assert!(
        found.is_empty(),
        "extract does file I/O:\n{}",
        found.join("\n")
    );
}

#[test]
fn model_does_not_depend_on_the_simulator() {
    let found = uses("model", &["crate::sim"]);
    assert!(found.is_empty(), "model uses sim:\n{}", found.join("\n"));
}

#[test]
fn testbench_does_not_depend_on_harmonic_balance() {
    let found = uses("testbench", &["crate::hb"]);
    assert!(found.is_empty(), "testbench uses hb:\n{}", found.join("\n"));
}

#[test]
fn harmonic_balance_does_not_depend_on_fit_or_diagnosis() {
    let found = uses("hb", &["crate::fit", "crate::diagnose"]);
    assert!(
        found.is_empty(),
        "hb uses fit/diagnose:\n{}",
        found.join("\n")
    );
}

#[test]
fn no_stage_downcasts_an_element() {
    let mut found = Vec::new();
    for f in rust_files(&src()) {
        let text = std::fs::read_to_string(&f).unwrap();
        for (n, line) in code_lines(&text) {
            if ["downcast", "dyn Any", "std::any::Any"]
                .iter()
                .any(|p| line.contains(p))
            {
                found.push(format!("{}:{n}: {}", f.display(), line.trim()));
            }
        }
    }
    assert!(found.is_empty(), "downcasts:\n{}", found.join("\n"));
}

/// Outcomes are types: no status is decided by matching the text of a
/// message (an optimiser's reason, a note).
#[test]
fn no_status_is_read_from_message_text() {
    let mut found = Vec::new();
    for f in rust_files(&src()) {
        let text = std::fs::read_to_string(&f).unwrap();
        for (n, line) in code_lines(&text) {
            let l = line.replace(' ', "");
            if [
                ".contains(\"didnotconverge",
                ".contains(\"maximum",
                ".contains(\"dropped",
                "to_lowercase().contains(",
            ]
            .iter()
            .any(|p| l.contains(&p.replace(' ', "")))
            {
                found.push(format!("{}:{n}: {}", f.display(), line.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "status read from text:\n{}",
        found.join("\n")
    );
}

/// Only the model (its laws and their registry) names a concrete element
/// law in a match; every other stage reads the law's description. The
/// diagnosis candidates name the law they add, in their own files.
#[test]
fn only_the_model_matches_on_element_laws() {
    let mut found = Vec::new();
    for f in rust_files(&src()) {
        let rel = f.strip_prefix(src()).unwrap().to_string_lossy().to_string();
        if rel.starts_with("model") || rel.starts_with("diagnose/candidates") {
            continue;
        }
        let text = std::fs::read_to_string(&f).unwrap();
        for (n, line) in code_lines(&text) {
            let matched = ["ElementSpec::", "ElementKind::", "AnyElement::"]
                .iter()
                .any(|ty| {
                    line.match_indices(ty).any(|(at, _)| {
                        let rest = &line[at + ty.len()..];
                        // a variant (capitalised) in a pattern or `matches!`
                        rest.starts_with(|c: char| c.is_ascii_uppercase())
                            && !rest.starts_with("ALL")
                            && (line.contains("matches!")
                                || line.trim_start().starts_with("Some(")
                                || line.contains("=>")
                                || line.trim_start().starts_with("let "))
                    })
                });
            if matched {
                found.push(format!("{}:{n}: {}", f.display(), line.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "a stage matches on a concrete law:\n{}",
        found.join("\n")
    );
}

/// The last top-level generic argument of each `Result<…>` in `line`
/// (the error type; `None` for a one-argument alias such as `Result<T>`).
fn result_error_types(line: &str) -> Vec<Option<String>> {
    let mut out = Vec::new();
    let mut rest = line;
    while let Some(at) = rest.find("Result<") {
        // only the type `Result`, not e.g. `SolveResult<`
        let before = rest[..at].chars().next_back();
        let args = &rest[at + "Result<".len()..];
        rest = args;
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
            continue;
        }
        let (mut depth, mut last_comma, mut end) = (0i32, None, None);
        for (k, c) in args.char_indices() {
            match c {
                '<' | '(' | '[' => depth += 1,
                '>' | ')' | ']' if depth == 0 => {
                    end = Some(k);
                    break;
                }
                '>' | ')' | ']' => depth -= 1,
                ',' if depth == 0 => last_comma = Some(k),
                _ => {}
            }
        }
        // a type split over lines: judged by what this line holds
        let end = end.unwrap_or(args.len());
        out.push(last_comma.map(|c| args[c + 1..end].trim().to_string()));
    }
    out
}

#[test]
fn library_errors_are_typed() {
    let mut found = Vec::new();
    for f in rust_files(&src()) {
        let text = std::fs::read_to_string(&f).unwrap();
        for (n, line) in code_lines(&text) {
            let string_error = result_error_types(line)
                .iter()
                .any(|e| matches!(e.as_deref(), Some("String" | "std::string::String")))
                || line.replace(' ', "").contains("typeError=String;");
            if string_error {
                found.push(format!("{}:{n}: {}", f.display(), line.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "String errors (use crate::Error or a typed error):\n{}",
        found.join("\n")
    );
}

#[test]
fn the_scanner_sees_what_it_looks_for() {
    assert_eq!(
        result_error_types("fn f() -> std::result::Result<Vec<(u8, u8)>, String> {"),
        vec![Some("String".to_string())]
    );
    assert_eq!(result_error_types("fn f() -> Result<()> {"), vec![None]);
    assert!(result_error_types("let r: SolveResult<u8, String>;").is_empty());
    let text = "use a;\n#[cfg(test)]\nmod tests {\n    use crate::sim;\n    fn f() {}\n}\nuse b;\n";
    let kept: Vec<&str> = code_lines(text).into_iter().map(|(_, l)| l).collect();
    assert_eq!(kept, vec!["use a;", "use b;"]);
    let text = "#[cfg(test)] use crate::sim;\nuse b;\n";
    let kept: Vec<&str> = code_lines(text).into_iter().map(|(_, l)| l).collect();
    assert_eq!(kept, vec!["use b;"]);
}

/// The command line only translates: `src/cli/` stays under 8 % of the
/// library's lines, and the README's figure is the measured one.
#[test]
fn the_command_line_is_thin() {
    let count = |files: Vec<PathBuf>| -> usize {
        files
            .iter()
            .map(|f| std::fs::read_to_string(f).unwrap().lines().count())
            .sum()
    };
    let cli = count(rust_files(&src().join("cli")));
    let library = count(
        rust_files(&src())
            .into_iter()
            .filter(|f| !f.starts_with(src().join("cli")) && !f.ends_with("main.rs"))
            .collect(),
    );
    let share = cli as f64 / library as f64;
    assert!(
        share < 0.08,
        "src/cli/ has {cli} lines, {:.1} % of the library's {library}",
        100.0 * share
    );
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    let stated = format!(
        "(`src/cli/`, {:.0} % of the library's lines)",
        100.0 * share
    );
    assert!(
        readme.contains(&stated),
        "the README should say {stated} ({cli} / {library} lines)"
    );
}
