#include "sim/fit/compare.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>

#include "sim/fit/engine.h"
#include "sim/fit/model.h"
#include "sim/fit/text.h"

namespace nvs::fit {

namespace {

constexpr double kTwoPi = 6.283185307179586;

// One model fitted to the dataset: its runs, working set, prediction and gain/offset fit.
struct Side {
    sensor::CameraParams cam;
    FitEffects extra;
    ModelRun m;
    std::unique_ptr<Work> w;
    MeanModel mm;
    std::vector<Plane> Y;
    LinFit fit;
};

std::unique_ptr<Side> fitSide(const Dataset& d, const std::filesystem::path& configDir,
                              const std::string& preset, const sensor::Overrides& settings,
                              const Options& opt, const Progress& progress) {
    auto s = std::make_unique<Side>();
    s->cam = loadModelCamera(configDir, preset, settings, s->extra);
    if (progress) progress(preset + ": the model's runs");
    s->m = simulate(d, s->cam, configDir, opt.seed, true, progress);
    s->w = std::make_unique<Work>(d, s->m, s->cam, opt, Progress{}, configDir);
    assembleUnblurred(*s->w, s->m);
    s->mm = modelExtras(s->extra, s->m);
    if (progress) progress(preset + ": MTF, gain and offset on the calibration frames");
    s->mm.sigma_px = fitBlur(*s->w, s->mm);
    s->Y = predict(*s->w, s->mm);
    s->fit = fitLinear(*s->w, s->Y, nullptr);
    return s;
}

const char* const kGrid[9] = {"top left", "top",         "top right", "left",        "centre",
                              "right",    "bottom left", "bottom",    "bottom right"};

}  // namespace

Comparison compareModels(const Dataset& d, const std::filesystem::path& configDir,
                         const std::string& presetA, const std::string& presetB, const Options& opt,
                         const Progress& progress, const sensor::Overrides* settingsB) {
    const std::unique_ptr<Side> A = fitSide(d, configDir, presetA, d.settings, opt, progress);
    const std::unique_ptr<Side> B =
        fitSide(d, configDir, presetB, settingsB ? *settingsB : d.settings, opt, progress);
    const Work& wa = *A->w;
    const Work& wb = *B->w;
    Comparison c;
    c.a.preset = presetA;
    c.b.preset = presetB;
    for (auto [side, mf] : {std::pair{A.get(), &c.a}, std::pair{B.get(), &c.b}}) {
        mf->gain_rel = side->fit.a;
        mf->offset_dc = side->fit.b;
        mf->blur_px = side->mm.sigma_px;
    }
    for (const char* g : kGrid)
        c.regions.push_back(g);
    for (const char* band : {"dark third", "middle third", "bright third"})
        c.regions.push_back(std::string("level: ") + band);
    for (const Roi& r : d.rois)
        c.regions.push_back("roi " + r.name);
    const std::size_t R = c.regions.size();
    std::vector<double> sa(R, 0.0), sb(R, 0.0), n(R, 0.0);
    const std::size_t T = static_cast<std::size_t>(wa.scoreTiles());
    std::vector<double> ta(T, 0.0), tb(T, 0.0);
    double ea = 0.0, eb = 0.0, la = 0.0, lb = 0.0;
    // The level bands from model A's predicted range over the pixels scored.
    double lo = 1e300, hi = -1e300;
    auto scored = [&](std::size_t i, std::size_t p, float M) {
        return wa.quiet(M, A->Y[i][p]) && wb.quiet(M, B->Y[i][p]);
    };
    auto pred = [&](const Side& s, std::size_t i, std::size_t p) {
        return std::clamp(s.fit.b + s.fit.a * s.Y[i][p], 0.0, s.m.maxDc);
    };
    for (std::size_t i = wa.cal.size(); i < wa.sub.size(); ++i) {
        const Plane& M = wa.measured(wa.sub[i]);
        for (std::size_t p = 0; p < M.size(); ++p)
            if (scored(i, p, M[p])) {
                lo = std::min(lo, pred(*A, i, p));
                hi = std::max(hi, pred(*A, i, p));
            }
    }
    auto loglik = [](const Side& s, double e, double y) {
        const double v =
            std::max(s.fit.a * s.fit.a * (s.w->noiseS0_dc2 + s.w->noiseS1_dc * y), 0.25);
        return -0.5 * (e * e / v + std::log(kTwoPi * v));
    };
    for (std::size_t i = wa.cal.size(); i < wa.sub.size(); ++i) {
        const Plane& M = wa.measured(wa.sub[i]);
        for (int y = 0; y < d.height; ++y)
            for (int x = 0; x < d.width; ++x) {
                const std::size_t p = static_cast<std::size_t>(y) * d.width + x;
                if (!scored(i, p, M[p])) continue;
                const double pa = pred(*A, i, p), pb = pred(*B, i, p);
                const double da = M[p] - pa, db = M[p] - pb;
                ea += da * da;
                eb += db * db;
                la += loglik(*A, da, std::max<double>(A->Y[i][p], 0.0));
                lb += loglik(*B, db, std::max<double>(B->Y[i][p], 0.0));
                c.pixels += 1.0;
                const std::size_t t = static_cast<std::size_t>(wa.scoreTileOf(x, y));
                ta[t] += da * da / wa.tileVar[t];
                tb[t] += db * db / wa.tileVar[t];
                auto add = [&](std::size_t r) {
                    sa[r] += da * da;
                    sb[r] += db * db;
                    n[r] += 1.0;
                };
                add(static_cast<std::size_t>(std::min(2, 3 * y / d.height) * 3 +
                                             std::min(2, 3 * x / d.width)));
                if (hi > lo)
                    add(9 + static_cast<std::size_t>(std::min(2.0, 3.0 * (pa - lo) / (hi - lo))));
                for (std::size_t k = 0; k < d.rois.size(); ++k) {
                    const Roi& r = d.rois[k];
                    if (x >= r.x && x < r.x + r.w && y >= r.y && y < r.y + r.h) add(12 + k);
                }
            }
    }
    if (c.pixels > 0) {
        c.a.heldoutRms_dc = std::sqrt(ea / c.pixels);
        c.b.heldoutRms_dc = std::sqrt(eb / c.pixels);
        c.a.logLikelihoodPerPixel = la / c.pixels;
        c.b.logLikelihoodPerPixel = lb / c.pixels;
    }
    for (std::size_t r = 0; r < R; ++r) {
        const double ra = n[r] > 0 ? std::sqrt(sa[r] / n[r]) : 0.0;
        const double rb = n[r] > 0 ? std::sqrt(sb[r] / n[r]) : 0.0;
        c.a.regionRms_dc.push_back(ra);
        c.b.regionRms_dc.push_back(rb);
        c.regionPixels.push_back(n[r]);
        c.regionGain_pct.push_back(ra > 0.0 ? 100.0 * (1.0 - rb / ra) : 0.0);
    }
    c.z = pairedScore(ta, tb, c.a.heldoutRms_dc, c.b.heldoutRms_dc, 0).z;
    if (progress) {
        char b[240];
        std::snprintf(b, sizeof b,
                      "held-out RMS %.4g DC (A) against %.4g DC (B); log-likelihood per pixel "
                      "%.4f against %.4f; paired z %.1f",
                      c.a.heldoutRms_dc, c.b.heldoutRms_dc, c.a.logLikelihoodPerPixel,
                      c.b.logLikelihoodPerPixel, c.z);
        progress(b);
    }
    return c;
}

sensor::Overrides settingsWithoutFindings(const Dataset& d, const Result& r) {
    sensor::Overrides out = d.settings;
    for (const Finding& f : r.findings) {
        if (f.status != "named") continue;
        for (const auto& kv : f.presetKeys) {
            const std::string table = kv.first.substr(0, kv.first.find('.') + 1);
            for (auto it = out.begin(); it != out.end();)
                it = !table.empty() && it->first.rfind(table, 0) == 0 ? out.erase(it)
                                                                      : std::next(it);
        }
    }
    return out;
}

namespace {

std::string num(double v) {
    return textf("%.6g", std::isfinite(v) ? v : 0.0);
}

std::string modelJson(const ModelFit& m) {
    return "{\"preset\":" + jsonString(m.preset) + ",\"gain_rel\":" + num(m.gain_rel) +
           ",\"offset_dc\":" + num(m.offset_dc) + ",\"mtf_extra_blur_px\":" + num(m.blur_px) +
           ",\"heldout_rms_dc\":" + num(m.heldoutRms_dc) +
           ",\"log_likelihood_per_pixel\":" + num(m.logLikelihoodPerPixel) + "}";
}

}  // namespace

std::string toJson(const Comparison& c) {
    std::string s =
        "{\"compare\":{\"a\":" + modelJson(c.a) + ",\"b\":" + modelJson(c.b) + ",\"regions\":[";
    for (std::size_t r = 0; r < c.regions.size(); ++r)
        s += std::string(r ? "," : "") + "{\"name\":" + jsonString(c.regions[r]) +
             ",\"pixels\":" + num(c.regionPixels[r]) + ",\"rms_a_dc\":" + num(c.a.regionRms_dc[r]) +
             ",\"rms_b_dc\":" + num(c.b.regionRms_dc[r]) +
             ",\"gain_pct\":" + num(c.regionGain_pct[r]) + "}";
    s += "],\"z\":" + num(c.z) + ",\"heldout_pixels\":" + num(c.pixels) + "}}";
    return s;
}

}  // namespace nvs::fit
