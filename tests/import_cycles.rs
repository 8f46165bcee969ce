//! No import loop spans more than two files: the file-level graph of `use crate::...`,
//! `use super::...`, `use child::...` and `crate::`/`super::`/`self::`/`child::` paths in code,
//! over every
//! file of `src/` (the library's modules; `main.rs` is its own crate), has no strongly
//! connected component of more than two files.
//!
//! Two files that import each other (a module and its tests, a type and its builder) are one
//! idea split in two; three or more in a loop means no file of them can be read, changed or
//! moved on its own.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// A module path: `["report", "page"]` for `crate::report::page`.
type ModPath = Vec<String>;

/// One source file: its path (for messages) and its text.
struct Source {
    name: String,
    module: ModPath,
    text: String,
}

/// The module of the file at `rel` (relative to `src/`): `lib.rs` is the crate, `a/mod.rs` and
/// `a.rs` are `a`; None for `main.rs` (the binary, another crate).
fn module_of(rel: &str) -> Option<ModPath> {
    let rel = rel.strip_suffix(".rs")?;
    if rel == "main" {
        return None;
    }
    if rel == "lib" {
        return Some(Vec::new());
    }
    let mut parts: ModPath = rel.split('/').map(String::from).collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    Some(parts)
}

/// Every `.rs` file under `dir`, by path relative to `root`.
fn read_tree(root: &Path, dir: &Path, out: &mut Vec<Source>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            read_tree(root, &path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            let rel = path
                .strip_prefix(root)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            if let Some(module) = module_of(&rel) {
                let text = std::fs::read_to_string(&path)
                    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
                out.push(Source {
                    name: format!("src/{rel}"),
                    module,
                    text,
                });
            }
        }
    }
}

/// `text` with comments, string and character literals blanked (so a path in a doc comment
/// or a message is not an import).
fn scrub(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    let mut i = 0;
    while i < c.len() {
        let at = |k: usize| c.get(k).copied().unwrap_or('\0');
        if c[i] == '/' && at(i + 1) == '/' {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if c[i] == '/' && at(i + 1) == '*' {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && at(i + 1) == '*' {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && at(i + 1) == '/' {
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
        } else if c[i] == '"' {
            i += 1;
            while i < c.len() && c[i] != '"' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if (c[i] == 'r' || (c[i] == 'b' && at(i + 1) == 'r'))
            && (i == 0 || !ident(c[i - 1]))
            && {
                let mut k = i + if c[i] == 'b' { 2 } else { 1 };
                while at(k) == '#' {
                    k += 1;
                }
                at(k) == '"'
            }
        {
            // A raw string: r"...", r#"..."#, br"...".
            i += if c[i] == 'b' { 2 } else { 1 };
            let mut hashes = 0;
            while c[i] == '#' {
                hashes += 1;
                i += 1;
            }
            i += 1;
            while i < c.len() {
                if c[i] == '"' && (1..=hashes).all(|h| at(i + h) == '#') {
                    i += 1 + hashes;
                    break;
                }
                i += 1;
            }
            out.push_str("\"\"");
        } else if c[i] == '\'' {
            // A character literal ('x', '\n', '\u{..}'), or a lifetime ('a) kept as it is.
            if at(i + 1) == '\\' {
                i += 2;
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
                out.push_str("' '");
            } else if at(i + 2) == '\'' {
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

/// The tokens that matter for paths: identifiers, `::`, and single punctuation characters.
fn tokens(code: &str) -> Vec<String> {
    let c: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        if c[i].is_alphanumeric() || c[i] == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            out.push(c[start..i].iter().collect());
        } else if c[i] == ':' && c.get(i + 1) == Some(&':') {
            out.push("::".into());
            i += 2;
        } else if c[i].is_whitespace() {
            i += 1;
        } else {
            out.push(c[i].to_string());
            i += 1;
        }
    }
    out
}

/// One path a `use` tree names, with the name it binds (None for a glob).
struct UsePath {
    segments: ModPath,
    name: Option<String>,
}

/// The paths a `use` tree names: `a::{b, c::{self, d as e}}` gives `a::b`, `a::c`, `a::c::d`
/// (bound as `e`); a glob names its module. `t` holds the tokens after `use` up to the `;`.
fn use_paths(t: &[String]) -> Vec<UsePath> {
    fn tree(t: &[String], i: &mut usize, prefix: &ModPath, out: &mut Vec<UsePath>) {
        let mut path = prefix.clone();
        let mut alias = None;
        while *i < t.len() {
            let tok = t[*i].as_str();
            match tok {
                "::" => *i += 1,
                "{" => {
                    *i += 1;
                    while *i < t.len() && t[*i] != "}" {
                        tree(t, i, &path, out);
                        if *i < t.len() && t[*i] == "," {
                            *i += 1;
                        }
                    }
                    *i += 1;
                    return;
                }
                "*" => {
                    *i += 1;
                    out.push(UsePath {
                        segments: path,
                        name: None,
                    });
                    return;
                }
                "as" => {
                    alias = t.get(*i + 1).cloned();
                    *i += 2;
                }
                "," | "}" => break,
                "self" if !path.is_empty() => *i += 1,
                _ => {
                    path.push(tok.to_string());
                    *i += 1;
                }
            }
        }
        let name = alias.or_else(|| path.last().cloned());
        out.push(UsePath {
            segments: path,
            name,
        });
    }
    let mut out = Vec::new();
    // `use ::std::...` (a leading `::`) names an external crate.
    if t.first().is_some_and(|s| s == "::") {
        return out;
    }
    tree(t, &mut 0, &Vec::new(), &mut out);
    out
}

/// A path as written in one module: the module it was written in and its segments.
struct Written {
    at: ModPath,
    segments: ModPath,
    /// For `pub use`: the name it exports.
    exports: Option<String>,
}

/// Whether `tok` is an identifier (or keyword).
fn is_ident(tok: &str) -> bool {
    tok.starts_with(|c: char| c.is_alphabetic() || c == '_')
}

/// Every module-relative path in `code` of the module `module`, and the inline modules
/// (`mod tests { ... }`) it declares.
fn paths_in(module: &ModPath, code: &str) -> (Vec<Written>, Vec<ModPath>) {
    let t = tokens(code);
    let mut written = Vec::new();
    let mut inline: Vec<ModPath> = Vec::new();
    // Open inline modules: their name and the brace depth inside them.
    let mut open: Vec<(String, usize)> = Vec::new();
    let mut depth = 0;
    let here = |open: &[(String, usize)]| {
        let mut m = module.clone();
        m.extend(open.iter().map(|(n, _)| n.clone()));
        m
    };
    let mut i = 0;
    while i < t.len() {
        let tok = t[i].as_str();
        if tok == "{" {
            depth += 1;
            i += 1;
        } else if tok == "}" {
            if open.last().is_some_and(|(_, d)| *d == depth) {
                open.pop();
            }
            depth -= 1;
            i += 1;
        } else if tok == "mod" && t.get(i + 2).is_some_and(|s| s == "{") {
            open.push((t[i + 1].clone(), depth + 1));
            inline.push(here(&open));
            depth += 1;
            i += 3;
        } else if tok == "use" && (i == 0 || t[i - 1] != "::") {
            let end = (i..t.len()).find(|&k| t[k] == ";").unwrap_or(t.len());
            // `pub use`, `pub(crate) use`, `pub(super) use`: a re-export.
            let public =
                i > 0 && (t[i - 1] == "pub" || (t[i - 1] == ")" && i >= 4 && t[i - 4] == "pub"));
            for u in use_paths(&t[i + 1..end]) {
                written.push(Written {
                    at: here(&open),
                    segments: u.segments,
                    exports: if public { u.name } else { None },
                });
            }
            i = end + 1;
        } else if is_ident(tok)
            && t.get(i + 1).is_some_and(|s| s == "::")
            && (i == 0 || t[i - 1] != "::")
        {
            let mut segments = vec![tok.to_string()];
            let mut k = i + 1;
            while t.get(k).is_some_and(|s| s == "::") && t.get(k + 1).is_some_and(|s| is_ident(s)) {
                segments.push(t[k + 1].clone());
                k += 2;
            }
            // A path from a child module (`scmos::run`) counts; `Type::f` and `std::x` do not
            // (they name no module of this crate).
            written.push(Written {
                at: here(&open),
                segments,
                exports: None,
            });
            i = k;
        } else {
            i += 1;
        }
    }
    (written, inline)
}

/// The file-level import graph of `sources`: for each file, the files it imports from.
///
/// A path to a re-exported name leads to the file that defines it (through every `pub use`),
/// and a `pub use` in a `mod.rs` or `lib.rs` (a facade) is no import of that file: the files
/// behind a facade are imported by whoever names the item, not by the facade.
fn graph(sources: &[Source]) -> BTreeMap<String, BTreeSet<String>> {
    // Every module, file or inline, and the file that holds it.
    let mut file_of: BTreeMap<ModPath, String> = BTreeMap::new();
    let mut parsed = Vec::new();
    for s in sources {
        file_of.insert(s.module.clone(), s.name.clone());
        let (written, inline) = paths_in(&s.module, &scrub(&s.text));
        for m in inline {
            file_of.entry(m).or_insert_with(|| s.name.clone());
        }
        parsed.push((s, written));
    }
    // Re-exports: (module, name) -> the path it stands for.
    let mut exports: BTreeMap<(ModPath, String), ModPath> = BTreeMap::new();
    for (_, written) in &parsed {
        for w in written {
            if let (Some(name), Some(target)) = (&w.exports, absolute(w, &file_of)) {
                exports.insert((w.at.clone(), name.clone()), target);
            }
        }
    }
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (s, written) in parsed {
        let facade = s.name.ends_with("/mod.rs") || s.name.ends_with("/lib.rs");
        let out = edges.entry(s.name.clone()).or_default();
        for w in written {
            if facade && w.exports.is_some() {
                continue;
            }
            let Some(path) = absolute(&w, &file_of) else {
                continue;
            };
            let file = defining_file(path, &file_of, &exports);
            if *file != s.name {
                out.insert(file.clone());
            }
        }
    }
    edges
}

/// The file that defines the item at `path`: the longest prefix that is a module, unless the
/// next name is one of that module's re-exports (then where that leads).
fn defining_file<'a>(
    mut path: ModPath,
    file_of: &'a BTreeMap<ModPath, String>,
    exports: &BTreeMap<(ModPath, String), ModPath>,
) -> &'a String {
    // Re-exports may chain; a loop of them (not valid Rust) stops after a few steps.
    for _ in 0..16 {
        let n = (0..=path.len())
            .rev()
            .find(|&n| file_of.contains_key(&path[..n]))
            .expect("the crate root is a module");
        let Some(target) = path
            .get(n)
            .and_then(|name| exports.get(&(path[..n].to_vec(), name.clone())))
        else {
            return &file_of[&path[..n]];
        };
        let mut next = target.clone();
        next.extend_from_slice(&path[n + 1..]);
        path = next;
    }
    &file_of[&Vec::new()]
}

/// The absolute module path of `w`, or None when it names another crate.
fn absolute(w: &Written, modules: &BTreeMap<ModPath, String>) -> Option<ModPath> {
    let mut segs = w.segments.iter().peekable();
    let mut base: ModPath = match segs.peek().map(|s| s.as_str()) {
        Some("crate") => {
            segs.next();
            Vec::new()
        }
        Some("self") => {
            segs.next();
            w.at.clone()
        }
        Some("super") => w.at.clone(),
        Some(first) => {
            // 2018 paths: a child module of this one, else another crate.
            let mut child = w.at.clone();
            child.push(first.to_string());
            if !modules.contains_key(&child) {
                return None;
            }
            w.at.clone()
        }
        None => return None,
    };
    while segs.peek().is_some_and(|s| *s == "super") {
        segs.next();
        base.pop()?;
    }
    base.extend(segs.cloned());
    Some(base)
}

/// Tarjan's strongly connected components of `edges`.
fn components(edges: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct State<'a> {
        edges: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on_stack: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a str) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on_stack.insert(v);
        if let Some(next) = s.edges.get(v) {
            for w in next {
                let w = w.as_str();
                if !s.index.contains_key(w) {
                    visit(s, w);
                    let lw = s.low[w];
                    let lv = s.low.get_mut(v).unwrap();
                    *lv = (*lv).min(lw);
                } else if s.on_stack.contains(w) {
                    let iw = s.index[w];
                    let lv = s.low.get_mut(v).unwrap();
                    *lv = (*lv).min(iw);
                }
            }
        }
        if s.low[v] == s.index[v] {
            let mut c = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(w);
                c.push(w.to_string());
                if w == v {
                    break;
                }
            }
            c.sort();
            s.out.push(c);
        }
    }
    let mut s = State {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in edges.keys() {
        if !s.index.contains_key(v.as_str()) {
            visit(&mut s, v);
        }
    }
    s.out
}

/// One loop through the component `c`, from its first file back to it: "a -> b -> c -> a".
fn a_loop(c: &[String], edges: &BTreeMap<String, BTreeSet<String>>) -> String {
    let inside: BTreeSet<&String> = c.iter().collect();
    let start = &c[0];
    // Breadth-first from the start to any file that imports the start.
    let mut came_from: BTreeMap<&String, &String> = BTreeMap::new();
    let mut queue = std::collections::VecDeque::from([start]);
    while let Some(v) = queue.pop_front() {
        for w in edges[v].iter().filter(|w| inside.contains(w)) {
            if w == start {
                let mut path = vec![start.as_str(), v.as_str()];
                let mut at = v;
                while at != start {
                    at = came_from[at];
                    path.push(at.as_str());
                }
                path.reverse();
                return path.join(" -> ");
            }
            if !came_from.contains_key(w) && w != start {
                came_from.insert(w, v);
                queue.push_back(w);
            }
        }
    }
    unreachable!("a strongly connected component has a loop")
}

/// A loop over more than two files: its files (sorted) and a description naming them, one loop
/// through them and the imports among them.
struct Loop {
    files: Vec<String>,
    text: String,
}

/// The loops over more than two files (strongly connected components of the import graph).
fn loops_over_two(sources: &[Source]) -> Vec<Loop> {
    let edges = graph(sources);
    components(&edges)
        .into_iter()
        .filter(|c| c.len() > 2)
        .map(|c| {
            let inside: BTreeSet<&String> = c.iter().collect();
            let imports: Vec<String> = c
                .iter()
                .map(|f| {
                    let to: Vec<&str> = edges[f]
                        .iter()
                        .filter(|w| inside.contains(w))
                        .map(String::as_str)
                        .collect();
                    format!("  {f} imports {}", to.join(", "))
                })
                .collect();
            let text = format!(
                "{} files, e.g. {}:\n{}",
                c.len(),
                a_loop(&c, &edges),
                imports.join("\n")
            );
            Loop { files: c, text }
        })
        .collect()
}

#[test]
fn no_import_loop_spans_more_than_two_files() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut sources = Vec::new();
    read_tree(&root, &root, &mut sources);
    assert!(sources.len() > 100, "read {} files", sources.len());
    let edges = graph(&sources);
    // The graph is the crate's: the report runs its sections, the CLI the library.
    assert!(edges["src/report/mod.rs"].contains("src/report/scmos/mod.rs"));
    assert!(edges["src/cli/report.rs"].contains("src/report/mod.rs"));
    let loops = loops_over_two(&sources);
    assert!(
        loops.is_empty(),
        "import loops over more than two files:\n{}",
        loops
            .iter()
            .map(|l| l.text.as_str())
            .collect::<Vec<_>>()
            .join("\n")
    );
}

/// A small crate with a loop of three files (one edge through a `use` group, one through a
/// path in code, one through `super`), a two-file loop, and paths that are not imports.
#[test]
fn a_loop_of_three_files_is_found_and_named() {
    let src = |name: &str, text: &str| Source {
        name: name.into(),
        module: module_of(name.strip_prefix("src/").unwrap()).unwrap(),
        text: text.into(),
    };
    let sources = [
        src("src/lib.rs", "pub mod a; pub mod b;\npub use a::One;"),
        src("src/a/mod.rs", "mod c;\nuse crate::b::{x::{self, Two}, y};\n"),
        src(
            "src/b/x.rs",
            "// use crate::a::c;\nfn f() -> u8 { let _ = \"crate::a\"; crate::a::c::g() }",
        ),
        src(
            "src/a/c.rs",
            "use super::One;\n#[cfg(test)]\nmod tests { use super::*; use std::fmt; }\npub(crate) fn g() -> u8 { 'x' as u8 }",
        ),
        src("src/b/y.rs", "use crate::b::z as q;"),
        src("src/b/z.rs", "use super::y::Thing;"),
        src("src/b/mod.rs", "pub mod x; pub mod y; pub mod z;"),
    ];
    let edges = graph(&sources);
    assert_eq!(
        edges["src/a/mod.rs"],
        BTreeSet::from(["src/b/x.rs".to_string(), "src/b/y.rs".to_string()])
    );
    assert_eq!(
        edges["src/b/x.rs"],
        BTreeSet::from(["src/a/c.rs".to_string()])
    );
    assert_eq!(
        edges["src/a/c.rs"],
        BTreeSet::from(["src/a/mod.rs".to_string()])
    );
    // lib.rs only re-exports: a facade imports nothing.
    assert!(edges["src/lib.rs"].is_empty());
    let loops = loops_over_two(&sources);
    assert_eq!(
        loops.len(),
        1,
        "only the three files' loop (y and z are two)"
    );
    assert_eq!(loops[0].files, ["src/a/c.rs", "src/a/mod.rs", "src/b/x.rs"]);
    assert!(loops[0]
        .text
        .starts_with("3 files, e.g. src/a/c.rs -> src/a/mod.rs -> src/b/x.rs -> src/a/c.rs:"));
}
