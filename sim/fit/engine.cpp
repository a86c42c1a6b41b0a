#include "sim/fit/engine.h"

#include <malloc.h>

#include <algorithm>
#include <cmath>
#include <utility>

#include "sim/fit/effect_registry.h"
#include "sim/sensor/chain.h"

namespace nvs::fit {

namespace {

// Evenly spaced picks of at most n from v.
std::vector<int> spread(const std::vector<int>& v, int n) {
    if (static_cast<int>(v.size()) <= n) return v;
    std::vector<int> out;
    for (int i = 0; i < n; ++i)
        out.push_back(v[static_cast<std::size_t>(i * static_cast<int>(v.size()) / n)]);
    return out;
}

// Each trial makes and drops whole sets of frame-sized planes (1.5 MB each at 768 x 494, 40 to
// a set). With glibc's defaults a freed set at the heap's top goes back to the kernel (the trim
// threshold follows the largest block freed, a few MB) and the next set's pages fault in again:
// on a 768 x 494 dataset a third of the time went to page faults and the copies through them
// (sys 29 s of 190 s). The heap keeps what it has instead: blocks under 32 MiB come from it,
// and only more than 1 GiB free at its top is returned. Once per process; a diagnosis runs to
// its end and exits, so the memory held is its own peak.
void keepFreedPlanes() {
    static const bool once = [] {
        mallopt(M_MMAP_THRESHOLD, 32 << 20);
        mallopt(M_TRIM_THRESHOLD, 1 << 30);
        return true;
    }();
    (void)once;
}

}  // namespace

// Ring kernel of a halo: the ring radius R with a radial width of a tenth of R (at least half
// a pixel), the blur of its edge being left to the MTF (docs/diagnose.md).
std::function<double(double)> ringKernel(double r_um, double pitch_um) {
    const double s = std::max(0.5 * pitch_um, 0.1 * r_um);
    return [r_um, s](double r) {
        const double u = (r - r_um) / s;
        return u * u > 40.0 ? 0.0 : std::exp(-0.5 * u * u);
    };
}

LagFilter::LagFilter(const MeanModel& mm, double period_s, double gate_s, std::size_t pixels)
    : W_(static_cast<float>(mm.persistW)), n_(pixels) {
    if (W_ == 0.0f) return;
    if (mm.persistPower > 0.0) {
        h_ = hyperbolicShares(mm.persistPower);
        history_.assign(h_.size(), std::vector<float>(pixels, 0.0f));
        return;
    }
    fin_ = static_cast<float>(
        sensor::PhosphorStage::inPeriodFraction(mm.persistTau_s, gate_s, period_s));
    dc_ = static_cast<float>(std::exp(-period_s / mm.persistTau_s));
    st_.assign(pixels, 0.0f);
}

std::vector<double> LagFilter::hyperbolicShares(double power) {
    std::vector<double> h(kHyperbolicCalls);
    double sum = 0.0;
    for (int j = 1; j <= kHyperbolicCalls; ++j) {
        // ∫_j^{j+1} t^−n dt, n > 1 (n = 1: the logarithm's difference).
        const double v =
            std::fabs(power - 1.0) < 1e-9
                ? std::log1p(1.0 / j)
                : (std::pow(j, 1.0 - power) - std::pow(j + 1.0, 1.0 - power)) / (power - 1.0);
        h[static_cast<std::size_t>(j - 1)] = v;
        sum += v;
    }
    for (double& v : h)
        v /= sum;
    return h;
}

void LagFilter::step(const float* x, float* out) {
    if (W_ == 0.0f) {
        if (out != x) std::copy_n(x, n_, out);
        return;
    }
    if (h_.empty()) {
        for (std::size_t p = 0; p < n_; ++p) {
            const float v = (1.0f - W_) * x[p] + W_ * (fin_ * x[p] + (1.0f - dc_) * st_[p]);
            st_[p] = dc_ * st_[p] + (1.0f - fin_) * x[p];
            out[p] = v;
        }
        return;
    }
    const std::size_t J = history_.size();
    if (!started_) {
        for (auto& h : history_)
            std::copy_n(x, n_, h.data());
        started_ = true;
    }
    // newest_ holds call c − 1; call c − j is (newest_ + j − 1) mod J.
    acc_.assign(n_, 0.0f);
    for (std::size_t j = 0; j < J; ++j) {
        const float hj = static_cast<float>(h_[j]);
        const float* q = history_[(newest_ + j) % J].data();
        for (std::size_t p = 0; p < n_; ++p)
            acc_[p] += hj * q[p];
    }
    newest_ = (newest_ + J - 1) % J;  // the oldest (call c − J) becomes call c
    std::copy_n(x, n_, history_[newest_].data());
    for (std::size_t p = 0; p < n_; ++p)
        out[p] = (1.0f - W_) * history_[newest_][p] + W_ * acc_[p];
}

std::function<double(double)> expKernel(double s_um) {
    return [s_um](double r) { return std::exp(-r / s_um); };
}

std::vector<LightSpread> lightSpreads(const Work& w, const MeanModel& mm) {
    std::vector<LightSpread> s;
    if (mm.haloF != 0.0) s.push_back({mm.haloF, ringKernel(mm.haloR_um, w.pitchX_um)});
    if (mm.glareG != 0.0) s.push_back({mm.glareG, expKernel(mm.glareS_um)});
    return s;
}

namespace {

void spread2(Work& w, std::vector<Plane>& Y, double frac,
             const std::function<double(double)>& kernel) {
    std::vector<Plane> K;
    w.conv->setFrames(Y);
    w.conv->convolve(kernel, K);
    for (std::size_t i = 0; i < Y.size(); ++i)
        for (std::size_t p = 0; p < Y[i].size(); ++p)
            Y[i][p] = static_cast<float>((1.0 - frac) * Y[i][p] + frac * K[i][p]);
}

// Per-call planes with bright-source protection and the added phosphor component applied, of
// the model's signal or of the calls' planes `from` (from->of[c] for every call up to the
// last needed).
std::vector<Plane> perCall(const Work& w, const MeanModel& mm, const std::vector<char>& needed,
                           const CallPlanes* from = nullptr) {
    const ModelRun& m = w.m;
    const std::size_t n = static_cast<std::size_t>(w.w) * w.h;
    std::vector<Plane> out(needed.size());
    LagFilter lag(mm, m.period_s, m.gate_s, n);
    Plane x(n);
    for (std::size_t c = 0; c < needed.size(); ++c) {
        double f = 1.0;
        if (mm.bspKnee_A > 0.0)
            f = 1.0 / (1.0 + std::pow(m.cathode_A[c] / mm.bspKnee_A, mm.bspExponent));
        const Plane& X = from ? from->planes[static_cast<std::size_t>(from->of[c])] : w.signal()[c];
        for (std::size_t p = 0; p < n; ++p)
            x[p] = static_cast<float>(X[p] * f);
        lag.step(x.data(), x.data());
        if (needed[c]) out[c] = x;
    }
    return out;
}

// S[i] += MTF ⊛ (Q(1 − e^(−U/Q)) − U), U = unblurred[i].
void addSaturation(Work& w, const MeanModel& mm, std::vector<Plane>& S,
                   const std::vector<Plane>& unblurred) {
    if (!w.blur)
        w.blur = std::make_shared<sensor::BlurStage>(w.cam, sensor::ChainOptions{}, w.configDir);
    const double q = mm.satQ_dc;
    for (std::size_t i = 0; i < S.size(); ++i) {
        const Plane& U = unblurred[i];
        for (int y = 0; y < w.h; ++y) {
            float* row = w.blur->inputRow(y);
            for (int x = 0; x < w.w; ++x) {
                const double u = U[static_cast<std::size_t>(y) * w.w + x];
                row[x] = static_cast<float>(q * -std::expm1(-u / q) - u);
            }
        }
        if (w.blur->enabled()) w.blur->filter();
        for (int y = 0; y < w.h; ++y) {
            const float* r = w.blur->enabled() ? w.blur->outputRow(y) : w.blur->inputRow(y);
            for (int x = 0; x < w.w; ++x)
                S[i][static_cast<std::size_t>(y) * w.w + x] += r[x];
        }
    }
}

// FNV-1a over the planes' bytes: identifies the planes a spread was made of (Work::SpreadMemo).
std::uint64_t planesHash(const std::vector<Plane>& P) {
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (const Plane& p : P) {
        const auto* b = reinterpret_cast<const unsigned char*>(p.data());
        for (std::size_t i = 0; i < p.size() * sizeof(float); ++i)
            h = (h ^ b[i]) * 0x100000001b3ull;
        h = (h ^ p.size()) * 0x100000001b3ull;
    }
    return h;
}

// The spatial effects in the camera's order: veiling glare (in the lens) and the halo (at the
// MCP's input) spread the light, the MCP saturates what reaches it, the chain's MTF blurs that,
// and the baseline's extra blur acts on the whole image. Spreads and blurs are linear and
// commute, so the signal is spread as it is and the saturation's change is computed on the
// unblurred image spread the same way:
//   S ← L(S) + MTF ⊛ (Q(1 − e^(−L(U)/Q)) − L(U)),   L = glare ∘ halo.
// `unblurred` holds U for each plane of S (used with saturation only).
void spatialEffects(Work& w, const MeanModel& mm, std::vector<Plane>& S,
                    const std::vector<Plane>& unblurred) {
    const std::vector<LightSpread> light = lightSpreads(w, mm);
    auto spreads = [&](std::vector<Plane>& P) {
        for (const LightSpread& l : light)
            spread2(w, P, l.fraction, l.kernel);
    };
    const bool sat = mm.satQ_dc > 0.0;
    if (!sat || light.empty()) {
        spreads(S);
        if (sat) addSaturation(w, mm, S, unblurred);
    } else {
        const std::uint64_t hs = planesHash(S), hu = planesHash(unblurred);
        Work::SpreadMemo* memo = w.spreadMemo.get();
        if (memo == nullptr || memo->haloF != mm.haloF || memo->haloR_um != mm.haloR_um ||
            memo->glareG != mm.glareG || memo->glareS_um != mm.glareS_um || memo->hashS != hs ||
            memo->hashU != hu) {
            auto m = std::make_shared<Work::SpreadMemo>();
            m->haloF = mm.haloF;
            m->haloR_um = mm.haloR_um;
            m->glareG = mm.glareG;
            m->glareS_um = mm.glareS_um;
            m->hashS = hs;
            m->hashU = hu;
            m->S = S;
            m->U = unblurred;
            w.spreadMemo.reset();  // its planes freed before the new ones are spread
            spreads(m->S);
            spreads(m->U);
            w.spreadMemo = m;
            memo = m.get();
        }
        S = memo->S;
        addSaturation(w, mm, S, memo->U);
    }
    if (mm.sigma_px > 0.0)
        for (Plane& p : S)
            gaussianBlur(p, w.w, w.h, mm.sigma_px);
}

}  // namespace

Work::Work(const Dataset& ds, const ModelRun& mr, const sensor::CameraParams& c, Options o,
           Progress p, std::filesystem::path config)
    : d(ds), m(mr), cam(c), opt(o), progress(std::move(p)), configDir(std::move(config)) {
    keepFreedPlanes();
    w = d.width;
    h = d.height;
    const int n = static_cast<int>(d.frameCount());
    std::vector<int> a, b;
    for (int k = 2; k < n; ++k) {
        (k < n / 2 ? a : b).push_back(k);
    }
    int cap = opt.maxFramesPerSplit;
    if (cap <= 0) cap = std::clamp(static_cast<int>(3.0e6 / (static_cast<double>(w) * h)), 6, 64);
    cal = spread(a, cap);
    ho = spread(b, cap);
    sub = cal;
    sub.insert(sub.end(), ho.begin(), ho.end());
    tile = static_cast<double>(w) * h > 200000.0 ? 16 : 8;
    tilesX = std::max(1, w / tile);
    tilesY = std::max(1, h / tile);
    stile = tile;
    stilesX = std::max(1, w / stile);
    stilesY = std::max(1, h / stile);
    if (cam.full_well_e > 0.0)
        fullWell_dc = static_cast<float>(0.95 * cam.full_well_e * cam.video_gain_dc_per_e);
    pitchX_um = cam.pitch_x_um * cam.taper_magnification;
    pitchY_um = cam.pitch_y_um * cam.taper_magnification;
    conv = std::make_unique<Convolver>(w, h, pitchX_um, pitchY_um);
    // The model's noise variance per tile on the held-out frames: each tile's squared error is
    // weighed by it, so that a tile counts by how far it is from its noise, not by its level.
    tileVar.assign(static_cast<std::size_t>(scoreTiles()), 0.0);
    std::vector<double> cnt(tileVar.size(), 0.0);
    // The same frames give the model's noise variance as a line in its signal, e² = s0 + s1·S,
    // by least squares where the noisy run is far from both ends of the ADC (shot noise through
    // the MCP has a variance linear in the signal): setHeadroom.
    const double top = m.maxDc - 0.5;
    double np = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    Plane S;
    for (int k : ho) {
        assembleFrame(m.signal, k, w, h, m.fieldScan, S);
        const Plane& N = m.noisy[static_cast<std::size_t>(k)];
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const std::size_t q = static_cast<std::size_t>(y) * w + x;
                const double mean = m.offset_dc + S[q];
                const double e = N[q] - mean;
                tileVar[static_cast<std::size_t>(scoreTileOf(x, y))] += e * e;
                cnt[static_cast<std::size_t>(scoreTileOf(x, y))] += 1.0;
                if (!(N[q] > 0.5f) || mean > 0.6 * top || mean < 0.0) continue;
                np += 1;
                sx += S[q];
                sy += e * e;
                sxx += static_cast<double>(S[q]) * S[q];
                sxy += S[q] * e * e;
            }
    }
    for (std::size_t t = 0; t < tileVar.size(); ++t)
        tileVar[t] = cnt[t] > 0 ? std::max(tileVar[t] / cnt[t], 0.25) : 1.0;
    if (np < 100) return;
    const double det = np * sxx - sx * sx;
    noiseS1_dc = det > 1e-9 * np * sxx ? std::max((np * sxy - sx * sy) / det, 0.0) : 0.0;
    noiseS0_dc2 = std::max((sy - noiseS1_dc * sx) / np, 0.0);
    setHeadroom();
}

namespace {

// The boundary between signals where `below` holds and where it does not, in [lo, hi], by
// bisection (`below` holds at lo and fails at hi, monotonically): the last signal found where
// it holds (first) and the first where it fails (second).
template <class Pred>
std::pair<double, double> boundary(double lo, double hi, Pred below) {
    for (int i = 0; i < 60; ++i) {
        const double mid = 0.5 * (lo + hi);
        (below(mid) ? lo : hi) = mid;
    }
    return {lo, hi};
}

}  // namespace

void Work::setHeadroom() {
    const double top = m.maxDc - 0.5;
    const double s0 = noiseS0_dc2, s1 = noiseS1_dc;
    auto sigma = [&](double sig) { return std::sqrt(s0 + s1 * std::max(sig, 0.0)); };
    auto edge = [&](double sig) { return 4.5 * sigma(sig) + 0.5; };
    // The largest signal whose mean + 4.5 σ stays under the top, and the smallest whose
    // mean − 4.5 σ stays above 0 (bisection: both sides are monotonic in the signal).
    headroomTop_dc = static_cast<float>(boundary(-m.offset_dc, m.maxDc, [&](double x) {
                                            return m.offset_dc + x + edge(x) < top;
                                        }).first);
    headroomBottom_dc = static_cast<float>(boundary(-m.offset_dc, m.maxDc, [&](double x) {
                                               return m.offset_dc + x - edge(x) <= 0.5;
                                           }).second);
    // The mean fits' band around the top (Work::inClipBand): 2.5 σ either side. At 2.5 σ under the
    // top 0.6 % of the frames clip and the kept mean is low by 0.018 σ (0.5 DC at the PULNiX
    // preset's 30 DC of noise there); 4.5 σ would leave out 135 DC either side of the top on that
    // preset, most of the bright half of a frame, where a flicker or a saturation shows. Only a
    // dataset that clips has the bias: one whose frames never reach the top selects nothing (the
    // band left the brightest surfaces of a moonlit scene out of every fit, and its hidden lunar
    // sky light went unnamed).
    bool clips = false;
    for (const Plane& M : d.frames)
        for (float v : M)
            clips = clips || v >= static_cast<float>(top);
    if (!clips) return;
    const double bandLo = boundary(-m.offset_dc, m.maxDc, [&](double x) {
                              return m.offset_dc + x + 2.5 * sigma(x) < top;
                          }).first;
    const double bandHi = boundary(bandLo, 4.0 * m.maxDc, [&](double x) {
                              return m.offset_dc + x - 2.5 * sigma(x) <= top;
                          }).second;
    Plane S;
    for (int k : sub) {
        assembleFrame(m.signal, k, w, h, m.fieldScan, S);
        std::vector<unsigned char> band(S.size());
        for (std::size_t q = 0; q < S.size(); ++q)
            band[q] = S[q] > bandLo && S[q] < bandHi ? 1 : 0;
        clipBand.push_back(std::move(band));
    }
}

namespace {

// The calls whose planes frames w.sub are assembled from (k and, in field scan, k − 1).
std::vector<char> neededCalls(const Work& w) {
    int maxCall = 0;
    for (int k : w.sub)
        maxCall = std::max(maxCall, k);
    std::vector<char> needed(static_cast<std::size_t>(maxCall) + 1, 0);
    for (int k : w.sub) {
        needed[static_cast<std::size_t>(k)] = 1;
        if (k > 0 && w.m.fieldScan) needed[static_cast<std::size_t>(k - 1)] = 1;
    }
    return needed;
}

// Y + s·(column mean of Y), the chain's interline smear.
void addSmear(const Work& w, double smear, std::vector<Plane>& S) {
    if (smear == 0.0) return;
    for (Plane& p : S) {
        std::vector<double> col(static_cast<std::size_t>(w.w), 0.0);
        for (int y = 0; y < w.h; ++y)
            for (int x = 0; x < w.w; ++x)
                col[static_cast<std::size_t>(x)] += p[static_cast<std::size_t>(y) * w.w + x];
        for (int y = 0; y < w.h; ++y)
            for (int x = 0; x < w.w; ++x)
                p[static_cast<std::size_t>(y) * w.w + x] +=
                    static_cast<float>(smear * col[static_cast<std::size_t>(x)] / w.h);
    }
}

// The calls' planes with protection and the added phosphor component (all calls; the
// needed ones filled).
std::vector<Plane> timeEffects(const Work& w, const MeanModel& mm, const std::vector<char>& needed,
                               bool& modified) {
    modified = mm.persistW != 0.0 || mm.bspKnee_A > 0.0;
    return modified ? perCall(w, mm, needed) : std::vector<Plane>{};
}

}  // namespace

bool spreadsPerCall(const Work& w) {
    return w.m.fieldScan && w.signalOverride == nullptr && !w.m.unblurred.empty();
}

namespace {

// The calls of `src` where take[c], a call equal to the one before (its signal and, with
// saturation, its unblurred image) sharing its plane, with the spatial effects of mm.
CallPlanes spatialCalls(Work& w, const MeanModel& mm, const std::vector<Plane>& src,
                        const std::vector<char>& take) {
    const bool sat = mm.satQ_dc > 0.0;
    CallPlanes cp;
    cp.of.assign(take.size(), -1);
    std::vector<Plane> U;
    for (std::size_t c = 0; c < take.size(); ++c) {
        if (!take[c]) continue;
        // A call that repeats the one before (a held stimulus, no afterglow): one plane.
        if (c > 0 && cp.of[c - 1] >= 0 && src[c] == src[c - 1] &&
            (!sat || w.m.unblurred[c] == w.m.unblurred[c - 1])) {
            cp.of[c] = cp.of[c - 1];
            continue;
        }
        cp.of[c] = static_cast<int>(cp.planes.size());
        cp.planes.push_back(src[c]);
        if (sat) U.push_back(w.m.unblurred[c]);
    }
    spatialEffects(w, mm, cp.planes, U);
    return cp;
}

}  // namespace

CallPlanes distinctCalls(Work& w, const MeanModel& mm) {
    const MeanModel& k = w.spatialKey;
    if (w.spatialCache && k.satQ_dc == mm.satQ_dc && k.sigma_px == mm.sigma_px &&
        k.haloF == mm.haloF && k.haloR_um == mm.haloR_um && k.glareG == mm.glareG &&
        k.glareS_um == mm.glareS_um)
        return *w.spatialCache;
    const std::vector<char> all(neededCalls(w).size(), 1);
    w.spatialCache = std::make_shared<const CallPlanes>(spatialCalls(w, mm, w.signal(), all));
    w.spatialKey = mm;
    return *w.spatialCache;
}

bool viaDistinctCalls(const MeanModel& mm) {
    return mm.persistW != 0.0 || mm.satQ_dc == 0.0;
}

CallPlanes afterglow(const Work& w, const MeanModel& mm, const CallPlanes& spatial) {
    if (mm.persistW == 0.0 && !(mm.bspKnee_A > 0.0)) return spatial;  // nothing in time
    const std::vector<char> needed = neededCalls(w);
    CallPlanes out;
    out.planes = perCall(w, mm, needed, &spatial);
    out.of.assign(needed.size(), -1);
    for (std::size_t c = 0; c < needed.size(); ++c)
        if (needed[c]) out.of[c] = static_cast<int>(c);
    return out;
}

CallPlanes callPlanes(Work& w, const MeanModel& mm) {
    // The added phosphor component is linear in time and the spatial effects act within a
    // call, so they commute: spatial effects on the distinct calls (a held stimulus repeats),
    // the afterglow after. The other order spreads every needed call, which the afterglow
    // makes all distinct.
    // Without saturation the spatial effects are linear, and protection (a factor per call)
    // commutes with them too.
    if (viaDistinctCalls(mm)) return afterglow(w, mm, distinctCalls(w, mm));
    const std::vector<char> needed = neededCalls(w);
    bool modified = false;
    const std::vector<Plane> calls = timeEffects(w, mm, needed, modified);
    return spatialCalls(w, mm, modified ? calls : w.signal(), needed);
}

void assembleCalls(const Work& w, const MeanModel& mm, const CallPlanes& cp,
                   std::vector<Plane>& S) {
    S.resize(w.sub.size());
    for (std::size_t i = 0; i < w.sub.size(); ++i) {
        const int k = w.sub[i];
        S[i].resize(static_cast<std::size_t>(w.w) * w.h);
        for (int y = 0; y < w.h; ++y) {
            const bool now = !w.m.fieldScan || (y & 1) == (k & 1) || k == 0;
            const int c = cp.of[static_cast<std::size_t>(now ? k : k - 1)];
            std::copy_n(
                cp.planes[static_cast<std::size_t>(c)].data() + static_cast<std::size_t>(y) * w.w,
                w.w, S[i].data() + static_cast<std::size_t>(y) * w.w);
        }
    }
    addSmear(w, mm.smear, S);
}

std::vector<Plane> predict(Work& w, const MeanModel& mm) {
    std::vector<Plane> S;
    if (spreadsPerCall(w)) {
        assembleCalls(w, mm, callPlanes(w, mm), S);
        applyRegistered(w, mm, S);
        return S;
    }
    // Frame scan (a call is a frame) or a scenario candidate's stimulus: on the frames.
    const std::vector<char> needed = neededCalls(w);
    bool modified = false;
    const std::vector<Plane> calls = timeEffects(w, mm, needed, modified);
    const std::vector<Plane>& src = modified ? calls : w.signal();
    S.resize(w.sub.size());
    for (std::size_t i = 0; i < w.sub.size(); ++i)
        assembleFrame(src, w.sub[i], w.w, w.h, w.m.fieldScan, S[i]);
    spatialEffects(w, mm, S, w.unblurred);
    addSmear(w, mm.smear, S);
    applyRegistered(w, mm, S);
    return S;
}

namespace {
// Solves the n×n system A x = r (n ≤ 3) by Gaussian elimination with partial pivoting.
bool solve(int n, double A[3][3], double r[3], double x[3]) {
    for (int i = 0; i < n; ++i) {
        int piv = i;
        for (int j = i + 1; j < n; ++j)
            if (std::fabs(A[j][i]) > std::fabs(A[piv][i])) piv = j;
        if (!(std::fabs(A[piv][i]) > 1e-300)) return false;
        std::swap(A[i], A[piv]);
        std::swap(r[i], r[piv]);
        for (int j = i + 1; j < n; ++j) {
            const double f = A[j][i] / A[i][i];
            for (int k = i; k < n; ++k)
                A[j][k] -= f * A[i][k];
            r[j] -= f * r[i];
        }
    }
    for (int i = n - 1; i >= 0; --i) {
        double s = r[i];
        for (int k = i + 1; k < n; ++k)
            s -= A[i][k] * x[k];
        x[i] = s / A[i][i];
    }
    return true;
}
}  // namespace

namespace {
// The normal equations of M ≈ b + a·Y (+ c·B) over the fit frames' valid pixels, with the sums
// of Y and Y² and the count. One sum per distinct entry, kept in registers: this ran in a loop
// over a 3 × 3 array per pixel and took a quarter of a diagnosis.
template <bool kWithB>
void normalSums(const Work& w, const std::vector<Plane>& Y, const std::vector<Plane>* B,
                double A[3][3], double r[3]) {
    double n = 0.0, sy = 0.0, syy = 0.0, sb = 0.0, syb = 0.0, sbb = 0.0;
    double sm = 0.0, sym = 0.0, sbm = 0.0;
    for (std::size_t i = 0; i < w.fitFrames(); ++i) {
        const Plane& M = w.measured(w.sub[i]);
        const float* y = Y[i].data();
        const float* b = kWithB ? (*B)[i].data() : nullptr;
        for (std::size_t p = 0; p < M.size(); ++p) {
            if (!w.valid(M[p], y[p]) || w.inClipBand(i, p)) continue;
            const double yv = y[p], m = M[p];
            n += 1.0;
            sy += yv;
            syy += yv * yv;
            sm += m;
            sym += yv * m;
            if constexpr (kWithB) {
                const double bv = b[p];
                sb += bv;
                syb += yv * bv;
                sbb += bv * bv;
                sbm += bv * m;
            }
        }
    }
    A[0][0] = n;
    A[0][1] = A[1][0] = sy;
    A[1][1] = syy;
    A[0][2] = A[2][0] = sb;
    A[1][2] = A[2][1] = syb;
    A[2][2] = sbb;
    r[0] = sm;
    r[1] = sym;
    r[2] = sbm;
}
}  // namespace

LinFit fitLinear(const Work& w, const std::vector<Plane>& Y, const std::vector<Plane>* B) {
    const int n = B ? 3 : 2;
    double A[3][3] = {}, r[3] = {}, x[3] = {};
    if (B)
        normalSums<true>(w, Y, B, A, r);
    else
        normalSums<false>(w, Y, B, A, r);
    const double cnt = A[0][0], sy = A[0][1], syy = A[1][1];
    // A stimulus with one level cannot tell gain from offset: the offset is then the model's
    // (row 0 becomes b = offset).
    if (cnt > 0 && syy / cnt - (sy / cnt) * (sy / cnt) < 1e-6 * (syy / cnt) + 1e-12) {
        A[0][0] = 1.0;
        for (int b = 1; b < n; ++b)
            A[0][b] = 0.0;
        r[0] = w.m.offset_dc;
    }
    LinFit f;
    if (!solve(n, A, r, x)) return f;
    f.b = x[0];
    f.a = x[1];
    f.c = B ? x[2] : 0.0;
    f.ok = true;
    const float maxDc = static_cast<float>(w.m.maxDc);
    // A local sum: f is written through a pointer that the clip band's bytes may alias, so a
    // sum in f itself went to memory on every pixel (a third of this function's time).
    double sse = 0.0;
    for (std::size_t i = 0; i < w.fitFrames(); ++i) {
        const Plane& M = w.measured(w.sub[i]);
        for (std::size_t p = 0; p < M.size(); ++p) {
            if (!w.valid(M[p], Y[i][p]) || w.inClipBand(i, p)) continue;
            double pr = f.b + f.a * Y[i][p] + (B ? f.c * (*B)[i][p] : 0.0);
            pr = std::clamp(pr, 0.0, static_cast<double>(maxDc));
            sse += (M[p] - pr) * (M[p] - pr);
        }
    }
    f.sseCal = sse;
    return f;
}

std::vector<double> heldoutTileSse(const Work& w, const std::vector<Plane>& Y,
                                   const std::vector<Plane>* B, const LinFit& f, double& rms) {
    std::vector<double> t(static_cast<std::size_t>(w.scoreTiles()), 0.0);
    double sum = 0.0;
    long long cnt = 0;
    for (std::size_t i = w.cal.size(); i < w.sub.size(); ++i) {
        const Plane& M = w.measured(w.sub[i]);
        for (int y = 0; y < w.h; ++y)
            for (int x = 0; x < w.w; ++x) {
                const std::size_t p = static_cast<std::size_t>(y) * w.w + x;
                if (!w.valid(M[p], Y[i][p]) || w.inClipBand(i, p)) continue;
                double pr = f.b + f.a * Y[i][p] + (B ? f.c * (*B)[i][p] : 0.0);
                pr = std::clamp(pr, 0.0, w.m.maxDc);
                const double e = (M[p] - pr) * (M[p] - pr);
                t[static_cast<std::size_t>(w.scoreTileOf(x, y))] += e;
                sum += e;
                ++cnt;
            }
    }
    rms = cnt > 0 ? std::sqrt(sum / static_cast<double>(cnt)) : 0.0;
    for (std::size_t i = 0; i < t.size(); ++i)
        t[i] /= w.tileVar[i];
    return t;
}

Score pairedScore(const std::vector<double>& before, const std::vector<double>& after,
                  double rmsBefore, double rmsAfter, int k) {
    Score s;
    s.rmsBefore = rmsBefore;
    s.rmsAfter = rmsAfter;
    const std::size_t n = before.size();
    if (n < 2) return s;
    double mean = 0.0;
    for (std::size_t i = 0; i < n; ++i)
        mean += before[i] - after[i];
    s.sum = mean;
    mean /= static_cast<double>(n);
    double var = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
        const double d = before[i] - after[i] - mean;
        var += d * d;
    }
    var /= static_cast<double>(n - 1);
    const double se = std::sqrt(var / static_cast<double>(n));
    s.z = se > 0.0 ? mean / se : (mean > 0.0 ? 1e3 : 0.0);
    s.z = std::min(s.z, 1e3);
    s.score = (s.z > 0.0 ? s.z * s.z : 0.0) - k * std::log(static_cast<double>(n));
    return s;
}

double fitBlur(Work& w, const MeanModel& mm) {
    auto sse = [&](double s) {
        MeanModel m = mm;
        m.sigma_px = s;
        const LinFit f = fitLinear(w, predict(w, m), nullptr);
        return f.ok ? f.sseCal : 1e300;
    };
    const double s0 = sse(0.0);
    const double sb = searchLog(sse, 0.15, 3.0, 6);
    return sse(sb) < s0 * (1.0 - 1e-3) ? sb : 0.0;  // a real gain, not rounding
}

double searchLog(const std::function<double(double)>& f, double lo, double hi, int n) {
    const double l0 = std::log(lo), l1 = std::log(hi);
    int best = 0;
    double fb = 0.0;
    std::vector<double> vals(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        vals[static_cast<std::size_t>(i)] = f(std::exp(l0 + (l1 - l0) * i / (n - 1)));
        if (i == 0 || vals[static_cast<std::size_t>(i)] < fb) {
            fb = vals[static_cast<std::size_t>(i)];
            best = i;
        }
    }
    const double step = (l1 - l0) / (n - 1);
    double a = l0 + step * std::max(best - 1, 0), b = l0 + step * std::min(best + 1, n - 1);
    const double g = 0.5 * (std::sqrt(5.0) - 1.0);
    double c = b - g * (b - a), d = a + g * (b - a);
    double fc = f(std::exp(c)), fd = f(std::exp(d));
    for (int it = 0; it < 10; ++it) {
        if (fc < fd) {
            b = d;
            d = c;
            fd = fc;
            c = b - g * (b - a);
            fc = f(std::exp(c));
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + g * (b - a);
            fd = f(std::exp(d));
        }
    }
    const double xm = std::exp(0.5 * (a + b));
    return std::min(fc, fd) <= fb ? xm : std::exp(l0 + step * best);
}

void gaussianBlur(Plane& p, int width, int height, double sigma_px) {
    const int r = std::max(1, static_cast<int>(std::ceil(4.0 * sigma_px)));
    std::vector<double> k(static_cast<std::size_t>(2 * r + 1));
    for (int i = -r; i <= r; ++i)
        k[static_cast<std::size_t>(i + r)] = std::exp(-0.5 * i * i / (sigma_px * sigma_px));
    Plane tmp(p.size());
    auto pass = [&](const Plane& in, Plane& out, bool horizontal) {
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) {
                double s = 0.0, ws = 0.0;
                for (int i = -r; i <= r; ++i) {
                    const int xx = horizontal ? x + i : x, yy = horizontal ? y : y + i;
                    if (xx < 0 || yy < 0 || xx >= width || yy >= height) continue;
                    const double kv = k[static_cast<std::size_t>(i + r)];
                    s += kv * in[static_cast<std::size_t>(yy) * width + xx];
                    ws += kv;
                }
                out[static_cast<std::size_t>(y) * width + x] = static_cast<float>(s / ws);
            }
    };
    pass(p, tmp, true);
    pass(tmp, p, false);
}

double normalCdf(double z) {
    return 0.5 * std::erfc(-z / std::sqrt(2.0));
}

}  // namespace nvs::fit
