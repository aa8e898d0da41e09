//! The workspace's code-shape rules, checked on every test run (see `docs/architecture.md`,
//! "Code-shape rules"): no source file over 800 lines and no function over 150 lines, outside
//! test code (a file's `#[cfg(test)]` module, `tests/` folders, `benches/`, `examples/`); and no
//! code comment that cites an issue number or README prose instead of a stable document.

use std::path::{Path, PathBuf};

const MAX_FILE_LINES: usize = 800;
const MAX_FN_LINES: usize = 150;
const CRATES: [&str; 8] = [
    "fom", "training", "rom", "twin", "serve", "fmu", "cli", "python",
];

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Every `.rs` file under the crates' `src/` folders.
fn sources() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    for c in CRATES {
        walk(&workspace().join(c).join("src"), &mut out);
    }
    assert!(out.len() > 50, "found only {} source files", out.len());
    out
}

/// The lines of `text` before its `#[cfg(test)]` module.
fn non_test_lines(text: &str) -> Vec<&str> {
    text.lines()
        .take_while(|l| !l.starts_with("#[cfg(test)]"))
        .collect()
}

/// Functions of `lines` as (name, first line number, length in lines): a `fn` item runs from its
/// signature to the closing brace at the signature's indentation.
fn functions(lines: &[&str]) -> Vec<(String, usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let l = lines[i];
        let trimmed = l.trim_start();
        let indent = l.len() - trimmed.len();
        let sig = trimmed
            .trim_start_matches("pub(crate) ")
            .trim_start_matches("pub(super) ")
            .trim_start_matches("pub ")
            .trim_start_matches("const ")
            .trim_start_matches("unsafe ");
        if let Some(rest) = sig.strip_prefix("fn ") {
            let name: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            let mut j = i;
            while j < lines.len() && !lines[j].trim_end().ends_with('{') {
                if lines[j].trim_end().ends_with(';') {
                    break;
                }
                j += 1;
            }
            if j < lines.len() && lines[j].trim_end().ends_with('{') {
                let close = " ".repeat(indent) + "}";
                let mut k = j + 1;
                while k < lines.len() && !lines[k].starts_with(&close) {
                    k += 1;
                }
                out.push((name, i + 1, k - i + 1));
                i = k;
            }
        }
        i += 1;
    }
    out
}

fn relative(p: &Path) -> String {
    p.strip_prefix(workspace())
        .unwrap_or(p)
        .display()
        .to_string()
}

#[test]
fn no_source_file_is_over_800_lines_outside_tests() {
    let long: Vec<_> = sources()
        .into_iter()
        .filter_map(|p| {
            let n = non_test_lines(&std::fs::read_to_string(&p).unwrap()).len();
            (n > MAX_FILE_LINES).then(|| format!("{} ({n} lines)", relative(&p)))
        })
        .collect();
    assert!(
        long.is_empty(),
        "files over {MAX_FILE_LINES} lines: {long:?}"
    );
}

#[test]
fn no_function_is_over_150_lines_outside_tests() {
    let long: Vec<_> = sources()
        .into_iter()
        .flat_map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            functions(&non_test_lines(&text))
                .into_iter()
                .filter(|(_, _, n)| *n > MAX_FN_LINES)
                .map(|(name, line, n)| format!("{}:{line} {name} ({n} lines)", relative(&p)))
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(
        long.is_empty(),
        "functions over {MAX_FN_LINES} lines: {long:?}"
    );
}

#[test]
fn the_function_counter_sees_a_long_function() {
    let body = "    let x = 1;\n".repeat(200);
    let text = format!(
        "pub fn long(\n    a: f64,\n) -> f64 {{\n{body}    x\n}}\nfn short() {{\n    1\n}}\n"
    );
    let f = functions(&text.lines().collect::<Vec<_>>());
    assert_eq!(f[0].0, "long");
    // Three signature lines, 200 body lines, the tail expression and the closing brace.
    assert_eq!(f[0].2, 205);
    assert_eq!((f[1].0.as_str(), f[1].2), ("short", 3));
}

#[test]
fn code_comments_cite_stable_documents_not_issues_or_readme_prose() {
    let bad: Vec<_> = sources()
        .into_iter()
        .flat_map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            text.lines()
                .enumerate()
                .filter(|(_, l)| {
                    let c = match l.find("//") {
                        Some(i) => &l[i..],
                        None => return false,
                    };
                    let lower = c.to_ascii_lowercase();
                    let issue = lower
                        .split("issue ")
                        .skip(1)
                        .any(|rest| rest.starts_with(|ch: char| ch.is_ascii_digit()));
                    issue || c.contains("README")
                })
                .map(|(i, _)| format!("{}:{}", relative(&p), i + 1))
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(
        bad.is_empty(),
        "comments citing issues or the README: {bad:?}"
    );
}
