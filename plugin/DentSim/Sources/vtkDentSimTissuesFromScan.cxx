#include "vtkDentSimTissuesFromScan.h"

#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkMatrix3x3.h>
#include <vtkMultiBlockDataSet.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <vector>

#include "vtkDentSimSurfaces.h"

vtkStandardNewMacro(vtkDentSimTissuesFromScan);

vtkDentSimTissuesFromScan::vtkDentSimTissuesFromScan() { this->SetNumberOfInputPorts(1); }

int vtkDentSimTissuesFromScan::FillInputPortInformation(int, vtkInformation* info) {
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  return 1;
}

int vtkDentSimTissuesFromScan::RequestUpdateExtent(vtkInformation*,
                                                   vtkInformationVector** inputVector,
                                                   vtkInformationVector* outputVector) {
  // Segmentation needs the whole scan: the rank asked for piece 0 reads all of it, the others
  // nothing (under MPI a reader would otherwise hand each rank a slab).
  vtkInformation* in = inputVector[0]->GetInformationObject(0);
  if (dentsim::IsPieceZero(outputVector)) {
    in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_PIECE_NUMBER(), 0);
    in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_NUMBER_OF_PIECES(), 1);
    if (in->Has(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT())) {
      in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(),
              in->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT()), 6);
    }
  } else {
    const int empty[6] = {0, -1, 0, -1, 0, -1};
    in->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), empty, 6);
  }
  return 1;
}

int vtkDentSimTissuesFromScan::RequestData(vtkInformation*, vtkInformationVector** inputVector,
                                         vtkInformationVector* outputVector) {
  vtkMultiBlockDataSet::GetData(outputVector, 0)->Initialize();
  if (!dentsim::IsPieceZero(outputVector)) return 1;
  vtkImageData* image = vtkImageData::GetData(inputVector[0], 0);
  vtkDataArray* scalars = image ? image->GetPointData()->GetScalars() : nullptr;
  if (!scalars) {
    vtkErrorMacro(<< "DentSim: the input image has no point scalars (grey values)");
    return 0;
  }
  if (scalars->GetNumberOfComponents() != 1) {
    vtkErrorMacro(<< "DentSim: the input array '" << (scalars->GetName() ? scalars->GetName() : "")
                  << "' has " << scalars->GetNumberOfComponents()
                  << " components; a CBCT scan has one");
    return 0;
  }
  int dims[3];
  image->GetDimensions(dims);
  dentsim::ffi::ImageGeometry geometry{};
  const double* spacing = image->GetSpacing();
  const double* origin = image->GetOrigin();
  vtkMatrix3x3* direction = image->GetDirectionMatrix();
  for (int r = 0; r < 3; ++r) {
    geometry.dims[r] = static_cast<uint32_t>(dims[r]);
    geometry.spacing[r] = spacing[r];
    geometry.origin[r] = origin[r];
    for (int c = 0; c < 3; ++c) geometry.direction[3 * r + c] = direction->GetElement(r, c);
  }
  const vtkIdType n = scalars->GetNumberOfTuples();
  std::vector<float> values(static_cast<size_t>(n));
  for (vtkIdType i = 0; i < n; ++i) values[i] = static_cast<float>(scalars->GetComponent(i, 0));

  dentsim::ffi::TissuesFromScanParams params{};
  params.voxel_size_mm = this->VoxelSize;
  params.fdi = static_cast<uint8_t>(this->Tooth > 0 && this->Tooth < 256 ? this->Tooth : 0);
  params.use_seed = this->UseSeedPoint;
  for (int i = 0; i < 3; ++i) params.seed_mm[i] = this->SeedPoint[i];
  try {
    dentsim::FillTissueBlocks(
        dentsim::RunJob(this, dentsim::ffi::start_tissues_from_scan(
                                  geometry, rust::Slice<const float>(values.data(), values.size()),
                                  params)),
        vtkMultiBlockDataSet::GetData(outputVector, 0));
  } catch (const rust::Error& e) {
    vtkMultiBlockDataSet::GetData(outputVector, 0)->Initialize();
    vtkErrorMacro(<< "DentSim: " << e.what());
    return 0;
  }
  return 1;
}

void vtkDentSimTissuesFromScan::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "VoxelSize: " << this->VoxelSize << " mm\n";
  os << indent << "Tooth: " << this->Tooth << "\n";
  os << indent << "UseSeedPoint: " << this->UseSeedPoint << "\n";
  os << indent << "SeedPoint: " << this->SeedPoint[0] << " " << this->SeedPoint[1] << " "
     << this->SeedPoint[2] << " mm\n";
}
