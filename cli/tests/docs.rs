//! The command examples of the documentation, run as written: every `console` block with a
//! `$ rom ...` line in `README.md`, `docs/` and `examples/` is executed by trycmd and its output
//! compared with the page (`...` and `[..]` elide only what is not deterministic: wall-clock
//! times). How to re-record and how to mark a heavy command: `CONTRIBUTING.md`.
//!
//! Each page runs in a working directory of its own under the target directory, which sees the
//! checkout's files (so `examples/data/loose` resolves as from the repository root) and receives
//! whatever the commands write, so the checkout stays clean.
//!
//! Blocks marked `console,ignore` are of two kinds. A README block whose command a guide page
//! runs is not run twice: its output must match the guide's recorded output (it may elide
//! lines with `...`). Any other `$ rom` block so marked is heavy: the `#[ignore]`d test runs it
//! as written, and `cli/tests/docs/short-variants.md` runs a short variant every time.

use std::path::{Path, PathBuf};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .canonicalize()
        .unwrap()
}

/// A fenced code block: the line index of its opening fence, its info string, its lines.
struct Block {
    fence: usize,
    info: String,
    lines: Vec<String>,
}

impl Block {
    fn is_console(&self) -> bool {
        self.info == "console"
    }

    fn is_ignored_console(&self) -> bool {
        self.info == "console,ignore"
    }

    fn commands(&self) -> impl Iterator<Item = &str> {
        self.lines.iter().filter_map(|l| l.strip_prefix("$ "))
    }

    /// The output shown after the block's first command.
    fn output(&self) -> String {
        let body: Vec<&str> = self
            .lines
            .iter()
            .skip(1)
            .take_while(|l| !l.starts_with("$ "))
            .map(String::as_str)
            .collect();
        body.join("\n")
    }
}

fn blocks(text: &str) -> Vec<Block> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        if let Some(info) = lines[i].strip_prefix("```") {
            let end = (i + 1..lines.len())
                .find(|&j| lines[j].starts_with("```"))
                .unwrap_or_else(|| panic!("a code block opened on line {} is not closed", i + 1));
            out.push(Block {
                fence: i,
                info: info.trim().to_string(),
                lines: lines[i + 1..end].iter().map(|l| l.to_string()).collect(),
            });
            i = end;
        }
        i += 1;
    }
    out
}

/// Markdown pages (relative to the workspace) with at least one `$ rom` command, README first.
fn pages_with_commands() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for p in entries {
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|e| e == "md") {
                out.push(p);
            }
        }
    }
    let root = workspace();
    let mut pages = vec![root.join("README.md")];
    walk(&root.join("docs"), &mut pages);
    walk(&root.join("examples"), &mut pages);
    pages
        .into_iter()
        .filter(|p| {
            std::fs::read_to_string(p)
                .unwrap()
                .lines()
                .any(|l| l.starts_with("$ rom"))
        })
        .map(|p| p.strip_prefix(&root).unwrap().to_path_buf())
        .collect()
}

fn read(page: &Path) -> String {
    std::fs::read_to_string(workspace().join(page)).unwrap()
}

/// Code blocks whose info string names a file after the language (```` ```toml small.toml ````)
/// are files the page's commands read, e.g. a campaign's settings: written into `dir`.
fn write_shown_files(page: &str, dir: &Path) {
    for b in blocks(page) {
        if let Some(name) = b.info.split_whitespace().nth(1) {
            std::fs::write(dir.join(name), b.lines.join("\n") + "\n").unwrap();
        }
    }
}

/// A page's copy in `scratch`, with its working directory `PAGE.in/` (trycmd's rule for a
/// case's directory) linking every top-level entry of the checkout but `target/`. With
/// `shared`, `PAGE.in` is a link to that one directory instead.
#[cfg(unix)]
fn stage(page: &Path, text: &str, scratch: &Path, shared: Option<&Path>) -> PathBuf {
    let root = workspace();
    let copy = scratch.join(page);
    std::fs::create_dir_all(copy.parent().unwrap()).unwrap();
    std::fs::write(&copy, text).unwrap();
    let dir = copy.with_extension("in");
    if let Some(shared) = shared {
        std::os::unix::fs::symlink(shared, &dir).unwrap();
    } else {
        std::fs::create_dir_all(&dir).unwrap();
    }
    for e in std::fs::read_dir(&root).unwrap() {
        let name = e.unwrap().file_name();
        let link = dir.join(&name);
        if name != "target" && !name.to_string_lossy().starts_with('.') && !link.exists() {
            std::os::unix::fs::symlink(root.join(&name), link).unwrap();
        }
    }
    write_shown_files(text, &dir);
    copy
}

fn overwriting() -> bool {
    std::env::var("TRYCMD").is_ok_and(|v| v == "overwrite")
}

/// Runs the pages' copies, in parallel unless `shared` gives them one working directory (then
/// in order, one page after the other); under `TRYCMD=overwrite` the re-recorded copies are
/// written back to the pages through `unstage`.
fn run_pages(
    pages: &[(PathBuf, String)],
    shared: Option<&Path>,
    unstage: impl Fn(&Path, &str) -> String,
) {
    let scratch = scratch();
    let copies: Vec<PathBuf> = pages
        .iter()
        .map(|(page, text)| stage(page, text, scratch.path(), shared))
        .collect();
    let groups: Vec<Vec<&PathBuf>> = match shared {
        None => vec![copies.iter().collect()],
        Some(_) => copies.iter().map(|c| vec![c]).collect(),
    };
    let outcome = std::panic::catch_unwind(|| {
        for group in &groups {
            let cases = trycmd::TestCases::new();
            cases
                .register_bin("rom", PathBuf::from(env!("CARGO_BIN_EXE_rom")))
                .register_bin("ls", PathBuf::from("/bin/ls"))
                .env("NO_COLOR", "1");
            for c in group {
                cases.case(c);
            }
            cases.run();
        }
    });
    if overwriting() {
        for ((page, text), copy) in pages.iter().zip(&copies) {
            let recorded = unstage(page, &std::fs::read_to_string(copy).unwrap());
            if &recorded != text {
                std::fs::write(workspace().join(page), recorded).unwrap();
            }
        }
    }
    if let Err(e) = outcome {
        std::panic::resume_unwind(e);
    }
}

fn scratch() -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix("docs-")
        .tempdir_in(env!("CARGO_TARGET_TMPDIR"))
        .unwrap()
}

/// Every command a runnable block of some page runs, with the output the page shows for it.
pub(crate) fn run_commands(pages: &[(PathBuf, String)]) -> Vec<(String, String, PathBuf)> {
    let mut out = Vec::new();
    for (page, text) in pages {
        for b in blocks(text).iter().filter(|b| b.is_console()) {
            for (k, line) in b.lines.iter().enumerate() {
                if let Some(cmd) = line.strip_prefix("$ ") {
                    let rest = Block {
                        fence: 0,
                        info: String::new(),
                        lines: b.lines[k..].to_vec(),
                    };
                    out.push((cmd.to_string(), rest.output(), page.clone()));
                }
            }
        }
    }
    out
}

/// README blocks marked `console,ignore` whose command a guide runs: their output must match
/// the guide's (the README may elide lines with `...` and ends of lines with `[..]`). Under
/// `TRYCMD=overwrite` a block that elides nothing is replaced by the guide's output.
fn check_readme_excerpts(pages: &[(PathBuf, String)]) {
    let run = run_commands(pages);
    let readme = read(Path::new("README.md"));
    let mut lines: Vec<String> = readme.lines().map(String::from).collect();
    let mut failures = Vec::new();
    for b in blocks(&readme).iter().filter(|b| b.is_ignored_console()) {
        let Some(cmd) = b.commands().next().filter(|c| c.starts_with("rom ")) else {
            continue;
        };
        let Some((_, shown, page)) = run.iter().find(|(c, _, _)| c == cmd) else {
            continue;
        };
        let excerpt = b.output();
        let elides = excerpt.contains("...") || excerpt.contains("[..]");
        if overwriting() && !elides && excerpt != *shown {
            let end = b.fence + 1 + b.lines.len();
            let new: Vec<String> = std::iter::once(b.lines[0].clone())
                .chain(shown.lines().map(String::from))
                .collect();
            lines.splice(b.fence + 1..end, new);
            std::fs::write(workspace().join("README.md"), lines.join("\n") + "\n").unwrap();
            return check_readme_excerpts(pages);
        }
        let verdict = snapbox::Assert::new().try_eq(
            Some(&page.display()),
            snapbox::Data::text(shown.clone()),
            snapbox::Data::text(excerpt),
        );
        if let Err(e) = verdict {
            failures.push(format!(
                "README.md line {}: `$ {cmd}` shows what {} does not:\n{e}",
                b.fence + 1,
                page.display()
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn pages_and_short_variants() -> Vec<(PathBuf, String)> {
    let mut pages: Vec<(PathBuf, String)> = pages_with_commands()
        .into_iter()
        .map(|p| {
            let text = read(&p);
            (p, text)
        })
        .collect();
    let short = PathBuf::from("cli/tests/docs/short-variants.md");
    let text = read(&short);
    pages.push((short, text));
    pages
}

#[test]
fn every_documented_command_prints_what_its_page_shows() {
    let pages = pages_and_short_variants();
    run_pages(&pages, None, |_, t| t.to_string());
    if overwriting() {
        check_readme_excerpts(&pages_and_short_variants());
    }
}

#[test]
fn the_readme_shows_what_the_guides_record() {
    check_readme_excerpts(&pages_and_short_variants());
}

/// Swaps `console` and `console,ignore` on the page's code blocks with these ordinals (the
/// n-th block of the page; re-recording moves lines but keeps the blocks).
fn flip(text: &str, ordinals: &[usize]) -> String {
    let bs = blocks(text);
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    for f in ordinals.iter().map(|&n| bs[n].fence) {
        lines[f] = match lines[f].as_str() {
            "```console" => "```console,ignore".to_string(),
            "```console,ignore" => "```console".to_string(),
            other => panic!("line {}: not a console block: {other}", f + 1),
        };
    }
    lines.join("\n") + if text.ends_with('\n') { "\n" } else { "" }
}

/// The heavy blocks (`console,ignore` with a `$ rom` command no page runs) of each page, as
/// the page with only those blocks runnable, and the blocks flipped to make it so.
fn heavy_pages() -> Vec<(PathBuf, String, Vec<usize>)> {
    let pages = pages_and_short_variants();
    let run = run_commands(&pages);
    let mut out = Vec::new();
    for (page, text) in &pages {
        let bs = blocks(text);
        let heavy: Vec<usize> = bs
            .iter()
            .enumerate()
            .filter(|(_, b)| b.is_ignored_console())
            .filter(|(_, b)| {
                b.commands()
                    .any(|c| c.starts_with("rom ") && !run.iter().any(|(r, _, _)| r == c))
            })
            .map(|(n, _)| n)
            .collect();
        if heavy.is_empty() {
            continue;
        }
        let mut ordinals = heavy;
        ordinals.extend((0..bs.len()).filter(|&n| bs[n].is_console()));
        out.push((page.clone(), flip(text, &ordinals), ordinals));
    }
    out
}

#[test]
fn the_heavy_blocks_are_few_and_known() {
    let pages = heavy_pages();
    for (page, text, ordinals) in &pages {
        assert_eq!(flip(text, ordinals), read(page), "{}", page.display());
    }
    let heavy: Vec<String> = pages
        .iter()
        .map(|(p, _, _)| p.display().to_string())
        .collect();
    assert_eq!(
        heavy,
        [
            "docs/guide/calibrate.md",
            "docs/guide/train.md",
            "docs/guide/validate.md"
        ],
        "a page gained or lost a heavy (console,ignore) block: give it a short variant in \
         cli/tests/docs/short-variants.md and list it here"
    );
}

/// The heavy blocks as written, one page after another in one working directory (the
/// validation guide uses the surrogate the training guide makes). About 15 minutes on two
/// cores.
#[test]
#[ignore]
fn heavy_documented_commands_as_written() {
    let heavy = heavy_pages();
    let pages: Vec<(PathBuf, String)> = heavy
        .iter()
        .map(|(p, t, _)| (p.clone(), t.clone()))
        .collect();
    let shared = scratch();
    run_pages(&pages, Some(shared.path()), |page, t| {
        let (_, _, ordinals) = heavy.iter().find(|(p, _, _)| p == page).unwrap();
        flip(t, ordinals)
    });
}
