#pragma once
// The atmosphere table: every sky term nvstim needs per frame, band-integrated for each camera
// band and tabulated over geometry, built once per (site altitude, atmosphere, source spectrum,
// bands), cached on disk, and interpolated per frame without allocation (docs/design.md §4.3).
//
// Terms, per band b with weight w_b(λ) (683·V(λ) for lux, QE(λ)·λ/(hc) for photoelectrons):
//   directTransmittance(b, z_s)      ∫E0·T_dir·w / ∫E0·w          beam, source at zenith z_s
//   skyRadiance(b, z_v, Δφ, z_s)     ∫E0·L_sky·w / ∫E0·w  [sr⁻¹]  per unit band TOA irradiance
//   diffuseHorizontal(b, z_s)        ∫E0·E_dif·w / ∫E0·w          per unit band TOA irradiance
//   nightSkyRadiance(b, z_v)         ∫L_night(z_v)·w  [band unit m⁻² sr⁻¹]  absolute
//   nightSkyHorizontal(b)            ∫E_night·w       [band unit m⁻²]       absolute
// E0 is the source's top-of-atmosphere spectral irradiance shape (the Moon: the solar spectrum
// times the lunar albedo), so a band term times the band TOA irradiance ∫E0·w is the band
// quantity. Δφ is the azimuth of the view from the source's azimuth, 0–180°.
//
// The night sky at the ground is given as isotropic-equivalent radiances (horizontal
// irradiance / π, as the thesis's Appendix G spectrum is): an airglow part, which brightens
// toward the horizon by the van Rhijn factor (emitting layer at 97 km) and dims by extinction,
// and a continuum part (integrated starlight, zodiacal light) taken as isotropic. Both keep their
// horizontal irradiance; both are attenuated by a cloud layer.
//
// Cache files: <DataDirs::cache>/atmosphere-<key>.bin, where <key> hashes every input and the
// format version; the payload carries a checksum. A stale, truncated or corrupt file is detected,
// reported on stderr and rebuilt, never used.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "sim/core/paths.h"
#include "sim/core/spectrum.h"
#include "sim/sky/atmosphere.h"

namespace nvs::sky {

struct SkyBand {
    std::string name;  // "lux", "pe", ...
    Spectrum weight;   // band weight w(λ): band value = ∫ X_λ w dλ
};

struct NightSkySpectra {
    Spectrum airglowRadiance_W_m2_sr_nm;    // isotropic-equivalent at the ground
    Spectrum continuumRadiance_W_m2_sr_nm;  // starlight + zodiacal, isotropic
};

struct AtmosphereTableInputs {
    AtmosphereParams atmosphere;
    Spectrum sourceShape;  // relative TOA spectral irradiance of the source (any scale)
    NightSkySpectra nightSky;
    std::vector<SkyBand> bands;
};

// Path terms between a sensor above the ground and what it sees (per unit band TOA irradiance
// of the source for the radiance; the night-sky part is absolute).
struct PathTerms {
    double transmittance = 1.0;          // band-averaged exp(−∫β ds)
    double radiancePerIrradiance = 0.0;  // source light scattered into the path [sr⁻¹]
    double nightSkyRadiance = 0.0;  // night-sky light scattered into the path [band m⁻² sr⁻¹]
};

class AtmosphereTable {
  public:
    // Grid sizes (degrees): source zenith 0–96 step 2, view zenith 0–90 step 2, Δφ 0–180
    // step 5; the direct beam, which changes fastest near the horizon, is tabulated as ln T
    // every 0.25°.
    static constexpr int kSourceZeniths = 49;
    static constexpr int kDirectZeniths = 385;
    static constexpr int kViewZeniths = 46;
    static constexpr int kAzimuths = 37;
    static constexpr std::uint32_t kFormatVersion = 1;

    // Builds the table (seconds), with the atmosphere's data from configDir.
    static AtmosphereTable build(const AtmosphereTableInputs& inputs,
                                 const std::filesystem::path& configDir);
    // Loads the cached table for these inputs from dirs.cache, or builds it and caches it there
    // (an empty dirs.cache: builds it, caches nothing). `rebuilt`, if given, says which
    // happened. Throws SetupError only for bad inputs; an unusable cache is rebuilt.
    static AtmosphereTable loadOrBuild(const AtmosphereTableInputs& inputs, const DataDirs& dirs,
                                       bool* rebuilt = nullptr);
    // The cache key (hash of every input and the format version), as 16 hex digits.
    static std::string cacheKey(const AtmosphereTableInputs& inputs);

    int bandCount() const { return static_cast<int>(bandNames_.size()); }
    int bandIndex(const std::string& name) const;  // −1 if absent
    const std::string& bandName(int b) const { return bandNames_[b]; }
    // ∫E0·w for the source shape given at build time (to rescale a real source to it).
    double sourceBandIntegral(int b) const { return sourceBand_[b]; }

    // Per-frame lookups: no allocation, no exceptions. Angles in radians.
    double directTransmittance(int b, double sourceZenith_rad) const;
    double skyRadiance(int b, double viewZenith_rad, double relAzimuth_rad,
                       double sourceZenith_rad) const;
    double diffuseHorizontal(int b, double sourceZenith_rad) const;
    double nightSkyRadiance(int b, double viewZenith_rad) const;
    double nightSkyHorizontal(int b) const { return nightHorizontal_[b]; }

    // Path radiance and transmittance along a straight line of `range_m` from a sensor at
    // `sensorHeight_m` above the site, at view zenith θv (> 90° looks down), for a source at
    // zenith θs and scattering angle cos ψ. Single scattering of the beam (which is stronger
    // aloft) by the exponential Rayleigh (8.4 km) and aerosol layers, plus in-scattering of the
    // diffuse sky and ground light taken as isotropic: J = β_sca (E_dif + ρ E_tot)/(2π).
    // 16-point Gauss–Legendre along the path; no allocation.
    PathTerms path(int b, double sensorHeight_m, double viewZenith_rad, double range_m,
                   double cosScatter, double sourceZenith_rad) const;

    // Serialisation (exposed for the cache tests).
    void save(const std::filesystem::path& file, std::uint64_t key) const;
    // Returns false (and says why in *why) if the file is missing, stale or corrupt.
    bool load(const std::filesystem::path& file, std::uint64_t key, int bandCount,
              std::string* why);

  private:
    std::size_t skyIndex(int b, int is, int iv, int ia) const {
        return ((static_cast<std::size_t>(b) * kSourceZeniths + is) * kViewZeniths + iv) *
                   kAzimuths +
               ia;
    }

    std::vector<std::string> bandNames_;
    std::vector<double> sourceBand_;       // [b]
    std::vector<float> logDirect_;         // [b][id], ln T
    std::vector<float> diffuse_;           // [b][is]
    std::vector<float> sky_;               // [b][is][iv][ia]
    std::vector<float> night_;             // [b][iv]
    std::vector<double> nightHorizontal_;  // [b]
    // Per band: source-weighted vertical τ_R, τ_a; then scalars: H_a, ω_a, g_a, ρ_ground.
    std::vector<double> bandTau_;  // [b][2]
    std::vector<double> scalars_;  // [4]
};

}  // namespace nvs::sky
