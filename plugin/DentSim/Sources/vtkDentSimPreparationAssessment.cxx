#include "vtkDentSimPreparationAssessment.h"

#include <vtkCellArray.h>
#include <vtkDoubleArray.h>
#include <vtkFloatArray.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkMultiBlockDataSet.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkFieldData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include "vtkDentSimSurfaces.h"

vtkStandardNewMacro(vtkDentSimPreparationAssessment);

vtkDentSimPreparationAssessment::vtkDentSimPreparationAssessment() {
  // 0: unused, so that ParaView never binds the active source to it; 1: prepared, 2: original,
  // 3: reference (each optional, over its file).
  this->SetNumberOfInputPorts(4);
  this->SetNumberOfOutputPorts(2);
}

int vtkDentSimPreparationAssessment::FillInputPortInformation(int port, vtkInformation* info) {
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), port == 0 ? "vtkDataObject" : "vtkMultiBlockDataSet");
  info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  return 1;
}

vtkDentSimPreparationAssessment::~vtkDentSimPreparationAssessment() {
  this->SetPreparedFile(nullptr);
  this->SetOriginalFile(nullptr);
  this->SetReferenceFile(nullptr);
}

// The pipeline makes each output from its DATA_TYPE_NAME: port 1 becomes a table.
int vtkDentSimPreparationAssessment::FillOutputPortInformation(int port, vtkInformation* info) {
  info->Set(vtkDataObject::DATA_TYPE_NAME(), port == 0 ? "vtkPolyData" : "vtkTable");
  return 1;
}

int vtkDentSimPreparationAssessment::RequestData(vtkInformation*, vtkInformationVector** inputVector,
                                                 vtkInformationVector* outputVector) {
  vtkPolyData::GetData(outputVector, 0)->Initialize();
  vtkTable::GetData(outputVector, 1)->Initialize();
  if (!dentsim::IsPieceZero(outputVector)) return 1;
  auto text = [](const char* s) { return rust::String(s ? s : ""); };
  dentsim::ffi::AssessmentParams params{text(this->PreparedFile), text(this->OriginalFile),
                                        text(this->ReferenceFile), this->Kind == 1, this->UseAxis,
                                        {this->Axis[0], this->Axis[1], this->Axis[2]}};
  // The tissues on a connected input, as the other DentSim sources hand them on.
  auto surfaces = [&](int port) {
    std::vector<dentsim::ffi::InputSurface> none;
    if (this->GetNumberOfInputConnections(port) == 0) return none;
    auto* blocks = vtkMultiBlockDataSet::GetData(inputVector[port], 0);
    return blocks ? dentsim::InputSurfaces(blocks) : none;
  };
  const auto prepared = surfaces(1), original = surfaces(2), reference = surfaces(3);
  const bool withReference = !reference.empty() || (this->ReferenceFile && *this->ReferenceFile);
  try {
    // On a thread of the core, for ParaView's progress bar and Abort.
    const dentsim::ffi::AssessmentResult result = dentsim::RunJob(
        this, dentsim::ffi::start_assessment(params, {prepared.data(), prepared.size()},
                                             {original.data(), original.size()},
                                             {reference.data(), reference.size()},
                                             this->TissueVoxelSize));
    vtkPolyData* surface = vtkPolyData::GetData(outputVector, 0);
    vtkNew<vtkPoints> points;
    points->SetDataTypeToFloat();
    const vtkIdType n = vtkIdType(result.points.size() / 3);
    points->SetNumberOfPoints(n);
    for (vtkIdType i = 0; i < n; ++i)
      points->SetPoint(i, result.points[3 * i], result.points[3 * i + 1], result.points[3 * i + 2]);
    vtkNew<vtkCellArray> polys;
    for (size_t t = 0; t + 2 < result.triangles.size(); t += 3) {
      const vtkIdType ids[3] = {vtkIdType(result.triangles[t]), vtkIdType(result.triangles[t + 1]),
                                vtkIdType(result.triangles[t + 2])};
      polys->InsertNextCell(3, ids);
    }
    surface->SetPoints(points);
    surface->SetPolys(polys);
    auto pointArray = [&](const char* name, const rust::Vec<float>& values) {
      vtkNew<vtkFloatArray> a;
      a->SetName(name);
      a->SetNumberOfTuples(vtkIdType(values.size()));
      for (size_t i = 0; i < values.size(); ++i) a->SetValue(vtkIdType(i), values[i]);
      surface->GetPointData()->AddArray(a);
    };
    pointArray("DeviationMm", result.deviation_mm);
    pointArray("CutDepthMm", result.cut_depth_mm);
    surface->GetPointData()->SetActiveScalars(withReference ? "DeviationMm" : "CutDepthMm");
    vtkNew<vtkStringArray> json;
    json->SetName("AssessmentJSON");
    json->InsertNextValue(std::string(result.json).c_str());
    surface->GetFieldData()->AddArray(json);

    vtkTable* table = vtkTable::GetData(outputVector, 1);
    vtkNew<vtkStringArray> criterion, unit, range, verdict, source;
    vtkNew<vtkDoubleArray> value;
    criterion->SetName("Criterion");
    value->SetName("Value");
    unit->SetName("Unit");
    range->SetName("Range");
    verdict->SetName("Verdict");
    source->SetName("Source");
    for (const auto& row : result.rows) {
      criterion->InsertNextValue(std::string(row.criterion).c_str());
      value->InsertNextValue(row.value);
      unit->InsertNextValue(std::string(row.unit).c_str());
      range->InsertNextValue(std::string(row.range).c_str());
      verdict->InsertNextValue(std::string(row.verdict).c_str());
      source->InsertNextValue(std::string(row.source).c_str());
    }
    table->AddColumn(criterion);
    table->AddColumn(value);
    table->AddColumn(unit);
    table->AddColumn(range);
    table->AddColumn(verdict);
    table->AddColumn(source);
  } catch (const rust::Error& e) {
    vtkErrorMacro(<< "DentSim: " << e.what());
    return 0;
  }
  return 1;
}

void vtkDentSimPreparationAssessment::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "PreparedFile: " << (this->PreparedFile ? this->PreparedFile : "(none)") << "\n";
  os << indent << "OriginalFile: " << (this->OriginalFile ? this->OriginalFile : "(none)") << "\n";
  os << indent << "ReferenceFile: " << (this->ReferenceFile ? this->ReferenceFile : "(none)") << "\n";
  os << indent << "Kind: " << this->Kind << "\n";
}
