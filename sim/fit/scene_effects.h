#pragma once
// The scenario effects of the catalog (docs/diagnose.md, "Scenario effects"), tried when the
// stimulus is rendered from a scenario (`[stimulus] scenario`) that lacks them:
//   lunar_sky_scatter   the Moon's light scattered by the atmosphere, scaled by s
//                       ([atmosphere] lunar_sky_scale = 0 in the model): L0 + s·(L1 − L0), the
//                       renderer being linear in it
//   refraction          the Moon raised by atmospheric refraction for a site pressure P
//                       ([site] pressure_hPa = 0 in the model): the scene rendered again
//   cloud_transmission  a grey cloud layer of optical depth τ ([atmosphere]
//                       cloud_optical_depth = 0 in the model): the scene rendered again
//   aerosol_extinction  the aerosol's extinction for another meteorological range V
//                       ([atmosphere] visibility_km, Koschmieder; tried whatever the
//                       scenario states): the scene rendered again
// Each is fitted on the calibration frames (the camera's gain and offset refitted with it) and
// scored on the held-out frames like the camera's mean effects. They change the stimulus, so
// they are tried first, on the baseline; the camera's effects are then tried on the stimulus
// with the scenario effects found.

#include <functional>
#include <vector>

#include "sim/fit/effects.h"

namespace nvs::fit {

struct SceneFit {
    SkyEffects fx;                // the scenario's values with the findings applied
    std::vector<ImageF> stimuli;  // rendered with fx; empty when nothing was found
};

// Records an effect's trial in the result (tried or not, and why).
using RecordTrial = std::function<void(const Candidate&, bool tried)>;

// Greedy over the four (best significant first, the others tried again on top of it); each
// trial passed to `record`, each finding appended to r.findings.
SceneFit trySceneEffects(Work& w, const Current& base, Result& r, const RecordTrial& record,
                         const Progress& progress);

}  // namespace nvs::fit
