#include "vtkDentSimPreparation.h"

#include <vtkCellArray.h>
#include <vtkDataArray.h>
#include <vtkDoubleArray.h>
#include <vtkIdList.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkMultiBlockDataSet.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkPolyData.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include <string>
#include <vector>

#include "vtkDentSimSurfaces.h"

vtkStandardNewMacro(vtkDentSimPreparation);

vtkDentSimPreparation::vtkDentSimPreparation() {
  this->SetNumberOfInputPorts(3);
  this->SetNumberOfOutputPorts(2);
  this->SetBurr("round:1.0");
}

vtkDentSimPreparation::~vtkDentSimPreparation() {
  this->SetTissuesFile(nullptr);
  this->SetToolPathFile(nullptr);
  this->SetBurr(nullptr);
}

int vtkDentSimPreparation::FillInputPortInformation(int port, vtkInformation* info) {
  // 0: unused (see the header); 1: tissues; 2: tool path.
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(),
            port == 1 ? "vtkMultiBlockDataSet" : port == 2 ? "vtkPolyData" : "vtkDataObject");
  info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  return 1;
}

int vtkDentSimPreparation::FillOutputPortInformation(int port, vtkInformation* info) {
  info->Set(vtkDataObject::DATA_TYPE_NAME(), port == 0 ? "vtkMultiBlockDataSet" : "vtkTable");
  return 1;
}

int vtkDentSimPreparation::RequestDataObject(vtkInformation*, vtkInformationVector**,
                                             vtkInformationVector* outputVector) {
  // The superclass would make every output a multiblock; port 1 is a table.
  for (int port = 0; port < 2; ++port) {
    vtkInformation* info = outputVector->GetInformationObject(port);
    vtkDataObject* current = info->Get(vtkDataObject::DATA_OBJECT());
    if (port == 0 && !vtkMultiBlockDataSet::SafeDownCast(current)) {
      vtkNew<vtkMultiBlockDataSet> out;
      info->Set(vtkDataObject::DATA_OBJECT(), out);
    } else if (port == 1 && !vtkTable::SafeDownCast(current)) {
      vtkNew<vtkTable> out;
      info->Set(vtkDataObject::DATA_OBJECT(), out);
    }
  }
  return 1;
}

namespace {

// The polyline's points in order: along its one line cell, or in id order when it has no lines.
bool PathOrder(vtkPolyData* path, std::vector<vtkIdType>& order, std::string& error) {
  vtkCellArray* lines = path->GetLines();
  const vtkIdType nLines = lines ? lines->GetNumberOfCells() : 0;
  if (nLines > 1) {
    error = "the tool path has " + std::to_string(nLines) + " lines; expected one polyline";
    return false;
  }
  if (nLines == 1) {
    vtkNew<vtkIdList> ids;
    lines->InitTraversal();
    lines->GetNextCell(ids);
    for (vtkIdType i = 0; i < ids->GetNumberOfIds(); ++i) order.push_back(ids->GetId(i));
  } else {
    for (vtkIdType i = 0; i < path->GetNumberOfPoints(); ++i) order.push_back(i);
  }
  return true;
}

// Copies an optional point array (`components` per point) in path order; absent leaves it empty.
bool PathArray(vtkPolyData* path, const char* name, int components, bool required,
               const std::vector<vtkIdType>& order, std::vector<double>& values,
               std::string& error) {
  vtkDataArray* a = path->GetPointData()->GetArray(name);
  if (!a) {
    if (required) {
      error = std::string("the tool path has no point array '") + name + "' (" +
              std::to_string(components) + " components)";
    }
    return !required;
  }
  if (a->GetNumberOfComponents() != components) {
    error = std::string("tool path array ") + name + " has " +
            std::to_string(a->GetNumberOfComponents()) + " components, expected " +
            std::to_string(components);
    return false;
  }
  for (vtkIdType id : order)
    for (int c = 0; c < components; ++c) values.push_back(a->GetComponent(id, c));
  return true;
}

rust::Slice<const double> Slice(const std::vector<double>& v) {
  return rust::Slice<const double>(v.data(), v.size());
}

}  // namespace

int vtkDentSimPreparation::RequestData(vtkInformation*, vtkInformationVector** inputVector,
                                       vtkInformationVector* outputVector) {
  dentsim::ffi::PreparationParams params{};
  params.tissues_path = this->TissuesFile ? this->TissuesFile : "";
  params.phantom_voxel_mm = this->PhantomVoxelSize;
  params.burr = this->Burr ? this->Burr : "";
  params.force_n = this->Force;
  params.path_csv = this->ToolPathFile ? this->ToolPathFile : "";

  // A failed run leaves empty outputs, not the previous result.
  vtkMultiBlockDataSet* blocks = vtkMultiBlockDataSet::GetData(outputVector, 0);
  vtkTable* table = vtkTable::GetData(outputVector, 1);
  blocks->Initialize();
  table->Initialize();
  if (!dentsim::IsPieceZero(outputVector)) return 1;

  std::vector<double> points, orientation, time, rpm, cut;
  vtkPolyData* path = vtkPolyData::GetData(inputVector[2], 0);
  params.use_polyline = path != nullptr;
  if (path) {
    std::vector<vtkIdType> order;
    std::string error;
    bool ok = PathOrder(path, order, error) &&
              PathArray(path, "Orientation", 4, true, order, orientation, error) &&
              PathArray(path, "Time", 1, false, order, time, error) &&
              PathArray(path, "RPM", 1, false, order, rpm, error) &&
              PathArray(path, "Cut", 1, false, order, cut, error);
    if (!ok) {
      vtkErrorMacro(<< "DentSim: Tool Path: " << error);
      return 0;
    }
    for (vtkIdType id : order) {
      double p[3];
      path->GetPoint(id, p);
      points.insert(points.end(), p, p + 3);
    }
  }

  std::vector<dentsim::ffi::InputSurface> tissues;
  if (vtkMultiBlockDataSet* input = vtkMultiBlockDataSet::GetData(inputVector[1], 0)) {
    tissues = dentsim::InputSurfaces(input);
    if (tissues.empty()) {
      vtkErrorMacro(<< "DentSim: Tissues: the input holds no tissue surfaces");
      return 0;
    }
  }

  try {
    auto surfaces = dentsim::RunJob(
        this, dentsim::ffi::start_preparation(
                  params,
                  rust::Slice<const dentsim::ffi::InputSurface>(tissues.data(), tissues.size()),
                  this->TissueVoxelSize, Slice(points), Slice(orientation), Slice(time),
                  Slice(rpm), Slice(cut)));
    dentsim::FillTissueBlocks(surfaces, blocks);

    vtkNew<vtkStringArray> tissue;
    tissue->SetName("Tissue");
    vtkNew<vtkDoubleArray> removed, before, after;
    removed->SetName("RemovedVolume");
    before->SetName("VolumeBefore");
    after->SetName("VolumeAfter");
    for (const auto& s : surfaces) {
      tissue->InsertNextValue(std::string(s.name));
      removed->InsertNextValue(s.removed_mm3);
      before->InsertNextValue(s.volume_before_mm3);
      after->InsertNextValue(s.volume_after_mm3);
    }
    table->AddColumn(tissue);
    table->AddColumn(removed);
    table->AddColumn(before);
    table->AddColumn(after);
  } catch (const rust::Error& e) {
    blocks->Initialize();
    table->Initialize();
    vtkErrorMacro(<< "DentSim: " << e.what());
    return 0;
  }
  return 1;
}

void vtkDentSimPreparation::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "TissuesFile: " << (this->TissuesFile ? this->TissuesFile : "(phantom)") << "\n";
  os << indent << "TissueVoxelSize: " << this->TissueVoxelSize << " mm\n";
  os << indent << "PhantomVoxelSize: " << this->PhantomVoxelSize << " mm\n";
  os << indent << "ToolPathFile: " << (this->ToolPathFile ? this->ToolPathFile : "") << "\n";
  os << indent << "Burr: " << (this->Burr ? this->Burr : "") << "\n";
  os << indent << "Force: " << this->Force << " N\n";
}
