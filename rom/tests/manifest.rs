//! The shipped models' manifest matches the models and their validation files: rebuilt in
//! memory, it equals `artifacts/manifest.json` in everything but the commits (which `git log`
//! gives only in a checkout). Regenerate with `cargo run -p beltwin-rom --example manifest`.

use std::path::PathBuf;

use rom::info::Manifest;

#[test]
fn the_manifest_matches_the_shipped_models_and_their_validation_files() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let read = |rel: &str| {
        std::fs::read_to_string(root.join(rel))
            .map_err(|e| rom::RomError::Data(format!("{rel}: {e}")))
    };
    let stored = Manifest::shipped().unwrap();
    let commit_of = |file: &str| {
        stored
            .models
            .iter()
            .find(|m| m.file.as_deref() == Some(file))
            .and_then(|m| m.commit.clone())
    };
    let rebuilt = Manifest::build(read, commit_of).unwrap();
    assert_eq!(
        rebuilt, stored,
        "artifacts/manifest.json is stale: regenerate it with `cargo run -p beltwin-rom \
         --example manifest`"
    );
    assert_eq!(stored.models.len(), 2);
    for m in &stored.models {
        let c = m.commit.as_deref().unwrap_or("");
        assert!(
            c.len() == 40 && c.chars().all(|ch| ch.is_ascii_hexdigit()),
            "{:?}: commit {c:?}",
            m.file
        );
        let v = m.validation.as_ref().unwrap();
        assert!(v.regions.iter().all(|r| r.points > 0), "{v:?}");
    }
}
