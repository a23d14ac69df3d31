//! Tidy checks over the source tree: every Rust file starts with a `//!` doc comment saying
//! what it is for (module docs are the map of the house), no file carries leftover debugging
//! macros, the files and `tacsim` subcommands README.md, ARCHITECTURE.md and the guides in
//! `docs/guide/` name exist, the README stays a short front page linking every guide, the guides
//! stay references under 60 KB, no document dates a result other than by commit and date, and no
//! module of a crate imports in a cycle.

use std::path::{Path, PathBuf};

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            if p.file_name().is_some_and(|n| n != "target") {
                rust_files(&p, out);
            }
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

#[test]
fn every_rust_file_has_module_docs() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for dir in [
        "src",
        "tests",
        "sim/src",
        "sim/tests",
        "sim/benches",
        "data/src",
        "fem/src",
        "fem/tests",
        "fem/examples",
        "model/src",
        "model/tests",
        "python/src",
        "xtask/src",
    ] {
        rust_files(&root.join(dir), &mut files);
    }
    assert!(files.len() > 20, "found only {} files", files.len());
    let mut missing = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).expect("readable");
        if !text.trim_start().starts_with("//!") {
            missing.push(f.strip_prefix(&root).unwrap_or(f).display().to_string());
        }
        if text.contains(&["dbg", "!("].concat()) {
            missing.push(format!("{} (leftover debug macro)", f.display()));
        }
    }
    assert!(missing.is_empty(), "files without a leading //! doc comment: {missing:?}");
}

/// Where a path named in the docs may be relative to: the repository or a crate's sources.
const DOC_ROOTS: [&str; 11] =
    ["", "sim/src/", "src/", "model/src/", "model/", "data/src/", "python/", "python/src/", "sim/", "fem/", "fem/src/"];
/// File kinds whose paths the docs name.
const DOC_EXTENSIONS: [&str; 8] = [".rs", ".toml", ".py", ".md", ".json", ".patch", ".sh", ".pyi"];

/// The code spans of a Markdown text: inline `code` and the lines of fenced blocks.
fn code_spans(text: &str) -> Vec<String> {
    let mut spans = Vec::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            spans.push(line.to_owned());
        } else {
            spans.extend(line.split('`').skip(1).step_by(2).map(str::to_owned));
        }
    }
    spans
}

/// The `tacsim` subcommands, from `tacsim --help`.
fn subcommands() -> Vec<String> {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tacsim")).arg("--help").output().expect("tacsim runs");
    let help = String::from_utf8_lossy(&o.stdout).into_owned();
    help.split("Commands:")
        .nth(1)
        .and_then(|t| t.split("Options:").next())
        .map(|t| t.lines().filter_map(|l| l.split_whitespace().next()).map(str::to_owned).collect())
        .unwrap_or_default()
}

/// The guides (`docs/guide/*.md`), relative to the root, sorted.
fn guides(root: &Path) -> Vec<PathBuf> {
    let mut guides: Vec<PathBuf> = std::fs::read_dir(root.join("docs/guide"))
        .expect("docs/guide")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "md"))
        .map(|p| p.strip_prefix(root).expect("under the root").to_path_buf())
        .collect();
    guides.sort();
    guides
}

#[test]
fn the_files_and_subcommands_the_docs_name_exist() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let commands = subcommands();
    assert!(commands.iter().any(|c| c == "generate"), "{commands:?}");
    let mut stale = Vec::new();
    let mut docs = vec![PathBuf::from("README.md"), PathBuf::from("ARCHITECTURE.md")];
    docs.extend(guides(&root));
    for doc in &docs {
        let text = std::fs::read_to_string(root.join(doc)).expect("readable");
        let doc = doc.display();
        for span in code_spans(&text) {
            let tokens: Vec<&str> = span.split_whitespace().collect();
            // `tacsim SUBCOMMAND ...` at the start of a span or after a shell prompt.
            let start = usize::from(tokens.first() == Some(&"$"));
            if tokens.get(start) == Some(&"tacsim")
                && let Some(sub) = tokens
                    .get(start + 1)
                    .filter(|t| !t.starts_with('-') && t.chars().all(|c| c.is_ascii_lowercase() || c == '-'))
                && !commands.iter().any(|c| c == sub)
            {
                stale.push(format!("{doc}: `tacsim {sub}` is not a subcommand"));
            }
            for t in tokens {
                let t = t.trim_matches(|c: char| ",;:()[]\"'".contains(c));
                let named = t.contains('/') && DOC_EXTENSIONS.iter().any(|e| t.ends_with(e));
                // Outputs, other trees, globs, `git show REV:path`, placeholders (`DIR/...`).
                let placeholder =
                    t.split('/').next().is_some_and(|c| c.chars().all(|c| c.is_ascii_uppercase() || c == '_'));
                let elsewhere = ["target/", "../", "/", "~", "$"].iter().any(|p| t.starts_with(p))
                    || t.contains('*')
                    || t.contains(':')
                    || placeholder;
                if named && !elsewhere && !DOC_ROOTS.iter().any(|r| root.join(format!("{r}{t}")).exists()) {
                    stale.push(format!("{doc}: {t} does not exist"));
                }
            }
        }
    }
    stale.sort();
    stale.dedup();
    assert!(stale.is_empty(), "the docs name what is not there: {stale:#?}");
}

/// The README stays a front page (set-up, tour, headline figures, links); the long form
/// lives in `docs/guide/`, and the README links every guide there is.
#[test]
fn the_readme_is_short_and_links_every_guide() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(root.join("README.md")).expect("readable");
    let lines = readme.lines().count();
    assert!(lines <= 200, "README.md has {lines} lines: move the long form into docs/guide/");
    let longest = readme.lines().map(|l| l.chars().count()).max().unwrap_or(0);
    assert!(longest <= 200, "README.md has a line of {longest} characters: at most 200");
    for guide in guides(&root) {
        let name = guide.display().to_string();
        assert!(readme.contains(&name), "README.md does not link {name}");
    }
}

/// The Markdown files of the repository (README, ARCHITECTURE, `docs/`), relative to the root.
fn markdown_files(root: &Path, dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(root.join(dir)) else { return };
    for e in entries.flatten() {
        let p = e.path();
        let rel = p.strip_prefix(root).expect("under the root").to_path_buf();
        if p.is_dir() {
            markdown_files(root, &rel, out);
        } else if p.extension().is_some_and(|x| x == "md") {
            out.push(rel);
        }
    }
}

/// Words that date a result by who or when worked on it instead of by commit and date.
const UNDATED: [&str; 3] = ["session", "working stretch", "this try"];

/// The same in code comments, where `session` alone may name a type.
const UNDATED_IN_CODE: [&str; 6] =
    ["a later session", "this session", "the same session", "previous session", "last session", "session's machine"];

/// The documents speak of the project, its commits and dates: no result is dated by the
/// working session that produced it ("a later session", "this session's machine").
#[test]
fn the_docs_date_results_by_commit_and_date_only() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut docs = vec![PathBuf::from("README.md"), PathBuf::from("ARCHITECTURE.md")];
    markdown_files(&root, Path::new("docs"), &mut docs);
    assert!(docs.len() > 10, "found only {} Markdown files", docs.len());
    let mut found = Vec::new();
    for doc in &docs {
        let text = std::fs::read_to_string(root.join(doc)).expect("readable").to_lowercase();
        for (i, line) in text.lines().enumerate() {
            found.extend(
                UNDATED.iter().filter(|w| line.contains(*w)).map(|w| format!("{}:{}: {w}", doc.display(), i + 1)),
            );
        }
    }
    // Comments in the code: the phrases (the word alone is also a training session's type).
    let mut sources = Vec::new();
    for dir in ["src", "tests", "sim", "model", "data", "fem", "explore", "python/src", "xtask"] {
        rust_files(&root.join(dir), &mut sources);
    }
    // This file names the phrases it looks for.
    for file in sources.iter().filter(|f| !f.ends_with("tests/tidy.rs")) {
        let text = std::fs::read_to_string(file).expect("readable").to_lowercase();
        for (i, line) in text.lines().enumerate() {
            let dated = UNDATED_IN_CODE.iter().find(|w| line.contains(*w));
            found.extend(
                dated.map(|w| format!("{}:{}: {w}", file.strip_prefix(&root).unwrap_or(file).display(), i + 1)),
            );
        }
    }
    assert!(found.is_empty(), "date these by commit and date instead: {found:#?}");
}

/// No guide is a notebook: each stays under 60 KB, the history in `docs/experiments/`.
#[test]
fn the_guides_stay_references() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let long: Vec<String> = guides(&root)
        .into_iter()
        .filter_map(|g| {
            let bytes = std::fs::metadata(root.join(&g)).expect("readable").len();
            (bytes > 60_000).then(|| format!("{} ({bytes} bytes)", g.display()))
        })
        .collect();
    assert!(long.is_empty(), "move the history into docs/experiments/: {long:?}");
}

/// A crate's modules (`a::b`, the root `""`) and their files, from `src`.
fn modules(src: &Path) -> Vec<(String, PathBuf)> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    files
        .into_iter()
        .map(|f| {
            let rel = f.strip_prefix(src).expect("under src").with_extension("");
            let mut name = rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect::<Vec<_>>();
            if name.last().is_some_and(|n| n == "mod" || n == "lib" || n == "main") {
                name.pop();
            }
            (name.join("::"), f)
        })
        .collect()
}

/// The modules a file names through `crate::` paths (comments and the test module left out):
/// for each path the longest prefix that is a module of the crate.
fn named_modules(text: &str, known: &[String]) -> Vec<String> {
    let code: String = text
        .split("#[cfg(test)]\nmod tests")
        .next()
        .unwrap_or_default()
        .lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n");
    let mut out = Vec::new();
    for (i, _) in code.match_indices("crate::") {
        let path: String = code[i + 7..]
            .chars()
            .take_while(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || *c == '_' || *c == ':')
            .collect();
        let parts: Vec<&str> = path.split("::").filter(|p| !p.is_empty()).collect();
        if let Some(m) = (1..=parts.len()).rev().map(|k| parts[..k].join("::")).find(|m| known.contains(m)) {
            out.push(m);
        }
    }
    out
}

/// Data flows one way: no file of a crate reaches, through `crate::` paths, a module that
/// reaches it back (checked on every crate's sources; `super::` paths stay inside a module).
#[test]
fn no_module_of_the_workspace_imports_in_a_cycle() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let mut cycles = Vec::new();
    for krate in ["src", "sim/src", "model/src", "data/src", "fem/src", "python/src"] {
        let mods = modules(&root.join(krate));
        let names: Vec<String> = mods.iter().map(|m| m.0.clone()).collect();
        let edges: Vec<Vec<usize>> = mods
            .iter()
            .map(|(name, file)| {
                let text = std::fs::read_to_string(file).expect("readable");
                let mut to: Vec<usize> = named_modules(&text, &names)
                    .iter()
                    .filter(|m| *m != name && !m.is_empty())
                    .filter_map(|m| names.iter().position(|n| n == m))
                    .collect();
                to.sort_unstable();
                to.dedup();
                to
            })
            .collect();
        // A module reaches another when a path of edges leads there; a cycle is a pair that
        // reach each other.
        let reach = |from: usize| {
            let mut seen = vec![false; names.len()];
            let mut todo = edges[from].clone();
            while let Some(v) = todo.pop() {
                if !std::mem::replace(&mut seen[v], true) {
                    todo.extend(&edges[v]);
                }
            }
            seen
        };
        let all: Vec<Vec<bool>> = (0..names.len()).map(reach).collect();
        for a in 0..names.len() {
            for b in a + 1..names.len() {
                if all[a][b] && all[b][a] {
                    cycles.push(format!("{krate}: {} <-> {}", names[a], names[b]));
                }
            }
        }
    }
    assert!(cycles.is_empty(), "modules that import each other (move the shared part down): {cycles:#?}");
}
