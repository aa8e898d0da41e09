//! The surrogate file: one JSON header line, then the JSON payload.
//!
//! The header carries the format version, provenance (crate version, creation time, the
//! configuration's SHA-256, sample count, seed, parameter ranges), the payload's length and a
//! SHA-256 over the header line (with that field empty) and the payload, so a truncated or
//! edited file, header included, is refused before its payload is parsed. Format 1 files (the
//! checksum over the payload only) are still read.

use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use training::dataset::hex;
use training::DesignRanges;

use crate::surrogate::Surrogate;
use crate::RomError;

/// Format version written: the steady processes as direct mean and variance predictors
/// (`gp::KrigingMean`, `gp::KrigingVariance`, the Cholesky factor packed as base64) instead of
/// the egobox state (2.6 MB and a 28.7 ms `rom predict` with the 248-run model;
/// `docs/validation/speed.md`, "Surrogate predictions").
pub const FORMAT: &str = "beltwin-surrogate/3";
/// Still read: the egobox state of the steady processes, checksum over header and payload.
pub const FORMAT_2: &str = "beltwin-surrogate/2";
/// Still read: its checksum covers the payload only.
pub const FORMAT_1: &str = "beltwin-surrogate/1";

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Header {
    pub format: String,
    pub crate_version: String,
    /// UTC creation time, ISO 8601.
    pub created_utc: String,
    /// SHA-256 of the full-order configuration's canonical TOML.
    pub config_sha256: String,
    pub samples: usize,
    pub seed: u64,
    pub training_runs: usize,
    pub failed_runs: usize,
    /// The trained design ranges (files before `DesignRanges`: centre distance, friction and
    /// installation tension only).
    pub ranges: DesignRanges,
    pub startup_modes: usize,
    pub steady_modes: usize,
    pub payload_bytes: usize,
    /// SHA-256 of the header line with this field empty, a newline and the payload (format 1:
    /// of the payload alone).
    #[serde(alias = "payload_sha256")]
    pub sha256: String,
}

/// A loaded surrogate with its header.
#[derive(Debug, Clone)]
pub struct SurrogateFile {
    pub header: Header,
    pub surrogate: Surrogate,
}

/// ISO 8601 UTC time of a Unix timestamp (days-from-civil inverse: H. Hinnant,
/// "chrono-Compatible Low-Level Date Algorithms", 2013).
pub fn iso_utc(unix_s: u64) -> String {
    let days = (unix_s / 86_400) as i64;
    let rem = unix_s % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

/// The current time, ISO 8601 UTC (a model file's creation stamp).
pub(crate) fn now_utc() -> String {
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    iso_utc(now)
}

/// Longest header line a surrogate file may have (it is about 600 bytes).
pub(crate) const MAX_HEADER_BYTES: u64 = 64 * 1024;

impl SurrogateFile {
    /// Wraps a fitted surrogate with a header stamped now.
    pub fn new(surrogate: Surrogate, config_sha256: String) -> Self {
        let st = &surrogate.settings;
        let header = Header {
            format: FORMAT.into(),
            crate_version: env!("CARGO_PKG_VERSION").into(),
            created_utc: now_utc(),
            config_sha256,
            samples: st.samples,
            seed: st.seed,
            training_runs: surrogate.training_runs,
            failed_runs: surrogate.failed_runs,
            ranges: st.ranges(),
            startup_modes: surrogate.startup.means.len(),
            steady_modes: surrogate.steady.means.len(),
            payload_bytes: 0,
            sha256: String::new(),
        };
        Self { header, surrogate }
    }

    /// Writes the file atomically.
    pub fn save(&self, path: &Path) -> Result<(), RomError> {
        let payload = serde_json::to_vec(&self.surrogate)
            .map_err(|e| RomError::Model(format!("serialising the surrogate: {e}")))?;
        let mut header = self.header.clone();
        header.format = FORMAT.into();
        save_sealed(path, header, &payload, |h, bytes, sha| {
            h.payload_bytes = bytes;
            h.sha256 = sha;
        })
    }

    /// Reads and checks a surrogate file.
    pub fn load(path: &Path) -> Result<Self, RomError> {
        let (reader, file_len) = open_model(path)?;
        Self::read(reader, file_len, &path.display().to_string())
    }

    /// Reads and checks a surrogate held in memory (a file's bytes); `origin` names it in
    /// errors.
    pub fn from_bytes(bytes: &[u8], origin: &str) -> Result<Self, RomError> {
        Self::read(bytes, bytes.len() as u64, origin)
    }

    /// Reads and checks a surrogate of `file_len` bytes from `reader`.
    fn read(
        mut reader: impl std::io::BufRead,
        file_len: u64,
        origin: &str,
    ) -> Result<Self, RomError> {
        let (head, nl) = read_header_line(&mut reader, origin)?;
        Self::read_after(head, nl, reader, file_len, origin)
    }

    /// Checks a file of this kind whose header line `head` (of `nl` bytes) is read; the
    /// payload follows in `reader` (`kind::ModelFile` reads the header once for every kind).
    pub(crate) fn read_after(
        head: serde_json::Value,
        nl: usize,
        reader: impl std::io::BufRead,
        file_len: u64,
        origin: &str,
    ) -> Result<Self, RomError> {
        let bad = |m: String| RomError::Model(format!("{origin}: {m}"));
        let format = head.get("format").and_then(|f| f.as_str()).unwrap_or("");
        if format != FORMAT && format != FORMAT_2 && format != FORMAT_1 {
            return Err(bad(format!(
                "format `{format}` is not `{FORMAT}` (or `{FORMAT_2}`, `{FORMAT_1}`), the \
                 versions this build reads; retrain with `rom train` or use a matching beltwin \
                 version"
            )));
        }
        let header: Header =
            serde_json::from_value(head).map_err(|e| bad(format!("header is malformed: {e}")))?;
        let bytes = read_payload(reader, file_len, nl, header.payload_bytes, origin)?;
        let payload = &bytes[..];
        let expected = if header.format == FORMAT_1 {
            hex(&Sha256::digest(payload))
        } else {
            let mut blank = header.clone();
            blank.sha256 = String::new();
            file_sha256(&blank, payload)
        };
        if expected != header.sha256 {
            return Err(bad(
                "checksum does not match the header (the file was edited or corrupted)".into(),
            ));
        }
        let mut surrogate: Surrogate = serde_json::from_slice(payload)
            .map_err(|e| bad(format!("payload is malformed: {e}")))?;
        surrogate
            .upgrade_from_processes()
            .map_err(|e| bad(format!("payload is malformed: {e}")))?;
        if surrogate.steady.variances.len() != surrogate.steady.means.len() {
            return Err(bad(
                "payload is malformed: the steady processes lack variance predictors".into(),
            ));
        }
        Ok(Self { header, surrogate })
    }

    /// The drive configuration to use the surrogate with: the file `config`, refused unless
    /// the surrogate was trained on it, or the surrogate's own (`rom ... --config`; Python's
    /// `Surrogate.load(config=...)`).
    pub fn drive_config(&self, config: Option<&Path>) -> Result<fom::ValidConfig, RomError> {
        checked_drive_config(&self.header.config_sha256, config, || {
            self.surrogate.config()
        })
    }

    /// Refuses a surrogate trained on another configuration than `config_sha256`.
    pub fn check_config(&self, config_sha256: &str, config_origin: &str) -> Result<(), RomError> {
        check_config_hash(&self.header.config_sha256, config_sha256, config_origin)
    }
}

/// The drive configuration a model of configuration hash `trained` is used on: the file
/// `config`, refused unless it has that hash, or the model's own (`own`).
pub(crate) fn checked_drive_config(
    trained: &str,
    config: Option<&Path>,
    own: impl FnOnce() -> Result<fom::ValidConfig, RomError>,
) -> Result<fom::ValidConfig, RomError> {
    match config {
        Some(p) => {
            let cfg = fom::DriveConfig::from_file(p)?;
            check_config_hash(
                trained,
                &training::config_hash(&cfg),
                &p.display().to_string(),
            )?;
            Ok(cfg)
        }
        None => own(),
    }
}

/// Opens a model file for reading: the buffered file and its length in bytes.
pub(crate) fn open_model(
    path: &Path,
) -> Result<(std::io::BufReader<std::fs::File>, u64), RomError> {
    let bad = |m: String| RomError::Model(format!("{}: {m}", path.display()));
    let file = std::fs::File::open(path).map_err(|e| bad(format!("cannot read: {e}")))?;
    let file_len = file
        .metadata()
        .map_err(|e| bad(format!("cannot read: {e}")))?
        .len();
    Ok((std::io::BufReader::new(file), file_len))
}

/// Refuses a model trained on the configuration of hash `trained` for the one of hash `given`
/// (read from `config_origin`).
pub(crate) fn check_config_hash(
    trained: &str,
    given: &str,
    config_origin: &str,
) -> Result<(), RomError> {
    if trained != given {
        return Err(RomError::Data(format!(
            "the surrogate was trained on another drive configuration than {config_origin} \
             (sha256 {} vs {}); train a surrogate on that configuration, or use the \
             surrogate's own",
            &trained[..12.min(trained.len())],
            &given[..12.min(given.len())]
        )));
    }
    Ok(())
}

/// Seals `header` with the payload's length and the checksum over header and payload (`seal`
/// sets the two fields), then writes the file (`write_header_payload`).
pub(crate) fn save_sealed<H: Serialize>(
    path: &Path,
    mut header: H,
    payload: &[u8],
    seal: impl Fn(&mut H, usize, String),
) -> Result<(), RomError> {
    seal(&mut header, payload.len(), String::new());
    let sha = file_sha256(&header, payload);
    seal(&mut header, payload.len(), sha);
    let head = serde_json::to_vec(&header).expect("header serialises");
    write_header_payload(path, &head, payload)
}

/// Writes a model file atomically: the header line `head`, a newline, the payload; creates the
/// directory if need be.
pub(crate) fn write_header_payload(
    path: &Path,
    head: &[u8],
    payload: &[u8],
) -> Result<(), RomError> {
    if let Some(dir) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| RomError::Model(format!("creating {}: {e}", dir.display())))?;
    }
    fom::output::write_atomic(path, |w| {
        w.write_all(head)?;
        w.write_all(b"\n")?;
        w.write_all(payload)
    })?;
    Ok(())
}

/// Reads a model file's header line, at most `MAX_HEADER_BYTES`, as JSON: a file that is no
/// model file (or one whose size the header contradicts) is refused before its bulk is read.
/// Returns the header and its length without the newline.
pub(crate) fn read_header_line(
    reader: &mut impl std::io::BufRead,
    origin: &str,
) -> Result<(serde_json::Value, usize), RomError> {
    use std::io::{BufRead, Read};
    let bad = |m: String| RomError::Model(format!("{origin}: {m}"));
    let mut head_bytes = Vec::new();
    reader
        .take(MAX_HEADER_BYTES)
        .read_until(b'\n', &mut head_bytes)
        .map_err(|e| bad(format!("cannot read: {e}")))?;
    if head_bytes.last() != Some(&b'\n') {
        return Err(bad(format!(
            "not a beltwin surrogate file (no header line in its first {MAX_HEADER_BYTES} \
             bytes)"
        )));
    }
    let nl = head_bytes.len() - 1;
    let head: serde_json::Value = serde_json::from_slice(&head_bytes[..nl])
        .map_err(|e| bad(format!("not a beltwin surrogate file (header: {e})")))?;
    Ok((head, nl))
}

/// Reads the payload after a header line of `head_len` bytes, refusing a file whose size is
/// not the header's `payload_bytes`.
pub(crate) fn read_payload(
    mut reader: impl std::io::Read,
    file_len: u64,
    head_len: usize,
    payload_bytes: usize,
    origin: &str,
) -> Result<Vec<u8>, RomError> {
    let bad = |m: String| RomError::Model(format!("{origin}: {m}"));
    let payload_len = file_len.saturating_sub(head_len as u64 + 1);
    if payload_len != payload_bytes as u64 {
        return Err(bad(format!(
            "payload is {payload_len} bytes, the header says {payload_bytes} (truncated or \
             edited file)"
        )));
    }
    let mut bytes = Vec::with_capacity(payload_bytes);
    reader
        .read_to_end(&mut bytes)
        .map_err(|e| bad(format!("cannot read: {e}")))?;
    if bytes.len() != payload_bytes {
        return Err(bad(format!(
            "payload is {} bytes, the header says {payload_bytes} (the file changed while read)",
            bytes.len()
        )));
    }
    Ok(bytes)
}

/// SHA-256 of a header (its `sha256` field empty) serialised as its file line, a newline and
/// the payload.
pub(crate) fn file_sha256<H: Serialize>(header_blank: &H, payload: &[u8]) -> String {
    let head = serde_json::to_vec(header_blank).expect("header serialises");
    let mut h = Sha256::new();
    h.update(&head);
    h.update(b"\n");
    h.update(payload);
    hex(&h.finalize())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2 GB file (sparse: made in an instant) is refused after its first 64 KiB, not read
    /// whole; so is one whose header claims another size than the file has.
    #[test]
    fn a_huge_file_is_refused_without_reading_it_whole() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.json");
        let f = std::fs::File::create(&path).unwrap();
        f.set_len(2_000_000_000).unwrap();
        let e = SurrogateFile::load(&path).unwrap_err().to_string();
        assert!(e.contains("no header line in its first 65536 bytes"), "{e}");
        // The shipped model's header line, followed by 2 GB of zeros.
        let text = std::str::from_utf8(crate::shipped::SLIP.bytes).unwrap();
        let header = &text[..=text.find('\n').unwrap()];
        std::fs::write(&path, header).unwrap();
        let f = std::fs::OpenOptions::new().write(true).open(&path).unwrap();
        f.set_len(header.len() as u64 + 2_000_000_000).unwrap();
        let e = SurrogateFile::load(&path).unwrap_err().to_string();
        assert!(
            e.contains("payload is 2000000000 bytes, the header says"),
            "{e}"
        );
    }

    #[test]
    fn iso_time_of_known_instants() {
        assert_eq!(iso_utc(0), "1970-01-01T00:00:00Z");
        assert_eq!(iso_utc(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(iso_utc(1_795_384_800), "2026-11-22T22:00:00Z");
    }
}
