#include "sim/fit/fpn_blotch.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "sim/fit/normal_eq.h"
#include "sim/fit/text.h"

namespace nvs::fit {

PatternGroups patternGroups(const Work& w, const Current& cur, std::size_t i0, std::size_t i1) {
    const std::size_t np = static_cast<std::size_t>(w.w) * w.h;
    PatternGroups pg{{Plane(np, 0.0f), Plane(np, 0.0f)},
                     {Plane(np, 0.0f), Plane(np, 0.0f)},
                     {std::vector<float>(np, 0.0f), std::vector<float>(np, 0.0f)},
                     Plane(np, 0.0f)};
    // Two groups with no field in common (in field scan frame k holds fields k and k − 1, so
    // only even frames are used) and, where the split saw more than one stimulus, from
    // different stimuli: a pattern fixed to the sensor is in both, an error of the mean model
    // tied to the scene is not.
    std::vector<int> stimRank;
    for (std::size_t i = i0; i < i1; ++i) {
        const int st = w.d.stimulusOfFrame[static_cast<std::size_t>(w.sub[i])];
        if (std::find(stimRank.begin(), stimRank.end(), st) == stimRank.end())
            stimRank.push_back(st);
    }
    int alt = 0;
    for (std::size_t i = i0; i < i1; ++i) {
        const int k = w.sub[i];
        if (w.m.fieldScan && (k & 1)) continue;
        int g = alt++ & 1;
        if (stimRank.size() >= 2) {
            const int st = w.d.stimulusOfFrame[static_cast<std::size_t>(k)];
            g = static_cast<int>(std::find(stimRank.begin(), stimRank.end(), st) -
                                 stimRank.begin()) &
                1;
        }
        const Plane& M = w.measured(w.sub[i]);
        for (std::size_t p = 0; p < np; ++p) {
            pg.stimulus[p] += cur.Y[i][p] / static_cast<float>(i1 - i0);
            if (!w.quiet(M[p], cur.Y[i][p])) continue;
            pg.A[g][p] += static_cast<float>(M[p] - (cur.fit.b + cur.fit.a * cur.Y[i][p]));
            pg.Y[g][p] += cur.Y[i][p];
            pg.count[g][p] += 1.0f;
        }
    }
    return pg;
}

namespace {

// Residual maps of the split's subset frames, averaged over two interleaved halves, and the
// tiles' covariance of the two and mean product of the two averaged signals.
void fixedPattern(const Work& w, const Current& cur, std::size_t i0, std::size_t i1,
                  std::vector<double>& C, std::vector<double>& q, std::vector<double>& n,
                  std::vector<double>& scale2, Plane* map) {
    const PatternGroups pg = patternGroups(w, cur, i0, i1);
    const Plane* A = pg.A;
    const Plane* Y = pg.Y;
    const std::vector<float>* cnt = pg.count;
    const int T = w.tiles();
    std::vector<double> s1(static_cast<std::size_t>(T), 0.0), s2 = s1, s12 = s1, s11 = s1, s22 = s1;
    C.assign(static_cast<std::size_t>(T), 0.0);
    q = C;
    n = C;
    scale2.assign(C.size(), 1.0);
    for (int y = 0; y < w.h; ++y)
        for (int x = 0; x < w.w; ++x) {
            const std::size_t p = static_cast<std::size_t>(y) * w.w + x;
            if (cnt[0][p] == 0.0f || cnt[1][p] == 0.0f) continue;
            const double a1 = A[0][p] / cnt[0][p], a2 = A[1][p] / cnt[1][p];
            if (map) (*map)[p] = static_cast<float>(0.5 * (a1 + a2));
            const std::size_t t = static_cast<std::size_t>(w.tileOf(x, y));
            s1[t] += a1;
            s2[t] += a2;
            s12[t] += a1 * a2;
            s11[t] += a1 * a1;
            s22[t] += a2 * a2;
            q[t] += cur.fit.a * cur.fit.a * (Y[0][p] / cnt[0][p]) * (Y[1][p] / cnt[1][p]);
            n[t] += 1.0;
        }
    for (int t = 0; t < T; ++t) {
        const std::size_t i = static_cast<std::size_t>(t);
        if (n[i] < 2) continue;
        C[i] = (s12[i] - s1[i] * s2[i] / n[i]) / (n[i] - 1.0);
        q[i] /= n[i];
        // Sampling variance of a covariance of n pairs: (σ₁²σ₂² + C²)/n.
        const double v1 = (s11[i] - s1[i] * s1[i] / n[i]) / (n[i] - 1.0);
        const double v2 = (s22[i] - s2[i] * s2[i] / n[i]) / (n[i] - 1.0);
        scale2[i] = std::max((v1 * v2 + C[i] * C[i]) / n[i], 1e-12);
    }
}

// Held-out comparison of two predictions of a tile observable.
// Each tile's squared error is divided by scale2 (its sampling variance up to a common factor).
Score compare(const std::vector<double>& obs, const std::vector<double>& before,
              const std::vector<double>& after, const std::vector<double>& n,
              const std::vector<double>& scale2, int k) {
    std::vector<double> eb, ea;
    double sb = 0, sa = 0, sn = 0;
    for (std::size_t i = 0; i < obs.size(); ++i) {
        if (!(n[i] > 0)) continue;
        const double b = (obs[i] - before[i]) * (obs[i] - before[i]);
        const double a = (obs[i] - after[i]) * (obs[i] - after[i]);
        eb.push_back(b / scale2[i]);
        ea.push_back(a / scale2[i]);
        sb += b;
        sa += a;
        sn += 1;
    }
    return pairedScore(eb, ea, sn > 0 ? std::sqrt(sb / sn) : 0, sn > 0 ? std::sqrt(sa / sn) : 0, k);
}

constexpr int kLags[] = {0, 1, 2, 3, 5, 8, 12};
constexpr double kSigmas_px[] = {1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 11.0, 16.0, 22.0, 32.0};

// Per-pixel gain deviation of each group, residual / signal, where the signal is well above
// its noise in both groups and the stimulus is flat: at an edge the mean model's own error
// (its blur against the camera's) is tied to the scene, in both groups alike, and would count
// as a pattern.
struct GainMaps {
    std::vector<float> g[2];
    std::vector<float> e[2];  // 1 / (the gain's noise variance + a pattern's, 0.05²)
    std::vector<unsigned char> ok;
};

GainMaps gainMaps(const Work& w, const Current& cur, const PatternGroups& pg) {
    const std::size_t np = static_cast<std::size_t>(w.w) * w.h;
    GainMaps gm{{std::vector<float>(np, 0.0f), std::vector<float>(np, 0.0f)},
                {std::vector<float>(np, 0.0f), std::vector<float>(np, 0.0f)},
                std::vector<unsigned char>(np, 0)};
    // Flat: the model's signal, over every frame of the split (the pixels' own frame sets
    // differ where the measured value reaches the ADC's ends), within 10 % of its 4 neighbours;
    // in field scan the rows above and below of the same field (adjacent rows were exposed at
    // another time, under another stimulus where it changed).
    const Plane& mean = pg.stimulus;
    const std::size_t dy = static_cast<std::size_t>(w.m.fieldScan ? 2 * w.w : w.w);
    const double a = cur.fit.a;
    for (int y = 2; y + 2 < w.h; ++y)
        for (int x = 1; x + 1 < w.w; ++x) {
            const std::size_t p = static_cast<std::size_t>(y) * w.w + x;
            const double m = mean[p];
            if (!(m > 0.0) || pg.count[0][p] == 0.0f || pg.count[1][p] == 0.0f) continue;
            bool flat = true;
            for (const std::size_t q : {p - 1, p + 1, p - dy, p + dy})
                flat = flat && std::fabs(mean[q] - m) <= 0.1 * m;
            if (!flat) continue;
            bool good = true;
            for (int g = 0; g < 2; ++g) {
                const double s = a * pg.Y[g][p] / pg.count[g][p];
                // The mean residual's noise over the group's frames (Work's noise line).
                const double sd =
                    std::sqrt(std::max(w.noiseS0_dc2 + w.noiseS1_dc * s, 1.0) / pg.count[g][p]);
                if (!(s > sd)) {
                    good = false;
                    break;
                }
                gm.g[g][p] = static_cast<float>(pg.A[g][p] / pg.count[g][p] / s);
                gm.e[g][p] = static_cast<float>(1.0 / (sd * sd / (s * s) + 0.0025));
            }
            gm.ok[p] = good ? 1 : 0;
        }
    return gm;
}

// The two groups' gain covariance at each lag (along rows and columns, pooled) within each
// super-tile of S px, the pairs' means taken out.
struct LagObs {
    std::vector<double> C, n, scale2;
    std::vector<int> lag;
};

LagObs lagCovariances(const Work& w, const GainMaps& gm, int S) {
    LagObs o;
    struct Pair {
        double u, v, w;
    };
    std::vector<Pair> pairs;
    const int tx = std::max(1, w.w / S), ty = std::max(1, w.h / S);
    for (int j = 0; j < ty; ++j)
        for (int i = 0; i < tx; ++i) {
            const int x0 = i * S, y0 = j * S;
            const int x1 = i + 1 == tx ? w.w : x0 + S, y1 = j + 1 == ty ? w.h : y0 + S;
            for (const int r : kLags) {
                if (r >= S / 4) break;
                // Weighted by each pair's inverse variance (the gain's noise falls with the
                // signal); the sampling variance from the products' own scatter.
                pairs.clear();
                const auto pair = [&](std::size_t p, std::size_t q) {
                    if (!gm.ok[p] || !gm.ok[q]) return;
                    pairs.push_back(
                        {gm.g[0][p], gm.g[1][q], static_cast<double>(gm.e[0][p]) * gm.e[1][q]});
                };
                for (int y = y0; y < y1; ++y)
                    for (int x = x0; x < x1; ++x) {
                        const std::size_t p = static_cast<std::size_t>(y) * w.w + x;
                        if (r == 0) {
                            pair(p, p);
                            continue;
                        }
                        if (x + r < x1) pair(p, p + static_cast<std::size_t>(r));
                        if (y + r < y1) pair(p, p + static_cast<std::size_t>(r) * w.w);
                    }
                if (pairs.size() < 32) continue;
                double W = 0, W2 = 0, su = 0, sv = 0;
                for (const Pair& q : pairs) {
                    W += q.w;
                    W2 += q.w * q.w;
                    su += q.w * q.u;
                    sv += q.w * q.v;
                }
                const double mu = su / W, mv = sv / W;
                double sc = 0;
                for (const Pair& q : pairs)
                    sc += q.w * (q.u - mu) * (q.v - mv);
                const double C = sc / W / (1.0 - W2 / (W * W));
                double var = 0;
                for (const Pair& q : pairs) {
                    const double d = (q.u - mu) * (q.v - mv) - C;
                    var += q.w * q.w * d * d;
                }
                o.C.push_back(C);
                o.n.push_back(W * W / W2);
                o.scale2.push_back(std::max(var / (W * W), 1e-30));
                o.lag.push_back(r);
            }
        }
    return o;
}

// The variance of the mean of an S × S block of the blotch pattern, in units of its own
// variance: the autocorrelation exp(−r²/4σ²) is separable, so it is the square of the 1-D
// block's.
double blockVariance(double sigma, int S) {
    double v = 0.0;
    for (int d = -(S - 1); d <= S - 1; ++d)
        v += (S - std::abs(d)) * std::exp(-0.25 * d * d / (sigma * sigma));
    v /= static_cast<double>(S) * S;
    return v * v;
}

// The covariance at lag r the member (white², blotch², σ) gives, the super-tile's mean out.
struct Basis {
    std::vector<double> white, blotch;
};
Basis basis(const LagObs& o, double sigma, int S) {
    Basis b;
    const double vs = sigma > 0.0 ? blockVariance(sigma, S) : 0.0;
    for (std::size_t k = 0; k < o.C.size(); ++k) {
        const int r = o.lag[k];
        b.white.push_back((r == 0 ? 1.0 : 0.0) - 1.0 / (static_cast<double>(S) * S));
        b.blotch.push_back(sigma > 0.0 ? std::exp(-0.25 * r * r / (sigma * sigma)) - vs : 0.0);
    }
    return b;
}

// Weighted least squares of C on the two columns, both coefficients ≥ 0 (one is dropped when
// it comes out negative); returns the weighted squared error.
double fitTwo(const LagObs& o, const Basis& b, bool withBlotch, double& pw2, double& pb2) {
    double a11 = 0, a12 = 0, a22 = 0, r1 = 0, r2 = 0;
    for (std::size_t k = 0; k < o.C.size(); ++k) {
        const double wt = 1.0 / o.scale2[k];
        a11 += wt * b.white[k] * b.white[k];
        a12 += wt * b.white[k] * b.blotch[k];
        a22 += wt * b.blotch[k] * b.blotch[k];
        r1 += wt * b.white[k] * o.C[k];
        r2 += wt * b.blotch[k] * o.C[k];
    }
    pw2 = 0.0;
    pb2 = 0.0;
    const double det = a11 * a22 - a12 * a12;
    if (withBlotch && det > 1e-12 * a11 * a22) {
        pw2 = (a22 * r1 - a12 * r2) / det;
        pb2 = (a11 * r2 - a12 * r1) / det;
    }
    if (!withBlotch || pw2 < 0.0 || pb2 < 0.0 || !(det > 1e-12 * a11 * a22)) {
        // One column alone: the better of the two that comes out positive.
        const double w1 = a11 > 0 ? std::max(r1 / a11, 0.0) : 0.0;
        const double b1 = withBlotch && a22 > 0 ? std::max(r2 / a22, 0.0) : 0.0;
        const double e1 = -2.0 * w1 * r1 + w1 * w1 * a11, e2 = -2.0 * b1 * r2 + b1 * b1 * a22;
        pw2 = e1 <= e2 ? w1 : 0.0;
        pb2 = e1 <= e2 ? 0.0 : b1;
    }
    double sse = 0.0;
    for (std::size_t k = 0; k < o.C.size(); ++k) {
        const double e = o.C[k] - pw2 * b.white[k] - pb2 * b.blotch[k];
        sse += e * e / o.scale2[k];
    }
    return sse;
}

std::vector<double> predict(const LagObs& o, double pw2, double pb2, double sigma, int S) {
    const Basis b = basis(o, sigma, S);
    std::vector<double> out(o.C.size());
    for (std::size_t k = 0; k < o.C.size(); ++k)
        out[k] = pw2 * b.white[k] + pb2 * b.blotch[k];
    return out;
}

Score heldOut(const LagObs& o, const std::vector<double>& before, const std::vector<double>& after,
              int k) {
    std::vector<double> eb, ea;
    double sb = 0, sa = 0;
    for (std::size_t i = 0; i < o.C.size(); ++i) {
        const double b = (o.C[i] - before[i]) * (o.C[i] - before[i]);
        const double a = (o.C[i] - after[i]) * (o.C[i] - after[i]);
        eb.push_back(b / o.scale2[i]);
        ea.push_back(a / o.scale2[i]);
        sb += b;
        sa += a;
    }
    const double n = static_cast<double>(std::max<std::size_t>(o.C.size(), 1));
    return pairedScore(eb, ea, std::sqrt(sb / n), std::sqrt(sa / n), k);
}

}  // namespace

BlotchMember fitBlotchMember(const Work& w, const Current& cur) {
    BlotchMember m;
    const std::size_t nc = w.cal.size(), nh = w.ho.size();
    if (nc < 2 || nh < 2) {
        m.why = "fewer than 2 frames per split";
        return m;
    }
    // Super-tiles of 64 px at full size, 48 below 200 000 pixels (Work's tiles are 16 and 8):
    // their means take out a smooth gain (vignetting) and leave blotches up to ~S/3.
    const int S = static_cast<double>(w.w) * w.h > 200000.0 ? 96 : 48;
    const LagObs oc = lagCovariances(w, gainMaps(w, cur, patternGroups(w, cur, 0, nc)), S);
    const LagObs oh = lagCovariances(w, gainMaps(w, cur, patternGroups(w, cur, nc, nc + nh)), S);
    for (std::size_t k = 0; k < oc.C.size(); ++k)
        if (oc.C.size() < 8 || oh.C.size() < 8) {
            m.why = "too few flat, well-lit regions for the pattern's covariance at several lags";
            return m;
        }
    double bestSse = 1e300, pw2 = 0.0, pb2 = 0.0, sigma = 0.0;
    for (const double s : kSigmas_px) {
        if (s > S / 3.0) break;
        double a = 0.0, b = 0.0;
        const double sse = fitTwo(oc, basis(oc, s, S), true, a, b);
        if (sse < bestSse) {
            bestSse = sse;
            pw2 = a;
            pb2 = b;
            sigma = s;
        }
    }
    double ww2 = 0.0, unused = 0.0;
    (void)fitTwo(oc, basis(oc, 0.0, S), false, ww2, unused);
    const double p0 = w.cam.prnu_rel, b0 = w.cam.prnu_blotch_rel;
    const std::vector<double> model = predict(oh, p0 * p0, b0 * b0, w.cam.prnu_blotch_sigma_px, S);
    const std::vector<double> member = predict(oh, pw2, pb2, sigma, S);
    const std::vector<double> white = predict(oh, ww2, 0.0, 0.0, S);
    m.vsModel = heldOut(oh, model, member, 3);
    m.vsWhite = heldOut(oh, white, member, 2);
    m.white_rel = std::sqrt(pw2);
    m.blotch_rel = std::sqrt(pb2);
    m.blotch_sigma_px = sigma;
    m.valid = pb2 > 0.0 && m.blotch_rel < 0.5;
    if (!m.valid) m.why = "no blotches: the pattern's covariance is a cell's alone";
    return m;
}

// fixed_pattern_noise (header): the cell-by-cell PRNU against the model's, and the blotchy
// member where it beats it.
Candidate fixedPatternNoise(const Work& w, const Current& cur, Result& res) {
    Candidate c;
    c.finding.effect = "fixed_pattern_noise";
    const std::size_t nc = w.cal.size(), nh = w.ho.size();
    if (nc < 2 || nh < 2) {
        c.why = "fewer than 2 frames per split";
        return c;
    }
    std::vector<double> Cc, qc, ncnt, Ch, qh, nhcnt, scc, sch;
    Plane map(static_cast<std::size_t>(w.w) * w.h, 0.0f);
    fixedPattern(w, cur, 0, nc, Cc, qc, ncnt, scc, &map);
    fixedPattern(w, cur, nc, nc + nh, Ch, qh, nhcnt, sch, nullptr);
    res.maps.push_back({"residual_calibration_mean", map});
    // The model has no offset pattern (the chain has no DSNU) and its own PRNU: before. After:
    // the PRNU fitted (the preset's one parameter). DSNU and PRNU apart (EMVA 1288) need more
    // than one signal level; the baseline reports that two-parameter split where it exists.
    const double p0model = w.cam.prnu_rel * w.cam.prnu_rel;
    double P = p0model;
    {
        double zero = 0.0;
        weightedLine(qc, Cc, ncnt, zero, P, true);
    }
    double dsnu2 = 0.0, prnu2 = 0.0;
    weightedLine(qc, Cc, ncnt, dsnu2, prnu2, false);
    double qlo = 1e300, qhi = 0.0;
    for (std::size_t i = 0; i < qc.size(); ++i)
        if (ncnt[i] > 0) {
            qlo = std::min(qlo, qc[i]);
            qhi = std::max(qhi, qc[i]);
        }
    const bool levels = qhi > 2.0 * qlo + 1.0;
    if (levels) {
        res.baseline["dsnu_dc"] = std::sqrt(std::max(dsnu2, 0.0));
        res.baseline["prnu_rel"] = std::sqrt(std::max(prnu2, 0.0));
    }
    std::vector<double> before(Ch.size()), after(Ch.size());
    for (std::size_t i = 0; i < Ch.size(); ++i) {
        before[i] = p0model * qh[i];
        after[i] = P * qh[i];
    }
    fillNoiseScore(c, compare(Ch, before, after, nhcnt, sch, 1),
                   "covariance of two independent residual averages per tile, held-out frames");
    const double prnu = std::sqrt(std::max(P, 0.0));
    c.valid = P > 0.0 && prnu < 0.5;
    if (!c.valid) c.why = "no fixed pattern that grows with signal";
    c.finding.parameters = {{"prnu_rel", prnu}};
    char buf[400];
    std::snprintf(
        buf, sizeof buf,
        "a pattern fixed to the sensor: pixel gains differ by %.2f %% rms (PRNU), the "
        "model has %.2f %%%s",
        100.0 * prnu, 100.0 * w.cam.prnu_rel,
        levels ? "" : " (one signal level: an offset pattern, DSNU, would look the same)");
    c.finding.cause = buf;
    c.finding.presetKeys = {{"ccd.prnu_rel", textf("%.6g", prnu)}};
    // The blotchy member, where it beats the cell-by-cell one on held-out frames.
    const BlotchMember bm = fitBlotchMember(w, cur);
    if (bm.valid && bm.vsWhite.z >= w.opt.zMin && bm.vsModel.z > c.finding.z) {
        fillNoiseScore(c, bm.vsModel,
                       "covariance of two independent residual gain maps at lags 0-12 px, held-out "
                       "frames");
        c.valid = true;
        c.why = "";
        c.finding.parameters = {{"prnu_rel", bm.white_rel},
                                {"prnu_blotch_rel", bm.blotch_rel},
                                {"prnu_blotch_sigma_px", bm.blotch_sigma_px}};
        std::snprintf(buf, sizeof buf,
                      "a pattern fixed to the sensor that varies in blotches: gains differ by "
                      "%.2f %% rms over blotches of sigma %.3g px (z %.1f over a cell-by-cell "
                      "pattern), and %.2f %% cell by cell; the model has %.2f %%",
                      100.0 * bm.blotch_rel, bm.blotch_sigma_px, bm.vsWhite.z, 100.0 * bm.white_rel,
                      100.0 * w.cam.prnu_rel);
        c.finding.cause = buf;
        c.finding.presetKeys = {{"ccd.prnu_rel", textf("%.6g", bm.white_rel)},
                                {"ccd.prnu_blotch_rel", textf("%.6g", bm.blotch_rel)},
                                {"ccd.prnu_blotch_sigma_px", textf("%.6g", bm.blotch_sigma_px)}};
    }
    return c;
}

}  // namespace nvs::fit
