//! The sample data sets of `examples/data/` answer as the README's quick start shows: a
//! newcomer's first `rom diagnose` must work on them.

use std::process::Command;

/// `rom diagnose` on `examples/data/SET`: stdout, after checking the exit status.
fn diagnose(set: &str) -> String {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/data/");
    let o = Command::new(env!("CARGO_BIN_EXE_rom"))
        .args(["diagnose", "--measured", &format!("{dir}{set}")])
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{set}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

/// The class column of label `label`'s row.
fn class_of<'a>(table: &'a str, label: &str) -> &'a str {
    let row = table
        .lines()
        .find(|l| l.starts_with(label))
        .unwrap_or_else(|| panic!("no row {label} in\n{table}"));
    row.rsplit('|').next().unwrap().trim()
}

#[test]
fn the_healthy_sample_is_healthy_at_every_label() {
    let t = diagnose("healthy");
    for label in ["d0", "d1", "d2", "d3"] {
        assert!(class_of(&t, label).starts_with("healthy"), "{t}");
    }
}

#[test]
fn the_loose_sample_is_healthy_then_strongly_loose_at_its_last_label() {
    let t = diagnose("loose");
    for label in ["d0", "d1", "d2"] {
        assert!(class_of(&t, label).starts_with("healthy"), "{t}");
    }
    assert!(class_of(&t, "d3").starts_with("strong"), "{t}");
}
