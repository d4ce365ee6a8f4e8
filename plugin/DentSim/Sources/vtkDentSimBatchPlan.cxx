#include "vtkDentSimBatchPlan.h"

#include <vtkDoubleArray.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkStreamingDemandDrivenPipeline.h>
#include <vtkStringArray.h>
#include <vtkTable.h>

#include "vtkDentSimSurfaces.h"

vtkStandardNewMacro(vtkDentSimBatchPlan);

vtkDentSimBatchPlan::vtkDentSimBatchPlan() { this->SetNumberOfInputPorts(0); }

vtkDentSimBatchPlan::~vtkDentSimBatchPlan() {
  this->SetManifestFile(nullptr);
  this->SetOutputDirectory(nullptr);
}

int vtkDentSimBatchPlan::RequestInformation(vtkInformation*, vtkInformationVector**,
                                            vtkInformationVector* outputVector) {
  // Each rank's piece is its shard of the cases.
  outputVector->GetInformationObject(0)->Set(CAN_HANDLE_PIECE_REQUEST(), 1);
  return 1;
}

int vtkDentSimBatchPlan::RequestData(vtkInformation*, vtkInformationVector**,
                                     vtkInformationVector* outputVector) {
  vtkInformation* info = outputVector->GetInformationObject(0);
  vtkTable* table = vtkTable::GetData(outputVector, 0);
  table->Initialize();
  const int piece = info->Has(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER())
                        ? info->Get(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER())
                        : 0;
  const int pieces = info->Has(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES())
                         ? info->Get(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES())
                         : 1;
  if (this->Step == 1 && piece > 0) return 1;  // one rank writes the report
  const std::string manifest = this->ManifestFile ? this->ManifestFile : "";
  const std::string out = this->OutputDirectory ? this->OutputDirectory : "";
  try {
    auto rows = this->Step == 0
                    ? dentsim::RunJob(this, dentsim::ffi::start_batch_shard(
                                                manifest, out, static_cast<uint32_t>(piece),
                                                static_cast<uint32_t>(pieces > 0 ? pieces : 1)))
                    : dentsim::ffi::batch_merge(manifest, out,
                                                static_cast<uint32_t>(pieces > 0 ? pieces : 1));
    const char* textNames[] = {"Case", "Scan", "Preparation", "Burr", "Tissue"};
    const char* numberNames[] = {"RemovedVolume", "VolumeBefore", "VolumeAfter", "Seconds"};
    vtkNew<vtkStringArray> text[5];
    vtkNew<vtkDoubleArray> numbers[4];
    for (int i = 0; i < 5; ++i) text[i]->SetName(textNames[i]);
    for (int i = 0; i < 4; ++i) numbers[i]->SetName(numberNames[i]);
    for (const auto& r : rows) {
      text[0]->InsertNextValue(std::string(r.case_name));
      text[1]->InsertNextValue(std::string(r.scan));
      text[2]->InsertNextValue(std::string(r.preparation));
      text[3]->InsertNextValue(std::string(r.burr));
      text[4]->InsertNextValue(std::string(r.tissue));
      numbers[0]->InsertNextValue(r.removed_mm3);
      numbers[1]->InsertNextValue(r.volume_before_mm3);
      numbers[2]->InsertNextValue(r.volume_after_mm3);
      numbers[3]->InsertNextValue(r.seconds);
    }
    for (auto& a : text) table->AddColumn(a);
    for (auto& a : numbers) table->AddColumn(a);
  } catch (const rust::Error& e) {
    table->Initialize();
    vtkErrorMacro(<< "DentSim: " << e.what());
    return 0;
  }
  return 1;
}

void vtkDentSimBatchPlan::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "ManifestFile: " << (this->ManifestFile ? this->ManifestFile : "") << "\n";
  os << indent << "OutputDirectory: " << (this->OutputDirectory ? this->OutputDirectory : "") << "\n";
  os << indent << "Step: " << this->Step << "\n";
}
