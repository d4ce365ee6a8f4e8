#include "vtkDentSimSurfaces.h"

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCompositeDataSet.h>
#include <vtkDoubleArray.h>
#include <vtkFieldData.h>
#include <vtkFloatArray.h>
#include <vtkInformation.h>
#include <vtkIntArray.h>
#include <vtkMultiBlockDataSet.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkStringArray.h>

#include <vtkAlgorithm.h>
#include <vtkSetGet.h>
#include <vtkDataObjectTreeIterator.h>
#include <vtkInformationVector.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <chrono>
#include <string>
#include <thread>

namespace {

void AddScalarField(vtkFieldData* fd, const char* name, double value) {
  vtkNew<vtkDoubleArray> a;
  a->SetName(name);
  a->InsertNextValue(value);
  fd->AddArray(a);
}

vtkSmartPointer<vtkPolyData> ToPolyData(const dentsim::ffi::TissueSurface& s) {
  const vtkIdType nPoints = vtkIdType(s.points.size() / 3);
  const vtkIdType nTris = vtkIdType(s.triangles.size() / 3);

  vtkNew<vtkFloatArray> xyz;
  xyz->SetNumberOfComponents(3);
  xyz->SetNumberOfTuples(nPoints);
  std::copy(s.points.begin(), s.points.end(), xyz->GetPointer(0));
  vtkNew<vtkPoints> points;
  points->SetData(xyz);

  vtkNew<vtkFloatArray> normals;
  normals->SetName("Normals");
  normals->SetNumberOfComponents(3);
  normals->SetNumberOfTuples(nPoints);
  std::copy(s.normals.begin(), s.normals.end(), normals->GetPointer(0));

  vtkNew<vtkCellArray> polys;
  polys->AllocateExact(nTris, nTris * 3);
  for (vtkIdType t = 0; t < nTris; ++t) {
    const vtkIdType ids[3] = {s.triangles[3 * t], s.triangles[3 * t + 1], s.triangles[3 * t + 2]};
    polys->InsertNextCell(3, ids);
  }

  vtkNew<vtkIntArray> tissue;
  tissue->SetName("Tissue");
  tissue->SetNumberOfTuples(nTris);
  tissue->FillValue(s.label);

  auto pd = vtkSmartPointer<vtkPolyData>::New();
  pd->SetPoints(points);
  pd->SetPolys(polys);
  pd->GetPointData()->SetNormals(normals);
  pd->GetCellData()->SetScalars(tissue);

  vtkFieldData* fd = pd->GetFieldData();
  vtkNew<vtkStringArray> name;
  name->SetName("TissueName");
  name->InsertNextValue(std::string(s.name));
  fd->AddArray(name);
  AddScalarField(fd, "Stiffness", s.stiffness_n_per_mm);
  AddScalarField(fd, "Damping", s.damping_n_s_per_mm);
  AddScalarField(fd, "RemovalRate", s.removal_rate_mm3_per_n_s);
  AddScalarField(fd, "Opacity", s.opacity);
  AddScalarField(fd, "VolumeBefore", s.volume_before_mm3);
  AddScalarField(fd, "VolumeAfter", s.volume_after_mm3);
  AddScalarField(fd, "RemovedVolume", s.removed_mm3);
  vtkNew<vtkDoubleArray> colour;
  colour->SetName("Colour");
  colour->SetNumberOfComponents(3);
  colour->InsertNextTuple3(s.colour[0], s.colour[1], s.colour[2]);
  fd->AddArray(colour);
  if (!s.warnings.empty()) {
    vtkNew<vtkStringArray> warnings;
    warnings->SetName("Warnings");
    for (const auto& w : s.warnings) warnings->InsertNextValue(std::string(w));
    fd->AddArray(warnings);
  }
  return pd;
}

}  // namespace

namespace dentsim {

void FillTissueBlocks(const rust::Vec<ffi::TissueSurface>& surfaces, vtkMultiBlockDataSet* out) {
  out->SetNumberOfBlocks(static_cast<unsigned int>(surfaces.size()));
  unsigned int i = 0;
  for (const auto& s : surfaces) {
    out->SetBlock(i, ToPolyData(s));
    out->GetMetaData(i)->Set(vtkCompositeDataSet::NAME(), std::string(s.name).c_str());
    ++i;
  }
}

void ReportWarnings(vtkAlgorithm* self, const rust::Vec<ffi::TissueSurface>& surfaces) {
  for (const auto& s : surfaces) {
    for (const auto& w : s.warnings) {
      vtkWarningWithObjectMacro(self, << "DentSim: " << std::string(s.name) << ": " << std::string(w));
    }
  }
}

void FollowJob(vtkAlgorithm* self, const std::function<bool()>& finished,
               const std::function<double()>& progress, const std::function<void()>& abort) {
  // VTK 9.1's executive does not clear an abort that ended the previous run.
  self->SetAbortExecute(0);
  while (!finished()) {
    self->UpdateProgress(progress());
    if (self->GetAbortExecute()) abort();
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  self->UpdateProgress(1.0);
}

bool IsPieceZero(vtkInformationVector* outputVector) {
  vtkInformation* info = outputVector->GetInformationObject(0);
  const auto key = vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER();
  return !info->Has(key) || info->Get(key) <= 0;
}

std::vector<ffi::InputSurface> InputSurfaces(vtkMultiBlockDataSet* blocks) {
  std::vector<ffi::InputSurface> out;
  vtkSmartPointer<vtkDataObjectTreeIterator> it;
  it.TakeReference(blocks->NewTreeIterator());
  for (it->InitTraversal(); !it->IsDoneWithTraversal(); it->GoToNextItem()) {
    vtkPolyData* pd = vtkPolyData::SafeDownCast(it->GetCurrentDataObject());
    if (!pd) continue;
    ffi::InputSurface s;
    const char* name = it->GetCurrentMetaData()->Get(vtkCompositeDataSet::NAME());
    s.name = name ? name : "";
    for (vtkIdType i = 0; i < pd->GetNumberOfPoints(); ++i) {
      double p[3];
      pd->GetPoint(i, p);
      for (double c : p) s.points.push_back(static_cast<float>(c));
    }
    vtkCellArray* polys = pd->GetPolys();
    vtkIdType n = 0;
    const vtkIdType* ids = nullptr;
    for (polys->InitTraversal(); polys->GetNextCell(n, ids);) {
      for (vtkIdType k = 1; k + 1 < n; ++k) {  // fan: a triangle stays one triangle
        s.triangles.push_back(static_cast<uint32_t>(ids[0]));
        s.triangles.push_back(static_cast<uint32_t>(ids[k]));
        s.triangles.push_back(static_cast<uint32_t>(ids[k + 1]));
      }
    }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace dentsim
