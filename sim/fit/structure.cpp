#include "sim/fit/structure.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "sim/fit/normal_eq.h"
#include "sim/fit/structure_shapes.h"

namespace nvs::fit {

using namespace shapes;

namespace {

// Legendre polynomials P0..P_deg at t in [−1, 1].
void legendre(double t, double* out) {
    out[0] = 1.0;
    out[1] = t;
    for (int n = 1; n < kLegendreDegree; ++n)
        out[n + 1] = ((2 * n + 1) * t * out[n] - n * out[n - 1]) / (n + 1);
}

// The image rotated 180° about its centre: pixel (x, y) from (w − 1 − x, h − 1 − y).
Plane rotated(const Plane& Y) {
    Plane o(Y.size());
    for (std::size_t i = 0; i < Y.size(); ++i)
        o[Y.size() - 1 - i] = Y[i];
    return o;
}

// The images the shapes regress on, for frames `frames` of f (the mirrored ones only with
// `mirror`). The mirrored copy is of the light (a·U, the model's signal before the MTF and
// before diagnose's saturation): a ghost forms in the lens, so a saturated spot's ghost has the
// spot's light, not its clipped level. The lag's regressor is a·(S_{k−1} − S_k).
void addImages(const Work& w, const std::vector<int>& frames, Frames& f, bool mirror) {
    for (std::size_t i = 0; i < f.AY.size() && mirror; ++i) {
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
    }
    for (std::size_t i = 0; i < f.AY.size(); ++i) {
        const int k = frames[i];
        Plane d(f.AY[i].size(), 0.0f);
        if (k > 0) {
            const Plane& s0 = w.m.signal[static_cast<std::size_t>(k - 1)];
            const Plane& s1 = w.m.signal[static_cast<std::size_t>(k)];
            for (std::size_t p = 0; p < d.size(); ++p)
                d[p] = static_cast<float>(f.gain * (s0[p] - s1[p]));
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
            // With an offset and a gain of the light beside the copy: the baseline, fitted
            // without the ghost, took part of its light into its own offset and gain (at
            // 768 x 494 a 2.2 % ghost raised the offset by 0.4 DC, and a smooth gain, which
            // can lower the dark regions the copy does not reach, explained it better).
            out[0] = f.mirror[i][p];
            out[1] = f.mirrorBlur[i][p];
            out[2] = 1.0;
            out[3] = f.G[i][p];
            return 4;
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
            return 4;
        case kLevel:
            return kLevelKnots;
        case kLag:
            return 1;
        default:
            return 0;
    }
}

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
    // frame_shift has no offset of its own: on frames without contrast (one level each) the
    // shift is not defined and an offset would take the level's error (that is frame_gain's).
    // frame_gain on a frame without contrast (one level): the gain cannot be told from the
    // offset, and the two would come out large and opposite; the offset alone then.
    bool flat = false;
    if (k == kFrameGain) {
        double n = 0.0, sg = 0.0, sgg = 0.0;
        for (int y = 0; y < w.h; ++y)
            for (int x = 0; x < w.w; ++x) {
                const std::size_t p = static_cast<std::size_t>(y) * w.w + x;
                if (!std::isfinite(R[p]) || !use(x, y)) continue;
                n += 1.0;
                sg += G[p];
                sgg += static_cast<double>(G[p]) * G[p];
            }
        const double mean = n > 0.0 ? sg / n : 0.0;
        flat = !(n > 0.0) || sgg / n - mean * mean <= 1e-4 * mean * mean;
    }
    NormalEquations ne(2);
    for (int y = 0; y < w.h; ++y)
        for (int x = 0; x < w.w; ++x) {
            const std::size_t p = static_cast<std::size_t>(y) * w.w + x;
            if (!std::isfinite(R[p]) || !use(x, y)) continue;
            if (k == kFrameGain && flat) {
                const double v[2] = {0.0, 1.0};
                ne.add(v, R[p]);
            } else if (k == kFrameGain) {
                const double v[2] = {G[p], 1.0};
                ne.add(v, R[p]);
            } else {
                double v[2] = {0.0, 0.0};
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
    return c[0] * gx + c[1] * gy;
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
            t.fold[fold].push_back(c);
        }
        t.perFrame.push_back(both);
    }
    return t;
}

// Calls f(group) for each set of frames of one stimulus in one half (indices into w.sub).
template <typename F>
void forEachStimulus(const Work& w, F f) {
    for (int half = 0; half < 2; ++half) {
        const std::size_t i0 = half == 0 ? 0 : w.cal.size();
        const std::size_t i1 = half == 0 ? w.cal.size() : w.sub.size();
        std::vector<bool> done(i1, false);
        for (std::size_t i = i0; i < i1; ++i) {
            if (done[i]) continue;
            const int st = w.d.stimulusOfFrame[static_cast<std::size_t>(w.sub[i])];
            std::vector<std::size_t> group;
            for (std::size_t j = i; j < i1; ++j)
                if (w.d.stimulusOfFrame[static_cast<std::size_t>(w.sub[j])] == st) {
                    group.push_back(j);
                    done[j] = true;
                }
            f(group);
        }
    }
}

// Each frame's parameters in `group` less their mean over the group.
void centreParameters(std::vector<std::vector<double>>& c, const std::vector<std::size_t>& group) {
    std::vector<double> mean(c[group[0]].size(), 0.0);
    for (std::size_t j : group)
        for (std::size_t q = 0; q < mean.size(); ++q)
            mean[q] += c[j][q] / static_cast<double>(group.size());
    for (std::size_t j : group)
        for (std::size_t q = 0; q < mean.size(); ++q)
            c[j][q] -= mean[q];
}

// Whether the two folds' parameters agree where they change between frames of one stimulus:
// each fold's parameters less their mean over the frames of a stimulus, each parameter scaled
// to unit RMS over the frames, correlated between the folds over every frame and parameter;
// z = atanh(r)·√(n − 3), n the pairs less one per stimulus and parameter. The folds share no
// pixel, so without a change from frame to frame their parameters are independent and z is
// standard normal. It weighs every frame alike: the paired tests over tiles and frames count
// the frames whose flicker happens to be near 1 against it (a flicker of ±6.6 % at 256 × 160
// came out at z 3.5 over tiles, its per-frame gains right to ±0.3 %).
double foldAgreement(const Work& w, const ShapeFit& t) {
    if (t.fold[0].size() != w.sub.size() || t.fold[0].empty()) return 0.0;
    const std::size_t np = t.fold[0][0].size();
    std::vector<std::vector<double>> c[2] = {t.fold[0], t.fold[1]};
    double n = 0.0;
    forEachStimulus(w, [&](const std::vector<std::size_t>& g) {
        if (g.size() < 2) {
            for (auto& cf : c)
                for (double& v : cf[g[0]])
                    v = 0.0;
            return;
        }
        n += static_cast<double>((g.size() - 1) * np);
        for (auto& cf : c)
            centreParameters(cf, g);
    });
    if (n < 4.0) return 0.0;
    double sab = 0.0, saa = 0.0, sbb = 0.0;
    for (std::size_t q = 0; q < np; ++q) {
        double ra = 0.0, rb = 0.0;
        for (std::size_t i = 0; i < c[0].size(); ++i) {
            ra += c[0][i][q] * c[0][i][q];
            rb += c[1][i][q] * c[1][i][q];
        }
        if (!(ra > 0.0) || !(rb > 0.0)) continue;
        for (std::size_t i = 0; i < c[0].size(); ++i) {
            const double a = c[0][i][q] / std::sqrt(ra), b = c[1][i][q] / std::sqrt(rb);
            sab += a * b;
            saa += a * a;
            sbb += b * b;
        }
    }
    if (!(saa > 0.0) || !(sbb > 0.0)) return 0.0;
    const double r = std::clamp(sab / std::sqrt(saa * sbb), -0.999999, 0.999999);
    return std::atanh(r) * std::sqrt(n - 3.0);
}

// A temporal shape must change between frames of one stimulus: its part common to the frames
// of a stimulus (in the same half) taken out, prediction and parameters alike, it must still
// explain the held-out frames (z ≥ 3, ShapeFit::within). On a stimulus of one level per frame
// (Table 18-5's uniform frames) a gain and an offset per frame absorb any error of the
// response's level, 65 % of the held-out error there, and would call it temporal; a flicker
// makes frames of one stimulus differ, a level error does not. (Scoring the centred shape
// alone lost flickers: the stimulus's mean flicker then looked like a level dependence.)
void withinStimulus(const Work& w, ShapeFit& t) {
    forEachStimulus(w, [&](const std::vector<std::size_t>& group) {
        Plane mean(t.Q[group[0]].size(), 0.0f);
        for (std::size_t j : group)
            for (std::size_t p = 0; p < mean.size(); ++p)
                mean[p] += t.Q[j][p] / static_cast<float>(group.size());
        for (std::size_t j : group)
            for (std::size_t p = 0; p < mean.size(); ++p)
                t.Q[j][p] -= mean[p];
        centreParameters(t.perFrame, group);
    });
}

ShapeFit fitShape(const Work& w, Kind k, const Frames& f, std::size_t nFit) {
    if (k == kFrameGain || k == kFrameRows) {
        ShapeFit t = fitPerFrame(w, k, f);
        ShapeFit within = t;
        withinStimulus(w, within);
        t.within = std::move(within.Q);
        if (k == kFrameGain) {
            // Each stimulus's frames less their mean: n − 1 degrees of freedom for n frames.
            double s2 = 0.0, dof = 0.0;
            forEachStimulus(w, [&](const std::vector<std::size_t>& g) {
                for (std::size_t j : g)
                    s2 += within.perFrame[j][0] * within.perFrame[j][0];
                dof += static_cast<double>(g.size() - 1);
            });
            t.gainWithinRms = dof > 0.0 ? std::sqrt(s2 / dof) : 0.0;
        }
        t.zFold = foldAgreement(w, t);
        return t;
    }
    if (k == kFixedColumns || k == kFixedRows) return fitLines(w, k == kFixedColumns, f, nFit);
    if (kShapes[k].perFrame) return fitPerFrame(w, k, f);
    return fitSmall(w, k, f, nFit);
}

struct Scored {
    Score s;               // paired test over the held-out tiles
    double zFrames = 0.0;  // the same over the held-out frames
    double zFold = 0.0;    // temporal per-frame shapes: the folds' agreement (foldAgreement)
    double share = 0.0;
    // How large the shape is against its bars (1 and more counts): its share over kMinShare or
    // frame_gain's gain rms within a stimulus over kMinFrameGainRms, the larger; point_mirror's
    // copy's light over kMinMirrorFraction alone.
    double size = 0.0;
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

// A fitted shape's scores: score() of its prediction, with the folds' agreement it carries.
Scored scoreFit(const Work& w, const Frames& f, Kind k, const ShapeFit& t) {
    Scored s = score(w, f, t.Q);
    s.zFold = t.zFold;
    s.size = std::max(s.share / kMinShare, t.gainWithinRms / kMinFrameGainRms);
    // A ghost by the light in its copy alone: its offset and gain would count the baseline's
    // errors as a ghost's.
    if (k == kPointMirror) s.size = mirrorFraction(t.coef) / kMinMirrorFraction;
    return s;
}

// Whether a shape counts: the paired test over tiles at zMin + 1, or over the held-out frames at
// zMin + 2 (few frames: a stricter bar), and 0.5 % of the held-out squared error, or a size of
// its own (Scored::size): frame_gain's gain changing by 1 % rms between frames of one stimulus,
// point_mirror's copy holding 1 % of the light. The tiles' test counts an effect's unevenness
// over the frame against it: a ghost is in a few tiles only (4.3 % of the error at z 3.6 over
// tiles), but in every frame.
bool counts(const Work& w, const Scored& s) {
    return (s.s.z >= w.opt.zMin + 1.0 || s.zFrames >= w.opt.zMin + 2.0 ||
            s.zFold >= w.opt.zMin + 1.0) &&
           s.size >= 1.0;
}

// The z a finding reports: the test that passed (the tiles' when both did).
double zOf(const Work& w, const Scored& s) {
    return s.s.z >= w.opt.zMin + 1.0 ? s.s.z : std::max({s.s.z, s.zFrames, s.zFold});
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
    const Scored s = scoreFit(w, f, k, t);
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
    addImages(w, w.sub, f, true);
    return f;
}

}  // namespace

std::vector<StructureFit> findStructure(Work& w, const Current& cur, Result& r,
                                        double* frameGainShare) {
    std::vector<StructureFit> found;
    if (frameGainShare != nullptr) *frameGainShare = 0.0;
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
        int toTry = 0, tried = 0;
        for (int k = 0; k < kKinds; ++k)
            toTry += taken[k] ? 0 : 1;
        for (int k = 0; k < kKinds; ++k) {
            if (taken[k]) continue;
            if (w.progress)
                w.progress("structure round " + std::to_string(round + 1) + ": " + kShapes[k].name +
                           " (" + std::to_string(++tried) + "/" + std::to_string(toTry) + ")");
            ShapeFit t = fitShape(w, static_cast<Kind>(k), f, w.cal.size());
            const Scored s = scoreFit(w, f, static_cast<Kind>(k), t);
            nvs::fit::Trial tr;
            tr.effect = std::string("unexplained:") + kShapes[k].name;
            tr.tried = true;
            tr.z = zOf(w, s);
            tr.score = s.s.score;
            tr.before = s.s.rmsBefore;
            tr.after = s.s.rmsAfter;
            tr.why = kShapes[k].character + std::string(", ") + fmt(2, 100.0 * s.share) +
                     " % of the held-out squared error";
            if (t.gainWithinRms > 0.0)
                tr.why += ", the gain " + fmt(2, 100.0 * t.gainWithinRms) +
                          " % rms between frames of one stimulus";
            if (k == kPointMirror)
                tr.why +=
                    ", a copy of " + fmt(2, 100.0 * mirrorFraction(t.coef)) + " % of the light";
            bool sig = counts(w, s);
            bool eligible = true;  // a temporal shape that changes within a stimulus
            if (!t.within.empty()) {
                const double zw = std::max(zOf(w, score(w, f, t.within)), t.zFold);
                if (zw < kRivalZ) {
                    sig = false;
                    eligible = false;
                    tr.why += ", but not between frames of one stimulus (z " + fmt(1, zw) + ")";
                }
            }
            recordTrial(r, tr);
            if (round == 0 && k == kFrameGain && frameGainShare != nullptr && counts(w, s))
                *frameGainShare = s.share;
            if (sig && (best < 0 || s.s.sum > bestS.s.sum)) {
                if (best >= 0) rivals.push_back({best, std::move(bestT), bestS});
                best = k;
                bestT = std::move(t);
                bestS = s;
            } else if (eligible && zOf(w, s) >= kRivalZ && s.size >= 0.5) {
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
            // A gain and an offset per frame is the simpler of the two per-frame shapes that
            // hold each other: an offset per row and frame contains its offset, and on uniform
            // frames (Table 18-5's) would take it by a z near 0 against one below 0. The
            // offsets per row replace it only where they still count on top of it.
            const bool simpler = best == kFrameGain && rv.k == kFrameRows;
            if (!counts(w, bestGiven) &&
                (simpler ? counts(w, rivalGiven) : zOf(w, rivalGiven) > zOf(w, bestGiven))) {
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
    // The mirrored images (two blurs a frame) only where a ghost was found.
    bool mirror = false;
    for (const StructureFit& sf : found)
        mirror = mirror || sf.kind == kPointMirror;
    // One frame at a time: only the corrected frames are kept, not each frame's working planes.
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
        addImages(w, std::vector<int>{k}, f, mirror);
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

bool isLight(const StructureFit& s) {
    return s.kind >= 0 && s.kind < kKinds && kShapes[s.kind].light;
}

StructureFit lightPart(StructureFit s) {
    if (s.kind == kPointMirror)
        for (std::size_t j = kMirrorCopyTerms; j < s.coef.size(); ++j)
            s.coef[j] = 0.0;
    return s;
}

}  // namespace nvs::fit
