//! Assessing a session: its output folder (of `dentsim session` or `dentsim replay`) names the
//! tissues it started from, and its log replays to any tick, so a preparation can be graded as it
//! stood at that tick without writing the tissues out first.
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::error::{Error, Result};
use crate::session::guidance::GuidanceReport;
use crate::session::log::SessionLog;
use crate::session::outputs::{ReplaySummary, SessionSummary};
use crate::session::replay::replay_until;
use crate::tissues::export::{LOG_NAME, REPLAY_SUMMARY_NAME, SUMMARY_NAME, TISSUES_NAME};
use crate::tissues::model::TissueModel;
use crate::tissues::table::TissueTable;

/// A session's or replay's output folder, read.
#[derive(Clone, Debug)]
pub struct SessionFolder {
    pub dir: PathBuf,
    /// The tissues the session started from, as its summary names them.
    pub original: PathBuf,
    /// The session's log (the folder's own, or the one a replay names).
    pub log: PathBuf,
    /// Its guidance events (from `summary.json` or `replay.json`).
    pub guidance: GuidanceReport,
}

/// What an assessment of a session adds to `assessment.json`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SessionPoint {
    pub folder: String,
    /// The tick the tissues were replayed to; `None` for the session's end.
    pub tick: Option<u64>,
    pub t_s: Option<f64>,
    /// Live guidance over the same ticks: what the student was warned of.
    pub guidance: GuidanceReport,
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let text = std::fs::read(path).map_err(|e| Error::File { path: path.to_owned(), message: e.to_string() })?;
    serde_json::from_slice(&text).map_err(|e| Error::File { path: path.to_owned(), message: format!("not what a session writes: {e}") })
}

/// A path a summary recorded: as written when it exists from here, else beside the folder
/// (a relative path given to the session from another working directory).
fn recorded(dir: &Path, path: &str) -> PathBuf {
    let p = PathBuf::from(path);
    if p.is_absolute() || p.exists() {
        return p;
    }
    dir.parent().map(|d| d.join(&p)).filter(|q| q.exists()).unwrap_or(p)
}

impl SessionFolder {
    /// `None` when `dir` is not a folder holding `summary.json` (a session's) or `replay.json`.
    pub fn open(dir: &Path) -> Result<Option<Self>> {
        if !dir.is_dir() {
            return Ok(None);
        }
        let (session, replay) = (dir.join(SUMMARY_NAME), dir.join(REPLAY_SUMMARY_NAME));
        if session.is_file() {
            let s: SessionSummary = read_json(&session)?;
            return Ok(Some(SessionFolder {
                dir: dir.to_owned(),
                original: recorded(dir, &s.tissues_file),
                log: dir.join(if s.log.is_empty() { LOG_NAME } else { &s.log }),
                guidance: s.guidance,
            }));
        }
        if replay.is_file() {
            let r: ReplaySummary = read_json(&replay)?;
            if r.tissues_file.is_empty() {
                return Err(Error::File { path: replay, message: "names no starting tissues (written before replays kept them): pass --original".into() });
            }
            return Ok(Some(SessionFolder { dir: dir.to_owned(), original: recorded(dir, &r.tissues_file), log: recorded(dir, &r.log), guidance: r.guidance }));
        }
        Ok(None)
    }

    /// The prepared tissues: the folder's `tissues.vdb`, or, at `tick`, the starting tissues
    /// replayed through that tick (with the guidance events up to it).
    pub fn prepared(&self, original: &Path, tick: Option<u64>, table: &TissueTable) -> Result<(TissueModel, SessionPoint)> {
        let folder = self.dir.display().to_string();
        let Some(tick) = tick else {
            let model = TissueModel::load(&self.dir.join(TISSUES_NAME), table)?;
            return Ok((model, SessionPoint { folder, tick: None, t_s: None, guidance: self.guidance.clone() }));
        };
        let log = SessionLog::read(&self.log)?;
        let start = TissueModel::load(original, table)?;
        let again = replay_until(&log, start, Some(tick), &mut |_| {}).map_err(|e| match e {
            Error::Invalid { .. } => Error::File { path: self.log.clone(), message: e.to_string() },
            other => other,
        })?;
        let t_s = log.records.iter().rev().find(|r| r.tick <= tick).map(|r| r.t_s);
        Ok((again.model, SessionPoint { folder, tick: Some(tick), t_s, guidance: again.guidance }))
    }
}
