#include "sim/sensor/chain.h"

#include <algorithm>
#include <cmath>

#include "sim/core/units.h"

namespace nvs::sensor {
IiccdChain::IiccdChain(const CameraParams& cam, std::uint64_t seed,
                       const std::filesystem::path& configDir, GammaTableCache& gammaTables,
                       ChainOptions opt, ControlSource controls)
    : cam_(cam),
      control_(cam_, controls),
      optics_(cam_),
      gate_(cam_),
      cathode_(cam_, seed),
      halo_(cam_),
      bsp_(cam_),
      mcp_(cam_, seed, gammaTables),
      mcpSat_(cam_),
      phosphor_(cam_),
      blur_(cam_, opt, configDir),
      ccd_(cam_, seed),
      videoStage_(cam_),
      rate_(cam_.width, cam_.height),
      sig_(cam_.width, cam_.height),
      counts_(cam_.width, cam_.height),
      video_(cam_.width, cam_.height),
      rowRate_(new float[kChainSlots * paddedRow(cam_.width)]),
      rowSig_(new float[kChainSlots * paddedRow(cam_.width)]),
      rowOptics_(static_cast<std::size_t>(cam_.height), 0.0),
      rowMcp_(static_cast<std::size_t>(cam_.height), 0.0),
      rowBad_(static_cast<std::size_t>(cam_.height), 0),
      rowLevel_(static_cast<std::size_t>(cam_.height), 0) {
    counts_.fill(static_cast<float>(std::clamp(cam_.video_offset_dc, 0.0, 65535.0)));
    // The phosphor's input is MCP saturation's output, at most a channel's full charge: its
    // afterglow store is bounded and kept in binary16 (PhosphorStage::boundInput).
    if (cam_.mcp_enabled && cam_.mcpsat_enabled) phosphor_.boundInput(cam_.mcpsat_pixel_charge_e);
}

IiccdChain::~IiccdChain() = default;

std::int64_t IiccdChain::countBadPixels(ImageView<const float> img) {
    std::int64_t bad = 0;
    for (int y = 0; y < img.height(); ++y) {
        const float* r = img.row(y);
        for (int x = 0; x < img.width(); ++x)
            bad += (r[x] >= 0.0f && r[x] < 3.0e38f) ? 0 : 1;
    }
    return bad;
}

const FieldInfo& IiccdChain::process(ImageView<const float> lpe) noexcept {
    const double t_s = (static_cast<double>(field_) + 0.5) * cam_.integrationPeriod_s();
    return process(lpe, CameraCommand{}, t_s);
}

const FieldInfo& IiccdChain::process(ImageView<const float> lpe, const CameraCommand& cmd,
                                     double t_sample_s) noexcept {
    info_ = FieldInfo{};
    info_.field = field_;
    if (lpe.width() != cam_.width || lpe.height() != cam_.height) {
        info_.size_mismatch = true;
        return info_;
    }
    FieldContext ctx;
    ctx.field = field_;
    ctx.period_s = cam_.integrationPeriod_s();
    const GainControl::Controls controls = control_.forField(cmd, field_, ctx.period_s, gate_);
    ctx.gain_V = controls.gain_V;
    ctx.gate_s = controls.gate_s;
    run(lpe, ctx);
    // 10. AGC loop: measures this field, commands field + lag.
    if (controls.loop != nullptr) controls.loop->update(ctx, info_.level_dc);
    info_.t_sample_s = t_sample_s;
    ++field_;
    return info_;
}

void IiccdChain::setExecutor(RowExecutor* exec) noexcept {
    exec_ = exec != nullptr ? exec : &serial_;
}

// 1. optics over the whole image before the other stages (with BSP or the halo), by bands;
// then 3b's spread and the photocathode's constants.
void IiccdChain::opticsPass(ImageView<const float> lpe, FieldContext& ctx) noexcept {
    const int w = cam_.width;
    const int h = cam_.height;
    const bool halo = halo_.enabled();
    // With the halo, bands of whole cell rows: each band's rows, then its cells' sums.
    const int units = halo ? halo_.cellRows() : h;
    const int rowsPer = halo ? HaloStage::kBlock : 1;
    const bool veil = optics_.veiled();
    auto optics = [&](int b) {
        const int u0 = bandStart(b, units), u1 = bandStart(b + 1, units);
        for (int y = u0 * rowsPer; y < std::min(h, u1 * rowsPer); ++y)
            rowBad_[y] = optics_.applyRow(lpe.row(y), rate_.row(y), y, rowOptics_[y]);
        if (halo && !veil) halo_.sumCells(rate_.cview(), u0, u1);
    };
    forEachIndex(*exec_, kChainSlots, optics);
    const double total = addOpticsSums(ctx);
    // Veiling glare needs the whole image's rate first (OpticsStage::apply's order).
    const double veilMean = veil ? optics_.veilMean(total) : 0.0;
    auto veilBand = [&](int b) {
        const int u0 = bandStart(b, units), u1 = bandStart(b + 1, units);
        for (int y = u0 * rowsPer; y < std::min(h, u1 * rowsPer); ++y)
            optics_.veilRow(rate_.row(y), veilMean);
        if (halo) halo_.sumCells(rate_.cview(), u0, u1);
    };
    if (veil) forEachIndex(*exec_, kChainSlots, veilBand);
    // 3b: a share of the photoelectrons lands on the halo disk (added to each row below).
    if (halo) halo_.spread(*exec_);
    cathode_.begin(ctx, w, h);
}

void IiccdChain::run(ImageView<const float> lpe, FieldContext& ctx) noexcept {
    const int w = cam_.width;
    const int h = cam_.height;
    // Each row's sums go to rowOptics_/rowMcp_ and are added up in row order afterwards: the
    // same sums, in the same order, however the bands ran.
    // 1. optics: the whole image first only where the gain depends on it (BSP: the cathode
    // current) or the halo spreads it; otherwise row by row below.
    const bool opticsFirst = bsp_.enabled() || halo_.enabled() || optics_.veiled();
    const bool halo = halo_.enabled();
    if (opticsFirst) opticsPass(lpe, ctx);
    // 4. bright-source protection (the gain for this field), 5. MCP gain
    const auto cathodeCurrent_A = [&] {
        return ctx.cathodeRate_pe_s * ctx.gate_s / ctx.period_s * kElectronCharge_C;
    };
    const double bspFactor = opticsFirst ? bsp_.factor(cathodeCurrent_A()) : 1.0;
    const bool onPe = cam_.bsp_on_photoelectrons;
    ctx.mcpGain = cam_.mcpGain(ctx.gain_V) * (onPe ? 1.0 : bspFactor);
    if (onPe && bspFactor != 1.0) cathode_.scaleExposure(bspFactor);
    FieldContext rowCtx = ctx;  // photocathode constants for the row-by-row case
    if (!opticsFirst) cathode_.begin(rowCtx, w, h);
    mcp_.begin(ctx);
    mcpSat_.begin(ctx);
    phosphor_.begin(ctx);
    // 1, 3, 5, 6 row by row: optics → photocathode → MCP → phosphor, written straight into
    // the blur's FFT input (or the signal image when the MTF is off); each band of rows with
    // its own scratch.
    auto rows = [&](int b) {
        const std::size_t off = static_cast<std::size_t>(b) * paddedRow(w);
        float* rate = rowRate_.get() + off;
        float* sig = rowSig_.get() + off;
        for (int y = bandStart(b, h); y < bandStart(b + 1, h); ++y) {
            const float* r = rate_.row(y);
            if (halo) {
                // Into the band's row: the image row is only read (no write-back stream).
                halo_.addBackRow(r, rate, y);
                r = rate;
            }
            if (!opticsFirst) {
                rowBad_[y] = optics_.applyRow(lpe.row(y), rate, y, rowOptics_[y]);
                r = rate;
            }
            cathode_.applyRow(r, sig, w, y, b);
            if (mcp_.enabled()) {
                // With saturation the row's output is saturation's sum, not the MCP's.
                const double rowOut = mcp_.applyRow(sig, w, y, b, !mcpSat_.enabled());
                rowMcp_[y] = mcpSat_.enabled() ? mcpSat_.applyRow(sig, w, y) : rowOut;
            }
            float* dst = blur_.enabled() ? blur_.slotRow(b) : sig_.row(y);
            if (phosphor_.enabled())
                phosphor_.applyRow(sig, dst, w, y);
            else
                std::copy(sig, sig + w, dst);
            if (blur_.enabled()) blur_.forwardRow(dst, y);  // 7's row transform, the row in cache
        }
    };
    forEachIndex(*exec_, kChainSlots, rows);
    double mcpTotal = 0.0;
    for (int y = 0; y < h; ++y)
        mcpTotal += rowMcp_[y];
    if (!opticsFirst) {
        addOpticsSums(ctx);
        cathode_.begin(ctx, w, h);  // the EBI, added after the optics as apply() does
    }
    ctx.mcpOut_e = mcp_.enabled() ? mcpTotal : ctx.cathodeRate_pe_s * ctx.gate_s;
    info_.gain_V = ctx.gain_V;
    info_.mcp_gain = ctx.mcpGain;
    info_.gate_s = ctx.gate_s;
    info_.bsp_factor = bspFactor;
    info_.cathode_current_A = cathodeCurrent_A();
    info_.screen_current_A = ctx.mcpOut_e * kElectronCharge_C / ctx.period_s;
    info_.mean_pe = ctx.cathodeRate_pe_s * ctx.gate_s / (w * h);
    readOut(ctx);
}

double IiccdChain::addOpticsSums(FieldContext& ctx) noexcept {
    std::int64_t bad = 0;
    double total = 0.0;
    for (int y = 0; y < cam_.height; ++y) {
        bad += rowBad_[y];
        total += rowOptics_[y];
    }
    info_.bad_input_px = bad;
    ctx.cathodeRate_pe_s += total;
    return total;
}

void IiccdChain::readOut(const FieldContext& ctx) noexcept {
    const int w = cam_.width;
    const int h = cam_.height;
    // 7. blur: its row transforms were made with the rows (run()); the columns now, the
    // inverse row transforms with the CCD load below.
    blur_.filterColumns(*exec_);
    // 8. CCD, 9. video: load (PRNU, dark) from the blurred image by bands of rows (each band
    // its own column maxima), then the column sums and blooming's down sweep where needed,
    // bloom, then smear and read noise by bands of rows, each row read out converted at once.
    ccd_.begin(ctx);
    if (blur_.enabled()) {
        ccd_.beginLoad();
        auto load = [&](int b) {
            float* row = blur_.slotRow(b);
            for (int y = bandStart(b, h); y < bandStart(b + 1, h); ++y) {
                blur_.inverseRow(y, row);
                ccd_.loadRowMax(row, sig_.row(y), y, b);
            }
        };
        forEachIndex(*exec_, kChainSlots, load);
        ccd_.finishLoad(sig_.view());
    } else {
        for (int y = 0; y < h; ++y)
            ccd_.loadRow(sig_.row(y), sig_.row(y), y);
    }
    info_.saturated_px = ccd_.bloom(sig_.view());
    auto finish = [&](int b) {
        for (int y = bandStart(b, h); y < bandStart(b + 1, h); ++y) {
            float* v = sig_.row(y);
            ccd_.finishRow(v, y, b);
            rowLevel_[y] = videoStage_.readsRow(field_, y)
                               ? videoStage_.applyRow(v, counts_.row(y), video_.row(y), w)
                               : -1;
        }
    };
    forEachIndex(*exec_, kChainSlots, finish);
    double sum = 0.0;
    std::int64_t n = 0;
    for (int y = 0; y < h; ++y) {
        if (rowLevel_[y] < 0) continue;
        sum += static_cast<double>(rowLevel_[y]);
        n += w;
    }
    info_.level_dc = n > 0 ? sum / static_cast<double>(n) : 0.0;
}

}  // namespace nvs::sensor
