#include "sim/sensor/stages/mcp.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "sim/core/fast_math.h"
#include "sim/core/rng.h"
#include "sim/core/simd.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/preset_reader.h"

namespace nvs::sensor {

void McpParams::read(const PresetReader& root) {
    const PresetReader bsp = root.sub("bsp");
    bsp_knee_A = positive(bsp, "knee_A", bsp_knee_A);
    bsp_exponent = positive(bsp, "exponent", bsp_exponent);
    const std::string actsOn = bsp.get<std::string>("acts_on", "gain");
    if (actsOn != "gain" && actsOn != "photoelectrons")
        bsp.fail("acts_on", "must be gain or photoelectrons");
    bsp_on_photoelectrons = actsOn == "photoelectrons";

    const PresetReader mcp = root.sub("mcp");
    mcp_enabled = mcp.get<bool>("enabled", mcp_enabled);
    const bool vcFile = mcp.inFile("crossover_V"), vcSet = mcp.overridden("crossover_V");
    mcp_crossover_V = positive(mcp, "crossover_V", mcp_crossover_V);
    luminous_gain_fL_fc = nonNegative(mcp, "luminous_gain_fL_fc", luminous_gain_fL_fc);
    luminous_gain_control_V = nonNegative(mcp, "luminous_gain_control_V", luminous_gain_control_V);
    if (vcFile && mcp.inFile("luminous_gain_fL_fc")) {
        mcp.fail("luminous_gain_fL_fc", "give either crossover_V or the luminous gain, not both");
    }
    if (vcSet && !mcp.overridden("luminous_gain_fL_fc")) luminous_gain_fL_fc = 0.0;  // Vc wins
    mcp_exponent = positive(mcp, "exponent", mcp_exponent);
    mcp_offset_V = mcp.get<double>("offset_V", mcp_offset_V);
    mcp_V_per_control_V = positive(mcp, "V_per_control_V", mcp_V_per_control_V);
    mcp_gain_max = nonNegative(mcp, "gain_max", mcp_gain_max);
    mcp_plate_max_V = nonNegative(mcp, "plate_max_V", mcp_plate_max_V);
    mcp_detection_efficiency = positive(mcp, "detection_efficiency", mcp_detection_efficiency);
    require(mcp_detection_efficiency <= 1.0, mcp, "detection_efficiency", "must be in (0, 1]");
    mcp_noise_factor = mcp.get<double>("noise_factor", mcp_noise_factor);
    require(mcp_noise_factor >= 1.0, mcp, "noise_factor", "F must be >= 1");
    mcp_noise = mcp.get<bool>("noise", mcp_noise);

    const PresetReader sat = root.sub("mcp_saturation");
    mcpsat_enabled = sat.get<bool>("enabled", mcpsat_enabled);
    mcpsat_pixel_charge_e = positive(sat, "pixel_charge_e", mcpsat_pixel_charge_e);
    mcpsat_recharge_s = positive(sat, "recharge_s", mcpsat_recharge_s);
}

double McpParams::plateVoltage_V(double gainControl_V) const {
    const double vm = mcp_offset_V + mcp_V_per_control_V * gainControl_V;
    return mcp_plate_max_V > 0.0 ? std::min(vm, mcp_plate_max_V) : vm;
}

double McpParams::mcpChannelGain(double gainControl_V) const {
    if (!mcp_enabled) return 1.0;
    const double vm = plateVoltage_V(gainControl_V);
    if (vm <= 0.0) return 0.0;
    const double x = std::pow(vm / mcp_crossover_V, mcp_exponent);
    return mcp_gain_max > 0.0 ? x / (1.0 + x / mcp_gain_max) : x;
}

double McpParams::mcpGain(double gainControl_V) const {
    if (!mcp_enabled) return 1.0;
    return mcp_detection_efficiency * mcpChannelGain(gainControl_V);
}

namespace {
// The law's unbounded gain x for a channel gain under the ceiling (x/(1 + x/G_max) = g).
double unboundedGain(double channel, double gainMax) {
    if (!(gainMax > 0.0)) return channel;
    return channel / (1.0 - std::min(channel / gainMax, 0.999));
}
}  // namespace

double McpParams::controlVoltageForGain(double gain) const {
    if (!(gain > 0.0)) return 0.0;
    const double x = unboundedGain(gain / mcp_detection_efficiency, mcp_gain_max);
    const double vm = mcp_crossover_V * std::pow(x, 1.0 / mcp_exponent);
    return (vm - mcp_offset_V) / mcp_V_per_control_V;
}

double McpParams::crossoverForGain(double gain, double gainControl_V) const {
    const double x = unboundedGain(gain / mcp_detection_efficiency, mcp_gain_max);
    return plateVoltage_V(gainControl_V) / std::pow(x, 1.0 / mcp_exponent);
}

namespace {

// Σ v in 16 float lanes, added up in double (as the other row sums).
NVS_SIMD_CLONES double rowSumOf(const float* __restrict v, int w) noexcept {
    constexpr int kL = 16;
    float acc[kL] = {};
    int x = 0;
    for (; x + kL <= w; x += kL) {
        for (int j = 0; j < kL; ++j)
            acc[j] += v[x + j];
    }
    for (; x < w; ++x)
        acc[x % kL] += v[x];
    double sum = 0.0;
    for (int j = 0; j < kL; ++j)
        sum += static_cast<double>(acc[j]);
    return sum;
}

// Noise-free MCP: v·G in place; returns the row sum.
NVS_SIMD_CLONES double mcpMeanKernel(float* __restrict v, int w, float g) noexcept {
    for (int x = 0; x < w; ++x)
        v[x] *= g;
    return rowSumOf(v, w);
}

// Marsaglia–Tsang's first attempt for m pixels with n photoelectrons: e = θ·d·(1 + c·z)³ when
// the squeeze accepts, else 0 (the caller finishes those, and shapes below 1, with
// gammaFromNormal).
NVS_SIMD_CLONES void gammaFirstAttemptKernel(const float* __restrict n, const float* __restrict z,
                                             const std::uint32_t* __restrict uw,
                                             double* __restrict e, int m, double k,
                                             double theta) noexcept {
    for (int j = 0; j < m; ++j) {
        const double shape = static_cast<double>(n[j]) * k;
        const double d = shape - 1.0 / 3.0;
        const double c = 1.0 / std::sqrt(9.0 * (shape >= 1.0 ? d : 1.0));
        const double zz = static_cast<double>(z[j]);
        const double u = uniformFromWord(uw[j]);
        double t = 1.0 + c * zz;
        t = t * t * t;
        const bool ok = (shape >= 1.0) & (t > 0.0) & (u < 1.0 - 0.0331 * (zz * zz) * (zz * zz));
        e[j] = ok ? theta * d * t : 0.0;
    }
}

// MCP row scans (McpStage::applyRow): how many pixels draw (v > 0), and whether any draw of
// a chunk of 16 is past the table (e < 0).
NVS_SIMD_CLONES int countPositive(const float* __restrict v, int w) noexcept {
    int m = 0;
    for (int x = 0; x < w; ++x)
        m += v[x] > 0.0f ? 1 : 0;
    return m;
}
NVS_SIMD_CLONES int countNegative(const float* __restrict e, int n) noexcept {
    int any = 0;
    for (int l = 0; l < n; ++l)
        any += e[l] < 0.0f ? 1 : 0;
    return any;
}

}  // namespace

// ---- 4. Bright-source protection ----

BspStage::BspStage(const CameraParams& c)
    : enabled_(c.agc == AgcMode::Bsp), knee_A_(c.bsp_knee_A), exponent_(c.bsp_exponent) {}

double BspStage::factor(double current_A) const noexcept {
    if (!enabled_ || !(current_A > 0.0)) return 1.0;
    // The series resistor R drops V = R·I from the cathode-MCP voltage; near the knee the
    // collection and gain fall together. A smooth 1/(1 + (I/I_knee)^p) keeps the measured
    // behaviour (gain constant at low current, ∝ 1/I above the knee) with two parameters.
    return 1.0 / (1.0 + std::pow(current_A / knee_A_, exponent_));
}

// ---- 5. MCP ---------------------------------------------------------------------------------

McpStage::McpStage(const CameraParams& c, std::uint64_t seed, GammaTableCache& gammaTables)
    : enabled_(c.mcp_enabled),
      noise_(c.mcp_noise && c.mcp_noise_factor > 1.0 + 1e-9),
      k_(c.mcp_noise_factor > 1.0 + 1e-9 ? 1.0 / (c.mcp_noise_factor - 1.0) : 0.0),
      seed_(seed),
      table_(enabled_ && noise_ ? gammaTables.forShapeStep(k_) : nullptr),
      stride_(paddedRow(c.width)),
      words_(new std::uint32_t[kChainSlots * stride_]),
      idx_(new int[kChainSlots * stride_]),
      blocks_(new std::uint32_t[kChainSlots * stride_]),
      uWords_(new std::uint32_t[kChainSlots * stride_]),
      n_(new float[kChainSlots * stride_]),
      e_(new float[kChainSlots * stride_]),
      rest_(new int[kChainSlots * stride_]),
      restN_(new float[kChainSlots * stride_]),
      heads_(new std::uint32_t[kChainSlots * 4 * stride_]),
      z_(new float[kChainSlots * stride_]),
      g_(new double[kChainSlots * stride_]) {}

void McpStage::apply(ImageView<float> pe, FieldContext& ctx) noexcept {
    begin(ctx);
    double total = 0.0;
    for (int y = 0; y < pe.height(); ++y)
        total += applyRow(pe.row(y), pe.width(), y);
    ctx.mcpOut_e = total;
}

void McpStage::begin(const FieldContext& ctx) noexcept {
    gain_ = ctx.mcpGain;
    field_ = ctx.field;
}

// The pixels of a row whose draw is past the table (e = −1, of m drawn; idx: their pixels, or
// null when the row was drawn whole): Marsaglia–Tsang from each one's own stream.
void McpStage::drawPastTable(const float* __restrict v, float* __restrict e, int m,
                             const int* __restrict idx, const PixelRng& rng, std::uint32_t yy,
                             double theta, std::size_t off) noexcept {
    // The pixels past the table (e = −1): rare, so the chunks without one are passed over.
    int* __restrict rest = rest_.get() + off;
    int nRest = 0;
    const int scan = countNegative(e, m) == 0 ? 0 : m;  // none past the table: no list
    for (int j0 = 0; j0 < scan; j0 += 16) {
        const int len = std::min(16, scan - j0);
        if (countNegative(e + j0, len) == 0) continue;
        for (int l = 0; l < len; ++l) {
            rest[nRest] = j0 + l;
            nRest += e[j0 + l] < 0.0f ? 1 : 0;
        }
    }
    if (nRest == 0) return;
    // Each one's stream head (made in bulk): word 0 gives the normal, word 1 the squeeze's
    // uniform; the first attempt in a vector pass, the rest one pixel at a time.
    std::uint32_t* __restrict xs = blocks_.get() + off;  // their pixels
    for (int r = 0; r < nRest; ++r)
        xs[r] = static_cast<std::uint32_t>(idx == nullptr ? rest[r] : idx[rest[r]]);
    std::uint32_t* __restrict heads = heads_.get() + 4 * off;
    rng.streamHeads(yy, xs, nRest, heads);
    // Their normal and uniform words, in the buffers of the words the table draws used.
    std::uint32_t* __restrict zw = words_.get() + off;
    std::uint32_t* __restrict u1 = uWords_.get() + off;
    float* __restrict rn = restN_.get() + off;
    for (int r = 0; r < nRest; ++r) {
        zw[r] = heads[4 * r];
        u1[r] = heads[4 * r + 1];
        rn[r] = v[xs[r]];
    }
    float* __restrict z = z_.get() + off;
    normalsFromWords(zw, z, nRest);
    double* __restrict first = g_.get() + off;
    gammaFirstAttemptKernel(rn, z, u1, first, nRest, k_, theta);
    for (int r = 0; r < nRest; ++r) {
        double ej = first[r];
        if (ej == 0.0) {
            PixelStream more(rng.pixelStream(xs[r], yy), heads + 4 * r, 2);
            ej = gammaFromNormal(static_cast<double>(rn[r]) * k_, theta, z[r], u1[r], more);
        }
        e[rest[r]] = static_cast<float>(ej);
    }
}

double McpStage::applyRow(float* __restrict v, int w, int y, int slot, bool sum) noexcept {
    const double g = gain_;
    if (!noise_) return mcpMeanKernel(v, w, static_cast<float>(g));
    // The gain of one electron has mean G and variance (F − 1)G²: a Gamma(k, G/k) with
    // k = 1/(F − 1). N independent ones sum to Gamma(N·k, G/k) exactly. Pixels with N = 0
    // draw nothing. Pixel x takes word x of its row: for N = 1 … GammaTable::kMaxN (whole
    // numbers) the tabulated quantile at that word; beyond (or for a fractional N, which a
    // noise-free photocathode passes on) Marsaglia–Tsang from the pixel's own stream, its first
    // attempt in a vector pass. The row's words are made for the whole row when many pixels
    // draw, for the drawing pixels' blocks alone when few do: the same words either way.
    int m = countPositive(v, w);
    if (m == 0) return 0.0;
    const PixelRng rng(seed_, RngStream::McpGain, field_);
    const std::uint32_t yy = static_cast<std::uint32_t>(y);
    const double theta = g / k_;
    const std::size_t off = static_cast<std::size_t>(slot) * stride_;
    int* __restrict idx = idx_.get() + off;
    std::uint32_t* __restrict wz = words_.get() + off;
    float* __restrict e = e_.get() + off;
    std::uint32_t* __restrict headsAll = heads_.get() + 4 * off;
    const bool dense = 4 * m > w;
    if (dense) {
        // Most pixels draw: the whole row at once (those with N = 0 get 0).
        rng.rowWords(yy, 0, 0, blocksFor(w), wz);
        gammaTableDraws(*table_, v, wz, e, w, static_cast<float>(theta));
        m = w;
    } else {
        // Few draw: those alone, gathered, their words from their own blocks.
        m = 0;
        for (int x = 0; x < w; ++x) {
            idx[m] = x;
            m += v[x] > 0.0f ? 1 : 0;
        }
        std::uint32_t* __restrict uw = uWords_.get() + off;
        float* __restrict n = n_.get() + off;
        std::uint32_t* __restrict b = blocks_.get() + off;
        for (int j = 0; j < m; ++j)
            b[j] = static_cast<std::uint32_t>(idx[j] / 4);
        rng.blocksAt(yy, 0, b, m, headsAll);
        for (int j = 0; j < m; ++j) {
            uw[j] = headsAll[static_cast<std::size_t>(4 * j + idx[j] % 4)];
            n[j] = v[idx[j]];
        }
        gammaTableDraws(*table_, n, uw, e, m, static_cast<float>(theta));
    }
    drawPastTable(v, e, m, dense ? nullptr : idx, rng, yy, theta, off);
    if (dense) {
        std::copy(e, e + w, v);
        return sum ? rowSumOf(v, w) : 0.0;
    }
    for (int j = 0; j < m; ++j)
        v[idx[j]] = e[j];
    return sum ? rowSumOf(e, m) : 0.0;
}
namespace {

// MCP saturation of one row (stage 5b): out = Q·(1 − e^(−D/Q)), Q → Q_max − (Q_max − Q +
// out)·keep.
// One channel: out = Q·(1 − e^(−D/Q)); a drained one (Q = 0) gives nothing (u held at 87
// gives Q·1 = 0, with no branch).
// Small: the caller knows u < 1/2.
template <bool Small>
__attribute__((always_inline)) inline float mcpSaturationPixel(float& d, float& q, float qMax,
                                                               float keep) noexcept {
    const float avail = q;
    const float u = std::min(d / std::max(avail, 1e-30f), 87.0f);
    const float out = avail * (Small ? oneMinusExpNegSmall(u) : oneMinusExpNeg(u));
    d = out;
    q = qMax - (qMax - avail + out) * keep;
    return out;
}

NVS_SIMD_CLONES double mcpSaturationKernel(float* __restrict e, float* __restrict q, int w,
                                           float qMax, float keep) noexcept {
    constexpr int kL = 16;
    float acc[kL] = {};
    int x = 0;
    for (; x + kL <= w; x += kL) {
        // Where no channel of the 16 takes half its charge or more (u < 1/2, the usual case
        // below saturation), 1 − e^(−u) is its Taylor branch alone: the same values without
        // forming the exponential branch.
        int big = 0;
        for (int j = 0; j < kL; ++j)
            big += e[x + j] >= 0.5f * q[x + j] ? 1 : 0;
        if (big == 0) {
            for (int j = 0; j < kL; ++j)
                acc[j] += mcpSaturationPixel<true>(e[x + j], q[x + j], qMax, keep);
        } else {
            for (int j = 0; j < kL; ++j)
                acc[j] += mcpSaturationPixel<false>(e[x + j], q[x + j], qMax, keep);
        }
    }
    for (; x < w; ++x)
        acc[x % kL] += mcpSaturationPixel<false>(e[x], q[x], qMax, keep);
    double sum = 0.0;
    for (int j = 0; j < kL; ++j)
        sum += static_cast<double>(acc[j]);
    return sum;
}

}  // namespace

// ---- 5b. MCP local saturation ----------------------------------------------------------------

McpSaturationStage::McpSaturationStage(const CameraParams& c)
    : enabled_(c.mcpsat_enabled), tau_s_(c.mcpsat_recharge_s) {
    if (!enabled_) return;
    qMax_ = static_cast<float>(c.mcpsat_pixel_charge_e);
    q_ = ImageF(c.width, c.height);
    reset();
}

void McpSaturationStage::reset() noexcept {
    if (!q_.empty()) q_.fill(qMax_);
}

void McpSaturationStage::begin(const FieldContext& ctx) noexcept {
    if (!enabled_) return;
    keep_ = static_cast<float>(std::exp(-ctx.period_s / tau_s_));
}

double McpSaturationStage::applyRow(float* __restrict e, int w, int y) noexcept {
    return mcpSaturationKernel(e, q_.row(y), w, qMax_, keep_);
}

}  // namespace nvs::sensor
