#pragma once
// What every stage of the microbolometer chain (sim/bolometer/chain.h) shares: the random
// streams it draws from and the per-frame values the stages hand to each other.
//
// A stage is a file pair here, as in the intensified camera (docs/bolometer.md): its
// parameters (a Params struct that reads its own table of the preset, ThermalCameraParams
// being all of them), its per-frame kernel and its class. BolometerChain runs them in order.

#include <cstdint>

namespace nvs {
class PresetReader;  // sim/core/preset_reader.h
}  // namespace nvs

namespace nvs::bolometer {

struct ThermalCameraParams;
using Reader = nvs::PresetReader;  // each stage's Params::read takes it

// Philox streams (sim/core/rng.h, RngKey::stream) of this chain, far from RngStream's values so
// that no stage of another chain ever draws the same words.
inline constexpr std::uint32_t kStreamTemporal = 0x4210;  // white, row, column and 1/f noise
inline constexpr std::uint32_t kStreamPattern = 0x4211;   // offset, gain, drift maps (frame 0)

// Per-frame values the stages hand to each other.
struct FrameContext {
    std::uint64_t frame = 0;
    double t_s = 0.0;            // time of this frame since the first [s]
    double fpa_K = 0.0;          // focal-plane temperature [K]
    bool shutterClosed = false;  // the shutter, not the scene, is in front of the array
};

}  // namespace nvs::bolometer
