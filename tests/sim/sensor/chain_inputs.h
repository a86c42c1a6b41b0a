#pragma once
// The hand-run chain timing tools (nvs_chain_cpu, nvs_chain_passes): their command line,
// `TOOL CONFIG_DIR [FIELDS]`, and their inputs: a uniform field of 1e13 pe s⁻¹ m⁻² sr⁻¹ (about
// 1.4 pe a pixel through the PULNiX preset), and the same with a lamp disk of radius 12 px at
// (300, 200), 1e4 times brighter (past the CCD's full well).

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "sim/core/image.h"
#include "sim/sensor/camera.h"

namespace nvs::sensor {

struct ChainToolArgs {
    std::filesystem::path config;
    int fields = 200;  // timed fields per input
    CameraParams cam;  // the PULNiX preset
};

// False, with the usage on stderr, without CONFIG_DIR.
inline bool chainToolArgs(int argc, char** argv, const char* tool, ChainToolArgs* a) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s CONFIG_DIR [FIELDS]\n", tool);
        return false;
    }
    a->config = argv[1];
    if (argc > 2) a->fields = std::max(1, std::atoi(argv[2]));
    a->cam = loadCamera(a->config, "pulnix-ag5745ef3");
    return true;
}

inline ImageF chainTimingInput(const CameraParams& cam, bool lamp) {
    ImageF lpe(cam.width, cam.height);
    lpe.fill(1e13f);
    if (lamp)
        for (int y = 0; y < cam.height; ++y)
            for (int x = 0; x < cam.width; ++x) {
                const int dx = x - 300, dy = y - 200;
                if (dx * dx + dy * dy < 144) lpe.row(y)[x] = 1e17f;
            }
    return lpe;
}

}  // namespace nvs::sensor
