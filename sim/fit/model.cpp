#include "sim/fit/model.h"

#include <algorithm>
#include <cmath>

#include "sim/core/gamma_table.h"
#include "sim/sensor/chain.h"
#include "sim/sensor/stages/video.h"

namespace nvs::fit {

namespace {

// The model with every random term off: its output is the chain's mean.
sensor::CameraParams meanCamera(const sensor::CameraParams& cam) {
    sensor::CameraParams m = cam;
    m.shot_noise = false;
    m.mcp_noise = false;
    m.read_noise_e = 0.0;
    m.video_noise_dc = 0.0;
    m.prnu_rel = 0.0;
    return m;
}

void copyPlane(ImageView<const float> img, double scale, Plane& out) {
    const int w = img.width();
    out.resize(static_cast<std::size_t>(w) * img.height());
    for (int y = 0; y < img.height(); ++y) {
        const float* r = img.row(y);
        float* o = out.data() + static_cast<std::size_t>(y) * w;
        for (int x = 0; x < w; ++x)
            o[x] = static_cast<float>(static_cast<double>(r[x]) * scale);
    }
}

// Dark signal per unit EBI [DC per lm/cm²], from the chain itself on a small dark frame.
double ebiLevel(const sensor::CameraParams& mean, const std::filesystem::path& configDir,
                GammaTableCache& tables) {
    sensor::CameraParams c = mean;
    c.width = 32;
    c.height = 32;
    c.agc = sensor::AgcMode::Off;
    ImageF dark(32, 32);
    double level[2] = {0.0, 0.0};
    const double ebi[2] = {0.0, 1e-11};
    for (int i = 0; i < 2; ++i) {
        c.ebi_lm_cm2 = ebi[i];
        sensor::IiccdChain chain(c, 0, configDir, tables);
        for (int k = 0; k < 8; ++k)
            chain.process(dark.cview());
        double s = 0.0;
        for (int y = 0; y < 32; ++y)
            for (int x = 0; x < 32; ++x)
                s += static_cast<double>(chain.electrons()(x, y));
        level[i] = s / 1024.0 * c.video_gain_dc_per_e;
    }
    return (level[1] - level[0]) / 1e-11;
}

// Neighbour covariance of the temporal noise of a dark frame per unit EBI [DC² per lm/cm²],
// from the noisy chain (frame differences at lag 2, as noise.cpp measures): what an EBI's shot
// noise, blurred by the MTF, adds to it.
double ebiC1(const sensor::CameraParams& cam, const std::filesystem::path& configDir,
             GammaTableCache& tables) {
    sensor::CameraParams c = cam;
    c.width = c.height = 64;
    c.agc = sensor::AgcMode::Off;
    c.read_noise_e = 0.0;
    c.video_noise_dc = 0.0;
    c.adc_bits = 16;  // no quantisation: the covariance of the shot noise alone
    c.video_gain_dc_per_e *= 256.0;
    c.video_offset_dc = 1000.0;
    const double ebi = 1e-9;
    c.ebi_lm_cm2 = ebi;
    ImageF dark(64, 64);
    sensor::IiccdChain chain(c, 7, configDir, tables);
    std::vector<Plane> f;
    for (int k = 0; k < 14; ++k) {
        chain.process(dark.cview());
        Plane p;
        copyPlane(chain.counts().cview(), 1.0 / 256.0, p);
        f.push_back(std::move(p));
    }
    double s = 0.0, n = 0.0;
    for (int k = 4; k < 14; ++k)
        for (int y = 0; y < 64; ++y)
            for (int x = 0; x + 1 < 64; ++x) {
                const std::size_t p = static_cast<std::size_t>(y) * 64 + x;
                s += (f[k][p] - f[k - 2][p]) * (f[k][p + 1] - f[k - 2][p + 1]);
                n += 1.0;
            }
    return s / (2.0 * n) / ebi;
}

}  // namespace

void assembleFrame(const std::vector<Plane>& perCall, int k, int width, int height, bool fieldScan,
                   Plane& out) {
    out.resize(static_cast<std::size_t>(width) * height);
    for (int y = 0; y < height; ++y) {
        const bool now = !fieldScan || (y & 1) == (k & 1) || k == 0;
        const Plane& src = perCall[static_cast<std::size_t>(now ? k : k - 1)];
        std::copy_n(src.data() + static_cast<std::size_t>(y) * width, width,
                    out.data() + static_cast<std::size_t>(y) * width);
    }
}

ModelRun simulate(const Dataset& d, const sensor::CameraParams& cam,
                  const std::filesystem::path& configDir, std::uint64_t seed, bool unblurred,
                  const Progress& progress) {
    ModelRun m;
    m.width = d.width;
    m.height = d.height;
    m.calls = static_cast<int>(d.frameCount());
    m.fieldScan = cam.scan == sensor::ScanMode::Field;
    m.offset_dc = cam.video_offset_dc;
    m.maxDc = (1 << cam.adc_bits) - 1;
    m.gamma = cam.gamma;
    const double vg = cam.video_gain_dc_per_e;
    m.readVar_dc2 =
        cam.read_noise_e * vg * cam.read_noise_e * vg + cam.video_noise_dc * cam.video_noise_dc;
    m.dcPerMcpElectron = cam.ccdElectronsPerMcpElectron() * vg;
    m.period_s = cam.integrationPeriod_s();
    m.gate_s = cam.gate_s > 0.0 ? cam.gate_s : m.period_s;
    GammaTableCache tables;
    const sensor::CameraParams mean = meanCamera(cam);
    m.ebiLevel_dc_per_lm_cm2 = ebiLevel(mean, configDir, tables);
    m.ebiC1_dc2_per_lm_cm2 = ebiC1(cam, configDir, tables);
    if (progress) progress("simulating " + std::to_string(m.calls) + " frames with the model");
    meanRun(d, d.stimuli, cam, configDir, seed, m.signal, unblurred ? &m.unblurred : nullptr,
            &m.cathode_A, &m.bspFactor);
    m.noisy = noisyRun(d, d.stimuli, cam, configDir, seed);
    return m;
}

void meanRun(const Dataset& d, const std::vector<ImageF>& stimuli, const sensor::CameraParams& cam,
             const std::filesystem::path& configDir, std::uint64_t seed, std::vector<Plane>& signal,
             std::vector<Plane>* unblurred, std::vector<double>* cathode_A,
             std::vector<double>* bspFactor) {
    GammaTableCache tables;
    const sensor::CameraParams mean = meanCamera(cam);
    const double vg = cam.video_gain_dc_per_e;
    const std::size_t calls = d.frameCount();
    auto run = [&](const sensor::CameraParams& c, std::vector<Plane>& out, bool current) {
        sensor::IiccdChain chain(c, seed, configDir, tables);
        out.resize(calls);
        if (current && cathode_A) cathode_A->clear();
        if (current && bspFactor) bspFactor->clear();
        for (std::size_t k = 0; k < calls; ++k) {
            const ImageF& s = stimuli[static_cast<std::size_t>(d.stimulusOfFrame[k])];
            const sensor::FieldInfo& info = chain.process(s.cview());
            if (current && cathode_A) cathode_A->push_back(info.cathode_current_A);
            if (current && bspFactor) bspFactor->push_back(info.bsp_factor);
            copyPlane(chain.electrons().cview(), vg, out[k]);
            // The video stage's droop acts on the line before the ADC (a linear filter of
            // each row, so of the signal in DC as of the electrons).
            if (c.streak_fraction > 0.0)
                for (int y = 0; y < d.height; ++y) {
                    float* row = out[k].data() + static_cast<std::size_t>(y) * d.width;
                    sensor::VideoStage::droopRow(row, row, d.width, c.streak_fraction,
                                                 c.streak_tau_px);
                }
        }
    };
    run(mean, signal, true);
    if (unblurred) {
        sensor::CameraParams u = mean;
        u.mtf_enabled = false;
        run(u, *unblurred, false);
    }
}

std::vector<Plane> noisyRun(const Dataset& d, const std::vector<ImageF>& stimuli,
                            const sensor::CameraParams& cam, const std::filesystem::path& configDir,
                            std::uint64_t seed, const std::vector<int>* stimulusOfFrame) {
    GammaTableCache tables;
    sensor::IiccdChain noisy(cam, seed ^ 0x5eedf17ull, configDir, tables);
    std::vector<Plane> out(d.frameCount());
    const std::vector<int>& of = stimulusOfFrame ? *stimulusOfFrame : d.stimulusOfFrame;
    for (std::size_t k = 0; k < out.size(); ++k) {
        const ImageF& s = stimuli[static_cast<std::size_t>(of[k])];
        noisy.process(s.cview());
        copyPlane(noisy.counts().cview(), 1.0, out[k]);
    }
    return out;
}

}  // namespace nvs::fit
