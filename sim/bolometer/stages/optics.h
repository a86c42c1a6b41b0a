#pragma once
// Step 1, optics (docs/bolometer.md): band radiance at the aperture → power on each pixel's
// absorber, blurred by the lens's diffraction and the pixel's aperture.
//
//   name               unit  default  meaning / source
//   f_number           1     1.0      lens f-number (the presets' datasheets)
//   transmission       1     0.9      lens transmission in the band (typical AR-coated Ge)
//   fill_factor        1     0.8      absorbing fraction of the pixel (typical, docs/bolometer.md)
//   mtf                bool  true     blur by the diffraction × pixel-aperture MTF
//
// MTF(ν) = MTF_diff(ν) · sinc(a νx) · sinc(a νy), a = pitch·√FF the side of the square
// absorber; MTF_diff(ν) = (2/π)(acos s − s√(1 − s²)), s = ν λ N (incoherent circular pupil,
// Goodman, "Introduction to Fourier Optics", 3rd ed., 2005, §6.3), averaged over the band with
// the weight of a 300 K blackbody's spectral radiance. The image, sampled at the pixel pitch p,
// is filtered by FFT (FFTW, single precision, plans from the shipped wisdom, else scalar estimated
// ones: the same bits on every CPU, sim/core/fft_plans.h)
// with the transfer function of the pixel-sampled PSF, by Poisson's summation
//   H(ν) = Σ_{mx, my} MTF(νx + mx/p, νy + my/p) / Σ_{mx, my} MTF(mx/p, my/p)
// (aliases from beyond Nyquist included, up to the cut-off 1/(λN): |m| ≤ ⌈νc·p + ½⌉), after
// mirroring at least 16 px of margin around the image. A compact kernel would not do: the Airy
// pattern's tails hold ~2 % of the energy beyond 8 px at f/1, and cutting them raises the MTF
// at 1/8 px⁻¹ by as much (measured, docs/bolometer.md).

#include <filesystem>
#include <memory>

#include "sim/bolometer/stages/stage.h"
#include "sim/core/fft_plans.h"
#include "sim/core/image.h"

namespace nvs::bolometer {

struct OpticsParams {
    double f_number = 1.0;
    double optics_transmission = 0.9;
    double fill_factor = 0.8;
    bool mtf_enabled = true;

    void read(const Reader& root);
};

// Band-averaged diffraction MTF of a circular pupil at spatial frequency ν [cycles/m]
// (weights: a 300 K blackbody's spectral radiance over [lo, hi] µm).
double bandDiffractionMtf(double nu_cyc_m, double fNumber, double lo_um, double hi_um);

class OpticsStage {
  public:
    // configDir: the shipped data (<configDir>/fftw/ wisdom); empty: the scalar estimated plans,
    // whatever wisdom the process holds.
    OpticsStage(const ThermalCameraParams& cam, const std::filesystem::path& configDir,
                FftPlanning planning = FftPlanning::Shipped);
    ~OpticsStage();
    OpticsStage(const OpticsStage&) = delete;
    OpticsStage& operator=(const OpticsStage&) = delete;
    // Pixel power [W] of the radiance image [W m⁻² sr⁻¹] (NaN, ±inf and negative pixels count
    // as 0 and are counted). Returns the number of bad pixels.
    int apply(ImageView<const float> radiance, ImageView<float> power_W) noexcept;
    // Fills the pixels with the power of a uniform radiance seen without the lens (the shutter,
    // in front of the array: no blur, no lens transmission).
    void uniform(double radiance_W_m2_sr, ImageView<float> power_W) const noexcept;
    // The padded transform's size [px].
    int paddedWidth() const { return wp_; }
    int paddedHeight() const { return hp_; }
    // Whether both transforms were planned from the shipped wisdom (false: the scalar estimate,
    // or the MTF off, or measured plans).
    bool plannedFromWisdom() const { return plannedFromWisdom_; }

  private:
    struct Fft;
    void buildTransfer(const ThermalCameraParams& cam, const std::filesystem::path& configDir,
                       FftPlanning planning);
    void filter(ImageView<float> power_W) noexcept;
    int w_, h_, wp_ = 0, hp_ = 0;
    float wattsPerRadiance_;
    float wattsPerRadianceOpen_;  // without the lens's transmission (shutter)
    std::unique_ptr<Fft> fft_;    // null with the MTF off
    bool plannedFromWisdom_ = false;
};

}  // namespace nvs::bolometer
