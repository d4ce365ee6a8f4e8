// Turns tissue surfaces from the Rust core into VTK polydata blocks. Private to the plugin.
#pragma once

#include <functional>
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
// `Colour`, `Opacity`, volumes before/after/removed (mm^3), and `Warnings` (strings) where the
// core found the tissue doubtful (segmentation's pulp warnings).
void FillTissueBlocks(const rust::Vec<ffi::TissueSurface>& surfaces, vtkMultiBlockDataSet* out);

// Each tissue's warnings as VTK warnings of `self` (ParaView's Output Messages).
void ReportWarnings(vtkAlgorithm* self, const rust::Vec<ffi::TissueSurface>& surfaces);

// Polls until `finished()`, passing progress to `self` (ParaView's progress bar) and `self`'s
// AbortExecute to the job.
void FollowJob(vtkAlgorithm* self, const std::function<bool()>& finished,
               const std::function<double()>& progress, const std::function<void()>& abort);

// Waits for a job of the Rust core as FollowJob does; returns its result or throws rust::Error.
template <class Job>
auto RunJob(vtkAlgorithm* self, rust::Box<Job> job) {
  FollowJob(
      self, [&] { return job->finished(); }, [&] { return job->progress(); },
      [&] { job->abort(); });
  return job->wait();
}

// Under MPI every rank runs the pipeline and asks for its own piece: the work is one piece,
// made by the rank asked for piece 0; the others answer with empty outputs.
bool IsPieceZero(vtkInformationVector* outputVector);

// The tissue surfaces of a multiblock (a DentSim source's output, or a reader's) as the core's
// input: one per polydata leaf, named by its block; non-triangle cells are ignored.
std::vector<ffi::InputSurface> InputSurfaces(vtkMultiBlockDataSet* blocks);
}
