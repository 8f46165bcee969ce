//! The manual's examples hold: every command line in the fenced code blocks of README.md and
//! docs/*.md parses with the real command line, the blocks marked to run do run (and print
//! exactly what the page says they print), and every relative link and anchor resolves.
//!
//! A command line starts with `detnoise ` or `cargo run --release -- ` (also inside a quoted
//! argument, as in `sbatch --wrap "detnoise ..."`); `\` continues it on the next line, `#`
//! starts a comment, `{a,b}` expands as in bash. Markers, HTML comments on the line before a
//! fence (invisible on the rendered page):
//! - `<!-- test: run -->`: every command of the block runs, in order, in the page's scratch
//!   directory (shared by the page's blocks, with `data-synthetic` linked in) and must succeed.
//! - `<!-- test: stdout -->`: the block is exactly what the last command of the run block
//!   before it printed on standard output (after a ```python block it is
//!   python/tests/test_docs.py's to compare).
//!
//! What the run blocks write must be listed in .gitignore, so that running the examples in a
//! clone leaves `git status` clean.

mod common;

use std::path::{Path, PathBuf};

use clap::FromArgMatches;

/// The manual's pages: README.md, then docs/*.md by name.
fn pages() -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut docs: Vec<PathBuf> = std::fs::read_dir(root.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    docs.sort();
    let mut all = vec![root.join("README.md")];
    all.extend(docs);
    all
}

/// A page's name relative to the repository, for messages.
fn name(page: &Path) -> String {
    page.strip_prefix(env!("CARGO_MANIFEST_DIR"))
        .unwrap_or(page)
        .display()
        .to_string()
}

/// One fenced code block of a page.
struct Block {
    /// Its info string (`sh`, `python`, ... or empty).
    info: String,
    /// The marker on the line before its fence (`run`, `stdout`), if any.
    marker: Option<String>,
    /// Its lines, with their 1-based line numbers in the page.
    lines: Vec<(usize, String)>,
}

/// The fenced code blocks of a markdown text.
fn blocks(text: &str) -> Vec<Block> {
    let mut out = Vec::new();
    // The open block's fence, its indentation (a block inside a list item) and the block.
    let mut open: Option<(&str, usize, Block)> = None;
    let mut previous = "";
    for (i, line) in text.lines().enumerate() {
        let trimmed = line.trim_start();
        let indent = line.len() - trimmed.len();
        if let Some((fence, fence_indent, block)) = &mut open {
            if trimmed.trim_end() == *fence {
                out.push(open.take().unwrap().2);
                previous = line;
            } else {
                let strip = indent.min(*fence_indent);
                block.lines.push((i + 1, line[strip..].to_string()));
            }
            continue;
        }
        if let Some(fence) = ["```", "~~~"].into_iter().find(|f| trimmed.starts_with(f)) {
            let marker = previous
                .trim()
                .strip_prefix("<!-- test:")
                .and_then(|m| m.strip_suffix("-->"))
                .map(|m| m.trim().to_string());
            let block = Block {
                info: trimmed[fence.len()..].trim().to_string(),
                marker,
                lines: Vec::new(),
            };
            open = Some((fence, indent, block));
        } else if !trimmed.is_empty() {
            previous = line;
        }
    }
    assert!(open.is_none(), "a fenced block is never closed");
    out
}

/// One word of a shell command.
#[derive(Clone, Debug)]
struct Word {
    /// The word as the command receives it (quotes removed, braces expanded).
    text: String,
    /// Whether it holds an unquoted glob character (the shell would expand it).
    glob: bool,
    /// Whether any of it was quoted (a quoted `"detnoise ..."` is a command line itself).
    quoted: bool,
}

/// A character of a word being read, and whether it was quoted or escaped (literal).
type Chars = Vec<(char, bool)>;

/// The words of a shell line as they are read: the commands so far and the word being read.
#[derive(Default)]
struct Lexer {
    commands: Vec<Vec<Word>>,
    word: Chars,
    started: bool,
    quoted: bool,
}

impl Lexer {
    /// Start a word (an empty `''` is a word too).
    fn start(&mut self, quoted: bool) {
        self.started = true;
        self.quoted |= quoted;
    }

    /// End the word being read, if any, adding its brace expansions to the current command.
    fn end_word(&mut self) {
        if self.started {
            let quoted = self.quoted;
            let words = expand_braces(&self.word).into_iter().map(|w| Word {
                glob: w
                    .iter()
                    .any(|&(c, lit)| !lit && matches!(c, '*' | '?' | '[')),
                text: w.into_iter().map(|(c, _)| c).collect(),
                quoted,
            });
            self.commands.last_mut().unwrap().extend(words);
        }
        self.word.clear();
        self.started = false;
        self.quoted = false;
    }
}

/// The commands of one shell line (split at `;`, `&&`, `||` and `|`), as words, up to a comment.
fn shell_words(line: &str) -> Vec<Vec<Word>> {
    let mut lx = Lexer {
        commands: vec![Vec::new()],
        ..Lexer::default()
    };
    let mut it = line.chars().peekable();
    while let Some(c) = it.next() {
        match c {
            '\'' => {
                lx.start(true);
                lx.word
                    .extend(it.by_ref().take_while(|&c| c != '\'').map(|c| (c, true)));
            }
            '"' => {
                lx.start(true);
                while let Some(c) = it.next() {
                    match c {
                        '"' => break,
                        '\\' if matches!(it.peek(), Some('"' | '\\' | '$' | '`')) => {
                            lx.word.push((it.next().unwrap(), true))
                        }
                        _ => lx.word.push((c, true)),
                    }
                }
            }
            '\\' => {
                lx.start(false);
                lx.word.extend(it.next().map(|c| (c, true)));
            }
            '#' if !lx.started => break,
            c if c.is_whitespace() => lx.end_word(),
            ';' | '|' | '&' => {
                lx.end_word();
                it.next_if_eq(&c);
                lx.commands.push(Vec::new());
            }
            c => {
                lx.start(false);
                lx.word.push((c, false));
            }
        }
    }
    lx.end_word();
    lx.commands.retain(|c| !c.is_empty());
    lx.commands
}

/// Bash's brace expansion of one word (`a{1,2}b` is `a1b a2b`), unquoted braces only.
fn expand_braces(word: &Chars) -> Vec<Chars> {
    let unquoted = |i: usize, ch: char| word[i] == (ch, false);
    let Some(open) = (0..word.len()).find(|&i| unquoted(i, '{')) else {
        return vec![word.clone()];
    };
    let Some(close) = (open..word.len()).find(|&i| unquoted(i, '}')) else {
        return vec![word.clone()];
    };
    let commas: Vec<usize> = (open..close).filter(|&i| unquoted(i, ',')).collect();
    if commas.is_empty() {
        return vec![word.clone()];
    }
    let bounds: Vec<usize> = std::iter::once(open)
        .chain(commas)
        .chain(std::iter::once(close))
        .collect();
    let tails = expand_braces(&word[close + 1..].to_vec());
    let mut out = Vec::new();
    for pair in bounds.windows(2) {
        for tail in &tails {
            let mut w = word[..open].to_vec();
            w.extend_from_slice(&word[pair[0] + 1..pair[1]]);
            w.extend_from_slice(tail);
            out.push(w);
        }
    }
    out
}

/// One command line of a page: where it is and its words, `detnoise` first.
struct Example {
    page: String,
    line: usize,
    words: Vec<Word>,
}

impl Example {
    fn text(&self) -> String {
        let words: Vec<&str> = self.words.iter().map(|w| w.text.as_str()).collect();
        words.join(" ")
    }
}

/// The detnoise command lines among a shell command's words (itself, or a quoted argument
/// that is one).
fn detnoise_commands(words: &[Word], page: &str, line: usize, out: &mut Vec<Example>) {
    let texts: Vec<&str> = words.iter().map(|w| w.text.as_str()).collect();
    let rest = match texts.as_slice() {
        ["detnoise", ..] => Some(&words[1..]),
        ["cargo", "run", "--release", "--", ..] => Some(&words[4..]),
        _ => None,
    };
    if let Some(rest) = rest {
        let mut all = vec![Word {
            text: "detnoise".into(),
            glob: false,
            quoted: false,
        }];
        all.extend_from_slice(rest);
        out.push(Example {
            page: page.to_string(),
            line,
            words: all,
        });
    }
    for w in words
        .iter()
        .filter(|w| w.quoted && w.text.starts_with("detnoise "))
    {
        for inner in shell_words(&w.text) {
            detnoise_commands(&inner, page, line, out);
        }
    }
}

/// The detnoise command lines of a block, joining `\` continuations.
fn examples(page: &str, block: &Block) -> Vec<Example> {
    let mut out = Vec::new();
    let mut logical = String::new();
    let mut start = 0;
    for (n, line) in &block.lines {
        if logical.is_empty() {
            start = *n;
        }
        match line.trim_end().strip_suffix('\\') {
            Some(head) => {
                logical.push_str(head);
                logical.push(' ');
            }
            None => {
                logical.push_str(line);
                for words in shell_words(&logical) {
                    detnoise_commands(&words, page, start, &mut out);
                }
                logical.clear();
            }
        }
    }
    out
}

/// Blocks whose lines are shell commands (not Python, not a command's printed output).
fn is_shell(block: &Block) -> bool {
    block.info != "python" && block.marker.as_deref() != Some("stdout")
}

#[test]
fn every_command_line_in_the_manual_parses() {
    let mut checked = 0;
    let mut failures = Vec::new();
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        for block in blocks(&text).iter().filter(|b| is_shell(b)) {
            for ex in examples(&name(&page), block) {
                checked += 1;
                let argv: Vec<&str> = ex.words.iter().map(|w| w.text.as_str()).collect();
                let parsed = detnoise::cli::command()
                    .try_get_matches_from(&argv)
                    .and_then(|m| detnoise::cli::Cli::from_arg_matches(&m));
                match parsed {
                    Ok(_) => {}
                    Err(e)
                        if matches!(
                            e.kind(),
                            clap::error::ErrorKind::DisplayHelp
                                | clap::error::ErrorKind::DisplayVersion
                        ) => {}
                    Err(e) => failures.push(format!("{}:{}: {}\n{e}", ex.page, ex.line, ex.text())),
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {checked} command lines of the manual do not parse:\n\n{}",
        failures.len(),
        failures.join("\n")
    );
    // The README and the manual hold dozens; a handful means the extraction broke.
    assert!(checked >= 30, "only {checked} command lines found");
}

/// The words of a command with unquoted globs expanded in `dir`, as bash does (a glob that
/// matches nothing stays as written).
fn expanded(words: &[Word], dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    for w in words {
        let matches: Vec<String> = if w.glob {
            let pattern = dir.join(&w.text).display().to_string();
            glob::glob(&pattern)
                .unwrap()
                .map(|p| {
                    let p = p.unwrap();
                    p.strip_prefix(dir).unwrap().display().to_string()
                })
                .collect()
        } else {
            Vec::new()
        };
        if matches.is_empty() {
            out.push(w.text.clone());
        } else {
            out.extend(matches);
        }
    }
    out
}

/// Run a page's marked blocks in a scratch directory; the failures, each naming page and line.
fn run_page(page: &Path) -> Vec<String> {
    let page_name = name(page);
    let text = std::fs::read_to_string(page).unwrap();
    let scratch = tempfile::tempdir().unwrap();
    // The bundled data and the committed test fixtures (the campaign example reads these).
    for linked in ["data-synthetic", "tests"] {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join(linked);
        std::os::unix::fs::symlink(data, scratch.path().join(linked)).unwrap();
    }
    let mut failures = Vec::new();
    // What the last run block printed; a Python block's output is python/tests/test_docs.py's.
    let mut last_stdout: Option<String> = None;
    let mut after_python = false;
    for block in blocks(&text) {
        let line = block.lines.first().map_or(0, |l| l.0);
        if block.marker.as_deref() != Some("stdout") {
            after_python = block.info == "python";
        }
        match block.marker.as_deref() {
            None => {}
            Some("stdout") if after_python => {}
            Some("run") => {
                let examples = examples(&page_name, &block);
                if examples.is_empty() {
                    failures.push(format!("{page_name}:{line}: a run block without commands"));
                }
                last_stdout = None;
                for ex in examples {
                    let args = expanded(&ex.words[1..], scratch.path());
                    let out = common::detnoise()
                        .current_dir(scratch.path())
                        .args(&args)
                        .output()
                        .unwrap();
                    if !out.status.success() {
                        failures.push(format!(
                            "{page_name}:{}: {} failed ({}):\n{}",
                            ex.line,
                            ex.text(),
                            out.status,
                            String::from_utf8_lossy(&out.stderr)
                        ));
                    }
                    last_stdout = Some(String::from_utf8(out.stdout).unwrap());
                }
            }
            Some("stdout") => {
                let mut shown: String = block.lines.iter().map(|(_, l)| format!("{l}\n")).collect();
                if shown.is_empty() {
                    shown.push('\n');
                }
                match &last_stdout {
                    None => failures.push(format!(
                        "{page_name}:{line}: a stdout block that follows no run block"
                    )),
                    Some(printed) if *printed != shown => {
                        // The first line that differs, as a line of the page.
                        let at = shown
                            .lines()
                            .zip(printed.lines())
                            .position(|(a, b)| a != b)
                            .unwrap_or(shown.lines().count().min(printed.lines().count()));
                        failures.push(format!(
                            "{page_name}:{}: differs from what the command printed \
                             (the page's block starts at line {line}); the page shows\n{shown}\n\
                             the command printed\n{printed}",
                            line + at
                        ))
                    }
                    Some(_) => {}
                }
            }
            Some(other) => failures.push(format!("{page_name}:{line}: unknown marker {other:?}")),
        }
    }
    failures.extend(
        not_ignored(scratch.path()).into_iter().map(|n| {
            format!("{page_name}: the examples write {n}, which .gitignore does not list")
        }),
    );
    failures
}

/// What the examples wrote in `dir` that git would show as untracked in a clone where they
/// ran (nothing when git or the repository is not there to ask).
fn not_ignored(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let entry = entry.unwrap();
        let mut name = entry.file_name().to_string_lossy().into_owned();
        if name == "data-synthetic" || name == "tests" {
            continue;
        }
        if entry.file_type().unwrap().is_dir() {
            name.push('/');
        }
        let asked = std::process::Command::new("git")
            .args(["check-ignore", "-q", "--no-index", &name])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .status();
        // 0: ignored, 1: not ignored; anything else: no git or no repository to ask.
        if asked.is_ok_and(|s| s.code() == Some(1)) {
            out.push(name);
        }
    }
    out.sort();
    out
}

#[test]
fn marked_examples_run_and_print_what_the_page_shows() {
    let mut failures = Vec::new();
    let mut ran = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        ran += blocks(&text)
            .iter()
            .filter(|b| b.marker.as_deref() == Some("run"))
            .count();
        failures.extend(run_page(&page));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    assert!(ran >= 5, "only {ran} blocks marked to run");
}

/// GitHub's anchor of a heading: lower case, spaces to `-`, punctuation other than `-` and
/// `_` dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a page's headings (outside code blocks).
fn anchors(text: &str) -> Vec<String> {
    let mut in_code = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            in_code = !in_code;
        } else if !in_code && line.starts_with('#') {
            out.push(slug(line.trim_start_matches('#')));
        }
    }
    out
}

/// The relative link targets of a page (`[text](target)` and images), with line numbers.
fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut in_code = false;
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            in_code = !in_code;
        }
        if in_code {
            continue;
        }
        let mut rest = line;
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let Some(end) = after.find(')') else { break };
            let target = &after[..end];
            if !target.contains("://") && !target.starts_with("mailto:") {
                out.push((i + 1, target.to_string()));
            }
            rest = &after[end..];
        }
    }
    out
}

#[test]
fn every_relative_link_and_anchor_of_the_manual_resolves() {
    let mut failures = Vec::new();
    let mut checked = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        for (line, target) in links(&text) {
            checked += 1;
            let (file, anchor) = match target.split_once('#') {
                Some((f, a)) => (f, Some(a)),
                None => (target.as_str(), None),
            };
            let path = if file.is_empty() {
                page.clone()
            } else {
                page.parent().unwrap().join(file)
            };
            if !path.exists() {
                failures.push(format!("{}:{line}: {target}: no such file", name(&page)));
                continue;
            }
            if let Some(anchor) = anchor {
                let target_text = std::fs::read_to_string(&path).unwrap_or_default();
                if !anchors(&target_text).iter().any(|a| a == anchor) {
                    failures.push(format!("{}:{line}: {target}: no such heading", name(&page)));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(checked >= 20, "only {checked} links found");
}

#[test]
fn the_extractor_reads_shell_as_bash_does() {
    let block = Block {
        info: "sh".into(),
        marker: None,
        lines: vec![
            (1, "detnoise report --flats f-{1,2}e.fits \\".into()),
            (2, "    --out 'my dir'   # a comment".into()),
            (
                3,
                "cargo run --release -- simulate --iters 5 && echo done".into(),
            ),
            (
                4,
                "sbatch --wrap \"detnoise subaps-merge parts --out m\"".into(),
            ),
            (5, "# detnoise not-a-command".into()),
        ],
    };
    let found: Vec<(usize, String)> = examples("p", &block)
        .iter()
        .map(|e| (e.line, e.text()))
        .collect();
    assert_eq!(
        found,
        [
            (
                1,
                "detnoise report --flats f-1e.fits f-2e.fits --out my dir".to_string()
            ),
            (3, "detnoise simulate --iters 5".to_string()),
            (4, "detnoise subaps-merge parts --out m".to_string()),
        ]
    );
    let words = &examples("p", &block)[0].words;
    assert_eq!(words[6].text, "my dir");
    let globbed = shell_words("detnoise darks d/*00e.fits '*x'");
    assert!(globbed[0][2].glob && !globbed[0][3].glob);
}
