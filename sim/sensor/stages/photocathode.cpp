#include "sim/sensor/stages/photocathode.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "sim/core/input_file.h"
#include "sim/core/rng.h"
#include "sim/core/simd.h"
#include "sim/core/units.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/preset_reader.h"

namespace nvs::sensor {

void PhotocathodeParams::read(const PresetReader& root) {
    const PresetReader spectral = root.sub("spectral");
    const std::string resp = spectral.get<std::string>("response_file", "");
    if (!resp.empty()) {
        std::filesystem::path p = resp;
        if (p.is_relative()) p = root.baseDir() / p;
        if (!pathExists(p)) spectral.fail("response_file", "no file " + p.string());
        response_file = p;
    }
    response_column = spectral.get<std::string>("response_column", response_column);
    const bool qeFile = spectral.inFile("qe_peak");
    qe_peak = positive(spectral, "qe_peak", qe_peak);
    require(qe_peak <= 1.0, spectral, "qe_peak", "must be <= 1");
    monochromatic_nm = nonNegative(spectral, "monochromatic_nm", monochromatic_nm);

    const PresetReader pc = root.sub("photocathode");
    shot_noise = pc.get<bool>("shot_noise", shot_noise);
    ebi_lm_cm2 = nonNegative(pc, "ebi_lm_cm2", ebi_lm_cm2);
    const bool skFile = pc.inFile("luminous_sensitivity_uA_lm");
    cathode_sensitivity_uA_lm =
        nonNegative(pc, "luminous_sensitivity_uA_lm", cathode_sensitivity_uA_lm);
    // One of the two is the datasheet's; the other follows from it through the response.
    if (qeFile && skFile && !response_file.empty()) {
        pc.fail("luminous_sensitivity_uA_lm",
                "give either [spectral] qe_peak or the luminous sensitivity, not both: each "
                "follows from the other through the spectral response");
    }
    taper_magnification = positive(pc, "taper_magnification", taper_magnification);
}

namespace {

// Photometric → photoelectron rate: lm/m² × A/lm ÷ e.
double ebiRatePerPixel_pe_s(const CameraParams& c) {
    const double ebi_lm_m2 = c.ebi_lm_cm2 * 1e4;
    const double current_A_m2 = ebi_lm_m2 * c.cathode_sensitivity_uA_lm * 1e-6;
    return current_A_m2 / kElectronCharge_C * c.pixelAreaAtCathode_m2();
}

// Photocathode means: (rate + ebi)·t.
NVS_SIMD_CLONES void cathodeMeanKernel(const float* __restrict r, float* __restrict mean, int w,
                                       float ebi, float t) noexcept {
    for (int x = 0; x < w; ++x)
        mean[x] = (r[x] + ebi) * t;
}

}  // namespace

// ---- 3. Photocathode ------------------------------------------------------------------------

PhotocathodeStage::PhotocathodeStage(const CameraParams& c, std::uint64_t seed)
    : noise_(c.shot_noise),
      ebi_pe_s_(ebiRatePerPixel_pe_s(c)),
      seed_(seed),
      stride_(paddedRow(c.width)),
      mean_(new float[kChainSlots * stride_]),
      words_(new std::uint32_t[kChainSlots * stride_]) {}

void PhotocathodeStage::apply(ImageView<const float> rate, ImageView<float> pe,
                              FieldContext& ctx) noexcept {
    begin(ctx, rate.width(), rate.height());
    for (int y = 0; y < rate.height(); ++y)
        applyRow(rate.row(y), pe.row(y), rate.width(), y);
}

void PhotocathodeStage::begin(FieldContext& ctx, int w, int h) noexcept {
    t_s_ = static_cast<float>(ctx.gate_s);
    field_ = ctx.field;
    ctx.cathodeRate_pe_s += ebi_pe_s_ * w * h;
}

void PhotocathodeStage::applyRow(const float* rate, float* pe, int w, int y, int slot) noexcept {
    const float ebi = static_cast<float>(ebi_pe_s_);
    if (!noise_) {
        cathodeMeanKernel(rate, pe, w, ebi, t_s_);
        return;
    }
    // One word per pixel; Poisson by the exact row sampler (zeros settled in a vector pass,
    // the rest by inversion or PTRS).
    const std::size_t off = static_cast<std::size_t>(slot) * stride_;
    float* __restrict mean = mean_.get() + off;
    std::uint32_t* __restrict words = words_.get() + off;
    cathodeMeanKernel(rate, mean, w, ebi, t_s_);
    const PixelRng rng(seed_, RngStream::Photocathode, field_);
    const std::uint32_t yy = static_cast<std::uint32_t>(y);
    rng.rowWords(yy, 0, 0, blocksFor(w), words);
    poissonRow(mean, words, pe, w, rng, 0, yy);
}

}  // namespace nvs::sensor
