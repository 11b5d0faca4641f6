//! ARCHITECTURE.md, the project's map, held to the code it describes.
//!
//! - The crate map (the first fenced block) draws every workspace crate and,
//!   under it, every workspace crate it depends on (`→ a, b`, normal
//!   dependencies, optional ones included); `cargo metadata` must show exactly
//!   those edges, and each crate must sit above every crate it imports.
//! - Every path the page names in backticks exists: from the repository's
//!   root, or as the tail of a path inside it (`calib/run.rs`,
//!   `commands/push.rs`), and every top-level module of the host's three
//!   crates is named in its crate's paragraph.
//! - No command in `host/src/commands/` imports another command: what two of
//!   them share lives in `helpers.rs` or `device_args.rs` there.
//!
//! Each failure names the edge, path, module or import that is out of step.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository's root (the workspace's), from this crate's directory.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("host/ has a parent")
        .to_path_buf()
}

fn architecture() -> String {
    fs::read_to_string(root().join("ARCHITECTURE.md")).expect("ARCHITECTURE.md is readable")
}

/// A crate of the map: its directory, and the crates it depends on.
#[derive(Debug, Default)]
struct Drawn {
    /// The directory in the heading's parentheses, relative to the root, without the `/`.
    dir: Option<String>,
    /// The crates named under `→`.
    deps: BTreeSet<String>,
}

/// The crate map: each crate with what it depends on, top floor first.
fn drawn_map(text: &str) -> Vec<(String, Drawn)> {
    let start = text
        .find("```\n")
        .expect("ARCHITECTURE.md has a fenced crate map")
        + 4;
    let block = &text[start..];
    let block = &block[..block.find("```").expect("the crate map's block ends")];
    let mut map: Vec<(String, Drawn)> = Vec::new();
    for line in block.lines().filter(|l| !l.trim().is_empty()) {
        if let Some(deps) = line.trim_start().strip_prefix('→') {
            let (name, crate_) = map
                .last_mut()
                .unwrap_or_else(|| panic!("`{line}` comes before any crate in the map"));
            assert!(
                crate_.deps.is_empty(),
                "crate `{name}` has two `→` lines in the map"
            );
            crate_.deps = dep_names(deps);
        } else {
            assert!(
                !line.starts_with(char::is_whitespace),
                "a line of the crate map neither names a crate nor starts with `→`: `{line}`"
            );
            let name = line
                .split_whitespace()
                .next()
                .unwrap_or_default()
                .to_owned();
            let dir = line
                .strip_prefix(&name)
                .and_then(|rest| rest.trim_start().strip_prefix('('))
                .and_then(|inner| inner.split([',', ')']).next())
                .map(|dir| dir.trim().trim_end_matches('/').to_owned());
            assert!(
                map.iter().all(|(n, _)| *n != name),
                "crate `{name}` is drawn twice in the map"
            );
            map.push((
                name,
                Drawn {
                    dir,
                    ..Drawn::default()
                },
            ));
        }
    }
    map
}

/// The crate names of one `→` line: comma-separated, each its first word
/// (what follows in parentheses says why); `nothing` for none.
fn dep_names(line: &str) -> BTreeSet<String> {
    let mut names = BTreeSet::new();
    let mut depth = 0usize;
    let mut current = String::new();
    for c in line.chars().chain([',']) {
        match c {
            '(' => depth += 1,
            ')' => depth = depth.saturating_sub(1),
            ',' if depth == 0 => {
                if let Some(name) = current.split_whitespace().next()
                    && name != "nothing"
                {
                    names.insert(name.to_owned());
                }
                current.clear();
            }
            _ if depth == 0 => current.push(c),
            _ => {}
        }
    }
    names
}

/// A workspace crate as `cargo metadata` has it.
struct Actual {
    /// Its directory, relative to the root, without the `/` (empty at the root).
    dir: String,
    /// The workspace crates among its normal dependencies (optional ones too).
    deps: BTreeSet<String>,
}

/// Every workspace crate and its normal dependencies on the others.
fn cargo_map() -> BTreeMap<String, Actual> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_owned());
    let output = Command::new(cargo)
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(root())
        .output()
        .expect("cargo metadata runs");
    assert!(
        output.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let metadata: serde_json::Value =
        serde_json::from_slice(&output.stdout).expect("cargo metadata prints JSON");
    let packages = metadata["packages"]
        .as_array()
        .expect("cargo metadata lists packages");
    let names: BTreeSet<&str> = packages.iter().filter_map(|p| p["name"].as_str()).collect();
    let root = root();
    packages
        .iter()
        .map(|p| {
            let name = p["name"].as_str().expect("a package has a name").to_owned();
            let manifest = PathBuf::from(p["manifest_path"].as_str().expect("a manifest path"));
            let dir = manifest
                .parent()
                .and_then(|d| d.strip_prefix(&root).ok())
                .map(|d| d.to_string_lossy().replace('\\', "/"))
                .unwrap_or_default();
            let deps = p["dependencies"]
                .as_array()
                .expect("a package lists its dependencies")
                .iter()
                .filter(|d| d["kind"].is_null())
                .filter_map(|d| d["name"].as_str())
                .filter(|d| names.contains(d))
                .map(str::to_owned)
                .collect();
            (name, Actual { dir, deps })
        })
        .collect()
}

#[test]
fn the_crate_map_draws_every_crate_and_every_edge_cargo_has() {
    let drawn = drawn_map(&architecture());
    let actual = cargo_map();
    let mut faults = Vec::new();
    let drawn_names: BTreeSet<&String> = drawn.iter().map(|(n, _)| n).collect();
    for name in actual.keys().filter(|n| !drawn_names.contains(n)) {
        faults.push(format!(
            "crate `{name}` is in the workspace but not in the map"
        ));
    }
    for (position, (name, crate_)) in drawn.iter().enumerate() {
        let Some(real) = actual.get(name) else {
            faults.push(format!(
                "the map draws crate `{name}`, which the workspace does not have"
            ));
            continue;
        };
        match &crate_.dir {
            Some(dir) if *dir == real.dir => {}
            Some(dir) => faults.push(format!(
                "the map puts `{name}` in `{dir}/`, cargo in `{}/`",
                real.dir
            )),
            None => faults.push(format!(
                "the map gives no directory for `{name}` (`{}/`)",
                real.dir
            )),
        }
        for dep in real.deps.difference(&crate_.deps) {
            faults.push(format!("missing edge in the map: {name} → {dep}"));
        }
        for dep in crate_.deps.difference(&real.deps) {
            faults.push(format!(
                "extra edge in the map: {name} → {dep} (not a normal dependency)"
            ));
        }
        for dep in &crate_.deps {
            if drawn[..=position].iter().any(|(n, _)| n == dep) {
                faults.push(format!(
                    "the map draws `{name}` below `{dep}`, which it imports: a crate sits above what it imports"
                ));
            }
        }
    }
    assert!(
        faults.is_empty(),
        "ARCHITECTURE.md's crate map is out of step with Cargo:\n  {}",
        faults.join("\n  ")
    );
}

/// Every span in backticks, with its whitespace (a line break) made one space.
fn backticked(text: &str) -> Vec<String> {
    let mut spans = Vec::new();
    let mut in_fence = false;
    let mut prose = String::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            in_fence = !in_fence;
            continue;
        }
        if !in_fence {
            prose.push_str(line);
            prose.push('\n');
        }
    }
    let mut parts = prose.split('`');
    parts.next();
    while let Some(inside) = parts.next() {
        spans.push(inside.split_whitespace().collect::<Vec<_>>().join(" "));
        parts.next();
    }
    spans
}

/// Whether a span in backticks names a file or folder: one word of path
/// characters with a `/`, or ending in a source or document extension.
/// Files the program writes (`report.html`) are not in the repository and
/// are named without such an extension.
fn is_path(span: &str) -> bool {
    const EXTENSIONS: [&str; 7] = [".rs", ".md", ".toml", ".urdf", ".x", ".s", ".lock"];
    !span.is_empty()
        && span
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "._-/".contains(c))
        && !span.contains("://")
        && (span.contains('/') || EXTENSIONS.iter().any(|e| span.ends_with(e)))
}

/// Every file and folder of the repository, relative to the root, leaving
/// out build output, dependencies and hidden folders.
fn repository_paths() -> Vec<String> {
    fn walk(dir: &Path, root: &Path, out: &mut Vec<String>) {
        let Ok(entries) = fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') || name == "target" || name == "node_modules" {
                continue;
            }
            let relative = path
                .strip_prefix(root)
                .expect("inside the root")
                .to_string_lossy()
                .replace('\\', "/");
            out.push(relative);
            if path.is_dir() {
                walk(&path, root, out);
            }
        }
    }
    let root = root();
    let mut out = Vec::new();
    walk(&root, &root, &mut out);
    out
}

#[test]
fn every_path_the_map_names_exists() {
    let root = root();
    let paths = repository_paths();
    let missing: Vec<String> = backticked(&architecture())
        .into_iter()
        .filter(|span| is_path(span))
        .filter(|span| {
            let path = span.trim_end_matches('/');
            let tail = format!("/{path}");
            !root.join(path).exists() && !paths.iter().any(|p| p.ends_with(&tail))
        })
        .collect();
    assert!(
        missing.is_empty(),
        "ARCHITECTURE.md names paths that are not in the repository (neither from the root nor inside a folder): {missing:?}"
    );
}

/// The paragraph of ARCHITECTURE.md on one crate: from its `**`dir/`**`
/// heading to the next blank line.
fn paragraph<'a>(text: &'a str, dir: &str) -> &'a str {
    let heading = format!("**`{dir}/`**");
    let start = text
        .find(&heading)
        .unwrap_or_else(|| panic!("ARCHITECTURE.md has no paragraph starting `{heading}`"));
    let rest = &text[start..];
    &rest[..rest.find("\n\n").unwrap_or(rest.len())]
}

#[test]
fn every_top_level_module_of_the_host_crates_is_on_the_map() {
    let text = architecture();
    let mut missing = Vec::new();
    for dir in ["host/engine", "host/core", "host"] {
        let spans = backticked(paragraph(&text, dir));
        let src = root().join(dir).join("src");
        let entries = fs::read_dir(&src).unwrap_or_else(|e| panic!("{}: {e}", src.display()));
        for entry in entries.flatten() {
            let file = entry.file_name().to_string_lossy().into_owned();
            let is_dir = entry.path().is_dir();
            let module = match file.strip_suffix(".rs") {
                Some("lib" | "main") => continue,
                Some(module) => module.to_owned(),
                None if is_dir => file.clone(),
                None => continue,
            };
            let prefix = format!("{dir}/src/");
            let named = spans.iter().any(|span| {
                let span = span.strip_prefix(&prefix).unwrap_or(span);
                span == module
                    || span == format!("{module}.rs")
                    || span.starts_with(&format!("{module}/"))
            });
            if !named {
                missing.push(format!("{dir}/src/{file}{}", if is_dir { "/" } else { "" }));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "ARCHITECTURE.md's paragraph on the crate does not name these top-level modules (in backticks): {missing:?}"
    );
}

/// The modules in `host/src/commands/` that all commands may use.
const SHARED: [&str; 2] = ["helpers", "device_args"];

/// Every `.rs` file under `dir`.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in fs::read_dir(dir).expect("a readable folder").flatten() {
        let path = entry.path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Source without its `//` comments: a doc comment may mention another
/// command, an import may not.
fn without_comments(source: &str) -> String {
    source
        .lines()
        .map(|line| match line.find("//") {
            Some(at) if !line[..at].ends_with(':') => &line[..at],
            _ => line,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The modules of `commands` a path in `source` reaches, each with how it
/// was written: `crate::commands::x`, `commands::{x, y}`, and `super::x`
/// (`super::super::x` from a command's folder), as `depth` says how many
/// `super`s lead from the file's module up to `commands`.
fn reached_commands(source: &str, depth: usize) -> Vec<(String, String)> {
    let supers = "super::".repeat(depth);
    let mut reached = Vec::new();
    for prefix in ["commands::", supers.as_str()] {
        let mut rest = source;
        while let Some(at) = rest.find(prefix) {
            let before = &rest[..at];
            let after = &rest[at + prefix.len()..];
            rest = after;
            // `super::super::x` read as `super::` from a deeper `super::`: skip
            // prefixes that are only the tail of a longer chain.
            if prefix.starts_with("super") && before.ends_with("super::") {
                continue;
            }
            let names: Vec<&str> = if let Some(group) = after.strip_prefix('{') {
                let group = &group[..group.find('}').unwrap_or(group.len())];
                group
                    .split(',')
                    .filter_map(|item| item.trim().split("::").next())
                    .collect()
            } else {
                vec![
                    after
                        .split(|c: char| !(c.is_alphanumeric() || c == '_'))
                        .next()
                        .unwrap_or_default(),
                ]
            };
            for name in names.into_iter().filter(|n| !n.is_empty()) {
                reached.push((name.to_owned(), format!("{prefix}{name}")));
            }
        }
    }
    reached
}

#[test]
fn no_command_imports_another() {
    let commands = root().join("host/src/commands");
    let mut files = Vec::new();
    rust_files(&commands, &mut files);
    let command_modules: BTreeSet<String> = fs::read_dir(&commands)
        .expect("host/src/commands is readable")
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let module = name.strip_suffix(".rs").unwrap_or(&name).to_owned();
            (e.path().is_dir() || name.ends_with(".rs")).then_some(module)
        })
        .filter(|m| m != "mod" && !SHARED.contains(&m.as_str()))
        .collect();
    let mut faults = Vec::new();
    for file in files {
        let relative = file.strip_prefix(&commands).expect("inside commands/");
        let parts: Vec<String> = relative
            .iter()
            .map(|p| p.to_string_lossy().into_owned())
            .collect();
        let own = parts[0].strip_suffix(".rs").unwrap_or(&parts[0]).to_owned();
        if !command_modules.contains(&own) {
            continue;
        }
        // commands/x.rs and commands/x/mod.rs are module commands::x (one
        // `super` to commands); commands/x/y.rs is commands::x::y (two).
        let depth = if parts.len() == 1 || parts.last().is_some_and(|p| p == "mod.rs") {
            1
        } else {
            parts.len()
        };
        let source = without_comments(&fs::read_to_string(&file).expect("a readable file"));
        for (module, written) in reached_commands(&source, depth) {
            if module != own && command_modules.contains(&module) {
                faults.push(format!(
                    "host/src/commands/{} uses `{written}`: a command imports another command (share it through helpers.rs or device_args.rs)",
                    parts.join("/")
                ));
            }
        }
    }
    assert!(faults.is_empty(), "{}", faults.join("\n"));
}

#[test]
fn the_checks_read_the_map_as_drawn() {
    assert_eq!(
        dep_names(" lrmcal-core, firmware (feature sim: the board, here), model"),
        ["firmware", "lrmcal-core", "model"]
            .map(str::to_owned)
            .into()
    );
    assert!(dep_names(" nothing").is_empty());
    assert!(is_path("calib/run.rs") && is_path("memory.x") && is_path("tests/emulator/"));
    assert!(!is_path("report.html") && !is_path("j3.d") && !is_path("core::io::arm_source"));
    assert!(!is_path("socket://HOST:PORT"));
    let reached = |source: &str, depth| {
        reached_commands(source, depth)
            .into_iter()
            .map(|(m, _)| m)
            .collect::<Vec<_>>()
    };
    assert_eq!(
        reached("use crate::commands::{helpers::x, plan};", 1),
        ["helpers", "plan"]
    );
    assert_eq!(reached("value_parser = super::plan::finite", 1), ["plan"]);
    assert_eq!(reached("use super::mover;", 2), Vec::<String>::new());
    assert_eq!(reached("use super::super::plan;", 2), ["plan"]);
}
