// The renderer's coarse radiance tiles (renderer.h: coarseFactor): the direct light on a grid
// every f pixels (the nodes), upsampled to each pixel with bilinear weights restricted to nodes on
// the pixel's own surface, plus the pixel's own sky term; pixels with no such node are shaded at
// full rate.

#include "sim/render/render_impl.h"

namespace nvs::render::detail {
namespace {

void buildWeightsRow(const Ctx& c, int y) noexcept {
    Renderer::Impl& im = *c.im;
    const int f = c.coarse;
    const float invF = 1.0f / static_cast<float>(f);
    const float cx = static_cast<float>(im.camPos.x), cy = static_cast<float>(im.camPos.y),
                cz = static_cast<float>(im.camPos.z);
    const int j = y / f;
    const float fy = static_cast<float>(y - j * f) * invF;
    const int nyRow[2] = {std::min(j * f, im.H - 1), std::min((j + 1) * f, im.H - 1)};
    for (int x = 0, k = 0, xr = 0; x < im.W; ++x, ++xr) {
        if (xr == f) xr = 0, ++k;  // k = x / f, xr = x mod f
        const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
        float* w = &im.uW[4 * i];
        w[0] = w[1] = w[2] = w[3] = 0.0f;
        const int m = im.gMat[i];
        if (m == kMiss) {
            im.uKind[i] = kUpMiss;
            continue;
        }
        const float* pp = &im.gPos[3 * i];
        const float* pn = &im.gNrm[3 * i];
        const float dx = pp[0] - cx, dy = pp[1] - cy, dz = pp[2] - cz;
        const float planeTol = 0.02f + 2e-3f * std::sqrt(dx * dx + dy * dy + dz * dz);
        const float fx = static_cast<float>(xr) * invF;
        const std::int16_t obj = im.gObj[i];
        // All four tests without early exits (the loads stay in the image; branch-free code
        // keeps the pipeline full); invalid taps weigh 0, which adds nothing to the sum.
        float wsum = 0.0f;
        for (int t = 0; t < 4; ++t) {
            const int dj = t >> 1, dk = t & 1;
            const std::size_t q = static_cast<std::size_t>(nyRow[dj]) * im.W +
                                  static_cast<std::size_t>(std::min((k + dk) * f, im.W - 1));
            const float* qn = &im.gNrm[3 * q];
            const float* qp = &im.gPos[3 * q];
            const float cosN = qn[0] * pn[0] + qn[1] * pn[1] + qn[2] * pn[2];
            const float off =
                (qp[0] - pp[0]) * pn[0] + (qp[1] - pp[1]) * pn[1] + (qp[2] - pp[2]) * pn[2];
            const bool ok = (im.gMat[q] == m) & (im.gObj[q] == obj) & !(cosN < 0.95f) &
                            !(std::abs(off) > planeTol);
            w[t] = ok ? (dk ? fx : 1.0f - fx) * (dj ? fy : 1.0f - fy) + 1e-6f : 0.0f;
            wsum += w[t];
        }
        if (!(wsum > 0.0f)) {
            im.uKind[i] = kUpFull;
            continue;
        }
        const float inv = 1.0f / wsum;
        for (int t = 0; t < 4; ++t)
            w[t] *= inv;
        im.uKind[i] = kUpInterp;
    }
}

// Upsampling: each pixel's radiance from its nodes' (precomputed weights) plus its own sky

}  // namespace

// Coarse nodes: radiance without the sky term at every f-th pixel, 16 at a time.
void nodeRows(void* vctx, int j0, int j1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    const int f = c.coarse;
    Counts n;
    for (int jr = j0; jr < j1; ++jr) {
        const int j = rowAt(jr, c.rowStepNodes, im.nodeH);
        const int y = std::min(j * f, im.H - 1);
        std::size_t qi[kPacket], qn[kPacket];
        int nq = 0;
        const auto flush = [&] {
            float out[kBands][kPacket];
            shadeBatch(c, nq, qi, false, out, n);
            for (int k = 0; k < nq; ++k) {
                im.nodeRad[qn[k] * kBands] = out[0][k];
                im.nodeRad[qn[k] * kBands + 1] = out[1][k];
            }
            nq = 0;
        };
        for (int k = 0; k < im.nodeW; ++k) {
            const int x = std::min(k * f, im.W - 1);
            const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
            const std::size_t node = static_cast<std::size_t>(j) * im.nodeW + k;
            if (im.gMat[i] == kMiss) {
                im.nodeRad[node * kBands] = im.nodeRad[node * kBands + 1] = 0.0f;
                continue;
            }
            qi[nq] = i;
            qn[nq++] = node;
            if (nq == kPacket) flush();
        }
        if (nq > 0) flush();
    }
    im.shadow += n.shadow;
    im.secondary += n.secondary;
}

// term; pixels with no node on their surface are shaded at full rate (16 at a time).
void upsampleRows(void* vctx, int y0, int y1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    const int f = c.coarse;
    const std::size_t nw = static_cast<std::size_t>(im.nodeW);
    Counts n;
    for (int yr = y0; yr < y1; ++yr) {
        const int y = shadeRowAt(c, yr);
        if (c.buildWeights && y >= c.weightsLo && y < c.weightsHi) buildWeightsRow(c, y);
        float* pe = c.pe.row(y);
        float* bw = c.bw.row(y);
        const std::size_t nodeRow = static_cast<std::size_t>(y / f) * nw;
        ShadeQueue q;
        for (int x = 0, k = 0, xr = 0; x < im.W; ++x, ++xr) {
            if (xr == f) xr = 0, ++k;  // k = x / f
            const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
            const std::uint8_t kind = im.uKind[i];
            if (kind == kUpInterp) {
                const float* w = &im.uW[4 * i];
                const float* r0 = &im.nodeRad[(nodeRow + static_cast<std::size_t>(k)) * kBands];
                const float* r1 = r0 + nw * kBands;
                const std::size_t mb = std::size_t{im.gMat[i]} * kBands;
                const float svf = im.gSvf[i];
                pe[x] =
                    w[0] * r0[0] + w[1] * r0[2] + w[2] * r1[0] + w[3] * r1[2] + im.kSky[mb] * svf;
                bw[x] = w[0] * r0[1] + w[1] * r0[3] + w[2] * r1[1] + w[3] * r1[3] +
                        im.kSky[mb + 1] * svf;
            } else if (kind == kUpMiss) {
                skyPixel(c, i, x, pe, bw);
            } else {
                q.push(c, i, x, pe, bw, n);
            }
        }
        q.finish(c, pe, bw, n);
    }
    im.shadow += n.shadow;
    im.secondary += n.secondary;
}

}  // namespace nvs::render::detail
