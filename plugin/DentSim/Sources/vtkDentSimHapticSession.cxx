#include "vtkDentSimHapticSession.h"

#include <vtkCellArray.h>
#include <vtkCompositeDataSet.h>
#include <vtkDoubleArray.h>
#include <vtkCellData.h>
#include <vtkFieldData.h>
#include <vtkIntArray.h>
#include <vtkUnsignedCharArray.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkMultiBlockDataSet.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>
#include <vtkStringArray.h>
#include <vtkTable.h>
#include <vtkUnsignedCharArray.h>

#include <cmath>
#include <cstdint>
#include <optional>

#include "vtkDentSimSurfaces.h"

// The Rust session and what was last shown; kept out of the header (no Rust types there).
struct vtkDentSimHapticSession::Internals {
  std::optional<rust::Box<dentsim::ffi::HapticSession>> Session;
  std::string StartedWith;  // the parameters the running session was started with
  vtkSmartPointer<vtkMultiBlockDataSet> Tissues;
  uint64_t MeshGeneration = 0;
  bool ShownFinal = false;
  bool StopRequested = false;
  // The force over time, one row per update that saw a new tick.
  vtkSmartPointer<vtkTable> History;
  uint64_t LastTick = UINT64_MAX;
};

vtkStandardNewMacro(vtkDentSimHapticSession);

vtkDentSimHapticSession::vtkDentSimHapticSession() : Internal(new Internals) {
  this->SetNumberOfInputPorts(0);
  this->SetNumberOfOutputPorts(2);
  const auto d = dentsim::ffi::default_session();
  this->PhantomVoxelSize = d.phantom_voxel_mm;
  this->SetProfile(std::string(d.profile).c_str());
  this->SetFilter(std::string(d.filter).c_str());
  this->SetBurr(std::string(d.burr).c_str());
  this->SetHandParameters("start=0:0:5.6,target=0:0:2.5,push=1,pedal=1,duration=10");
  this->SetSpaceMouseParameters("");
  this->SetOpenIGTLinkURL("igtl://127.0.0.1:18944");
  this->SetPedalKey("b");
  this->SetSessionLog("");
  this->RealTime = d.realtime;
}

vtkDentSimHapticSession::~vtkDentSimHapticSession() {
  delete this->Internal;  // drops the session: stops and joins its threads
  this->SetTissuesFile(nullptr);
  this->SetScriptedPath(nullptr);
  this->SetHandParameters(nullptr);
  this->SetSpaceMouseParameters(nullptr);
  this->SetOpenIGTLinkURL(nullptr);
  this->SetPedalKey(nullptr);
  this->SetSessionLog(nullptr);
  this->SetProfile(nullptr);
  this->SetFilter(nullptr);
  this->SetBurr(nullptr);
}

bool vtkDentSimHapticSession::GetNeedsUpdate() {
  if (!this->Internal->Session || this->Internal->ShownFinal) {
    return false;
  }
  this->Modified();
  return true;
}

int vtkDentSimHapticSession::FillOutputPortInformation(int port, vtkInformation* info) {
  if (port == 1) {
    info->Set(vtkDataObject::DATA_TYPE_NAME(), "vtkTable");
    return 1;
  }
  return this->Superclass::FillOutputPortInformation(port, info);
}

vtkMTimeType vtkDentSimHapticSession::GetMTime() {
  const vtkMTimeType t = this->Superclass::GetMTime();
  if (this->Internal && this->Internal->Session && !this->Internal->ShownFinal) {
    // Still running: news may be waiting, so every update polls (pvpython needs no timer).
    this->Modified();
    return this->Superclass::GetMTime();
  }
  return t;
}

void vtkDentSimHapticSession::Stop() {
  if (this->Internal->Session && !this->Internal->ShownFinal) {
    this->Internal->StopRequested = true;
    this->Modified();
  }
}

namespace {

std::string Str(const char* s) { return s ? s : ""; }

// A constant RGB colour for every point of `pd` (point array `Colour`, shown with Map Scalars off).
void Paint(vtkPolyData* pd, unsigned char r, unsigned char g, unsigned char b) {
  vtkNew<vtkUnsignedCharArray> c;
  c->SetName("Colour");
  c->SetNumberOfComponents(3);
  for (vtkIdType i = 0; i < pd->GetNumberOfPoints(); ++i) c->InsertNextTuple3(r, g, b);
  pd->GetPointData()->AddArray(c);
}

// A live device's workspace on the scan: three great circles of the sphere it reaches.
vtkSmartPointer<vtkPolyData> Workspace(const dentsim::ffi::SessionState& s) {
  const double* c = s.workspace_centre_mm.data();
  const double r = s.workspace_radius_mm;
  constexpr int n = 96;
  vtkNew<vtkPoints> points;
  vtkNew<vtkCellArray> lines;
  for (int plane = 0; plane < 3; ++plane) {
    lines->InsertNextCell(n + 1);
    for (int i = 0; i <= n; ++i) {
      const double a = 2.0 * 3.14159265358979323846 * (i % n) / n;
      double p[3] = {c[0], c[1], c[2]};
      p[plane] += r * std::cos(a);
      p[(plane + 1) % 3] += r * std::sin(a);
      lines->InsertCellPoint(points->InsertNextPoint(p));
    }
  }
  auto pd = vtkSmartPointer<vtkPolyData>::New();
  pd->SetPoints(points);
  pd->SetLines(lines);
  return pd;
}

vtkSmartPointer<vtkTable> NewHistory() {
  auto t = vtkSmartPointer<vtkTable>::New();
  for (const char* name : {"Time", "Force", "Fx", "Fy", "Fz"}) {
    vtkNew<vtkDoubleArray> a;
    a->SetName(name);
    t->AddColumn(a);
  }
  vtkNew<vtkStringArray> contact;
  contact->SetName("ContactTissue");
  t->AddColumn(contact);
  return t;
}

void AddField(vtkFieldData* fd, const char* name, double value) {
  vtkNew<vtkDoubleArray> a;
  a->SetName(name);
  a->InsertNextValue(value);
  fd->AddArray(a);
}

// A line from the burr centre along the force (10 mm per N), `Force` (N) at both ends.
vtkSmartPointer<vtkPolyData> ForceArrow(const dentsim::ffi::SessionState& s, double burrRadius) {
  const double c[3] = {s.burr_position_mm[0], s.burr_position_mm[1], s.burr_position_mm[2] + burrRadius};
  vtkNew<vtkPoints> points;
  points->InsertNextPoint(c);
  constexpr double mmPerN = 10.0;  // contact forces are ~0.1–3 N; the burr head is ~1 mm
  points->InsertNextPoint(c[0] + mmPerN * s.force_n[0], c[1] + mmPerN * s.force_n[1],
                          c[2] + mmPerN * s.force_n[2]);
  vtkNew<vtkCellArray> lines;
  const vtkIdType ids[2] = {0, 1};
  lines->InsertNextCell(2, ids);
  vtkNew<vtkDoubleArray> force;
  force->SetName("Force");
  force->SetNumberOfComponents(3);
  force->InsertNextTuple3(s.force_n[0], s.force_n[1], s.force_n[2]);
  force->InsertNextTuple3(s.force_n[0], s.force_n[1], s.force_n[2]);
  auto pd = vtkSmartPointer<vtkPolyData>::New();
  pd->SetPoints(points);
  pd->SetLines(lines);
  pd->GetPointData()->SetVectors(force);
  return pd;
}

// Every cell's `Tissue` label: the default colour map (the tissue table's, categorical) colours
// the session's burr and force arrow as it colours the tissues.
void SetLabel(vtkPolyData* pd, int label) {
  vtkNew<vtkIntArray> tissue;
  tissue->SetName("Tissue");
  tissue->SetNumberOfTuples(pd->GetNumberOfCells());
  tissue->FillValue(label);
  pd->GetCellData()->SetScalars(tissue);
}

// The burr's `Colour` from live guidance: steel when clear, amber within the thin-dentin
// threshold of the pulp, magenta-red in it (the force arrow is plain red); its level as field data.
void AddGuidance(vtkPolyData* burr, const dentsim::ffi::SessionState& s) {
  if (!burr) return;
  static const unsigned char colours[3][3] = {{140, 150, 170}, {255, 170, 0}, {230, 0, 120}};
  const unsigned char* c = colours[s.warning_level < 3 ? s.warning_level : 2];
  Paint(burr, c[0], c[1], c[2]);
  AddField(burr->GetFieldData(), "GuidanceLevel", double(s.warning_level));
  SetLabel(burr, dentsim::ffi::burr_label(s.warning_level));
}

}  // namespace

int vtkDentSimHapticSession::RequestData(vtkInformation*, vtkInformationVector**,
                                         vtkInformationVector* outputVector) {
  auto* output = vtkMultiBlockDataSet::GetData(outputVector, 0);
  if (!dentsim::IsPieceZero(outputVector)) {
    output->Initialize();  // one session, on the rank asked for piece 0
    return 1;
  }
  auto& in = *this->Internal;
  dentsim::ffi::SessionParams params = dentsim::ffi::default_session();
  params.tissues_path = Str(this->TissuesFile);
  params.phantom_voxel_mm = this->PhantomVoxelSize;
  std::string device;
  switch (this->DeviceKind) {
    case 0: device = "scripted:" + Str(this->ScriptedPath); break;
    case 2: device = Str(this->SpaceMouseParameters).empty() ? "spacemouse" : "spacemouse:" + Str(this->SpaceMouseParameters); break;
    case 3: device = Str(this->OpenIGTLinkURL); break;
    default: device = "hand:" + Str(this->HandParameters); break;
  }
  if (this->FootPedal) device += "+pedal:key=" + Str(this->PedalKey);
  params.device = device;
  params.log_path = Str(this->SessionLog);
  params.profile = Str(this->Profile);
  params.filter = Str(this->Filter);
  params.realtime = this->RealTime;
  params.burr = Str(this->Burr);
  const std::string signature = std::string(params.tissues_path) + "|" +
    std::to_string(params.phantom_voxel_mm) + "|" + std::string(params.device) + "|" +
    std::string(params.profile) + "|" + std::string(params.filter) + "|" +
    std::string(params.burr) + "|" + (params.realtime ? "rt" : "batch") + "|" +
    std::string(params.log_path);
  try {
    if (!in.Session || in.StartedWith != signature) {
      in.Session.reset();  // stop the old one first
      in.Tissues = nullptr;
      in.MeshGeneration = 0;
      in.ShownFinal = false;
      in.StopRequested = false;
      in.History = NewHistory();
      in.LastTick = UINT64_MAX;
      in.StartedWith = signature;
      in.Session.emplace(dentsim::ffi::start_session(params));
    }
    auto& session = **in.Session;
    const bool stop = in.StopRequested;
    in.StopRequested = false;
    session.set_paused(this->Paused);
    const auto state = stop ? session.stop() : session.poll();
    if (!in.Tissues || state.mesh_generation != in.MeshGeneration) {
      in.Tissues = vtkSmartPointer<vtkMultiBlockDataSet>::New();
      dentsim::FillTissueBlocks(session.tissue_surfaces(), in.Tissues);
      in.MeshGeneration = state.mesh_generation;
    }
    rust::Vec<dentsim::ffi::TissueSurface> burr;
    burr.push_back(session.burr_surface());
    vtkNew<vtkMultiBlockDataSet> burrBlock;
    dentsim::FillTissueBlocks(burr, burrBlock);

    const unsigned int n = in.Tissues->GetNumberOfBlocks();
    const bool live = state.workspace_radius_mm > 0.0;
    output->SetNumberOfBlocks(n + (live ? 3 : 2));
    for (unsigned int i = 0; i < n; ++i) {
      output->SetBlock(i, in.Tissues->GetBlock(i));
      output->GetMetaData(i)->Set(vtkCompositeDataSet::NAME(),
                                  in.Tissues->GetMetaData(i)->Get(vtkCompositeDataSet::NAME()));
    }
    auto* burrSurface = burrBlock->GetBlock(0);
    AddGuidance(vtkPolyData::SafeDownCast(burrSurface), state);
    output->SetBlock(n, burrSurface);
    output->GetMetaData(n)->Set(vtkCompositeDataSet::NAME(), "burr");
    auto arrow = ForceArrow(state, 0.5);
    Paint(arrow, 220, 30, 30);
    SetLabel(arrow, dentsim::ffi::force_label());
    output->SetBlock(n + 1, arrow);
    output->GetMetaData(n + 1)->Set(vtkCompositeDataSet::NAME(), "force");
    if (live) {
      auto workspace = Workspace(state);
      Paint(workspace, 60, 120, 220);
      output->SetBlock(n + 2, workspace);
      output->GetMetaData(n + 2)->Set(vtkCompositeDataSet::NAME(), "workspace");
    }

    vtkFieldData* fd = output->GetFieldData();
    vtkNew<vtkStringArray> contact;
    contact->SetName("ContactTissue");
    contact->InsertNextValue(std::string(state.contact_tissue));
    fd->AddArray(contact);
    arrow->GetFieldData()->AddArray(contact);
    AddField(fd, "Tick", double(state.tick));
    AddField(fd, "Time", state.time_s);
    AddField(fd, "Running", state.running ? 1.0 : 0.0);
    // Live guidance: tissue left over the pulp (NaN when far), the warning level, the events.
    AddField(fd, "RemainingDentinMm", state.remaining_dentin_mm);
    AddField(fd, "GuidanceLevel", double(state.warning_level));
    AddField(fd, "ThinDentinThresholdMm", state.thin_dentin_mm);
    AddField(fd, "ThinDentinEvents", double(state.thin_dentin_events));
    AddField(fd, "PulpExposureEvents", double(state.pulp_exposure_events));
    in.ShownFinal = !state.running;
    if (state.tick != in.LastTick) {
      in.LastTick = state.tick;
      const double f[3] = {state.force_n[0], state.force_n[1], state.force_n[2]};
      const double values[5] = {state.time_s, std::sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]), f[0], f[1], f[2]};
      for (int c = 0; c < 5; ++c) vtkDoubleArray::SafeDownCast(in.History->GetColumn(c))->InsertNextValue(values[c]);
      vtkStringArray::SafeDownCast(in.History->GetColumn(5))->InsertNextValue(std::string(state.contact_tissue));
    }
    auto* history = vtkTable::GetData(outputVector, 1);
    history->ShallowCopy(in.History);
  } catch (const rust::Error& e) {
    in.Session.reset();
    in.ShownFinal = true;
    vtkErrorMacro(<< "DentSim: " << e.what());
    return 0;
  }
  return 1;
}

void vtkDentSimHapticSession::PrintSelf(ostream& os, vtkIndent indent) {
  this->Superclass::PrintSelf(os, indent);
  os << indent << "TissuesFile: " << Str(this->TissuesFile) << "\n";
  os << indent << "DeviceKind: " << this->DeviceKind << "\n";
  os << indent << "ScriptedPath: " << Str(this->ScriptedPath) << "\n";
  os << indent << "HandParameters: " << Str(this->HandParameters) << "\n";
  os << indent << "Profile: " << Str(this->Profile) << " Filter: " << Str(this->Filter)
     << " RealTime: " << this->RealTime << "\n";
  os << indent << "Burr: " << Str(this->Burr) << "\n";
}
