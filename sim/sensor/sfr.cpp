#include "sim/sensor/sfr.h"

#include <algorithm>
#include <cmath>
#include <complex>

#include "sim/core/error.h"
#include "sim/core/units.h"

namespace nvs::sensor {

namespace {

constexpr int kOver = 4;  // ESF bins per pixel

// Steps 1–2: the edge as the line x = a + b·y through the centroids of each row's derivative.
struct EdgeLine {
    double a = 0.0, b = 0.0;
};
EdgeLine fitEdge(ImageView<const float> roi) {
    const int w = roi.width();
    const int h = roi.height();
    // 1. Edge centroid per row from the derivative [-0.5, 0.5].
    std::vector<double> cy, cx;
    for (int y = 0; y < h; ++y) {
        const float* r = roi.row(y);
        double s = 0.0, sx = 0.0;
        for (int x = 1; x < w - 1; ++x) {
            const double d =
                std::fabs(0.5 * (static_cast<double>(r[x + 1]) - static_cast<double>(r[x - 1])));
            s += d;
            sx += d * x;
        }
        if (s > 0.0) {
            cy.push_back(y);
            cx.push_back(sx / s);
        }
    }
    if (cy.size() < 8) throw SetupError("slantedEdgeSfr: no edge in the ROI");
    // 2. Least-squares line x = a + b·y.
    double my = 0.0, mx = 0.0;
    for (std::size_t i = 0; i < cy.size(); ++i) {
        my += cy[i];
        mx += cx[i];
    }
    my /= static_cast<double>(cy.size());
    mx /= static_cast<double>(cy.size());
    double syy = 0.0, sxy = 0.0;
    for (std::size_t i = 0; i < cy.size(); ++i) {
        syy += (cy[i] - my) * (cy[i] - my);
        sxy += (cy[i] - my) * (cx[i] - mx);
    }
    const double b = sxy / syy;
    return {mx - b * my, b};
}

// Step 3: the ESF, kOver bins per pixel along the edge normal, over the central span where
// every bin is populated.
std::vector<double> binnedEsf(ImageView<const float> roi, const EdgeLine& edge) {
    const int w = roi.width();
    const int h = roi.height();
    const double a = edge.a, b = edge.b;
    const double cosT = 1.0 / std::sqrt(1.0 + b * b);
    // 3. 4× oversampled ESF along the edge normal.
    const double half = 0.5 * w;
    const int nb = static_cast<int>(2.0 * half * kOver) + 1;
    std::vector<double> sum(static_cast<std::size_t>(nb), 0.0);
    std::vector<int> cnt(static_cast<std::size_t>(nb), 0);
    for (int y = 0; y < h; ++y) {
        const float* r = roi.row(y);
        for (int x = 0; x < w; ++x) {
            const double d = (x - (a + b * y)) * cosT;
            const int bin = static_cast<int>(std::floor((d + half) * kOver));
            if (bin < 0 || bin >= nb) continue;
            sum[static_cast<std::size_t>(bin)] += static_cast<double>(r[x]);
            ++cnt[static_cast<std::size_t>(bin)];
        }
    }
    // Only the central span where every bin is populated.
    int lo = 0, hi = nb - 1;
    while (lo < nb && cnt[static_cast<std::size_t>(lo)] == 0)
        ++lo;
    while (hi > lo && cnt[static_cast<std::size_t>(hi)] == 0)
        --hi;
    std::vector<double> esf;
    for (int i = lo; i <= hi; ++i) {
        const auto k = static_cast<std::size_t>(i);
        if (cnt[k] > 0)
            esf.push_back(sum[k] / cnt[k]);
        else
            esf.push_back(esf.empty() ? 0.0 : esf.back());  // rare empty bin: hold
    }
    if (esf.size() < 32) throw SetupError("slantedEdgeSfr: edge span too short");
    return esf;
}

// Step 4: the LSF by central difference, Hamming window centred on its centroid.
std::vector<double> windowedLsf(const std::vector<double>& esf) {
    const int n = static_cast<int>(esf.size());
    std::vector<double> lsf(static_cast<std::size_t>(n), 0.0);
    for (int i = 1; i < n - 1; ++i)
        lsf[static_cast<std::size_t>(i)] =
            0.5 * (esf[static_cast<std::size_t>(i + 1)] - esf[static_cast<std::size_t>(i - 1)]);
    double s = 0.0, si = 0.0;
    for (int i = 0; i < n; ++i) {
        s += std::fabs(lsf[static_cast<std::size_t>(i)]);
        si += std::fabs(lsf[static_cast<std::size_t>(i)]) * i;
    }
    const double c = si / s;
    const double halfWin = std::min(c, n - 1 - c);
    for (int i = 0; i < n; ++i) {
        const double u = (i - c) / halfWin;
        const double win = std::fabs(u) <= 1.0 ? 0.54 + 0.46 * std::cos(kPi * u) : 0.0;
        lsf[static_cast<std::size_t>(i)] *= win;
    }
    return lsf;
}

}  // namespace

SfrResult slantedEdgeSfr(ImageView<const float> roi) {
    if (roi.width() < 16 || roi.height() < 16)
        throw SetupError("slantedEdgeSfr: ROI smaller than 16 x 16");
    const EdgeLine edge = fitEdge(roi);
    const double b = edge.b;
    const std::vector<double> esf = binnedEsf(roi, edge);
    const int n = static_cast<int>(esf.size());
    const std::vector<double> lsf = windowedLsf(esf);
    // 5. DFT modulus up to 1 cycle/pixel, corrected for the derivative and the bin width.
    SfrResult r;
    r.edgeAngle_rad = std::atan(b);
    const double dx = 1.0 / kOver;
    const int nf = n * kOver / 4;  // up to ~1 cyc/px... (k/(n·dx) ≤ 1)
    std::complex<double> dc = 0.0;
    for (int i = 0; i < n; ++i)
        dc += lsf[static_cast<std::size_t>(i)];
    for (int k = 0; k <= nf && k < n / 2; ++k) {
        const double f = k / (n * dx);
        std::complex<double> acc = 0.0;
        for (int i = 0; i < n; ++i)
            acc += lsf[static_cast<std::size_t>(i)] *
                   std::polar(1.0, -kTwoPi * k * static_cast<double>(i) / n);
        double m = std::abs(acc) / std::abs(dc);
        const double xd = kTwoPi * f * dx;  // central difference over ±dx
        if (k > 0) m /= std::sin(xd) / xd;
        const double xb = kPi * f * dx;  // bin width dx
        if (k > 0) m /= std::sin(xb) / xb;
        r.frequency_cyc_px.push_back(f);
        r.sfr.push_back(m);
    }
    return r;
}

double sfrAt(const SfrResult& r, double f) {
    const auto& fr = r.frequency_cyc_px;
    if (fr.empty()) return 0.0;
    if (f <= fr.front()) return r.sfr.front();
    for (std::size_t i = 1; i < fr.size(); ++i) {
        if (f <= fr[i]) {
            const double t = (f - fr[i - 1]) / (fr[i] - fr[i - 1]);
            return r.sfr[i - 1] + t * (r.sfr[i] - r.sfr[i - 1]);
        }
    }
    return r.sfr.back();
}

}  // namespace nvs::sensor
