// Turns tissue surfaces from the Rust core into VTK polydata blocks. Private to the plugin.
#pragma once

#include <vector>

#include "rust/cxx.h"  // rust::Error, the exception cxx throws for an Err
#include "dentsim-ffi/src/lib.rs.h"

class vtkAlgorithm;
class vtkInformationVector;
class vtkMultiBlockDataSet;
class vtkPolyData;

namespace dentsim {
// One block per tissue, named after it: points, triangles, `Normals`, cell array `Tissue`
// (label), field data `TissueName`, `Stiffness` (N/mm), `Damping` (N s/mm), `RemovalRate`,
// `Colour`, `Opacity`, and volumes before/after/removed (mm^3).
void FillTissueBlocks(const rust::Vec<ffi::TissueSurface>& surfaces, vtkMultiBlockDataSet* out);

// Waits for a job of the Rust core, passing its progress to `self` (ParaView's progress bar) and
// `self`'s AbortExecute to the job; returns the surfaces or throws rust::Error.
rust::Vec<ffi::TissueSurface> RunJob(vtkAlgorithm* self, rust::Box<ffi::SurfaceJob> job);

// Under MPI every rank runs the pipeline and asks for its own piece: the work is one piece,
// made by the rank asked for piece 0; the others answer with empty outputs.
bool IsPieceZero(vtkInformationVector* outputVector);

// The tissue surfaces of a multiblock (a DentSim source's output, or a reader's) as the core's
// input: one per polydata leaf, named by its block; non-triangle cells are ignored.
std::vector<ffi::InputSurface> InputSurfaces(vtkMultiBlockDataSet* blocks);
}
