#pragma once
// Step 3b, halo (docs/sensor.md): photoelectrons backscattered at the MCP input land on a disk.

#include <cstdint>
#include <vector>

#include "sim/core/image.h"
#include "sim/core/row_executor.h"
#include "sim/sensor/stages/stage.h"

namespace nvs::sensor {

struct CameraParams;

struct HaloParams {
    // --- 3b. Halo: photoelectrons backscattered at the MCP input land on a disk ------------
    bool halo_enabled = false;
    double halo_fraction = 0.0;   // share of the photoelectrons that land displaced
    double halo_gap_um = 150.0;   // cathode–MCP gap d; elastic backscatter lands within 2d
    double halo_radius_um = 0.0;  // ring radius at the cathode; 0: 2·gap
    double haloRadius_um() const {
        return halo_radius_um > 0.0 ? halo_radius_um : 2.0 * halo_gap_um;
    }

    // Reads [halo] of the preset over the defaults above; errors name
    // file:line or the --set KEY.
    void read(const PresetReader& root);
};

// ---- 3b. Halo ------------------------------------------------------------------------------
// Photoelectrons that strike the MCP's web between channels scatter back elastically, with the
// energy e·V the cathode–MCP field gave them, and the same field turns them round: launched at
// θ from the normal they land r = 2d·sin 2θ away (d the gap), whatever V is. So a share f of the
// photoelectrons land on a disk of radius R = 2d, densest at its rim (r = R·sin 2θ over
// cosine-law launches: p(r) ∝ 1/√(1 − (r/R)²)). Applied to the expected photocathode rate
// (displacing a Poisson process's points keeps it Poisson), on a grid of kBlock-pixel cells:
// the disk spans tens of pixels and its sum is smooth at that scale.
class HaloStage {
  public:
    static constexpr int kBlock = 4;
    explicit HaloStage(const CameraParams& cam);
    bool enabled() const { return enabled_; }
    // rate ← (1 − f)·rate + f·(rate ⊛ disk), in place; conserves the total. By bands of rows
    // through `exec` (the same bits with any executor).
    void apply(ImageView<float> rate) noexcept;
    void apply(ImageView<float> rate, RowExecutor& exec) noexcept;
    // apply() in its steps, for callers that fuse them with their own row passes: sumCells()
    // for every band of cell rows [cy0, cy1) (after the kBlock pixel rows of each are
    // written), then spread(exec), then addBackRow(rate row y, y) for every pixel row.
    int cellRows() const { return ch_; }
    void sumCells(ImageView<const float> rate, int cy0, int cy1) noexcept;
    void spread(RowExecutor& exec) noexcept;
    void addBackRow(float* rateRow, int y) noexcept;
    // The same into `out` (another row of the image's width; rateRow is only read).
    void addBackRow(const float* rateRow, float* out, int y) noexcept;
    // The kernel on the cell grid (odd size, sums to 1), for tests.
    const std::vector<float>& kernel() const { return kernel_; }
    int kernelRadiusCells() const { return kr_; }

  private:
    bool enabled_;
    float fraction_ = 0.0f;
    int w_ = 0, h_ = 0, cw_ = 0, ch_ = 0, kr_ = 0;
    std::vector<float> kernel_;  // (2kr+1)² weights
    ImageF cells_;               // rate summed over each cell
    ImageF spread_;              // cells convolved with the disk, per pixel of a cell
};

}  // namespace nvs::sensor
