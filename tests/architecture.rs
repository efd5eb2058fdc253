//! The library's dependency arrows and error discipline, checked on the
//! source text (a rule broken in a refactor fails here, not in review).
//!
//! The layers are crates (`crates/hystid-core` < `crates/hystid-signal` <
//! `crates/hystid-identify` < the root package, the application and its
//! front ends), so the compiler refuses an arrow upwards between them. The
//! scans read every crate's `src/` as one tree of modules (each layer
//! re-exports those below under their own names):
//!
//! * Each layer is the crate it should be ([`LAYERS`] against the folders).
//! * `extract` reads samples, never files: no `crate::record`, no `std::fs`.
//! * The model does not depend on the simulator: no `crate::sim` in `model`.
//! * The test bench does not depend on harmonic balance: no `crate::hb`.
//! * Harmonic balance does not depend on fitting or diagnosis.
//! * No import cycle between modules (their files; a folder module's files
//!   among themselves too), and no layer uses one above it: core (errors,
//!   harmonics, signals, the model, the simulator, harmonic balance, the
//!   observer) < signals (`extract`, `record`, `import`, `plot`,
//!   `testbench`) < identification (`validate`, `fit`, `diagnose`) < the
//!   application (`analysis`) < the front ends (`cli`, `main.rs`).
//! * No `dyn Any` or `downcast`: what a stage needs to know of an element it
//!   asks the element (`Element`, its law's `Description`).
//! * No `Result<_, String>` (nor a `String` conversion error): errors are
//!   typed.
//! * No source file of a crate or of `python/src/` longer than 1,200 lines:
//!   a file that grows past it is split by responsibility.
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

/// Whether `file` is a test module in its own file: its parent declares it
/// as `#[cfg(test)] mod name;`, so all of it is `#[cfg(test)]` code.
fn is_test_module_file(file: &Path) -> bool {
    let (Some(dir), Some(stem)) = (file.parent(), file.file_stem()) else {
        return false;
    };
    let stem = stem.to_string_lossy();
    // `a/x.rs` and `a/x/mod.rs` are both declared in `a/mod.rs` or `a.rs`
    let (name, dir) = if stem == "mod" {
        let Some(up) = dir.parent() else { return false };
        (dir.file_name().unwrap_or_default().to_string_lossy(), up)
    } else {
        (stem, dir)
    };
    let mut parents = vec![dir.join("mod.rs"), dir.with_extension("rs")];
    if sources().iter().any(|s| s == dir) {
        parents.extend([dir.join("lib.rs"), dir.join("main.rs")]);
    }
    let declaration = format!("mod {name};");
    parents.iter().any(|p| {
        let Ok(text) = std::fs::read_to_string(p) else {
            return false;
        };
        let lines: Vec<&str> = text.lines().map(str::trim).collect();
        lines.iter().enumerate().any(|(i, l)| {
            l.strip_prefix("#[cfg(test)]").is_some_and(|rest| {
                rest.trim() == declaration
                    || (rest.trim().is_empty() && lines.get(i + 1) == Some(&declaration.as_str()))
            })
        })
    })
}

/// Every `.rs` file under `dir` but the test modules in their own files.
fn code_files(dir: &Path) -> Vec<PathBuf> {
    rust_files(dir)
        .into_iter()
        .filter(|f| !is_test_module_file(f))
        .collect()
}

/// The source's code lines, numbered from 1, without comment lines and
/// without `#[cfg(test)]` items (counted by braces, which is enough for
/// this crate's test modules; a gated field or argument is its line).
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
                // a `;` item, or a field or argument (`name: value,`)
                (opened && depth <= 0)
                    || (!opened && (l.trim_end().ends_with(';') || l.trim_end().ends_with(',')))
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

/// The crates of the workspace, lowest layer first: the library's layers
/// and the application with its front ends (the root package).
const CRATES: &[&str] = &[
    "crates/hystid-core",
    "crates/hystid-signal",
    "crates/hystid-identify",
    ".",
];

/// Each crate's `src/`, in the order of [`CRATES`].
fn sources() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    CRATES
        .iter()
        .map(|c| match *c {
            "." => root.join("src"),
            c => root.join(c).join("src"),
        })
        .collect()
}

/// The source folder `file` is in.
fn source_of(file: &Path) -> PathBuf {
    sources()
        .into_iter()
        .filter(|s| file.starts_with(s))
        .max_by_key(|s| s.components().count())
        .unwrap_or_else(|| panic!("{}: in no crate's src/", file.display()))
}

/// Every code file of every crate, read as one tree of modules: a layer
/// crate re-exports those below it under their own names, so `crate::model`
/// means the same module in each. The layer crates' `lib.rs` (their
/// re-exports and module list) are left out: the application's root stands
/// for all of them.
fn library_files() -> Vec<PathBuf> {
    let app = src();
    sources()
        .iter()
        .flat_map(|s| code_files(s))
        .filter(|f| !(f.ends_with("lib.rs") && f.parent() != Some(app.as_path())))
        .collect()
}

/// Where the module `name` (a top-level one) lives: its folder's path
/// without the extension.
fn module_root(name: &str) -> PathBuf {
    sources()
        .into_iter()
        .map(|s| s.join(name))
        .find(|p| p.is_dir() || p.with_extension("rs").is_file())
        .unwrap_or_else(|| panic!("module {name} is in no crate"))
}

/// `file:line: text` for every code line of `src/<module>` holding one of
/// `forbidden`.
fn uses(module: &str, forbidden: &[&str]) -> Vec<String> {
    let root = module_root(module);
    let files = if root.is_dir() {
        code_files(&root)
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
    for f in library_files() {
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
    for f in library_files() {
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
    for f in library_files() {
        let rel = f
            .strip_prefix(source_of(&f))
            .unwrap()
            .to_string_lossy()
            .to_string();
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
    for f in library_files() {
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
    // a test module in its own file is test code, its parent is not
    assert!(is_test_module_file(
        &module_root("model").join("masing/tests.rs")
    ));
    assert!(!is_test_module_file(
        &module_root("model").join("masing/mod.rs")
    ));
}

/// The command line only translates: `src/cli/` stays under 8 % of the
/// library's lines.
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
        sources()
            .iter()
            .flat_map(|s| rust_files(s))
            .filter(|f| !f.starts_with(src().join("cli")) && !f.ends_with("main.rs"))
            .collect(),
    );
    let share = cli as f64 / library as f64;
    assert!(
        share < 0.08,
        "src/cli/ has {cli} lines, {:.1} % of the library's {library}",
        100.0 * share
    );
}

/// A module of `src/`, by its path: `src/fit/time.rs` is `fit::time`, a
/// folder's `mod.rs` the folder, `lib.rs` the library's root (no segment),
/// `main.rs` the binary's root (`main`).
type Module = Vec<String>;

fn module_of(file: &Path) -> Module {
    let rel = file
        .strip_prefix(source_of(file))
        .unwrap()
        .with_extension("");
    let mut segments: Module = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if segments.last().is_some_and(|s| s == "mod") {
        segments.pop();
    }
    if segments == ["lib"] {
        segments.clear();
    }
    segments
}

fn name(module: &[String]) -> String {
    if module.is_empty() {
        "lib".into()
    } else {
        module.join("::")
    }
}

/// Whether `module` is the binary's (whose `crate::` is not the library).
fn in_binary(module: &[String]) -> bool {
    module.first().is_some_and(|s| s == "main" || s == "cli")
}

/// The paths a `use` tree names, each with the name it brings in:
/// `a::{b, c::{d, e as f}}` is `a::b` (`b`), `a::c::d` (`d`), `a::c::e`
/// (`f`); `a::{self}` is `a`, and a glob `a::*` is `a` (`*`).
fn use_tree_paths(tree: &str) -> Vec<(Vec<String>, String)> {
    fn split_top(s: &str) -> Vec<&str> {
        let (mut parts, mut depth, mut from) = (Vec::new(), 0i32, 0);
        for (i, c) in s.char_indices() {
            match c {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    parts.push(&s[from..i]);
                    from = i + 1;
                }
                _ => {}
            }
        }
        parts.push(&s[from..]);
        parts
    }
    fn segments(s: &str) -> Vec<String> {
        s.split("::")
            .map(str::trim)
            .filter(|p| !p.is_empty())
            .map(String::from)
            .collect()
    }
    fn walk(prefix: &[String], tree: &str, out: &mut Vec<(Vec<String>, String)>) {
        for part in split_top(tree) {
            let part = part.trim();
            if part.is_empty() {
                continue;
            }
            if let (Some(open), Some(close)) = (part.find('{'), part.rfind('}')) {
                let head = [prefix, &segments(&part[..open])].concat();
                walk(&head, &part[open + 1..close], out);
                continue;
            }
            let (path, alias) = match part.split_once(" as ") {
                Some((p, a)) => (p, Some(a.trim().to_string())),
                None => (part, None),
            };
            let mut path = [prefix, &segments(path)].concat();
            let last = path.last().cloned().unwrap_or_default();
            if last == "self" || last == "*" {
                path.pop();
            }
            let known_as = match (alias, last.as_str()) {
                (Some(a), _) => a,
                (None, "self") => path.last().cloned().unwrap_or_default(),
                (None, _) => last,
            };
            out.push((path, known_as));
        }
    }
    let flat = tree.split_whitespace().collect::<Vec<_>>().join(" ");
    let mut out = Vec::new();
    walk(&[], &flat, &mut out);
    out
}

/// The paths of `line` that start at a module (`crate::`, `super::`,
/// `self::`, and the library's name as the binary writes it), as segments.
fn module_paths(line: &str) -> Vec<Vec<String>> {
    let b = line.as_bytes();
    let ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = (b[i].is_ascii_alphabetic() || b[i] == b'_')
            && (i == 0 || !(ident(b[i - 1]) || b[i - 1] == b':'));
        if !starts {
            i += 1;
            continue;
        }
        let mut segments = Vec::new();
        let mut j = i;
        loop {
            let from = j;
            while j < b.len() && ident(b[j]) {
                j += 1;
            }
            segments.push(line[from..j].to_string());
            if line[j..].starts_with("::") && b.get(j + 2).is_some_and(|&c| ident(c)) {
                j += 2;
            } else {
                break;
            }
        }
        if segments.len() > 1 && ["crate", "super", "self", "hystid"].contains(&&*segments[0]) {
            out.push(segments);
        }
        i = j;
    }
    out
}

/// A code line with any trailing `//` comment cut off.
fn without_comment(line: &str) -> &str {
    line.find("//").map_or(line, |at| &line[..at])
}

/// What one module refers to: each path it names (made absolute), with
/// where (`file:line: text`), and the names its `use` statements bring in.
struct Refs {
    paths: Vec<(Vec<String>, String)>,
    imports: std::collections::BTreeMap<String, Vec<String>>,
}

/// `path` as written in `module`, made absolute (`fit::time::TimeRecord`);
/// `None` for a path outside `src/`'s modules (`std::`, a dependency, the
/// binary's root items).
fn absolute(
    module: &[String],
    path: &[String],
    modules: &std::collections::BTreeSet<Module>,
) -> Option<Vec<String>> {
    let (head, rest) = path.split_first()?;
    match head.as_str() {
        "crate" if in_binary(module) => (rest.first()? == "cli").then(|| rest.to_vec()),
        "crate" | "hystid" => Some(rest.to_vec()),
        "self" | "super" => {
            let mut base = module.to_vec();
            if head == "super" {
                base.pop();
            }
            let mut rest = rest;
            while rest.first().is_some_and(|s| s == "super") {
                base.pop();
                rest = &rest[1..];
            }
            base.extend_from_slice(rest);
            Some(base)
        }
        // a submodule named from its parent (`use newton::Core;` in
        // `hb/mod.rs`); the binary's root names its modules so too
        child => {
            let parent: &[String] = if module == ["main"] { &[] } else { module };
            let mut own = parent.to_vec();
            own.push(child.to_string());
            modules.contains(&own).then(|| [parent, path].concat())
        }
    }
}

fn refs_of(file: &Path, module: &[String], modules: &std::collections::BTreeSet<Module>) -> Refs {
    let text = std::fs::read_to_string(file).unwrap();
    let mut refs = Refs {
        paths: Vec::new(),
        imports: Default::default(),
    };
    let shown = file
        .strip_prefix(env!("CARGO_MANIFEST_DIR"))
        .unwrap_or(file);
    let at = |n: usize, line: &str| format!("{}:{n}: {}", shown.display(), line.trim());
    let mut lines = code_lines(&text).into_iter();
    while let Some((n, line)) = lines.next() {
        let code = without_comment(line);
        let t = code.trim_start();
        let tree = ["use ", "pub use ", "pub(crate) use ", "pub(super) use "]
            .iter()
            .find_map(|p| t.strip_prefix(p));
        let Some(tree) = tree else {
            for p in module_paths(code) {
                if let Some(a) = absolute(module, &p, modules) {
                    refs.paths.push((a, at(n, line)));
                }
            }
            continue;
        };
        // a `use` statement, up to its `;`
        let mut statement = tree.to_string();
        while !statement.contains(';') {
            let Some((_, more)) = lines.next() else { break };
            statement.push(' ');
            statement.push_str(without_comment(more));
        }
        let statement = statement.split(';').next().unwrap();
        for (path, known_as) in use_tree_paths(statement) {
            if let Some(a) = absolute(module, &path, modules) {
                if known_as != "*" {
                    refs.imports.insert(known_as, a.clone());
                }
                refs.paths.push((a, at(n, line)));
            }
        }
    }
    refs
}

/// Module → module it refers to → where (`file:line: text`), over every
/// file of `src/`. A path is followed through the `use` items it names
/// (`crate::fit::TimeRecord`, which `fit` re-exports, is `fit::time`'s).
/// A module's references to its own ancestors are left out: a file of a
/// folder module uses the types its `mod.rs` shares, which declares and
/// re-exports the file in turn, and that is one module, not a cycle.
/// (An inline module is read as its file's.)
type Graph = std::collections::BTreeMap<Module, std::collections::BTreeMap<Module, Vec<String>>>;

fn module_graph() -> Graph {
    let files: Vec<(Module, PathBuf)> = library_files()
        .into_iter()
        .map(|f| (module_of(&f), f))
        .collect();
    let modules: std::collections::BTreeSet<Module> =
        files.iter().map(|(m, _)| m.clone()).collect();
    let refs: std::collections::BTreeMap<Module, Refs> = files
        .iter()
        .map(|(m, f)| (m.clone(), refs_of(f, m, &modules)))
        .collect();
    // the module that defines what `path` names
    let resolve = |path: &[String]| -> Option<Module> {
        let mut path = path.to_vec();
        for _ in 0..16 {
            let k = (0..=path.len())
                .rev()
                .find(|&k| modules.contains(&path[..k]))?;
            let Some(via) = path
                .get(k)
                .and_then(|item| refs.get(&path[..k])?.imports.get(item))
            else {
                return Some(path[..k].to_vec());
            };
            path = [via.as_slice(), &path[k + 1..]].concat();
        }
        None
    };
    let mut graph = Graph::new();
    for (from, r) in &refs {
        for (path, at) in &r.paths {
            let Some(to) = resolve(path) else { continue };
            if to == *from || from.starts_with(&to) {
                continue;
            }
            graph
                .entry(from.clone())
                .or_default()
                .entry(to)
                .or_default()
                .push(at.clone());
        }
    }
    graph
}

/// The graph's strongly connected components of more than one module.
fn cycles(graph: &Graph) -> Vec<Vec<Module>> {
    struct Tarjan<'g> {
        graph: &'g Graph,
        index: std::collections::BTreeMap<&'g Module, (usize, usize)>,
        stack: Vec<&'g Module>,
        on_stack: std::collections::BTreeSet<&'g Module>,
        found: Vec<Vec<Module>>,
    }
    impl<'g> Tarjan<'g> {
        fn visit(&mut self, v: &'g Module) {
            let i = self.index.len();
            self.index.insert(v, (i, i));
            self.stack.push(v);
            self.on_stack.insert(v);
            for w in self.graph.get(v).into_iter().flat_map(|e| e.keys()) {
                if !self.index.contains_key(w) {
                    self.visit(w);
                    let low = self.index[v].1.min(self.index[w].1);
                    self.index.get_mut(v).unwrap().1 = low;
                } else if self.on_stack.contains(w) {
                    let low = self.index[v].1.min(self.index[w].0);
                    self.index.get_mut(v).unwrap().1 = low;
                }
            }
            if self.index[v].0 == self.index[v].1 {
                let mut component = Vec::new();
                while let Some(w) = self.stack.pop() {
                    self.on_stack.remove(w);
                    component.push(w.clone());
                    if w == v {
                        break;
                    }
                }
                if component.len() > 1 {
                    component.sort();
                    self.found.push(component);
                }
            }
        }
    }
    let mut t = Tarjan {
        graph,
        index: Default::default(),
        stack: Vec::new(),
        on_stack: Default::default(),
        found: Vec::new(),
    };
    for v in graph.keys() {
        if !t.index.contains_key(v) {
            t.visit(v);
        }
    }
    t.found.sort();
    t.found
}

/// One cycle through the first module of `component`, each arrow with the
/// line that makes it.
fn describe_cycle(graph: &Graph, component: &[Module]) -> String {
    let inside: std::collections::BTreeSet<&Module> = component.iter().collect();
    let start = &component[0];
    // breadth first from `start` back to it, inside the component
    let mut came_from: std::collections::BTreeMap<&Module, &Module> = Default::default();
    let mut queue = std::collections::VecDeque::from([start]);
    'search: while let Some(v) = queue.pop_front() {
        for w in graph[v].keys().filter(|w| inside.contains(w)) {
            if w == start {
                came_from.insert(start, v);
                break 'search;
            }
            if !came_from.contains_key(w) {
                came_from.insert(w, v);
                queue.push_back(w);
            }
        }
    }
    let mut path = vec![start];
    let mut v = came_from[start];
    while v != start {
        path.push(v);
        v = came_from[v];
    }
    path.push(start);
    path.reverse();
    let mut out = format!(
        "{} ({} modules: {})\n",
        path.iter()
            .map(|m| name(m))
            .collect::<Vec<_>>()
            .join(" -> "),
        component.len(),
        component
            .iter()
            .map(|m| name(m))
            .collect::<Vec<_>>()
            .join(", ")
    );
    for pair in path.windows(2) {
        out += &format!(
            "    {} -> {}: {}\n",
            name(pair[0]),
            name(pair[1]),
            graph[pair[0]][pair[1]][0]
        );
    }
    out
}

/// The most lines a source file may have.
const MAX_FILE_LINES: usize = 1200;

/// Every `.rs` file of the library, the binary and the Python bindings (test
/// modules in their own files too) is at most [`MAX_FILE_LINES`] long.
#[test]
fn no_source_file_over_1200_lines() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut over = Vec::new();
    for dir in sources()
        .into_iter()
        .chain([root.join("python").join("src")])
    {
        for f in rust_files(&dir) {
            let lines = std::fs::read_to_string(&f).unwrap().lines().count();
            if lines > MAX_FILE_LINES {
                let shown = f.strip_prefix(root).unwrap_or(&f);
                over.push(format!("{}: {lines} lines", shown.display()));
            }
        }
    }
    assert!(
        over.is_empty(),
        "source files over {MAX_FILE_LINES} lines:\n{}",
        over.join("\n")
    );
}

/// No module depends on itself through others: between the files of `src/`
/// (a folder module's files among themselves too) the arrows go one way.
#[test]
fn no_module_import_cycle() {
    let graph = module_graph();
    let found: Vec<String> = cycles(&graph)
        .iter()
        .map(|c| describe_cycle(&graph, c))
        .collect();
    assert!(
        found.is_empty(),
        "module import cycles:\n{}",
        found.join("\n")
    );
}

/// The layers, lowest first: a module may use its own layer and those
/// below, never one above.
const LAYERS: &[(&str, &[&str])] = &[
    (
        "core",
        &[
            "error",
            "atomic",
            "harmonics",
            "signals",
            "model",
            "sim",
            "hb",
            "observe",
        ],
    ),
    (
        "signal",
        &["extract", "record", "import", "plot", "testbench"],
    ),
    ("identification", &["validate", "fit", "diagnose"]),
    ("app", &["analysis"]),
    ("front end", &["cli", "main"]),
];

fn layer_of(top: &str) -> Option<usize> {
    LAYERS.iter().position(|(_, ms)| ms.contains(&top))
}

/// Each layer is a crate: a module of a layer above is not in scope below
/// it, so the compiler refuses an upward import (`crate::fit` in the signal
/// crate names nothing). This keeps [`LAYERS`], which the scans above read,
/// the same as the crates.
#[test]
fn each_layer_is_a_crate_of_its_own() {
    let top_modules = |src: &Path| -> std::collections::BTreeSet<String> {
        std::fs::read_dir(src)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_dir() || p.extension().is_some_and(|x| x == "rs"))
            .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
            .filter(|m| m != "lib")
            .collect()
    };
    let sources = sources();
    for (i, (layer, modules)) in LAYERS.iter().enumerate() {
        // the application and its front ends share the root package
        let at = i.min(CRATES.len() - 1);
        let found = top_modules(&sources[at]);
        for m in *modules {
            assert!(
                found.contains(*m),
                "the {layer} layer's {m} is not in {}",
                CRATES[at]
            );
        }
    }
    for (at, src) in sources.iter().enumerate() {
        for m in top_modules(src) {
            let layer = layer_of(&m).unwrap_or_else(|| panic!("{m} is in no layer"));
            assert_eq!(
                layer.min(CRATES.len() - 1),
                at,
                "{m} ({}) is in {}",
                LAYERS[layer].0,
                CRATES[at]
            );
        }
    }
}

#[test]
fn no_layer_uses_a_layer_above_it() {
    let graph = module_graph();
    let mut found = Vec::new();
    let mut unplaced = std::collections::BTreeSet::new();
    for (from, to) in graph
        .iter()
        .flat_map(|(f, e)| e.iter().map(move |t| (f, t)))
    {
        let (Some(a), Some(b)) = (from.first(), to.0.first()) else {
            continue;
        };
        let (Some(la), Some(lb)) = (layer_of(a), layer_of(b)) else {
            unplaced.extend([a, b].into_iter().filter(|m| layer_of(m).is_none()));
            continue;
        };
        if lb > la {
            for at in to.1 {
                found.push(format!(
                    "{} ({}) uses {} ({}): {at}",
                    name(from),
                    LAYERS[la].0,
                    name(to.0),
                    LAYERS[lb].0
                ));
            }
        }
    }
    assert!(
        unplaced.is_empty(),
        "modules in no layer (add them to LAYERS): {unplaced:?}"
    );
    assert!(found.is_empty(), "upward references:\n{}", found.join("\n"));
}

#[test]
fn the_module_scanner_reads_paths_as_rust_does() {
    let paths = use_tree_paths("crate::a::{b, c::{d, e as f}, self}");
    let names: Vec<(String, &str)> = paths
        .iter()
        .map(|(p, n)| (p.join("::"), n.as_str()))
        .collect();
    assert_eq!(
        names,
        vec![
            ("crate::a::b".to_string(), "b"),
            ("crate::a::c::d".to_string(), "d"),
            ("crate::a::c::e".to_string(), "f"),
            ("crate::a".to_string(), "a"),
        ]
    );
    let seen: Vec<String> =
        module_paths("let x = crate::fit::time::f(super::g::<u8>(), a::crate_b);")
            .iter()
            .map(|p| p.join("::"))
            .collect();
    assert_eq!(seen, vec!["crate::fit::time::f", "super::g"]);
    let modules = [vec!["hb".to_string()], vec!["hb".into(), "newton".into()]]
        .into_iter()
        .collect();
    let hb_aft = ["hb".to_string(), "aft".into()];
    let to = |p: &str| {
        absolute(
            &hb_aft,
            &p.split("::").map(String::from).collect::<Vec<_>>(),
            &modules,
        )
        .map(|a| a.join("::"))
    };
    assert_eq!(
        to("super::newton::Core").as_deref(),
        Some("hb::newton::Core")
    );
    assert_eq!(
        to("crate::model::Element").as_deref(),
        Some("model::Element")
    );
    assert_eq!(to("std::sync::Arc"), None);
}

/// The most lines of code (blank and comment lines not counted) a function
/// of the library may have, as clippy's `too_many_lines` counts them.
const MAX_FUNCTION_LINES: usize = 100;

/// The library's functions still over [`MAX_FUNCTION_LINES`], by file and
/// name, each to be split by what its parts do. The list only shrinks: a
/// function listed here that is short enough fails the test too, so that
/// its entry goes.
const LONG_FUNCTIONS: &[&str] = &[
    "crates/hystid-core/src/hb/aft/mod.rs: evaluate",
    "crates/hystid-core/src/hb/continuation.rs: trace",
    "crates/hystid-core/src/hb/newton.rs: newton",
    "crates/hystid-signal/src/extract/stepped/mod.rs: reduce_stepped_as",
    "crates/hystid-signal/src/import/uff/channels.rs: load",
    "crates/hystid-signal/src/testbench/mod.rs: run_level",
    "crates/hystid-identify/src/diagnose/mod.rs: diagnose",
    "crates/hystid-identify/src/fit/identify/mod.rs: identify_from",
    "crates/hystid-identify/src/fit/time/driver.rs: identify_time",
    "src/analysis/diagnose.rs: refine_in_time",
    "src/analysis/multisine.rs: diagnose_multisine",
    "src/analysis/validate.rs: validate_on",
];

/// The lines without their string and character literals' contents, so
/// that a brace in `"{v}"` or `'{'` is not counted; a string may run over
/// several lines (`"… \` then the rest).
fn without_literals(lines: &[&str]) -> Vec<String> {
    let mut in_string = false;
    lines
        .iter()
        .map(|line| {
            let mut out = String::with_capacity(line.len());
            let mut chars = line.chars().peekable();
            while let Some(c) = chars.next() {
                if in_string {
                    match c {
                        '\\' => {
                            chars.next();
                        }
                        '"' => {
                            in_string = false;
                            out.push('"');
                        }
                        _ => {}
                    }
                    continue;
                }
                match c {
                    '"' => {
                        in_string = true;
                        out.push('"');
                    }
                    '\'' => {
                        // a character literal ('{', '\'') or a lifetime ('a)
                        let rest: String = chars.clone().take(3).collect();
                        let literal = rest.starts_with('\\') || rest.chars().nth(1) == Some('\'');
                        if literal {
                            while let Some(s) = chars.next() {
                                if s == '\\' {
                                    chars.next();
                                } else if s == '\'' {
                                    break;
                                }
                            }
                            out.push_str("' '");
                        } else {
                            out.push('\'');
                        }
                    }
                    '/' if chars.peek() == Some(&'/') => break,
                    c => out.push(c),
                }
            }
            out
        })
        .collect()
}

/// Every function with a body in `text` (test items left out): its name and
/// its lines of code, from the line of its body's opening brace to its
/// closing one.
fn function_lengths(text: &str) -> Vec<(String, usize)> {
    let code: Vec<&str> = code_lines(text).into_iter().map(|(_, l)| l).collect();
    let lines = without_literals(&code);
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let t = line.trim_start();
        let t = ["pub(crate) ", "pub(super) ", "pub "]
            .iter()
            .find_map(|p| t.strip_prefix(p))
            .unwrap_or(t);
        let t = ["const ", "unsafe "]
            .iter()
            .find_map(|p| t.strip_prefix(p))
            .unwrap_or(t);
        let Some(rest) = t.strip_prefix("fn ") else {
            continue;
        };
        let name: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        // the body: from the first `{` (before any `;`) to its match
        // (a `;` inside the signature's brackets, `[f64; 3]`, is not its end)
        let (mut depth, mut nest, mut opened, mut counted) = (0i64, 0i64, false, 0usize);
        let mut declared_only = false;
        for l in &lines[i..] {
            for c in l.chars() {
                match c {
                    '{' => {
                        depth += 1;
                        opened = true;
                    }
                    '}' => depth -= 1,
                    '(' | '[' if !opened => nest += 1,
                    ')' | ']' if !opened => nest -= 1,
                    ';' if !opened && nest == 0 => {
                        declared_only = true;
                        break;
                    }
                    _ => {}
                }
            }
            // counted from the body's opening line, as clippy does
            if opened && !l.trim().is_empty() {
                counted += 1;
            }
            if declared_only || (opened && depth <= 0) {
                break;
            }
        }
        if opened {
            out.push((name, counted));
        }
    }
    out
}

#[test]
fn the_function_scanner_counts_code_lines() {
    let text = "pub fn a(x: u8) -> u8 {\n    // why\n\n    let s = \"{\\\n        {{ \\\"q\\\" }}\";\n    let c = '}';\n}\n\
                fn b<'a>(s: &'a str, _: [u8; 2])\nwhere\n    u8: Copy,\n{\n    s.len();\n}\n\
                trait T {\n    fn c(&self);\n}\n";
    assert_eq!(
        function_lengths(text),
        vec![("a".to_string(), 5), ("b".to_string(), 3)]
    );
}

/// No function of the library crates or of the application's library is
/// over [`MAX_FUNCTION_LINES`] lines of code, but those listed in
/// [`LONG_FUNCTIONS`], and each listed one still is.
#[test]
fn no_function_over_100_lines() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut over = Vec::new();
    for f in library_files() {
        if f.starts_with(src().join("cli")) || f.ends_with("main.rs") {
            continue;
        }
        let text = std::fs::read_to_string(&f).unwrap();
        let shown = f.strip_prefix(root).unwrap_or(&f).display().to_string();
        for (name, n) in function_lengths(&text) {
            if n > MAX_FUNCTION_LINES {
                over.push((format!("{shown}: {name}"), n));
            }
        }
    }
    let unlisted: Vec<String> = over
        .iter()
        .filter(|(f, _)| !LONG_FUNCTIONS.contains(&f.as_str()))
        .map(|(f, n)| format!("{f} ({n} lines)"))
        .collect();
    let fixed: Vec<&&str> = LONG_FUNCTIONS
        .iter()
        .filter(|l| !over.iter().any(|(f, _)| f == *l))
        .collect();
    assert!(
        unlisted.is_empty() && fixed.is_empty(),
        "functions over {MAX_FUNCTION_LINES} lines of code:\n{}\nlisted but no longer long (remove them from LONG_FUNCTIONS):\n{:?}",
        unlisted.join("\n"),
        fixed
    );
}
