//! `artifacts/` holds only what `rom` ships (`artifacts/README.md`): the models' `*.json`, their
//! `manifest.json` and the README. Experiments live in `studies/`, one folder each, and no
//! script in the repository writes into `artifacts/`.

use std::path::{Path, PathBuf};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Why the entry `name` of `artifacts/` does not belong there, if it does not (`is_file`: a
/// regular file, not a folder or a link).
fn misplaced(name: &str, is_file: bool) -> Option<String> {
    if !is_file {
        return Some(format!(
            "{name}: not a regular file (experiments go to studies/<name>/)"
        ));
    }
    if name == "README.md" || name.ends_with(".json") {
        return None;
    }
    Some(format!(
        "{name}: only the models' *.json, manifest.json and README.md belong in artifacts/ \
         (scripts and results: studies/<name>/; test inputs: tests/fixtures/)"
    ))
}

/// Signs that a script line writes the file it names: a redirection, an output flag, a copy
/// or move, a training run (which writes `--model`), or a file opened for writing.
const WRITE_MARKS: [&str; 14] = [
    ">",
    "--out",
    "--json",
    "--plot",
    "--report",
    "--startup",
    "--measurement-out",
    "--manifest",
    "tee ",
    "cp ",
    "mv ",
    " train",
    "\"w\"",
    "write",
];

/// Whether `line` of a script names the `artifacts` folder other than to read one of the
/// shipped files `shipped` (`artifacts/NAME` on a line that writes nothing).
fn writes_into_artifacts(line: &str, shipped: &[String]) -> bool {
    let mut rest = line;
    while let Some(i) = rest.find("artifacts") {
        let before = rest[..i].chars().next_back();
        let after = &rest[i + "artifacts".len()..];
        rest = after;
        // Only the folder itself: not `build_artifacts` or `artifactsdir`.
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '-')
            || after
                .chars()
                .next()
                .is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '-')
        {
            continue;
        }
        let Some(path) = after.strip_prefix('/') else {
            return true; // the folder as a whole: an output folder
        };
        let name: String = path
            .chars()
            .take_while(|c| c.is_alphanumeric() || matches!(c, '.' | '-' | '_'))
            .collect();
        let name = name.trim_end_matches('.'); // a sentence's full stop
        if !shipped.iter().any(|s| s == name) || WRITE_MARKS.iter().any(|m| line.contains(m)) {
            return true;
        }
    }
    false
}

/// Every script of the workspace: shell and Python files, and the crates' Rust examples, outside
/// build output and hidden folders.
fn scripts() -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            if name.starts_with('.') || name == "target" || name == "__pycache__" {
                continue;
            }
            if p.is_dir() {
                walk(&p, out);
            } else if name.ends_with(".sh")
                || name.ends_with(".py")
                || (name.ends_with(".rs")
                    && p.parent()
                        .and_then(Path::file_name)
                        .is_some_and(|d| d == "examples"))
            {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    walk(&workspace(), &mut out);
    out
}

#[test]
fn artifacts_holds_only_the_shipped_models_their_manifest_and_readme() {
    let dir = workspace().join("artifacts");
    let mut names = Vec::new();
    let mut wrong = Vec::new();
    for e in std::fs::read_dir(&dir).unwrap() {
        let e = e.unwrap();
        let name = e.file_name().to_string_lossy().into_owned();
        wrong.extend(misplaced(&name, e.file_type().unwrap().is_file()));
        names.push(name);
    }
    assert!(wrong.is_empty(), "in artifacts/:\n{}", wrong.join("\n"));
    // Every *.json besides the manifest is a model the manifest lists.
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("manifest.json")).unwrap()).unwrap();
    let listed: Vec<String> = manifest["models"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| {
            m["file"]
                .as_str()
                .unwrap()
                .trim_start_matches("artifacts/")
                .to_string()
        })
        .collect();
    for name in names
        .iter()
        .filter(|n| n.ends_with(".json") && *n != "manifest.json")
    {
        assert!(
            listed.contains(name),
            "artifacts/{name} is not a model listed in artifacts/manifest.json \
             (test inputs belong in tests/fixtures/)"
        );
    }
    for model in [
        "hvac-surrogate.json",
        "synchronous-arc-tooth-surrogate.json",
        "manifest.json",
        "README.md",
    ] {
        assert!(
            names.iter().any(|n| n == model),
            "artifacts/{model} missing"
        );
    }
}

#[test]
fn no_script_writes_into_artifacts() {
    let shipped: Vec<String> = std::fs::read_dir(workspace().join("artifacts"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let scripts = scripts();
    assert!(
        scripts
            .iter()
            .any(|p| p.ends_with("studies/gap-confusion/run.sh")),
        "the walk missed studies/: {} scripts",
        scripts.len()
    );
    let mut found = Vec::new();
    for path in scripts {
        let text = std::fs::read_to_string(&path).unwrap();
        for (i, line) in text.lines().enumerate() {
            if writes_into_artifacts(line, &shipped) {
                found.push(format!("{}:{}: {}", path.display(), i + 1, line.trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "scripts that write into artifacts/ (write into their study's folder instead):\n{}",
        found.join("\n")
    );
}

#[test]
fn the_checks_tell_an_output_from_a_read_of_a_shipped_model() {
    let shipped = vec!["hvac-surrogate.json".to_string()];
    for line in [
        "out=artifacts/gap_confusion.csv",
        "rom simulate --out artifacts/run.csv",
        "rom train --model artifacts/hvac-surrogate.json",
        "cat run.csv > artifacts/hvac-surrogate.json",
        "        .unwrap_or_else(|| root.join(\"artifacts\"));",
        "cd artifacts && ./run.sh",
    ] {
        assert!(writes_into_artifacts(line, &shipped), "not caught: {line}");
    }
    for line in [
        "rom predict --model artifacts/hvac-surrogate.json --d 0.42",
        "# the shipped model is artifacts/hvac-surrogate.json.",
        "cargo build --release  # build_artifacts are elsewhere",
    ] {
        assert!(!writes_into_artifacts(line, &shipped), "flagged: {line}");
    }
    assert!(misplaced("gap_confusion.sh", true).is_some());
    assert!(misplaced("field", false).is_some());
    assert!(misplaced("hvac-surrogate.json", true).is_none());
    assert!(misplaced("README.md", true).is_none());
}
