//! The crate's import graph, read from the source: no file imports itself
//! back through a circle of other files, no folder does either, and every
//! folder imports only from the folders before it in the data flow
//! ([`ORDER`], the crate docs' list), so the physics and the transport import
//! nothing from the folders that schedule work, write files or speak other
//! tools' languages.
//!
//! An import is any path a file names through `crate::`, `super::` or one of
//! its own child modules, in code outside its `#[cfg(test)] mod tests`
//! (tests may reach anywhere). `cargo test --test layering -- --nocapture`
//! prints the folder graph.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The library's folders in data-flow order (the crate docs' list): each may
/// import only from folders before it, and from the root's files. So nothing
/// in physics, geometry, polarization, sampling, atmosphere, sensor, job,
/// transport or film imports io, run, compat or cli, and the job imports
/// nothing of the transport that renders it.
const ORDER: [&str; 14] = [
    "physics",
    "geometry",
    "polarization",
    "sampling",
    "atmosphere",
    "sensor",
    "job",
    "transport",
    "film",
    "io",
    "run",
    "compat",
    "skymodel",
    "cli",
];
/// The root's own files, which every folder may use.
const ROOT: [&str; 3] = ["<root>", "error", "fnv"];

/// One source file as a module: its path in the crate and its text without
/// comments and test module.
struct Module {
    path: Vec<String>,
    file: PathBuf,
    code: String,
}

fn module_path(root: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(root).unwrap();
    let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
    let last = parts.pop().unwrap();
    let stem = last.trim_end_matches(".rs");
    if stem != "mod" && stem != "lib" && stem != "main" {
        parts.push(stem.to_string());
    }
    parts
}

/// The file's code up to its test module, line comments removed.
fn code_of(text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = String::new();
    for (i, line) in lines.iter().enumerate() {
        if line.trim() == "#[cfg(test)]" {
            let next = lines[i + 1..].iter().find(|l| !l.trim().is_empty());
            if next.is_some_and(|l| l.trim_start().starts_with("mod ")) {
                break;
            }
        }
        let code = match line.find("//") {
            Some(k) => &line[..k],
            None => line,
        };
        out.push_str(code);
        out.push('\n');
    }
    out
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") && path.file_name().unwrap() != "tests.rs" {
            out.push(path);
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
enum Token {
    Ident(String),
    PathSep,
    Open,
    Close,
    Comma,
    Other,
}

fn tokens(code: &str) -> Vec<Token> {
    let mut out = Vec::new();
    let chars: Vec<char> = code.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c.is_alphanumeric() || c == '_' {
            let start = i;
            while i < chars.len() && (chars[i].is_alphanumeric() || chars[i] == '_') {
                i += 1;
            }
            out.push(Token::Ident(chars[start..i].iter().collect()));
            continue;
        }
        if c == ':' && chars.get(i + 1) == Some(&':') {
            out.push(Token::PathSep);
            i += 2;
            continue;
        }
        if !c.is_whitespace() {
            out.push(match c {
                '{' => Token::Open,
                '}' => Token::Close,
                ',' => Token::Comma,
                _ => Token::Other,
            });
        }
        i += 1;
    }
    out
}

/// The paths of a use tree starting at `tokens[i]` (after a `::`), each
/// prefixed by `prefix`.
fn use_tree(tokens: &[Token], mut i: usize, prefix: Vec<String>, out: &mut Vec<Vec<String>>) -> usize {
    let mut path = prefix;
    loop {
        match tokens.get(i) {
            Some(Token::Ident(name)) => {
                path.push(name.clone());
                i += 1;
                if tokens.get(i) == Some(&Token::PathSep) {
                    i += 1;
                    continue;
                }
                out.push(path);
                return i;
            }
            Some(Token::Open) => {
                i += 1;
                loop {
                    match tokens.get(i) {
                        Some(Token::Close) => return i + 1,
                        Some(Token::Comma) => i += 1,
                        None => return i,
                        _ => {
                            let before = i;
                            i = use_tree(tokens, i, path.clone(), out);
                            // skip `as name` and anything unparsed up to the next separator
                            while !matches!(tokens.get(i), Some(Token::Comma | Token::Close) | None) {
                                i += 1;
                            }
                            if i == before {
                                i += 1;
                            }
                        }
                    }
                }
            }
            _ => {
                out.push(path);
                return i;
            }
        }
    }
}

/// The modules each file imports, as indices into `modules`.
fn edges(modules: &[Module]) -> Vec<BTreeSet<usize>> {
    let index: BTreeMap<Vec<String>, usize> = modules.iter().enumerate().map(|(i, m)| (m.path.clone(), i)).collect();
    let resolve =
        |path: &[String]| -> Option<usize> { (1..=path.len()).rev().find_map(|n| index.get(&path[..n]).copied()) };
    modules
        .iter()
        .enumerate()
        .map(|(me, m)| {
            let toks = tokens(&m.code);
            let children: BTreeSet<&str> = toks
                .windows(2)
                .filter_map(|w| match (&w[0], &w[1]) {
                    (Token::Ident(k), Token::Ident(name)) if k == "mod" => Some(name.as_str()),
                    _ => None,
                })
                .collect();
            let mut paths = Vec::new();
            for i in 0..toks.len() {
                let after_sep = i > 0 && toks[i - 1] == Token::PathSep;
                let Token::Ident(head) = &toks[i] else { continue };
                if after_sep || toks.get(i + 1) != Some(&Token::PathSep) {
                    continue;
                }
                let prefix = match head.as_str() {
                    "crate" => vec![],
                    "super" => m.path[..m.path.len().saturating_sub(1)].to_vec(),
                    child if children.contains(child) => {
                        let mut p = m.path.clone();
                        p.push(child.to_string());
                        paths.push(p);
                        continue;
                    }
                    _ => continue,
                };
                use_tree(&toks, i + 2, prefix, &mut paths);
            }
            paths.iter().filter_map(|p| resolve(p)).filter(|&t| t != me).collect()
        })
        .collect()
}

/// Strongly connected components with more than one member (Tarjan).
fn circles(graph: &[BTreeSet<usize>]) -> Vec<Vec<usize>> {
    struct State<'a> {
        graph: &'a [BTreeSet<usize>],
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on_stack: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        out: Vec<Vec<usize>>,
    }
    fn visit(s: &mut State, v: usize) {
        s.index[v] = Some(s.next);
        s.low[v] = s.next;
        s.next += 1;
        s.stack.push(v);
        s.on_stack[v] = true;
        for &w in s.graph[v].iter() {
            match s.index[w] {
                None => {
                    visit(s, w);
                    s.low[v] = s.low[v].min(s.low[w]);
                }
                Some(iw) if s.on_stack[w] => s.low[v] = s.low[v].min(iw),
                _ => {}
            }
        }
        if Some(s.low[v]) == s.index[v] {
            let mut component = Vec::new();
            loop {
                let w = s.stack.pop().unwrap();
                s.on_stack[w] = false;
                component.push(w);
                if w == v {
                    break;
                }
            }
            if component.len() > 1 {
                s.out.push(component);
            }
        }
    }
    let n = graph.len();
    let mut s = State {
        graph,
        index: vec![None; n],
        low: vec![0; n],
        on_stack: vec![false; n],
        stack: Vec::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in 0..n {
        if s.index[v].is_none() {
            visit(&mut s, v);
        }
    }
    s.out
}

fn load(root: &Path, entry: &str) -> Vec<Module> {
    let mut files = Vec::new();
    rust_files(root, &mut files);
    files.sort();
    files
        .into_iter()
        .filter(|f| {
            // the library's files, or the binary's: `main.rs` and `cli/`
            let rel = f.strip_prefix(root).unwrap();
            let bin = rel == Path::new("main.rs") || rel.starts_with("cli");
            (entry == "main.rs") == bin
        })
        .map(|f| Module {
            path: module_path(root, &f),
            code: code_of(&std::fs::read_to_string(&f).unwrap()),
            file: f,
        })
        .collect()
}

fn folder(m: &Module) -> String {
    m.path.first().cloned().unwrap_or_else(|| "<root>".to_string())
}

fn check(entry: &str) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let modules = load(&root, entry);
    let graph = edges(&modules);
    let name = |i: usize| modules[i].file.strip_prefix(&root).unwrap().display().to_string();

    let file_circles = circles(&graph);
    let mut described = Vec::new();
    for c in &file_circles {
        described.push(c.iter().map(|&i| name(i)).collect::<Vec<_>>().join(" ↔ "));
        for &a in c {
            let inside: Vec<String> = graph[a].iter().filter(|b| c.contains(b)).map(|&b| name(b)).collect();
            described.push(format!("    {} → {}", name(a), inside.join(", ")));
        }
    }
    assert!(
        described.is_empty(),
        "{entry}: files that import each other in a circle:\n{}",
        described.join("\n")
    );

    // The folder graph, from the file graph.
    let folders: Vec<String> = modules
        .iter()
        .map(folder)
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    let at = |f: &str| folders.iter().position(|x| x == f).unwrap();
    let mut folder_graph = vec![BTreeSet::new(); folders.len()];
    let mut why: BTreeMap<(usize, usize), String> = BTreeMap::new();
    for (from, targets) in graph.iter().enumerate() {
        for &to in targets {
            let (a, b) = (at(&folder(&modules[from])), at(&folder(&modules[to])));
            if a != b && folders[b] != "<root>" {
                folder_graph[a].insert(b);
                why.entry((a, b))
                    .or_insert_with(|| format!("{} → {}", name(from), name(to)));
            }
        }
    }
    println!("{entry}: folder imports");
    for (a, targets) in folder_graph.iter().enumerate() {
        let list: Vec<&str> = targets.iter().map(|&b| folders[b].as_str()).collect();
        println!("  {:<13} → {}", folders[a], list.join(", "));
    }
    let folder_circles = circles(&folder_graph);
    if let Some(c) = folder_circles.first() {
        let names: Vec<&str> = c.iter().map(|&i| folders[i].as_str()).collect();
        let why = &why;
        let examples: Vec<&String> = c
            .iter()
            .flat_map(|&a| c.iter().filter_map(move |&b| why.get(&(a, b))))
            .collect();
        panic!(
            "{entry}: folders in a circle: {}; for example {examples:?}",
            names.join(" ↔ ")
        );
    }
    // Every folder in the order, every import toward an earlier one.
    let rank = |f: &str| ORDER.iter().position(|x| *x == f);
    let mut out_of_order = Vec::new();
    for f in &folders {
        if !ROOT.contains(&f.as_str()) && rank(f).is_none() {
            out_of_order.push(format!("folder {f} is not in ORDER"));
        }
    }
    for (&(a, b), example) in &why {
        if ROOT.contains(&folders[b].as_str()) {
            continue;
        }
        if let (Some(ra), Some(rb)) = (rank(&folders[a]), rank(&folders[b]))
            && rb >= ra
        {
            out_of_order.push(format!("{} imports the later {}: {example}", folders[a], folders[b]));
        }
    }
    assert!(
        out_of_order.is_empty(),
        "{entry}: against the data-flow order:\n{}",
        out_of_order.join("\n")
    );
}

#[test]
fn the_library_imports_run_one_way() {
    check("lib.rs");
}

#[test]
fn the_binary_imports_run_one_way() {
    check("main.rs");
}

#[test]
fn a_circle_is_found() {
    // Three files: a imports b, b imports c, c imports a; d imports a.
    let code = |s: &str| code_of(s);
    let modules = vec![
        Module {
            path: vec!["a".into()],
            file: "a.rs".into(),
            code: code("use crate::b::X;"),
        },
        Module {
            path: vec!["b".into()],
            file: "b.rs".into(),
            code: code("use crate::{c::{self, Y}, d};"),
        },
        Module {
            path: vec!["c".into()],
            file: "c.rs".into(),
            code: code("fn f() { super::a::g() }"),
        },
        Module {
            path: vec!["d".into()],
            file: "d.rs".into(),
            code: code("// crate::a::g\nmod e;\nfn h() { e::k() }"),
        },
        Module {
            path: vec!["d".into(), "e".into()],
            file: "d/e.rs".into(),
            code: code("fn k() {}\n#[cfg(test)]\nmod tests { use crate::a; }"),
        },
    ];
    let graph = edges(&modules);
    let expect: Vec<BTreeSet<usize>> = vec![[1].into(), [2, 3].into(), [0].into(), [4].into(), [].into()];
    assert_eq!(graph, expect);
    let found = circles(&graph);
    assert_eq!(found.len(), 1);
    let mut members = found[0].clone();
    members.sort();
    assert_eq!(members, vec![0, 1, 2]);
}
