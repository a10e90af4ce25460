//! The book as the docs tests read it: README.md and every Markdown file
//! under docs/, their fenced blocks, inline code spans and tables. Shared
//! by `tests/docs.rs` and the binary's test of the commands shown
//! (`src/cli/doc_commands.rs`, which includes this file by path).
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// README.md and the Markdown files under docs/ (recursively), sorted,
/// as paths relative to the repository root.
pub fn doc_files() -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut out = vec!["README.md".to_string()];
    let mut stack = vec![root.join("docs")];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else { continue };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "md") {
                out.push(rel(root, &p));
            }
        }
    }
    out.sort();
    out
}

fn rel(root: &Path, p: &Path) -> String {
    p.strip_prefix(root).unwrap_or(p).to_string_lossy().replace('\\', "/")
}

/// The text of a repository file.
pub fn read(rel: &str) -> String {
    let path: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A fenced code block: its info string's first word, its first line's
/// number (1-based, the line after the fence) and its text.
#[derive(Debug, Clone)]
pub struct Block {
    pub lang: String,
    pub line: usize,
    pub text: String,
}

/// The fenced blocks (``` or ~~~) of a Markdown text.
pub fn fenced_blocks(text: &str) -> Vec<Block> {
    let mut out = Vec::new();
    let mut open: Option<(String, String, usize, String)> = None; // fence, lang, line, text
    for (i, line) in text.lines().enumerate() {
        let t = line.trim_start();
        match &mut open {
            None => {
                for fence in ["```", "~~~"] {
                    if let Some(info) = t.strip_prefix(fence) {
                        let lang = info.split_whitespace().next().unwrap_or("").to_string();
                        open = Some((fence.to_string(), lang, i + 2, String::new()));
                        break;
                    }
                }
            }
            Some((fence, lang, first, body)) => {
                if t.starts_with(fence.as_str()) && t.trim_start_matches(fence.as_str()).trim().is_empty() {
                    out.push(Block {
                        lang: std::mem::take(lang),
                        line: *first,
                        text: std::mem::take(body),
                    });
                    open = None;
                } else {
                    body.push_str(line);
                    body.push('\n');
                }
            }
        }
    }
    out
}

/// The text outside fenced blocks, line by line (1-based numbers).
pub fn prose_lines(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut fence: Option<&str> = None;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim_start();
        match fence {
            None if t.starts_with("```") => fence = Some("```"),
            None if t.starts_with("~~~") => fence = Some("~~~"),
            None => out.push((i + 1, line.to_string())),
            Some(f) if t.starts_with(f) => fence = None,
            Some(_) => {}
        }
    }
    out
}

/// The inline code spans outside fenced blocks, with their line numbers.
/// A span may run over a line break, as Markdown allows within a paragraph.
pub fn inline_code(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let lines = prose_lines(text);
    // Join each paragraph's lines so that spans broken across lines are
    // whole; remember the line each paragraph starts on.
    let mut paragraphs: Vec<(usize, String)> = Vec::new();
    for (n, line) in lines {
        if line.trim().is_empty() {
            paragraphs.push((n + 1, String::new()));
            continue;
        }
        match paragraphs.last_mut() {
            Some((_, p)) if !p.is_empty() => {
                p.push(' ');
                p.push_str(line.trim());
            }
            _ => paragraphs.push((n, line.trim().to_string())),
        }
    }
    for (n, p) in paragraphs {
        let mut rest = p.as_str();
        while let Some(start) = rest.find('`') {
            let ticks = rest[start..].chars().take_while(|&c| c == '`').count();
            let after = &rest[start + ticks..];
            let closing = "`".repeat(ticks);
            let Some(end) = after.find(&closing) else { break };
            out.push((n, after[..end].trim().to_string()));
            rest = &after[end + ticks..];
        }
    }
    out
}

/// The rows of the Markdown tables in `text` (outside fenced blocks): each
/// row's cells, trimmed, with the row's line number; separator rows left
/// out. A `\|` inside a cell is kept as `|`.
pub fn table_rows(text: &str) -> Vec<(usize, Vec<String>)> {
    let mut out = Vec::new();
    for (n, line) in prose_lines(text) {
        let t = line.trim();
        if !(t.starts_with('|') && t.ends_with('|') && t.len() > 1) {
            continue;
        }
        let inner = &t[1..t.len() - 1];
        let cells: Vec<String> = split_cells(inner);
        if cells
            .iter()
            .all(|c| !c.is_empty() && c.chars().all(|ch| matches!(ch, '-' | ':')))
        {
            continue;
        }
        out.push((n, cells));
    }
    out
}

fn split_cells(inner: &str) -> Vec<String> {
    let mut cells = Vec::new();
    let mut cell = String::new();
    let mut chars = inner.chars().peekable();
    let mut in_code = false;
    while let Some(c) = chars.next() {
        match c {
            '\\' if chars.peek() == Some(&'|') => {
                cell.push('|');
                chars.next();
            }
            '`' => {
                in_code = !in_code;
                cell.push(c);
            }
            '|' if !in_code => cells.push(std::mem::take(&mut cell).trim().to_string()),
            _ => cell.push(c),
        }
    }
    cells.push(cell.trim().to_string());
    cells
}

/// The code spans of one table cell, in order.
pub fn cell_code(cell: &str) -> Vec<String> {
    inline_code(cell).into_iter().map(|(_, s)| s).collect()
}

/// The text under each heading of level `level` (`###` for 3): the
/// heading's text and the lines up to the next heading of that level or
/// above.
pub fn sections(text: &str, level: usize) -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = Vec::new();
    let mut current: Option<(String, String)> = None;
    for (_, line) in prose_lines_with_fences(text) {
        let hashes = line.chars().take_while(|&c| c == '#').count();
        if hashes > 0 && hashes <= level && line[hashes..].starts_with(' ') {
            if let Some(s) = current.take() {
                out.push(s);
            }
            if hashes == level {
                current = Some((line[hashes..].trim().to_string(), String::new()));
            }
            continue;
        }
        if let Some((_, body)) = &mut current {
            body.push_str(&line);
            body.push('\n');
        }
    }
    if let Some(s) = current {
        out.push(s);
    }
    out
}

/// Every line, with headings recognised only outside fenced blocks (a `#`
/// comment in a TOML or shell block is not a heading).
fn prose_lines_with_fences(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut fence: Option<&str> = None;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim_start();
        let marked = match fence {
            None if t.starts_with("```") => {
                fence = Some("```");
                true
            }
            None if t.starts_with("~~~") => {
                fence = Some("~~~");
                true
            }
            Some(f) if t.starts_with(f) => {
                fence = None;
                true
            }
            Some(_) => true,
            None => false,
        };
        // Inside a fence, hide a leading '#' from the heading test.
        out.push((i + 1, if marked { format!(" {line}") } else { line.to_string() }));
    }
    out
}
