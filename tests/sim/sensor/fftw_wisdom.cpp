// Makes the FFTW wisdom the camera chains ship with (config/fftw/, sim/core/fft_plans.h):
// FFTW_PATIENT plans of the intensified chain's blur (row and column transforms) for every
// preset in CONFIG/cameras, and of the microbolometer optics' MTF (the 2-d r2c and c2r of the
// mirror-padded frame) for every preset in CONFIG/thermal_cameras, exported to OUT. Plans made
// from wisdom are the same in every run (a measured plan is not), so the replay digests stay
// fixed while the FFTs run at the speed of a planned transform.
//   nvs_fftw_wisdom [--measure] [--import WISDOM] CONFIG_DIR OUT_FILE [WxH …]
//   nvs_fftw_wisdom --signature
// WxH: more frame sizes for the blur, e.g. a scenario's. --measure: FFTW_MEASURE plans instead (a
// planner an emulator slows down 10-40 times finishes in minutes rather than hours).
// --import: loads WISDOM first: the problems it holds keep its plans (the planner takes a plan
// from wisdom before it measures), only new problems are planned, and OUT holds both.
// --signature: prints the header FFTW gives this CPU's wisdom (its hash of the solvers it
// registers). tests/sim/sensor/make_wisdom.sh makes the shipped files with both (as a CPU with
// SSE4.2 only, under qemu-user: sim/sensor/chain.cpp says why).

#include <fftw3.h>

#include <cstdio>
#include <filesystem>
#include <string>

#include "sim/bolometer/chain.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/chain.h"

int main(int argc, char** argv) {
    if (argc == 2 && std::string(argv[1]) == "--signature") {
        // The header of this CPU's wisdom: FFTW's hash of the solvers it has here.
        char* w = fftwf_export_wisdom_to_string();
        const std::string text = w != nullptr ? w : "";
        fftwf_free(w);
        std::printf("%s\n", text.substr(0, text.find('\n')).c_str());
        return 0;
    }
    nvs::sensor::ChainOptions opt;
    opt.patientFft = true;
    if (argc > 1 && std::string(argv[1]) == "--measure") {
        opt.patientFft = false;
        opt.measureFft = true;
        ++argv;
        --argc;
    }
    if (argc > 2 && std::string(argv[1]) == "--import") {
        if (fftwf_import_wisdom_from_filename(argv[2]) == 0) {
            std::fprintf(stderr, "nvs_fftw_wisdom: cannot import %s (another CPU's header?)\n",
                         argv[2]);
            return 1;
        }
        argv += 2;
        argc -= 2;
    }
    if (argc < 3) {
        std::fprintf(stderr,
                     "usage: nvs_fftw_wisdom [--measure] [--import WISDOM] CONFIG_DIR "
                     "OUT_FILE [WxH ...]\n");
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
    const nvs::FftPlanning planning =
        opt.patientFft ? nvs::FftPlanning::Patient : nvs::FftPlanning::Measure;
    for (const auto& entry : std::filesystem::directory_iterator(config / "thermal_cameras")) {
        if (entry.path().extension() != ".toml") continue;
        const nvs::bolometer::ThermalCameraParams cam =
            nvs::bolometer::loadThermalCamera(config, entry.path().string());
        // No config folder: no shipped wisdom imported, the optics' plans made anew.
        const nvs::bolometer::OpticsStage optics(cam, {}, planning);
        std::printf("%s: %dx%d, FFT %dx%d\n", entry.path().filename().c_str(), cam.width,
                    cam.height, optics.paddedWidth(), optics.paddedHeight());
    }
    if (!nvs::exportFftWisdom(argv[2])) {
        std::fprintf(stderr, "nvs_fftw_wisdom: cannot write %s\n", argv[2]);
        return 1;
    }
    return 0;
}
