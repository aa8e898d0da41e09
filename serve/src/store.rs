//! SQLite storage (one file, WAL mode): segments, their diagnoses, alarms, gap reports, the
//! drives' state and the counters. Each segment (and each gap check) is written with its
//! drive's new state in one transaction, so a restart (even after `kill -9`) resumes from a consistent database with
//! nothing recorded lost or doubled (docs/guide/serve.md, "Storage").

use std::collections::VecDeque;
use std::path::Path;

use rusqlite::{params, Connection, OpenFlags, OptionalExtension};

use crate::alarm::Alarm;
use crate::engine::{Counters, DriveStatus, Segment, TrendPoint};
use crate::gap_check::GapRecord;
use crate::Event;

/// The database's schema version (`PRAGMA user_version`).
pub const SCHEMA_VERSION: i64 = 2;
/// Records between two retention sweeps.
const SWEEP_EVERY: u64 = 500;
/// Most segments one history request returns.
pub const MAX_HISTORY: usize = 10_000;
/// Most gap checks one history request returns (a report is tens of KB).
pub const MAX_GAP_HISTORY: usize = 1_000;

const SCHEMA: &str = "
CREATE TABLE IF NOT EXISTS drives (
    id TEXT PRIMARY KEY, status TEXT NOT NULL, alarm TEXT NOT NULL, trend TEXT NOT NULL,
    recorded_until_s REAL);
CREATE TABLE IF NOT EXISTS segments (
    drive TEXT NOT NULL, idx INTEGER NOT NULL, start_s REAL NOT NULL, end_s REAL NOT NULL,
    samples INTEGER NOT NULL, reason TEXT NOT NULL, evidence TEXT, state TEXT NOT NULL,
    wall_unix_s REAL NOT NULL, PRIMARY KEY (drive, idx));
CREATE TABLE IF NOT EXISTS diagnoses (
    drive TEXT NOT NULL, idx INTEGER NOT NULL, json TEXT NOT NULL, PRIMARY KEY (drive, idx));
CREATE TABLE IF NOT EXISTS alarms (
    id INTEGER PRIMARY KEY AUTOINCREMENT, drive TEXT NOT NULL, from_state TEXT NOT NULL,
    to_state TEXT NOT NULL, at_s REAL NOT NULL, wall_unix_s REAL NOT NULL);
CREATE TABLE IF NOT EXISTS gap_reports (
    id INTEGER PRIMARY KEY AUTOINCREMENT, drive TEXT NOT NULL, at_s REAL NOT NULL,
    first_segment INTEGER NOT NULL, last_segment INTEGER NOT NULL, verdict TEXT,
    named TEXT NOT NULL, error TEXT, json TEXT NOT NULL, wall_unix_s REAL NOT NULL);
CREATE INDEX IF NOT EXISTS gap_reports_at ON gap_reports (drive, at_s);
CREATE TABLE IF NOT EXISTS counters (id INTEGER PRIMARY KEY CHECK (id = 1), json TEXT NOT NULL);
CREATE INDEX IF NOT EXISTS segments_end ON segments (drive, end_s);
";

#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    #[error("database {path}: {source}")]
    Sql {
        path: String,
        #[source]
        source: rusqlite::Error,
    },
    #[error("database: {0}")]
    Json(String),
}

impl StoreError {
    pub fn json(e: serde_json::Error) -> Self {
        StoreError::Json(e.to_string())
    }
}

/// A drive as stored: its status, alarm, trend and where its recorded readings end.
#[derive(Debug, Clone)]
pub struct StoredDrive {
    pub id: String,
    pub status: DriveStatus,
    pub alarm: Alarm,
    pub trend: VecDeque<TrendPoint>,
    pub recorded_until_s: Option<f64>,
}

/// The database of one `rom serve`.
pub struct Store {
    conn: Connection,
    path: String,
    retention_s: Option<f64>,
    since_sweep: u64,
}

pub(crate) fn now_unix_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

fn state_name(s: impl serde::Serialize) -> String {
    serde_json::to_value(s)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_default()
}

impl Store {
    /// Opens (or creates) the database at `path`, in WAL mode; `retention_days` bounds how
    /// long segments, diagnoses and alarms are kept.
    pub fn open(path: &Path, retention_days: Option<f64>) -> Result<Self, StoreError> {
        let p = path.display().to_string();
        let sql = |source| StoreError::Sql {
            path: p.clone(),
            source,
        };
        let conn = Connection::open(path).map_err(sql)?;
        // WAL with synchronous=NORMAL: a committed transaction survives the process being
        // killed (not a power cut); readers (the HTTP thread) never block the writer.
        conn.pragma_update(None, "journal_mode", "WAL")
            .map_err(sql)?;
        conn.pragma_update(None, "synchronous", "NORMAL")
            .map_err(sql)?;
        conn.busy_timeout(std::time::Duration::from_secs(5))
            .map_err(sql)?;
        let version: i64 = conn
            .pragma_query_value(None, "user_version", |r| r.get(0))
            .map_err(sql)?;
        if version > SCHEMA_VERSION {
            return Err(StoreError::Json(format!(
                "{p} has schema version {version}; this version reads {SCHEMA_VERSION}"
            )));
        }
        if version == 1 {
            // Version 1 had a placeholder `gap_reports` table, never written: made anew.
            conn.execute_batch("DROP TABLE IF EXISTS gap_reports;")
                .map_err(sql)?;
        }
        conn.execute_batch(SCHEMA).map_err(sql)?;
        conn.pragma_update(None, "user_version", SCHEMA_VERSION)
            .map_err(sql)?;
        let mut s = Store {
            conn,
            path: p,
            retention_s: retention_days.map(|d| d * 86_400.0),
            since_sweep: 0,
        };
        s.sweep()?;
        Ok(s)
    }

    /// A read-only connection to the database at `path` (the HTTP API's).
    pub fn open_reader(path: &Path) -> Result<Self, StoreError> {
        let p = path.display().to_string();
        let conn = Connection::open_with_flags(
            path,
            OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
        )
        .map_err(|source| StoreError::Sql {
            path: p.clone(),
            source,
        })?;
        let _ = conn.busy_timeout(std::time::Duration::from_secs(5));
        Ok(Store {
            conn,
            path: p,
            retention_s: None,
            since_sweep: 0,
        })
    }

    fn sql(&self, source: rusqlite::Error) -> StoreError {
        StoreError::Sql {
            path: self.path.clone(),
            source,
        }
    }

    /// Deletes what is older than the retention.
    fn sweep(&mut self) -> Result<(), StoreError> {
        self.since_sweep = 0;
        let Some(r) = self.retention_s else {
            return Ok(());
        };
        let before = now_unix_s() - r;
        self.conn
            .execute_batch(&format!(
                "BEGIN;
                 DELETE FROM diagnoses WHERE (drive, idx) IN
                   (SELECT drive, idx FROM segments WHERE wall_unix_s < {before});
                 DELETE FROM segments WHERE wall_unix_s < {before};
                 DELETE FROM alarms WHERE wall_unix_s < {before};
                 DELETE FROM gap_reports WHERE wall_unix_s < {before};
                 COMMIT;"
            ))
            .map_err(|e| self.sql(e))
    }

    /// Every stored drive and the fleet's counters.
    pub fn load(&self) -> Result<(Vec<StoredDrive>, Counters), StoreError> {
        let mut q = self
            .conn
            .prepare("SELECT id, status, alarm, trend, recorded_until_s FROM drives ORDER BY id")
            .map_err(|e| self.sql(e))?;
        let rows = q
            .query_map([], |r| {
                Ok((
                    r.get::<_, String>(0)?,
                    r.get::<_, String>(1)?,
                    r.get::<_, String>(2)?,
                    r.get::<_, String>(3)?,
                    r.get::<_, Option<f64>>(4)?,
                ))
            })
            .map_err(|e| self.sql(e))?;
        let mut drives = Vec::new();
        for row in rows {
            let (id, status, alarm, trend, recorded_until_s) = row.map_err(|e| self.sql(e))?;
            drives.push(StoredDrive {
                id,
                status: serde_json::from_str(&status).map_err(StoreError::json)?,
                alarm: serde_json::from_str(&alarm).map_err(StoreError::json)?,
                trend: serde_json::from_str(&trend).map_err(StoreError::json)?,
                recorded_until_s,
            });
        }
        Ok((drives, self.counters()?))
    }

    /// The fleet's stored counters (zero when none yet).
    pub fn counters(&self) -> Result<Counters, StoreError> {
        let json: Option<String> = self
            .conn
            .query_row("SELECT json FROM counters WHERE id = 1", [], |r| r.get(0))
            .optional()
            .map_err(|e| self.sql(e))?;
        match json {
            Some(j) => serde_json::from_str(&j).map_err(StoreError::json),
            None => Ok(Counters::default()),
        }
    }

    pub fn save_counters(&mut self, c: &Counters) -> Result<(), StoreError> {
        let json = serde_json::to_string(c).map_err(StoreError::json)?;
        self.conn
            .execute(
                "INSERT OR REPLACE INTO counters (id, json) VALUES (1, ?1)",
                params![json],
            )
            .map(drop)
            .map_err(|e| self.sql(e))
    }

    /// Writes one segment, its diagnosis, an alarm if the state changed, the drive's new
    /// state and the counters, all in one transaction.
    pub fn record_segment(
        &mut self,
        drive: &StoredDrive,
        seg: &Segment,
        json: &serde_json::Value,
        event: Option<&Event>,
        counters: &Counters,
    ) -> Result<(), StoreError> {
        let diag = to_json(json)?;
        self.transact(drive, event, counters, |tx, now| {
            tx.execute(
                "INSERT INTO segments (drive, idx, start_s, end_s, samples, reason, evidence,
                 state, wall_unix_s) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
                params![
                    seg.drive,
                    seg.index as i64,
                    seg.start_s,
                    seg.end_s,
                    seg.samples as i64,
                    state_name(seg.reason),
                    seg.evidence.map(state_name),
                    state_name(seg.state),
                    now
                ],
            )?;
            tx.execute(
                "INSERT INTO diagnoses (drive, idx, json) VALUES (?1, ?2, ?3)",
                params![seg.drive, seg.index as i64, diag],
            )
            .map(drop)
        })
    }

    /// Writes one gap check (`json`: its [`GapRecord`]), an alarm if the state changed, the
    /// drive's new state and the counters, all in one transaction.
    pub fn record_gap(
        &mut self,
        drive: &StoredDrive,
        rec: &GapRecord,
        json: &serde_json::Value,
        event: Option<&Event>,
        counters: &Counters,
    ) -> Result<(), StoreError> {
        let (named, body) = (to_json(&rec.named)?, to_json(json)?);
        self.transact(drive, event, counters, |tx, now| {
            tx.execute(
                "INSERT INTO gap_reports (drive, at_s, first_segment, last_segment, verdict,
                 named, error, json, wall_unix_s) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9)",
                params![
                    rec.drive,
                    rec.at_s,
                    rec.first_segment as i64,
                    rec.last_segment as i64,
                    rec.verdict,
                    named,
                    rec.error,
                    body,
                    now
                ],
            )
            .map(drop)
        })
    }

    /// One transaction: `write` (given the wall time), then an alarm if `event` is a state
    /// change, the drive's row and the counters; a retention sweep now and then.
    fn transact(
        &mut self,
        drive: &StoredDrive,
        event: Option<&Event>,
        counters: &Counters,
        write: impl FnOnce(&rusqlite::Transaction, f64) -> rusqlite::Result<()>,
    ) -> Result<(), StoreError> {
        let now = now_unix_s();
        let path = self.path.clone();
        let sql = |source| StoreError::Sql {
            path: path.clone(),
            source,
        };
        let tx = self.conn.transaction().map_err(sql)?;
        write(&tx, now).map_err(sql)?;
        put_drive(&tx, now, drive, event, counters).map_err(sql)?;
        tx.commit().map_err(sql)?;
        self.since_sweep += 1;
        if self.since_sweep >= SWEEP_EVERY {
            self.sweep()?;
        }
        Ok(())
    }

    /// A drive's gap checks whose `at_s` lies in `[from_s, to_s]`, oldest first, at most
    /// `MAX_GAP_HISTORY` (each the [`GapRecord`]'s JSON).
    pub fn gap_reports(
        &self,
        drive: &str,
        from_s: f64,
        to_s: f64,
    ) -> Result<Vec<serde_json::Value>, StoreError> {
        let mut q = self
            .conn
            .prepare(
                "SELECT json FROM gap_reports WHERE drive = ?1 AND at_s >= ?2 AND at_s <= ?3
                 ORDER BY id LIMIT ?4",
            )
            .map_err(|e| self.sql(e))?;
        let rows = q
            .query_map(params![drive, from_s, to_s, MAX_GAP_HISTORY as i64], |r| {
                r.get::<_, String>(0)
            })
            .map_err(|e| self.sql(e))?;
        rows.map(|r| {
            r.map_err(|e| self.sql(e))
                .and_then(|j| serde_json::from_str(&j).map_err(StoreError::json))
        })
        .collect()
    }

    /// A drive's segments (with their diagnoses) whose end lies in `[from_s, to_s]`, oldest
    /// first, at most `MAX_HISTORY`; and its alarms in that range.
    pub fn history(
        &self,
        drive: &str,
        from_s: f64,
        to_s: f64,
    ) -> Result<(Vec<serde_json::Value>, Vec<serde_json::Value>), StoreError> {
        let mut q = self
            .conn
            .prepare(
                "SELECT d.json FROM segments s JOIN diagnoses d ON s.drive = d.drive AND s.idx = d.idx
                 WHERE s.drive = ?1 AND s.end_s >= ?2 AND s.end_s <= ?3 ORDER BY s.idx LIMIT ?4",
            )
            .map_err(|e| self.sql(e))?;
        let segs = q
            .query_map(params![drive, from_s, to_s, MAX_HISTORY as i64], |r| {
                r.get::<_, String>(0)
            })
            .map_err(|e| self.sql(e))?
            .map(|r| {
                r.map_err(|e| self.sql(e))
                    .and_then(|j| serde_json::from_str(&j).map_err(StoreError::json))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut q = self
            .conn
            .prepare(
                "SELECT from_state, to_state, at_s FROM alarms
                 WHERE drive = ?1 AND at_s >= ?2 AND at_s <= ?3 ORDER BY id",
            )
            .map_err(|e| self.sql(e))?;
        let alarms = q
            .query_map(params![drive, from_s, to_s], |r| {
                Ok(serde_json::json!({
                    "from": r.get::<_, String>(0)?,
                    "to": r.get::<_, String>(1)?,
                    "at_s": r.get::<_, f64>(2)?,
                }))
            })
            .map_err(|e| self.sql(e))?
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| self.sql(e))?;
        Ok((segs, alarms))
    }

    /// Every stored segment's (drive, index, start, end), for checks.
    pub fn segment_keys(&self) -> Result<Vec<(String, i64, f64, f64)>, StoreError> {
        let mut q = self
            .conn
            .prepare("SELECT drive, idx, start_s, end_s FROM segments ORDER BY drive, idx")
            .map_err(|e| self.sql(e))?;
        let rows = q
            .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?, r.get(3)?)))
            .map_err(|e| self.sql(e))?
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| self.sql(e));
        rows
    }

    /// SQLite's own integrity check: "ok" when the file is sound.
    pub fn integrity_check(&self) -> Result<String, StoreError> {
        self.conn
            .query_row("PRAGMA integrity_check", [], |r| r.get(0))
            .map_err(|e| self.sql(e))
    }
}

fn to_json<T: serde::Serialize>(v: &T) -> Result<String, StoreError> {
    serde_json::to_string(v).map_err(StoreError::json)
}

/// Inside a transaction: an alarm if `event` is a state change, the drive's row and the
/// counters.
fn put_drive(
    tx: &rusqlite::Transaction,
    now: f64,
    drive: &StoredDrive,
    event: Option<&Event>,
    counters: &Counters,
) -> rusqlite::Result<()> {
    let json = |v: Result<String, serde_json::Error>| {
        v.map_err(|e| rusqlite::Error::ToSqlConversionFailure(Box::new(e)))
    };
    let status = json(serde_json::to_string(&drive.status))?;
    let alarm = json(serde_json::to_string(&drive.alarm))?;
    let trend = json(serde_json::to_string(&drive.trend))?;
    let cnt = json(serde_json::to_string(counters))?;
    if let Some(Event::StateChanged {
        drive,
        from,
        to,
        at_s,
    }) = event
    {
        tx.execute(
            "INSERT INTO alarms (drive, from_state, to_state, at_s, wall_unix_s)
             VALUES (?1, ?2, ?3, ?4, ?5)",
            params![drive, state_name(from), state_name(to), at_s, now],
        )?;
    }
    tx.execute(
        "INSERT OR REPLACE INTO drives (id, status, alarm, trend, recorded_until_s)
         VALUES (?1, ?2, ?3, ?4, ?5)",
        params![drive.id, status, alarm, trend, drive.recorded_until_s],
    )?;
    tx.execute(
        "INSERT OR REPLACE INTO counters (id, json) VALUES (1, ?1)",
        params![cnt],
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::drive::CloseReason;
    use crate::State;
    use twin::diagnose::LabelVerdict;

    fn segment(index: u64, end_s: f64) -> Segment {
        Segment {
            drive: "a".into(),
            index,
            start_s: end_s - 5.0,
            end_s,
            samples: 2500,
            reason: CloseReason::Stopped,
            evidence: Some(State::Loose),
            state: State::Loose,
            verdict: LabelVerdict {
                label: "a".into(),
                runs: 1,
                known_center_distance_m: None,
                measured: None,
                estimate: None,
                cannot_diagnose: None,
                misfit: Vec::new(),
            },
        }
    }

    fn record(s: &mut Store, index: u64, end_s: f64) {
        let seg = segment(index, end_s);
        let json = serde_json::to_value(&seg).unwrap();
        let drive = StoredDrive {
            id: "a".into(),
            status: DriveStatus {
                label: "a".into(),
                segments: index,
                ..DriveStatus::default()
            },
            alarm: Alarm::default(),
            trend: VecDeque::new(),
            recorded_until_s: Some(end_s),
        };
        let ev = Event::StateChanged {
            drive: "a".into(),
            from: State::Healthy,
            to: State::Loose,
            at_s: end_s,
        };
        let counters = Counters {
            segments: index,
            ..Counters::default()
        };
        s.record_segment(&drive, &seg, &json, (index == 2).then_some(&ev), &counters)
            .unwrap();
    }

    /// A failed gap check of drive `a` up to `at_s`.
    fn record_gap(s: &mut Store, at_s: f64) {
        let rec = GapRecord {
            drive: "a".into(),
            wall_unix_s: now_unix_s(),
            first_segment: 2,
            last_segment: 3,
            at_s,
            trigger: crate::gap_check::Trigger::Segments,
            verdict: None,
            named: Vec::new(),
            evidence: None,
            error: Some("refused".into()),
            elapsed_s: 0.1,
            labels: Vec::new(),
            report: None,
        };
        let json = serde_json::to_value(&rec).unwrap();
        let (drives, counters) = s.load().unwrap();
        let d = drives.into_iter().next().unwrap();
        s.record_gap(&d, &rec, &json, None, &counters).unwrap();
    }

    #[test]
    fn segments_and_gap_checks_come_back_by_range_the_drive_resumes_and_retention_deletes_old_rows()
    {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.db");
        let mut s = Store::open(&path, None).unwrap();
        for i in 1..=3 {
            record(&mut s, i, 10.0 * i as f64);
        }
        record_gap(&mut s, 30.0);
        assert_eq!(s.gap_reports("a", 25.0, 35.0).unwrap().len(), 1);
        assert!(s.gap_reports("a", 0.0, 25.0).unwrap().is_empty());
        let (segs, alarms) = s.history("a", 15.0, 30.0).unwrap();
        assert_eq!(
            segs.iter().map(|v| v["index"].clone()).collect::<Vec<_>>(),
            [2, 3]
        );
        assert_eq!(alarms.len(), 1);
        assert_eq!(alarms[0]["to"], "loose");
        drop(s);
        let s = Store::open(&path, None).unwrap();
        let (drives, counters) = s.load().unwrap();
        assert_eq!((drives.len(), drives[0].recorded_until_s), (1, Some(30.0)));
        assert_eq!((drives[0].status.segments, counters.segments), (3, 3));
        assert_eq!(s.integrity_check().unwrap(), "ok");
        drop(s);
        std::thread::sleep(std::time::Duration::from_millis(20));
        // A retention of about 9 ms: everything recorded is older.
        let s = Store::open(&path, Some(1e-7)).unwrap();
        assert!(s.segment_keys().unwrap().is_empty());
        assert!(s.history("a", f64::MIN, f64::MAX).unwrap().1.is_empty());
        assert!(s.gap_reports("a", f64::MIN, f64::MAX).unwrap().is_empty());
        // The drive's state stays (only history ages out).
        assert_eq!(s.load().unwrap().0.len(), 1);
    }
}
