// Turns tissue surfaces from the Rust core into VTK polydata blocks. Private to the plugin.
#pragma once

#include "rust/cxx.h"  // rust::Error, the exception cxx throws for an Err
#include "dentsim-ffi/src/lib.rs.h"

class vtkMultiBlockDataSet;
class vtkPolyData;

namespace dentsim {
// One block per tissue, named after it: points, triangles, `Normals`, cell array `Tissue`
// (label), field data `TissueName`, `Stiffness` (N/mm), `Damping` (N s/mm), `RemovalRate`,
// `Colour`, `Opacity`, and volumes before/after/removed (mm^3).
void FillTissueBlocks(const rust::Vec<ffi::TissueSurface>& surfaces, vtkMultiBlockDataSet* out);
}
