#pragma once
// The nvstimsrc element's settings as plain C++ (no GStreamer here): its properties, turned into
// the options of the run it pulls frames from (rt/session), the data folders it reads, and the
// time stamps of a pulled frame (docs/gstreamer.md).

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "rt/session/session.h"
#include "sim/core/paths.h"

namespace nvs::gst {

// The element's properties as set (an empty string: not set).
struct SrcSettings {
    std::string scenario;
    std::string channel;
    rt::ClockKind clock = rt::ClockKind::Wall;  // `nvstim run --clock`'s default
    std::int64_t frames = -1;                   // -1: the scenario's duration
    std::string camera;
    std::string sets;  // "KEY=VALUE,KEY=VALUE" or with ';'
    std::string telemetry;
    std::string configDir;
    std::string cacheDir;
};

// The `set` property: KEY=VALUE items separated by ',' or ';', blanks around each item dropped,
// empty items skipped. Each item is checked by sensor::parseOverrides (SetupError naming it).
std::vector<std::string> splitSets(const std::string& text);

// Where the element reads its configuration and keeps its caches (rt/cli/data_dirs.h's rules for
// a library, which has no executable of its own to look beside):
//   config  the config-dir property; else $NVS_CONFIG_DIR; else the config folder of the tree
//           this plugin is installed in (PLUGIN_DIR/<relative path from the plugin folder to
//           DATADIR/nvstim/config>), then the configured install prefix's
//           (CMAKE_INSTALL_FULL_DATADIR/nvstim/config), whichever exists first; else the source
//           tree's config/ the plugin was built from
//   cache   the cache-dir property; else $NVS_CACHE_DIR; else $XDG_CACHE_HOME/nvstim; else
//           $HOME/.cache/nvstim; else <temporary directory>/nvstim-cache
// `pluginDir`: the folder of the loaded plugin ("" where unknown).
DataDirs pluginDataDirs(const SrcSettings& s, const std::filesystem::path& pluginDir);

// The run's options from the settings (throws SetupError, with the message `nvstim run` prints
// for the same mistake where it has one). The scenario is a file or folder, or a bare name of a
// shipped scenario, as `nvstim run SCENARIO` (rt/cli/data_dirs.h, resolveScenario).
rt::SessionOptions sessionOptions(const SrcSettings& s, const std::filesystem::path& pluginDir);

// CLOCK_MONOTONIC instant [ns] of a frame's exposure mid-time under the wall clock: its
// emission instant less the run-clock time between exposure mid-time and emission.
std::int64_t exposureMonotonic_ns(const rt::PulledFrame& f);

// The frame's counts as GStreamer's GRAY8 (bits ≤ 8: v << (8 − bits)) or GRAY16_LE (v << (16 −
// bits), little-endian) rows, `stride` bytes apart (padding zeroed): the sample values the y4m
// output writes (drivers/sinks/sinks.cpp), so the bytes compare.
void packGray(const rt::PulledFrame& f, unsigned char* dst, std::size_t stride_bytes);

}  // namespace nvs::gst
