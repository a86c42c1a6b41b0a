#pragma once
// The inputs of the hand-run chain timing tools (nvs_chain_cpu, nvs_chain_passes): a uniform
// field of 1e13 pe s⁻¹ m⁻² sr⁻¹ (about 1.4 pe a pixel through the PULNiX preset), and the same
// with a lamp disk of radius 12 px at (300, 200), 1e4 times brighter (past the CCD's full well).

#include "sim/core/image.h"
#include "sim/sensor/camera.h"

namespace nvs::sensor {

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
