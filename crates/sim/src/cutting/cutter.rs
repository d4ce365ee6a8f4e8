//! Cutting a tissue model with a burr swept from one pose to the next.
//!
//! Per tick: the swept head becomes a dense patch of signed distances ([`Sweep`]), and every
//! tissue takes `max(value, -(tool + offset))` over it in place (`LevelSet::subtract_logged`),
//! with offset 0 for geometric cuts and a partial depth when a removal rate limits the tick
//! ([`crate::cutting::removal`]). The changed voxels' old values feed the undo journal
//! ([`History`]); by [`Handoff`], either the dirty-chunk set a mesher drains ([`DirtyLeaves`]) or
//! each tissue's changed voxels with their new values, which a session hands to its mesher's copy
//! of the grids. Once its buffers have grown to the largest stroke, [`Cutter::cut_with`] allocates
//! nothing.
//!
//! A stroke ends in a head every grid has lost (a round burr's: a ball). While no one else edits
//! the grids (their stamps are the ones this cutter left), the next stroke skips the voxels that
//! head already took: a haptic tick's stroke overlaps the previous one almost wholly.
use dentsim_vdb::{Measure, VoxelChange};
use glam::{DAffine3, DVec3, IVec3};
use serde::Serialize;

use crate::burr::Burr;
use crate::cutting::dirty::DirtyLeaves;
use crate::cutting::history::History;
use crate::cutting::removal::{pick_offset, Feed, RemovalBank, MAX_BANKED_S, OFFSET_SAMPLES};
use crate::cutting::sweep::{CutBall, CutHead, Done, Sweep};
use crate::error::Result;
use crate::tissues::model::TissueModel;

/// Volume each tissue lost to one stroke.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct StrokeReport {
    pub removed_mm3: Vec<(String, f64)>,
    pub changed_voxels: u64,
    /// Poses the sweep was evaluated at, minus one.
    pub substeps: usize,
    /// True when a removal rate held some tissue back this tick.
    pub rate_limited: bool,
    /// False when the cutter skipped measuring (`removed_mm3` then reads 0; see [`Cutter::set_measure`]).
    pub measured: bool,
}

impl StrokeReport {
    pub fn removed(&self, tissue: &str) -> f64 {
        self.removed_mm3.iter().find(|(n, _)| n == tissue).map_or(0.0, |(_, v)| *v)
    }

    pub fn total_mm3(&self) -> f64 {
        self.removed_mm3.iter().map(|(_, v)| v).sum()
    }

    /// Zeroes the figures, keeping the tissue names (and their allocations) when they match.
    fn reset_for(&mut self, model: &TissueModel) {
        let same = self.removed_mm3.len() == model.tissues.len()
            && self.removed_mm3.iter().zip(&model.tissues).all(|((n, _), t)| *n == t.props.name);
        if same {
            self.removed_mm3.iter_mut().for_each(|(_, v)| *v = 0.0);
        } else {
            self.removed_mm3 = model.tissues.iter().map(|t| (t.props.name.clone(), 0.0)).collect();
        }
        self.changed_voxels = 0;
        self.substeps = 0;
        self.rate_limited = false;
        self.measured = true;
    }
}

/// What a cutter keeps of each cut besides the undo journal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Handoff {
    /// The mesh chunks the cuts dirtied, until [`Cutter::take_dirty`] (planning, undo).
    #[default]
    DirtyChunks,
    /// The last cut's changed voxels with their new values per tissue ([`Cutter::last_changes`]),
    /// for a thread that keeps a copy of the grids and tracks its own chunks (a session's mesher):
    /// it writes them instead of cutting again.
    NewValues,
}

/// Reuses its buffers from stroke to stroke; owns the undo journal and the dirty set.
#[derive(Default)]
pub struct Cutter {
    sweep: Sweep,
    log: Vec<VoxelChange>,
    report: StrokeReport,
    bank: RemovalBank,
    pub history: History,
    pub dirty: DirtyLeaves,
    /// The head (a ball, or any head at its pose) the last stroke ended in and the grids' stamps
    /// it left (see the module notes).
    done: Option<Done>,
    /// The done head the last stroke skipped (its cut depends on it, to [`crate::cutting::sweep`]'s slack).
    skipped: Option<Done>,
    done_stamps: Vec<u64>,
    measure: Measure,
    handoff: Handoff,
    /// [`Handoff::NewValues`]: each tissue's voxels the last cut changed, with their new values.
    changes: Vec<Vec<VoxelChange>>,
}

impl Cutter {
    /// A cutter whose undo journal holds at most `history_bytes`.
    pub fn with_history_bytes(history_bytes: usize) -> Self {
        Cutter { history: History::with_bytes(history_bytes), ..Default::default() }
    }

    /// Whether geometric cuts measure the volume they remove. Skipping it halves a haptic tick's
    /// cut; a session measures on the mesher's mirror instead. Rate-limited cuts always measure
    /// (the removal bank needs it).
    pub fn set_measure(&mut self, measure: Measure) {
        self.measure = measure;
    }

    /// What each cut leaves for others (see [`Handoff`]).
    pub fn set_handoff(&mut self, handoff: Handoff) {
        self.handoff = handoff;
    }

    /// [`Handoff::NewValues`]: the voxels the last cut changed in `tissue`, with their new values
    /// (empty for a tissue it left alone).
    pub fn last_changes(&self, tissue: usize) -> &[VoxelChange] {
        self.changes.get(tissue).map_or(&[], |c| c.as_slice())
    }

    /// Grows every buffer (the cutter's and the grids') for strokes of `burr` whose head moves at
    /// most `travel_mm`, so that such strokes allocate nothing: for the haptic thread, whose
    /// strokes are bounded by the proxy's step.
    pub fn prepare(&mut self, model: &mut TissueModel, burr: &Burr, travel_mm: f64) {
        let Some(h) = model.voxel_size() else { return };
        let band = model.tissues.iter().map(|t| f64::from(t.grid.background())).fold(0.0, f64::max);
        let dims = self.sweep.reserve(burr, h, band, travel_mm);
        let voxels = dims.iter().map(|d| *d as usize).product::<usize>();
        self.log.reserve(voxels.saturating_sub(self.log.len()));
        for t in &mut model.tissues {
            t.grid.reserve_cut(dims);
        }
        if self.handoff == Handoff::NewValues {
            self.changes.resize_with(model.tissues.len(), Vec::new);
            for c in &mut self.changes {
                c.reserve(voxels.saturating_sub(c.len()));
            }
        }
        // And the journal's pages mapped, so that recording the strokes takes no page faults.
        self.history.prefault();
        self.report.reset_for(model);
    }

    /// Bytes [`Self::prepare`] would reserve for cuts of `travel_mm` in `model` (for memory caps,
    /// checked before it allocates): per voxel of the cut's box, the patch value, the change log
    /// and, per tissue, the grid's cut buffer and a change queue.
    pub fn buffer_bytes_estimate(model: &TissueModel, burr: &Burr, travel_mm: f64) -> u64 {
        let Some(h) = model.voxel_size() else { return 0 };
        let band = model.tissues.iter().map(|t| f64::from(t.grid.background())).fold(0.0, f64::max);
        let side = crate::cutting::sweep::Sweep::box_side(burr, h, band, travel_mm);
        let change = std::mem::size_of::<dentsim_vdb::VoxelChange>() as u64;
        let per_voxel = 4 + change + model.tissues.len() as u64 * (4 + change);
        side.saturating_mul(side).saturating_mul(side).saturating_mul(per_voxel)
    }

    /// Removes the burr's swept volume from `from` to `to` out of every tissue (geometric cut).
    pub fn cut(&mut self, model: &mut TissueModel, burr: &Burr, from: DAffine3, to: DAffine3) -> Result<StrokeReport> {
        self.cut_with(model, burr, from, to, Feed::Geometric)?;
        Ok(self.report.clone())
    }

    /// The haptic tick: like [`cut`](Self::cut) under a [`Feed`], returning a borrowed report.
    pub fn cut_with(&mut self, model: &mut TissueModel, burr: &Burr, from: DAffine3, to: DAffine3, feed: Feed) -> Result<&StrokeReport> {
        let done = self.done.take().filter(|_| self.grids_as_left(model));
        self.cut_skipping(model, burr, from, to, feed, done)
    }

    /// Cuts again, on a copy of the grids, a stroke another cutter made: `skipped` is what that
    /// cutter's [`last_skipped`](Self::last_skipped) said, so the copy changes bit for bit as the
    /// original did.
    pub fn recut(&mut self, model: &mut TissueModel, burr: &Burr, from: DAffine3, to: DAffine3, skipped: Option<Done>) -> Result<&StrokeReport> {
        self.cut_skipping(model, burr, from, to, Feed::Geometric, skipped)
    }

    /// The done head the last cut skipped (see [`recut`](Self::recut)).
    pub fn last_skipped(&self) -> Option<Done> {
        self.skipped
    }

    fn cut_skipping(&mut self, model: &mut TissueModel, burr: &Burr, from: DAffine3, to: DAffine3, feed: Feed, done: Option<Done>) -> Result<&StrokeReport> {
        feed.validate()?;
        self.report.reset_for(model);
        if self.handoff == Handoff::NewValues && self.changes.len() != model.tissues.len() {
            self.changes.resize_with(model.tissues.len(), Vec::new);
        }
        self.changes.iter_mut().for_each(Vec::clear);
        let Some(h) = model.voxel_size() else { return Ok(&self.report) };
        let band = model.tissues.iter().map(|t| f64::from(t.grid.background())).fold(0.0, f64::max);
        self.skipped = done;
        // Only blocks where some grid has material can change (an outside tile cannot).
        let grids = &model.tissues;
        // A geometric feed measures nothing unless told to; a limited one reads past the band.
        let unmeasured = self.measure == Measure::Skip && feed == Feed::Geometric;
        self.sweep.set_unmeasured(unmeasured);
        // The haptic tick's: a near-vertical head's band in columns along its axis (tests pin
        // the grids it leaves to the rows').
        self.sweep.set_columns(unmeasured);
        // Which subtracts along the runs alone (cut_column_runs_exact pins them to the patch's).
        self.sweep.set_runs_only(unmeasured);
        self.sweep.build_in(burr, from, to, h, band, done, |lo, dims, blocks| {
            grids.iter().try_for_each(|t| t.grid.mark_material_blocks(lo, dims, blocks).map_err(Into::into))
        })?;
        self.report.substeps = self.sweep.substeps;
        let auto_stroke = !self.history.is_open();
        self.history.begin_stroke();
        let result = self.apply(model, h, feed);
        if auto_stroke {
            self.history.end_stroke();
        }
        let deepest_offset = result?;
        self.done = match burr.ball_radius() {
            Some(r) => {
                let radius = r - f64::from(deepest_offset);
                (radius > 0.0).then(|| Done::Ball(CutBall { centre: to.transform_point3(DVec3::new(0.0, 0.0, burr.bound().0)), radius }))
            }
            None => Some(Done::Head(CutHead { to_tool: to.inverse(), offset: f64::from(deepest_offset) })),
        };
        if self.done.is_some() {
            self.done_stamps.clear();
            self.done_stamps.extend(model.tissues.iter().map(|t| t.grid.stamp()));
        }
        Ok(&self.report)
    }

    /// True when every grid is as this cutter's last stroke left it.
    fn grids_as_left(&self, model: &TissueModel) -> bool {
        self.done_stamps.len() == model.tissues.len() && model.tissues.iter().zip(&self.done_stamps).all(|(t, s)| t.grid.stamp() == *s)
    }

    /// Cuts every tissue; returns the largest tool offset a removal rate imposed (0 = whole tool).
    fn apply(&mut self, model: &mut TissueModel, h: f64, feed: Feed) -> Result<f32> {
        let mut offsets = [0f32; OFFSET_SAMPLES];
        let mut removed = [0f64; OFFSET_SAMPLES];
        if feed != Feed::Geometric {
            // Deep enough that the last offset shrinks the tool to nothing.
            let deepest = self.sweep.patch.values.iter().fold(0f32, |m, v| m.min(*v));
            let depth = -deepest + 1.5 * h as f32;
            for (i, o) in offsets.iter_mut().enumerate() {
                *o = depth * i as f32 / (OFFSET_SAMPLES - 1) as f32;
            }
        }
        let mut deepest_offset = 0f32;
        for (t, tissue) in model.tissues.iter_mut().enumerate() {
            let mut offset = 0.0;
            let budget = feed.budget(tissue.props.removal_rate_mm3_per_n_s);
            if let (Some(b), Feed::Limited { dt_s, .. }) = (budget, feed) {
                let cap = if dt_s > 0.0 { b / dt_s * MAX_BANKED_S } else { 0.0 };
                let allowed = self.bank.earn(t, b, cap);
                tissue.grid.removal_by_offset(&self.sweep.patch, &offsets, &mut removed)?;
                offset = pick_offset(&offsets, &removed, allowed);
                if offset > 0.0 {
                    self.report.rate_limited = true;
                }
            }
            deepest_offset = deepest_offset.max(offset);
            self.log.clear();
            // A tissue changes at most every patch voxel: room for that once, not a regrowth
            // whenever a tick changes more voxels than any before it.
            self.log.reserve(self.sweep.patch.values.len());
            let measure = if budget.is_some() { Measure::Volume } else { self.measure };
            self.report.measured &= measure == Measure::Volume;
            let stats = tissue.grid.subtract_logged_runs(&self.sweep.patch, self.sweep.column_runs(), offset, measure, &mut self.log)?;
            if let Some(b) = budget {
                self.bank.spend(t, stats.removed_mm3, b);
            }
            match self.handoff {
                Handoff::DirtyChunks => self.dirty.record(t, &self.log),
                Handoff::NewValues => {
                    let changes = &mut self.changes[t];
                    changes.reserve(self.log.len());
                    tissue.grid.last_cut_values(changes);
                }
            }
            self.history.record(t, &self.log);
            self.report.removed_mm3[t].1 = stats.removed_mm3;
            self.report.changed_voxels += stats.changed_voxels;
        }
        Ok(deepest_offset)
    }

    /// Groups the following cuts into one undoable stroke (e.g. while the pedal is down).
    pub fn begin_stroke(&mut self) {
        self.history.begin_stroke();
    }

    pub fn end_stroke(&mut self) {
        self.history.end_stroke();
    }

    /// Takes back the last stroke; false when there is none. Its chunks become dirty.
    pub fn undo(&mut self, model: &mut TissueModel) -> bool {
        let dirty = &mut self.dirty;
        self.history.undo(model, &mut |t, changes| dirty.record(t, changes))
    }

    pub fn redo(&mut self, model: &mut TissueModel) -> bool {
        let dirty = &mut self.dirty;
        self.history.redo(model, &mut |t, changes| dirty.record(t, changes))
    }

    /// Forgets banked removal allowance (e.g. when the burr leaves the tooth or the tool changes).
    pub fn reset_removal(&mut self) {
        self.bank.reset();
    }

    /// Moves the dirty (tissue index, leaf origin) pairs into `out` and clears them.
    pub fn take_dirty(&mut self, out: &mut Vec<(usize, IVec3)>) {
        self.dirty.drain_into(out);
    }

    /// The last tick's report.
    pub fn last_report(&self) -> &StrokeReport {
        &self.report
    }
}
