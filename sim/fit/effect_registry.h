#pragma once
// Effects added through the registry (docs/diagnose.md, "Adding an effect"): each is one file in
// sim/fit/effects/ that fills a RegisteredEffect — its forward model, its parameters with their
// units and search ranges, the preset keys it writes, its cause line, and how the hidden-effect
// generator (generate.h) hides it in a camera — and is listed once, in registeredEffects()
// (effect_registry.cpp). diagnose tries every registered effect the model under test lacks in
// each greedy round beside the catalog's own (diagnose.cpp), with the generic fit and score of
// tryRegistered; the generator hides any registered effect by name; `nvs_validate_diagnose`
// sweeps it. Nothing else is edited to add one.
//
// A registered effect is a mean effect that acts on the assembled frames last, after the
// CCD's smear: a stage of the video path (the digitiser's line filter, a grabber's gain curve).

#include <string>
#include <utility>
#include <vector>

#include "sim/fit/effects.h"
#include "sim/sensor/camera.h"

namespace nvs::fit {

struct EffectParameter {
    const char* name;  // the finding's parameter and the truth key's suffix
    const char* key;   // the chain's preset key ("section.key") that holds it
    const char* unit;
    double lo, hi;          // the fit's search range (log spaced); a fit at its edge is rejected
    double hideLo, hideHi;  // the hidden-effect generator's range (drawn uniformly)
};

struct RegisteredEffect {
    const char* name;
    const char* stage;  // the camera chain's stage that implements it (docs/sensor.md)
    std::vector<EffectParameter> parameters;
    // Whether the camera of the model under test has it on (then it is not tried).
    bool (*present)(const sensor::CameraParams& cam);
    // The forward model: the assembled frames S [model DC above offset] with parameters p.
    void (*apply)(const Work& w, const std::vector<double>& p, std::vector<Plane>& S);
    // One line an engineer reads.
    std::string (*cause)(const std::vector<double>& p);
};

// The one table of registered effects.
const std::vector<const RegisteredEffect*>& registeredEffects();
const RegisteredEffect* findRegistered(const std::string& name);

// The preset keys ("section.key", TOML value) that switch e on with parameters p: each
// parameter's key with its value (a parameter different from 0 turns the chain's stage on).
std::vector<std::pair<std::string, std::string>> registeredPresetKeys(const RegisteredEffect& e,
                                                                      const std::vector<double>& p);

// Fits effect e on top of cur (each parameter by a log search, the others held, two rounds),
// gain and offset refitted with it on the calibration frames, scored on the held-out frames as
// the catalog's mean effects are; valid when every parameter lies inside its range.
Candidate tryRegistered(Work& w, const Current& cur, const RegisteredEffect& e);

// The registered effects of mm applied to S, in the order they were taken (engine.cpp, predict).
void applyRegistered(const Work& w, const MeanModel& mm, std::vector<Plane>& S);

}  // namespace nvs::fit
