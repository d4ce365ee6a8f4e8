// The default look, set when the plugin loads on a client (GUI, pvpython, pvbatch): ParaView
// colours DentSim outputs by their cell array `Tissue`; these settings make the colour map it
// creates for that array categorical, with each tissue's colour, opacity and name from the
// tissue table (enamel translucent, a legend of names). A user's or site's own default for
// `Tissue` (Color Map Editor → save as default for this array) outranks it.
#include <vtkSMSettings.h>

#include "rust/cxx.h"
#include "dentsim-ffi/src/lib.rs.h"

namespace {

// Below the settings files ParaView reads (site 0 and up, user above), so theirs win.
constexpr double kPriority = -1.0;

struct TissueColourDefaults {
  TissueColourDefaults() {
    const rust::String json = dentsim::ffi::tissue_colour_settings();
    vtkSMSettings::GetInstance()->AddCollectionFromString(std::string(json), kPriority);
  }
};

const TissueColourDefaults registered;

}  // namespace
