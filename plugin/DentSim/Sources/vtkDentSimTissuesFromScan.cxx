#include "vtkDentSimTissuesFromScan.h"

#include <vtkDICOMImageReader.h>
#include <vtkDataArray.h>
#include <vtkDataSetAttributes.h>
#include <vtkFieldData.h>
#include <vtkFileSeriesReader.h>
#include <vtkImageData.h>
#include <vtkImageReader2.h>
#include <vtkStringArray.h>
#include <vtksys/SystemTools.hxx>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkMatrix3x3.h>
#include <vtkMultiBlockDataSet.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <algorithm>
#include <string>
#include <vector>

#include "vtkDentSimSurfaces.h"

vtkStandardNewMacro(vtkDentSimTissuesFromScan);

vtkDentSimTissuesFromScan::vtkDentSimTissuesFromScan() {
  this->SetNumberOfInputPorts(1);
  // the grey values: the image's point scalars unless another array is chosen
  this->SetInputArrayToProcess(0, 0, 0, vtkDataObject::FIELD_ASSOCIATION_POINTS,
                               vtkDataSetAttributes::SCALARS);
}

vtkDentSimTissuesFromScan::~vtkDentSimTissuesFromScan() { this->SetThresholds(nullptr); }

namespace {
// `path` if dentsim reads its format (by its extension), else empty.
std::string Readable(const std::string& path) {
  const std::string lower = vtksys::SystemTools::LowerCase(path);
  for (const std::string tail : {".nii", ".nii.gz", ".mha", ".mhd", ".dcm"}) {
    if (lower.size() >= tail.size() && lower.compare(lower.size() - tail.size(), tail.size(), tail) == 0) {
      return path;
    }
  }
  return std::string();
}

// The scan file behind a reader dentsim reads too (a DICOM folder or file, NIfTI, MetaImage);
// empty for any other producer.
std::string ScanFileOf(vtkAlgorithm* producer) {
  // ParaView puts a post filter (array conversions) after a reader's port: look past it.
  while (producer && producer->IsA("vtkPVPostFilter") && producer->GetNumberOfInputConnections(0) > 0) {
    producer = producer->GetInputAlgorithm(0, 0);
  }
  if (auto* dicom = vtkDICOMImageReader::SafeDownCast(producer)) {
    const char* dir = dicom->GetDirectoryName();
    const char* file = dicom->GetFileName();
    return dir && *dir ? std::string(dir) : std::string(file ? file : "");
  }
  if (auto* series = vtkFileSeriesReader::SafeDownCast(producer)) {
    if (vtkDICOMImageReader::SafeDownCast(series->GetReader())) return ScanFileOf(series->GetReader());
    const char* current = series->GetCurrentFileName();
    return current && *current ? Readable(current) : ScanFileOf(series->GetReader());
  }
  auto* reader = vtkImageReader2::SafeDownCast(producer);
  return reader && reader->GetFileName() ? Readable(reader->GetFileName()) : std::string();
}
}  // namespace

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
  vtkDataArray* scalars = image ? this->GetInputArrayToProcess(0, inputVector) : nullptr;
  const std::string scanFile = this->ReadScanFile ? ScanFileOf(this->GetInputAlgorithm(0, 0)) : std::string();
  if (!scalars && scanFile.empty()) {
    vtkErrorMacro(<< "DentSim: the input image has no point array of grey values"
                  << " (Grey Values chooses one)");
    return 0;
  }
  if (scanFile.empty() && scalars->GetNumberOfComponents() != 1) {
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
  // The file is read again by dentsim: no copy of the image's values is needed then.
  const vtkIdType n = scanFile.empty() ? scalars->GetNumberOfTuples() : 0;
  std::vector<float> values(static_cast<size_t>(n));
  for (vtkIdType i = 0; i < n; ++i) values[i] = static_cast<float>(scalars->GetComponent(i, 0));

  dentsim::ffi::TissuesFromScanParams params{};
  params.voxel_size_mm = this->VoxelSize;
  params.fdi = static_cast<uint8_t>(this->Tooth > 0 && this->Tooth < 256 ? this->Tooth : 0);
  params.use_seed = this->UseSeedPoint;
  for (int i = 0; i < 3; ++i) params.seed_mm[i] = this->SeedPoint[i];
  params.keep_shading = this->KeepShading;
  vtkMultiBlockDataSet* output = vtkMultiBlockDataSet::GetData(outputVector, 0);
  const rust::Slice<const float> grey(values.data(), values.size());
  const char* thresholds = this->Thresholds ? this->Thresholds : "";
  std::vector<vtkMultiBlockDataSet*> tissueSets;  // the blocks holding tissues
  try {
    // On a thread of the core, for ParaView's progress bar and Abort.
    if (this->AllTeeth) {
      const auto teeth = dentsim::RunJob(
          this, dentsim::ffi::start_teeth_from_scan(geometry, grey, params, scanFile, thresholds));
      output->SetNumberOfBlocks(static_cast<unsigned int>(teeth.size()));
      unsigned int b = 0;
      for (const auto& tooth : teeth) {
        vtkNew<vtkMultiBlockDataSet> block;
        dentsim::FillTissueBlocks(tooth.tissues, block);
        dentsim::ReportWarnings(this, tooth.tissues);
        output->SetBlock(b, block);
        std::string name = "tooth " + std::to_string(tooth.tooth);
        if (tooth.cut_by_field_of_view) name += " (cut by the field of view)";
        output->GetMetaData(b)->Set(vtkCompositeDataSet::NAME(), name.c_str());
        tissueSets.push_back(block);
        ++b;
      }
    } else {
      const auto surfaces =
          dentsim::RunJob(this, dentsim::ffi::start_tissues_from_scan(geometry, grey, params, scanFile, thresholds));
      dentsim::FillTissueBlocks(surfaces, output);
      dentsim::ReportWarnings(this, surfaces);
      tissueSets.push_back(output);
    }
  } catch (const rust::Error& e) {
    vtkMultiBlockDataSet::GetData(outputVector, 0)->Initialize();
    vtkErrorMacro(<< "DentSim: " << e.what());
    return 0;
  }
  // Say which grey values were segmented, and in which frame.
  const std::string source =
      scanFile.empty()
          ? std::string("input array '") + (scalars->GetName() ? scalars->GetName() : "") +
                "' in the image's frame"
          : "read through dentsim's reader from " + scanFile +
                " (patient LPS frame, as dentsim segment; the reader's image lacks its orientation, "
                "origin or sign)";
  for (vtkMultiBlockDataSet* set : tissueSets) {
    for (unsigned int b = 0; b < set->GetNumberOfBlocks(); ++b) {
      vtkDataObject* block = set->GetBlock(b);
      if (!block) continue;
      vtkNew<vtkStringArray> note;
      note->SetName("ScanSource");
      note->InsertNextValue(source);
      block->GetFieldData()->AddArray(note);
    }
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
  os << indent << "ReadScanFile: " << this->ReadScanFile << "\n";
  os << indent << "AllTeeth: " << this->AllTeeth << "\n";
  os << indent << "Thresholds: " << (this->Thresholds ? this->Thresholds : "") << "\n";
  os << indent << "KeepShading: " << this->KeepShading << "\n";
}
