// nvs_bolometer_frames CONFIG_DIR PRESET FRAMES: runs the microbolometer chain on a fixed scene
// (a 280-320 K ramp with a 340 K block) for FRAMES frames, the start-up shutter correction
// included, planning the optics' FFTs from CONFIG_DIR's shipped wisdom, and prints one line per
// frame: the FNV-1a digest of its raw and display images. tests/sim/bolometer/isa_frames.sh
// compares the lines of this CPU with those under qemu as other CPUs (docs/portability.md).

#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "sim/bolometer/chain.h"
#include "sim/core/planck.h"

namespace {
std::uint64_t fnv(std::uint64_t h, const void* data, std::size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < n; ++i)
        h = (h ^ p[i]) * 1099511628211ULL;
    return h;
}
}  // namespace

int main(int argc, char** argv) {
    if (argc != 4) {
        std::fprintf(stderr, "usage: nvs_bolometer_frames CONFIG_DIR PRESET FRAMES\n");
        return 2;
    }
    const std::filesystem::path config = argv[1];
    const nvs::bolometer::ThermalCameraParams cam =
        nvs::bolometer::loadThermalCamera(config, argv[2]);
    const int frames = std::atoi(argv[3]);
    nvs::bolometer::BolometerChain chain(cam, 7, config);
    std::printf("optics planned from the shipped wisdom: %s\n",
                chain.optics().plannedFromWisdom() ? "yes" : "no");
    nvs::ImageF in(cam.width, cam.height);
    for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x) {
            const double T_K =
                (x > cam.width / 3 && x < cam.width / 2 && y > cam.height / 5 && y < cam.height / 2)
                    ? 340.0
                    : 280.0 + 40.0 * x / cam.width;
            in(x, y) = static_cast<float>(
                nvs::planckBandRadiance_W_m2_sr(cam.band_lo_um, cam.band_hi_um, T_K));
        }
    for (int k = 0; k < frames; ++k) {
        const nvs::bolometer::FrameInfo& info = chain.process(in.cview());
        std::uint64_t h = 1469598103934665603ULL;
        for (int y = 0; y < cam.height; ++y) {
            h = fnv(h, chain.raw().row(y), sizeof(std::uint16_t) * cam.width);
            h = fnv(h, chain.display().row(y), static_cast<std::size_t>(cam.width));
        }
        std::printf("frame %d frozen %d mean_raw %.3f digest %016" PRIx64 "\n", k,
                    info.frozen ? 1 : 0, info.mean_raw, h);
    }
    return 0;
}
