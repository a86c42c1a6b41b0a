#pragma once
// The frame's sky message (sim/msg/sky.h) from the sky model and the Sun/Moon state: the Moon's
// beam and disk, the diffuse lunar and night-sky irradiance, and the sky radiance in view on the
// atmosphere table's grid, in the renderer's two bands.

#include <array>

#include "sim/msg/sky.h"
#include "sim/sky/sky_model.h"

namespace nvs::sky {

static_assert(msg::kSkyViewZeniths == AtmosphereTable::kViewZeniths &&
                  msg::kSkyAzimuths == AtmosphereTable::kAzimuths,
              "the frame's sky radiance grid is the atmosphere table's");

// tableBand[b] is the atmosphere table's band for renderer band b. lunarSkyScale multiplies the
// Moon's light scattered by the atmosphere (diffuse irradiance and sky radiance in view): 1 is
// the physics, 0 leaves it out as the thesis's atmosphere builder did (its Table 8-3). No
// allocation, no throw.
msg::FrameSky frameSky(const SkyModel& model, const std::array<int, msg::kBands>& tableBand,
                       const msg::MoonState& moon, double t_sample_s,
                       double lunarSkyScale = 1.0) noexcept;

}  // namespace nvs::sky
