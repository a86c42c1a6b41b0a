#pragma once
// Device and telemetry factories for `nvstim run` (kept apart so run.cpp stays readable).

#include <atomic>
#include <filesystem>
#include <memory>
#include <string>

#include "rt/compose/scenario.h"
#include "rt/loop/frame_loop.h"
#include "rt/loop/stages.h"
#include "rt/run/run.h"

namespace nvs::rt {

// v4l2:/dev/videoN[?format=GREY|Y16|YUYV&io=write|mmap], gpio:CHIP:LINE[?active=high|low];
// nullptr for an unknown scheme.
std::unique_ptr<FrameSink> makeDeviceSink(Spec& spec, const Scenario& sc, const std::string& what);
// gpio:CHIP:LINE → a trigger input (rising edges); throws SetupError naming `what`.
std::unique_ptr<TriggerSource> makeTrigger(const std::string& spec, const std::string& what);
// replay:FILE[?dbc=FILE], can:IFACE[?dbc=FILE&fd=1&record=FILE&idle_s=S],
// serial:DEV?baud=N&proto=nmea|mavlink. The DBC file defaults to <configDir>/can/nvstim.dbc.
// can: under the sim clock runs in lockstep with the telemetry's time signal; `stop` ends its
// waiting (nullptr: none).
std::unique_ptr<PlatformSource> makeTelemetrySource(Spec& spec, const Scenario& sc, ClockKind clock,
                                                    const std::string& what,
                                                    const std::filesystem::path& configDir,
                                                    const std::atomic<bool>* stop = nullptr);

}  // namespace nvs::rt
