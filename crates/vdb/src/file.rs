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

/// Reads every grid of a .vdb file.
pub fn read_file(path: &Path) -> Result<Vec<FileGrid>> {
    let file_err = |message: String| Error::File { path: path.to_owned(), message };
    let meta = std::fs::metadata(path).map_err(|e| file_err(e.to_string()))?;
    if !meta.is_file() {
        return Err(file_err("not a regular file".into()));
    }
    let path_str = path.to_str().ok_or_else(|| file_err("path is not valid UTF-8".into()))?;
    let mut list = ffi::read_file(path_str).map_err(|e| file_err(e.what().to_owned()))?;
    if list.len() == 0 {
        return Err(file_err("holds no grids (empty or truncated file)".into()));
    }
    let mut out = Vec::with_capacity(list.len());
    for i in 0..list.len() {
        let describe = |r: Result<String, cxx::Exception>| r.map_err(|e| file_err(e.what().to_owned()));
        let name = describe(list.grid_name(i))?;
        let grid_type = describe(list.grid_type(i))?;
        let grid_class = describe(list.grid_class(i))?;
        let level_set = if grid_type == "Tree_float_5_4_3" {
            let inner = list.pin_mut().take(i).map_err(|e| file_err(e.what().to_owned()))?;
            Some(LevelSet::from_inner(inner))
        } else {
            None
        };
        out.push(FileGrid { name, grid_type, grid_class, level_set });
    }
    Ok(out)
}
