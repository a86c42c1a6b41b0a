#pragma once
// What every stage of the IICCD chain (sim/sensor/chain.h) shares: the bands of rows a field is
// split into, the row scratch they use, and the per-field values the stages hand to each other.
//
// A stage is a file pair here: its parameters (a Params struct that reads its own tables of the
// preset, CameraParams being all of them), its row kernels and its class. IiccdChain runs the
// stages' row operations in order (sim/sensor/chain.cpp).

#include <cstddef>
#include <cstdint>

namespace nvs {
class PresetReader;  // sim/core/preset_reader.h: each stage's Params::read takes it
}  // namespace nvs

namespace nvs::sensor {

using nvs::PresetReader;

// Row scratch is rounded up to whole Philox blocks and vector chunks.
inline constexpr int kRowPad_px = 32;
// The chain splits a field into this many bands of rows, whatever the number of threads that
// run them: each band has its own row scratch in every stage (its slot), and no result depends
// on which thread ran a band or in what order. Sixteen, so that a thread that finishes its last
// band early waits for at most a sixteenth of a pass (and a thread held up by the machine holds
// back that much).
inline constexpr int kChainSlots = 16;

// Per-field values the stages hand to each other.
struct FieldContext {
    std::uint64_t field = 0;
    double period_s = 0.0;
    double gate_s = 0.0;
    double gain_V = 0.0;
    double mcpGain = 1.0;
    double cathodeRate_pe_s = 0.0;  // expected, whole cathode
    double mcpOut_e = 0.0;          // MCP output electrons, whole screen
};

// Row scratch length: the width rounded up to whole vector chunks and Philox blocks.
inline std::size_t paddedRow(int width) {
    return static_cast<std::size_t>((width + kRowPad_px - 1) / kRowPad_px * kRowPad_px);
}
// Rows (or columns) [begin, end) of band b of n: the same bands whatever runs them.
inline int bandStart(int b, int n) {
    return static_cast<int>(static_cast<long long>(b) * n / kChainSlots);
}
// Philox blocks that cover `n` words.
inline int blocksFor(int n) {
    return (n + 3) / 4;
}

}  // namespace nvs::sensor
