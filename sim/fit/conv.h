#pragma once
// 2-D convolution of frame-sized planes with radially symmetric kernels, through FFTW (single
// precision). Frames are padded to twice their size with their mirror image at each edge
// (symmetric extension), not with zeros and not circularly. The scene outside the frame is
// not known, but it is not dark: the photocathode and the optics see past the CCD's
// rectangle, and the light from there spreads in as the frame's light spreads out. Taking the
// scene past an edge as the mirror of the scene inside it keeps a uniform scene uniform up to
// the edges (zero padding darkened its border by the part of the kernel that falls outside,
// which a fit then read as signal) and adds no edge of its own, as replicating the border
// row would for a bright point on it. The kernel's tail beyond half the padding wraps.
//
// setFrames() transforms a set of planes once; convolve() then multiplies by one kernel's
// spectrum and transforms back, so trying many kernels on the same frames costs one inverse
// transform per frame and kernel.

#include <functional>
#include <memory>
#include <vector>

#include "sim/fit/dataset.h"

namespace nvs::fit {

class Convolver {
  public:
    // pitch_x, pitch_y: a pixel's size in the plane where the kernel is defined [µm].
    Convolver(int width, int height, double pitchX_um, double pitchY_um);
    ~Convolver();
    Convolver(const Convolver&) = delete;
    Convolver& operator=(const Convolver&) = delete;

    void setFrames(const std::vector<Plane>& frames);
    // kernel(r_um) for r = distance from the centre [µm]; normalised here to sum 1 over the
    // padded plane. out[i] = kernel ⊛ frames[i].
    void convolve(const std::function<double(double)>& kernel, std::vector<Plane>& out);
    // A single plane with a kernel (no caching).
    void convolveOne(const Plane& in, const std::function<double(double)>& kernel, Plane& out);

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace nvs::fit
