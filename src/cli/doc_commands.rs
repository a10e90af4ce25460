//! The commands the book shows (README.md and docs/) against the command
//! line itself: every `atmosim` command in a shell block parses as the
//! binary would parse it (a real subcommand, real flags, values of the
//! right kind), every `atmosim …` code span in the prose names a real
//! subcommand and real flags, and every `cargo test --test NAME` names a
//! test that exists. Shown failing on a drifted copy below. (The job files
//! and the other chapters are checked by `tests/docs.rs`.)

use clap::error::ErrorKind;
use clap::{CommandFactory, Parser};

#[path = "../../tests/common/markdown.rs"]
mod markdown;

/// The words of a shell command line: quotes removed, backslash escapes
/// kept literal.
fn shell_words(line: &str) -> Vec<String> {
    let mut words = Vec::new();
    let mut word = String::new();
    let mut quote: Option<char> = None;
    let mut started = false;
    for c in line.chars() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some(_), c) => word.push(c),
            (None, '"' | '\'') => {
                quote = Some(c);
                started = true;
            }
            (None, c) if c.is_whitespace() => {
                if started || !word.is_empty() {
                    words.push(std::mem::take(&mut word));
                }
                started = false;
            }
            (None, c) => word.push(c),
        }
    }
    if started || !word.is_empty() {
        words.push(word);
    }
    words
}

/// The commands of a shell block: continuation lines joined, comments
/// dropped, split at `&&`, `;` and `|`; each with its first line's number.
fn shell_commands(block: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut pending: Option<(usize, String)> = None;
    for (i, raw) in block.lines().enumerate() {
        let line = match raw.find(" #") {
            Some(k) => &raw[..k],
            None if raw.trim_start().starts_with('#') => "",
            None => raw,
        };
        let (text, more) = match line.trim_end().strip_suffix('\\') {
            Some(t) => (t, true),
            None => (line, false),
        };
        let entry = pending.get_or_insert((i, String::new()));
        entry.1.push(' ');
        entry.1.push_str(text.trim());
        if !more && let Some((n, cmd)) = pending.take() {
            for part in cmd.split("&&").flat_map(|p| p.split(';')).flat_map(|p| p.split('|')) {
                if !part.trim().is_empty() {
                    out.push((n, part.trim().to_string()));
                }
            }
        }
    }
    out
}

/// The arguments after `atmosim` of a command that runs it (`atmosim …`,
/// `target/release/atmosim …`, `cargo run --release -- …`), environment
/// assignments and redirections dropped; `None` for other programs.
fn atmosim_args(words: &[String]) -> Option<Vec<String>> {
    let start = words.iter().position(|w| !w.contains('=') || w.starts_with('-'))?;
    let words = &words[start..];
    let args = if words[0] == "atmosim" || words[0].ends_with("/atmosim") {
        &words[1..]
    } else if words.len() > 2 && words[0] == "cargo" && words[1] == "run" && !words.iter().any(|w| w == "--example") {
        let dash = words.iter().position(|w| w == "--")?;
        &words[dash + 1..]
    } else {
        return None;
    };
    let mut out = Vec::new();
    let mut skip = false;
    for w in args {
        if skip {
            skip = false;
        } else if [">", ">>", "<", "2>", "2>&1"].contains(&w.as_str()) {
            skip = w != "2>&1";
        } else if w.starts_with('>') || w.starts_with("2>") {
        } else {
            out.push(w.clone());
        }
    }
    Some(out)
}

/// The test target of `cargo test … --test NAME`, if the command is one.
fn cargo_test_target(words: &[String]) -> Option<String> {
    let start = words.iter().position(|w| !w.contains('='))?;
    let words = &words[start..];
    if words.len() < 2 || words[0] != "cargo" || words[1] != "test" {
        return None;
    }
    let k = words.iter().position(|w| w == "--test")?;
    words.get(k + 1).cloned()
}

/// What of the commands in `text` (a Markdown file, named `file`) is not
/// the command line's.
fn command_drift(file: &str, text: &str) -> Vec<String> {
    let mut drift = Vec::new();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    // Shell blocks: parsed as the binary parses its arguments.
    for block in markdown::fenced_blocks(text) {
        if !["sh", "bash", "shell", "console"].contains(&block.lang.as_str()) {
            continue;
        }
        for (i, cmd) in shell_commands(&block.text) {
            let at = format!("{file}:{}: `{cmd}`", block.line + i);
            let words = shell_words(&cmd);
            if let Some(test) = cargo_test_target(&words)
                && !root.join("tests").join(format!("{test}.rs")).exists()
            {
                drift.push(format!("{at}: no test target {test}"));
            }
            let Some(args) = atmosim_args(&words) else { continue };
            let argv = std::iter::once("atmosim".to_string()).chain(args);
            match crate::Cli::try_parse_from(argv) {
                Ok(_) => {}
                Err(e) if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) => {}
                Err(e) => {
                    let first = e.to_string().lines().next().unwrap_or_default().to_string();
                    drift.push(format!("{at}: {first}"));
                }
            }
        }
    }
    // Code spans in the prose: a real subcommand and real flags.
    let cli = crate::Cli::command();
    for (line, span) in markdown::inline_code(text) {
        let words = shell_words(&span);
        let Some(args) = atmosim_args(&words) else { continue };
        // `atmosim <command> --help` names no command in particular.
        let Some(sub) = args.first().filter(|s| !s.starts_with('<')) else {
            continue;
        };
        let at = format!("{file}:{line}: `{span}`");
        if sub.starts_with('-') {
            if !["--help", "-h", "--version", "-V"].contains(&sub.as_str()) {
                drift.push(format!("{at}: `atmosim` has no {sub}"));
            }
            continue;
        }
        let Some(command) = cli.find_subcommand(sub) else {
            drift.push(format!("{at}: no subcommand {sub}"));
            continue;
        };
        for token in args.iter().skip(1).flat_map(|t| t.split('|')) {
            let token = token.trim_matches(|c| matches!(c, '[' | ']' | '(' | ')' | '.' | '…' | ','));
            let (long, short) = if let Some(l) = token.strip_prefix("--") {
                (Some(l.split('=').next().unwrap_or(l)), None)
            } else if let Some(s) = token.strip_prefix('-').filter(|s| s.chars().count() == 1) {
                (None, s.chars().next())
            } else {
                continue;
            };
            let known = long.is_some_and(|l| l == "help" || command.get_arguments().any(|a| a.get_long() == Some(l)))
                || short.is_some_and(|s| s == 'h' || command.get_arguments().any(|a| a.get_short() == Some(s)));
            if !known {
                drift.push(format!("{at}: `atmosim {sub}` has no {token}"));
            }
        }
    }
    drift
}

#[test]
fn every_command_the_book_shows_is_real() {
    let mut drift = Vec::new();
    let mut shown = 0;
    for file in markdown::doc_files() {
        let text = markdown::read(&file);
        shown += text.matches("atmosim ").count();
        drift.extend(command_drift(&file, &text));
    }
    assert!(drift.is_empty(), "{}", drift.join("\n"));
    assert!(shown > 60, "{shown} commands");
}

#[test]
fn a_drifted_command_is_caught() {
    let good = "Run `atmosim bench --grid [--quick] [--samples N | --per-pixel]`:\n\n```sh\n\
                cargo run --release -- render examples/quickstart.toml\n\
                atmosim fit FIT.toml --shard 3/6   # a shard\n\
                atmosim fit-report fit.toml --mid out/mid \\\n    --transmittance-check out/t\n\
                ATMOSIM_FUZZ_CASES=10 cargo test --release --test readers_fuzz -- --nocapture\n\
                atmosim render job.toml --stdout > tail.csv\n```\n";
    assert_eq!(command_drift("good", good), Vec::<String>::new());
    for (what, drifted) in [
        ("a flag misspelt", good.replace("--stdout", "--std-out")),
        ("a subcommand renamed", good.replace("fit-report", "report")),
        (
            "a value of the wrong kind",
            good.replace("--shard 3/6", "--shard three"),
        ),
        (
            "a continued line's flag",
            good.replace("--transmittance-check", "--transmittance-checks"),
        ),
        ("an inline flag", good.replace("--per-pixel", "--per-pixels")),
        (
            "an inline subcommand",
            good.replace("`atmosim bench", "`atmosim benchmark"),
        ),
        (
            "a test that does not exist",
            good.replace("readers_fuzz", "readers_fuzzing"),
        ),
    ] {
        assert_ne!(drifted, good, "{what}: the copy did not drift");
        assert!(!command_drift("drifted", &drifted).is_empty(), "{what}: not caught");
    }
}

#[test]
fn each_commands_help_names_what_it_makes_and_its_chapter() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let cli = crate::Cli::command();
    let about = cli.get_about().map(|a| a.to_string()).unwrap_or_default();
    assert!(about.contains("docs/README.md"), "{about}");
    let mut count = 0;
    for sub in cli.get_subcommands() {
        count += 1;
        let about = sub.get_about().map(|a| a.to_string()).unwrap_or_default();
        let chapter = about
            .rsplit_once("(docs/")
            .and_then(|(_, c)| c.strip_suffix(')'))
            .unwrap_or_else(|| panic!("{}: no chapter in {about:?}", sub.get_name()));
        assert!(
            root.join("docs").join(chapter).exists(),
            "{}: docs/{chapter}",
            sub.get_name()
        );
        assert!(!about.contains('\n'), "{}: more than a line", sub.get_name());
    }
    assert_eq!(count, 12);
}
