//! Writes `artifacts/manifest.json`, the shipped models' manifest (`rom::info::Manifest`):
//! per model its kind, id, inputs and trained ranges, provenance, the commit that last changed
//! the file (`git log -1`) and the validation summary of its `rom validate` files.
//!
//! `cargo run --release -p beltwin-rom --example manifest` from a checkout; run it again after
//! a shipped model or its validation files change (`rom/tests/manifest.rs` fails until then).

use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let read = |rel: &str| {
        std::fs::read_to_string(root.join(rel))
            .map_err(|e| rom::RomError::Data(format!("{rel}: {e}")))
    };
    let commit = |rel: &str| {
        let out = std::process::Command::new("git")
            .args(["log", "-1", "--format=%H", "--", rel])
            .current_dir(&root)
            .output()
            .ok()?;
        let hash = String::from_utf8(out.stdout).ok()?.trim().to_string();
        (!hash.is_empty()).then_some(hash)
    };
    let manifest = rom::info::Manifest::build(read, commit)?;
    let text = serde_json::to_string_pretty(&manifest)? + "\n";
    let path = root.join("artifacts/manifest.json");
    fom::output::write_atomic(&path, |w| w.write_all(text.as_bytes()))?;
    println!("wrote {}", path.display());
    Ok(())
}
