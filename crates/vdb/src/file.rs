use std::path::Path;

use crate::error::{Error, Result};
use crate::level_set::LevelSet;
use crate::sys::ffi;

/// One grid read from a .vdb file; `level_set` is `None` for grids that are not float grids.
#[derive(Debug)]
pub struct FileGrid {
    pub name: String,
    pub grid_type: String,
    pub grid_class: String,
    pub level_set: Option<LevelSet>,
}

/// What a .vdb file may ask of the reader before it is refused (the defaults suit teeth in mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReadLimits {
    /// Memory the read may take, and the dense box of a float grid's active voxels may fill
    /// (4 bytes a voxel: a session voxelizes each tissue's inside).
    pub max_bytes: u64,
    /// Voxel size range (world units, mm for dentsim).
    pub min_voxel: f64,
    pub max_voxel: f64,
    /// OpenVDB's reader gets this long, plus a second per 4 MB of file.
    pub timeout_s: u32,
}

impl Default for ReadLimits {
    fn default() -> Self {
        ReadLimits { max_bytes: 8 << 30, min_voxel: 0.005, max_voxel: 5.0, timeout_s: 20 }
    }
}

/// Writes named grids (with their metadata) to one .vdb file. The file appears whole or not at
/// all ([`dentsim_atomic::write_via`]).
pub fn write_file(path: &Path, grids: &[&LevelSet]) -> Result<()> {
    let file_err = |message: String| Error::File { path: path.to_owned(), message };
    let mut list = ffi::new_grid_list();
    for g in grids {
        list.pin_mut().push(g.inner());
    }
    dentsim_atomic::write_via(path, |staged| {
        let staged = staged.to_str().ok_or_else(|| file_err("path is not valid UTF-8".into()))?;
        list.write_file(staged).map_err(|e| file_err(e.what().to_owned()))
    })
}

/// Reads every grid of a .vdb file with the default [`ReadLimits`].
pub fn read_file(path: &Path) -> Result<Vec<FileGrid>> {
    read_file_with(path, &ReadLimits::default())
}

/// Reads every grid of a .vdb file. A hostile file gives an error naming it, never a crash: the
/// layout is checked against the file's size, only a reader process parses the file's bytes with
/// OpenVDB (its reader can crash or overflow a buffer on corrupt data) and hands the grids back
/// as OpenVDB's writer writes them; each float grid's voxel size and box are checked against
/// `limits`.
pub fn read_file_with(path: &Path, limits: &ReadLimits) -> Result<Vec<FileGrid>> {
    let file_err = |message: String| Error::File { path: path.to_owned(), message: one_line(&message) };
    let meta = std::fs::metadata(path).map_err(|e| file_err(e.to_string()))?;
    if !meta.is_file() {
        return Err(file_err("not a regular file".into()));
    }
    if meta.len() > limits.max_bytes {
        return Err(file_err(format!("is {} MiB, more than the {} MiB memory limit", meta.len() >> 20, limits.max_bytes >> 20)));
    }
    let bytes = std::fs::read(path).map_err(|e| file_err(e.to_string()))?;
    read_bytes(&bytes, limits).map_err(file_err)
}

/// [`read_file_with`] on bytes already in memory; errors are one line, without the file's name.
pub fn read_bytes(bytes: &[u8], limits: &ReadLimits) -> std::result::Result<Vec<FileGrid>, String> {
    check_layout(bytes)?;
    let timeout_ms = (limits.timeout_s as u64 + bytes.len() as u64 / (4 << 20)).saturating_mul(1000);
    // A corrupt length can ask for gigabytes; a real level set's tree is at most tens of times
    // its compressed file (inactive values are not stored), so the child gets far less than
    // the whole limit and fails fast.
    let probe_bytes = limits.max_bytes.min((1 << 30) + 64 * bytes.len() as u64);
    let clean = crate::reader_process::guarded_read(bytes, probe_bytes, timeout_ms).map_err(|e| one_line(&e))?;
    // What OpenVDB's writer made of the grids the child read: never the file's own bytes.
    read_unguarded(&clean, limits)
}

/// Reads in this process without the child's guard: for the C++ fuzz target and tests of the
/// checks after the read. A corrupt file can crash the process.
#[doc(hidden)]
pub fn read_unguarded(bytes: &[u8], limits: &ReadLimits) -> std::result::Result<Vec<FileGrid>, String> {
    let mut list = ffi::read_bytes(bytes).map_err(|e| one_line(e.what()))?;
    if list.len() == 0 {
        return Err("holds no grids".into());
    }
    let mut out = Vec::with_capacity(list.len());
    for i in 0..list.len() {
        let describe = |r: std::result::Result<String, cxx::Exception>| r.map_err(|e| one_line(e.what()));
        let name = describe(list.grid_name(i))?;
        let grid_type = describe(list.grid_type(i))?;
        let grid_class = describe(list.grid_class(i))?;
        let level_set = if grid_type == "Tree_float_5_4_3" {
            let grid = LevelSet::from_inner(list.pin_mut().take(i).map_err(|e| one_line(e.what()))?);
            check_grid(&name, &grid, limits)?;
            Some(grid)
        } else {
            None
        };
        out.push(FileGrid { name: one_line(&name), grid_type: one_line(&grid_type), grid_class, level_set });
    }
    Ok(out)
}

fn check_grid(name: &str, grid: &LevelSet, limits: &ReadLimits) -> std::result::Result<(), String> {
    let name = quoted_name(name);
    let h = grid.voxel_size();
    if !(h >= limits.min_voxel && h <= limits.max_voxel) {
        return Err(format!("grid '{name}' has voxel size {h}, expected {} to {}", limits.min_voxel, limits.max_voxel));
    }
    if let Some(b) = grid.index_bbox() {
        let voxels: f64 = (b.max - b.min).as_dvec3().to_array().iter().map(|d| d + 1.0).product();
        let bytes = voxels * 4.0;
        if bytes > limits.max_bytes as f64 {
            return Err(format!(
                "grid '{name}' spans {} x {} x {} voxels ({:.0} GiB dense), more than the {} MiB memory limit",
                b.max.x as i64 - b.min.x as i64 + 1,
                b.max.y as i64 - b.min.y as i64 + 1,
                b.max.z as i64 - b.min.z as i64 + 1,
                bytes / (1u64 << 30) as f64,
                limits.max_bytes >> 20
            ));
        }
    }
    Ok(())
}

/// OpenVDB's messages can quote whatever garbage a corrupt file held (megabytes of it): keep one
/// printable line of at most 300 characters.
fn one_line(message: &str) -> String {
    clip(message, 300)
}

/// A name out of the file (a grid's), as short as a message can quote it.
fn quoted_name(name: &str) -> String {
    clip(name, 60)
}

fn clip(message: &str, max_chars: usize) -> String {
    let mut out = String::new();
    let mut last_space = true;
    for c in message.chars() {
        let c = if c.is_control() || c.is_whitespace() { ' ' } else { c };
        if c == ' ' && last_space {
            continue;
        }
        last_space = c == ' ';
        if out.chars().count() >= max_chars {
            out.push('…');
            break;
        }
        out.push(c);
    }
    out.trim_end().to_owned()
}

/// The .vdb layout (`openvdb/io/Archive.cc`, file format 222 and later): header, file metadata,
/// grid count, then per grid a descriptor (name, type, instance parent, grid/block/end byte
/// offsets) followed by the grid. Checked so a truncated file or a wild count or length is one
/// clear error before OpenVDB allocates what a corrupt length asks for.
#[doc(hidden)]
pub fn check_layout(bytes: &[u8]) -> std::result::Result<(), String> {
    let n = bytes.len() as u64;
    let mut c = Cursor { bytes, pos: 0 };
    let magic = c.u64("magic number")?;
    if magic != 0x5644_4220 {
        return Err("is not an OpenVDB file (no magic number)".into());
    }
    let version = c.u32("file version")?;
    if !(222..=300).contains(&version) {
        // Older layouts differ; the guarded read still covers them.
        return Ok(());
    }
    c.take(8, "library version")?;
    let has_offsets = c.take(1, "header")?[0] != 0;
    c.take(36, "file UUID")?;
    let meta_count = c.u32("file metadata count")?;
    for _ in 0..meta_count {
        c.string("file metadata name")?;
        c.string("file metadata type")?;
        c.string("file metadata value")?;
    }
    let grids = c.u32("grid count")?;
    if grids as u64 > n / 16 {
        return Err(format!("claims {grids} grids in {n} bytes (corrupt)"));
    }
    if !has_offsets {
        return Ok(());
    }
    for i in 0..grids {
        let name = c.string("grid name")?;
        let name = quoted_name(&String::from_utf8_lossy(name));
        c.string("grid type")?;
        c.string("grid instance parent")?;
        let start = c.pos;
        let (grid_pos, block_pos, end_pos) = (c.u64("grid offset")?, c.u64("grid offset")?, c.u64("grid offset")?);
        if end_pos > n {
            return Err(format!(
                "is truncated: grid '{name}' ({} of {grids}) ends at byte {end_pos}, the file has {n} bytes",
                i + 1
            ));
        }
        if grid_pos != start + 24 || !(grid_pos <= block_pos && block_pos <= end_pos) {
            return Err(format!("grid '{name}' has corrupt offsets ({grid_pos}, {block_pos}, {end_pos})"));
        }
        c.pos = end_pos;
    }
    Ok(())
}

struct Cursor<'a> {
    bytes: &'a [u8],
    pos: u64,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, len: u64, what: &str) -> std::result::Result<&'a [u8], String> {
        let end = self.pos.checked_add(len).filter(|&e| e <= self.bytes.len() as u64);
        let Some(end) = end else {
            return Err(format!("is truncated: its {what} needs {len} bytes at byte {}, the file has {}", self.pos, self.bytes.len()));
        };
        let s = &self.bytes[self.pos as usize..end as usize];
        self.pos = end;
        Ok(s)
    }
    fn u32(&mut self, what: &str) -> std::result::Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().expect("4 bytes")))
    }
    fn u64(&mut self, what: &str) -> std::result::Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().expect("8 bytes")))
    }
    fn string(&mut self, what: &str) -> std::result::Result<&'a [u8], String> {
        let len = self.u32(what)?;
        self.take(len as u64, what)
    }
}
