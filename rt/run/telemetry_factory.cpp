#include "rt/run/telemetry_factory.h"

#include "sim/core/error.h"

namespace nvs::rt {

std::unique_ptr<FrameSink> makeDeviceSink(Spec& /*spec*/, const Scenario& /*sc*/,
                                          const std::string& /*what*/) {
    return nullptr;
}

std::unique_ptr<PlatformSource> makeTelemetrySource(Spec& spec, const Scenario& /*sc*/,
                                                    ClockKind /*clock*/, const std::string& what) {
    throw SetupError(what + ": unknown telemetry scheme '" + spec.scheme + "'");
}

}  // namespace nvs::rt
