#include "vtkDentSimPhantomStroke.h"

#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkMultiBlockDataSet.h>
#include <vtkObjectFactory.h>

#include "vtkDentSimSurfaces.h"

vtkStandardNewMacro(vtkDentSimPhantomStroke);

vtkDentSimPhantomStroke::vtkDentSimPhantomStroke() {
  this->SetNumberOfInputPorts(0);
  const auto d = dentsim::ffi::default_stroke();
  this->VoxelSize = d.voxel_size_mm;
  this->BurrDiameter = d.burr_diameter_mm;
  for (int i = 0; i < 3; ++i) {
    this->StrokeStart[i] = d.start_mm[i];
    this->StrokeEnd[i] = d.end_mm[i];
  }
}

int vtkDentSimPhantomStroke::RequestData(vtkInformation*, vtkInformationVector**,
                                         vtkInformationVector* outputVector) {
  auto* output = vtkMultiBlockDataSet::GetData(outputVector, 0);
  output->Initialize();
  if (!dentsim::IsPieceZero(outputVector)) return 1;
  dentsim::ffi::StrokeParams params{};
  params.voxel_size_mm = this->VoxelSize;
  params.burr_diameter_mm = this->BurrDiameter;
  for (int i = 0; i < 3; ++i) {
    params.start_mm[i] = this->StrokeStart[i];
    params.end_mm[i] = this->StrokeEnd[i];
  }
  try {
    dentsim::FillTissueBlocks(dentsim::ffi::phantom_stroke(params), output);
  } catch (const rust::Error& e) {
    vtkErrorMacro(<< "DentSim: " << e.what());
    return 0;
  }
  return 1;
}

void vtkDentSimPhantomStroke::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "VoxelSize: " << this->VoxelSize << " mm\n";
  os << indent << "BurrDiameter: " << this->BurrDiameter << " mm\n";
  os << indent << "StrokeStart: " << this->StrokeStart[0] << " " << this->StrokeStart[1] << " "
     << this->StrokeStart[2] << " mm\n";
  os << indent << "StrokeEnd: " << this->StrokeEnd[0] << " " << this->StrokeEnd[1] << " "
     << this->StrokeEnd[2] << " mm\n";
}
