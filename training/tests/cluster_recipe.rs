//! The cluster recipes in docs/guide/train.md ("On a cluster") are the generator's output for
//! the campaign the page describes, so the page cannot drift from what `rom train --submit`
//! writes. `BELTWIN_BLESS=1` rewrites the page's blocks from the generator.

use std::path::PathBuf;

use training::cluster::{kubernetes_recipe, slurm_script, ClusterCampaign, SlurmOptions, Step};

fn page() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../docs/guide/train.md")
}

/// The campaign of the page: 1024 points in 16 shards, one refinement round of 24.
fn campaign() -> ClusterCampaign {
    ClusterCampaign {
        rom: "rom".into(),
        data: "/data/campaign".into(),
        flags: vec!["--samples".into(), "1024".into()],
        shards: 16,
        rounds: vec![24],
        model: None,
    }
}

/// The fenced block after the line `marker` on the page: (start, end) byte offsets of its body.
fn block(text: &str, marker: &str) -> (usize, usize) {
    let at = text
        .find(marker)
        .unwrap_or_else(|| panic!("{marker} missing from {}", page().display()));
    let open = at
        + text[at..]
            .find("```")
            .expect("a fenced block after the marker");
    let start = open + text[open..].find('\n').unwrap() + 1;
    let end = start + text[start..].find("```").expect("the block's end");
    (start, end)
}

#[test]
fn the_pages_slurm_script_and_kubernetes_recipe_are_the_generators() {
    let c = campaign();
    let opts = SlurmOptions {
        partition: None,
        time: Some("01:00:00".into()),
    };
    let expected = [
        (
            "<!-- generated: the Slurm script of the design's runs -->",
            slurm_script(&c, Step::Shards { round: 0 }, &opts),
        ),
        (
            "<!-- generated: the Kubernetes recipe -->",
            kubernetes_recipe(&c, "your-registry/beltwin:latest", "beltwin-data"),
        ),
    ];
    let mut text = std::fs::read_to_string(page()).unwrap();
    if std::env::var_os("BELTWIN_BLESS").is_some() {
        for (marker, want) in &expected {
            let (s, e) = block(&text, marker);
            text.replace_range(s..e, want);
        }
        std::fs::write(page(), &text).unwrap();
    }
    for (marker, want) in &expected {
        let (s, e) = block(&text, marker);
        assert_eq!(
            &text[s..e],
            want,
            "{} after {marker} is not the generator's output (re-record with BELTWIN_BLESS=1)",
            page().display()
        );
    }
}
