#pragma once
// A plain C++ reference of the thesis's camera model, eq. 7.1 (RIT 1999, §7.4; the IDL program
// iiccd_simulator.pro of Appendix J):
//
//     g(x, y) = F⁻¹{ F{ f(x, y) + n_p(x, y) } · MTF } · gain + bias + n_g(x, y)
//
// per-pixel Poisson photon (here photoelectron) noise n_p, one FFT filter by a system MTF, additive
// Gaussian noise n_g, a linear gain and bias, clipped to the ADC range.
//
// It is written the way a user would write it from the thesis, deliberately untuned: double
// precision, one std::poisson_distribution constructed per pixel and one std::normal_distribution
// drawing from a std::mt19937, FFTW's r2c/c2r transforms planned once with FFTW_ESTIMATE, a
// Gaussian MTF computed once. `nvstim bench` times it on the same frames as the camera chain
// (sim/sensor's IiccdChain, which does every stage of the tube, phosphor, CCD and video) so that
// the chain's speed is stated against what the plain model costs, not against itself. It is not
// used by the simulator.
//
// Parameters (name, unit, meaning):
//   width, height      [px]        frame size
//   pe_per_input       [pe / unit] mean photoelectrons per pixel per unit of the input image
//   mtf_sigma_px       [px]        σ of the Gaussian point spread: MTF(ξ) = exp(−2π²σ²|ξ|²), ξ in
//                                  cycles per pixel; 0: all-pass (the FFTs still run)
//   gain_dc_per_pe     [DC / pe]   linear gain
//   bias_dc            [DC]        offset
//   noise_dc           [DC rms]    σ of the additive Gaussian noise
//   adc_bits           [1]         output clipped to [0, 2^bits − 1] and rounded
//   seed                           std::mt19937 seed

#include <cstdint>
#include <random>
#include <vector>

namespace nvs::rt::bench {

struct Eq71Params {
    int width = 768;
    int height = 494;
    double pe_per_input = 1.0;
    double mtf_sigma_px = 1.0;
    double gain_dc_per_pe = 1.0;
    double bias_dc = 0.0;
    double noise_dc = 0.0;
    int adc_bits = 8;
    std::uint32_t seed = 1;
};

class Eq71Reference {
  public:
    // Plans both transforms and computes the MTF (throws SetupError on bad parameters).
    explicit Eq71Reference(const Eq71Params& p);
    ~Eq71Reference();
    Eq71Reference(const Eq71Reference&) = delete;
    Eq71Reference& operator=(const Eq71Reference&) = delete;

    // One frame: `in` and `out` are width × height, row-major.
    void process(const float* in, std::uint16_t* out);

    const Eq71Params& params() const { return p_; }

  private:
    Eq71Params p_;
    std::vector<double> image_;  // width × height
    void* spectrum_ = nullptr;   // fftw_complex[height × (width/2 + 1)]
    std::vector<double> mtf_;    // height × (width/2 + 1), divided by width·height
    void* forward_ = nullptr;    // fftw_plan
    void* inverse_ = nullptr;    // fftw_plan
    std::mt19937 rng_;
};

}  // namespace nvs::rt::bench
