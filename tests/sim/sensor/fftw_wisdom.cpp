// Makes the FFTW wisdom the blur stage ships with (config/fftw/wisdom-single.txt):
// FFTW_PATIENT plans of the row and column transforms of every preset in CONFIG/cameras, made
// with no wisdom loaded, exported to OUT. Plans made from wisdom are the same in every run (a
// measured plan is not), so the replay digests stay fixed while the blur runs at the speed of
// a patient plan.
//   nvs_fftw_wisdom [--measure] CONFIG_DIR OUT_FILE [WxH …]
// WxH: more frame sizes, e.g. a scenario's. --measure: FFTW_MEASURE plans instead (a planner an
// emulator slows down 10-40 times finishes in minutes rather than hours).
// The shipped file is made as a CPU with SSE4.2 only, so that its plans use codelets every
// x86-64 CPU has (docs/portability.md):
//   qemu-x86_64 -cpu Nehalem-v2 build/release/tests/sim/sensor/nvs_fftw_wisdom --measure
//       config config/fftw/wisdom-single.txt 1280x1024

#include <cstdio>
#include <filesystem>
#include <string>

#include "sim/sensor/camera.h"
#include "sim/sensor/chain.h"

int main(int argc, char** argv) {
    nvs::sensor::ChainOptions opt;
    opt.patientFft = true;
    if (argc > 1 && std::string(argv[1]) == "--measure") {
        opt.patientFft = false;
        opt.measureFft = true;
        ++argv;
        --argc;
    }
    if (argc < 3) {
        std::fprintf(stderr, "usage: nvs_fftw_wisdom [--measure] CONFIG_DIR OUT_FILE [WxH ...]\n");
        return 2;
    }
    const std::filesystem::path config = argv[1];
    for (int i = 3; i < argc; ++i) {
        nvs::sensor::CameraParams cam;
        if (std::sscanf(argv[i], "%dx%d", &cam.width, &cam.height) != 2) {
            std::fprintf(stderr, "nvs_fftw_wisdom: '%s' is not WxH\n", argv[i]);
            return 2;
        }
        const nvs::sensor::BlurStage blur(cam, opt, config / "cameras");
        std::printf("%s: FFT %dx%d\n", argv[i], blur.paddedWidth(), blur.paddedHeight());
    }
    for (const auto& entry : std::filesystem::directory_iterator(config / "cameras")) {
        if (entry.path().extension() != ".toml") continue;
        const nvs::sensor::CameraParams cam =
            nvs::sensor::loadCamera(config, entry.path().string());
        // A folder without fftw/: no shipped wisdom is imported, every plan is made anew.
        const nvs::sensor::BlurStage blur(cam, opt, config / "cameras");
        std::printf("%s: %dx%d, FFT %dx%d\n", entry.path().filename().c_str(), cam.width,
                    cam.height, blur.paddedWidth(), blur.paddedHeight());
    }
    if (!nvs::sensor::BlurStage::exportWisdom(argv[2])) {
        std::fprintf(stderr, "nvs_fftw_wisdom: cannot write %s\n", argv[2]);
        return 1;
    }
    return 0;
}
