//! The module graph of both crates has no import cycles.
//!
//! Every source file of `simserpent-core` (`src/`) and of `simserpent` (`../../src/`) is read,
//! comments and string literals are dropped, and every path that names a module of its own crate
//! (`use crate::…`, `use super::…`, `self::…`, and `crate::a::b::Item` written inline) becomes an
//! edge from the file's module to the module it names. Test code (`#[cfg(test)] mod …`) is left
//! out: a test may reach anywhere. Two graphs are checked for cycles:
//!
//! - between the top-level modules of a crate (`config`, `model`, `run`, `record`, …);
//! - between the sibling submodules of every module (`record::parquet` and `record::sink`, …).
//!
//! A path that names an item re-exported by a parent (`super::Observation` when the parent says
//! `pub use gait::Observation`) counts as naming the child that defines it. A cycle fails the test
//! with the modules in order and, for each edge, one file and path that makes it.
//!
//! Run: `cargo test -p simserpent-core --test module_graph` (with `MODULE_GRAPH_EDGES=1` and
//! `-- --nocapture` it prints every edge).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A module path: its segments below the crate root (`[]` is the crate root).
type ModPath = Vec<String>;

/// One source file: its module path and its code without comments, strings and test modules.
struct Source {
    module: ModPath,
    file: PathBuf,
    code: String,
}

/// The crate rooted at `src` (lib.rs): every `.rs` file with its module path.
fn read_crate(src: &Path) -> Vec<Source> {
    let mut files = Vec::new();
    collect(src, &mut files);
    files.sort();
    files
        .into_iter()
        .filter(|f| f.file_name().is_some_and(|n| n != "main.rs"))
        .filter(|f| !f.components().any(|c| c.as_os_str() == "bin"))
        .map(|file| {
            let rel = file.strip_prefix(src).expect("file under src");
            let mut module: ModPath =
                rel.parent().into_iter().flat_map(|p| p.iter()).map(|s| s.to_string_lossy().into_owned()).collect();
            let stem = rel.file_stem().expect("file stem").to_string_lossy().into_owned();
            if stem != "mod" && stem != "lib" {
                module.push(stem);
            }
            let text = std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
            Source { module, code: drop_test_modules(&strip(&text)), file }
        })
        .collect()
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    let entries = std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    for entry in entries {
        let path = entry.expect("directory entry").path();
        if path.is_dir() {
            collect(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The code without comments, string and character literals (their contents become spaces).
fn strip(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < c.len() {
        if c[i] == '/' && c.get(i + 1) == Some(&'/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if c[i] == '/' && c.get(i + 1) == Some(&'*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
            out.push(' ');
        } else if c[i] == 'r' && (c.get(i + 1) == Some(&'"') || c.get(i + 1) == Some(&'#')) && !ident_char(&c, i) {
            // Raw string r"…", r#"…"#.
            let mut j = i + 1;
            let mut hashes = 0;
            while c.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if c.get(j) != Some(&'"') {
                out.push(c[i]);
                i += 1;
                continue;
            }
            j += 1;
            while j < c.len() {
                if c[j] == '"' && (0..hashes).all(|h| c.get(j + 1 + h) == Some(&'#')) {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            out.push_str("\"\"");
            i = j;
        } else if c[i] == '"' {
            i += 1;
            while i < c.len() && c[i] != '"' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if c[i] == '\'' {
            // A character literal ('x', '\n', '\u{..}') or a lifetime ('a).
            if c.get(i + 1) == Some(&'\\') {
                let mut j = i + 2;
                while j < c.len() && c[j] != '\'' {
                    j += 1;
                }
                i = j + 1;
                out.push_str("' '");
            } else if c.get(i + 2) == Some(&'\'') {
                i += 3;
                out.push_str("' '");
            } else {
                out.push(c[i]);
                i += 1;
            }
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

/// Whether the character before `i` continues an identifier (so `c[i]` is inside one).
fn ident_char(c: &[char], i: usize) -> bool {
    i > 0 && (c[i - 1].is_alphanumeric() || c[i - 1] == '_')
}

/// The code without the modules marked `#[cfg(test)]` (the attribute up to the module's
/// closing brace).
fn drop_test_modules(code: &str) -> String {
    let mut out = String::with_capacity(code.len());
    let mut rest = code;
    while let Some(at) = rest.find("#[cfg(test)]") {
        out.push_str(&rest[..at]);
        let after = &rest[at + "#[cfg(test)]".len()..];
        let trimmed = after.trim_start();
        let is_mod = trimmed.starts_with("mod ") || trimmed.starts_with("pub mod ");
        let Some(open) = after.find(['{', ';']) else { break };
        if !is_mod || after.as_bytes()[open] == b';' {
            // An attribute on something else, or `mod tests;` in its own file: keep going.
            rest = &after[open + 1..];
            continue;
        }
        let mut depth = 0;
        let mut end = after.len();
        for (k, ch) in after[open..].char_indices() {
            match ch {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        end = open + k + 1;
                        break;
                    }
                }
                _ => {}
            }
        }
        rest = &after[end..];
    }
    out.push_str(rest);
    out
}

/// Files of test modules declared as `#[cfg(test)] mod tests;` live in `tests.rs` files: left out.
fn is_test_file(s: &Source) -> bool {
    s.module.last().is_some_and(|m| m == "tests")
}

/// Every path of the code that starts with `crate`, `super` or `self`, as a list of segments
/// (`use` trees expanded: `use crate::{a, b::{c, d}}` gives `crate::a`, `crate::b::c`, `crate::b::d`).
fn paths(code: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    let bytes = code.as_bytes();
    // `use` statements: expand their trees.
    let mut i = 0;
    while let Some(at) = code[i..].find("use ") {
        let start = i + at;
        i = start + 4;
        if start > 0 && (bytes[start - 1].is_ascii_alphanumeric() || bytes[start - 1] == b'_') {
            continue;
        }
        let Some(end) = code[i..].find(';') else { break };
        let tree = compact(&code[i..i + end]);
        expand(&tree, &mut Vec::new(), &mut out);
        i += end;
    }
    // Inline paths `crate::a::b`, `super::x`, `self::y` anywhere (use trees included: harmless).
    for root in ["crate::", "super::", "self::"] {
        let mut i = 0;
        while let Some(at) = code[i..].find(root) {
            let start = i + at;
            i = start + root.len();
            if start > 0
                && (bytes[start - 1].is_ascii_alphanumeric() || bytes[start - 1] == b'_' || bytes[start - 1] == b':')
            {
                continue;
            }
            let mut segs = vec![root.trim_end_matches(':').to_string()];
            let mut j = i;
            loop {
                let len = code[j..].find(|c: char| !(c.is_alphanumeric() || c == '_')).unwrap_or(code.len() - j);
                if len == 0 {
                    break;
                }
                segs.push(code[j..j + len].to_string());
                j += len;
                if code[j..].starts_with("::") {
                    j += 2;
                } else {
                    break;
                }
            }
            out.push(segs);
        }
    }
    out.retain(|p| matches!(p.first().map(String::as_str), Some("crate" | "super" | "self")));
    out
}

/// A `use` tree without whitespace, `a as b` written `a@b`.
fn compact(tree: &str) -> String {
    let spaced: String = tree.chars().map(|c| if c.is_whitespace() { ' ' } else { c }).collect();
    spaced.replace(" as ", "@").chars().filter(|c| *c != ' ').collect()
}

/// Expands one `use` tree (without whitespace) under `prefix` into full paths.
fn expand(tree: &str, prefix: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    let tree = tree.trim_start_matches("::");
    if let Some(open) = tree.find('{') {
        let head = &tree[..open];
        let close = tree.rfind('}').unwrap_or(tree.len());
        let inner = &tree[open + 1..close];
        let n = prefix.len();
        prefix.extend(head.split("::").filter(|s| !s.is_empty()).map(str::to_string));
        let mut depth = 0;
        let mut from = 0;
        for (k, ch) in inner.char_indices() {
            match ch {
                '{' => depth += 1,
                '}' => depth -= 1,
                ',' if depth == 0 => {
                    expand(&inner[from..k], prefix, out);
                    from = k + 1;
                }
                _ => {}
            }
        }
        if from < inner.len() {
            expand(&inner[from..], prefix, out);
        }
        prefix.truncate(n);
    } else {
        let item = tree.split('@').next().unwrap_or(tree);
        let mut path = prefix.clone();
        path.extend(item.split("::").filter(|s| !s.is_empty() && *s != "*").map(str::to_string));
        if path.last().is_some_and(|s| s == "self") {
            path.pop();
        }
        if !path.is_empty() {
            out.push(path);
        }
    }
}

/// The crate's module graph.
struct Graph {
    modules: BTreeSet<ModPath>,
    /// Per module: item name → the child module that defines it (`pub use child::Item`).
    reexports: BTreeMap<ModPath, BTreeMap<String, String>>,
    /// (from, to) → an example (file, path) that makes the edge.
    edges: BTreeMap<(ModPath, ModPath), (PathBuf, String)>,
}

impl Graph {
    fn build(sources: &[Source]) -> Self {
        let modules: BTreeSet<ModPath> = sources.iter().map(|s| s.module.clone()).collect();
        let mut reexports: BTreeMap<ModPath, BTreeMap<String, String>> = BTreeMap::new();
        for s in sources {
            for stmt in s.code.split(';') {
                let stmt = stmt.trim();
                let Some(tree) = stmt.strip_prefix("pub use ").or_else(|| stmt.strip_prefix("pub(crate) use ")) else {
                    continue;
                };
                let tree = compact(tree);
                let tree = tree.trim_start_matches("self::");
                let mut expanded = Vec::new();
                expand(tree, &mut Vec::new(), &mut expanded);
                for p in expanded {
                    if p.len() >= 2 {
                        let mut child = s.module.clone();
                        child.push(p[0].clone());
                        if modules.contains(&child) {
                            reexports.entry(s.module.clone()).or_default().insert(p[p.len() - 1].clone(), p[0].clone());
                        }
                    }
                }
            }
        }
        let mut graph = Self { modules, reexports, edges: BTreeMap::new() };
        for s in sources.iter().filter(|s| !is_test_file(s)) {
            for p in paths(&s.code) {
                if let Some(target) = graph.resolve(&s.module, &p)
                    && target != s.module
                {
                    graph.edges.entry((s.module.clone(), target)).or_insert_with(|| (s.file.clone(), p.join("::")));
                }
            }
        }
        graph
    }

    /// The module that path `p`, written in module `from`, names: the longest prefix that is a
    /// module, or the child that defines a re-exported item.
    fn resolve(&self, from: &ModPath, p: &[String]) -> Option<ModPath> {
        let mut base: ModPath = match p.first()?.as_str() {
            "crate" => Vec::new(),
            "self" => from.clone(),
            "super" => {
                let mut m = from.clone();
                m.pop()?;
                m
            }
            _ => return None,
        };
        let mut rest = &p[1..];
        while rest.first().is_some_and(|s| s == "super") {
            base.pop()?;
            rest = &rest[1..];
        }
        for seg in rest {
            let mut next = base.clone();
            next.push(seg.clone());
            if self.modules.contains(&next) {
                base = next;
            } else {
                if let Some(child) = self.reexports.get(&base).and_then(|r| r.get(seg)) {
                    base.push(child.clone());
                }
                break;
            }
        }
        Some(base)
    }

    /// The edges between the children of `parent` (for `None`: between top-level modules), each
    /// lifted from any descendant to the child that contains it.
    fn sibling_edges(&self, parent: &ModPath) -> BTreeMap<(String, String), (PathBuf, String)> {
        let mut out = BTreeMap::new();
        let n = parent.len();
        for ((from, to), why) in &self.edges {
            if from.len() > n && to.len() > n && from[..n] == parent[..] && to[..n] == parent[..] && from[n] != to[n] {
                out.entry((from[n].clone(), to[n].clone())).or_insert_with(|| why.clone());
            }
        }
        out
    }
}

/// The strongly connected components of `edges` with more than one node (each one or more
/// cycles), each as a cycle through all of its nodes where one exists, else its nodes in order.
fn cyclic_components(edges: &BTreeMap<(String, String), (PathBuf, String)>) -> Vec<Vec<String>> {
    let mut adj: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    for (a, b) in edges.keys() {
        adj.entry(a).or_default().insert(b);
        adj.entry(b).or_default();
    }
    // Components: the nodes that reach each other.
    let reach = |from: &str| -> BTreeSet<&str> {
        let mut seen = BTreeSet::new();
        let mut todo = vec![from];
        while let Some(n) = todo.pop() {
            for &m in &adj[n] {
                if seen.insert(m) {
                    todo.push(m);
                }
            }
        }
        seen
    };
    let reaches: BTreeMap<&str, BTreeSet<&str>> = adj.keys().map(|&n| (n, reach(n))).collect();
    let mut done: BTreeSet<&str> = BTreeSet::new();
    let mut out = Vec::new();
    for &n in adj.keys() {
        if done.contains(n) || !reaches[n].contains(n) {
            continue;
        }
        let component: BTreeSet<&str> = reaches[n].iter().copied().filter(|m| reaches[m].contains(n)).collect();
        done.extend(component.iter().copied());
        if component.len() < 2 {
            continue;
        }
        // A shortest cycle back to n inside the component (breadth first).
        let mut parent: BTreeMap<&str, &str> = BTreeMap::new();
        let mut queue = std::collections::VecDeque::from([n]);
        let mut cycle = None;
        while let Some(a) = queue.pop_front() {
            for &b in &adj[a] {
                if !component.contains(b) {
                    continue;
                }
                if b == n {
                    let mut path = vec![a];
                    while let Some(&p) = parent.get(path[path.len() - 1]) {
                        path.push(p);
                    }
                    path.reverse();
                    if path[0] != n {
                        path.insert(0, n);
                    }
                    path.push(n);
                    cycle = Some(path);
                    break;
                }
                if b != n && !parent.contains_key(b) {
                    parent.insert(b, a);
                    queue.push_back(b);
                }
            }
            if cycle.is_some() {
                break;
            }
        }
        let mut text: Vec<String> = cycle.unwrap_or_default().iter().map(|s| s.to_string()).collect();
        let rest: Vec<String> =
            component.iter().filter(|m| !text.iter().any(|t| t == *m)).map(|s| s.to_string()).collect();
        if !rest.is_empty() {
            text.push(format!("(with {})", rest.join(", ")));
        }
        out.push(text);
    }
    out
}

/// Every cycle (one per strongly connected set of sibling modules), described for the failure
/// message.
fn cycles(name: &str, src: &Path) -> Vec<String> {
    let graph = Graph::build(&read_crate(src));
    let parents: BTreeSet<ModPath> =
        std::iter::once(Vec::new()).chain(graph.modules.iter().filter(|m| !m.is_empty()).cloned()).collect();
    let mut out = Vec::new();
    for parent in parents {
        let edges = graph.sibling_edges(&parent);
        if std::env::var_os("MODULE_GRAPH_EDGES").is_some() {
            for ((a, b), (file, path)) in &edges {
                let file = file.strip_prefix(env!("CARGO_MANIFEST_DIR")).unwrap_or(file);
                eprintln!(
                    "{name}: {}{a} -> {b}: {} uses {path}",
                    parent.iter().map(|p| format!("{p}::")).collect::<String>(),
                    file.display()
                );
            }
        }
        for cycle in cyclic_components(&edges) {
            let prefix = if parent.is_empty() { String::new() } else { format!("{}::", parent.join("::")) };
            let named: Vec<String> =
                cycle.iter().map(|m| if m.starts_with('(') { m.clone() } else { format!("{prefix}{m}") }).collect();
            let mut text = format!("{name}: cycle {}", named.join(" -> "));
            for w in cycle.windows(2) {
                if let Some((file, path)) = edges.get(&(w[0].clone(), w[1].clone())) {
                    let file = file.strip_prefix(env!("CARGO_MANIFEST_DIR")).unwrap_or(file);
                    text.push_str(&format!(
                        "\n    {prefix}{} -> {prefix}{}: {} uses {path}",
                        w[0],
                        w[1],
                        file.display()
                    ));
                }
            }
            out.push(text);
        }
    }
    out
}

fn crate_src(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(relative)
}

#[test]
fn no_import_cycles_between_modules() {
    let mut found = cycles("simserpent-core", &crate_src("src"));
    found.extend(cycles("simserpent", &crate_src("../../src")));
    assert!(found.is_empty(), "import cycles (move the shared item into the lower module):\n{}", found.join("\n"));
}

#[test]
fn the_checker_finds_a_planted_cycle() {
    let dir = std::env::temp_dir().join(format!("simserpent-module-graph-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("b")).expect("scratch folder");
    std::fs::write(dir.join("lib.rs"), "pub mod a;\npub mod b;\npub mod c;\n").expect("write");
    // a -> b (inline path), b -> c (use tree), c -> a (through a re-export of a's child).
    std::fs::write(dir.join("a.rs"), "// crate::c is only a comment\nfn f() { crate::b::x(); }\n").expect("write");
    std::fs::write(dir.join("b/mod.rs"), "mod inner;\npub use inner::Thing;\npub fn x() {}\n").expect("write");
    std::fs::write(dir.join("b/inner.rs"), "use crate::{c::{self, Y}};\npub struct Thing;\n").expect("write");
    std::fs::write(
        dir.join("c.rs"),
        "use super::a as _;\npub struct Y;\n#[cfg(test)]\nmod tests { use crate::b::Thing; }\n",
    )
    .expect("write");
    let found = cycles("planted", &dir);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].starts_with("planted: cycle a -> b -> c -> a"), "{}", found[0]);
}

#[test]
fn re_exported_items_resolve_to_the_defining_child() {
    let dir = std::env::temp_dir().join(format!("simserpent-module-graph-re-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("m")).expect("scratch folder");
    std::fs::write(dir.join("lib.rs"), "pub mod m;\n").expect("write");
    std::fs::write(dir.join("m/mod.rs"), "mod x;\nmod y;\npub use x::Xs;\npub use y::{Ys};\n").expect("write");
    std::fs::write(dir.join("m/x.rs"), "use super::Ys;\npub struct Xs;\n").expect("write");
    std::fs::write(dir.join("m/y.rs"), "pub struct Ys(crate::m::Xs);\n").expect("write");
    let found = cycles("re", &dir);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(found[0].contains("m::x -> m::y -> m::x") || found[0].contains("m::y -> m::x -> m::y"), "{}", found[0]);
}
