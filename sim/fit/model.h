#pragma once
// The camera model's prediction of a dataset: the stimulus pushed through the project's IICCD
// chain (sim/sensor IiccdChain), one call per frame as `nvstim sensor` does.
//
// Two runs. The mean run switches every noise source off (shot noise, MCP gain noise, read and
// video noise, the PRNU pattern) and keeps, for every call, the whole frame's signal above the
// video offset [DC] before read-out: what the chain would output on average. The noisy run is
// the model as configured, with a seed: its frames give the model's own noise statistics
// (temporal variance, neighbour covariance), computed the same way as the measured ones.
//
// Field scan reads half the rows per call (VideoStage::readsRow); assemble() builds the output
// frames from the per-call images the way the chain's output frame is built.

#include <cstdint>
#include <filesystem>
#include <vector>

#include "sim/fit/dataset.h"

namespace nvs::fit {

struct ModelRun {
    int width = 0, height = 0, calls = 0;
    bool fieldScan = false;
    std::vector<Plane> signal;      // per call: signal above offset [DC], noise-free, blurred
    std::vector<Plane> unblurred;   // per call: the same without the MTF (mcp_saturation)
    std::vector<Plane> noisy;       // per call: the model's noisy output frame [DC]
    std::vector<double> cathode_A;  // per call: cathode current (bright-source protection)
    std::vector<double> bspFactor;  // per call: the mean run's bright-source protection factor
    double offset_dc = 0.0;         // video offset
    double maxDc = 255.0;           // ADC full scale
    double gamma = 1.0;
    double readVar_dc2 = 0.0;             // read + video noise of the model [DC²]
    double dcPerMcpElectron = 0.0;        // DC per MCP output electron (phosphor, CCD, video)
    double ebiLevel_dc_per_lm_cm2 = 0.0;  // dark signal per unit EBI [DC per lm/cm²]
    double ebiC1_dc2_per_lm_cm2 = 0.0;    // neighbour covariance of dark noise per unit EBI
    double period_s = 0.0;                // one call's integration period
    double gate_s = 0.0;
};

// Runs the model over the dataset's stimulus sequence. `unblurred` only when asked.
ModelRun simulate(const Dataset& d, const sensor::CameraParams& cam,
                  const std::filesystem::path& configDir, std::uint64_t seed, bool unblurred,
                  const Progress& progress = {});

// The mean run alone for a stimulus sequence (one image per distinct stimulus, indexed by
// d.stimulusOfFrame): signal per call [DC] as ModelRun::signal, without the MTF into
// `unblurred`, the cathode current into `cathode_A` and the protection's gain factor into
// `bspFactor` where given.
void meanRun(const Dataset& d, const std::vector<ImageF>& stimuli, const sensor::CameraParams& cam,
             const std::filesystem::path& configDir, std::uint64_t seed, std::vector<Plane>& signal,
             std::vector<Plane>* unblurred, std::vector<double>* cathode_A = nullptr,
             std::vector<double>* bspFactor = nullptr);

// The model's noisy output frames for the dataset's sequence of stimuli (one per distinct
// stimulus, indexed by d.stimulusOfFrame, or by `stimulusOfFrame` where given).
std::vector<Plane> noisyRun(const Dataset& d, const std::vector<ImageF>& stimuli,
                            const sensor::CameraParams& cam, const std::filesystem::path& configDir,
                            std::uint64_t seed, const std::vector<int>* stimulusOfFrame = nullptr);

// Output frame k from per-call images: in field scan the rows read in call k come from call k,
// the others from call k − 1 (call 0: from call 0).
void assembleFrame(const std::vector<Plane>& perCall, int k, int width, int height, bool fieldScan,
                   Plane& out);

}  // namespace nvs::fit
