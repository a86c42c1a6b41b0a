#include "sim/fit/structure.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "sim/fit/normal_eq.h"

namespace nvs::fit {

namespace {

enum Kind {
    kSmoothGain,
    kFixedColumns,
    kFixedRows,
    kPointMirror,
    kLevel,
    kFrameGain,
    kFrameRows,
    kFrameShift,
    kLag,
    kKinds
};

struct Shape {
    const char* name;
    const char* character;
    bool perFrame;
    const char* what;
};

constexpr Shape kShapes[kKinds] = {
    {"smooth_gain", "spatial", false,
     "a gain that varies smoothly over the frame (vignetting, an uneven photocathode)"},
    {"fixed_columns", "spatial", false, "an offset fixed to each column"},
    {"fixed_rows", "spatial", false, "an offset fixed to each row"},
    {"point_mirror", "spatial", false,
     "a copy of the image rotated 180 deg about its centre (a ghost)"},
    {"level_transfer", "level", false, "a response that bends with the level"},
    {"frame_gain", "temporal", true, "a gain and an offset that change from frame to frame"},
    {"frame_rows", "temporal", true, "row offsets that change from frame to frame"},
    {"frame_shift", "geometric", true, "the image moving by part of a pixel from frame to frame"},
    {"lag", "temporal", false, "part of the previous frame's light carried into the next"},
};

// smooth_gain: 15 terms. The constant is there too: the baseline's gain acts after the
// model's saturation, a gain of the light before it (a vignetted frame's saturated spot keeps
// its level while the panels lose theirs).
constexpr int kLegendreDegree = 4;
constexpr int kLevelKnots = 10;  // level_transfer: hat functions over the predicted range
constexpr double kMirrorBlur_px = 4.0;
constexpr double kMinShare = 0.005;  // of the held-out squared error
constexpr int kMaxStructures = 3;
constexpr double kRivalZ = 3.0;  // a shape this close is checked against the one taken

// Legendre polynomials P0..P_deg at t in [−1, 1].
void legendre(double t, double* out) {
    out[0] = 1.0;
    out[1] = t;
    for (int n = 1; n < kLegendreDegree; ++n)
        out[n + 1] = ((2 * n + 1) * t * out[n] - n * out[n - 1]) / (n + 1);
}

// The frames the shapes work on: residual, prediction and the regressors that are images.
struct Frames {
    int w = 0, h = 0;
    std::vector<Plane> R;   // measured − prediction [DC]; NaN where not valid
    std::vector<Plane> P;   // prediction b + a·Y [DC]
    std::vector<Plane> AY;  // a·Y [DC above offset]
    // a·dY/d(ln L): how the prediction moves when the light L changes by a factor (a gain of
    // the light, before the model's saturation and protection bend it); a·Y where the model
    // is linear.
    std::vector<Plane> G;
    double gain = 1.0;          // a, the baseline's gain
    std::vector<Plane> mirror;  // a·U rotated 180°, blurred by 1 px (and by 4 px: mirrorBlur)
    std::vector<Plane> mirrorBlur;
    std::vector<Plane> lag;      // S_{k−1} − S_k (then × a), S the model's per-call signal
    std::vector<double> lx, ly;  // Legendre values per column and row, kLegendreDegree+1 each
    double levelLo = 0.0, levelHi = 1.0;
};

// The image rotated 180° about its centre: pixel (x, y) from (w − 1 − x, h − 1 − y).
Plane rotated(const Plane& Y) {
    Plane o(Y.size());
    for (std::size_t i = 0; i < Y.size(); ++i)
        o[Y.size() - 1 - i] = Y[i];
    return o;
}

// The images the shapes regress on, for frames `frames` of f. The mirrored copy is of the
// light (a·U, the model's signal before the MTF and before diagnose's saturation): a ghost forms
// in the lens, so a saturated spot's ghost has the spot's light, not its clipped level.
void addImages(const Work& w, const std::vector<int>& frames, Frames& f) {
    for (std::size_t i = 0; i < f.AY.size(); ++i) {
        Plane U;
        if (w.m.unblurred.empty()) {
            U = f.AY[i];
        } else {
            assembleFrame(w.m.unblurred, frames[i], w.w, w.h, w.m.fieldScan, U);
            for (float& v : U)
                v = static_cast<float>(v * f.gain);
        }
        Plane sharp = rotated(U);
        gaussianBlur(sharp, w.w, w.h, 1.0);
        f.mirror.push_back(std::move(sharp));
        Plane b = rotated(U);
        gaussianBlur(b, w.w, w.h, kMirrorBlur_px);
        f.mirrorBlur.push_back(std::move(b));
        const int k = frames[i];
        Plane d(f.AY[i].size(), 0.0f);
        if (k > 0) {
            const Plane& s0 = w.m.signal[static_cast<std::size_t>(k - 1)];
            const Plane& s1 = w.m.signal[static_cast<std::size_t>(k)];
            for (std::size_t p = 0; p < d.size(); ++p)
                d[p] = s0[p] - s1[p];
        }
        f.lag.push_back(std::move(d));
    }
    f.lx.resize(static_cast<std::size_t>(w.w) * (kLegendreDegree + 1));
    f.ly.resize(static_cast<std::size_t>(w.h) * (kLegendreDegree + 1));
    for (int x = 0; x < w.w; ++x)
        legendre(w.w > 1 ? 2.0 * x / (w.w - 1) - 1.0 : 0.0,
                 &f.lx[static_cast<std::size_t>(x) * (kLegendreDegree + 1)]);
    for (int y = 0; y < w.h; ++y)
        legendre(w.h > 1 ? 2.0 * y / (w.h - 1) - 1.0 : 0.0,
                 &f.ly[static_cast<std::size_t>(y) * (kLegendreDegree + 1)]);
    double lo = 1e300, hi = -1e300;
    for (std::size_t i = 0; i < f.P.size(); ++i)
        for (std::size_t p = 0; p < f.P[i].size(); ++p)
            if (std::isfinite(f.R[i][p])) {
                lo = std::min(lo, static_cast<double>(f.P[i][p]));
                hi = std::max(hi, static_cast<double>(f.P[i][p]));
            }
    f.levelLo = lo < hi ? lo : 0.0;
    f.levelHi = lo < hi ? hi : 1.0;
}

// level_transfer's knots, evenly spaced over the predicted range. (Knots denser toward the dark
// end, uniform in the square root of the level, followed a power law's slope there better but
// gave the model's own output a level structure at z 8.2 from its top knot, 3.1 DC at 147 DC,
// in 1 of 2 null datasets, and took a flicker for a level dependence.)
double knotLevel(double lo, double hi, int j) {
    return lo + (hi - lo) * static_cast<double>(j) / (kLevelKnots - 1);
}
// The segment j of level v and its position u in [0, 1] along it.
void levelSegment(double lo, double hi, double v, int& j, double& u) {
    const double t = std::max(v - lo, 0.0) / (hi - lo) * (kLevelKnots - 1);
    j = std::clamp(static_cast<int>(t), 0, kLevelKnots - 2);
    const double a = knotLevel(lo, hi, j), b = knotLevel(lo, hi, j + 1);
    u = std::clamp((v - a) / (b - a), 0.0, 1.0);
}

// The regressors of a fixed shape with a small basis at pixel p of frame i; returns how many.
int basis(Kind k, const Frames& f, std::size_t i, int x, int y, std::size_t p, double* out) {
    switch (k) {
        case kSmoothGain: {
            int n = 0;
            const double* lx = &f.lx[static_cast<std::size_t>(x) * (kLegendreDegree + 1)];
            const double* ly = &f.ly[static_cast<std::size_t>(y) * (kLegendreDegree + 1)];
            for (int dx = 0; dx <= kLegendreDegree; ++dx)
                for (int dy = 0; dx + dy <= kLegendreDegree; ++dy)
                    out[n++] = f.G[i][p] * lx[dx] * ly[dy];
            return n;
        }
        case kPointMirror:
            out[0] = f.mirror[i][p];
            out[1] = f.mirrorBlur[i][p];
            return 2;
        case kLevel: {
            for (int j = 0; j < kLevelKnots; ++j)
                out[j] = 0.0;
            int j = 0;
            double u = 0.0;
            levelSegment(f.levelLo, f.levelHi, f.P[i][p], j, u);
            out[j] = 1.0 - u;
            out[j + 1] = u;
            return kLevelKnots;
        }
        case kLag:
            out[0] = f.lag[i][p];
            return 1;
        default:
            return 0;
    }
}

int basisSize(Kind k) {
    switch (k) {
        case kSmoothGain:
            return (kLegendreDegree + 1) * (kLegendreDegree + 2) / 2;
        case kPointMirror:
            return 2;
        case kLevel:
            return kLevelKnots;
        case kLag:
            return 1;
        default:
            return 0;
    }
}

// A shape's prediction of the residual on every frame of the set.
struct ShapeFit {
    std::vector<Plane> Q;
    std::vector<double> coef;                   // fixed shapes
    std::vector<std::vector<double>> perFrame;  // per-frame shapes: each frame's parameters
};

bool inFold(const Work& w, int x, int y, int fold) {
    return ((x / w.stile + y / w.stile) & 1) == fold;
}

// A fixed shape's prediction with coefficients coef on every frame of f.
std::vector<Plane> predictFixed(const Work& w, Kind k, const Frames& f,
                                const std::vector<double>& coef) {
    std::vector<Plane> Q(f.R.size(), Plane(f.R[0].size(), 0.0f));
    double x[16];
    const int n = basisSize(k);
    for (std::size_t i = 0; i < f.R.size(); ++i)
        for (int y = 0; y < w.h; ++y)
            for (int xx = 0; xx < w.w; ++xx) {
                const std::size_t p = static_cast<std::size_t>(y) * w.w + xx;
                double s = 0.0;
                if (k == kFixedColumns || k == kFixedRows) {
                    s = coef[static_cast<std::size_t>(k == kFixedColumns ? xx : y)];
                } else {
                    basis(k, f, i, xx, y, p, x);
                    for (int j = 0; j < n; ++j)
                        s += x[j] * coef[static_cast<std::size_t>(j)];
                }
                Q[i][p] = static_cast<float>(s);
            }
    return Q;
}

// Fixed shape with a small basis: fitted on frames [0, nFit), predicted everywhere.
ShapeFit fitSmall(const Work& w, Kind k, const Frames& f, std::size_t nFit) {
    const int n = basisSize(k);
    NormalEquations ne(n);
    double x[16];
    for (std::size_t i = 0; i < nFit; ++i)
        for (int y = 0; y < w.h; ++y)
            for (int xx = 0; xx < w.w; ++xx) {
                const std::size_t p = static_cast<std::size_t>(y) * w.w + xx;
                if (!std::isfinite(f.R[i][p])) continue;
                basis(k, f, i, xx, y, p, x);
                ne.add(x, f.R[i][p]);
            }
    ShapeFit t;
    t.coef = ne.solve();
    t.Q = predictFixed(w, k, f, t.coef);
    return t;
}

// An offset per column (or row), the mean residual over frames [0, nFit).
ShapeFit fitLines(const Work& w, bool columns, const Frames& f, std::size_t nFit) {
    const int n = columns ? w.w : w.h;
    std::vector<double> s(static_cast<std::size_t>(n), 0.0), c(s.size(), 0.0);
    for (std::size_t i = 0; i < nFit; ++i)
        for (int y = 0; y < w.h; ++y)
            for (int x = 0; x < w.w; ++x) {
                const std::size_t p = static_cast<std::size_t>(y) * w.w + x;
                if (!std::isfinite(f.R[i][p])) continue;
                const std::size_t j = static_cast<std::size_t>(columns ? x : y);
                s[j] += f.R[i][p];
                c[j] += 1.0;
            }
    ShapeFit t;
    t.coef.resize(s.size());
    for (std::size_t j = 0; j < s.size(); ++j)
        t.coef[j] = c[j] > 0 ? s[j] / c[j] : 0.0;
    t.Q = predictFixed(w, columns ? kFixedColumns : kFixedRows, f, t.coef);
    return t;
}

// Central differences of a·Y along x and y.
void gradients(const Plane& Y, int w, int h, std::size_t p, int x, int y, double& gx, double& gy) {
    const std::size_t xl = x > 0 ? p - 1 : p, xr = x + 1 < w ? p + 1 : p;
    const std::size_t yu = y > 0 ? p - static_cast<std::size_t>(w) : p;
    const std::size_t yd = y + 1 < h ? p + static_cast<std::size_t>(w) : p;
    gx = (Y[xr] - Y[xl]) / static_cast<double>(xr - xl > 1 ? 2 : 1);
    gy = (Y[yd] - Y[yu]) / static_cast<double>(yd - yu > static_cast<std::size_t>(w) ? 2 : 1);
}

// One frame's per-frame shape fitted on the pixels `use` accepts; returns the parameters.
template <class Use>
std::vector<double> fitFrame(const Work& w, Kind k, const Plane& R, const Plane& AY, const Plane& G,
                             Use use) {
    if (k == kFrameRows) {
        std::vector<double> s(static_cast<std::size_t>(w.h), 0.0), c(s.size(), 0.0);
        for (int y = 0; y < w.h; ++y)
            for (int x = 0; x < w.w; ++x) {
                const std::size_t p = static_cast<std::size_t>(y) * w.w + x;
                if (!std::isfinite(R[p]) || !use(x, y)) continue;
                s[static_cast<std::size_t>(y)] += R[p];
                c[static_cast<std::size_t>(y)] += 1.0;
            }
        for (std::size_t j = 0; j < s.size(); ++j)
            s[j] = c[j] > 0 ? s[j] / c[j] : 0.0;
        return s;
    }
    NormalEquations ne(k == kFrameGain ? 2 : 3);
    for (int y = 0; y < w.h; ++y)
        for (int x = 0; x < w.w; ++x) {
            const std::size_t p = static_cast<std::size_t>(y) * w.w + x;
            if (!std::isfinite(R[p]) || !use(x, y)) continue;
            if (k == kFrameGain) {
                const double v[2] = {G[p], 1.0};
                ne.add(v, R[p]);
            } else {
                double v[3] = {0.0, 0.0, 1.0};
                gradients(AY, w.w, w.h, p, x, y, v[0], v[1]);
                ne.add(v, R[p]);
            }
        }
    return ne.solve();
}

double frameValue(const Work& w, Kind k, const std::vector<double>& c, const Plane& AY,
                  const Plane& G, std::size_t p, int x, int y) {
    if (k == kFrameRows) return c[static_cast<std::size_t>(y)];
    if (k == kFrameGain) return c[0] * G[p] + c[1];
    double gx = 0.0, gy = 0.0;
    gradients(AY, w.w, w.h, p, x, y, gx, gy);
    return c[0] * gx + c[1] * gy + c[2];
}

// A per-frame shape, cross-validated within each frame: fitted on one colour of the tiles'
// checkerboard, predicted on the other.
ShapeFit fitPerFrame(const Work& w, Kind k, const Frames& f) {
    ShapeFit t;
    t.Q.assign(f.R.size(), Plane(f.R[0].size(), 0.0f));
    for (std::size_t i = 0; i < f.R.size(); ++i) {
        std::vector<double> both;
        for (int fold = 0; fold < 2; ++fold) {
            const std::vector<double> c = fitFrame(
                w, k, f.R[i], f.AY[i], f.G[i], [&](int x, int y) { return inFold(w, x, y, fold); });
            for (int y = 0; y < w.h; ++y)
                for (int x = 0; x < w.w; ++x)
                    if (!inFold(w, x, y, fold)) {
                        const std::size_t p = static_cast<std::size_t>(y) * w.w + x;
                        t.Q[i][p] =
                            static_cast<float>(frameValue(w, k, c, f.AY[i], f.G[i], p, x, y));
                    }
            both.resize(c.size(), 0.0);
            for (std::size_t j = 0; j < c.size(); ++j)
                both[j] += 0.5 * c[j];
        }
        t.perFrame.push_back(both);
    }
    return t;
}

ShapeFit fitShape(const Work& w, Kind k, const Frames& f, std::size_t nFit) {
    if (k == kFixedColumns || k == kFixedRows) return fitLines(w, k == kFixedColumns, f, nFit);
    if (kShapes[k].perFrame) return fitPerFrame(w, k, f);
    return fitSmall(w, k, f, nFit);
}

struct Scored {
    Score s;               // paired test over the held-out tiles
    double zFrames = 0.0;  // the same over the held-out frames
    double share = 0.0;
};

// Held-out tiles' squared residual over the model's noise, before and after the shape.
Scored score(const Work& w, const Frames& f, const std::vector<Plane>& Q) {
    const std::size_t T = static_cast<std::size_t>(w.scoreTiles());
    std::vector<double> before(T, 0.0), after(T, 0.0), fb, fa;
    double sb = 0.0, sa = 0.0, n = 0.0;
    for (std::size_t i = w.cal.size(); i < f.R.size(); ++i) {
        const double sb0 = sb, sa0 = sa;
        for (int y = 0; y < w.h; ++y)
            for (int x = 0; x < w.w; ++x) {
                const std::size_t p = static_cast<std::size_t>(y) * w.w + x;
                const double r = f.R[i][p];
                if (!std::isfinite(r)) continue;
                const double e = r - Q[i][p];
                const std::size_t t = static_cast<std::size_t>(w.scoreTileOf(x, y));
                before[t] += r * r;
                after[t] += e * e;
                sb += r * r;
                sa += e * e;
                n += 1.0;
            }
        fb.push_back(sb - sb0);
        fa.push_back(sa - sa0);
    }
    for (std::size_t t = 0; t < T; ++t) {
        before[t] /= w.tileVar[t];
        after[t] /= w.tileVar[t];
    }
    Scored out;
    if (!(n > 0)) return out;
    out.s = pairedScore(before, after, std::sqrt(sb / n), std::sqrt(sa / n), 0);
    out.zFrames = pairedScore(fb, fa, 0.0, 0.0, 0).z;
    out.share = sb > 0.0 ? (sb - sa) / sb : 0.0;
    return out;
}

// Whether a shape counts: the paired test over tiles at zMin + 1, or over the held-out frames at
// zMin + 2 (few frames: a stricter bar), and 0.5 % of the held-out squared error. The tiles'
// test counts an effect's unevenness over the frame against it: a ghost is in a few tiles only
// (4.3 % of the error at z 3.6 over tiles), but in every frame.
bool counts(const Work& w, const Scored& s) {
    return (s.s.z >= w.opt.zMin + 1.0 || s.zFrames >= w.opt.zMin + 2.0) && s.share >= kMinShare;
}

// The z a finding reports: the test that passed (the tiles' when both did).
double zOf(const Work& w, const Scored& s) {
    return s.s.z >= w.opt.zMin + 1.0 ? s.s.z : std::max(s.s.z, s.zFrames);
}

// A number with `digits` decimals.
std::string fmt(int digits, double v) {
    char b[64];
    std::snprintf(b, sizeof b, "%.*f", digits, v);
    return b;
}

double rmsOf(const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v)
        s += x * x;
    return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
}

// The finding's summary parameters, its cause line, and its curve or map in the report.
void describe(const Work& w, Kind k, const Frames& f, const ShapeFit& t, Finding& fd, Result& r) {
    const std::string tag = std::string("unexplained_") + kShapes[k].name;
    std::string shape;
    switch (k) {
        case kSmoothGain: {
            Plane map(static_cast<std::size_t>(w.w) * w.h, 1.0f);
            double lo = 1e300, hi = -1e300, corners = 0.0;
            for (int y = 0; y < w.h; ++y)
                for (int x = 0; x < w.w; ++x) {
                    const double* lx = &f.lx[static_cast<std::size_t>(x) * (kLegendreDegree + 1)];
                    const double* ly = &f.ly[static_cast<std::size_t>(y) * (kLegendreDegree + 1)];
                    double g = 0.0;
                    int n = 0;
                    for (int dx = 0; dx <= kLegendreDegree; ++dx)
                        for (int dy = 0; dx + dy <= kLegendreDegree; ++dy)
                            g += t.coef[static_cast<std::size_t>(n++)] * lx[dx] * ly[dy];
                    map[static_cast<std::size_t>(y) * w.w + x] = static_cast<float>(1.0 + g);
                    lo = std::min(lo, 1.0 + g);
                    hi = std::max(hi, 1.0 + g);
                    if ((x == 0 || x == w.w - 1) && (y == 0 || y == w.h - 1))
                        corners += 0.25 * (1.0 + g);
                }
            const float centre = map[static_cast<std::size_t>(w.h / 2) * w.w + w.w / 2];
            fd.parameters = {{"gain_min_rel", lo},
                             {"gain_max_rel", hi},
                             {"corner_over_centre", corners / centre}};
            shape = "the gain ranges " + fmt(3, lo) + "-" + fmt(3, hi) +
                    " over the frame, corners " + fmt(3, corners / centre) + " of the centre";
            r.maps.push_back({tag, std::move(map)});
            break;
        }
        case kFixedColumns:
        case kFixedRows: {
            const bool cols = k == kFixedColumns;
            fd.parameters = {{"rms_dc", rmsOf(t.coef)}};
            shape = fmt(2, rmsOf(t.coef)) + " DC rms between " + (cols ? "columns" : "rows");
            Curve c{tag, cols ? "column" : "row", "offset [DC]", {"fitted"}, {{}}, {{}}};
            for (std::size_t j = 0; j < t.coef.size(); ++j) {
                c.x[0].push_back(static_cast<double>(j));
                c.y[0].push_back(t.coef[j]);
            }
            r.curves.push_back(std::move(c));
            break;
        }
        case kPointMirror:
            fd.parameters = {{"fraction_sharp", t.coef[0]}, {"fraction_blurred", t.coef[1]}};
            shape = fmt(3, t.coef[0] + t.coef[1]) + " of the light as a point-mirrored copy";
            break;
        case kLevel: {
            Curve c{tag, "predicted level [DC]", "measured - predicted [DC]", {"fitted"}, {{}},
                    {{}}};
            double worst = 0.0, at = 0.0;
            for (int j = 0; j < kLevelKnots; ++j) {
                const double lv = knotLevel(f.levelLo, f.levelHi, j);
                c.x[0].push_back(lv);
                c.y[0].push_back(t.coef[static_cast<std::size_t>(j)]);
                if (std::fabs(t.coef[static_cast<std::size_t>(j)]) > std::fabs(worst)) {
                    worst = t.coef[static_cast<std::size_t>(j)];
                    at = lv;
                }
            }
            fd.parameters = {{"largest_deviation_dc", worst}, {"at_level_dc", at}};
            shape = "the response departs from the model's by up to " + fmt(1, worst) + " DC at " +
                    fmt(0, at) + " DC";
            r.curves.push_back(std::move(c));
            break;
        }
        case kFrameGain:
        case kFrameRows:
        case kFrameShift: {
            std::vector<double> g, o;
            Curve c{tag, "held-out frame", k == kFrameShift ? "shift [px]" : "value", {}, {}, {}};
            for (const auto& pf : t.perFrame) {
                if (k == kFrameRows) {
                    g.push_back(rmsOf(pf));
                } else {
                    g.push_back(pf[0]);
                    o.push_back(pf[1]);
                }
            }
            auto centred = [](std::vector<double> v) {
                double m = 0.0;
                for (double x : v)
                    m += x;
                m /= static_cast<double>(std::max<std::size_t>(v.size(), 1));
                for (double& x : v)
                    x -= m;
                return v;
            };
            if (k == kFrameGain) {
                fd.parameters = {{"gain_rms_rel", rmsOf(centred(g))},
                                 {"offset_rms_dc", rmsOf(centred(o))}};
                shape = "the gain varies " + fmt(3, rmsOf(centred(g))) +
                        " rms between frames, the offset " + fmt(2, rmsOf(centred(o))) + " DC";
                c.series = {"gain - 1", "offset [DC]"};
                c.x = {{}, {}};
                c.y = {g, o};
            } else if (k == kFrameRows) {
                fd.parameters = {{"rms_dc", rmsOf(g)}};
                shape = fmt(2, rmsOf(g)) + " DC rms of row offsets in a frame";
                c.series = {"row offsets rms [DC]"};
                c.x = {{}};
                c.y = {g};
            } else {
                // R = α·∂Y/∂x + β·∂Y/∂y: the image moved by (−α, −β) px.
                std::vector<double> s;
                for (std::size_t i = 0; i < g.size(); ++i)
                    s.push_back(std::hypot(g[i], o[i]));
                fd.parameters = {{"shift_rms_px", rmsOf(s)}};
                shape = fmt(2, rmsOf(s)) + " px rms of frame-to-frame shift";
                c.series = {"x", "y"};
                c.x = {{}, {}};
                c.y = {centred(g), centred(o)};
                for (double& v : c.y[0])
                    v = -v;
                for (double& v : c.y[1])
                    v = -v;
            }
            for (std::size_t s = 0; s < c.series.size(); ++s)
                for (std::size_t i = 0; i < c.y[s].size(); ++i)
                    c.x[s].push_back(static_cast<double>(w.sub[i]));
            r.curves.push_back(std::move(c));
            break;
        }
        case kLag:
            fd.parameters = {{"fraction", t.coef[0]}};
            shape = fmt(3, t.coef[0]) + " of the previous frame's change carried";
            break;
        default:
            break;
    }
    fd.cause = std::string("not explained by the catalog: ") + kShapes[k].what + "; " + shape +
               ", " + fmt(1, 100.0 * fd.share) + " % of the held-out squared error";
}

// Shape k fitted and scored on the residual with the prediction Q of another shape taken out.
Scored conditional(const Work& w, Frames& f, Kind k, const std::vector<Plane>& Q) {
    auto shift = [&](float sign) {
        for (std::size_t i = 0; i < f.R.size(); ++i)
            for (std::size_t p = 0; p < f.R[i].size(); ++p)
                if (std::isfinite(f.R[i][p])) f.R[i][p] -= sign * Q[i][p];
    };
    shift(1.0f);
    const ShapeFit t = fitShape(w, k, f, w.cal.size());
    const Scored s = score(w, f, t.Q);
    shift(-1.0f);
    return s;
}

// a·dY/d(ln L) by a finite difference. The model's chain runs are linear in the light; its
// non-linear terms are diagnose's saturation (charge Q) and protection (knee current), so the
// prediction at light (1 + ε)·L is (1 + ε)·Y with Q and the knee divided by 1 + ε.
std::vector<Plane> lightGain(Work& w, const Current& cur) {
    if (cur.mm.satQ_dc == 0.0 && cur.mm.bspKnee_A == 0.0) {
        std::vector<Plane> G = cur.Y;
        for (Plane& g : G)
            for (float& v : g)
                v = static_cast<float>(cur.fit.a * v);
        return G;
    }
    constexpr double eps = 0.05;
    MeanModel mm = cur.mm;
    mm.satQ_dc /= 1.0 + eps;
    mm.bspKnee_A /= 1.0 + eps;
    std::vector<Plane> G = predict(w, mm);
    for (std::size_t i = 0; i < G.size(); ++i)
        for (std::size_t p = 0; p < G[i].size(); ++p)
            G[i][p] = static_cast<float>(cur.fit.a * ((1.0 + eps) * G[i][p] - cur.Y[i][p]) / eps);
    return G;
}

Frames residualFrames(Work& w, const Current& cur) {
    Frames f;
    f.gain = cur.fit.a;
    f.w = w.w;
    f.h = w.h;
    for (std::size_t i = 0; i < w.sub.size(); ++i) {
        const Plane& M = w.measured(w.sub[i]);
        Plane R(M.size()), P(M.size()), AY(M.size());
        for (std::size_t p = 0; p < M.size(); ++p) {
            const double y = cur.Y[i][p];
            const double pr = std::clamp(cur.fit.b + cur.fit.a * y, 0.0, w.m.maxDc);
            P[p] = static_cast<float>(pr);
            AY[p] = static_cast<float>(cur.fit.a * y);
            R[p] = w.quiet(M[p], cur.Y[i][p]) ? static_cast<float>(M[p] - pr)
                                              : std::numeric_limits<float>::quiet_NaN();
        }
        f.R.push_back(std::move(R));
        f.P.push_back(std::move(P));
        f.AY.push_back(std::move(AY));
    }
    f.G = lightGain(w, cur);
    addImages(w, w.sub, f);
    for (Plane& d : f.lag)
        for (float& v : d)
            v = static_cast<float>(v * cur.fit.a);
    return f;
}

}  // namespace

std::vector<StructureFit> findStructure(Work& w, const Current& cur, Result& r) {
    std::vector<StructureFit> found;
    if (w.cal.empty() || w.ho.empty()) return found;
    Frames f = residualFrames(w, cur);
    bool taken[kKinds] = {};
    for (int round = 0; round < kMaxStructures; ++round) {
        int best = -1;
        ShapeFit bestT;
        Scored bestS;
        struct Rival {
            int k;
            ShapeFit t;
            Scored s;
        };
        std::vector<Rival> rivals;
        for (int k = 0; k < kKinds; ++k) {
            if (taken[k]) continue;
            if (w.progress)
                w.progress(std::string("structure round ") + std::to_string(round + 1) + ": " +
                           kShapes[k].name);
            ShapeFit t = fitShape(w, static_cast<Kind>(k), f, w.cal.size());
            const Scored s = score(w, f, t.Q);
            nvs::fit::Trial tr;
            tr.effect = std::string("unexplained:") + kShapes[k].name;
            tr.tried = true;
            tr.z = zOf(w, s);
            tr.score = s.s.score;
            tr.before = s.s.rmsBefore;
            tr.after = s.s.rmsAfter;
            tr.why = kShapes[k].character + std::string(", ") + fmt(2, 100.0 * s.share) +
                     " % of the held-out squared error";
            bool replaced = false;
            for (nvs::fit::Trial& old : r.trials)
                if (old.effect == tr.effect) {
                    old = tr;
                    replaced = true;
                }
            if (!replaced) r.trials.push_back(tr);
            const bool sig = counts(w, s);
            if (sig && (best < 0 || s.s.sum > bestS.s.sum)) {
                if (best >= 0) rivals.push_back({best, std::move(bestT), bestS});
                best = k;
                bestT = std::move(t);
                bestS = s;
            } else if (zOf(w, s) >= kRivalZ && s.share >= 0.5 * kMinShare) {
                rivals.push_back({k, std::move(t), s});
            }
        }
        if (best < 0) break;
        // Shapes can stand in for each other where the stimulus ties them (a ladder whose
        // brightest panels sit in a corner makes a vignetting look like a compression): the
        // one taken must still explain the residual once a rival's prediction is taken out,
        // else the rival that still does on top of it is taken instead.
        for (Rival& rv : rivals) {
            const Scored bestGiven = conditional(w, f, static_cast<Kind>(best), rv.t.Q);
            const Scored rivalGiven = conditional(w, f, static_cast<Kind>(rv.k), bestT.Q);
            if (w.progress)
                w.progress(std::string(kShapes[best].name) + " given " + kShapes[rv.k].name +
                           ": z " + fmt(1, zOf(w, bestGiven)) + "; " + kShapes[rv.k].name +
                           " given " + kShapes[best].name + ": z " + fmt(1, zOf(w, rivalGiven)));
            if (!counts(w, bestGiven) && zOf(w, rivalGiven) > zOf(w, bestGiven)) {
                best = rv.k;
                bestT = std::move(rv.t);
                bestS = rv.s;
            }
        }
        taken[best] = true;
        StructureFit sf;
        sf.kind = best;
        sf.coef = bestT.coef;
        if (best == kLevel) {
            // The knots' range goes with the curve (withoutStructure places them the same).
            sf.coef.push_back(f.levelLo);
            sf.coef.push_back(f.levelHi);
        }
        Finding& fd = sf.finding;
        fd.effect = "unexplained";
        fd.status = "unexplained";
        fd.structure = kShapes[best].name;
        fd.character = kShapes[best].character;
        fd.share = bestS.share;
        fd.z = zOf(w, bestS);
        fd.score = fd.z * fd.z;
        fd.confidence = normalCdf(fd.z);
        fd.heldoutRmsBefore = bestS.s.rmsBefore;
        fd.heldoutRmsAfter = bestS.s.rmsAfter;
        fd.unit = "DC";
        fd.observable = "held-out frames: RMS of measured - predicted over valid pixels";
        describe(w, static_cast<Kind>(best), f, bestT, fd, r);
        if (w.progress) w.progress("unexplained " + fd.structure + ": " + fd.cause);
        for (std::size_t i = 0; i < f.R.size(); ++i)
            for (std::size_t p = 0; p < f.R[i].size(); ++p)
                if (std::isfinite(f.R[i][p])) f.R[i][p] -= bestT.Q[i][p];
        found.push_back(std::move(sf));
    }
    return found;
}

std::vector<Plane> withoutStructure(const Work& w, const Current& cur,
                                    const std::vector<StructureFit>& found) {
    const int n = static_cast<int>(w.d.frameCount());
    std::vector<Plane> out;
    out.reserve(static_cast<std::size_t>(n));
    // One frame at a time (all frames of a long dataset would not fit as planes).
    for (int k = 0; k < n; ++k) {
        Frames f;
        f.gain = cur.fit.a;
        const Plane& M = w.measured(k);
        Plane S;
        assembleFrame(w.m.signal, k, w.w, w.h, w.m.fieldScan, S);
        // The baseline's extra blur, as the mean model has it (a shift's correction is made
        // from the prediction's gradients).
        if (cur.mm.sigma_px > 0.0) gaussianBlur(S, w.w, w.h, cur.mm.sigma_px);
        Plane R(M.size()), P(M.size()), AY(M.size());
        for (std::size_t p = 0; p < M.size(); ++p) {
            const double pr = std::clamp(cur.fit.b + cur.fit.a * S[p], 0.0, w.m.maxDc);
            P[p] = static_cast<float>(pr);
            AY[p] = static_cast<float>(cur.fit.a * S[p]);
            R[p] = w.quiet(M[p], S[p]) ? static_cast<float>(M[p] - pr)
                                       : std::numeric_limits<float>::quiet_NaN();
        }
        f.R.push_back(std::move(R));
        f.P.push_back(std::move(P));
        f.G.push_back(AY);
        f.AY.push_back(std::move(AY));
        addImages(w, std::vector<int>{k}, f);
        for (float& v : f.lag[0])
            v = static_cast<float>(v * cur.fit.a);
        Plane C = M;
        for (const StructureFit& sf : found) {
            const Kind kind = static_cast<Kind>(sf.kind);
            if (kind == kLevel) {
                f.levelLo = sf.coef[kLevelKnots];
                f.levelHi = sf.coef[kLevelKnots + 1];
            }
            ShapeFit t;
            t.coef = sf.coef;
            if (kShapes[kind].perFrame) {
                const std::vector<double> c =
                    fitFrame(w, kind, f.R[0], f.AY[0], f.G[0], [](int, int) { return true; });
                t.Q.assign(1, Plane(M.size(), 0.0f));
                for (int y = 0; y < w.h; ++y)
                    for (int x = 0; x < w.w; ++x) {
                        const std::size_t p = static_cast<std::size_t>(y) * w.w + x;
                        t.Q[0][p] =
                            static_cast<float>(frameValue(w, kind, c, f.AY[0], f.G[0], p, x, y));
                    }
            } else {
                t.Q = predictFixed(w, kind, f, sf.coef);
            }
            for (std::size_t p = 0; p < C.size(); ++p) {
                if (!std::isfinite(f.R[0][p])) continue;
                double q = t.Q[0][p];
                if (kind == kLevel) {
                    // A transfer curve scales the noise too: the deviation from the curve is
                    // divided by its slope, f' from the hat functions' neighbouring knots.
                    int j = 0;
                    double u = 0.0;
                    levelSegment(f.levelLo, f.levelHi, f.P[0][p], j, u);
                    const double span =
                        knotLevel(f.levelLo, f.levelHi, j + 1) - knotLevel(f.levelLo, f.levelHi, j);
                    const double slope = 1.0 + (sf.coef[static_cast<std::size_t>(j + 1)] -
                                                sf.coef[static_cast<std::size_t>(j)]) /
                                                   span;
                    const double dev = f.R[0][p] - q;
                    C[p] = static_cast<float>(f.P[0][p] + dev / std::max(slope, 0.2));
                    f.R[0][p] = static_cast<float>(C[p] - f.P[0][p]);
                    continue;
                }
                C[p] = static_cast<float>(C[p] - q);
                f.R[0][p] = static_cast<float>(f.R[0][p] - q);
            }
        }
        out.push_back(std::move(C));
    }
    return out;
}

}  // namespace nvs::fit
