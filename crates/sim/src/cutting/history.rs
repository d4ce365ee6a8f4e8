//! Undo and redo at stroke granularity with bounded memory. The journal keeps, for each changed
//! voxel, its value before the change (16 bytes + the tissue index), in one ring buffer whose
//! capacity is fixed up front: recording at haptic rate allocates nothing, and when the cap is
//! reached the oldest strokes are dropped. A stroke bigger than the whole cap cannot be undone.
use std::collections::VecDeque;

use dentsim_vdb::VoxelChange;

use crate::tissues::model::TissueModel;

#[derive(Clone, Copy, Debug, PartialEq)]
struct Entry {
    tissue: u16,
    change: VoxelChange,
}

/// A stroke taken back by undo: its old and new voxel values.
struct Undone {
    old: Vec<Entry>,
    new: Vec<Entry>,
}

pub struct History {
    entries: VecDeque<Entry>,
    /// Entry count of each complete stroke, oldest first.
    strokes: VecDeque<usize>,
    /// Entries of the open stroke (at the back of `entries`); `None` when no stroke is open.
    open: Option<usize>,
    /// The open stroke outgrew the cap and can no longer be undone.
    overflowed: bool,
    redo: Vec<Undone>,
    cap_entries: usize,
    /// Every slot of `entries` has been written once (see [`History::prefault`]).
    prefaulted: bool,
}

/// Default cap: 64 MiB of journal.
pub const DEFAULT_HISTORY_BYTES: usize = 64 << 20;

impl Default for History {
    fn default() -> Self {
        History::with_bytes(DEFAULT_HISTORY_BYTES)
    }
}

impl History {
    /// A journal that never holds more than `bytes` of voxel records.
    pub fn with_bytes(bytes: usize) -> Self {
        let cap_entries = (bytes / std::mem::size_of::<Entry>()).max(1);
        History {
            entries: VecDeque::with_capacity(cap_entries),
            strokes: VecDeque::with_capacity(1024),
            open: None,
            overflowed: false,
            redo: Vec::new(),
            cap_entries,
            prefaulted: false,
        }
    }

    /// Writes every slot of the journal's ring once (then forgets the writes), so that recording
    /// never page-faults: the ring is reserved up front but the kernel maps its pages at their
    /// first write, and a haptic tick that journals a few thousand voxels would otherwise take a
    /// page fault per 4 KiB of them (a tenth of a cylinder burr's tick, until the whole cap had
    /// been written once). Done once per journal; it keeps what is recorded.
    pub fn prefault(&mut self) {
        if self.prefaulted {
            return;
        }
        let kept = self.entries.len();
        let blank = Entry { tissue: 0, change: VoxelChange::default() };
        // Within the capacity: no allocation, every free slot of the ring written.
        self.entries.resize(self.entries.capacity(), blank);
        self.entries.truncate(kept);
        self.prefaulted = true;
    }

    pub fn bytes(&self) -> usize {
        self.entries.len() * std::mem::size_of::<Entry>()
    }

    pub fn undo_depth(&self) -> usize {
        self.strokes.len()
    }

    pub fn redo_depth(&self) -> usize {
        self.redo.len()
    }

    pub fn begin_stroke(&mut self) {
        if self.open.is_none() {
            self.open = Some(0);
            self.overflowed = false;
        }
    }

    pub fn is_open(&self) -> bool {
        self.open.is_some()
    }

    /// Closes the open stroke; an empty or overflowed stroke leaves nothing to undo.
    pub fn end_stroke(&mut self) {
        if let Some(n) = self.open.take() {
            if n > 0 && !self.overflowed {
                if self.strokes.len() == self.strokes.capacity() {
                    self.drop_oldest();
                }
                self.strokes.push_back(n);
            }
        }
    }

    /// Appends the old values of one tissue's changes to the open stroke.
    pub fn record(&mut self, tissue: usize, log: &[VoxelChange]) {
        let Some(open) = self.open else { return };
        if log.is_empty() {
            return;
        }
        if !self.redo.is_empty() {
            self.redo.clear();
        }
        if self.overflowed {
            return;
        }
        if open + log.len() > self.cap_entries {
            // The stroke alone exceeds the cap: forget it (its voxels stay cut).
            self.entries.truncate(self.entries.len() - open);
            self.open = Some(0);
            self.overflowed = true;
            return;
        }
        while self.entries.len() + log.len() > self.cap_entries {
            self.drop_oldest();
        }
        self.open = Some(open + log.len());
        let tissue = tissue as u16;
        self.entries.extend(log.iter().map(|&change| Entry { tissue, change }));
    }

    fn drop_oldest(&mut self) {
        if let Some(n) = self.strokes.pop_front() {
            self.entries.drain(..n);
        }
    }

    /// Takes back the last complete stroke; false when there is none.
    pub fn undo(&mut self, model: &mut TissueModel, touched: &mut dyn FnMut(usize, &[VoxelChange])) -> bool {
        self.end_stroke();
        let Some(n) = self.strokes.pop_back() else { return false };
        let start = self.entries.len() - n;
        let old: Vec<Entry> = self.entries.drain(start..).collect();
        let mut new = old.clone();
        for (t, tissue) in model.tissues.iter_mut().enumerate() {
            let mut current: Vec<VoxelChange> = new.iter().filter(|e| e.tissue as usize == t).map(|e| e.change).collect();
            if current.is_empty() {
                continue;
            }
            tissue.grid.read_voxels(&mut current);
            let mut it = current.iter();
            for e in new.iter_mut().filter(|e| e.tissue as usize == t) {
                e.change = *it.next().expect("same count");
            }
            // Latest change first, so each voxel ends at its value from before the stroke.
            let back: Vec<VoxelChange> = old.iter().rev().filter(|e| e.tissue as usize == t).map(|e| e.change).collect();
            tissue.grid.write_voxels(&back);
            touched(t, &back);
        }
        self.redo.push(Undone { old, new });
        true
    }

    /// Re-applies the last undone stroke; false when there is none.
    pub fn redo(&mut self, model: &mut TissueModel, touched: &mut dyn FnMut(usize, &[VoxelChange])) -> bool {
        let Some(u) = self.redo.pop() else { return false };
        for (t, tissue) in model.tissues.iter_mut().enumerate() {
            let values: Vec<VoxelChange> = u.new.iter().filter(|e| e.tissue as usize == t).map(|e| e.change).collect();
            if !values.is_empty() {
                tissue.grid.write_voxels(&values);
                touched(t, &values);
            }
        }
        while self.entries.len() + u.old.len() > self.cap_entries && !self.strokes.is_empty() {
            self.drop_oldest();
        }
        if self.entries.len() + u.old.len() <= self.cap_entries {
            self.entries.extend(u.old.iter().copied());
            self.strokes.push_back(u.old.len());
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Prefaulting keeps what the journal holds and its capacity, and the strokes recorded
    /// after it (the cap dropping the oldest) leave the journal as they leave one never
    /// prefaulted.
    #[test]
    fn prefaulting_keeps_the_journal_and_records_as_before() {
        let bytes = 100 * std::mem::size_of::<Entry>();
        let (mut prefaulted, mut plain) = (History::with_bytes(bytes), History::with_bytes(bytes));
        let log = |n: i32| (0..n).map(|i| VoxelChange { i, j: n, k: 2, value: i as f32 }).collect::<Vec<_>>();
        for h in [&mut prefaulted, &mut plain] {
            h.begin_stroke();
            h.record(1, &log(30));
            h.end_stroke();
        }
        let capacity = prefaulted.entries.capacity();
        prefaulted.prefault();
        assert_eq!((prefaulted.entries.capacity(), prefaulted.undo_depth()), (capacity, 1));
        assert_eq!(prefaulted.entries, plain.entries);
        for n in [20, 35, 25, 40] {
            for h in [&mut prefaulted, &mut plain] {
                h.begin_stroke();
                h.record(0, &log(n));
                h.end_stroke();
            }
            assert_eq!(prefaulted.entries, plain.entries, "after a stroke of {n}");
            assert_eq!((prefaulted.undo_depth(), prefaulted.bytes()), (plain.undo_depth(), plain.bytes()));
        }
        assert_eq!(prefaulted.entries.capacity(), capacity);
    }
}
