#pragma once
// Internals of diagnose(): the working set (frames of the two splits, tiles), the mean model
// with the effects taken so far, the least-squares fit of gain and offset, and the held-out
// score. effects.cpp builds each effect's candidates on these.

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "sim/fit/conv.h"
#include "sim/fit/diagnose.h"
#include "sim/fit/model.h"

namespace nvs::sensor {
class BlurStage;
}

namespace nvs::fit {

struct RegisteredEffect;

// A registered effect taken (effect_registry.h) and its parameters.
struct AddedEffect {
    const RegisteredEffect* effect;
    std::vector<double> parameters;
};

// The mean model: the chain's mean signal with the effects taken so far (0 = off).
struct MeanModel {
    double sigma_px = 0.0;      // baseline: extra Gaussian blur (MTF)
    double persistW = 0.0;      // phosphor_persistence: weight of the added component
    double persistTau_s = 0.0;  //   and its decay time (the exponential member)
    double persistPower = 0.0;  //   > 0: the hyperbolic member's power n (LagFilter)
    double bspKnee_A = 0.0;     // bright_source_protection: knee current
    double bspExponent = 1.0;
    double satQ_dc = 0.0;                  // mcp_saturation: charge per pixel [model DC]
    double haloF = 0.0, haloR_um = 0.0;    // halo: fraction, ring radius at the cathode
    double glareG = 0.0, glareS_um = 0.0;  // veiling_glare: fraction, scale at the cathode
    double smear = 0.0;                    // vertical_smear: fraction of the column mean
    std::vector<AddedEffect> added;        // registered effects, applied last (predict)
};

// The added phosphor component of a MeanModel as a filter over calls, pixel by pixel:
// out = (1 − W)·x + W·lag. Exponential member (persistTau_s): the component's light integrated
// over each call's period, as the chain's phosphor (PhosphorStage::inPeriodFraction), from a
// dark start. Hyperbolic member (persistPower n): an afterglow I(t) ∝ t^−n, whose light falls
// on the kHyperbolicCalls calls after the one excited, call j ≥ 1 taking ∝ j^(1−n) − (j+1)^(1−n)
// (∫ from jT to (j+1)T); the calls before the first are the first's (the scene was there
// before the recording: a tail of many calls is not settled from a dark start).
class LagFilter {
  public:
    static constexpr int kHyperbolicCalls = 32;
    LagFilter(const MeanModel& mm, double period_s, double gate_s, std::size_t pixels);
    // The next call's input x → out (both `pixels` long; out may be x).
    void step(const float* x, float* out);
    // The hyperbolic member's shares of calls 1..kHyperbolicCalls (summing to 1).
    static std::vector<double> hyperbolicShares(double power);

  private:
    float W_ = 0.0f, fin_ = 1.0f, dc_ = 0.0f;
    std::vector<float> st_;                    // exponential: the stored light
    std::vector<double> h_;                    // hyperbolic: shares of calls 1..J
    std::vector<std::vector<float>> history_;  // hyperbolic: the last J inputs, newest first
    std::vector<float> acc_;                   // hyperbolic: the lag of the call
    std::size_t n_ = 0, newest_ = 0;
    bool started_ = false;
};

// Gain and offset (and one effect amplitude) by least squares on the calibration frames.
struct LinFit {
    double b = 0.0, a = 1.0, c = 0.0;
    double sseCal = 0.0;
    bool ok = false;
};

// Ring kernel of a halo and the exponential kernel of veiling glare (r in µm at the cathode).
std::function<double(double)> ringKernel(double r_um, double pitch_um);
std::function<double(double)> expKernel(double s_um);

// A scored candidate: per-tile held-out squared error and its paired test against `before`.
struct Score {
    double rmsBefore = 0.0, rmsAfter = 0.0, z = 0.0, score = 0.0;
    double sum = 0.0;  // Σ_t (before_t − after_t)
};

struct CallPlanes;

struct Work {
    const Dataset& d;
    const ModelRun& m;
    const sensor::CameraParams& cam;
    Options opt;
    Progress progress;
    int w = 0, h = 0;
    std::vector<int> cal, ho;  // frames of the two splits used for mean effects
    std::vector<int> sub;      // cal then ho
    // fitLinear on every frame of `sub`, not the calibration half only: the final parameter
    // estimates of effects already selected and scored on the held-out half (refitJointly).
    bool fitAll = false;
    std::size_t fitFrames() const { return fitAll ? sub.size() : cal.size(); }
    // Tiles of the noise statistics and of the mean effects' held-out score (8 px, 16 px
    // above 200 000 pixels). The paired test over tiles measures how evenly an effect improves
    // them: one that changes part of the frame (a column's smear, a point's halo, EBI seen in
    // the dim tiles) falls in more small tiles, so its z grows with its spread.
    int tile = 8, tilesX = 0, tilesY = 0;
    int stile = 8, stilesX = 0, stilesY = 0;
    std::vector<double> tileVar;   // the model's noise variance per score tile [DC²]
    std::vector<Plane> unblurred;  // assembled unblurred frames of `sub` (mcp_saturation)
    // Scenario effects (scene_effects.h): the mean signal per call of another stimulus, used in
    // place of m.signal while set.
    const std::vector<Plane>* signalOverride = nullptr;
    const std::vector<Plane>& signal() const { return signalOverride ? *signalOverride : m.signal; }
    // distinctCalls()'s last result and the spatial effects it was made with (engine.cpp).
    std::shared_ptr<const CallPlanes> spatialCache;
    MeanModel spatialKey;
    // The last glare and halo spreads of a signal and its unblurred image (spatialEffects,
    // engine.cpp): a saturation search on top of a halo spreads the same planes at every
    // charge it tries. Keyed by the spreads' parameters and a hash of the planes spread.
    struct SpreadMemo {
        double haloF = 0.0, haloR_um = 0.0, glareG = 0.0, glareS_um = 0.0;
        std::uint64_t hashS = 0, hashU = 0;
        std::vector<Plane> S, U;
    };
    std::shared_ptr<SpreadMemo> spreadMemo;
    std::unique_ptr<Convolver> conv;
    std::shared_ptr<sensor::BlurStage> blur;  // the model's MTF (mcp_saturation)
    double pitchX_um = 0.0, pitchY_um = 0.0;  // a pixel at the photocathode

    std::filesystem::path configDir;

    Work(const Dataset& ds, const ModelRun& mr, const sensor::CameraParams& c, Options o,
         Progress p, std::filesystem::path config);
    // headroomTop_dc, headroomBottom_dc and clipBand from the noise line (the constructor).
    void setHeadroom();
    int tiles() const { return tilesX * tilesY; }
    int tileOf(int x, int y) const {
        return std::min(y / tile, tilesY - 1) * tilesX + std::min(x / tile, tilesX - 1);
    }
    int scoreTiles() const { return stilesX * stilesY; }
    int scoreTileOf(int x, int y) const {
        return std::min(y / stile, stilesY - 1) * stilesX + std::min(x / stile, stilesX - 1);
    }
    const Plane& measured(int frame) const { return d.frames[static_cast<std::size_t>(frame)]; }
    // The noise's re-test beside unexplained structure (diagnose.cpp): the mean signal [DC] of
    // the structures found that are light (a ghost, a gain over the frame), per frame; light
    // the model's noisy run lacks, with its shot noise (noise.cpp). Null: none.
    const std::vector<Plane>* structureLight = nullptr;
    // A measured value inside the ADC's range, where the model is linear: not clipped, and
    // not at the CCD's full well (blooming), where the effects' linear forward models fail.
    bool valid(float v) const { return v > 0.5f && v < static_cast<float>(m.maxDc) - 0.5f; }
    // With the model's prediction there (model DC above offset): also inside the CCD's full
    // well.
    bool valid(float v, float model) const { return valid(v) && model < fullWell_dc; }
    // Frame i of `sub`, pixel p: the model's mean (its own signal, every candidate alike) lies
    // within 2.5 of its noise σ of the ADC's top, in a dataset that clips. There some frames
    // clip and some do not, and the ones kept are the low ones: the kept mean comes out low
    // (on the model's own output at full size, 9184 pixels clipped in its brightest frame, a
    // fitted gain of 0.974 and, through it, a false excess noise of 1.72 for 1.6). The mean
    // fits leave these out. Far above the top every frame clips (left out by its value); a
    // saturation's measured peaks, under the top where the model without it predicts far
    // above, keep their evidence. Decided on the model's signal, not each candidate's
    // prediction, so that every candidate is scored on the same pixels.
    bool inClipBand(std::size_t i, std::size_t p) const {
        return !clipBand.empty() && clipBand[i][p] != 0;
    }
    std::vector<std::vector<unsigned char>> clipBand;  // per frame of `sub`; empty: none
    // valid, and the model's own mean at least 4.5 of its noise σ inside the ADC's range
    // (headroom): for the noise statistics and the residual's structure. Leaving out only the
    // pixels whose measured value is clipped keeps those that happened to fall below the top
    // and drops those above it, so near the top the kept values' variance and mean come out
    // low (on the model's own output, a false excess_noise at z 11.7, noise factor 1.47 for
    // 1.6). A test on the model's mean selects no noise. The mean effects keep `valid` with
    // the narrower inClipBand: the brightest points are the evidence of a saturation, and the
    // model without it predicts them beyond the top.
    bool quiet(float v, float model) const {
        return valid(v, model) && model < headroomTop_dc && model > headroomBottom_dc;
    }
    float fullWell_dc = 3e38f;  // 95 % of the full well in model DC above offset
    // The model's signal [DC above offset] whose mean lies 4.5 σ inside the ADC's range (σ the
    // model's noise at that signal, from its noisy run: Work's constructor).
    float headroomTop_dc = 3e38f, headroomBottom_dc = -3e38f;
    // The model's noise variance at signal S [DC above offset]: noiseS0_dc2 + noiseS1_dc·S (the
    // same fit; 0 and 0 when the noisy run has too few pixels away from the ADC's ends).
    double noiseS0_dc2 = 0.0, noiseS1_dc = 0.0;
};

// The unblurred frames of w.sub from the model's run m (mcp_saturation's forward model).
void assembleUnblurred(Work& w, const ModelRun& m);

// A trial of the report, replacing an earlier trial of the same effect.
void recordTrial(Result& r, const Trial& t);

// The effects a preset switches on that diagnose models itself (halo, veiling glare, MCP
// saturation: Dataset::cameraExtra), as a mean model with nothing else.
MeanModel modelExtras(const FitEffects& e, const ModelRun& m);

// The mean model's signal above offset [model DC] for the frames of w.sub.
std::vector<Plane> predict(Work& w, const MeanModel& mm);

// The spreads of the light in the mean model, in the order both the forward model
// (spatialEffects, engine.cpp) and the noisy re-run (diagnose.cpp) apply them: the halo, then
// veiling glare, each Y ← (1 − fraction)·Y + fraction·K ⊛ Y with its radial kernel K. Empty
// when the model has neither.
struct LightSpread {
    double fraction;
    std::function<double(double)> kernel;
};
std::vector<LightSpread> lightSpreads(const Work& w, const MeanModel& mm);

// The chain spreads a halo or glare over each call's image (a field in field scan), and an
// output frame takes its rows from two calls, which differ wherever the scene changed or the
// phosphor still glows. So in field scan the spatial effects act on the calls' planes, and
// frames are assembled after (spreading the assembled frame lags the halo by half a call:
// with persistence hidden too, the halo fraction came back 11-30 % low and the decay 7-33 %
// high). The saturation and the extra blur act per call too (the chain's MTF blurs each
// field; one model for all candidates, so that a candidate is not scored for a change of
// route). `of[c]` is call c's plane (−1: not needed); a call equal to the one before shares
// its plane.
struct CallPlanes {
    std::vector<Plane> planes;
    std::vector<int> of;
};
// Whether halo and glare are spread per call: field scan, the dataset's own stimulus (a
// scenario candidate's is spread over the assembled frames) and the unblurred run present.
bool spreadsPerCall(const Work& w);
// The planes of the calls w.sub needs, with every effect of mm but the smear.
CallPlanes callPlanes(Work& w, const MeanModel& mm);
// With the added phosphor component: every call's plane (up to the last one w.sub needs, equal
// neighbours shared) with mm's spatial effects, and the afterglow (and protection) of mm over
// such planes, for the calls w.sub needs. callPlanes(w, mm) = afterglow(w, mm,
// distinctCalls(w, mm)) then; a spread K is added as afterglow(K ⊛ distinctCalls).
// The last result is kept (Work::spatialCache): the searches of a time effect (afterglow,
// protection) on top of a halo or glare reuse it.
CallPlanes distinctCalls(Work& w, const MeanModel& mm);
CallPlanes afterglow(const Work& w, const MeanModel& mm, const CallPlanes& spatial);
// Whether callPlanes(w, mm) is afterglow(w, mm, distinctCalls(w, mm)): with an afterglow, or
// without saturation (then every spatial effect is linear and commutes with protection).
bool viaDistinctCalls(const MeanModel& mm);
// Frames of w.sub assembled from the calls' planes as the chain's output, smear added.
void assembleCalls(const Work& w, const MeanModel& mm, const CallPlanes& cp, std::vector<Plane>& S);

// b + a·Y + c·B on the calibration frames (B may be null).
LinFit fitLinear(const Work& w, const std::vector<Plane>& Y, const std::vector<Plane>* B);
// Held-out squared error per tile of b + a·Y + c·B (clipped to the ADC range) over the tile's
// noise variance (Work::tileVar), and the RMS error [DC].
std::vector<double> heldoutTileSse(const Work& w, const std::vector<Plane>& Y,
                                   const std::vector<Plane>* B, const LinFit& f, double& rms);
// Paired test over tiles: d_t = before_t − after_t; z = mean/se; score = z² − k·ln(tiles).
Score pairedScore(const std::vector<double>& before, const std::vector<double>& after,
                  double rmsBefore, double rmsAfter, int k);

// The extra Gaussian blur σ [px] (the MTF) of the mean model mm that fits best on the fit
// frames (searched over 0.15-3 px), or 0 where it lowers the squared error by 0.1 % or less.
double fitBlur(Work& w, const MeanModel& mm);

// Minimises f over [lo, hi] on a log grid of n points, then by golden section.
double searchLog(const std::function<double(double)>& f, double lo, double hi, int n);

// Gaussian blur of a plane, σ in pixels, truncated at 4σ and renormalised at the edges.
void gaussianBlur(Plane& p, int width, int height, double sigma_px);

// Normal CDF.
double normalCdf(double z);

}  // namespace nvs::fit
